"""Tests of the independent trace checker (tests/support/tracecheck/) itself.

All traces here are synthetic and built in the tests; nothing from the
vplotter package is used.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from support import tracecheck as tc

CFG = tc.load_config(None)
SPM = 4096 / 25.0                    # 163.84 steps per mm of cord
HALF = [int(p, 2) for p in tc.SEQUENCES["half"]]


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------

class TraceBuilder:
    """Writes synthetic traces row by row (times in integer microseconds)."""

    def __init__(self, cfg=None, initial=None, pen_us=500):
        self.cfg = tc.merge_config(cfg)
        m = self.cfg["motors"]
        self.pins = {"left": list(m["left_pins"]), "right": list(m["right_pins"])}
        self.pen_pin = self.cfg["pen"]["pin"]
        self.seq = [int(p, 2) for p in tc.SEQUENCES[m["drive"]]]
        self.rows: list[tuple[int, int, int]] = []
        self.code = {}
        self.phase = {}
        initial = initial or {"left": self.seq[0], "right": self.seq[0]}
        for motor in ("left", "right"):
            self.code[motor] = initial[motor]
            self.phase[motor] = self.seq.index(initial[motor]) if initial[motor] in self.seq else None
            for bit, p in enumerate(self.pins[motor]):
                self.rows.append((0, p, (initial[motor] >> (3 - bit)) & 1))
        self.rows.append((0, self.pen_pin, pen_us))

    def pattern(self, t_us, motor, code):
        """Set a motor's four pins to ``code`` at one instant (only changed pins written)."""
        old = self.code[motor]
        for bit, p in enumerate(self.pins[motor]):
            b = (code >> (3 - bit)) & 1
            if b != (old >> (3 - bit)) & 1:
                self.rows.append((t_us, p, b))
        self.code[motor] = code

    def step(self, t_us, motor, seq_dir):
        self.phase[motor] = (self.phase[motor] + seq_dir) % len(self.seq)
        self.pattern(t_us, motor, self.seq[self.phase[motor]])

    def pen(self, t_us, us):
        self.rows.append((t_us, self.pen_pin, us))

    def release(self, t_us):
        for motor in ("left", "right"):
            self.pattern(t_us, motor, 0)
        self.pen(t_us, 0)

    def write(self, path, comments=True):
        with open(path, "w") as fh:
            fh.write("# vplotter trace v1\n")
            if comments:
                fh.write("# synthetic\n")
            fh.write("t,pin,value\n")
            for i, (t, p, v) in enumerate(self.rows):
                if comments and i == 3:
                    fh.write("# a comment in the middle\n")
                fh.write(f"{t / 1e6:.6f},{p},{v}\n")
        return path


def _decoded_from_points(points, pen_down=True):
    pts = np.asarray(points, float)
    return tc.Decoded(t=np.arange(len(pts)) * 0.01, x=pts[:, 0], y=pts[:, 1],
                      pen_down=np.full(len(pts), pen_down))


def simulate(parts, cfg=None, start=(0.0, 0.0), dt_us=2000, settle_us=300_000):
    """A tiny independent 'driver': follow ``parts`` = [(pen_down, points)], rounding
    each cord to the nearest step, one step per motor per instant, constant rate."""
    b = TraceBuilder(cfg)
    c = b.cfg
    L0, R0 = (float(v) for v in tc.inverse_kinematics(c, *start))
    n = {"left": 0, "right": 0}
    t = 0
    pen = False
    pos = np.array(start, float)
    rev = {m: c["motors"][f"{m}_reverse"] for m in ("left", "right")}
    for down, pts in parts:
        if down != pen:
            t += dt_us
            b.pen(t, c["pen"]["down_us"] if down else c["pen"]["up_us"])
            t += settle_us
            pen = down
        for p in np.asarray(pts, float):
            seg = tc._sample_line(pos, p, 0.001)
            L, R = tc.inverse_kinematics(c, seg[:, 0], seg[:, 1])
            tl = np.rint((L - L0) * SPM).astype(int)
            tr = np.rint((R - R0) * SPM).astype(int)
            keep = np.ones(len(tl), bool)
            keep[1:] = (tl[1:] != tl[:-1]) | (tr[1:] != tr[:-1])
            for a, bb in zip(tl[keep].tolist(), tr[keep].tolist()):
                target = {"left": a, "right": bb}
                while target != n:
                    t += dt_us
                    for m in ("left", "right"):
                        if target[m] != n[m]:
                            d = 1 if target[m] > n[m] else -1
                            b.step(t, m, -d if rev[m] else d)
                            n[m] += d
            pos = p
    t += dt_us
    b.pen(t, c["pen"]["up_us"])
    t += settle_us
    b.release(t)
    return b


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------

