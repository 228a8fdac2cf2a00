"""The pen model in the pipeline (drawing/pens.py, prepare's records, G-code tool changes,
info, convert, estimate and dry runs). tests/test_pen_kinds.py is about the servo backend."""

from __future__ import annotations

import argparse
import json
import re

import numpy as np
import pytest
from hypothesis import given, strategies as st

from support import tracecheck as tc
from support import REPO
from vplotter import config
from vplotter.cli import main
from vplotter.commands.files import write_gcode
from vplotter.config.sections import PenSpec
from vplotter.drawing import order, pens
from vplotter.inputs import gcode, gcode_tools
from vplotter.inputs.gcode import Move, Pause, Pen
from vplotter.inputs.strokes import Stroke
from vplotter.pipeline import Summary
from vplotter.prepare import Prepared
from vplotter.readers.gcode import gcode_strokes

OWNED = (PenSpec("black", "#000000"), PenSpec("red", "#d02020", speed_mm_s=2.0),
         PenSpec("yellow", "#ffff00"), PenSpec("blue", "#2030c0"))
PENS_TOML = """
[pens]
change_x_mm = 0.0
change_y_mm = 250.0

[pens.black]
colour = "black"

[pens.red]
colour = "#d02020"
speed_mm_s = 2.0

[pens.yellow]
colour = "yellow"
"""
LAYERS_SVG = """<svg xmlns="http://www.w3.org/2000/svg"
 xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" width="60mm" height="60mm"
 viewBox="0 0 60 60">
<g inkscape:groupmode="layer" id="l1" inkscape:label="black">
 <path id="b1" d="M5 5 L55 5" stroke="black"/><path id="b2" d="M5 55 L55 55" stroke="black"/></g>
<g inkscape:groupmode="layer" id="l2" inkscape:label="red"><path id="r1" d="M5 15 L55 15" stroke="red"/></g>
<g inkscape:groupmode="layer" id="l3" inkscape:label="Yellow">
 <circle id="y1" cx="30" cy="35" r="10" stroke="yellow"/></g>
</svg>
"""


