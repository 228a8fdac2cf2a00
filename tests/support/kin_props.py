"""The properties every kinematic model of the two-cord machine must have, checked at one
point (the test files draw the points with hypothesis, each over its own models and ranges):
forward kinematics inverts the inverse; slopes and bends are the derivatives along a line;
a motor turns round where extrema says, and the step solver finds where a cord reaches a
length."""

from __future__ import annotations

import math

import numpy as np
import pytest


def forward_inverts_inverse(kin, x: float, y: float) -> None:
    m = kin.to_machine(np.array([[x, y]]))
    assert np.allclose(kin.forward(kin.inverse(m)), m, atol=1e-9)


def derivatives_along_a_line(kin, x: float, y: float, a: float) -> None:
    """slope, bend and slope_bend against central differences of the inverse (h = 1e-3 mm)."""
    p = kin.to_machine(np.array([[x, y]]))
    e = np.array([[math.cos(a), math.sin(a)]])
    h = 1e-3
    qm, q0, qp = (kin.inverse(p + k * h * e) for k in (-1, 0, 1))
    k, b = kin.slope_bend(p, e)
    assert np.allclose(k, (qp - qm) / (2 * h), atol=1e-7)
    assert np.allclose(b, (qp - 2 * q0 + qm) / h ** 2, atol=1e-4)
    assert np.allclose(k, kin.slope(p, e), atol=1e-12)
    assert np.allclose(b, kin.bend(p, e), atol=1e-12)


def extrema_and_crossing(kin, x: float, y: float, a: float, d: float, frac: float,
                         cord_tol: float = 1e-9, piece_tol: float = 1e-9) -> None:
    """On the piece from G-code (x, y) along angle a for d mm: where a motor turns round its
    slope is zero; on each monotonic part the step solver puts the pen where the cord is
    `frac` of the way (within cord_tol mm), inside the part (within piece_tol mm)."""
    p0 = kin.to_machine(np.array([[x, y]]))
    e = np.array([[math.cos(a), math.sin(a)]])
    ext = kin.extrema(p0, e, np.array([d]))[0]
    for m in (0, 1):
        cuts = [0.0, *([ext[m]] if not math.isnan(ext[m]) else []), d]
        if not math.isnan(ext[m]):           # the slope is zero there: the motor turns round
            assert abs(kin.slope(p0 + e * ext[m], e)[0, m]) < 1e-9
        for s0, s1 in zip(cuts[:-1], cuts[1:]):
            a0, a1 = p0 + e * s0, p0 + e * s1
            q0, q1 = kin.inverse(a0)[0, m], kin.inverse(a1)[0, m]
            if abs(q1 - q0) < 1e-6:
                continue
            target = q0 + frac * (q1 - q0)
            s = kin.crossing(a0, e, m, np.array([0]), np.array([target]), np.array([q1 > q0]),
                             abs(q1 - q0))[0]      # (one step: the schedule's way, spaced)
            assert -1e-9 <= s <= s1 - s0 + piece_tol
            assert kin.inverse(a0 + e * s)[0, m] == pytest.approx(target, abs=cord_tol)
