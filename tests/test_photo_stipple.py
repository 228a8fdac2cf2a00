"""Stipples (inputs/image/stipple.py): where the dots go, how many, the tour through them."""

import sys

import numpy as np
import pytest

from vplotter.errors import ConfigError
from vplotter.inputs import image
from vplotter.inputs.image import stipple, stipple_tour, tone
from vplotter.inputs.image.picture import Picture

pytest.importorskip("scipy")
from scipy.spatial import cKDTree  # noqa: E402


def picture(d, width_mm=50.0) -> Picture:
    d = np.asarray(d, dtype=np.float32)
    return Picture(d, width_mm, width_mm * d.shape[0] / d.shape[1])


def halves(left=0.8, right=0.2, h=120, w=160) -> Picture:
    d = np.full((h, w), right)
    d[:, : w // 2] = left
    return picture(d, 40.0)


def photo(h=150, w=120, seed=3) -> Picture:
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w] / max(h, w)
    d = 0.2 + 0.6 * x * y + np.where((x - 0.4) ** 2 + (y - 0.5) ** 2 < 0.04, 0.5, 0.0)
    return picture(np.clip(d + rng.normal(0, 0.05, d.shape), 0, 1), 30.0)


def all_points(strokes) -> np.ndarray:
    return np.concatenate([s.pts for s in strokes])


def cv_nn(pts) -> float:
    dd, _ = cKDTree(pts).query(pts, k=2)
    return float(dd[:, 1].std() / dd[:, 1].mean())


def test_registered_style():
    assert image.style("stipple") is stipple.strokes


@pytest.mark.parametrize("opts", [{}, {"tsp": True}, {"dot_mm": 1.2}])
def test_every_point_strictly_inside(opts):
    pic = photo()
    out = stipple.strokes(pic, 0.8, 0.5, **opts)
    p = all_points(out)
    assert len(p) > 100
    assert np.all(p > 0) and np.all(p[:, 0] < pic.width_mm) and np.all(p[:, 1] < pic.height_mm)


def test_dots_are_one_point_strokes():
    out = stipple.strokes(photo(), 0.8, 0.5)
    assert all(s.pts.shape == (1, 2) for s in out)


def test_dots_come_in_a_short_order():
    """The pen hops from dot to dot in the order of their tour: shorter than the greedy order
    the drawing's ordering would give, and no longer than its best."""
    from vplotter.drawing import order

    out = stipple.strokes(photo(), 0.8, 0.5)
    hops = float(np.hypot(*np.diff(all_points(out), axis=0).T).sum())

    def travel(strokes):
        return order.travel_mm(strokes, start_xy=strokes[0].pts[0])

    assert hops == pytest.approx(travel(out))
    assert hops < 0.97 * travel(order.order(out, "greedy", out[0].pts[0]))
    assert hops <= travel(order.order(out, "best", out[0].pts[0])) * 1.001


def test_discs_are_small_closed_spirals():
    pts = stipple.points(photo(), 1.5)
    out = stipple.strokes(photo(), 1.5, 0.5, dot_mm=1.5)
    assert len(out) == len(pts)
    for s in out[:20]:
        c = s.pts[0]                                 # the spiral starts at the centre
        r = np.hypot(*(s.pts - c).T)
        assert r.max() == pytest.approx(0.5, abs=1e-9)          # (1.5 - 0.5) / 2
        assert r[-1] == pytest.approx(0.5, abs=1e-9)            # ends on the outer circle


def test_darker_gets_more_dots_in_proportion():
    pic = halves(0.8, 0.2)
    p = stipple.points(pic, 0.7)
    left = np.count_nonzero(p[:, 0] < 20.0)
    right = len(p) - left
    assert 3.4 < left / right < 4.6
    # the whole: N = sum(darkness) x pixel area / spacing²
    assert len(p) == round(float(pic.darkness.sum()) * pic.mm_per_px ** 2 / 0.7 ** 2)


