"""prepare(), info and convert, the file options on draw/estimate, and what the motors draw for a
placed and ordered file (decoded by tests/support/tracecheck/)."""

from __future__ import annotations

import io
import json
import os
import sys
import types

import numpy as np
import pytest
from hypothesis import given, strategies as st

from support import tracecheck as tc
from support import REPO
from vplotter import config
from vplotter.drawing import order
from vplotter.cli import main
from vplotter.commands.files import write_gcode
from vplotter.inputs import gcode
from vplotter.inputs.strokes import Drawing, Stroke
from vplotter.prepare import Prepared
from vplotter.readers.gcode import gcode_strokes

CAR = REPO / "gcode_samples" / "car.ngc"


def run(capsys, argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == (0 if code == 0 else 1), err
    return code, out, err


@pytest.fixture
def svg_stub(monkeypatch):
    """A stand-in for the SVG reader (inputs/svg.py is another module's work): the file's
    content is ignored, the strokes come from `drawing` below, in G-code mm."""
    box = {"drawing": None, "calls": []}

    def read(path, tol_mm, layers=None, warn=None):
        box["calls"].append((path, tol_mm, layers))
        d = box["drawing"]
        if layers:
            d = Drawing(d.name, [s for s in d.strokes if s.layer in layers], d.width_mm,
                        d.height_mm, d.layers, d.skipped)
        return d

    mod = types.ModuleType("vplotter.inputs.svg")
    mod.read = read
    monkeypatch.setitem(sys.modules, "vplotter.inputs.svg", mod)
    import vplotter.inputs

    monkeypatch.setattr(vplotter.inputs, "svg", mod, raising=False)
    return box


def _two_layers() -> Drawing:
    s = [Stroke(np.array([[x, 0.0], [x, 20.0]]), line=i + 1, layer=lay, src=f"p{i}")
         for i, (x, lay) in enumerate([(0, "red"), (30, "blue"), (10, "red"), (40, "blue")])]
    s.append(Stroke(np.array([[5.0, 5.0]]), line=5, layer="blue", src="dot"))
    return Drawing("t.svg", s, 100.0, 80.0,
                   [{"id": "layer1", "label": "red", "visible": True},
                    {"id": "layer2", "label": "blue", "visible": True},
                    {"id": "layer3", "label": "ghost", "visible": False}],
                   {"text": 2, "image": 1, "hidden": 3})


# ------------------------------------------------------------------ info
def test_info_json_for_gcode_matches_estimate(capsys, config_path):
    code, out, _ = run(capsys, ["--config", config_path, "info", CAR, "--json"])
    assert code == 0
    info = json.loads(out)
    assert set(info) == {"width_mm", "height_mm", "extent", "strokes", "drawn_mm", "travel_mm",
                         "time_s", "layers", "skipped", "notes", "details", "advice", "pens"}
    assert info["layers"] == [] and info["skipped"] == {"text": 0, "image": 0, "hidden": 0}
    assert info["notes"] == [] and info["details"] == [] and info["advice"] == []
    x0, y0, x1, y1 = info["extent"]
    assert info["width_mm"] == pytest.approx(x1 - x0, abs=1e-3)
    assert info["height_mm"] == pytest.approx(y1 - y0, abs=1e-3)
    assert info["strokes"] == 15
    assert info["travel_mm"]["best"] < info["travel_mm"]["file"]
    assert info["time_s"]["best"] < info["time_s"]["file"]
    for order_opt, key in (([], "file"), (["--order", "best"], "best")):
        code, out, _ = run(capsys, ["--config", config_path, "estimate", CAR, *order_opt])
        said = float(out.split("(")[-1].split(" s)")[0])
        assert said == pytest.approx(info["time_s"][key], abs=0.05)


def test_info_svg_layers_and_skipped(capsys, config_path, tmp_path, svg_stub):
    svg_stub["drawing"] = _two_layers()
    f = tmp_path / "t.svg"
    f.write_text("<svg/>")
    code, out, _ = run(capsys, ["--config", config_path, "info", f, "--json"])
    info = json.loads(out)
    assert (info["width_mm"], info["height_mm"]) == (100.0, 80.0)
    assert info["skipped"] == {"text": 2, "image": 1, "hidden": 3}
    assert info["layers"][2] == {"id": "layer3", "label": "ghost", "visible": False}
    assert info["strokes"] == 5
    assert info["extent"] == [0.0, 0.0, 40.0, 20.0]
    assert info["drawn_mm"] == pytest.approx(80.0)
    code, out, _ = run(capsys, ["--config", config_path, "info", f])
    assert "skipped 2 text elements" in out and "layer ghost (id layer3): hidden" in out


def test_file_type_by_content(capsys, config_path, tmp_path, svg_stub):
    svg_stub["drawing"] = _two_layers()
    f = tmp_path / "drawing.txt"
    f.write_text("  <?xml version='1.0'?><svg/>")
    assert run(capsys, ["--config", config_path, "info", f, "--json"])[0] == 0
    assert svg_stub["calls"] and svg_stub["calls"][0][1] == pytest.approx(0.0075)


# ------------------------------------------------------------------ errors
def test_page_error_names_the_svg_element(capsys, config_path, tmp_path, svg_stub):
    d = _two_layers()
    d.strokes.append(Stroke(np.array([[0.0, 0.0], [500.0, 0.0]]), line=9, src="far-away"))
    svg_stub["drawing"] = d
    f = tmp_path / "t.svg"
    f.write_text("<svg/>")
    for cmd in (["draw", f, "--dry-run"], ["estimate", f]):
        code, _, err = run(capsys, ["--config", config_path, *cmd])
        assert code == 2
        assert f"{f}: element far-away: error: point X" in err and "outside the page" in err


def test_page_error_after_placement_names_the_gcode_line(capsys, config_path):
    code, _, err = run(capsys, ["--config", config_path, "estimate", CAR, "--scale", "4"])
    assert code == 2
    msg = [e for e in err.splitlines() if "error:" in e][0]
    assert msg.startswith(f"{CAR}:") and ": error: point X" in msg
    line = int(msg.split(":")[1])
    assert 1 <= line <= 320
    # fitted to the page it fits
    assert run(capsys, ["--config", config_path, "estimate", CAR, "--fit", "--margin", "10"])[0] == 0


@pytest.mark.parametrize("bad", [["--scale", "0"], ["--scale", "-2"], ["--scale", "nan"],
                                 ["--scale", "x"], ["--rotate", "inf"], ["--join", "-1"],
                                 ["--margin", "-1"], ["--fit", "--scale", "2"],
                                 ["--align", "diagonal"], ["--order", "fast"],
                                 ["--offset", "1"], ["--layer", "red"],
                                 ["--fit", "--margin", "300"]])
@pytest.mark.parametrize("command", ["draw", "estimate", "info", "convert"])
def test_bad_option_values(capsys, config_path, tmp_path, command, bad):
    extra = ["--dry-run"] if command == "draw" else ["-o", tmp_path / "o.ngc"] if command == "convert" else []
    code, _, err = run(capsys, ["--config", config_path, command, CAR, *extra, *bad])
    assert code == 2


DEGENERATE = (b"G0 X0 Y0\nG1 X0 Y0\nM3\nG1 X0 Y0\nG4 P0\nG2 X0 Y0 I5 J0\n"
              b"G3 X0 Y0 I0 J-0.01\nG1 X0\nM5\nM5\nG0 X0 Y0\n")


@pytest.mark.parametrize("content,code", [(b"", 0), (b"G1 X10 Y10\n", 0), (b"\x00\xff garbage", 2),
                                          (None, 2), ("dir", 2), (DEGENERATE, 0),
                                          (b"G0 X10 Y10\nM3\nG1 X500 Y0\nM5\n", 0)])
@pytest.mark.parametrize("command", ["info", "convert"])
def test_info_and_convert_on_bad_input(capsys, config_path, tmp_path, command, content, code):
    f = tmp_path / "in.ngc"
    if content == "dir":
        f.mkdir()
    elif content is not None:
        f.write_bytes(content)
    extra = ["-o", tmp_path / "o.ngc"] if command == "convert" else []
    got, out, err = run(capsys, ["--config", config_path, command, f, *extra])
    assert got == code
    bad_cfg = tmp_path / "bad.toml"
    bad_cfg.write_text(open(config_path).read().replace("max_step_rate = 663", "max_step_rate = -5"))
    assert run(capsys, ["--config", bad_cfg, command, CAR, *extra])[0] == 2
    if isinstance(content, bytes) and b"X500" in content and command == "info":
        assert "does not fit the page" in out and "warning:" in err


# ------------------------------------------------------------------ convert
def _strokes_of(text: str) -> list[Stroke]:
    recs = gcode.parse_lines(text.splitlines(), "out.ngc", gcode.detect_pen_mode(text.splitlines()))
    return gcode_strokes(recs, 0.001)


def test_convert_reads_back_and_converts_to_itself(capsys, config_path, tmp_path):
    a, b = tmp_path / "a.ngc", tmp_path / "b.ngc"
    assert run(capsys, ["--config", config_path, "convert", CAR, "-o", a, "--order", "best",
                        "--rotate", "90", "--fit"])[0] == 0
    assert run(capsys, ["--config", config_path, "convert", a, "-o", b])[0] == 0
    ta, tb = a.read_text(), b.read_text()
    assert ta.splitlines()[1:] == tb.splitlines()[1:]           # the first line names the input
    assert ta.splitlines()[1:4] == ["G21", "G90", "G0 Z5"]
    assert not [x for x in ta.splitlines() if x.split(" ")[0] in ("G2", "G3")]
    # the strokes are the placed, ordered ones
    from vplotter.commands.files import prepare_file
    import argparse

    cfg = config.load(config_path)
    from vplotter.prepare import prepare

    args = argparse.Namespace(order="best", rotate=90.0, fit=True, scale=None, margin=0.0,
                              align=None, valign=None, offset=None, join=None, layer=None,
                              pause_between_layers=False, strict=False)
    prep = prepare(str(CAR), cfg, args, warn=lambda m: None)
    got = _strokes_of(ta)
    want = prep.strokes
    assert prep.join_mm == cfg.motion.tolerance_mm * 0.75      # the default join
    joined = order.joined(want, prep.join_mm)
    assert len(got) == len(want) - joined.sum()
    pts_got = np.concatenate([s.pts for s in got])
    pts_want = np.concatenate([s.pts for s in want])
    d = np.hypot(*(pts_got[:, None, :] - pts_want[None, :, :]).transpose(2, 0, 1))
    assert d.min(axis=0).max() <= 1e-4 and d.min(axis=1).max() <= 1e-4
    assert abs(sum(s.length_mm() for s in got) - sum(s.length_mm() for s in want)) \
        <= prep.join_mm * joined.sum() + 1e-3
    del prepare_file


grid = st.integers(-400, 400).map(lambda v: v * 0.25)


@st.composite
def drawings(draw):
    out = []
    for _ in range(draw(st.integers(0, 8))):
        pts = draw(st.lists(st.tuples(grid, grid), min_size=1, max_size=6))
        pts = [p for i, p in enumerate(pts) if i == 0 or p != pts[i - 1]]
        feed = draw(st.sampled_from([None, 2.0, 3.5]))
        out.append(Stroke(np.array(pts, dtype=float), feed_mm_s=feed))
    return out


@given(drawings())
def test_convert_round_trip(ss):
    cfg = config.load(REPO / "config.toml")
    prep = Prepared("x.svg", "svg", False, join_mm=0.0)
    prep._strokes = ss
    f = io.StringIO()
    write_gcode(prep, cfg, f)
    back = _strokes_of(f.getvalue())
    assert len(back) == len(ss)
    for a, b in zip(ss, back):
        assert np.array_equal(a.pts, b.pts)
        if len(a.pts) > 1 and any(s.feed_mm_s is not None for s in ss):   # a dot has no feed
            want = a.feed_mm_s or cfg.motion.draw_speed_mm_s
            assert b.feed_mm_s == pytest.approx(want)
    # and once more: the same text
    prep2 = Prepared("x.ngc", "gcode", False, join_mm=0.0)
    prep2._strokes = back
    g = io.StringIO()
    write_gcode(prep2, cfg, g)
    assert g.getvalue().splitlines()[1:] == f.getvalue().splitlines()[1:]


def test_convert_pen_words_follow_the_configured_dialect():
    """Z5/Z-1 by default; with a [gcode] pen dialect (config.toml), that dialect's words."""
    from vplotter.commands.files import pen_words

    cfg = config.load(REPO / "config.toml")
    assert pen_words(cfg) == ("G0 Z5", "G1 Z-1")
    dialect = types.SimpleNamespace
    assert pen_words(dialect(gcode=dialect(pen="auto", z_down_below_mm=0.0))) == ("G0 Z5", "G1 Z-1")
    assert pen_words(dialect(gcode=dialect(pen="z", z_down_below_mm=3.0))) == ("G0 Z8", "G1 Z2")
    assert pen_words(dialect(gcode=dialect(pen="m3", m3_down=True))) == ("M5", "M3")
    assert pen_words(dialect(gcode=dialect(pen="m3", m3_down=False))) == ("M3", "M5")
    assert pen_words(dialect(gcode=dialect(pen="m280", m280_servo=1, m280_up_s=(70.0, 180.0),
                                           m280_down_s=(0.0, 50.0)))) == ("M280 P1 S125",
                                                                          "M280 P1 S25")


def test_convert_with_m3_pen_reads_back(tmp_path):
    cfg = config.load(REPO / "config.toml")
    cfg_m3 = types.SimpleNamespace(motion=cfg.motion,
                                   gcode=types.SimpleNamespace(pen="m3", m3_down=True))
    ss = [Stroke(np.array([[0.0, 0.0], [10, 0], [10, 5]])), Stroke(np.array([[20.0, 1.0]]))]
    prep = Prepared("x.svg", "svg", False, join_mm=0.0)
    prep._strokes = ss
    f = io.StringIO()
    write_gcode(prep, cfg_m3, f)
    assert "Z" not in f.getvalue() and "M3" in f.getvalue()
    back = _strokes_of(f.getvalue())
    assert [b.pts.tolist() for b in back] == [s.pts.tolist() for s in ss]


# ------------------------------------------------------------------ draw
def test_placed_ordered_draw_lies_on_the_placed_path(capsys, config_path, tmp_path):
    """A dry run of car.ngc rotated, scaled, moved and reordered: the decoded trace lies within
    0.02 mm of the converted (placed, ordered) G-code both ways, and the printed estimate is
    the trace's time."""
    opts = ["--order", "best", "--rotate", "30", "--scale", "0.8", "--offset", "-20", "10"]
    out_ngc, trace = tmp_path / "placed.ngc", tmp_path / "t.csv"
    assert run(capsys, ["--config", config_path, "calibrate", "--at", "0", "0"])[0] == 0
    assert run(capsys, ["--config", config_path, "convert", CAR, "-o", out_ngc, *opts])[0] == 0
    code, out, _ = run(capsys, ["--config", config_path, "draw", CAR, "--dry-run", "--trace",
                                trace, *opts])
    assert code == 0
    cfg = tc.load_config(config_path)
    assert tc.verify(tc.read_trace(trace), out_ngc, cfg, tol_mm=0.02) == []
    said = float(out.split("(")[-1].split(" s)")[0])
    assert abs(said - tc.plot_time(tc.read_trace(trace))) <= 0.05 + 0.001 * said
    assert "pen lifts" in out and "placed and ordered in" in out


def test_svg_draw_pauses_between_layers_in_a_dry_run(capsys, config_path, tmp_path, svg_stub):
    svg_stub["drawing"] = _two_layers()
    f = tmp_path / "t.svg"
    f.write_text("<svg/>")
    assert run(capsys, ["--config", config_path, "calibrate", "--at", "0", "0"])[0] == 0
    code, out, _ = run(capsys, ["--config", config_path, "draw", f, "--dry-run",
                                "--pause-between-layers"])
    assert code == 0
    assert out.count("pause:") == 1
    assert "pause: layer red done; next: layer blue: change the pen (dry run: not waiting)" in out


def test_pause_waits_for_enter_with_the_pen_up(capsys, config_path, tmp_path, svg_stub,
                                               monkeypatch):
    svg_stub["drawing"] = _two_layers()
    f = tmp_path / "t.svg"
    f.write_text("<svg/>")
    trace = tmp_path / "t.csv"
    read = []

    class Stdin(io.StringIO):
        def readline(self, *a):
            read.append(True)
            return super().readline(*a)

    monkeypatch.setattr(sys, "stdin", Stdin("\n"))
    assert run(capsys, ["--config", config_path, "calibrate", "--at", "0", "0"])[0] == 0
    code, out, _ = run(capsys, ["--config", config_path, "draw", f, "--backend", "fake",
                                "--trace", trace, "--pause-between-layers", "--layer", "red",
                                "--layer", "blue"])
    assert code == 0 and read == [True]
    assert "change the pen, then press Enter" in out
    cfg = tc.load_config(config_path)
    dec = tc.decode(tc.read_trace(trace), cfg)
    drawn = tc.drawn_polylines(dec)
    assert len(drawn) >= 3                      # the red strokes, then the blue ones
    assert tc.released_at_end(tc.read_trace(trace), cfg) == []
    # released at the pause in a one-coil phase, energised there again, and the half step
    # taken back before the next move: legal all through, on the path
    assert tc.two_coil_edges(tc.read_trace(trace), cfg) == []
    assert tc.illegal_transitions(dec) == []


def test_layer_option_draws_only_those_layers(capsys, config_path, tmp_path, svg_stub):
    svg_stub["drawing"] = _two_layers()
    f = tmp_path / "t.svg"
    f.write_text("<svg/>")
    code, out, _ = run(capsys, ["--config", config_path, "estimate", f, "--layer", "red"])
    assert code == 0 and ", 2 pen lifts," in out
    assert svg_stub["calls"][-1][2] == ["red"]


def test_gcode_keep_streams_the_file_itself(config_path):
    import argparse

    from vplotter.prepare import prepare

    cfg = config.load(config_path)
    args = argparse.Namespace(order=None, scale=None, rotate=None, fit=False, offset=None)
    prep = prepare(str(CAR), cfg, args, warn=lambda m: None)
    assert prep.passthrough and prep.order_s == 0
    a = list(prep.records())
    assert a == list(gcode.read(str(CAR), warn=lambda m: None))
    assert list(prep.records()) == a                         # a fresh iterator each time
    assert any(isinstance(r, gcode.Move) and r.arc for r in a)     # exact arcs


def test_interrupted_ordered_draw_resumes_on_the_placed_path(capsys, config_path, tmp_path,
                                                             monkeypatch):
    """Placed and reordered drawings are numbered record by record: a stop mid-stroke resumes
    there, both parts lie on the placed path and together cover it; other options are refused."""
    import signal

    from scipy.spatial import cKDTree

    from support.signals import interrupt_after
    from vplotter.machine import state
    from vplotter.backends.fake import FakeBackend

    opts = ["--order", "best", "--rotate", "15", "--scale", "0.9"]
    placed, t1, t2 = tmp_path / "placed.ngc", tmp_path / "t1.csv", tmp_path / "t2.csv"
    assert run(capsys, ["--config", config_path, "calibrate", "--at", "0", "0"])[0] == 0
    assert run(capsys, ["--config", config_path, "convert", CAR, "-o", placed, *opts])[0] == 0
    orig = interrupt_after(monkeypatch, 150_000, signal.SIGINT)
    assert main(["--config", str(config_path), "draw", str(CAR), "--backend", "fake", "--trace",
                 str(t1), *opts]) == 130
    capsys.readouterr()
    monkeypatch.setattr(FakeBackend, "play", orig)
    resume = state.load().extra["resume"]
    assert resume["line"] > 0
    code, _, err = run(capsys, ["--config", config_path, "draw", CAR, "--backend", "fake",
                                "--resume", "--order", "greedy"])
    assert code == 2 and "other options" in err
    pos = state.load()
    assert run(capsys, ["--config", config_path, "draw", CAR, "--backend", "fake", "--resume",
                        "--trace", t2, *opts])[0] == 0
    cfg = tc.load_config(config_path)
    from vplotter import config as vconfig, kinematics

    vcfg = vconfig.load(config_path)
    kin = kinematics.from_config(vcfg)
    xy = kin.to_gcode(kin.forward(np.array([[pos.left_mm, pos.right_mm]])))[0]
    dec1 = tc.decode(tc.read_trace(t1), cfg, (0.0, 0.0))
    dec2 = tc.decode(tc.read_trace(t2), cfg, (float(xy[0]), float(xy[1])))
    ref = tc.reference_path(placed)
    for dec in (dec1, dec2):
        pts = np.column_stack((dec.x, dec.y))[dec.pen_down]
        assert len(pts) and tc.distances_to_polylines(pts, ref).max() <= 0.02
    drawn = np.vstack([np.column_stack((d.x, d.y))[d.pen_down] for d in (dec1, dec2)])
    assert max(cKDTree(drawn).query(r)[0].max() for r in ref) <= 0.02


def test_pause_goes_on_when_stdin_is_closed(capsys, tmp_path):
    from vplotter.commands.draw import wait_enter

    with open(tmp_path / "empty", "w+") as f:          # a real file descriptor at its end
        wait_enter(f, lambda: False)
    assert "standard input is closed" in capsys.readouterr().err
    r, w = os.pipe()                                   # nothing typed: a signal ends the wait
    with os.fdopen(r) as f:
        calls = []
        wait_enter(f, lambda: calls.append(1) or len(calls) > 2, poll_s=0)
    os.close(w)
    assert len(calls) == 3


def test_progress_line_shows_travel_pen_lifts_and_time(capsys):
    from vplotter.commands.common import Progress
    from vplotter.pipeline import Summary

    p = Progress(Summary(travel_mm=1234.0, pen_downs=17, time_s=3725.0))
    p(1_862_500_000, 42)
    err = capsys.readouterr().err
    assert "50%" in err and "line 42" in err and "31:02 left" in err
    assert "travel 1.23 m, 17 pen lifts, plot time 1:02:05" in err
