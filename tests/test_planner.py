"""Planner and schedule: the limits hold piece by piece, and streaming keeps memory flat."""

import numpy as np
import pytest

from vplotter import config, kinematics
from vplotter.motion.planner import RATE_MARGIN, Planner
from vplotter.motion.refine import MAX_PARTS
from vplotter.motion.schedule import Scheduler
from vplotter.motion.steps import Dwell, Motion, PenMove

from support import REPO

CFG = config.load(REPO / "config.toml")
KIN = kinematics.from_config(CFG)
SPM = CFG.motors.steps_per_unit[0]


def zigzag(n, seed=0):
    rng = np.random.default_rng(seed)
    g = np.column_stack((rng.uniform(-150, 150, n), rng.uniform(-200, 250, n)))
    return KIN.to_machine(g)


def plan_all(pts, window=64, cap=8.0):
    start = KIN.to_machine([[0.0, 0.0]])[0]
    p = Planner(KIN, CFG.motors.max_step_rate, CFG.motors.max_accel, SPM, start, window=window)
    blocks = list(p.add(pts, cap, 1, True)) + list(p.stop())
    return blocks


def test_blocks_join_up_and_stop_at_the_end():
    blocks = plan_all(zigzag(500))
    for a, b in zip(blocks, blocks[1:]):
        assert np.array_equal(a.verts[-1], b.verts[0])
        assert abs(a.v1[-1] - b.v0[0]) < 1e-9
    assert blocks[0].v0[0] == 0.0 and blocks[-1].v1[-1] == 0.0
    for b in blocks:
        # bounded by the look-ahead window: a piece is cut at most in three where a cord turns
        # round, then in MAX_PARTS for the rate limit and twice more next to sharp corners
        assert len(b.d) <= 2 * 64 * 3 * (MAX_PARTS + 2)
        assert np.allclose(b.v1[:-1], b.v0[1:])


def test_cord_speeds_stay_below_the_step_rate():
    for b in plan_all(zigzag(300, seed=3)):
        e = b.e
        for where in (b.verts[:-1], b.verts[1:]):
            k = np.abs(KIN.slope(where, e)).max(axis=1)
            assert (k * b.vp * SPM <= CFG.motors.max_step_rate * RATE_MARGIN * (1 + 1e-9)).all()


def test_ramps_respect_the_acceleration():
    for b in plan_all(zigzag(300, seed=4)):
        k = np.abs(KIN.slope(b.verts[:-1], b.e)).max(axis=1)
        assert (k * b.a * SPM <= CFG.motors.max_accel + 1e-6).all()
        # speeds are reachable within each piece
        assert (b.vp ** 2 - b.v0 ** 2 <= 2 * b.a * b.d + 1e-9).all()
        assert (b.vp ** 2 - b.v1 ** 2 <= 2 * b.a * b.d + 1e-9).all()


def test_pieces_are_monotonic_in_both_cords():
    for b in plan_all(zigzag(200, seed=5)):
        k0 = KIN.slope(b.verts[:-1], b.e)
        k1 = KIN.slope(b.verts[1:], b.e)
        assert (k0 * k1 >= -1e-9).all()


def test_schedule_counts_match_rounded_cords():
    blocks = plan_all(zigzag(50, seed=6))
    ref = KIN.inverse(KIN.to_machine([[0.0, 0.0]]))[0]
    s = Scheduler(CFG, KIN, (0, 0), ref)
    s.start()
    for b in blocks:
        rows = s.motion(b)
        want = np.rint((b.cords[-1] - ref) * SPM)
        assert np.array_equal(rows.steps[-1], want)
        assert (np.diff(rows.t_us) >= 0).all()
        # one motor changes by one step per row
        assert (np.abs(np.diff(rows.steps, axis=0)).sum(axis=1) <= 1).all()


def test_cord_move_rest_to_rest():
    ref = KIN.inverse(KIN.to_machine([[0.0, 0.0]]))[0]
    s = Scheduler(CFG, KIN, (0, 0), ref)
    rows = s.cord_move([2000, -700])
    assert tuple(rows.steps[-1]) == (2000, -700)
    assert rows.coils[-1] == 0                      # released at the end
    t = rows.t_us[rows.steps[:, 0] != np.roll(rows.steps[:, 0], 1)]
    assert np.diff(t).min() >= 1e6 / CFG.motors.max_step_rate


# ---------------------------------------------------------------- plan once, draw as planned
from hypothesis import assume, given, strategies as st  # noqa: E402

from vplotter import pipeline  # noqa: E402
from vplotter.motion import segment  # noqa: E402
from vplotter.inputs import gcode  # noqa: E402

STROKES = REPO / "gcode_samples" / "strokes.ngc"


def _start():
    return (0, 0), KIN.inverse(KIN.to_machine([[0.0, 0.0]]))[0]


