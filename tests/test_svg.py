"""The SVG reader against the rules of issue 11 (README, section "SVG").

Geometry is checked against an independent reference computed here: dense points of the true
curve (circles, ellipses, arcs solved geometrically in the unit-circle space of the ellipse,
Béziers by de Casteljau), mapped by the affine map built here from the document's numbers; the
reader's polyline must lie within tolerance of the true curve and cover it (both ways)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vplotter.errors import InputError
from vplotter.inputs import svg

NS = ('xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
      'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"')
TOL = 0.01


def doc(body: str, size: str = 'width="100mm" height="100mm" viewBox="0 0 100 100"') -> str:
    return f'<svg {NS} {size}>{body}</svg>'


def read(tmp_path, text: str, tol: float = TOL, layers=None, name: str = "t.svg"):
    p = tmp_path / name
    p.write_text(text)
    warnings: list[str] = []
    d = svg.read(str(p), tol, layers, warnings.append)
    return d, warnings


def near(got, want) -> bool:
    return np.shape(got) == np.shape(want) and np.allclose(got, want, atol=1e-9)


def strokes(tmp_path, body: str, **kw):
    d, _ = read(tmp_path, doc(body, **kw))
    return [s.pts for s in d.strokes]


def error(tmp_path, text: str, layers=None) -> str:
    with pytest.raises(InputError) as e:
        read(tmp_path, text, layers=layers)
    msg = str(e.value)
    assert "\n" not in msg and "error:" in msg
    return msg


# ------------------------------------------------------------------ reference geometry
def seg_dist(p: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each point p (N, 2) to the polyline poly (M, 2), exactly: long segments are
    cut into pieces no longer than the mean (the same polyline), and each point is measured
    against every piece whose midpoint is near enough to hold its nearest point (k nearest
    midpoints, k doubled until the k-th is beyond that bound)."""
    p, poly = np.asarray(p, dtype=float).reshape(-1, 2), np.asarray(poly, dtype=float)
    if len(poly) == 1:
        return np.hypot(*(p - poly[0]).T)
    from scipy.spatial import cKDTree

    lengths = np.hypot(*np.diff(poly, axis=0).T)
    cap = max(float(lengths.mean()), 1e-12)
    cuts = np.maximum(1, np.ceil(lengths / cap).astype(int))
    seg = np.repeat(np.arange(len(lengths)), cuts)
    frac = (np.arange(len(seg)) - np.repeat(np.cumsum(cuts) - cuts, cuts)) / np.repeat(cuts, cuts)
    d = np.diff(poly, axis=0)
    a = poly[seg] + frac[:, None] * d[seg]
    ab = d[seg] / np.repeat(cuts, cuts)[:, None]
    half = float(np.hypot(*ab.T).max()) / 2
    tree = cKDTree(a + ab / 2)

    def exact(q, idx):          # q (n, 2), idx (n, k) pieces -> (n,) nearest distance
        aa, vv = a[idx], ab[idx]
        t = np.clip(np.sum((q[:, None] - aa) * vv, axis=2) / np.maximum(np.sum(vv * vv, axis=2), 1e-300), 0, 1)
        return np.hypot(*np.moveaxis(q[:, None] - (aa + t[..., None] * vv), 2, 0)).min(axis=1)

    out = np.empty(len(p))
    todo = np.arange(len(p))
    k = 8
    while len(todo):
        k = min(k, len(a))
        dist, idx = tree.query(p[todo], k=k)
        dist, idx = dist.reshape(len(todo), -1), idx.reshape(len(todo), -1)
        best = exact(p[todo], idx)
        done = (dist[:, -1] > best + half) | (k == len(a))
        out[todo[done]] = best[done]
        todo = todo[~done]
        k *= 2
    return out


def assert_close_both_ways(got: np.ndarray, true_dense: np.ndarray, tol: float) -> None:
    """Every output point within tol of the true curve (dense polyline: its chords are far
    shorter than tol, so their error is negligible), and every true point within tol of the
    output polyline."""
    eps = 1e-6
    assert seg_dist(got, true_dense).max() <= tol + eps
    assert seg_dist(true_dense, got).max() <= tol + eps


