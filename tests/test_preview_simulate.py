"""preview and simulate: the pictures' geometry (right way up, strokes where the G-code puts
them, page and anchors), the SVG twin, simulate of a dry-run trace covering the drawing, the
trace reader, and errors as one line with exit status 2."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from PIL import Image

from support.cli import GARBAGE, run
from vplotter import config, kinematics
from vplotter.drawing import render
from vplotter.machine import trace
from vplotter.motion.schedule import Rows
from vplotter.motion.sequencer import TABLES, coil_words

SAMPLES = Path(__file__).resolve().parent.parent / "gcode_samples"
SVG = "{http://www.w3.org/2000/svg}"

# Two strokes: first a square high on the page, right of the origin (red, first), then a short
# line low on the page, left of it (violet, last).
TWO = (b"G0 X40 Y150\nM3\nG1 X100 Y150\nG1 X100 Y210\nG1 X40 Y210\nG1 X40 Y150\nM5\n"
       b"G0 X-150 Y-200\nM3\nG1 X-100 Y-200\nM5\n")


@pytest.fixture
def cfg(config_path):
    return config.load(str(config_path))


def _rgb(img, xy) -> np.ndarray:
    """The pixel that holds picture point xy (pixel i spans i..i+1, as in SVG)."""
    x, y = np.floor(xy).astype(int)
    return np.asarray(img.convert("RGB"))[y, x].astype(int)


def _inked(img, xy, r: int = 1) -> bool:
    """Something darker or more saturated than the paper within r px of xy."""
    a = np.asarray(img.convert("RGB")).astype(int)
    x, y = np.floor(xy).astype(int)
    patch = a[y - r:y + r + 1, x - r:x + r + 1]
    return bool(((patch.max(axis=2) - patch.min(axis=2) > 60) | (patch.max(axis=2) < 140)).any())


def _preview(capsys, config_path, tmp_path, content=TWO, out="p.png", size=400):
    g = tmp_path / "in.ngc"
    g.write_bytes(content)
    code, stdout, err = run(capsys, ["--config", config_path, "preview", g, "-o",
                                     tmp_path / out, "--size", size])
    return code, tmp_path / out, stdout, err


def test_preview_png_geometry(capsys, config_path, tmp_path, cfg):
    code, out, stdout, _ = _preview(capsys, config_path, tmp_path)
    assert code == 0 and "2 pen lifts" in stdout
    img = Image.open(out)
    assert max(img.size) == 400 and img.size[0] < img.size[1]     # the page is taller than wide
    kin = kinematics.from_config(cfg)
    # the same view as the command's (the page and the anchors cover this drawing)
    view = render.preview([np.zeros((1, 2))], (0, 0), kin, cfg.page, "", 400).view
    assert (view.width_px, view.height_px) == img.size
    for p in [(70, 150), (100, 180), (40, 180), (-125, -200), (0, 0)]:
        assert _inked(img, view.px([p])[0]), p
    for p in [(70, 180), (-170, 0), (150, -200)]:             # inside the square, empty paper
        assert tuple(_rgb(img, view.px([p])[0])) == (255, 255, 255), p
    # the pen-up travel from the first stroke's end to the second's start: grey
    grey = np.asarray(img.convert("RGB")).astype(int)
    x, y = np.floor(view.px([(-55, -25)])[0]).astype(int)
    patch = grey[y - 1:y + 2, x - 1:x + 2].reshape(-1, 3)
    darkest = patch[patch.sum(axis=1).argmin()]
    assert darkest.max() < 230 and darkest.max() - darkest.min() < 10
    # the anchors: dark dots at the top corners, the left one on the left
    left, right = view.px(kin.to_gcode(kin.anchors))
    assert _rgb(img, left).max() < 100 and _rgb(img, right).max() < 100
    assert left[1] < 0.1 * img.size[1] and left[0] < right[0]
    # the page: paper inside its corners, the wall outside
    wall = tuple(int(render.WALL[i:i + 2], 16) for i in (1, 3, 5))
    for corner, inward in [((cfg.page.x_min_mm, cfg.page.y_min_mm), (1, -1)),
                           ((cfg.page.x_max_mm, cfg.page.y_max_mm), (-1, 1))]:
        c = view.px([corner])[0]
        # (within 4 levels: the downsampling filter rings a little next to the frame)
        assert np.abs(_rgb(img, c + 3 * np.array(inward)) - 255).max() <= 4
        assert np.abs(_rgb(img, c - 3 * np.array(inward)) - wall).max() <= 4


def test_preview_right_way_up_and_order_colours(capsys, config_path, tmp_path):
    """From the pixels alone: the first stroke (red) is high on the page and right, the last
    (violet) is low and left; G-code +Y is up in the picture."""
    code, out, _, _ = _preview(capsys, config_path, tmp_path, size=600)
    a = np.asarray(Image.open(out).convert("RGB")).astype(int)
    r, g, b = a[..., 0], a[..., 1], a[..., 2]
    red = (r - np.maximum(g, b) > 80) & (np.abs(g - b) < 30)
    violet = (b - g > 80) & (r - g > 40)
    assert red.sum() > 50 and violet.sum() > 10
    ry, rx = np.nonzero(red)
    vy, vx = np.nonzero(violet)
    assert ry.mean() < vy.mean() and rx.mean() > vx.mean()
    # the legend line sits below the page and says what was measured
    assert code == 0


def test_preview_svg_has_one_element_per_stroke_and_the_travel(capsys, config_path, tmp_path):
    code, out, _, _ = _preview(capsys, config_path, tmp_path, out="p.svg", size=500)
    assert code == 0
    root = ET.parse(out).getroot()
    assert root.tag == f"{SVG}svg" and int(root.get("height")) == 500
    strokes = [e for e in root.iter(f"{SVG}polyline") if e.get("class") == "stroke"]
    travel = [e for e in root.iter(f"{SVG}path") if e.get("class") == "travel"]
    assert len(strokes) == 2 and len(travel) == 1
    assert travel[0].get("d").count("M") == 2                   # start -> first, first -> last
    ys = [np.array([p.split(",") for p in e.get("points").split()], float)[:, 1] for e in strokes]
    assert ys[0].max() < ys[1].min()                             # the first stroke is higher
    assert strokes[0].get("stroke") != strokes[1].get("stroke")
    legend = [e.text for e in root.iter(f"{SVG}text") if e.get("class") == "legend"]
    assert "drawn 0.29 m" in legend[0] and "2 pen lifts" in legend[0] and "plot time" in legend[0]


def test_preview_legend_is_the_estimate_and_the_grey_is_the_travel(capsys, config_path,
                                                                   tmp_path, cfg):
    """The legend's figures are estimate's, and the grey lines are as long as its travel."""
    g = SAMPLES / "car.ngc"
    code, est, _ = run(capsys, ["--config", config_path, "estimate", g])
    time = est.split("plot time ")[1].strip()
    travel_m = float(est.split("travel ")[1].split(" m")[0])
    code, _, _ = run(capsys, ["--config", config_path, "preview", g, "-o", tmp_path / "s.svg"])
    root = ET.parse(tmp_path / "s.svg").getroot()
    legend = [e.text for e in root.iter(f"{SVG}text") if e.get("class") == "legend"][0]
    assert code == 0 and f"plot time {time}" in legend and f"travel {travel_m:.2f} m" in legend
    d = [e.get("d") for e in root.iter(f"{SVG}path") if e.get("class") == "travel"][0]
    seg = np.array([[q.split(",") for q in part.split(" L")] for part in d[1:].split(" M")],
                   float)
    view = render.preview([np.zeros((1, 2))], (0, 0), kinematics.from_config(cfg), cfg.page,
                          "", 1600).view
    grey_m = np.hypot(*(seg[:, 1] - seg[:, 0]).T).sum() / view.scale / 1000
    assert grey_m == pytest.approx(travel_m, abs=0.006)


def _dry_trace(capsys, config_path, tmp_path, gfile) -> Path:
    t = tmp_path / "t.csv"
    code, _, _ = run(capsys, ["--config", config_path, "draw", gfile, "--dry-run", "--trace", t])
    assert code == 0
    return t


def test_simulate_covers_the_drawing(capsys, config_path, tmp_path, cfg):
    """The dark pixels of simulate lie on the strokes of preview and cover them (the same view:
    page and anchors), and the legend's lengths agree with the estimate."""
    g = tmp_path / "in.ngc"
    g.write_bytes(TWO)
    t = _dry_trace(capsys, config_path, tmp_path, g)
    code, out, _ = run(capsys, ["--config", config_path, "simulate", t, "-o", tmp_path / "s.png",
                                "--size", "500"])
    assert code == 0 and "pen down 0.29 m" in out and "2 pen lifts" in out
    code, _, _ = run(capsys, ["--config", config_path, "preview", g, "-o", tmp_path / "p.png",
                              "--size", "500"])
    s = np.asarray(Image.open(tmp_path / "s.png").convert("RGB")).astype(int)
    sim = (s.min(axis=2) < 190) & (s.max(axis=2) - s.min(axis=2) < 25)       # dark grey
    a = np.asarray(Image.open(tmp_path / "p.png").convert("RGB")).astype(int)
    strokes = (a.max(axis=2) - a.min(axis=2)) > 60                           # coloured
    assert sim.shape == strokes.shape
    # dilate by 1 px each way and compare
    def grow(m):
        g = m.copy()
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                g |= np.roll(np.roll(m, dy, 0), dx, 1)
        return g
    # compare inside the page, away from its frame, its label and the origin's label
    view = render.preview([np.zeros((1, 2))], (0, 0), kinematics.from_config(cfg), cfg.page,
                          "", 500).view
    (x0, y0), (x1, y1) = np.rint(view.px([(cfg.page.x_min_mm, cfg.page.y_max_mm),
                                          (cfg.page.x_max_mm, cfg.page.y_min_mm)])).astype(int)
    inside = np.zeros_like(sim)
    inside[y0 + 20:y1 - 4, x0 + 4:x1 - 4] = True
    ox, oy = np.rint(view.px([(0, 0)])[0]).astype(int)
    inside[oy - 10:oy + 20, ox - 10:ox + 40] = False
    sim &= inside
    strokes &= inside
    assert strokes.sum() > 100
    assert (strokes & ~grow(sim)).sum() <= 0.02 * strokes.sum()
    assert (sim & ~grow(strokes)).sum() <= 0.02 * sim.sum()