def test_replayed_plan_gives_the_rows_of_a_fresh_stream():
    counts, ref = _start()
    for path in (STROKES, REPO / "gcode_samples" / "car.ngc"):
        summary = pipeline.validate(CFG, gcode.read(str(path), warn=lambda m: None), counts, ref)
        assert summary.plan is not None
        a = pipeline.Rows.concat(list(pipeline.replay(CFG, summary.plan, counts, ref)))
        b = pipeline.Rows.concat(list(pipeline.stream(CFG, gcode.read(str(path), warn=lambda m: None),
                                                      counts, ref)))
        for f in ("t_us", "coils", "pen_us", "line", "steps"):
            assert np.array_equal(getattr(a, f), getattr(b, f)), f
        assert summary.time_s == a.t_us[-1] / 1e6


def test_a_plan_too_long_to_keep_is_planned_again(monkeypatch):
    monkeypatch.setattr(pipeline, "PLAN_LIMIT", 100)
    counts, ref = _start()
    summary = pipeline.validate(CFG, gcode.read(str(STROKES), warn=lambda m: None), counts, ref)
    assert summary.plan is None and summary.pieces > 100


def test_pen_changes_are_stops_inside_the_look_ahead(monkeypatch):
    from vplotter.motion.planner import Planner as P

    rounds = []
    orig = P._profile
    monkeypatch.setattr(P, "_profile", lambda self, *a: rounds.append(1) or orig(self, *a))
    counts, ref = _start()
    ops = list(pipeline.plan(CFG, gcode.read(str(STROKES), warn=lambda m: None), counts, ref,
                             "strokes", pipeline.Summary()))
    pens = [op for op in ops if isinstance(op, PenMove)]
    recs = [r for r in gcode.read(str(STROKES), warn=lambda m: None) if isinstance(r, gcode.Pen)]
    assert [(p.down, p.line) for p in pens] == [(r.down, r.line) for r in recs]   # all, in order
    assert len(rounds) < len(pens) / 4          # many strokes planned in one look-ahead round
    for op, nxt in zip(ops, ops[1:]):
        if isinstance(op, Motion) and isinstance(nxt, (PenMove, Dwell)):
            assert op.block.v1[-1] == 0.0 and op.block.stop[-1]   # standing still at a pen change
        if isinstance(op, PenMove) and isinstance(nxt, Motion):
            assert nxt.block.v0[0] == 0.0


@given(st.lists(st.tuples(st.floats(-100, 100), st.floats(-100, 100), st.floats(-100, 100),
                          st.floats(-100, 100), st.sampled_from([-1, 0, 1]),
                          st.floats(-3, 3), st.floats(-3, 3)), min_size=1, max_size=20),
       st.sampled_from([0.0075, 0.05, 1.0]))
def test_cutting_many_moves_at_once_equals_one_by_one(raw, tol):
    moves = []
    for x0, y0, x1, y1, arc, i, j in raw:
        if arc:   # centre near the start; the end put on the same circle or not (spirals)
            assume(abs(i) + abs(j) > 1e-6)     # (the reader refuses arcs of zero radius)
            moves.append(gcode.Move(1, 1, x0, y0, x1, y1, arc, x0 + i, y0 + j))
        else:
            moves.append(gcode.Move(1, 1, x0, y0, x1 if i > 0 else x0, y1 if i > 0 else y0))
    pts, n = segment.points_many(moves, tol)
    one = [segment.points(m, tol) for m in moves]
    assert n.tolist() == [len(p) for p in one]
    if len(pts):
        assert np.abs(pts - np.concatenate([p for p in one if len(p)])).max() < 1e-9


@pytest.mark.parametrize("name", ["gcode_samples/strokes.ngc", "tests/data/micro_arcs.ngc",
                                  "tests/data/gcodetools_far.ngc"])
def test_corners_and_ramps_share_the_acceleration_budget(name):
    """On every piece, what each ramp adds to a cord's acceleration plus what the corner at
    either end adds stays within the budget, each with its sign: a ramp speeding up changes a
    cord's speed the way of its slope, slowing down the other way; a corner the way of the
    slope change. |s x slope x a + (slope change) x v x max(1/TAU, v/ds)| <= max_accel per
    motor (steps/s^2), s = +1 for the ramp up and -1 for the ramp down of each trapezoid; ds
    the shorter piece, or on a curve cut into chords (corners.Corners.takes) half of each."""
    from vplotter.motion.planner import ACCEL_MARGIN, TAU_S

    counts, ref = _start()
    acc = CFG.motors.max_accel * ACCEL_MARGIN / SPM
    ops = pipeline.plan(CFG, gcode.read(str(REPO / name), warn=lambda m: None), counts, ref,
                        name, pipeline.Summary())
    for b in (op.block for op in ops if isinstance(op, Motion)):
        e = b.e
        k0, k1 = KIN.slope(b.verts[:-1], e), KIN.slope(b.verts[1:], e)
        kmax = np.maximum(np.maximum(np.abs(k0), np.abs(k1)), 0.25)
        sign = np.sign(k0 + k1)
        ramp = kmax * b.a[:, None]
        assert (ramp <= acc * (1 + 1e-6)).all()
        if len(b.d) < 2:
            continue
        # the cord accelerations of each piece's ramps, up (where it speeds up) and down
        up = np.where((b.vp > b.v0)[:, None], sign * ramp, 0.0)
        down = np.where((b.vp > b.v1)[:, None], -sign * ramp, 0.0)
        unknown = (sign == 0) & (ramp > 0)
        change = k0[1:] - k1[:-1]
        v = b.v1[:-1, None]
        # the jump counts over the shorter piece; on a curve (the shorter piece passed within
        # TAU / 1.5) over half of each, the longer up to what is passed in TAU / 1.5
        ds = np.minimum(b.d[1:], b.d[:-1])[:, None]
        dl = np.maximum(b.d[1:], b.d[:-1])[:, None]
        curve = v * TAU_S / 1.5 >= ds
        cell = np.where(curve, 0.5 * (ds + np.minimum(dl, v * TAU_S / 1.5)), ds)
        corner = change * v * np.maximum(1 / TAU_S, v / cell)
        assert (np.abs(corner) <= acc * (1 + 1e-9)).all()
        for r in (up, down):        # with the corner at a piece's start, and at its end
            for side, c in ((slice(1, None), corner), (slice(None, -1), corner)):
                worst = np.where(unknown[side], np.abs(c) + ramp[side], np.abs(r[side] + c))
                assert (worst <= acc * (1 + 1e-6)).all()