def run(capsys, argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    assert len([x for x in err.splitlines() if "error:" in x]) == (0 if code == 0 else 1), err
    return code, out, err


@pytest.fixture
def pens_config(tmp_path, config_path):
    p = tmp_path / "pens.toml"
    p.write_text(config_path.read_text() + PENS_TOML)
    return p


def line(x0, y0, x1, y1, **kw) -> Stroke:
    return Stroke(np.array([[x0, y0], [x1, y1]], dtype=float), **kw)


def prepared(strokes, **kw) -> Prepared:
    p = Prepared("x.svg", "svg", False, **{"join_mm": 0.0, **kw})
    p._strokes = strokes
    return p


# ------------------------------------------------------------------ colour difference
@pytest.mark.parametrize("lab1,lab2,want", [          # Sharma, Wu and Dalal (2005), table 1
    ((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
    ((50.0, 2.5, 0.0), (50.0, 0.0, -2.5), 4.3065),
    ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
    ((50.0, 2.5, 0.0), (50.0, 3.2592, 0.335), 1.0),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((22.7233, 20.0904, -46.694), (23.0331, 14.973, -42.5619), 2.0373),
    ((90.9257, -0.5406, -0.9208), (88.6381, -0.8985, -0.7239), 1.5381),
    ((2.0776, 0.0795, -1.135), (0.9033, -0.0636, -0.5514), 0.9082),
])
def test_ciede2000_matches_the_published_pairs(lab1, lab2, want):
    assert pens.ciede2000(lab1, lab2) == pytest.approx(want, abs=1e-4)
    assert pens.ciede2000(lab2, lab1) == pytest.approx(want, abs=1e-4)


def test_lab_of_white_and_black():
    assert pens.lab("#ffffff") == pytest.approx((100.0, 0.0, 0.0), abs=0.01)
    assert pens.lab("#000000") == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)


# ------------------------------------------------------------------ resolving
def test_owned_pens_by_layer_then_name_then_nearest_colour():
    warned: list[str] = []
    ss = [line(0, 0, 1, 0, pen="orange", colour="#ffa500", layer="Red"),   # the layer names a pen
          line(0, 1, 1, 1, pen="yellow", colour="#ffff00"),               # the pen's own name
          line(0, 2, 1, 2, pen="#ee1010", colour="#ee1010"),              # nearest: red
          line(0, 3, 1, 3, pen="navy", colour="#000080"),                 # nearest: blue
          line(0, 4, 1, 4),                                               # no pen: the darkest
          line(0, 5, 1, 5, pen="T3"),                                     # unknown, no colour
          line(0, 6, 1, 6, pen="T3", feed_mm_s=9.0)]
    got = pens.resolve(ss, OWNED, warned.append, "f.svg")
    assert [(s.pen, s.colour) for s in got] == [
        ("red", "#d02020"), ("yellow", "#ffff00"), ("red", "#d02020"), ("blue", "#2030c0"),
        ("black", "#000000"), ("T3", "#000000"), ("T3", "#000000")]
    assert [s.feed_mm_s for s in got] == [2.0, None, 2.0, None, None, None, 9.0]
    assert warned == ["f.svg: warning: pen T3 is not one of the pens in [pens] "
                      "(black, red, yellow, blue): it is asked for by that name"]
    assert ss[0].pen == "orange"                       # the input is left as it is


def test_a_colour_far_from_every_pen_is_warned_about_once():
    warned: list[str] = []
    ss = [line(0, 0, 1, 0, pen="lime", colour="#00ff00")] * 3
    got = pens.resolve(ss, OWNED[:2], warned.append, "f.svg")
    assert {s.pen for s in got} == {"black"} or {s.pen for s in got} == {"red"}
    assert len(warned) == 1 and "no pen in [pens] is close to colour lime" in warned[0]
    assert pens.distance("#00ff00", got[0].colour) > pens.FAR_DE


def test_without_owned_pens_each_colour_is_a_pen_named_as_written():
    ss = [line(0, 0, 1, 0, pen="red", colour="#ff0000"),
          line(0, 1, 1, 1, pen="#FF0000", colour="#ff0000"),      # the same colour: the same pen
          line(0, 2, 1, 2, pen="T2"),                             # a tool: a pen of its own
          line(0, 3, 1, 3),                                       # no pen: the default (black)
          line(0, 4, 1, 4, pen="#ff8800", colour="#ff8800")]
    got = pens.resolve(ss)
    assert [(s.pen, s.colour) for s in got] == [
        ("red", "#ff0000"), ("red", "#ff0000"), ("T2", "#000000"), ("default", "#000000"),
        ("#ff8800", "#ff8800")]
    black = pens.resolve([line(0, 0, 1, 0), line(0, 1, 1, 1, pen="black", colour="#000000")])
    assert [s.pen for s in black] == ["black", "black"]           # the default joins black


def test_pen_order_light_to_dark_ties_in_first_appearance_and_file_order():
    ss = pens.resolve([line(0, 0, 1, 0, pen="black", colour="#000000"),
                       line(0, 1, 1, 1, pen="T1"), line(0, 2, 1, 2, pen="red", colour="#ff0000"),
                       line(0, 3, 1, 3, pen="yellow", colour="#ffff00"),
                       line(0, 4, 1, 4, pen="T1"), line(0, 5, 1, 5, pen="T0")])
    names = [n for n, _ in pens.pens_of(pens.arrange(ss))]
    assert names == ["yellow", "red", "black", "T1", "T0"]
    assert [n for n, _ in pens.pens_of(pens.arrange(ss, "file"))] == [
        "black", "T1", "red", "yellow", "T0"]
    with pytest.raises(ValueError):
        pens.arrange(ss, "dark-to-light")


colours_st = st.sampled_from(["#ff0000", "#ffff00", "#000000", "#2030c0", None])


@given(st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50), st.integers(-50, 50),
                          st.integers(-50, 50), colours_st), min_size=1, max_size=25),
       st.sampled_from(["greedy", "best", "keep"]))