def test_read_trace_skips_comments_and_checks_header(tmp_path):
    b = TraceBuilder()
    b.step(2000, "left", +1)
    path = b.write(tmp_path / "a.csv")
    tr = tc.read_trace(path)
    assert len(tr) == len(b.rows)
    assert tr.t_us.tolist() == [r[0] for r in b.rows]
    assert tr.pin.tolist() == [r[1] for r in b.rows]
    assert tc.format_problems(tr, CFG) == []
    assert tc.plot_time(tr) == pytest.approx(0.002)

    bad = tmp_path / "bad.csv"
    bad.write_text("t,pin,value\n0.000000,0,0\n")
    with pytest.raises(tc.TraceFormatError):
        tc.read_trace(bad)
    bad.write_text("# vplotter trace v1\n0.000000,0,0\n")
    with pytest.raises(tc.TraceFormatError):
        tc.read_trace(bad)


def test_format_problems_missing_initial_pin(tmp_path):
    b = TraceBuilder()
    b.rows = [r for r in b.rows if r[1] != 13]
    tr = tc.read_trace(b.write(tmp_path / "a.csv"))
    probs = tc.format_problems(tr, CFG)
    assert any("13" in p for p in probs)


# ---------------------------------------------------------------------------
# decoding
# ---------------------------------------------------------------------------

def test_eight_forward_half_steps_left_shorten_cord(tmp_path):
    b = TraceBuilder()
    for i in range(8):
        b.step(2000 * (i + 1), "left", +1)
    dec = tc.decode(tc.read_trace(b.write(tmp_path / "a.csv")), CFG)
    st = dec.steps["left"]
    assert len(st) == 8 and len(dec.steps["right"]) == 0
    assert st.seq_dirs.tolist() == [1] * 8
    assert st.dirs.tolist() == [-1] * 8             # left_reverse = true: forward shortens
    assert np.allclose(st.times, 0.002 * np.arange(1, 9))
    L0, R0 = dec.start_cords
    assert dec.left_mm[-1] - L0 == pytest.approx(-8 / 163.84, abs=1e-12)
    assert dec.right_mm[-1] == pytest.approx(R0, abs=1e-12)
    assert tc.illegal_transitions(dec) == []
    assert tc.min_step_interval(dec)["left"] == pytest.approx(0.002)
    assert tc.min_step_interval(dec)["right"] == math.inf
    assert tc.check_step_rate(dec, 663) == []
    assert tc.check_step_rate(dec, 500) == []       # exactly at the limit is fine
    assert len(tc.check_step_rate(dec, 400)) == 1   # a stricter limit (2.5 ms) fails
    # start point is the G-code origin, and positions follow the forward kinematics
    assert dec.x[0] == pytest.approx(0.0, abs=1e-9) and dec.y[0] == pytest.approx(0.0, abs=1e-9)
    X, Y = tc.forward_kinematics(CFG, dec.left_mm[-1], dec.right_mm[-1])
    assert (dec.x[-1], dec.y[-1]) == (X, Y)
    # shortening the left cord moves the pen up and to the left
    assert dec.x[-1] < 0 and dec.y[-1] > 0


def test_right_forward_lengthens_and_backward_shortens(tmp_path):
    b = TraceBuilder()
    for i in range(5):
        b.step(2000 * (i + 1), "right", +1)
    for i in range(2):
        b.step(20000 + 2000 * i, "right", -1)
    dec = tc.decode(b.write(tmp_path / "a.csv"), CFG, start_xy=(10.0, -20.0))
    assert dec.steps["right"].dirs.tolist() == [1] * 5 + [-1] * 2
    assert dec.right_mm[-1] - dec.start_cords[1] == pytest.approx(3 / SPM, abs=1e-12)
    assert (dec.x[0], dec.y[0]) == pytest.approx((10.0, -20.0), abs=1e-9)


