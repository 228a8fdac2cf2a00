"""Kinematics and segmenter: property tests over random geometry."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vplotter.inputs.gcode import Move
from vplotter.kinematics.vplotter import TwoCord
from vplotter.motion.segment import arc_sweep, points

KIN = TwoCord(422.5, 211.25, 430.0)
coord = st.floats(-180, 180, allow_nan=False)
ycoord = st.floats(-240, 290, allow_nan=False)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(coord, ycoord)
def test_forward_inverts_inverse(x, y):
    m = KIN.to_machine(np.array([[x, y]]))
    back = KIN.to_gcode(KIN.forward(KIN.inverse(m)))
    assert np.allclose(back, [[x, y]], atol=1e-9)


def test_cords_of_the_seed_machine():
    # origin below the middle of the anchors: both cords equal, hypot(211.25, 430)
    cords = KIN.inverse(KIN.to_machine(np.array([[0.0, 0.0]])))[0]
    assert cords == pytest_approx([math.hypot(211.25, 430.0)] * 2)


def pytest_approx(v):
    import pytest

    return pytest.approx(v, abs=1e-9)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(coord, ycoord, coord, ycoord, st.floats(0.05, 100))
def test_crossing_solves_the_cord_length(x0, y0, x1, y1, frac):
    p0 = KIN.to_machine(np.array([[x0, y0]]))
    p1 = KIN.to_machine(np.array([[x1, y1]]))
    d = float(np.hypot(*(p1 - p0)[0]))
    if d < 1e-3:
        return
    e = (p1 - p0) / d
    for motor in (0, 1):
        ext = KIN.extrema(p0, e, np.array([d]))[0, motor]
        end = ext if not np.isnan(ext) else d      # a monotonic stretch of the piece
        s_true = end * min(frac, 99.0) / 100.0
        q = KIN.inverse(p0 + e * s_true)[0, motor]
        rising = KIN.slope(p0, e)[0, motor] > 0
        s = KIN.crossing(p0, e, motor, np.array([0]), np.array([q]), np.array([rising]))[0]
        assert abs(s - s_true) < 1e-6


def _dist_to_circle(pts, cx, cy, r):
    return np.abs(np.hypot(pts[:, 0] - cx, pts[:, 1] - cy) - r)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.floats(0.02, 500), st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi),
       st.sampled_from([-1, 1]), st.sampled_from([0.001, 0.01, 0.1]))
def test_arc_chords_stay_within_tolerance(r, a0, a1, arc, tol):
    cx, cy = 3.0, -2.0
    mv = Move(1, 1, cx + r * math.cos(a0), cy + r * math.sin(a0), cx + r * math.cos(a1),
              cy + r * math.sin(a1), arc, cx, cy)
    pts = np.vstack(([[mv.x0, mv.y0]], points(mv, tol)))
    assert np.array_equal(pts[-1], [mv.x1, mv.y1])
    # every chord's midpoint (its farthest point from the arc) is within tol of the circle
    mid = (pts[1:] + pts[:-1]) / 2
    assert _dist_to_circle(mid, cx, cy, r).max() <= tol * 1.0001 + 1e-9
    # chords turn the right way round
    sweep = arc_sweep(mv)
    assert np.sign(sweep) == arc


def test_full_circle_when_start_equals_end():
    mv = Move(1, 1, 10.0, 0.0, 10.0, 0.0, 1, 0.0, 0.0)
    pts = points(mv, 0.01)
    assert len(pts) == 71   # 2 pi / (2 acos(1 - 0.01 / 10)) = 70.2
    ang = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    assert ang[-1] - 0.0 == pytest_approx(2 * math.pi)


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.floats(1, 100), st.floats(1, 100), st.floats(0.1, 6.2), st.sampled_from([-1, 1]))
def test_spiral_radius_linear_in_angle_and_ends_exactly(r0, r1, sweep, arc):
    cx, cy = 0.0, 0.0
    a1 = arc * sweep
    mv = Move(1, 1, r0, 0.0, r1 * math.cos(a1), r1 * math.sin(a1), arc, cx, cy)
    pts = points(mv, 0.01)
    assert np.array_equal(pts[-1], [mv.x1, mv.y1])
    ang = np.abs(np.unwrap(np.concatenate(([0.0], np.arctan2(pts[:, 1], pts[:, 0])))))[1:]
    rad = np.hypot(pts[:, 0], pts[:, 1])
    expect = r0 + (r1 - r0) * ang / abs(arc_sweep(mv))
    assert np.allclose(rad, expect, atol=1e-6)
