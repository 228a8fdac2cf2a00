"""The V-plotter's two-cord kinematics (kinematics/vplotter.py, TwoCord, the plain machine):
property tests over random geometry. The gondola and cord models: test_kinematics_models.py."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vplotter.kinematics.vplotter import TwoCord

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