def affine(m: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return pts @ m[:2, :2].T + m[:2, 2]


def page_map(w_mm: float, h_mm: float, scale: float) -> np.ndarray:
    """user units -> G-code mm for a viewBox at 0 0 filling the page with this scale."""
    return np.array([[scale, 0, -w_mm / 2], [0, -scale, h_mm / 2], [0, 0, 1.0]])


def svg_matrix(a, b, c, d, e, f) -> np.ndarray:
    return np.array([[a, c, e], [b, d, f], [0, 0, 1.0]])


def true_arc(x0, y0, rx, ry, phi_deg, large, sweep, x1, y1, n=20000) -> np.ndarray:
    """Dense points of an SVG arc, solved geometrically: in the ellipse's own unit-circle
    space the two ends lie on a unit circle whose centre is on their bisector."""
    phi = math.radians(phi_deg)
    rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    to_unit = np.diag([1 / rx, 1 / ry]) @ rot.T
    p0, p1 = to_unit @ (x0, y0), to_unit @ (x1, y1)
    half = np.linalg.norm(p1 - p0) / 2
    scale = max(1.0, half)          # radii too small: scaled up until the ends fit
    p0, p1 = p0 / scale, p1 / scale
    half /= scale
    mid = (p0 + p1) / 2
    normal = np.array([-(p1 - p0)[1], (p1 - p0)[0]]) / (2 * half)
    h = math.sqrt(max(0.0, 1 - half * half))
    best = None
    for c in (mid + h * normal, mid - h * normal):
        a0 = math.atan2(*(p0 - c)[::-1])
        a1 = math.atan2(*(p1 - c)[::-1])
        d = (a1 - a0) % (2 * math.pi) if sweep else -((a0 - a1) % (2 * math.pi))
        if (abs(d) > math.pi) == bool(large) or abs(abs(d) - math.pi) < 1e-9:
            best = (c, a0, d)
            break
    c, a0, d = best
    t = a0 + d * np.linspace(0, 1, n)
    unit = c + np.column_stack((np.cos(t), np.sin(t)))
    return (np.linalg.inv(to_unit) @ (unit * scale).T).T


def true_bezier(ctrl: np.ndarray, n=5000) -> np.ndarray:
    t = np.linspace(0, 1, n)[:, None]
    pts = [np.broadcast_to(c, (n, 2)) for c in ctrl]
    while len(pts) > 1:               # de Casteljau
        pts = [(1 - t) * a + t * b for a, b in zip(pts[:-1], pts[1:])]
    return pts[0]


# ------------------------------------------------------------------ geometry
def test_default_placement_centres_the_page(tmp_path):
    (pts,) = strokes(tmp_path, '<line x1="0" y1="0" x2="100" y2="50"/>',
                     size='width="200mm" height="100mm" viewBox="0 0 100 50"')
    assert np.allclose(pts, [[-100, 50], [100, -50]])


def test_circle_under_skew_and_non_uniform_scale(tmp_path):
    d, _ = read(tmp_path, doc('<g transform="matrix(1.5 0.2 0.7 0.6 3 4)">'
                              '<circle cx="30" cy="40" r="20" transform="skewX(25)"/></g>',
                              size='width="120mm" height="100mm" viewBox="0 0 60 50"'))
    (s,) = d.strokes
    t = np.linspace(0, 2 * np.pi, 20000)
    circle = np.column_stack((30 + 20 * np.cos(t), 40 + 20 * np.sin(t)))
    m = page_map(120, 100, 2.0) @ svg_matrix(1.5, 0.2, 0.7, 0.6, 3, 4) @ \
        svg_matrix(1, 0, math.tan(math.radians(25)), 1, 0, 0)
    assert_close_both_ways(s.pts, affine(m, circle), TOL)
    assert np.array_equal(s.pts[0], s.pts[-1])
    # it starts at (cx + r, cy), as SVG says
    assert np.allclose(s.pts[0], affine(m, np.array([[50.0, 40.0]]))[0])


def test_ellipse_and_rounded_rect(tmp_path):
    d, _ = read(tmp_path, doc('<ellipse cx="50" cy="50" rx="40" ry="10" transform="rotate(30 50 50)"/>'
                              '<rect x="10" y="20" width="60" height="30" rx="8" ry="5"/>'))
    e, r = d.strokes
    m = page_map(100, 100, 1.0)
    t = np.linspace(0, 2 * np.pi, 20000)
    c, s_ = math.cos(math.radians(30)), math.sin(math.radians(30))
    ell = np.column_stack((40 * np.cos(t), 10 * np.sin(t))) @ np.array([[c, s_], [-s_, c]]) + 50
    assert_close_both_ways(e.pts, affine(m, ell), TOL)
    # the rounded rect: four quarter ellipses and four straight sides
    q = np.linspace(0, np.pi / 2, 3000)
    corners = [(62, 25, 0), (62, 45, 1), (18, 45, 2), (18, 25, 3)]
    parts = []
    for cx, cy, k in corners:   # k-th quarter, starting at angle -pi/2 + k pi/2 ... clockwise
        a = -np.pi / 2 + k * np.pi / 2 + q
        parts.append(np.column_stack((cx + 8 * np.cos(a), cy + 5 * np.sin(a))))
    ring = np.concatenate(parts + [parts[0][:1]])
    assert_close_both_ways(r.pts, affine(m, ring), TOL)
    assert np.array_equal(r.pts[0], r.pts[-1])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rx=st.floats(0.5, 60), ry=st.floats(0.5, 60), phi=st.floats(-360, 360),
       large=st.booleans(), sweep=st.booleans(),
       x1=st.floats(-50, 50), y1=st.floats(-50, 50),
       mat=st.tuples(*[st.floats(-2, 2)] * 4), tol=st.sampled_from([0.001, 0.01, 0.1]))