def test_simulate_svg_and_at_shifts_the_drawing(capsys, config_path, tmp_path, cfg):
    """simulate writes SVG too; --at X Y moves the whole drawing by about that much."""
    t = _dry_trace(capsys, config_path, tmp_path, SAMPLES / "square.ngc")
    centres = []
    for extra in ([], ["--at", "50", "0"]):
        code, out, _ = run(capsys, ["--config", config_path, "simulate", t, "-o",
                                    tmp_path / "s.svg", *extra])
        assert code == 0
        root = ET.parse(tmp_path / "s.svg").getroot()
        down = [e for e in root.iter(f"{SVG}polyline") if e.get("class") == "down"]
        assert len(down) == 1                      # the square is one pen-down run
        p = np.array([q.split(",") for q in down[0].get("points").split()], float)
        centres.append((p.min(axis=0) + p.max(axis=0)) / 2)
    view = render.preview([np.zeros((1, 2))], (0, 0), kinematics.from_config(cfg), cfg.page,
                          "", 1600).view
    assert centres[0] == pytest.approx(view.px([(0, 0)])[0], abs=0.5)
    shift = (centres[1] - centres[0]) / view.scale
    assert shift == pytest.approx([50, 0], abs=3)


def test_simulate_at_moves_the_drawing_by_the_offset(capsys, config_path, tmp_path, cfg):
    t = _dry_trace(capsys, config_path, tmp_path, SAMPLES / "square.ngc")
    steps = trace.read_steps(str(t), cfg.motors, cfg.pen)
    kin = kinematics.from_config(cfg)

    def drawn(at):
        c0 = kin.inverse(kin.to_machine(np.array([at], float)))[0]
        xy = kin.to_gcode(kin.forward(c0 + steps.steps / np.asarray(cfg.motors.steps_per_unit)))
        return xy[steps.down]
    p0 = drawn((0, 0))
    assert np.abs(p0).max() == pytest.approx(30, abs=0.02)      # the 60 mm square
    p1 = drawn((50, 20))
    # the same steps from another start: roughly the square moved by the offset
    assert np.median(p1 - p0, axis=0) == pytest.approx([50, 20], abs=3)


