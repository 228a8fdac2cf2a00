"""The polar plotter: kinematics properties, drawings around and across the table's centre
decoded independently (tracecheck: STEP edges with their DIR level, polar forward kinematics),
turns in place at the pole, the shorter way round, reach, home, calibrate, status."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st

from support import tracecheck as tc
from vplotter import config
from vplotter.machine import state
from vplotter.cli import main
from vplotter.kinematics.polar import Polar

from support import REPO

POLAR = REPO / "examples" / "polar.toml"
SAMPLES = sorted((REPO / "gcode_samples" / "polar").glob("*.ngc"))
coord = st.floats(-60, 60, allow_nan=False)


def polar_cfg(tmp_path, **changes) -> str:
    """examples/polar.toml with some [polar] values changed."""
    text = POLAR.read_text(encoding="utf-8")
    for key, value in changes.items():
        lines = text.splitlines()
        text = "\n".join(f"{key} = {value}" if ln.startswith(f"{key} ") else ln for ln in lines) + "\n"
    p = tmp_path / "polar.toml"
    p.write_text(text, encoding="utf-8")
    return str(p)


def draw(cfg_path, gfile, trace, at=("0", "0")):
    assert main(["--config", str(cfg_path), "calibrate", "--at", *at]) == 0
    return main(["--config", str(cfg_path), "draw", str(gfile), "--dry-run", "--trace", str(trace)])


def gfile(tmp_path, text: str):
    p = tmp_path / "g.ngc"
    p.write_text("G21 G90\n" + text.strip() + "\n", encoding="utf-8")
    return p


# ------------------------------------------------------------------ kinematics
KIN = Polar(3.0, -2.0, 30.0, 0.0, 65.0)


@given(coord, coord)
def test_forward_inverts_inverse(x, y):
    xy = np.array([[x, y]])
    q = KIN.inverse(xy)
    assert -180 < q[0, 0] <= 180
    # (within 0.1 um of the centre the angle is 0: the pen is over the centre at any angle)
    assert np.allclose(KIN.forward(q), xy, atol=1e-9 if math.hypot(x, y) >= 1e-4 else 2e-4)
    # the paper point at polar angle p lies under the arm when a = arm - p (at the centre: 0)
    p = math.degrees(math.atan2(y, x))
    want = 30.0 - p if math.hypot(x, y) > 1e-4 else 0.0
    assert abs((q[0, 0] - want + 180) % 360 - 180) < 1e-9


@given(coord, coord, st.floats(0, 2 * math.pi), st.floats(0.1, 80), st.floats(0.05, 0.95))
def test_crossing_finds_where_a_motor_reaches_a_value(x0, y0, ang, d, f):
    p0 = np.array([x0, y0])
    e = np.array([math.cos(ang), math.sin(ang)])
    if p0 @ e < 0:
        e = -e                                         # moving away from the foot: monotonic
    h = abs(x0 * e[1] - y0 * e[0])
    assume(h > 0.05)
    p1 = p0 + d * e
    q = KIN.path(np.array([p0, p1]), KIN.inverse(p0[None, :])[0])[1]
    for m in (0, 1):
        target = q[0, m] + f * (q[1, m] - q[0, m])
        s = KIN.crossing(p0[None, :], e[None, :], m, np.array([0]), np.array([target]),
                         np.array([q[1, m] > q[0, m]]))[0]
        at = KIN.path(np.array([p0, p0 + s * e]), q[0])[1][1, m]
        assert 0 <= s <= d + 1e-9 and abs(at - target) < 1e-7


@given(coord, coord, st.floats(0, 2 * math.pi))
def test_slope_and_bend_are_the_derivatives(x, y, ang):
    xy = np.array([[x, y]])
    assume(np.hypot(x, y) > 1.0)
    e = np.array([[math.cos(ang), math.sin(ang)]])
    h = 1e-4
    q = KIN.path(xy + np.array([-h, 0.0, h])[:, None] * e, KIN.inverse(xy)[0])[1]
    assert np.allclose(KIN.slope(xy, e)[0], (q[2] - q[0]) / (2 * h), rtol=1e-5, atol=1e-5)
    assert np.allclose(np.abs(KIN.bend(xy, e)[0]), np.abs(q[2] - 2 * q[1] + q[0]) / h ** 2,
                       rtol=1e-3, atol=1e-2)


def test_the_angle_unwraps_the_shorter_way_and_keeps_counting():
    kin = Polar(0.0, 0.0, 0.0, 0.0, 65.0)
    # 45 degrees to 315 degrees on the paper: the table turns by 90, not 270
    pts = 10 * np.array([[math.cos(math.radians(a)), math.sin(math.radians(a))] for a in (45, 315)])
    q = kin.path(pts, (-45.0, 10.0))[1]
    assert q[1, 0] - q[0, 0] == pytest.approx(90.0)
    # twice round the centre: 720 degrees one way, no jump at +-180
    ang = np.radians(np.linspace(0, 720, 97))
    circle = 20 * np.column_stack((np.cos(ang), np.sin(ang)))
    q = kin.path(circle, (0.0, 20.0))[1]
    assert q[-1, 0] == pytest.approx(-720.0) and (np.abs(np.diff(q[:, 0])) < 10).all()
    # through the centre: half a turn there, with the pen standing at the centre
    q_in, q_out = kin.path(np.array([[-10.0, 0], [0, 0], [10.0, 0]]), (180.0, 10.0))
    assert q_in[1].tolist() == [180.0, 0.0] and abs(q_out[1, 0] - q_in[1, 0]) == 180.0
    # an arm that passes over the centre goes on with a negative radius instead
    over = Polar(0.0, 0.0, 0.0, -20.0, 65.0)
    q_in, q_out = over.path(np.array([[-10.0, 0], [0, 0], [10.0, 0]]), (180.0, 10.0))
    assert (q_in == q_out).all() and q_out[:, 0].tolist() == [180.0] * 3
    assert q_out[2, 1] == -10.0


# ------------------------------------------------------------------ drawings, decoded
@pytest.mark.parametrize("g", SAMPLES, ids=[p.name for p in SAMPLES])
def test_polar_samples_draw_the_gcode_path(g, tmp_path, capsys):
    trace = tmp_path / "t.csv"
    assert draw(POLAR, g, trace) == 0
    cfg = tc.load_config(POLAR)
    tr = tc.read_trace(trace)
    # STEP edges with their DIR level -> angle and radius -> forward kinematics: within 0.02 mm
    # of the G-code path both ways; DIR set-up, pulse widths, ENABLE low while stepping and high
    # at the end; step rate and acceleration; pen points on the tool path; the shorter way round
    assert tc.verify(tr, g, cfg, tol_mm=0.02) == []
    out = capsys.readouterr().out
    said = float(out.split("(")[-1].split(" s)")[0])
    assert abs(said - tc.plot_time(tr)) <= 0.05 + 0.001 * said


HELD_OUT = {
    "through the centre": "G0 X-30 Y5\nM3\nG1 X30 Y-5 F600\nG1 X-20 Y-20\nG1 X20 Y20\nM5",
    "near misses": "G0 X-30 Y0.001\nM3\nG1 X30 Y0.001 F600\nG1 X30 Y-0.02\nG1 X-30 Y0.02\nM5",
    "corner at the centre": "G0 X0 Y25\nM3\nG1 X0 Y0 F600\nG1 X25 Y0\nG1 X0 Y0\nG1 X-25 Y-1\nM5",
    "arcs around": "G0 X5 Y0\nM3\nG3 X-5 Y0 I-5 J0 F600\nG3 X5 Y0 I5 J0\nG2 X60 Y0 I27.5 J0\nM5",
    "off centre start": "G0 X40 Y40\nM3\nG1 X-40 Y-40 F600\nM5\nG0 X0 Y0",
}


@pytest.mark.parametrize("name", HELD_OUT)
def test_drawings_around_and_across_the_pole(name, tmp_path):
    g = gfile(tmp_path, HELD_OUT[name])
    trace = tmp_path / "t.csv"
    assert draw(POLAR, g, trace, at=("10", "-3")) == 0
    assert tc.verify(tc.read_trace(trace), g, tc.load_config(POLAR), start_xy=(10, -3)) == []


def test_a_line_through_the_centre_turns_the_table_half_round_there(tmp_path):
    g = gfile(tmp_path, "G0 X-20 Y0\nM3\nG1 X20 Y0 F600\nM5")
    trace = tmp_path / "t.csv"
    assert draw(POLAR, g, trace, at=("-20", "0")) == 0
    cfg = tc.load_config(POLAR)
    dec = tc.decode(tc.read_trace(trace), cfg, (-20, 0))
    rot, lin = dec.steps["rotary"], dec.steps["linear"]
    assert len(rot) == 180 * 80 and abs(rot.dirs.sum()) == 180 * 80   # half a turn, one way
    # ... while the pen stands at the centre (no linear step meanwhile)
    inside = (lin.t_us > rot.t_us[0]) & (lin.t_us < rot.t_us[-1])
    assert not inside.any()
    at = np.searchsorted(dec.t, rot.times)
    assert np.hypot(dec.x[at], dec.y[at]).max() < 0.01


def test_an_arm_over_the_centre_does_not_turn(tmp_path):
    cfg_path = polar_cfg(tmp_path, radius_min_mm="-30.0")
    g = gfile(tmp_path, "G0 X20 Y0\nM3\nG1 X-20 Y0 F600\nM5")
    trace = tmp_path / "t.csv"
    assert draw(cfg_path, g, trace, at=("20", "0")) == 0
    cfg = tc.load_config(cfg_path)
    tr = tc.read_trace(trace)
    assert tc.verify(tr, g, cfg, start_xy=(20, 0)) == []
    dec = tc.decode(tr, cfg, (20, 0))
    assert len(dec.steps["rotary"]) == 0
    assert dec.right_mm.min() == pytest.approx(-20, abs=0.01)        # the radius went negative


def test_the_rotation_check_catches_a_needless_turn():
    """A hand-made trace: the pen stays at the centre while the table spins once round."""
    c = tc.load_config(POLAR)
    rows = [(0, p, v) for p, v in ((17, 0), (27, 0), (22, 0), (23, 0), (4, 1), (24, 500))]
    rows += [(1000, 4, 0), (1500, 27, 1)]
    t = 2000
    for _ in range(360 * 80):
        rows += [(t, 17, 1), (t + 2, 17, 0)]
        t += 300
    rows += [(t, 4, 1)]
    tr = tc.Trace(np.array([r[0] for r in rows]) / 1e6, np.array([r[0] for r in rows]),
                  np.array([r[1] for r in rows]), np.array([r[2] for r in rows]))
    probs = tc.verify(tr, "G21\nG0 X0 Y0\n", c, check_accel=False)
    assert any(p.startswith("[rotation]") for p in probs)
    assert not any(p.startswith("[travel]") or p.startswith("[stepdir]") for p in probs)


def test_points_out_of_reach_are_refused_before_anything_moves(tmp_path, capsys):
    assert main(["--config", str(POLAR), "calibrate", "--at", "0", "0"]) == 0
    g = gfile(tmp_path, "G0 X10 Y10\nG1 X60 Y40\n")
    assert main(["--config", str(POLAR), "draw", str(g), "--backend", "fake"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{g}:3:1: error: the pen cannot reach X60.000 Y40.000" in err[0]
    # an arm that does not reach the centre: a line passing too close is refused too
    cfg_path = polar_cfg(tmp_path, radius_min_mm="5.0")
    assert main(["--config", cfg_path, "calibrate", "--at", "20", "0"]) == 0
    g = gfile(tmp_path, "G0 X-20 Y1\n")
    assert main(["--config", cfg_path, "draw", str(g), "--backend", "fake"]) == 2
    assert "or the line to it" in capsys.readouterr().err
    assert state.load().counts == (0, 0)


def test_polar_config_keys(tmp_path):
    import tomllib

    data = tomllib.loads(POLAR.read_text())
    cfg = config.from_dict(data)
    assert cfg.machine.kind == "polar" and cfg.motors.names == ("rotary", "linear")
    assert cfg.motors.steps_per_unit == (80.0, 152.96)
    assert (cfg.page.x_min_mm, cfg.page.x_max_mm) == (-65.0, 65.0)   # around the table's reach
    for section, key, value, message in [
        ("machine", "anchor_distance_mm", 400.0, 'is only for machine kind = "vplotter"'),
        ("motors", "steps_per_rev", 200, 'is only for machine kind = "vplotter"'),
        ("motors", "left_step_pin", 5, 'is only for machine kind = "vplotter"'),
        ("polar", "radius_min_mm", 70.0, "radius_min_mm must be below radius_max_mm"),
        ("polar", "centre_z_mm", 1.0, "unknown key [polar] centre_z_mm"),
    ]:
        bad = json.loads(json.dumps(data))
        bad[section][key] = value
        with pytest.raises(config.ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
            config.from_dict(bad)
    bad = json.loads(json.dumps(data))
    bad["origin"] = {"x_mm": 0.0, "y_mm": 1.0}
    with pytest.raises(config.ConfigError, match=r'\[origin\] is only for machine kind = "vplotter"'):
        config.from_dict(bad)
    del data["motors"]["rotary_steps_per_deg"]
    with pytest.raises(config.ConfigError, match=r"\[motors\] rotary_steps_per_deg is missing"):
        config.from_dict(data)


# ------------------------------------------------------------------ home, calibrate, status
def test_home_finds_the_switch_and_sets_angle_zero(tmp_path, capsys):
    trace = tmp_path / "h.csv"
    assert main(["--config", str(POLAR), "home", "--backend", "fake", "--trace", str(trace)]) == 0
    assert "table angle 0, pen at radius 63.99" in capsys.readouterr().out
    pos = state.load()
    assert pos.left_mm == 0.0 and pos.right_mm == pytest.approx(64.0, abs=0.01)
    assert pos.extra["machine"] == "polar"
    # the search moved only the linear axis, outwards, then back 2 mm
    dec = tc.decode(tc.read_trace(trace), tc.load_config(POLAR), start_q=(0.0, 0.0))
    assert len(dec.steps["rotary"]) == 0
    lin = dec.steps["linear"].dirs
    assert (lin[:-306] == 1).all() and (lin[-306:] == -1).all()
    assert main(["--config", str(POLAR), "status"]) == 0
    assert "table 0.000 deg" in capsys.readouterr().out
    assert main(["--config", str(POLAR), "goto", "10", "10", "--backend", "fake"]) == 0
    assert state.load().left_mm == pytest.approx(-45.0, abs=0.02)


def test_calibrate_jog_and_a_stored_position_of_another_machine(tmp_path, capsys, config_path):
    assert main(["--config", str(POLAR), "calibrate", "--cords", "0", "20"]) == 0
    assert "pen at X20.000 Y0.000" in capsys.readouterr().out
    assert main(["--config", str(POLAR), "jog", "--dx", "-40", "--backend", "fake"]) == 0
    pos = state.load()
    assert pos.right_mm == pytest.approx(20, abs=0.01) and abs(pos.left_mm) == pytest.approx(180)
    assert main(["--config", str(POLAR), "calibrate", "--cords", "0", "80"]) == 2
    assert "cannot be 80 mm from the table's centre" in capsys.readouterr().err
    # a V-plotter config does not take the polar machine's position for cords
    assert main(["--config", str(config_path), "goto", "0", "0", "--backend", "fake"]) == 2
    assert "stored position is of a polar machine" in capsys.readouterr().err


def test_jog_by_motor_and_resume_after_ctrl_c(tmp_path, capsys, monkeypatch):
    import signal

    from support.signals import interrupt_after

    assert main(["--config", str(POLAR), "calibrate", "--at", "0", "0"]) == 0
    g = REPO / "gcode_samples" / "polar" / "pole.ngc"
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    orig = interrupt_after(monkeypatch, 150_000, signal.SIGINT)
    assert main(["--config", str(POLAR), "draw", str(g), "--backend", "fake", "--trace", str(first)]) == 130
    stopped = state.load()
    assert stopped.clean and stopped.extra["resume"]["line"] > 0
    monkeypatch.setattr("vplotter.backends.fake.FakeBackend.play", orig)
    assert main(["--config", str(POLAR), "draw", str(g), "--resume", "--backend", "fake",
                 "--trace", str(second)]) == 0
    cfg = tc.load_config(POLAR)
    a = tc.decode(tc.read_trace(first), cfg, (0, 0))
    b = tc.decode(tc.read_trace(second), cfg, start_q=(stopped.left_mm, stopped.right_mm))
    # the position stored at the stop is where the trace left the motors, to the step
    assert (a.left_mm[-1], a.right_mm[-1]) == pytest.approx((stopped.left_mm, stopped.right_mm), abs=1e-9)
    # both parts together draw the whole file
    drawn = tc.drawn_polylines(a) + tc.drawn_polylines(b)
    ref = tc.reference_path(g)
    far = tc.distances_to_polylines(np.concatenate([tc._densify(p, 0.005) for p in ref]), drawn)
    assert far.max() < 0.02
    # jog the motors themselves: --left turns the table by degrees, --right moves the arm by mm
    before = state.load()
    assert main(["--config", str(POLAR), "jog", "--left", "90", "--right", "3", "--backend", "fake"]) == 0
    after = state.load()
    assert after.left_mm - before.left_mm == pytest.approx(90, abs=0.02)
    assert after.right_mm - before.right_mm == pytest.approx(3, abs=0.01)
    assert main(["--config", str(POLAR), "jog", "--right", "500", "--backend", "fake"]) == 2
    assert "does not reach" in capsys.readouterr().err


def test_calibrate_at_the_centre_is_angle_zero(tmp_path, capsys):
    cfg_path = polar_cfg(tmp_path, arm_angle_deg="90.0", centre_x_mm="5.0")
    assert main(["--config", cfg_path, "calibrate", "--at", "5", "0"]) == 0
    pos = state.load()
    assert (pos.left_mm, pos.right_mm) == (0.0, 0.0)
    g = gfile(tmp_path, "G0 X5 Y20\nM3\nG1 X25 Y0 F600\nG1 X5 Y0\nG1 X-15 Y0\nM5")
    trace = tmp_path / "t.csv"
    assert draw(cfg_path, g, trace, at=("5", "0")) == 0
    cfg = tc.load_config(cfg_path)
    assert tc.verify(tc.read_trace(trace), g, cfg, start_xy=(5, 0)) == []
    dec = tc.decode(tc.read_trace(trace), cfg, (5, 0))
    # the paper point X5 Y20 is under the arm (pointing +Y) with the table at 0: no turn first
    first = dec.steps["rotary"].t_us
    assert len(first) == 0 or first[0] > dec.steps["linear"].t_us[0]


@st.composite
def strokes_near_the_pole(draw_):
    """A pen-down polyline whose lines pass through or close by the table's centre."""
    pts = []
    for _ in range(draw_(st.integers(2, 4))):
        ang = draw_(st.floats(0, 2 * math.pi))
        r = draw_(st.floats(2, 40))
        miss = draw_(st.sampled_from([0.0, 0.0, 1e-3, 0.02, 0.5]))
        a = np.array([math.cos(ang), math.sin(ang)])
        n = np.array([-a[1], a[0]]) * miss
        pts += [(r * a + n).tolist(), (-r * 0.7 * a + n).tolist()]
    return pts