def test_arcs_under_any_affine_map(tmp_path, rx, ry, phi, large, sweep, x1, y1, mat, tol):
    a, b, c, d = mat
    if abs(a * d - b * c) < 0.05 or math.hypot(x1, y1) < 0.01:
        return
    body = (f'<path transform="matrix({a!r} {b!r} {c!r} {d!r} 50 50)" '
            f'd="M 0 0 A {rx!r} {ry!r} {phi!r} {int(large)} {int(sweep)} {x1!r} {y1!r}"/>')
    dr, _ = read(tmp_path, doc(body, size='width="400mm" height="400mm" viewBox="0 0 100 100"'),
                 tol=tol)
    (s,) = dr.strokes
    m = page_map(400, 400, 4.0) @ svg_matrix(a, b, c, d, 50, 50)
    true = affine(m, true_arc(0, 0, rx, ry, phi, large, sweep, x1, y1))
    assert_close_both_ways(s.pts, true, tol)
    assert np.allclose(s.pts[-1], affine(m, np.array([[x1, y1]]))[0], atol=1e-9)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(ctrl=st.lists(st.tuples(st.floats(0, 100), st.floats(0, 100)), min_size=3, max_size=4),
       mat=st.tuples(*[st.floats(-3, 3)] * 4))
def test_beziers_under_any_affine_map(tmp_path, ctrl, mat):
    a, b, c, d = mat
    if abs(a * d - b * c) < 0.05:
        return
    cmd = "Q" if len(ctrl) == 3 else "C"
    pts = " ".join(f"{x!r} {y!r}" for x, y in ctrl[1:])
    body = (f'<path transform="matrix({a!r} {b!r} {c!r} {d!r} 0 0)" '
            f'd="M {ctrl[0][0]!r} {ctrl[0][1]!r} {cmd} {pts}"/>')
    dr, _ = read(tmp_path, doc(body))
    m = page_map(100, 100, 1.0) @ svg_matrix(a, b, c, d, 0, 0)
    true = affine(m, true_bezier(np.array(ctrl, dtype=float)))
    got = np.concatenate([s.pts for s in dr.strokes])
    assert_close_both_ways(got, true, TOL)


def test_arc_flags_pick_the_four_arcs(tmp_path):
    # radius 10 through (0,0) and (10,0): the four arcs have these lengths and bulge sides
    lengths, lowest = {}, {}
    for large in (0, 1):
        for sweep in (0, 1):
            d, _ = read(tmp_path, doc(f'<path d="M 40 50 A 10 10 0 {large} {sweep} 50 50"/>'))
            (s,) = d.strokes
            lengths[large, sweep] = s.length_mm()
            lowest[large, sweep] = s.pts[:, 1].min()
    small, big = 10 * (math.pi / 3), 10 * (2 * math.pi - math.pi / 3)
    assert lengths[0, 0] == pytest.approx(small, abs=0.01)
    assert lengths[0, 1] == pytest.approx(small, abs=0.01)
    assert lengths[1, 0] == pytest.approx(big, abs=0.05)
    assert lengths[1, 1] == pytest.approx(big, abs=0.05)
    # sweep=1 runs clockwise on the screen (y down): from (40,50) to (50,50) it goes over the
    # top, i.e. to larger G-code Y; its small arc stays above the chord
    assert lowest[0, 1] == pytest.approx(0.0, abs=1e-9)
    assert lowest[0, 0] < -1


def test_zero_radius_arc_is_a_line_and_same_end_arc_is_nothing(tmp_path):
    (a,) = strokes(tmp_path, '<path d="M 0 0 A 0 5 0 0 1 10 0"/>')
    assert len(a) == 2
    (b,) = strokes(tmp_path, '<path d="M 0 0 A 5 5 0 0 1 0 0"/>')   # a dot: it goes nowhere
    assert len(b) == 1


