"""Tone curves fitted to a drawing's measured response (inputs/image/calibrate.py)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings, strategies as st

from vplotter.inputs.image import calibrate, tone


def _dark(seed: int, n: int = 60) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n] / n
    return np.clip(0.5 * x + 0.4 * np.sin(6 * y) ** 2 + 0.1 * rng.random((n, n)), 0, 1)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), q=st.floats(0.0, 0.8), k=st.floats(0.05, 3.0),
       g=st.floats(1.0, 9.0), mean=st.floats(0.01, 0.4))
def test_a_fitted_curve_rises_from_nothing(seed, q, k, g, mean):
    """Whatever the response measured, the fitted curve is 0 at white and strictly rising (a
    darker tone never gets less ink), and below the threshold only a trace of the top."""
    dark = _dark(seed)
    ink = np.minimum(k * tone.curve(dark, g), 1)          # a response that saturates
    t = calibrate.table(calibrate.response(g, ink, dark), dark, mean, q)
    f = np.asarray(t.values)
    assert f[0] == 0 and np.all(np.diff(f) > 0) and np.all(np.isfinite(f))
    xs = np.linspace(0, 1, len(f))
    below = xs < calibrate.threshold(dark, q)
    assert np.all(f[below] <= calibrate.FLOOR * f[-1] + 1e-12)
    assert tone.curve(np.array([0.0, 1.0]), t).tolist() == [0.0, np.float32(f[-1])]


def test_the_fitted_curve_straightens_a_known_response():
    """A drawing whose ink saturates (overlapping lines: 0.4 (1 - e^-3f) of the curve's f):
    the fitted curve, put through the same response, gives ink rising in a straight line above
    the threshold (where the ink asked for was measured), with the mean asked for."""
    dark = _dark(1)
    respond = lambda f: 0.4 * (1 - np.exp(-3 * f))       # noqa: E731
    ink = respond(tone.curve(dark, 3.0))
    want = 0.5 * float(ink.mean())
    t = calibrate.table(calibrate.response(3.0, ink, dark), dark, want, 0.3)
    d0 = calibrate.threshold(dark, 0.3)
    xs = np.linspace(d0 + 0.05, dark.max(), 12)
    out = respond(tone.curve(xs, t))
    assert out[-1] < ink.max()                            # within the measured response
    slope = np.diff(out) / np.diff(xs)
    assert np.ptp(slope) < 0.15 * slope.mean(), slope     # straight
    got = respond(tone.curve(dark, t)).mean()
    assert abs(got / want - 1) < 0.1                     # about the ink asked for


@settings(max_examples=60, deadline=None)
@given(peak=st.floats(0.0, 0.9))
def test_the_threshold_search_finds_the_peak(peak):
    """A score with one peak anywhere in 0..0.9: found within a REFINE step, in a few calls."""
    calls = []

    def value(q):
        calls.append(q)
        return -abs(q - peak)

    q = calibrate.search(value)
    assert abs(q - peak) <= calibrate.REFINE / 2 + 1e-9
    assert len(calls) == len(set(calls)) <= 10 and all(0 <= c <= calibrate.MOST_Q for c in calls)