SEED = config.load(str(Path(__file__).resolve().parent.parent / "config.toml"))


@settings(max_examples=40)
@given(st.lists(st.tuples(st.integers(-1, 1), st.integers(-1, 1), st.booleans()),
                min_size=1, max_size=60),
       st.integers(0, 7), st.integers(0, 7), st.booleans(), st.booleans(),
       st.sampled_from(sorted(TABLES)))
def test_read_steps_inverts_the_trace_writer(tmp_path_factory, moves, ph_l, ph_r, rev_l, rev_r,
                                             drive):
    """Random walks of both motors and the pen, written by the real TraceWriter, read back
    (full steps change two pins in one row: rows with equal t take effect together)."""
    from dataclasses import replace

    path = tmp_path_factory.mktemp("t") / "t.csv"
    base = SEED
    motors = replace(base.motors, left_reverse=rev_l, right_reverse=rev_r, drive=drive)
    sign = np.array([-1 if rev_l else 1, -1 if rev_r else 1])
    d = np.array([(a, b) for a, b, _ in moves])
    counts = np.vstack(([0, 0], np.cumsum(d, axis=0)))          # cord steps after each row
    phase = np.array([ph_l, ph_r]) + counts * sign
    pen = np.array([0] + [base.pen.down_us if down else base.pen.up_us for *_, down in moves])
    pen[::5] = 0                                                   # pulses off now and then
    n = len(counts)
    table = TABLES[drive]
    rows = Rows(np.arange(n, dtype=np.int64) * 1000, coil_words(table, phase[:, 0], phase[:, 1]),
                pen.astype(np.int32), np.zeros(n, np.int64), counts)
    with open(path, "w") as f:
        w = trace.TraceWriter(f, list(motors.left_pins) + list(motors.right_pins), base.pen.pin)
        w.write(rows[:1])
        w.write(rows[1:])
    got = trace.read_steps(str(path), motors, base.pen)
    t_us = np.rint(got.t_s * 1e6).astype(int)
    i = t_us // 1000
    assert np.array_equal(got.steps, counts[i])
    # the pen: the last nonzero width so far
    last = np.maximum.accumulate(np.where(pen != 0, np.arange(n), -1))
    want = np.where(last >= 0, pen[np.maximum(last, 0)] == base.pen.down_us, False)
    assert np.array_equal(got.down, want[i])