def test_tolerance_holds_under_scaling(tmp_path):
    # the same circle, 100 times larger on the page: more points, same error
    small = strokes(tmp_path, '<circle cx="0.5" cy="0.5" r="0.4"/>',
                    size='width="1mm" height="1mm" viewBox="0 0 1 1"')[0]
    big = strokes(tmp_path, '<circle cx="0.5" cy="0.5" r="0.4"/>',
                  size='width="100mm" height="100mm" viewBox="0 0 1 1"')[0]
    assert len(big) > 5 * len(small)
    r = np.hypot(*big.T)
    assert np.all(np.abs(r - 40) <= 1e-9 + TOL)
    mids = (big[1:] + big[:-1]) / 2
    assert 40 - np.hypot(*mids.T).min() <= TOL


# ------------------------------------------------------------------ path data
def test_subpaths_dots_and_nothing(tmp_path):
    d, _ = read(tmp_path, doc('<path d="M 10 10 L 20 10 L 20 20 Z m 5 5 l 10 0 M 30 30 Z '
                              'M 40 40 l 0 0 M 50 50"/><path d=""/><path d="M 1 1"/><path/>'))
    got = [s.pts.tolist() for s in d.strokes]
    assert got == [[[-40, 40], [-30, 40], [-30, 30], [-40, 40]],   # closed: ends at its start
                   [[-35, 35], [-25, 35]],                         # m after Z: from the start
                   [[-20, 20]],                                    # M x y Z: a dot
                   [[-10, 10]]]                                    # l 0 0: a dot
    assert all(s.line == 2 and s.src == "path#2" for s in d.strokes)
    assert d.strokes[0].closed


def test_closed_curve_ends_exactly_at_its_start(tmp_path):
    (pts,) = strokes(tmp_path, '<path transform="rotate(17) scale(1.3 0.7)" '
                               'd="M 10.1 20.3 C 40 0 60 90 33.3 44.4 A 9 7 11 1 0 10.1 20.3 Z"/>')
    assert np.array_equal(pts[0], pts[-1])
    assert not np.any(np.all(pts[1:] == pts[:-1], axis=1))   # no repeated point


def test_polyline_polygon_line(tmp_path):
    d, _ = read(tmp_path, doc('<polyline points="0,0 10,0 10,10"/><polygon points="0 0 10 0 10 10"/>'
                              '<polyline points="5 5"/><polygon points="5 5"/>'
                              '<line x1="1" y1="1" x2="1" y2="1"/>'))
    got = [s.pts.tolist() for s in d.strokes]
    assert got == [[[-50, 50], [-40, 50], [-40, 40]],
                   [[-50, 50], [-40, 50], [-40, 40], [-50, 50]],
                   [[-45, 45]],          # a one-point polygon is M x y Z: a dot
                   [[-49, 49]]]          # a zero-length line: a dot


def test_shapes_with_zero_size_draw_nothing(tmp_path):
    assert strokes(tmp_path, '<rect width="0" height="5"/><circle r="0"/><ellipse rx="3" ry="0"/>') == []


# ------------------------------------------------------------------ units and viewBox
@pytest.mark.parametrize("w, mm", [("50mm", 50), ("5cm", 50), ("2in", 50.8), ("144pt", 50.8),
                                   ("12pc", 50.8), ("192px", 50.8), ("192", 50.8)])
def test_units(tmp_path, w, mm):
    d, _ = read(tmp_path, doc('<line x1="0" y1="0" x2="10" y2="0"/>',
                              size=f'width="{w}" height="{w}" viewBox="0 0 10 10"'))
    assert d.width_mm == pytest.approx(mm) and d.height_mm == pytest.approx(mm)
    assert d.strokes[0].length_mm() == pytest.approx(mm)


@pytest.mark.parametrize("size", ['viewBox="0 0 96 48"', 'width="100%" height="auto" viewBox="0 0 96 48"'])
def test_missing_size_takes_the_viewbox_in_px(tmp_path, size):
    d, _ = read(tmp_path, doc('<line x1="0" y1="0" x2="96" y2="0"/>', size=size))
    assert (d.width_mm, d.height_mm) == pytest.approx((25.4, 12.7))
    assert near(d.strokes[0].pts, [[-12.7, 6.35], [12.7, 6.35]])


def test_no_viewbox_user_unit_is_a_css_px(tmp_path):
    d, _ = read(tmp_path, doc('<line x1="0" y1="0" x2="96" y2="0"/><line x1="0" y1="0" x2="10mm" y2="0"/>',
                              size='width="50.8mm" height="25.4mm"'))
    assert d.strokes[0].length_mm() == pytest.approx(25.4)
    assert d.strokes[1].length_mm() == pytest.approx(10)