VARIED = ["tiny_shapes.ngc", "far_arcs.ngc", "micro_arcs.ngc", "gcodetools_far.ngc",
          "zigzag.ngc", "long_travel.ngc", "mixed.ngc", "corners.ngc"]
SIZED = {"seed": REPO / "config.toml", "wall1m": REPO / "tests" / "data" / "wall1m.toml",
         "wall2m": REPO / "tests" / "data" / "wall2m.toml"}


@pytest.mark.parametrize("machine,name",
                         [("seed", f"gcode_samples/{n}") for n in ("strokes.ngc", "circles.ngc",
                                                                    "square.ngc", "long_line.ngc")]
                         + [(m, f"tests/data/{n}") for m in SIZED for n in VARIED])
def test_plot_time_is_close_to_time_optimal(machine, name):
    """bench/reference/topp.py computes the time-optimal parameterisation of the same path
    under the same motor limits (the planner's derated ones; the pen within tolerance_mm at
    corners); the plan is within 5 % of it, and of the reference at the raw limits too, on the
    seed machine and on a 1 m and a 2 m wall (tests/data: other anchors, pages, spools, rates
    and accelerations), for the samples and the varied small files of bench/make/varied.py."""
    import sys

    sys.path.insert(0, str(REPO))      # bench/ is a package at the repository's root
    try:
        from bench.reference import topp
    finally:
        sys.path.pop(0)
    cfg = config.load(SIZED[machine])
    kin = kinematics.from_config(cfg)
    path = str(REPO / name)
    ref = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
    planned = pipeline.validate(cfg, gcode.read(path, warn=lambda m: None), (0, 0), ref).time_s
    best = topp.reference(cfg, path)
    assert best <= planned <= 1.05 * best
    # and against the bound at the raw limits (no derating), which no schedule reaches
    assert planned <= 1.05 * topp.reference(cfg, path, derated=False)


@pytest.mark.parametrize("machine,name", [("wall1m", "zigzag.ngc"), ("wall2m", "micro_arcs.ngc"),
                                          ("seed", "long_travel.ngc")])
def test_sized_machines_keep_the_limits(machine, name, tmp_path):
    """Dry-run traces of the varied files on the sized machines, decoded by tracecheck: step
    rate, 0.1 s-window acceleration, settling, release and accuracy (0.02 mm both ways)."""
    from support import tracecheck as tc
    from vplotter.cli import main

    gfile, trace = REPO / "tests" / "data" / name, tmp_path / "t.csv"
    assert main(["--config", str(SIZED[machine]), "calibrate", "--at", "0", "0"]) == 0
    assert main(["--config", str(SIZED[machine]), "draw", str(gfile), "--dry-run",
                 "--trace", str(trace)]) == 0
    assert tc.verify(tc.read_trace(trace), gfile, tc.load_config(SIZED[machine]), tol_mm=0.02) == []


def test_rows_come_in_parts_of_bounded_size(tmp_path):
    """400 pen-up moves across 150 mm are one planned block of 8.7 million steps; its rows
    come in parts of about STEPS_PER_PART, so memory does not grow with the pieces' length."""
    path = tmp_path / "zig.ngc"
    path.write_text("G21 G90\n" + "".join(f"G00 X{-75 if i % 2 else 75} Y{-100 + i * 0.5:.1f}\n"
                                          for i in range(60)))
    counts, ref = _start()
    sizes, total = [], 0
    for rows in pipeline.stream(CFG, gcode.read(str(path)), counts, ref):
        sizes.append(len(rows))
        total += len(rows)
    assert total > 5 * pipeline.STEPS_PER_PART
    assert max(sizes) <= pipeline.STEPS_PER_PART + 2 * 150 * SPM      # a part and one piece