@settings(max_examples=8)
@given(strokes_near_the_pole())
def test_random_strokes_across_the_pole(pts):
    """Property: lines through and close by the centre, decoded independently, stay within
    0.02 mm of the path both ways, within the limits, turning the shorter way."""
    import io
    import tempfile

    from vplotter import kinematics, pipeline
    from vplotter.inputs import gcode as gc
    from vplotter.machine.trace import TraceWriter

    cfg = config.load(POLAR)
    text = "G21 G90\n" + f"G0 X{pts[0][0]:.4f} Y{pts[0][1]:.4f}\nM3\n" + "".join(
        f"G1 X{x:.4f} Y{y:.4f} F600\n" for x, y in pts[1:]) + "M5\n"
    with tempfile.TemporaryDirectory() as d:
        g = f"{d}/g.ngc"
        with open(g, "w") as f:
            f.write(text)
        kin = kinematics.from_config(cfg)
        q = kin.inverse(kin.to_machine(np.array([[0.0, 0.0]])))[0]
        buf = io.StringIO()
        w = TraceWriter(buf, cfg.motors.out_pins, cfg.pen.pin)
        for rows in pipeline.stream(cfg, gc.read(g), (0, 0), q, g):
            w.write(rows)
        with open(f"{d}/t.csv", "w") as f:
            f.write(buf.getvalue())
        probs = tc.verify(tc.read_trace(f"{d}/t.csv"), g, tc.load_config(POLAR))
    assert probs == []