@pytest.mark.parametrize("par, corners", [
    (None, [(-25, 50), (25, -50)]),                 # xMidYMid meet: 100x200 mm page, 1 mm/unit
    ("xMinYMin meet", [(-50, 50), (0, -50)]),
    ("xMaxYMax", [(0, 50), (50, -50)]),
    ("none", [(-50, 50), (50, -50)]),
    ("xMidYMid slice", [(-50, 100), (50, -100)]),
    ("xMinYMax slice", [(-50, 150), (50, -50)]),
])
def test_preserve_aspect_ratio(tmp_path, par, corners):
    attr = f' preserveAspectRatio="{par}"' if par else ""
    d, _ = read(tmp_path, doc('<line x1="0" y1="0" x2="50" y2="100"/>',
                              size=f'width="100mm" height="100mm" viewBox="0 0 50 100"{attr}'))
    assert near(d.strokes[0].pts, [list(c) for c in corners])


def test_viewbox_offset_and_nested_svg(tmp_path):
    d, _ = read(tmp_path, doc('<line x1="10" y1="20" x2="110" y2="20"/>'
                              '<svg x="10" y="20" width="50" height="50" viewBox="0 0 5 5">'
                              '<line x1="0" y1="0" x2="5" y2="5"/></svg>',
                              size='width="100mm" height="100mm" viewBox="10 20 100 100"'))
    assert near(d.strokes[0].pts, [[-50, 50], [50, 50]])
    assert near(d.strokes[1].pts, [[-50, 50], [0, 0]])


def test_percentages_on_shapes(tmp_path):
    (pts,) = strokes(tmp_path, '<rect x="10%" y="0" width="50%" height="20%"/>',
                     size='width="200mm" height="100mm" viewBox="0 0 200 100"')
    assert near(pts[:3], [[-80, 50], [20, 50], [20, 30]])


# ------------------------------------------------------------------ visibility
def test_display_none_hides_the_subtree_and_counts_it(tmp_path):
    d, _ = read(tmp_path, doc('<g style="display:none"><path d="M0 0 L1 1"/>'
                              '<g style="display:inline"><circle r="3"/></g></g>'
                              '<rect display="none" width="3" height="3"/><path d="M 5 5 L 6 6"/>'))
    assert len(d.strokes) == 1 and d.skipped["hidden"] == 3


def test_visibility_is_inherited_and_can_be_undone(tmp_path):
    d, _ = read(tmp_path, doc('<g visibility="hidden"><path id="a" d="M0 0 L1 1"/>'
                              '<path id="b" style="visibility:visible" d="M0 0 L2 2"/>'
                              '<g><path id="c" d="M0 0 L3 3"/></g>'
                              '<g style="visibility:visible"><path id="d" d="M0 0 L4 4"/></g></g>'))
    assert [s.src for s in d.strokes] == ["b", "d"]
    assert d.skipped["hidden"] == 2
    # display:none cannot be undone below
    d, _ = read(tmp_path, doc('<g display="none"><path style="display:inline;visibility:visible" '
                              'd="M0 0 L1 1"/></g>'))
    assert d.strokes == [] and d.skipped["hidden"] == 1


def test_style_rules(tmp_path):
    css = ('<style>/* c */ .gone { display: none } #hid{visibility:hidden} ellipse {display:none} '
           'g.x path.y, #z { display : none !important } a b { display:none } '
           '@media print { path { display:none } }</style>')
    d, _ = read(tmp_path, doc(css + '<path class="a gone" d="M0 0 L1 1"/><path id="hid" d="M0 0 L1 1"/>'
                              '<ellipse rx="2" ry="2"/><path id="keep" d="M0 0 L2 2"/>'
                              '<path id="z" style="display:inline" d="M0 0 L1 1"/>'
                              '<path class="gone" style="display:inline" id="shown" d="M0 0 L3 3"/>'))
    assert [s.src for s in d.strokes] == ["keep", "shown"]
    assert d.skipped["hidden"] == 4
    d, _ = read(tmp_path, doc('<style>* { visibility: hidden }</style><path d="M0 0 L1 1"/>'))
    assert d.strokes == [] and d.skipped["hidden"] == 1