def test_ordering_stays_within_each_pen(rows, method):
    ss = pens.resolve([line(x0, y0, x1, y1, pen=c, colour=c) for x0, y0, x1, y1, c in rows])
    got = pens.arrange(ss, "light-to-dark", lambda g, at: order.order(g, method, at))
    seq = [s.pen for s in got]
    runs = [p for i, p in enumerate(seq) if i == 0 or seq[i - 1] != p]
    assert len(runs) == len(set(seq))                     # each pen's strokes in one run
    light = [pens.colours.lightness(dict(pens.pens_of(got))[p]) for p in runs]
    assert light == sorted(light, reverse=True)
    for p in set(seq):                                    # the same segments per pen
        a = sorted(tuple(sorted(map(tuple, s.pts.tolist()))) for s in got if s.pen == p)
        b = sorted(tuple(sorted(map(tuple, s.pts.tolist()))) for s in ss if s.pen == p)
        assert a == b


def test_table_per_pen_in_drawing_order():
    ss = pens.arrange(pens.resolve([line(0, 0, 10, 0, pen="black", colour="#000000"),
                                    line(0, 0, 0, 5, pen="yellow", colour="#ffff00"),
                                    line(0, 0, 3, 4, pen="black", colour="#000000")]))
    assert pens.table(ss) == [
        {"name": "yellow", "colour": "#ffff00", "strokes": 1, "drawn_mm": 5.0},
        {"name": "black", "colour": "#000000", "strokes": 2, "drawn_mm": 15.0}]


@pytest.mark.parametrize("text,mm", [("80m", 80_000.0), ("500cm", 5000.0), ("1200mm", 1200.0),
                                     ("2.5", 2500.0), (" 3M ", 3000.0)])
def test_refill_distance(text, mm):
    assert pens.parse_distance(text) == mm


@pytest.mark.parametrize("text", ["", "m", "0m", "-1m", "nan", "inf", "5km", "abc"])
def test_bad_refill_distance(text):
    with pytest.raises(ValueError, match="a distance above 0"):
        pens.parse_distance(text)


# ------------------------------------------------------------------ records
def _pauses(records) -> list[Pause]:
    return [r for r in records if isinstance(r, Pause)]


def _pen_up_at_every_pause(records) -> bool:
    down = False
    for r in records:
        if isinstance(r, Pen):
            down = r.down
        elif isinstance(r, Pause) and down:
            return False
    return True


def test_records_pause_before_each_pen_the_first_included():
    ss = pens.arrange(pens.resolve([line(0, 0, 10, 0, pen="black", colour="#000000"),
                                    line(10, 0, 20, 0, pen="red", colour="#ff0000"),
                                    line(20, 0, 30, 0, pen="red", colour="#ff0000"),
                                    line(30, 0, 40, 0, pen="yellow", colour="#ffff00")]))
    recs = list(prepared(ss, join_mm=0.01).records())
    got = [(p.message, p.pen, p.index, p.count) for p in _pauses(recs)]
    assert got == [("put in the yellow pen (1 of 3)", "yellow", 1, 3),
                   ("put in the red pen (2 of 3)", "red", 2, 3),
                   ("put in the black pen (3 of 3)", "black", 3, 3)]
    assert _pen_up_at_every_pause(recs)         # strokes that touch are not joined across pens
    assert [r.line for r in recs] == sorted(r.line for r in recs)
    one = pens.resolve([line(0, 0, 1, 0, pen="red", colour="#ff0000")] * 2)
    assert _pauses(prepared(one).records()) == []            # one pen: nothing to ask for


def test_layer_pause_and_pen_change_at_the_same_place_are_one_pause():
    ss = pens.resolve([line(0, 0, 1, 0, pen="yellow", colour="#ffff00", layer="a"),
                       line(0, 1, 1, 1, pen="yellow", colour="#ffff00", layer="b"),
                       line(0, 2, 1, 2, pen="black", colour="#000000", layer="c")])
    got = [p.message for p in _pauses(prepared(ss, pause=True).records())]
    assert got == ["put in the yellow pen (1 of 2)", "layer a done; next: layer b: change the pen",
                   "put in the black pen (2 of 2)"]


