"""Planner and schedule: the limits hold piece by piece, and streaming keeps memory flat."""

import numpy as np

from vplotter import config, kinematics
from vplotter.planner import RATE_MARGIN, Planner
from vplotter.schedule import Scheduler

from conftest import REPO

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
        assert len(b.d) <= 2 * 64 * 3  # bounded by the look-ahead window (cuts at most triple)
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
