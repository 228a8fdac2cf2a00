"""Placement maths and pen-up travel ordering (place.py, order.py): properties with hypothesis,
and a comparison with a nearest-neighbour sort written here the way vpype's linesort does it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from vplotter.drawing import order
from vplotter.drawing import place
from vplotter.inputs.strokes import Stroke
from vplotter.drawing.place import Box, Placement

coord = st.floats(-100, 100, allow_nan=False).map(lambda v: round(v, 3))
point = st.tuples(coord, coord)


@st.composite
def strokes(draw, min_size=1, max_size=25):
    out = []
    for i in range(draw(st.integers(min_size, max_size))):
        kind = draw(st.sampled_from(["open", "open", "closed", "dot"]))
        if kind == "dot":
            pts = [draw(point)]
        else:
            pts = draw(st.lists(point, min_size=2, max_size=6))
            if kind == "closed":
                pts = pts + [pts[0]] if len(pts) >= 3 else pts
        out.append(Stroke(np.array(pts, dtype=float), line=i + 1))
    return out


def segments(ss: list[Stroke]) -> set:
    """What is drawn: unordered segments (and dots), rounded."""
    out = set()
    for s in ss:
        p = [tuple(np.round(q, 6)) for q in s.pts.tolist()]
        if len(p) == 1:
            out.add((p[0],))
        for a, b in zip(p, p[1:]):
            if a != b:
                out.add(tuple(sorted((a, b))))
    return out


def _pts(ss):
    return np.concatenate([s.pts for s in ss])


PAGE = Box(-200.0, -250.0, 200.0, 300.0)
pages = st.builds(lambda x, y, w, h: Box(x, y, x + w, y + h),
                  coord, coord, st.floats(50, 500), st.floats(50, 500))


# ------------------------------------------------------------------ placement
@given(strokes(), pages, st.floats(0, 20), st.floats(-360, 360))
def test_fit_is_inside_the_page_and_as_large_as_possible(ss, page, margin, deg):
    out = place.place(ss, Placement(fit=True, margin_mm=margin, rotate_deg=deg), page)
    box = place.extent(out)
    eps = 1e-6 * (1 + abs(page.x_max) + abs(page.y_max))
    assert box.x_min >= page.x_min + margin - eps and box.x_max <= page.x_max - margin + eps
    assert box.y_min >= page.y_min + margin - eps and box.y_max <= page.y_max - margin + eps
    room = page.size - 2 * margin
    if box.size.max() > 1e-9:   # it touches the page (less margin) on one axis at least
        assert max(box.size[0] / room[0], box.size[1] / room[1]) == pytest.approx(1, rel=1e-6)
    assert np.allclose(box.centre, page.centre, atol=eps)


@given(strokes(), pages, st.floats(10, 300), coord, coord, st.floats(0, 5))
def test_fit_on_a_polar_machine_keeps_the_corners_in_reach(ss, page, r, dx, dy, margin):
    """A page with a reach (the disc a polar arm covers): the fitted extent's corners lie
    inside both, and it is as large as that allows (a corner on the circle or an edge on
    the page)."""
    x, y = page.centre[0] + dx / 4, page.centre[1] + dy / 4
    disc = Box(page.x_min, page.y_min, page.x_max, page.y_max, (x, y, r))
    if math.hypot(*(disc.centre - (x, y))) >= r - margin:
        return                                      # the page's centre is out of reach
    out = place.place(ss, Placement(fit=True, margin_mm=margin), disc)
    box = place.extent(out)
    eps = 1e-6 * (1 + abs(page.x_max) + abs(page.y_max) + r)
    corners = np.array([[box.x_min, box.y_min], [box.x_max, box.y_min],
                        [box.x_min, box.y_max], [box.x_max, box.y_max]])
    far = np.hypot(corners[:, 0] - x, corners[:, 1] - y).max()
    assert far <= r - margin + eps
    assert box.x_min >= page.x_min + margin - eps and box.x_max <= page.x_max - margin + eps
    assert box.y_min >= page.y_min + margin - eps and box.y_max <= page.y_max - margin + eps
    room = page.size - 2 * margin
    if box.size.max() > 1e-9:
        edge = max(box.size[0] / room[0], box.size[1] / room[1])
        assert edge == pytest.approx(1, rel=1e-6) or far == pytest.approx(
            r - margin - place.REACH_IN_MM, rel=1e-6)
    assert place.outside(corners, Box(page.x_min, page.y_min, page.x_max, page.y_max,
                                      (x, y, r))) == -1


def test_outside_names_the_first_point_off_the_page_or_out_of_reach():
    disc = Box(-100, -100, 100, 100, (0.0, 0.0, 50.0))
    assert place.outside(np.array([[0, 0], [30, 30], [40, 40], [200, 0]]), disc) == 2
    assert place.outside(np.array([[0, 0], [0, 150]]), PAGE) == -1
    assert place.outside(np.array([[0, 0], [0, 350]]), PAGE) == 1


@given(strokes(), pages)
def test_fit_keeps_the_aspect(ss, page):
    before = place.extent(ss)
    after = place.extent(place.place(ss, Placement(fit=True), page))
    if before.size.min() > 1e-6:
        assert after.size[0] / after.size[1] == pytest.approx(before.size[0] / before.size[1],
                                                              rel=1e-6)


@given(strokes(), st.floats(-720, 720), st.floats(0.1, 10))
def test_scale_and_rotate_are_about_the_centre(ss, deg, s):
    box = place.extent(ss)
    A, b = place.matrix(Placement(scale=s, rotate_deg=deg), _pts(ss), PAGE)
    c = box.centre
    assert np.allclose(A @ c + b, c, atol=1e-9 * (1 + np.abs(c).max()))
    # a similarity: distances scale by s, angles are kept (det > 0: no mirror)
    assert np.allclose(A.T @ A, s * s * np.eye(2))
    assert np.linalg.det(A) > 0
    a = math.radians(deg)
    assert np.allclose(A @ [1, 0], s * np.array([math.cos(a), math.sin(a)]))  # counter-clockwise


@given(strokes(), st.sampled_from([None, "left", "center", "right"]),
       st.sampled_from([None, "top", "middle", "bottom"]), st.booleans(),
       st.floats(-50, 50), st.floats(-50, 50), st.floats(-90, 90))
def test_offset_comes_last(ss, align, valign, fit, dx, dy, deg):
    p = Placement(fit=fit, align=align, valign=valign, rotate_deg=deg, margin_mm=5)
    A0, b0 = place.matrix(p, _pts(ss), PAGE)
    A1, b1 = place.matrix(Placement(**{**p.__dict__, "offset_mm": (dx, dy)}), _pts(ss), PAGE)
    assert np.array_equal(A0, A1)
    assert np.allclose(b1 - b0, [dx, dy])


@given(strokes(), st.floats(0, 30))
def test_align_puts_the_edges_on_the_page(ss, margin):
    # on the edge to a few nanometres, and never over it (rounding included)
    box = place.extent(place.place(ss, Placement(align="left", valign="top", margin_mm=margin), PAGE))
    assert box.x_min == pytest.approx(PAGE.x_min + margin, abs=1e-8)
    assert box.y_max == pytest.approx(PAGE.y_max - margin, abs=1e-8)
    assert box.x_min >= PAGE.x_min + margin and box.y_max <= PAGE.y_max - margin
    box = place.extent(place.place(ss, Placement(align="right", valign="bottom", margin_mm=margin), PAGE))
    assert box.x_max == pytest.approx(PAGE.x_max - margin, abs=1e-8)
    assert box.y_min == pytest.approx(PAGE.y_min + margin, abs=1e-8)
    assert box.x_max <= PAGE.x_max - margin and box.y_min >= PAGE.y_min + margin


def test_identity_leaves_strokes_alone():
    ss = [Stroke(np.array([[1.0, 2.0], [3.0, 4.0]]))]
    assert place.place(ss, Placement(), PAGE) is ss


# ------------------------------------------------------------------ ordering
@given(strokes(), st.sampled_from(order.METHODS), point)
def test_ordering_never_changes_what_is_drawn(ss, method, start):
    out = order.order(ss, method, start)
    assert segments(out) == segments(ss)
    assert len(out) == len(ss)
    for s in out:                       # closed strokes stay closed, dots stay dots
        assert s.closed or len(s.pts) < 3 or not np.array_equal(s.pts[0], s.pts[-1])


def between(ss) -> float:
    """Travel between strokes only, as vpype's pen_up_length measures it."""
    return order.travel_mm(ss, ss[0].pts[0]) if ss else 0.0