def test_clip_path_and_mask_are_ignored_and_defs_not_drawn(tmp_path):
    d, _ = read(tmp_path, doc(
        '<defs><path id="p" d="M0 0 L9 9"/><clipPath id="c"><rect width="1" height="1"/></clipPath></defs>'
        '<clipPath><path d="M0 0 L1 0"/></clipPath><mask><path d="M0 0 L1 0"/></mask>'
        '<marker><path d="M0 0 L1 0"/></marker><pattern><path d="M0 0 L1 0"/></pattern>'
        '<symbol id="s"><path d="M0 0 L1 0"/></symbol>'
        '<rect clip-path="url(#c)" mask="url(#m)" x="10" y="10" width="50" height="50"/>'))
    (s,) = d.strokes
    assert s.length_mm() == pytest.approx(200)
    assert d.skipped == {"text": 0, "image": 0, "hidden": 0}


def test_text_and_flowroot_are_drawn_images_counted(tmp_path):
    d, w = read(tmp_path, doc('<text>a</text><text><tspan>b</tspan></text><image width="1" height="1"/>'
                              '<flowRoot><flowRegion><rect width="50" height="50"/></flowRegion>'
                              '<flowPara>c</flowPara></flowRoot><path d="M0 0 L1 1"/>'))
    assert {s.src for s in d.strokes} == {"text#2", "text#3", "flowRoot#6", "path#10"}
    assert d.skipped == {"text": 0, "image": 1, "hidden": 0}
    assert w == []


# ------------------------------------------------------------------ use
def test_use_places_its_target_with_x_y_and_transform(tmp_path):
    d, w = read(tmp_path, doc('<defs><g id="g"><line x1="0" y1="0" x2="10" y2="0"/></g></defs>'
                              '<use id="u1" xlink:href="#g" x="5" y="7"/>'
                              '<use href="#g" x="5" transform="translate(20 0) scale(2)"/>'
                              '<g transform="translate(0 50)"><use href="#u1"/></g>'))
    assert w == []
    got = [s.pts.tolist() for s in d.strokes]
    assert got == [[[-45, 43], [-35, 43]],                     # x, y after the target
                   [[-20, 50], [0, 50]],                       # transform, then x
                   [[-45, -7], [-35, -7]]]                     # a use of a use
    assert [(s.src, s.line) for s in d.strokes] == [("u1", 5), ("use#6", 6), ("use#8", 8)]


def test_use_of_a_symbol_with_a_viewbox(tmp_path):
    d, _ = read(tmp_path, doc('<symbol id="s" viewBox="0 0 10 10"><line x1="0" y1="0" x2="10" y2="10"/></symbol>'
                              '<use href="#s" x="10" y="10" width="20" height="20"/>'))
    assert near(d.strokes[0].pts, [[-40, 40], [-20, 20]])


def test_use_inherits_visibility_from_the_use_not_from_defs(tmp_path):
    d, _ = read(tmp_path, doc('<defs style="display:none"><path id="p" d="M0 0 L1 1"/>'
                              '<path id="h" visibility="hidden" d="M0 0 L1 1"/></defs>'
                              '<use href="#p"/><use href="#p" visibility="hidden"/>'
                              '<use href="#h"/><g display="none"><use href="#p"/></g>'))
    assert len(d.strokes) == 1 and d.skipped["hidden"] == 3


def test_use_missing_target_warns_once_naming_it(tmp_path):
    d, w = read(tmp_path, doc('<use href="#nope"/><use href="#nope"/><use xlink:href="other.svg#x"/>'
                              '<path d="M0 0 L1 1"/>'))
    assert len(d.strokes) == 1
    assert len(w) == 2 and "'#nope'" in w[0] and "not found" in w[0] and "other.svg#x" in w[1]
    assert w[0].startswith(f"{tmp_path / 't.svg'}:1:")


def test_use_cycle_is_an_error(tmp_path):
    msg = error(tmp_path, doc('<g id="a"><use href="#a"/></g>'))
    assert "refers to itself" in msg


# ------------------------------------------------------------------ layers
LAYERED = doc('<g inkscape:groupmode="layer" id="layer1" inkscape:label="Red">'
              '<path d="M0 0 L1 1"/><g inkscape:groupmode="layer" id="sub" inkscape:label="Inner">'
              '<path d="M0 0 L2 2"/></g></g>'
              '<g inkscape:groupmode="layer" id="layer2" inkscape:label="Blue" style="display:none">'
              '<path d="M0 0 L3 3"/></g>'
              '<g inkscape:groupmode="layer" id="layer3"><path d="M0 0 L4 4"/></g>'
              '<path id="loose" d="M0 0 L5 5"/>')