@pytest.mark.parametrize("content, what", [
    (None, "cannot read"),
    (b"G0 X0 Y0\n", "not a vplotter trace"),
    (b"# vplotter trace v1\nt,pin,value\n0.0,0,1\n0.0,zz,1\n", "not a trace v1 row"),
    (b"# vplotter trace v1\nt,pin,value\n", "no rows"),
    (b"# vplotter trace v1\nt,pin,value\n1.0,0,0\n0.5,0,1\n", "time goes backwards"),
    (b"# vplotter trace v1\nt,pin,value\n0.0,7,0\n", "pin 7 is not one of the config's pins"),
    (b"# vplotter trace v1\nt,pin,value\n0.0,0,0\n", "no rows for pin"),
    (GARBAGE, "not a vplotter trace"),
])
def test_simulate_errors(capsys, config_path, tmp_path, content, what):
    t = tmp_path / "t.csv"
    if content is not None:
        t.write_bytes(content)
    code, _, err = run(capsys, ["--config", config_path, "simulate", t, "-o", tmp_path / "s.png"])
    assert code == 2 and what in err and str(t) in err
    assert not (tmp_path / "s.png").exists()


def test_simulate_with_the_wrong_pins_or_drive(capsys, config_path, tmp_path):
    t = _dry_trace(capsys, config_path, tmp_path, SAMPLES / "square.ngc")
    seed = config_path.read_text()
    for change, what in [(("left_pins = [0, 5, 6, 13]", "left_pins = [1, 5, 6, 13]"),
                          "pin 0 is not one of the config's pins"),
                         (("left_pins = [0, 5, 6, 13]", "left_pins = [5, 0, 6, 13]"),
                          "not in the 8-step table"),
                         (('drive = "half"', 'drive = "full"'), "not in the 4-step table")]:
        c = tmp_path / "c.toml"
        c.write_text(seed.replace(*change))
        code, _, err = run(capsys, ["--config", c, "simulate", t, "-o", tmp_path / "s.png"])
        assert code == 2 and what in err