def test_refill_pauses_every_n_mm_inside_and_between_strokes():
    ss = pens.resolve([Stroke(np.array([[0.0, 0.0], [1000.0, 0.0]])),
                       Stroke(np.array([[0.0, 10.0], [100.0, 10.0], [100.0, 20.0]]))])
    recs = list(prepared(ss, refill_mm=300.0).records())
    ps = _pauses(recs)
    assert [(p.pen, p.index, p.count) for p in ps] == [("default", 1, 1)] * 3
    assert ps[0].message == "0.3 m drawn with the default pen: put in a fresh one or refill it"
    assert _pen_up_at_every_pause(recs)
    # the cuts lie on the stroke at 300, 600 and 900 mm; 100 + 10 mm drawn after the last one
    ends = [r.x1 for r in recs if isinstance(r, Move) and not r.rapid][:4]
    assert ends == pytest.approx([300.0, 600.0, 900.0, 1000.0])
    drawn = sum(np.hypot(r.x1 - r.x0, r.y1 - r.y0) for r in recs
                if isinstance(r, Move) and not r.rapid)
    assert drawn == pytest.approx(1110.0)
    # a refill that would leave 1 mm or less of a stroke waits for the next stroke
    near = pens.resolve([Stroke(np.array([[0.0, 0.0], [300.5, 0.0]])), line(0, 5, 50, 5)])
    recs = list(prepared(near, refill_mm=300.0).records())
    i = next(k for k, r in enumerate(recs) if isinstance(r, Pause))
    assert isinstance(recs[i + 1], Move) and recs[i + 1].rapid and recs[i + 1].y1 == 5.0


def test_summary_times_each_pen_and_counts_fresh_pens():
    s = Summary(time_s=100.0)
    for pen, t, i in (("yellow", 0.0, 1), ("yellow", 20.0, 1), ("black", 30.0, 2),
                      (None, 40.0, 0)):
        s.pen_mark(Pause(1, 0, "m", pen, i, 2 if pen else 0), t)
    assert s.pen_lines() == ["pen 1 of 2: yellow for 0:30 (30.0 s), 1 fresh pen",
                             "pen 2 of 2: black for 1:10 (70.0 s)"]
    one = Summary(time_s=50.0)
    one.pen_mark(Pause(1, 0, "m", "default", 1, 1), 10.0)
    assert one.pen_lines() == ["pen default for 0:50 (50.0 s), 1 fresh pen"]
    assert Summary(time_s=5.0).pen_lines() == []


# ------------------------------------------------------------------ G-code tool changes
def _read(text: str) -> tuple[list, list[str]]:
    warned: list[str] = []
    lines = text.split("\n")
    return list(gcode.parse_lines(lines, "t.ngc", gcode.detect_pen_mode(lines),
                                  warn=warned.append)), warned


@pytest.mark.parametrize("text", [
    "T1 M6\nM3\nG1 X1\nM5\nM6 T2\nM3\nG1 X2\nM5",
    "T1\nM6\nM3\nG1 X1\nM5\nT2\nG0 X1\nM6\nM3\nG1 X2\nM5",
    "T1\nM3\nG1 X1\nM5\nT2\nM3\nG1 X2\nM5",                  # no M6 in the file: T changes
    "M0 (pen: T1)\nM3\nG1 X1\nM5\nM1 (pen: T2)\nM3\nG1 X2\nM5",
])
def test_tool_changes_become_pen_change_pauses(text):
    recs, warned = _read(text)
    assert warned == []
    assert [(p.pen, p.index, p.count, p.message) for p in _pauses(recs)] == [
        ("T1", 1, 2, "put in the T1 pen (1 of 2)"), ("T2", 2, 2, "put in the T2 pen (2 of 2)")]
    strokes = gcode_strokes(recs, 0.001)
    assert [(s.pen, s.pts[-1, 0]) for s in strokes] == [("T1", 1.0), ("T2", 2.0)]