def test_layers_are_listed_with_visibility(tmp_path):
    d, _ = read(tmp_path, LAYERED)
    assert d.layers == [{"id": "layer1", "label": "Red", "visible": True},
                        {"id": "sub", "label": "Inner", "visible": True},
                        {"id": "layer2", "label": "Blue", "visible": False},
                        {"id": "layer3", "label": "layer3", "visible": True}]
    assert [s.layer for s in d.strokes] == ["Red", "Inner", "layer3", None]
    assert d.skipped["hidden"] == 1


def test_layer_selection_by_label_or_id(tmp_path):
    d, _ = read(tmp_path, LAYERED, layers=["Red"])
    assert [s.layer for s in d.strokes] == ["Red", "Inner"]
    d, _ = read(tmp_path, LAYERED, layers=["layer3", "sub"])
    assert [s.layer for s in d.strokes] == ["Inner", "layer3"]
    d, w = read(tmp_path, LAYERED, layers=["Blue"])
    assert d.strokes == [] and "hidden" in w[0]
    msg = error(tmp_path, LAYERED, layers=["Green"])
    assert "'Green'" in msg and "'Red'" in msg and "'Blue'" in msg


# ------------------------------------------------------------------ errors
@pytest.mark.parametrize("text, where, what", [
    ('<svg xmlns="http://www.w3.org/2000/svg" width="1mm" height="1mm">\n <path d="M0 0"</svg>',
     ":2:", "not well-formed"),
    ("", ":1:1:", "not well-formed"),
    ('<svg xmlns="http://www.w3.org/2000/svg"><path d="M0 0 L1 1"/></svg>', ":1:1:", "size"),
    ('<svg xmlns="http://www.w3.org/2000/svg" width="10mm"><path d="M0 0 L1 1"/></svg>', ":1:1:", "size"),
    ('<html/>', ":1:1:", "not an SVG"),
    (doc('\n<path d="M 0 0 L 1 X"/>'), ":2:1:", "<path> d:"),
    (doc('<path d="L 1 1"/>'), ":1:", "<path> d:"),
    (doc('<circle r="-1"/>'), ":1:", "negative"),
    (doc('<rect width="abc" height="1"/>'), ":1:", "not a length"),
    (doc('<polyline points="1 2 3"/>'), ":1:", "odd number"),
    (doc('<line x1="3em2"/>'), ":1:", "line"),
    (doc('<line x1="1e999"/>'), ":1:", "too large"),
    (doc('<polygon points="1 1 1e400 2"/>'), ":1:", "too large"),
    (doc('', size='width="10furlong" height="1mm" viewBox="0 0 1 1"'), ":1:1:", "unit"),
    (doc('', size='width="10mm" height="1mm" viewBox="0 0 0 1"'), ":1:1:", "viewBox"),
    (doc('', size='width="-10mm" height="1mm" viewBox="0 0 1 1"'), ":1:1:", "above 0"),
    (doc('', size='width="10mm" height="1mm" viewBox="0 0 1 1" preserveAspectRatio="middle"'),
     ":1:1:", "preserveAspectRatio"),
])
def test_errors_are_one_line_at_the_place(tmp_path, text, where, what):
    msg = error(tmp_path, text)
    assert msg.startswith(str(tmp_path / "t.svg") + where), msg
    assert what in msg