@settings(max_examples=60)
@given(strokes(), point)
def test_best_is_never_longer_than_file_order_or_linesort_by_either_measure(ss, start):
    best = order.order(ss, "best", start)
    vp = [Stroke(p) for p in _linesort(ss)]
    for other in (ss, vp):
        assert order.travel_mm(best, start) <= order.travel_mm(other, start) + 1e-9
        assert between(best) <= between(other) + 1e-9


@settings(max_examples=40)
@given(strokes(), point)
def test_ordering_is_deterministic(ss, start):
    a = order.order(ss, "best", start)
    b = order.order([Stroke(s.pts.copy(), s.line) for s in ss], "best", start)
    assert [s.line for s in a] == [s.line for s in b]
    assert all(np.array_equal(x.pts, y.pts) for x, y in zip(a, b))


def test_closed_stroke_starts_at_the_vertex_nearest_the_pen():
    square = Stroke(np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], dtype=float))
    out = order.order([square], "best", (11, 11))
    assert out[0].pts[0].tolist() == [10, 10] and out[0].pts[-1].tolist() == [10, 10]
    assert segments(out) == segments([square])


def test_open_strokes_are_reversed_and_chained():
    a = Stroke(np.array([[0.0, 0], [10, 0]]), line=1)
    b = Stroke(np.array([[20.0, 0], [10, 0.01]]), line=2)     # ends next to a's end
    out = order.order([a, b], "best", (0, 0))
    assert [s.line for s in out] == [1, 2]
    assert out[1].pts[0].tolist() == [10, 0.01]                 # b drawn backwards
    assert order.joined(out, 0.05).tolist() == [False, True]
    assert order.joined(out, 0.005).tolist() == [False, False]
    assert order.travel_mm(out, (0, 0), join_mm=0.05) == 0