def test_load_config_merges_defaults(tmp_path):
    text = "[motors]\ndrive = 'wave'\nleft_pins = [1, 2, 3, 4]\n[pen]\nsettle_s = 0.5\n"
    (tmp_path / "c.toml").write_text(text)
    for src in (text, str(tmp_path / "c.toml"), tmp_path / "c.toml"):
        c = tc.load_config(src)
        assert c["motors"]["drive"] == "wave" and c["motors"]["left_pins"] == [1, 2, 3, 4]
        assert c["motors"]["max_accel"] == 2000 and c["pen"]["settle_s"] == 0.5
        assert c["pen"]["down_us"] == 1500 and c["origin"]["y_mm"] == 430.0
    assert tc.steps_per_mm(CFG) == pytest.approx(163.84)


def test_kinematics_roundtrip():
    X = np.array([-200.0, 0.0, 150.0, 3.3])
    Y = np.array([-250.0, 0.0, 300.0, -7.1])
    L, R = tc.inverse_kinematics(CFG, X, Y)
    X2, Y2 = tc.forward_kinematics(CFG, L, R)
    assert np.allclose(X2, X, atol=1e-9) and np.allclose(Y2, Y, atol=1e-9)
    L, R = tc.inverse_kinematics(CFG, 0.0, 0.0)
    assert float(L) == pytest.approx(math.hypot(211.25, 430.0))
    assert float(R) == pytest.approx(math.hypot(422.5 - 211.25, 430.0))


def test_full_drive_needs_simultaneous_pin_changes(tmp_path):
    cfg = {"motors": {"drive": "full"}}
    b = TraceBuilder(cfg)
    b.step(2000, "left", +1)                      # 1100 -> 0110: two pins, same t
    b.step(4000, "left", +1)
    dec = tc.decode(b.write(tmp_path / "ok.csv"), cfg)
    assert tc.illegal_transitions(dec) == [] and len(dec.steps["left"]) == 2

    b = TraceBuilder(cfg)
    b.rows += [(2000, 0, 0), (2001, 6, 1)]          # 1100 -> 0100 (not in full table) -> 0110
    dec = tc.decode(b.write(tmp_path / "bad.csv"), cfg)
    assert dec.n_illegal == 2 and len(dec.steps["left"]) == 0


def test_rows_with_equal_time_apply_together(tmp_path):
    # half drive: 1000 -> (1100 set and IN1 cleared in the same instant) = 0100: a 2-phase jump
    b = TraceBuilder()
    b.rows += [(2000, 5, 1), (2000, 0, 0)]
    dec = tc.decode(b.write(tmp_path / "a.csv"), CFG)
    assert dec.n_illegal == 1 and "jump of 2" in dec.illegal[0]
    # the same rows at two instants are two legal steps
    b = TraceBuilder()
    b.rows += [(2000, 5, 1), (4000, 0, 0)]
    dec = tc.decode(b.write(tmp_path / "b.csv"), CFG)
    assert dec.n_illegal == 0 and len(dec.steps["left"]) == 2


def test_illegal_transitions_detected(tmp_path):
    b = TraceBuilder()
    b.pattern(2000, "right", HALF[2])               # jump 2 phases
    b.pattern(4000, "right", 0b1010)                # not in table
    dec = tc.decode(b.write(tmp_path / "a.csv"), CFG)
    msgs = tc.illegal_transitions(dec)
    assert len(msgs) == 2 and all(m.startswith("right") for m in msgs)
    assert "t=0.002000" in msgs[0] and "1010" in msgs[1]
    assert len(dec.steps["right"]) == 0


def test_energise_rules(tmp_path):
    # first energise from the released initial state: any phase is fine
    b = TraceBuilder(initial={"left": 0, "right": 0})
    b.pattern(1000, "left", HALF[5])
    b.pattern(3000, "left", HALF[6])                # step
    b.pattern(5000, "left", 0)                      # release at phase 6
    b.pattern(9000, "left", HALF[6])                # energise at the same phase: ok
    b.pattern(11000, "left", 0)
    dec = tc.decode(b.write(tmp_path / "ok.csv"), CFG)
    assert tc.illegal_transitions(dec) == []
    assert len(dec.steps["left"]) == 1
    b.pattern(13000, "left", HALF[7])               # energise at a different phase
    dec = tc.decode(b.write(tmp_path / "bad.csv"), CFG)
    assert dec.n_illegal == 1 and "released at" in dec.illegal[0]
    # release from the initial energised phase, re-energise elsewhere: illegal
    b = TraceBuilder()
    b.pattern(1000, "right", 0)
    b.pattern(2000, "right", HALF[1])
    dec = tc.decode(b.write(tmp_path / "bad2.csv"), CFG)
    assert dec.n_illegal == 1