@pytest.mark.parametrize("argv, what", [
    (["preview", "{missing}", "-o", "{out}.png"], "nope.ngc: error:"),
    (["preview", "{garbage}", "-o", "{out}.png"], "error:"),
    (["preview", "{outside}", "-o", "{out}.png"], "outside the page"),
    (["preview", "{square}", "-o", "{out}.jpg"], "must be a .png or .svg"),
    (["preview", "{square}", "-o", "{out}.png", "--size", "5"], "--size must be"),
    (["preview", "{square}", "-o", "{tmp}/no/such/dir/p.png"], "cannot write"),
    (["preview", "{square}"], "required"),
    (["simulate", "{square}", "-o", "{out}.png", "--at", "0", "nan"], "--at"),
    (["simulate", "{square}", "-o", "{out}.png", "--at", "0", "500"], "not below the anchors"),
])
def test_preview_and_simulate_argument_errors(capsys, config_path, tmp_path, argv, what):
    (tmp_path / "g.ngc").write_bytes(GARBAGE)
    (tmp_path / "o.ngc").write_bytes(b"G0 X10 Y10\nM3\nG1 X500 Y0\nM5\n")
    names = {"missing": tmp_path / "nope.ngc", "garbage": tmp_path / "g.ngc",
             "outside": tmp_path / "o.ngc", "square": SAMPLES / "square.ngc",
             "out": tmp_path / "pic", "tmp": tmp_path}
    args = [a.format(**names) for a in argv]
    if what == "required":      # argparse's own usage error: exit 2, not ours to word
        assert run_usage(capsys, ["--config", str(config_path), *args]) == 2
        return
    code, _, err = run(capsys, ["--config", config_path, *args])
    assert code == 2 and what in err


def run_usage(capsys, argv) -> int:
    from vplotter.cli import main

    code = main(argv)
    _, err = capsys.readouterr()
    assert "Traceback" not in err
    return code


def test_help_imports_nothing_heavy():
    """`vplotter --help` and the pictures' own --help import neither Pillow nor numpy."""
    code = ("import sys; from vplotter.cli import main; rcs = [main(['--help']), "
            "main(['preview', '--help']), main(['simulate', '--help'])]; "
            "heavy = [m for m in ('numpy', 'PIL', 'gpiozero', 'lgpio') if m in sys.modules]; "
            "print(rcs, heavy)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[0, 0, 0] []"
    assert "preview" in out.stdout and "--at X Y" in out.stdout


def test_simulate_starts_at_the_stored_position(capsys, config_path, tmp_path, cfg):
    """Without --at the trace starts where the stored position says (a dry run leaves it)."""
    code, _, _ = run(capsys, ["--config", config_path, "calibrate", "--at", "30", "40"])
    assert code == 0
    t = _dry_trace(capsys, config_path, tmp_path, SAMPLES / "square.ngc")
    view = render.preview([np.zeros((1, 2))], (0, 0), kinematics.from_config(cfg), cfg.page,
                          "", 1600).view
    centres = []
    for extra in ([], ["--at", "0", "0"]):
        code, _, _ = run(capsys, ["--config", config_path, "simulate", t, "-o",
                                  tmp_path / "s.svg", *extra])
        root = ET.parse(tmp_path / "s.svg").getroot()
        down = [e for e in root.iter(f"{SVG}polyline") if e.get("class") == "down"][0]
        p = np.array([q.split(",") for q in down.get("points").split()], float)
        centres.append(((p.min(axis=0) + p.max(axis=0)) / 2 - view.px([(0, 0)])[0])
                       / view.scale * [1, -1])
    assert centres[0] == pytest.approx([0, 0], abs=0.05)           # the square where it is
    # from a wrong start the same steps draw elsewhere (and bent: the cords are not a grid)
    assert np.hypot(*centres[1]) > 40


@given(st.binary(max_size=300) | st.text(alphabet="0123456789.,-e#\n tpinvalu", max_size=300))
def test_read_steps_takes_anything_after_the_header(tmp_path_factory, body):
    """Whatever follows the header, the reader gives steps or one InputError, nothing else."""
    base = SEED
    path = tmp_path_factory.mktemp("t") / "t.csv"
    path.write_bytes(trace.HEADER.encode() + (body.encode() if isinstance(body, str) else body))
    try:
        got = trace.read_steps(str(path), base.motors, base.pen)
    except Exception as e:          # noqa: BLE001 - the property: only InputError
        assert type(e).__name__ == "InputError" and str(path) in str(e), repr(e)
    else:
        assert len(got.t_s) == len(got.steps) == len(got.down)


@given(st.tuples(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4)),
       st.tuples(st.floats(1e-3, 1e4), st.floats(1e-3, 1e4)), st.integers(100, 3000))