def test_layers_keep_their_order():
    ss = [Stroke(np.array([[x, 0.0], [x, 1]]), line=i, layer=lay)
          for i, (x, lay) in enumerate([(50, "a"), (0, "b"), (51, "a"), (1, "b")])]
    out = order.order(ss, "best", (0, 0))
    assert [s.layer for s in out] == ["a", "a", "b", "b"]
    assert order.joined([ss[0], ss[1]], 100).tolist() == [False, False]   # never across layers


def test_dots_are_not_joined():
    ss = [Stroke(np.array([[0.0, 0]])), Stroke(np.array([[0.0, 0], [1, 0]]))]
    assert not order.joined(ss, 1).any()


def _linesort(ss: list[Stroke]) -> list[np.ndarray]:
    """vpype's linesort (greedy, with reversal): the first line stays first, then always the
    nearest end of what is left (brute force here); it keeps the file order when that is not
    longer between lines."""
    lines = [s.pts for s in ss]
    out = [lines[0]]
    left = list(range(1, len(lines)))
    while left:
        at = out[-1][-1]
        d = [(math.dist(at, lines[i][0]), 0, i) for i in left] + \
            [(math.dist(at, lines[i][-1]), 1, i) for i in left]
        _, rev, i = min(d)
        left.remove(i)
        out.append(lines[i][::-1] if rev else lines[i])
    if between([Stroke(p) for p in out]) > between(ss):
        return lines
    return out


@pytest.mark.parametrize("seed", range(6))
def test_best_is_at_most_linesort(seed):
    rng = np.random.default_rng(seed)
    n = 300
    a = rng.uniform(-100, 100, (n, 2))
    ss = [Stroke(np.array([p, p + rng.normal(0, 3, 2), p + rng.normal(0, 3, 2)])) for p in a]
    vp = [Stroke(p) for p in _linesort(ss)]
    ours = order.order(ss, "best", (0, 0))
    assert order.travel_mm(ours, (0, 0)) <= order.travel_mm(vp, (0, 0))
    assert between(ours) <= between(vp)
    assert segments(ours) == segments(ss)


def _greedy_reference(ss, start):
    """Nearest neighbour with reversal by brute force: (distance², first point before last
    point, file order) decides."""
    left = list(range(len(ss)))
    at = np.asarray(start, dtype=float)
    out = []
    while left:
        cands = []
        for i in left:
            for rev, q in ((0, ss[i].pts[0]), (1, ss[i].pts[-1])):
                cands.append((float(((q - at) ** 2).sum()), rev, i))
        _, rev, i = min(cands)
        left.remove(i)
        p = ss[i].pts[::-1] if rev else ss[i].pts
        out.append((i, rev))
        at = p[-1]
    return out


@pytest.mark.parametrize("kind", ["uniform", "cluster", "starburst"])
def test_greedy_is_nearest_neighbour_on_uneven_drawings(kind):
    """The grid's dense-cell and sparse-search paths give the brute-force answer."""
    rng = np.random.default_rng(3)
    if kind == "uniform":
        a = rng.uniform(-100, 100, (400, 2))
    elif kind == "cluster":
        a = np.vstack([rng.uniform(0, 0.5, (390, 2)), rng.uniform(-190, 190, (10, 2))])
    else:
        a = np.zeros((300, 2))
    ss = []
    for i, p in enumerate(a):
        q = p + (rng.normal(0, 0.2, 2) if kind != "starburst"
                 else 80 * np.array([math.cos(i), math.sin(i)]))
        ss.append(Stroke(np.array([p, q]), line=i))
    if kind == "starburst":
        ss += [Stroke(np.array([[3.0, 3.0]]), line=300 + i) for i in range(100)]  # one spot
    ref = _greedy_reference(ss, (150.0, 150.0))
    got = order.order(ss, "greedy", (150.0, 150.0))
    assert [s.line for s in got] == [ss[i].line for i, _ in ref]
    for s, (i, rev) in zip(got, ref):
        assert np.array_equal(s.pts, ss[i].pts[::-1] if rev else ss[i].pts)
