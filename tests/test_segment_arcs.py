"""The segmenter (motion/segment.py): arcs cut into chords within the tolerance, full circles,
spirals; property tests over random geometry."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vplotter.inputs.gcode import Move
from vplotter.motion.segment import arc_sweep, points


def pytest_approx(v):
    import pytest

    return pytest.approx(v, abs=1e-9)


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


def test_a_spiral_of_next_to_no_sweep_is_one_chord():
    """Radius 1 -> 2 over a sweep of about 1e-63 rad (hypothesis found it): 1 - tol/r rounds
    to 1, and the chord count divided by zero (a ValueError in points_many, an internal error
    in draw). It is the straight piece to the end point, one and many at once alike."""
    from vplotter.inputs.gcode import Move
    from vplotter.motion import segment

    m = Move(1, 1, 0.0, 0.0, 1.0, 0.0, -1, -1.0, -1.1803185848828598e-63)
    one = segment.points(m, 0.0075)
    many, n = segment.points_many([m], 0.0075)
    assert one.tolist() == [[1.0, 0.0]] and many.tolist() == one.tolist() and n.tolist() == [1]