def test_too_fast_steps_detected(tmp_path):
    b = TraceBuilder()
    for i in range(4):
        b.step(1000 * (i + 1), "right", +1)         # 1000 steps/s
    dec = tc.decode(b.write(tmp_path / "a.csv"), CFG)
    assert tc.min_step_interval(dec)["right"] == pytest.approx(0.001)
    probs = tc.check_step_rate(dec, 663)
    assert len(probs) == 1 and probs[0].startswith("right: 3 step intervals")


def test_pen_state_and_settling(tmp_path):
    b = TraceBuilder()
    b.pen(100_000, 1500)                            # down
    b.step(200_000, "left", 1)                      # only 0.1 s later: violation
    b.step(399_999, "left", 1)                      # 1 us early: within time rounding, ok
    b.pen(500_000, 0)                               # pulses off: not a change to nonzero
    b.step(500_000, "left", 1)
    b.pen(600_000, 500)                             # up
    b.step(1_000_000, "right", 1)
    path = b.write(tmp_path / "a.csv")
    dec = tc.decode(path, CFG)
    assert dec.pen_events == [(0.1, True), (0.6, False)]
    assert dec.pen_is_down_at(0.55) and not dec.pen_is_down_at(0.05)
    # points after steps at 0.2..0.5 are pen-down, the one at 1.0 is pen-up
    assert dec.pen_down.tolist() == [False, True, True, True, True, False, False]
    probs = tc.steps_while_settling(dec, 0.3)
    assert len(probs) == 1 and "1 steps" in probs[0] and "t=0.100000" in probs[0]
    assert tc.steps_while_settling(dec, 0.09) == []
    # initial level counts only on request
    assert len(tc.steps_while_settling(dec, 0.25, include_initial=True)) == 2


def test_released_at_end(tmp_path):
    b = TraceBuilder()
    b.pen(10_000, 1500)
    b.pen(20_000, 500)
    b.release(30_000)
    assert tc.released_at_end(tc.read_trace(b.write(tmp_path / "ok.csv")), CFG) == []

    b = TraceBuilder()
    b.pen(10_000, 1500)
    b.pattern(30_000, "left", 0)
    b.pen(30_000, 0)
    probs = tc.released_at_end(b.write(tmp_path / "bad.csv"), CFG)
    assert any("right coil pin 12" in p for p in probs)
    assert any("last commanded to 1500" in p for p in probs)
    assert not any("left" in p for p in probs)


def test_window_acceleration():
    # 100 steps/s for 1 s starting from rest: windows hold 10 steps each.
    t_us = ((np.arange(100) + 0.5) * 10_000).astype(np.int64)
    dec = tc.Decoded(end_time=1.0)
    dec.steps["left"] = tc.MotorSteps(t_us / 1e6, t_us, np.ones(100, np.int64), np.ones(100, np.int64))
    acc = tc.max_window_accel(dec, 0.1)
    assert acc["left"] == pytest.approx(1000.0)    # 0 -> 100 steps/s in one window
    assert acc["right"] == 0.0
    starts, v = tc.window_velocities(dec, "left", 0.1, 0.0)
    assert starts[0] == pytest.approx(-0.1) and starts[1] == 0.0
    assert v[0] == 0 and np.all(v[1:11] == 100) and np.all(v[11:] == 0)
    assert tc.check_window_accel(dec, 2000) == []
    assert len(tc.check_window_accel(dec, 700)) == 1
    # a reversal within the run: +100 -> -100 steps/s
    dirs = np.where(np.arange(100) < 50, 1, -1)
    dec.steps["left"] = tc.MotorSteps(t_us / 1e6, t_us, dirs, dirs)
    assert tc.max_window_accel(dec, 0.1)["left"] == pytest.approx(2000.0)


# ---------------------------------------------------------------------------
# reference G-code interpreter
# ---------------------------------------------------------------------------

def _spacing_ok(polys, h=0.005):
    return all(len(p) < 2 or np.hypot(*np.diff(p, axis=0).T).max() <= h + 1e-12 for p in polys)