# ------------------------------------------------------------------ placement in reach
def test_a_photo_and_a_fitted_svg_fill_the_disc_the_arm_reaches(tmp_path, capsys):
    """Without --width a photo is the largest inside the reach (not the square around it),
    and --fit puts an SVG there too: every pen-down point within radius_max_mm."""
    from PIL import Image

    photo = tmp_path / "p.png"
    g = np.linspace(0, 255, 160, dtype=np.uint8)[None, :].repeat(120, 0)
    Image.fromarray(g).save(photo)
    out = tmp_path / "p.ngc"
    cfg = str(POLAR)
    assert main(["--config", cfg, "convert", str(photo), "-o", str(out), "--style", "hatch",
                 "--max-time", "10m"]) == 0
    err = capsys.readouterr().err
    assert "photo: hatch, 104 x 78 mm" in err                 # 130 mm across: 4:3 in the disc
    pts = np.concatenate(tc.reference_path(str(out)))
    assert np.hypot(pts[:, 0], pts[:, 1]).max() <= 65 + 1e-6
    svg = tmp_path / "s.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="200mm" height="100mm" '
                   'viewBox="0 0 200 100"><rect x="0" y="0" width="200" height="100" '
                   'fill="none" stroke="black"/></svg>')
    out2 = tmp_path / "s.ngc"
    assert main(["--config", cfg, "convert", str(svg), "-o", str(out2), "--fit"]) == 0
    pts = np.concatenate(tc.reference_path(str(out2)))
    r = np.hypot(pts[:, 0], pts[:, 1])
    assert r.max() <= 65 and r.max() > 64.99                      # its corners on the circle
    assert main(["--config", cfg, "estimate", str(out2)]) == 0    # and the file draws as written


def test_a_photo_too_big_for_the_reach_is_one_line(tmp_path, capsys):
    from PIL import Image

    photo = tmp_path / "p.png"
    Image.new("L", (40, 30), 90).save(photo)
    code = main(["--config", str(POLAR), "convert", str(photo), "-o", str(tmp_path / "o.ngc"),
                 "--width", "120", "--max-time", "10m"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and "Traceback" not in "".join(err)
    assert "the picture (120 x 90 mm) reaches" in err[-1] and "within 65 mm of X0 Y0" in err[-1]