def test_file_errors(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        svg.read(str(tmp_path / "missing.svg"), TOL)
    with pytest.raises(InputError, match="directory"):
        svg.read(str(tmp_path), TOL)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(d=st.text(alphabet="MmLlHhVvCcSsQqTtAaZz0123456789.,-+eE \n", max_size=40),
       attr=st.sampled_from(["d", "transform", "points", "viewBox", "width", "r", "style"]))
def test_arbitrary_values_raise_only_input_error(tmp_path, d, attr):
    tag = {"d": "path", "points": "polygon", "r": "circle"}.get(attr, "rect")
    text = doc(f'<{tag} {attr}="{d}" width="1" height="1" r="1"/>') if attr != "viewBox" else \
        f'<svg {NS} viewBox="{d}"><path d="M0 0 L1 1"/></svg>'
    try:
        dr, _ = read(tmp_path, text)
    except InputError as e:
        assert "\n" not in str(e)
        return
    for s in dr.strokes:
        assert s.pts.ndim == 2 and s.pts.shape[1] == 2 and len(s.pts) >= 1
        assert np.all(np.isfinite(s.pts))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(pts=st.lists(st.tuples(st.integers(-50, 50), st.integers(-50, 50)), min_size=2, max_size=8),
       closed=st.booleans())
def test_relative_and_absolute_path_data_agree(tmp_path, pts, closed):
    absolute = "M " + " L ".join(f"{x} {y}" for x, y in pts) + (" Z" if closed else "")
    rel = [f"m {pts[0][0]} {pts[0][1]}"] + [f"l {x - px} {y - py}" for (px, py), (x, y) in zip(pts, pts[1:])]
    relative = " ".join(rel) + (" z" if closed else "")
    a = strokes(tmp_path, f'<path d="{absolute}"/>')
    b = strokes(tmp_path, f'<path d="{relative}"/>')
    assert len(a) == len(b) == 1 and np.allclose(a[0], b[0], atol=1e-9)
    if closed:
        assert np.array_equal(a[0][0], a[0][-1])


# ------------------------------------------------------------------ the samples
SAMPLES = __import__("pathlib").Path(__file__).resolve().parent.parent / "svg_samples"


def sample(name: str, layers=None):
    warnings: list[str] = []
    return svg.read(str(SAMPLES / name), TOL, layers, warnings.append), warnings


def bbox(pts: np.ndarray) -> list[float]:
    return [*pts.min(axis=0), *pts.max(axis=0)]


def test_sample_inkscape_layers():
    d, w = sample("inkscape_layers.svg")
    assert (d.width_mm, d.height_mm) == (210, 148)
    assert [(x["label"], x["visible"]) for x in d.layers] == [
        ("Frame", True), ("Arcs", True), ("Stars", True), ("Construction", True), ("Sketch", False)]
    # the title is drawn; the flowRoot sits in the hidden layer
    assert d.skipped == {"text": 0, "image": 0, "hidden": 5}
    assert w == []           # the bundled sample draws without a warning (missing <use>: below)
    by = {}
    for s in d.strokes:
        by.setdefault(s.src, []).append(s)
    assert list(by) == ["frame", "sun", "title", "arcs", "skewed-arc", "skewed-circle", "star1", "star2",
                        "curves", "stipple", "shown-again"]
    assert [len(s.pts) for s in by["stipple"]] == [1, 1, 1, 1]
    assert by["star1"][0].layer == "Stars" and by["frame"][0].layer == "Frame"
    # the rotated ellipse: its bounding box, computed from its axes (page centre 105, 74)
    c, s_ = math.cos(math.radians(20)), math.sin(math.radians(20))
    hx, hy = math.hypot(14 * c, 9 * s_), math.hypot(14 * s_, 9 * c)
    assert bbox(by["sun"][0].pts) == pytest.approx([65 - hx, 39 - hy, 65 + hx, 39 + hy], abs=TOL)
    # the first star's eye: circle (0, -1) r 1.2 placed at (40, 110) in a layer moved down 4
    eye = by["star1"][1].pts
    assert np.hypot(*(eye - (40 - 105, 74 - 113)).T) == pytest.approx(1.2, abs=TOL)
    d, _ = sample("inkscape_layers.svg", ["Stars"])
    assert {s.src for s in d.strokes} == {"star1", "star2"}


def test_sample_units_symbols():
    d, w = sample("units_symbols.svg")
    assert w == [] and d.layers == []
    assert (d.width_mm, d.height_mm) == pytest.approx((152.4, 101.6))
    assert d.skipped == {"text": 0, "image": 1, "hidden": 2}
    # 600 x 300 user units in 6 x 4 in: 0.254 mm each, letterboxed 12.7 mm from the top
    first_gear = d.strokes[1].pts      # symbol circle r 8 in a -10..10 viewBox, 60 units wide
    centre = (70 * 0.254 - 76.2, 50.8 - 12.7 - 70 * 0.254)
    assert np.hypot(*(first_gear - centre).T) == pytest.approx(24 * 0.254, abs=TOL)
    assert {s.src for s in d.strokes} >= {"rect#21", "circle#24", "polygon#18"}


def test_sample_generative():
    d, w = sample("generative.svg")
    assert w == [] and [x["label"] for x in d.layers] == ["1 flow", "2 stipple", "3 circles"]
    dots = [s for s in d.strokes if len(s.pts) == 1]
    assert len(dots) == 400 and all(s.layer == "2 stipple" for s in dots)
    assert all(np.all(np.abs(s.pts) <= 100) for s in d.strokes)


def test_svgz_is_read_and_a_broken_one_is_one_error(tmp_path):
    import gzip

    p = tmp_path / "t.svgz"
    p.write_bytes(gzip.compress(doc('<path d="M0 0 L1 1"/>').encode()))
    assert len(svg.read(str(p), TOL).strokes) == 1
    p.write_bytes(gzip.compress(doc('<path d="M0 0 L1 1"/>').encode())[:40])
    with pytest.raises(InputError, match="error: not a valid gzip"):
        svg.read(str(p), TOL)