def test_full_circle_g2_radius_and_direction():
    polys = tc.reference_path("G0 X10 Y0\nM3\nG2 X10 Y0 I-10 J0\nM5\n")
    assert len(polys) == 1
    p = polys[0]
    r = np.hypot(p[:, 0], p[:, 1])
    assert np.allclose(r, 10.0, atol=1e-12)
    assert np.allclose(p[0], [10, 0]) and np.allclose(p[-1], [10, 0])
    # clockwise from (10, 0) goes through negative Y first
    assert p[len(p) // 4][1] < -9.9
    assert _spacing_ok(polys)
    length = np.hypot(*np.diff(p, axis=0).T).sum()
    assert length == pytest.approx(2 * math.pi * 10, rel=1e-6)


def test_arc_directions_and_r_form():
    q = math.sqrt(50)
    ccw = tc.reference_path("G0 X10 Y0\nM3\nG3 X0 Y10 I-10 J0\n")[0]
    assert np.min(np.hypot(ccw[:, 0] - q, ccw[:, 1] - q)) < 0.003        # short way via (7.07, 7.07)
    assert np.hypot(*np.diff(ccw, axis=0).T).sum() == pytest.approx(0.5 * math.pi * 10, rel=1e-6)
    cw = tc.reference_path("G0 X10 Y0\nM3\nG2 X0 Y10 I-10 J0\n")[0]
    assert np.min(np.hypot(cw[:, 0] + q, cw[:, 1] + q)) < 0.003          # 270 degrees via (-7.07, -7.07)
    r_pos = tc.reference_path("G0 X10 Y0\nM3\nG3 X0 Y10 R10\n")[0]
    assert np.allclose(np.hypot(*r_pos.T), 10, atol=1e-9)                # centre (0, 0)
    r_neg = tc.reference_path("G0 X10 Y0\nM3\nG3 X0 Y10 R-10\n")[0]
    assert np.allclose(np.hypot(r_neg[:, 0] - 10, r_neg[:, 1] - 10), 10, atol=1e-9)  # centre (10, 10)
    span = np.hypot(*np.diff(r_neg, axis=0).T).sum()
    assert span == pytest.approx(1.5 * math.pi * 10, rel=1e-6)
    r_cw = tc.reference_path("G0 X10 Y0\nM3\nG2 X0 Y10 R10\n")[0]
    assert np.allclose(np.hypot(r_cw[:, 0] - 10, r_cw[:, 1] - 10), 10, atol=1e-9)   # centre (10, 10)
    assert np.hypot(*np.diff(r_cw, axis=0).T).sum() == pytest.approx(0.5 * math.pi * 10, rel=1e-6)


def test_spiral_ends_at_end_point_with_linear_radius():
    # centre (0,0), start radius 10, end (0, 12): radius grows linearly over 90 degrees
    p = tc.reference_path("G0 X10 Y0\nM3\nG3 X0 Y12 I-10 J0\n")[0]
    assert tuple(p[-1]) == (0.0, 12.0)
    ang = np.arctan2(p[:, 1], p[:, 0])
    r = np.hypot(*p.T)
    assert np.allclose(r, 10 + 2 * ang / (math.pi / 2), atol=1e-9)
    assert _spacing_ok([p])


def test_interpreter_modes_units_and_syntax():
    text = """%
(header) ; comment
N10 G21 G90 G17 G94 G40 G49 G54 G61 G64 G80
N20 G00 X1 Y1 *57
N30 M3 S1000 T1
N40 G01 X2 F300 (move)
N50 Y2
N60 G91 X1 Y1
N70 G4 P0.5
N80 M7 M8 M9 M5
N90 G90 G20 X1 Y0
N100 M3
N110 G1 X1.1 Y0
N120 M30
N130 M5
N140 G1 X0 Y0
%
"""
    polys = tc.reference_path(text)
    assert len(polys) == 2
    a, b = polys
    assert np.allclose(a[0], [1, 1]) and np.allclose(a[-1], [3, 3])
    assert np.min(np.hypot(a[:, 0] - 2, a[:, 1] - 1)) < 1e-12           # corner at (2, 1)
    assert np.allclose(b[0], [25.4, 0]) and np.allclose(b[-1], [27.94, 0])  # inches
    assert _spacing_ok(polys)


def test_z_pen_file_and_pen_change_before_motion():
    text = "G0 Z5\nG0 X1 Y1\nG1 X2 Y1 Z-1 M5\nG1 X3 Y1\nG0 X4 Y1 Z2\nM3\nG1 X5\n"
    polys = tc.reference_path(text)
    assert len(polys) == 1                           # M3/M5 ignored in a Z file
    p = polys[0]
    assert np.allclose(p[0], [1, 1]) and np.allclose(p[-1], [3, 1])      # pen down before the move
    # M3/M5 file: M3 down, M5 up; a pen-down without motion is a dot
    polys = tc.reference_path("G0 X1 Y1\nM3\nM5\nG0 X2\nM3 G1 X3\n")
    assert len(polys) == 2 and len(polys[0]) == 1 and np.allclose(polys[1][-1], [3, 1])
    # G91 Z is relative
    polys = tc.reference_path("G91\nG0 Z1\nG1 X1 Z-2\nG1 X1\nG1 Z1\nG1 X1\n")
    assert len(polys) == 1 and np.allclose(polys[0][-1], [2, 0])


def test_interpreter_rejects_unknown():
    for bad in ("G28\n", "M6\n", "G1 X1 A3\n", "G18\n", "G2 X1 Y1\n", "G1 X1 $\n"):
        with pytest.raises(tc.GCodeError):
            tc.reference_path(bad)


def test_sample_file_parses():
    import pathlib
    sample = pathlib.Path(__file__).resolve().parents[1] / "gcode_samples" / "car.ngc"
    if not sample.exists():
        pytest.skip("no gcode sample")
    polys = tc.reference_path(sample)
    pts = np.concatenate(polys)
    assert len(polys) > 0 and _spacing_ok(polys)
    assert pts.min() > 0 and pts.max() < 200


# ---------------------------------------------------------------------------
# accuracy
# ---------------------------------------------------------------------------

def test_accuracy_of_perfect_and_offset_lines():
    ref = tc.reference_path("G0 X0 Y0\nM3\nG1 X10 Y5\nM5\n")
    pts = np.column_stack([np.linspace(0, 10, 3001), np.linspace(0, 5, 3001)])
    d1, d2 = tc.accuracy(_decoded_from_points(pts), ref)
    assert d1 < 1e-9 and d2 < 1e-9
    n = np.array([-5, 10]) / math.hypot(5, 10)
    d1, d2 = tc.accuracy(_decoded_from_points(pts + 0.05 * n), ref)
    assert d1 == pytest.approx(0.05, abs=1e-9) and d2 == pytest.approx(0.05, abs=1e-9)
    # half the line missing
    d1, d2 = tc.accuracy(_decoded_from_points(pts[:1500]), ref)
    assert d1 < 1e-9 and d2 == pytest.approx(math.hypot(10, 5) * 1501 / 3000, rel=1e-6)
    # pen-up points do not count as drawn
    d1, d2 = tc.accuracy(_decoded_from_points(pts + 1.0, pen_down=False), ref)
    assert d1 == 0.0 and d2 == math.inf


def test_distance_is_to_segments_not_vertices():
    poly = [np.array([[0.0, 0.0], [1.0, 0.0]])]
    d = tc.distances_to_polylines([[0.5, 0.01], [2.0, 0.0], [-0.3, -0.4]], poly, spacing=10.0)
    assert np.allclose(d, [0.01, 1.0, 0.5])


def test_simulated_drawing_passes_and_wrong_config_fails(tmp_path):
    gcode = "G21\nG0 X5 Y5\nG1 Z-1\nG1 X12 Y8\nG2 X12 Y8 I0 J-1.5\nG0 Z1\nG0 X0 Y0\nM2\n"
    ref = tc.reference_path(gcode)
    parts = [(False, [[5, 5]]), (True, ref[0][::10]), (True, [ref[0][-1]]), (False, [[0, 0]])]
    b = simulate(parts)
    path = b.write(tmp_path / "sim.csv")
    assert tc.verify(path, gcode, CFG, check_accel=False) == []
    dec = tc.decode(path, CFG)
    d1, d2 = tc.accuracy(dec, ref)
    assert d1 < 0.01 and d2 < 0.01
    assert dec.x[-1] == pytest.approx(0.0, abs=0.01) and dec.y[-1] == pytest.approx(0.0, abs=0.01)
    # the constant-rate toy driver does not ramp: the accel check notices
    assert any(p.startswith("[accel]") for p in tc.verify(path, gcode, CFG))
    # decoding with the wrong direction flag draws something else
    wrong = {"motors": {"left_reverse": False}}
    probs = tc.verify(path, gcode, wrong, check_accel=False)
    assert any(p.startswith("[accuracy]") for p in probs)
    # a start point mismatch shifts the drawing
    probs = tc.verify(path, gcode, CFG, start_xy=(0.1, 0.0), check_accel=False)
    assert any(p.startswith("[accuracy]") for p in probs)