def test_pauses_in_gcode_lift_the_pen_and_lower_it_again():
    recs, warned = _read("T1 M6\nM3\nG1 X1\nM0 (look at it)\nG1 X2\nT2 M6\nG1 X3\nM5\nT2 M6\nM2")
    kinds = [(type(r).__name__, getattr(r, "down", getattr(r, "pen", None))) for r in recs]
    assert kinds == [("Pause", "T1"), ("Pen", True), ("Move", None), ("Pen", False),
                     ("Pause", None), ("Pen", True), ("Move", None), ("Pen", False),
                     ("Pause", "T2"), ("Pen", True), ("Move", None), ("Pen", False)]
    assert recs[4].message == "look at it"
    assert warned == ["t.ngc: warning: ignored codes that change nothing for a pen plotter: M6"]
    one, warned = _read("T1 M6\nM3\nG1 X1\nM5")            # one tool: nothing to ask for
    assert _pauses(one) == [] and "M6" in warned[0]
    assert _read("M0\nG1 X1")[0][0].message == "M0: program pause"


@pytest.mark.parametrize("text,col,what", [
    ("M6", 1, "M6 (tool change) without a tool"), ("T2.5 M6", 1, "tool number T2.5"),
    ("M0 (pen: )", 4, "needs a pen name")])
def test_tool_change_errors(text, col, what):
    with pytest.raises(gcode.InputError, match=rf"^t\.ngc:2:{col}: error: .*{re.escape(what)}"):
        _read("G21\n" + text)


def test_m280_t_word_is_not_a_tool():
    recs, _ = _read("M280 P0 S30 T5\nG1 X1\nM280 P0 S100 T7\nT1\nG1 X2\nT2\nG1 X3")
    assert [p.pen for p in _pauses(recs)] == ["T1", "T2"]


def test_gcode_file_with_tools_draws_with_pauses_in_its_order(capsys, config_path, tmp_path,
                                                                pens_config):
    f = tmp_path / "tools.ngc"
    f.write_text("T1 M6\nM3\nG1 X10 F600\nM5\nT2 M6\nG0 X20\nM3\nG1 X30\nM5\nT1 M6\nG0 X0 Y10\n"
                 "M3\nG1 X10 Y10\nM5\nM2\n")
    code, out, _ = run(capsys, ["--config", config_path, "draw", f, "--dry-run"])
    assert code == 0
    assert [x.split(": ", 1)[1] for x in out.splitlines() if x.startswith("pause:")] == [
        "put in the T1 pen (1 of 2) (dry run: not waiting)",
        "put in the T2 pen (2 of 2) (dry run: not waiting)",
        "put in the T1 pen (1 of 2) (dry run: not waiting)"]
    assert "tools.ngc: pen 2 of 2: T2 for " in out
    code, out, err = run(capsys, ["--config", pens_config, "estimate", f])
    assert code == 0 and "pen T1 is not one of the pens in [pens]" in err


# ------------------------------------------------------------------ commands
def test_dry_run_names_each_pen_change_light_to_dark(capsys, pens_config, tmp_path):
    f = tmp_path / "layers.svg"
    f.write_text(LAYERS_SVG)
    code, out, _ = run(capsys, ["--config", pens_config, "draw", f, "--dry-run"])
    assert code == 0
    assert [x for x in out.splitlines() if x.startswith("pause:")] == [
        f"pause: put in the {p} pen ({i} of 3) (dry run: not waiting)"
        for i, p in enumerate(["yellow", "red", "black"], 1)]
    lines = [x for x in out.splitlines() if ": pen " in x]
    assert [x.split(": pen ")[1].split(" for ")[0] for x in lines] == [
        "1 of 3: yellow", "2 of 3: red", "3 of 3: black"]
    code, out, _ = run(capsys, ["--config", pens_config, "estimate", f, "--pen-order", "file"])
    assert [x.split(": pen ")[1].split(" for ")[0] for x in out.splitlines() if ": pen " in x] == [
        "1 of 3: black", "2 of 3: red", "3 of 3: yellow"]
    said = float(out.split("(")[-1].split(" s)")[0])      # the summary stays the last line
    summary = next(x for x in out.splitlines() if "plot time" in x)       # and the first
    assert said == float(summary.split("(")[-1].split(" s)")[0]) > 0