def test_white_gives_nothing():
    pic = picture(np.zeros((50, 60)))
    assert stipple.strokes(pic, 1.0, 0.5) == []
    assert stipple.strokes(pic, 1.0, 0.5, tsp=True) == []


def test_half_the_spacing_four_times_the_dots():
    pic = photo()
    n1 = len(stipple.strokes(pic, 1.2, 0.5))
    n2 = len(stipple.strokes(pic, 0.6, 0.5))
    assert 3.7 < n2 / n1 < 4.3


def test_dots_given():
    assert len(stipple.points(photo(), 1.0, dots=321)) == 321


def test_lloyd_evens_the_dots():
    pic = picture(np.full((100, 100), 0.7), 40.0)
    start = stipple.points(pic, 0.8, iterations=0)
    done = stipple.points(pic, 0.8)
    assert len(start) == len(done)
    assert cv_nn(done) < 0.6 * cv_nn(start)
    # and Lloyd keeps the proportions of a two-tone picture
    pic = halves(0.9, 0.3)
    p = stipple.points(pic, 0.7)
    assert 2.6 < np.count_nonzero(p[:, 0] < 20) / np.count_nonzero(p[:, 0] >= 20) < 3.4


def test_tour_visits_every_stipple_once_and_is_short():
    pic = photo()
    pts = stipple.points(pic, 0.6, gamma=2.0)
    out = stipple.strokes(pic, 0.6, 0.5, tsp=True)
    got = all_points(out)
    assert len(got) == len(pts)
    assert np.array_equal(np.unique(got, axis=0), np.unique(pts, axis=0))
    t = stipple_tour.tour(pts)
    assert np.array_equal(np.sort(t), np.arange(len(pts)))

    def length(p):
        return float(np.hypot(*np.diff(p, axis=0).T).sum())

    rand = pts[np.random.default_rng(0).permutation(len(pts))]
    nn = pts[stipple_tour.nearest_neighbour(pts)]
    assert length(pts[t]) < 0.1 * length(rand)
    assert length(pts[t]) < 0.95 * length(nn)
    # split only at long edges: every drawn edge is at most MAX_EDGE spacings
    for s in out:
        assert np.all(np.hypot(*np.diff(s.pts, axis=0).T) <= stipple_tour.MAX_EDGE * 0.6 + 1e-9)


def test_tour_lifts_the_pen_over_white():
    d = np.full((100, 150), 0.9)
    d[:, 70:80] = 0.0                         # a white band 2.7 mm wide down the middle
    pic = picture(d, 40.0)
    out = stipple.strokes(pic, 0.8, 0.5, tsp=True)
    assert len(out) >= 2
    lo, hi = 70 * pic.mm_per_px, 80 * pic.mm_per_px
    for s in out:
        x = s.pts[:, 0]
        assert not (x.min() < lo and x.max() > hi), "a line crosses the white band"


@pytest.mark.parametrize("curve", [8.0, "table"])
def test_a_steep_tone_curve_keeps_the_tour_a_line(curve):
    """A grey picture whose darkest tones are two thin lines: a steep curve gathers the
    stipples there, the spacing in black shrinks to a fraction of the one asked for, and the
    tour through the grey between is still a line (its long-edge caps are on the spacing
    asked for), not a scatter of dots; it still lifts over white paper."""
    d = np.full((120, 120), 0.6)
    d[30:32, :] = d[:, 80:82] = 1.0
    d[:, :15] = 0.0                                # white paper down the left
    pic = picture(d, 60.0)
    if curve == "table":                           # a fitted curve: ink from 0.5 up, small
        xs = np.linspace(0, 1, 33)
        curve = tone.Table(tuple(0.01 * xs + 0.3 * np.maximum(xs - 0.5, 0)))
    out = stipple.strokes(pic, 2.0, 0.5, tsp=True, curve=curve)
    pts = all_points(out)
    assert len(pts) > 100
    assert sum(len(s.pts) for s in out if len(s.pts) > 1) > 0.8 * len(pts)
    assert np.all(pts[:, 0] > 15 * pic.mm_per_px)