def test_view_fits_the_box_on_its_long_side(lo, span, size):
    legend = 30.0
    hi = (lo[0] + span[0], lo[1] + span[1])
    v = render.View.fit(lo, hi, size, legend)
    assert max(v.width_px, v.height_px) == size
    corners = v.px([lo, hi, (lo[0], hi[1]), (hi[0], lo[1])])
    assert corners[:, 0].min() >= v.margin_px - 0.51
    assert corners[:, 0].max() <= v.width_px - v.margin_px + 0.51
    assert corners[:, 1].min() >= v.margin_px - 0.51
    assert corners[:, 1].max() <= v.height_px - v.margin_px - legend + 0.51
    # +Y is up: the top edge of the box (hi Y) is above the bottom edge
    assert v.px([(lo[0], hi[1])])[0][1] < v.px([lo])[0][1]


def test_preview_draws_a_dot_where_the_pen_only_touches(capsys, config_path, tmp_path, cfg):
    """A pen down and up at one point (stipple art) is a dot in both PNG and SVG."""
    content = b"G0 X-100 Y100\nM3\nM5\nG0 X100 Y-100\nM3\nG1 X120 Y-100\nM5\n"
    code, out, _, _ = _preview(capsys, config_path, tmp_path, content=content, size=600)
    assert code == 0
    view = render.preview([np.zeros((1, 2))], (0, 0), kinematics.from_config(cfg), cfg.page,
                          "", 600).view
    img = Image.open(out)
    assert _inked(img, view.px([(-100, 100)])[0], r=0)
    assert not _inked(img, view.px([(-100, 104)])[0], r=1)
    code, out, _, _ = _preview(capsys, config_path, tmp_path, content=content, out="p.svg")
    dots = [e for e in ET.parse(out).getroot().iter(f"{SVG}polyline")
            if e.get("class") == "stroke"]
    first = np.array([q.split(",") for q in dots[0].get("points").split()], float)
    assert len(dots) == 2 and np.ptp(first, axis=0).max() == 0 and len(first) == 2


def _svg_strokes(path) -> list[np.ndarray]:
    return [np.array([q.split(",") for q in e.get("points").split()], float)
            for e in ET.parse(path).getroot().iter(f"{SVG}polyline") if e.get("class") == "stroke"]


def test_preview_shows_the_placed_and_ordered_drawing(capsys, config_path, tmp_path, cfg):
    """Placement and order options (prepare.py) change the picture as they change the draw."""
    far_first = (b"G0 X100 Y200\nM3\nG1 X150 Y200\nM5\n"      # far from the pen: first in file
                 b"G0 X10 Y10\nM3\nG1 X20 Y10\nM5\n")
    view = render.preview([np.zeros((1, 2))], (0, 0), kinematics.from_config(cfg), cfg.page,
                          "", 500).view
    keep = _preview(capsys, config_path, tmp_path, far_first, "k.svg", 500)   # G-code: keep
    assert keep[0] == 0
    code, _, _ = run(capsys, ["--config", config_path, "preview", tmp_path / "in.ngc", "-o",
                              tmp_path / "g.svg", "--size", "500", "--order", "greedy"])
    assert code == 0
    first_keep, first_greedy = _svg_strokes(keep[1])[0], _svg_strokes(tmp_path / "g.svg")[0]
    assert first_keep[:, 0].min() == pytest.approx(view.px([(100, 200)])[0][0], abs=0.01)
    assert first_greedy[:, 0].min() == pytest.approx(view.px([(10, 10)])[0][0], abs=0.01)
    code, _, _ = run(capsys, ["--config", config_path, "preview", tmp_path / "in.ngc", "-o",
                              tmp_path / "o.svg", "--size", "500", "--offset", "-50", "-30"])
    moved = _svg_strokes(tmp_path / "o.svg")[0]
    shift = (moved.min(axis=0) - first_keep.min(axis=0)) / view.scale * [1, -1]
    assert code == 0 and shift == pytest.approx([-50, -30], abs=0.01)


def test_simulate_refuses_what_it_cannot_decode_yet(capsys, config_path, tmp_path):
    """A step/dir machine's trace is not coil patterns: one line, exit 2 (not a wrong picture)."""
    from support.stepdir import stepdir_toml

    c = tmp_path / "sd.toml"
    c.write_text(stepdir_toml(config_path), encoding="utf-8")
    t = _dry_trace(capsys, c, tmp_path, SAMPLES / "square.ngc")
    code, _, err = run(capsys, ["--config", c, "simulate", t, "-o", tmp_path / "s.png"])
    assert code == 2 and 'driver = "stepdir"' in err