def test_info_json_has_the_pens_in_drawing_order(capsys, pens_config, tmp_path):
    f = tmp_path / "layers.svg"
    f.write_text(LAYERS_SVG)
    code, out, _ = run(capsys, ["--config", pens_config, "info", f, "--json"])
    info = json.loads(out)
    assert [(p["name"], p["colour"], p["strokes"]) for p in info["pens"]] == [
        ("yellow", "#ffff00", 1), ("red", "#d02020", 1), ("black", "#000000", 2)]
    assert [p["drawn_mm"] for p in info["pens"]] == pytest.approx(
        [2 * np.pi * 10, 50.0, 100.0], abs=0.05)
    assert set(info["pens"][0]) == {"name", "colour", "strokes", "drawn_mm"}
    code, out, _ = run(capsys, ["--config", pens_config, "info", f])
    assert "3 pens, light to dark:" in out and "yellow (#ffff00): 1 stroke, drawn 0.06 m" in out


def test_info_json_of_a_one_pen_gcode_file(capsys, config_path):
    code, out, _ = run(capsys, ["--config", config_path, "info",
                                REPO / "gcode_samples" / "car.ngc", "--json"])
    info = json.loads(out)
    assert [(p["name"], p["colour"], p["strokes"]) for p in info["pens"]] == [
        ("default", "#000000", 15)]
    assert info["pens"][0]["drawn_mm"] == pytest.approx(info["drawn_mm"], abs=0.01)


def test_convert_writes_m0_per_pen_and_reads_back_the_same_pens(tmp_path):
    cfg = config.load(REPO / "config.toml")
    ss = pens.arrange(pens.resolve([
        line(0, 0, 10, 0, pen="black", colour="#000000"),
        line(10, 0, 20, 5, pen="#ffcc00", colour="#ffcc00"),
        line(0, 10, 10, 10, pen="T2"),
        Stroke(np.array([[0.0, 20.0], [5.0, 25.0], [10.0, 20.0]]), pen="#ffcc00",
               colour="#ffcc00"),
        line(0, 30, 5, 30, pen="rgb(0, 128, 255)", colour="#0080ff")]))
    out = tmp_path / "o.ngc"
    with open(out, "w") as f:
        write_gcode(prepared(ss, join_mm=0.01), cfg, f)
    text = out.read_text()
    assert [x for x in text.splitlines() if x.startswith("M0")] == [
        "M0 (pen: #ffcc00)", "M0 (pen: #0080ff)", "M0 (pen: black)", "M0 (pen: T2)"]
    back = pens.resolve(gcode_strokes(gcode.read(str(out), warn=lambda m: None), 0.001))
    want = pens.table(ss)
    want[1]["name"] = "#0080ff"             # a name with parentheses is written as its colour
    assert pens.table(back) == want
    assert [s.pts.tolist() for s in back] == [s.pts.tolist() for s in ss]


def test_fake_backend_draw_is_the_file_in_pens(capsys, pens_config, tmp_path):
    """A dry run with a trace of a drawing in three pens draws the file's strokes within
    0.02 mm both ways (the converted G-code, its M0 pauses left out for the independent
    decoder), with the pen up and the coils released at every pause."""
    f, placed, trace = tmp_path / "layers.svg", tmp_path / "placed.ngc", tmp_path / "t.csv"
    f.write_text(LAYERS_SVG)
    assert run(capsys, ["--config", pens_config, "calibrate", "--at", "0", "0"])[0] == 0
    assert run(capsys, ["--config", pens_config, "convert", f, "-o", placed])[0] == 0
    ref = tmp_path / "ref.ngc"
    ref.write_text("\n".join(x for x in placed.read_text().splitlines() if not x.startswith("M0")))
    code, out, _ = run(capsys, ["--config", pens_config, "draw", f, "--dry-run", "--trace", trace])
    assert code == 0 and out.count("pause:") == 3
    cfg = tc.load_config(REPO / "config.toml")
    assert tc.verify(tc.read_trace(trace), ref, cfg, tol_mm=0.02) == []


@pytest.mark.parametrize("bad,what", [(["--refill-every", "0m"], "--refill-every must be"),
                                      (["--refill-every", "far"], "--refill-every must be"),
                                      (["--pen-order", "dark"], "--pen-order")])