def test_deterministic():
    pic = photo()
    for opts in ({}, {"tsp": True}):
        a = stipple.strokes(pic, 0.9, 0.5, seed=7, **opts)
        b = stipple.strokes(pic, 0.9, 0.5, seed=7, **opts)
        assert len(a) == len(b)
        assert all(np.array_equal(x.pts, y.pts) for x, y in zip(a, b))
    a = stipple.strokes(pic, 0.9, 0.5, seed=7)
    c = stipple.strokes(pic, 0.9, 0.5, seed=8)
    assert len(a) != len(c) or not np.array_equal(all_points(a), all_points(c))


def test_without_scipy_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "scipy.spatial", None)
    with pytest.raises(ConfigError) as e:
        stipple.strokes(photo(), 1.0, 0.5)
    assert str(e.value) == ("error: --style stipple needs SciPy: pip install scipy "
                            "(Pi OS: sudo apt install python3-scipy)")


def test_bad_spacing():
    with pytest.raises(ConfigError):
        stipple.strokes(photo(), 0.0, 0.5)


def test_fit_follows_the_tone_as_seen():
    """The dots moved by stipple_fit draw the tone better (the converter's own score) than
    Lloyd left them, at a budget's sparse spacing; same count, all inside the picture."""
    from vplotter.inputs.image import score

    y, x = np.mgrid[0:200, 0:300] / 300.0
    d = np.clip(0.1 + 0.5 * x + 0.4 * np.exp(-((x - 0.5) ** 2 + (y - 0.3) ** 2) / 0.005), 0, 1)
    pic = picture(d, 90.0)
    lloyd = stipple.strokes(pic, 3.5, 0.5, fit=False)
    fitted = stipple.strokes(pic, 3.5, 0.5)
    assert len(fitted) == len(lloyd) > 100
    assert all(s.pts.shape == (1, 2) for s in fitted)
    p = all_points(fitted)
    assert np.all(p > 0) and np.all(p[:, 0] < pic.width_mm) and np.all(p[:, 1] < pic.height_mm)
    assert (score.correlation(fitted, pic, 0.5) > score.correlation(lloyd, pic, 0.5) + 0.02)


def test_fit_keeps_a_ramp_rising():
    """Ink per area (dots per band) still rises band by band on a grey ramp after the fit."""
    d = np.tile(np.linspace(0.05, 1.0, 400), (120, 1))
    pic = picture(d, 120.0)
    p = all_points(stipple.strokes(pic, 3.0, 0.5))
    counts = np.histogram(p[:, 0], bins=5, range=(0, 120.0))[0]
    assert np.all(np.diff(counts) > 0), counts


def test_fit_alone():
    from vplotter.inputs.image import stipple_fit

    pts = np.array([[1.0, 1.0], [2.0, 2.0]])
    flat = np.full((20, 20), 0.5, dtype=np.float32)
    assert np.array_equal(stipple_fit.fitted(pts, flat, 10.0, 10.0)[0], pts)   # nothing to follow
    assert np.array_equal(stipple_fit.fitted(pts[:1], flat, 10.0, 10.0)[0], pts[:1])


def test_chosen_curve_is_the_one_drawn_and_told():
    pic = photo(300, 240)
    g, pts, r = stipple.chosen(pic, 2.5, 0.5)
    assert g in {2.0 ** k for k in range(7)} and 0 < r <= 1
    assert stipple.tone_gamma(pic, 2.5, 0.5) == g                 # what `info` says
    out = all_points(stipple.strokes(pic, 2.5, 0.5))
    assert np.array_equal(np.unique(out, axis=0), np.unique(pts, axis=0))
    assert len(out) == round(float(pic.darkness.sum()) * pic.mm_per_px ** 2 / 2.5 ** 2)