@pytest.mark.parametrize("command", ["draw", "estimate", "info", "convert"])
def test_bad_pen_options(capsys, config_path, tmp_path, command, bad, what):
    extra = (["--dry-run"] if command == "draw" else
             ["-o", tmp_path / "o.ngc"] if command == "convert" else [])
    code, _, err = run(capsys, ["--config", config_path, command,
                                REPO / "gcode_samples" / "square.ngc", *extra, *bad])
    assert code == 2 and what in err


def test_bad_tool_change_is_one_line_and_exit_2(capsys, config_path, tmp_path):
    f = tmp_path / "bad.ngc"
    f.write_text("G21\nM3\nG1 X1\nM5\nM6\nG1 X2\n")
    code, out, err = run(capsys, ["--config", config_path, "draw", f, "--dry-run"])
    assert code == 2 and out == ""
    assert err.strip().splitlines()[-1].startswith(f"{f}:5:1: error: M6 (tool change) without")


def test_svg_colours_are_pens_light_to_dark(capsys, config_path, tmp_path):
    f = tmp_path / "c.svg"
    f.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="40mm" height="40mm" '
                 'viewBox="0 0 40 40"><path d="M5 5 L35 5" stroke="black"/>'
                 '<path d="M5 15 L35 15" stroke="#ff8800"/><path d="M5 25 L35 25" stroke="red"/>'
                 '<path d="M5 35 L35 35" stroke="rgb(255,255,0)"/></svg>')
    code, out, _ = run(capsys, ["--config", config_path, "info", f, "--json"])
    got = json.loads(out)["pens"]
    assert [p["colour"] for p in got] == ["#ffff00", "#ff8800", "#ff0000", "#000000"]
    assert [p["strokes"] for p in got] == [1, 1, 1, 1]
    code, out, _ = run(capsys, ["--config", config_path, "draw", f, "--dry-run"])
    assert [x.split("put in the ")[1].split(" pen (")[0]
            for x in out.splitlines() if x.startswith("pause:")] == [p["name"] for p in got]


def test_passthrough_gcode_names_owned_pens_and_caps_their_speed(pens_config, tmp_path):
    from vplotter.prepare import prepare

    f = tmp_path / "p.ngc"
    f.write_text("M0 (pen: Yellow)\nM3\nG1 X10 F600\nM5\nM0 (pen: red)\nM3\nG1 X20 F600\nM5\n")
    cfg = config.load(pens_config)
    args = argparse.Namespace(order=None, scale=None, rotate=None, fit=False, offset=None)
    prep = prepare(str(f), cfg, args, warn=lambda m: None)
    assert prep.passthrough
    recs = list(prep.records())
    assert [p.pen for p in _pauses(recs)] == ["yellow", "red"]
    assert [r.feed_mm_s for r in recs if isinstance(r, Move)] == [10.0, 2.0]


def test_passthrough_gcode_pen_by_a_far_colour_is_warned_about_once(pens_config, tmp_path):
    """`(pen: purple)` in a G-code file drawn as it is, with no purple pen: drawn with the
    nearest pen, and said once, as for an SVG's far colour."""
    from vplotter.prepare import prepare

    f = tmp_path / "p.ngc"
    f.write_text("M0 (pen: purple)\nM3\nG1 X10 F600\nM5\nM0 (pen: red)\nM3\nG1 X20\nM5\n"
                 "M0 (pen: purple)\nM3\nG1 X30\nM5\n")
    said = []
    args = argparse.Namespace(order=None, scale=None, rotate=None, fit=False, offset=None)
    prep = prepare(str(f), config.load(pens_config), args, warn=said.append)
    assert prep.passthrough
    assert [p.pen for p in _pauses(list(prep.records()))] == ["black", "red", "black"]
    assert [m for m in said if "purple" in m] == [
        f"{f}:1: warning: no pen in [pens] is close to colour purple: drawn with black "
        "(#000000, colour difference 34)"]


@st.composite
def tool_programs(draw):
    """Programs of strokes and tool changes in every form the reader takes."""
    lines, m6 = [], draw(st.booleans())
    for k in range(draw(st.integers(1, 8))):
        t = draw(st.integers(0, 3))
        form = draw(st.sampled_from(["T M6", "M6 T", "T;M6", "M6.0 T", "M0", "M0.0", "none"]
                                    if m6 else ["T", "M0", "M0.0", "none"]))
        lines += {"T M6": [f"T{t} M6"], "M6 T": [f"M6 T{t}"], "T;M6": [f"T{t}", "G0 X0", "M6"],
                  "M6.0 T": [f"M6.0 T{t}"], "T": [f"T{t}"], "M0": [f"M0 (pen: P{t})"],
                  "M0.0": [f"M1.0 (pen: P{t})"], "none": []}[form]
        lines += ["M3", f"G1 X{k + 1}", "M5"]
    return "\n".join(lines)


@given(tool_programs())
def test_tool_changes_agree_with_the_scan(text):
    recs, _ = _read(text)
    _, names = gcode_tools.scan(text.split("\n"))
    ps = _pauses(recs)
    assert all(p.pen in names and p.index == names.index(p.pen) + 1 and p.count == len(names)
               for p in ps)
    assert all(a.pen != b.pen for a, b in zip(ps, ps[1:]))       # no change to the pen in
    assert (len(ps) > 0) == (len(names) > 1)
    assert _pen_up_at_every_pause(recs)
    strokes = gcode_strokes(recs, 0.001)
    want, pen = [], None
    for r in recs:
        if isinstance(r, Pause):
            pen = r.pen
        elif isinstance(r, Pen) and r.down:
            want.append(pen)
    assert [s.pen for s in strokes] == want


def test_the_scan_sees_a_pen_change_written_with_a_decimal_point():
    # M0.0 is M0 to the reader: the scan that counts the pens must see it too, else the
    # second pen is not counted and neither change pauses (the file looked like one pen)
    text = "M0 (pen: red)\nM3\nG1 X1\nM5\nM0.0 (pen: blue)\nM3\nG1 X2\nM5"
    assert gcode_tools.scan(text.split("\n")) == (False, ("red", "blue"))
    recs, _ = _read(text)
    assert [(p.pen, p.index, p.count) for p in _pauses(recs)] == [("red", 1, 2), ("blue", 2, 2)]


def test_refill_every_on_a_gcode_file_drawn_as_it_is(capsys, config_path):
    """--refill-every without placement options still pauses (the file is then read into
    strokes rather than streamed)."""
    code, out, _ = run(capsys, ["--config", config_path, "draw", REPO / "gcode_samples" /
                                "car.ngc", "--dry-run", "--refill-every", "0.5m"])
    assert code == 0
    assert out.count("pause: 0.5 m drawn with the default pen") == 3


def test_plain_m0_left_out_of_a_placed_gcode_file_is_said(capsys, config_path, tmp_path):
    f = tmp_path / "m0.ngc"
    f.write_text("G1 X0 Y0 Z-1\nG1 X10\nM0 (look)\nG1 Y10\nG0 Z5\n")
    code, out, err = run(capsys, ["--config", config_path, "draw", f, "--dry-run"])
    assert code == 0 and "pause: look" in out
    code, out, err = run(capsys, ["--config", config_path, "draw", f, "--dry-run", "--scale", "2"])
    assert code == 0 and "pause:" not in out
    assert f"{f}:3: warning: 1 M0/M1 pause left out" in err


def test_white_strokes_are_left_out_unless_a_white_pen_is_owned():
    """A page's white background rectangle (matplotlib, Illustrator) must not ask for a white
    pen: white does not show on paper. One warning counts what is left out."""
    sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 0.0]])
    ss = [Stroke(sq, 1, pen="white", colour="#ffffff"), Stroke(sq + 1, 2, pen="red",
                                                                colour="#ff0000"),
          Stroke(sq + 2, 3, pen="#fefefe", colour="#fefefe")]
    said = []
    got = pens.resolve(ss, (), said.append, "f.svg")
    assert [s.pen for s in got] == ["red"]
    assert said == ["f.svg: warning: 2 strokes in white left out (white does not show on "
                    "paper; a white pen in [pens] draws them)"]
    owned = (PenSpec("chalk", "#ffffff"), PenSpec("ink", "#cc1010"))
    said.clear()
    got = pens.resolve(ss, owned, said.append, "f.svg")
    assert [s.pen for s in got] == ["chalk", "ink", "chalk"]
    assert not any("white" in m for m in said)
