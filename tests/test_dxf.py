"""The DXF reader (issue 23) and hostile input files.

DXFs are built with ezdxf here; the geometry read back is checked against the analytic shape
(circles, arcs, bulge arcs, ellipses through their own equations, block transforms applied to
them by matrices built here), within the chord tolerance. Text is checked against the box its
height, alignment and the Hershey font's advance give. Hostile SVGs (entity bombs, external
entities and DTDs) and broken DXFs must stop with one line and exit 2."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

ezdxf = pytest.importorskip("ezdxf")

from vplotter.cli import main  # noqa: E402
from vplotter.errors import InputError  # noqa: E402
from vplotter.inputs import dxf, dxf_text, svg  # noqa: E402
from vplotter.inputs import text as hershey  # noqa: E402

TOL = 0.01


def new():
    doc = ezdxf.new("R2010", units=4)            # ezdxf.new says metres by default
    return doc, doc.modelspace()


def read(tmp_path, doc, tol=TOL, layers=None, centre=False, name="t.dxf"):
    p = tmp_path / name
    doc.saveas(p)
    warnings: list[str] = []
    d = dxf.read(str(p), tol, layers, warnings.append, centre=centre)
    return d, warnings


def pts_of(tmp_path, doc, **kw):
    d, _ = read(tmp_path, doc, **kw)
    return [s.pts for s in d.strokes]


def chord_mids(p: np.ndarray) -> np.ndarray:
    return (p[1:] + p[:-1]) / 2


def within_circle(p, c, r, tol=TOL):
    """Every vertex on the circle, every chord's middle within tol inside it."""
    d = np.hypot(*(p - c).T)
    m = np.hypot(*(chord_mids(p) - c).T)
    return np.allclose(d, r, atol=1e-9) and (r - m).max() <= tol + 1e-9


def run(capsys, argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err + out
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == (0 if code == 0 else 1), err
    return code, out, err


# ------------------------------------------------------------------ curves
def test_circle_and_arc_within_tolerance(tmp_path):
    doc, msp = new()
    msp.add_circle((10, 20), 30)
    msp.add_arc((-5, 5), 12, 30, 300)
    circle, arc = pts_of(tmp_path, doc)
    assert within_circle(circle, (10, 20), 30) and (circle[0] == circle[-1]).all()
    assert within_circle(arc, (-5, 5), 12)
    a0, a1 = math.radians(30), math.radians(300)
    assert np.allclose(arc[0], (-5 + 12 * math.cos(a0), 5 + 12 * math.sin(a0)))
    assert np.allclose(arc[-1], (-5 + 12 * math.cos(a1), 5 + 12 * math.sin(a1)))
    ang = np.unwrap(np.arctan2(arc[:, 1] - 5, arc[:, 0] + 5))
    assert (np.diff(ang) > 0).all()                 # counter-clockwise


def test_arc_through_zero_degrees_and_mirrored_extrusion(tmp_path):
    doc, msp = new()
    msp.add_arc((0, 0), 10, 350, 10)
    msp.add_circle((10, 0), 2, dxfattribs={"extrusion": (0, 0, -1)})
    arc, circle = pts_of(tmp_path, doc)
    ang = np.degrees(np.arctan2(arc[:, 1], arc[:, 0]))
    assert np.abs(ang).max() <= 10 + 1e-9 and len(arc) > 3   # the 20 degrees, not 340
    assert within_circle(circle, (-10, 0), 2)      # OCS x points the other way


@settings(max_examples=30)
@given(b=st.floats(-4, 4).filter(lambda b: abs(b) > 0.01), angle=st.floats(0, 360))
def test_bulge_arcs(tmp_path_factory, b, angle):
    tmp_path = tmp_path_factory.mktemp("bulge")
    p = np.array([3.0, -2.0])
    q = p + 20 * np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle))])
    doc, msp = new()
    msp.add_lwpolyline([(*p, b), (*q, 0)], format="xyb")
    (pts,) = pts_of(tmp_path, doc)
    assert np.allclose(pts[0], p) and np.allclose(pts[-1], q)
    # the arc's middle lies b x chord / 2 from the chord's middle, right of p->q for b > 0
    d = (q - p) / 20
    apex = (p + q) / 2 + np.array([d[1], -d[0]]) * b * 10
    # the circle through p, q and the apex
    a = np.array([2 * (q - p), 2 * (apex - p)])
    c = np.linalg.solve(a, [q @ q - p @ p, apex @ apex - p @ p])
    r = float(np.hypot(*(p - c)))
    assert within_circle(pts, c, r)
    assert np.hypot(*(pts - apex).T).min() < TOL + 1e-6 or np.abs(
        np.hypot(*(chord_mids(pts) - apex).T)).min() < 2 * TOL
    u, v = pts[1:-1] - pts[:-2], pts[2:] - pts[1:-1]
    turn = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    assert (np.sign(turn[np.abs(turn) > 1e-12]) == np.sign(b)).all()


def test_closed_polylines_and_3d_polyline(tmp_path):
    doc, msp = new()
    msp.add_lwpolyline([(0, 0), (10, 0), (10, 10)], close=True)
    msp.add_polyline2d([(0, 0, 0, 0, 1), (10, 0, 0, 0, 0)], format="xyseb", close=True)
    msp.add_polyline3d([(0, 0, 5), (1, 2, 3), (4, 5, 6)])
    lw, p2, p3 = pts_of(tmp_path, doc)
    assert lw.tolist() == [[0, 0], [10, 0], [10, 10], [0, 0]]
    assert within_circle(p2[:-1], (5, 0), 5) and np.allclose(p2[-1], (0, 0))
    assert p3.tolist() == [[0, 0], [1, 2], [4, 5]]


def test_ellipse(tmp_path):
    doc, msp = new()
    msp.add_ellipse((5, 6), major_axis=(30 * math.cos(0.5), 30 * math.sin(0.5)), ratio=0.4)
    msp.add_ellipse((0, 0), major_axis=(10, 0), ratio=0.5, start_param=0.3, end_param=2.0)
    full, part = pts_of(tmp_path, doc)
    rot = np.array([[math.cos(0.5), -math.sin(0.5)], [math.sin(0.5), math.cos(0.5)]])
    for p, c, m, a, b in ((full, (5, 6), rot, 30, 12), (part, (0, 0), np.eye(2), 10, 5)):
        u = (p - c) @ m                             # into the ellipse's axes
        assert np.allclose((u[:, 0] / a) ** 2 + (u[:, 1] / b) ** 2, 1, atol=1e-9)
        # chord middles: inside by at most tol (measured along the normal, near enough)
        v = (chord_mids(p) - c) @ m
        k = np.sqrt((v[:, 0] / a) ** 2 + (v[:, 1] / b) ** 2)
        assert ((1 - k) * b).max() <= TOL
    assert np.allclose(part[0], (10 * math.cos(0.3), 5 * math.sin(0.3)))
    assert np.allclose(part[-1], (10 * math.cos(2.0), 5 * math.sin(2.0)))


def test_spline_through_its_fit_points(tmp_path):
    fit = [(0, 0), (10, 8), (20, -3), (35, 5), (40, 0)]
    doc, msp = new()
    msp.add_spline(fit)
    (pts,) = pts_of(tmp_path, doc)
    for f in fit:
        assert np.hypot(*(pts - f).T).min() < 0.05
    assert np.allclose(pts[0], fit[0]) and np.allclose(pts[-1], fit[-1])


# ------------------------------------------------------------------ blocks
def test_insert_scale_rotation_nested_and_base_point(tmp_path):
    doc, msp = new()
    inner = doc.blocks.new("INNER", base_point=(1, 1))
    inner.add_circle((1, 1), 1)                     # the unit circle about the base point
    outer = doc.blocks.new("OUTER")
    outer.add_blockref("INNER", (5, 0), dxfattribs={"xscale": 2, "yscale": 2})
    msp.add_blockref("OUTER", (100, 50), dxfattribs={"xscale": 3, "yscale": 1.5,
                                                     "rotation": 30})
    (pts,) = pts_of(tmp_path, doc)
    a = math.radians(30)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    m = rot @ np.diag([3, 1.5]) @ np.diag([2, 2])   # unit circle -> drawing
    centre = np.array([100, 50]) + rot @ np.diag([3, 1.5]) @ np.array([5, 0])
    u = np.linalg.solve(m, (pts - centre).T).T
    assert np.allclose(np.hypot(*u.T), 1, atol=1e-9)
    # chord middles of the transformed curve stay within tol of it: the local tolerance is
    # divided by the largest stretch (6)
    mid = np.linalg.solve(m, (chord_mids(pts) - centre).T).T
    assert ((1 - np.hypot(*mid.T)) * 6).max() <= TOL


def test_minsert_grid_and_missing_block(tmp_path):
    doc, msp = new()
    b = doc.blocks.new("DOT")
    b.add_line((0, 0), (1, 0))
    ref = msp.add_blockref("DOT", (0, 0))
    ref.dxf.row_count, ref.dxf.column_count = 2, 3
    ref.dxf.row_spacing, ref.dxf.column_spacing = 10, 20
    msp.add_blockref("NOPE", (0, 0))
    d, warnings = read(tmp_path, doc)
    starts = sorted(tuple(s.pts[0]) for s in d.strokes)
    assert starts == [(x, y) for x in (0, 20, 40) for y in (0, 10)]
    assert len(warnings) == 1 and "no block 'NOPE'" in warnings[0]


def test_insert_units_and_centring(tmp_path):
    doc, msp = new()
    doc.header["$INSUNITS"] = 1                     # inches
    msp.add_line((0, 0), (1, 0))
    msp.add_line((0, 0), (0, 2))
    d, _ = read(tmp_path, doc)
    assert np.allclose(d.strokes[0].pts, [[0, 0], [25.4, 0]], atol=1e-9)
    doc.header["$INSUNITS"] = 5                     # cm
    assert read(tmp_path, doc)[0].strokes[0].length_mm() == pytest.approx(10)
    doc.header["$INSUNITS"] = 0                     # unitless: mm
    d, _ = read(tmp_path, doc, centre=True)
    assert d.strokes[1].pts.tolist() == [[-0.5, -1], [-0.5, 1]]
    assert (d.width_mm, d.height_mm) == (1, 2)


def test_self_inserting_blocks_refused(tmp_path, capsys, config_path):
    doc, msp = new()
    a = doc.blocks.new("A")
    b = doc.blocks.new("B")
    a.add_blockref("B", (0, 0))
    b.add_blockref("A", (1, 0))
    msp.add_blockref("A", (0, 0))
    p = tmp_path / "loop.dxf"
    doc.saveas(p)
    code, _, err = run(capsys, ["--config", config_path, "convert", p, "-o", tmp_path / "o.ngc"])
    assert code == 2 and "block 'A' inserts itself (A -> B -> A" in err
    doc, msp = new()
    doc.blocks.new("SELF").add_blockref("SELF", (0, 0))
    msp.add_blockref("SELF", (0, 0))
    with pytest.raises(InputError, match="block 'SELF' inserts itself"):
        read(tmp_path, doc)


def test_expansion_bound(tmp_path, monkeypatch):
    doc, msp = new()
    doc.blocks.new("L0").add_line((0, 0), (1, 0))
    for k in range(1, 8):                           # 10^7 lines once expanded
        blk = doc.blocks.new(f"L{k}")
        for i in range(10):
            blk.add_blockref(f"L{k - 1}", (i, 0))
    msp.add_blockref("L7", (0, 0))
    with pytest.raises(InputError, match=f"more than {dxf.MAX_ENTITIES} entities"):
        read(tmp_path, doc)


# ------------------------------------------------------------------ layers and colours
def test_layers_are_pens_with_colours(tmp_path):
    doc, msp = new()
    doc.layers.add("RED", color=1)
    doc.layers.add("WHITE", color=7)
    lay = doc.layers.add("TRUE")
    lay.rgb = (1, 2, 3)
    doc.layers.add("ICE", color=4).freeze()
    doc.layers.add("DARK", color=5).off()
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "RED"})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "WHITE"})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "TRUE"})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "RED", "true_color": 0x102030})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "RED", "color": 3})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "ICE"})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "DARK"})
    msp.add_line((0, 0), (1, 0), dxfattribs={"layer": "Defpoints"})
    blk = doc.blocks.new("B")
    blk.add_line((0, 0), (1, 0), dxfattribs={"layer": "0", "color": 0})   # BYBLOCK, layer 0
    blk.add_line((0, 0), (1, 0), dxfattribs={"layer": "WHITE"})
    msp.add_blockref("B", (0, 0), dxfattribs={"layer": "RED", "color": 5})
    msp.add_blockref("B", (0, 0), dxfattribs={"layer": "ICE"})           # all hidden
    d, _ = read(tmp_path, doc)
    got = [(s.layer, s.pen, s.colour) for s in d.strokes]
    assert got == [("RED", "RED", "#ff0000"), ("WHITE", "WHITE", "#000000"),
                   ("TRUE", "TRUE", "#010203"), ("RED", "RED", "#102030"),
                   ("RED", "RED", "#00ff00"), ("RED", "RED", "#0000ff"),
                   ("WHITE", "WHITE", "#000000")]
    assert d.skipped["hidden"] == 4
    vis = {lay["label"]: lay["visible"] for lay in d.layers}
    assert vis == {"RED": True, "WHITE": True, "TRUE": True, "ICE": False, "DARK": False,
                   "Defpoints": False}
    d, warnings = read(tmp_path, doc, layers=["white"])        # names are not case-sensitive
    assert [s.layer for s in d.strokes] == ["WHITE", "WHITE"]
    d, warnings = read(tmp_path, doc, layers=["ICE"])
    assert d.strokes == [] and "frozen or off" in warnings[0]
    with pytest.raises(InputError, match="no layer 'NOPE'"):
        read(tmp_path, doc, layers=["NOPE"])


def test_unsupported_counted_in_one_warning(tmp_path):
    doc, msp = new()
    msp.add_line((0, 0), (1, 0))
    for _ in range(2):
        h = msp.add_hatch()
        h.paths.add_polyline_path([(0, 0), (1, 0), (1, 1)])
    msp.add_point((3, 3))
    msp.add_3dface([(0, 0), (1, 0), (1, 1)])
    d, warnings = read(tmp_path, doc)
    assert len(d.strokes) == 1 and len(warnings) == 1
    assert "not drawn: 2 HATCH, 1 3DFACE, 1 POINT" in warnings[0]
    assert d.skipped["other"] == 4


# ------------------------------------------------------------------ text
def box_of(strokes) -> np.ndarray:
    p = np.concatenate([s.pts for s in strokes])
    return np.array([*p.min(axis=0), *p.max(axis=0)])


def test_text_inside_its_box(tmp_path):
    from ezdxf.enums import TextEntityAlignment

    doc, msp = new()
    h = 5.0
    size = h * dxf_text.SIZE_PER_HEIGHT             # the height is the font size
    cap = size * hershey.CAP_HEIGHT
    adv = hershey.layout("Hello", size).advance
    fm = hershey.metrics()
    msp.add_text("Hello", height=h, dxfattribs={"insert": (10, 20)})
    d, _ = read(tmp_path, doc)
    x0, y0, x1, y1 = box_of(d.strokes)
    assert x0 >= 10 - 1e-9 and x1 <= 10 + adv + 1e-9 and x1 > 10 + 0.8 * adv
    assert y0 >= 20 + fm.descent * size - 1e-9 and y1 <= 20 + fm.ascent * size + 1e-9
    assert y1 == pytest.approx(20 + cap)            # the capital H
    # rotated 90 degrees, width factor 2, centred on the alignment point, top-aligned
    doc, msp = new()
    t = msp.add_text("Hello", height=h, rotation=90, dxfattribs={"width": 2})
    t.set_placement((0, 0), align=TextEntityAlignment.TOP_CENTER)
    d, _ = read(tmp_path, doc)
    x0, y0, x1, y1 = box_of(d.strokes)
    assert y0 == pytest.approx(-adv, abs=0.3 * adv) and y1 == pytest.approx(adv, abs=0.3 * adv)
    assert -(y0 + y1) / 2 == pytest.approx(0, abs=0.1 * adv)
    assert x0 == pytest.approx(0) and x1 <= cap - fm.descent * size + 1e-9  # top on the point
    # fit between two points: as long as they are apart
    doc, msp = new()
    t = msp.add_text("Hello", height=h)
    t.set_placement((0, 0), (100, 0), align=TextEntityAlignment.FIT)
    d, _ = read(tmp_path, doc)
    x0, y0, x1, y1 = box_of(d.strokes)
    assert 90 < x1 - x0 <= 100 + 1e-9 and y1 == pytest.approx(cap)


def test_every_text_in_its_box(tmp_path):
    """Many TEXTs (heights, rotations, the left/center/right x baseline/bottom/middle/top
    alignments, descenders): each draws, and each lies in its font size x advance box, in its
    own frame, shifted as its alignment says."""
    from ezdxf.enums import TextEntityAlignment as A

    rng = np.random.default_rng(5)
    doc, msp = new()
    want = {}
    fm = hershey.metrics()
    for k, (h, v) in enumerate(zip("LCR" * 4, ["BASELINE"] * 3 + ["BOTTOM"] * 3 + ["MIDDLE"] * 3
                                   + ["TOP"] * 3)):
        content = ["Ag", "typography", "HELLO 42", "jQ|y"][k % 4]
        height, rot = float(rng.uniform(1, 20)), float(rng.uniform(0, 360))
        p = rng.uniform(-500, 500, 2)
        name = {"L": "LEFT", "C": "CENTER", "R": "RIGHT"}[h]
        align = getattr(A, "LEFT" if (name, v) == ("LEFT", "BASELINE") else f"{v}_{name}"
                        if v != "BASELINE" else name)
        t = msp.add_text(content, height=height, rotation=rot)
        t.set_placement(tuple(p), align=align)
        size = height * dxf_text.SIZE_PER_HEIGHT
        adv = hershey.layout(content, size).advance
        cap = size * hershey.CAP_HEIGHT
        dx = {"L": 0, "C": -adv / 2, "R": -adv}[h]
        dy = {"BASELINE": 0, "BOTTOM": -fm.descent * size, "MIDDLE": -cap / 2, "TOP": -cap}[v]
        want[t.dxf.handle] = (p, rot, dx, dy, adv, size)
    d, _ = read(tmp_path, doc)
    by = {}
    for s in d.strokes:
        by.setdefault(s.src.split()[-1], []).append(s.pts)
    assert set(by) == set(want)
    for handle, (p, rot, dx, dy, adv, size) in want.items():
        a = math.radians(rot)
        back = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        q = (np.concatenate(by[handle]) - p) @ back          # into the text's frame
        assert q[:, 0].min() >= dx - 1e-6 and q[:, 0].max() <= dx + adv + 1e-6
        assert q[:, 1].min() >= dy + fm.descent * size - 1e-6
        assert q[:, 1].max() <= dy + fm.ascent * size + 1e-6


def test_mtext_lines_and_attachment(tmp_path):
    doc, msp = new()
    h = 4.0
    size = h * dxf_text.SIZE_PER_HEIGHT
    cap = size * hershey.CAP_HEIGHT
    m = msp.add_mtext("FIRST LINE\\PSecond", dxfattribs={"char_height": h, "insert": (50, 50),
                                                         "attachment_point": 5})
    assert m.plain_text() == "FIRST LINE\nSecond"
    d, _ = read(tmp_path, doc)
    x0, y0, x1, y1 = box_of(d.strokes)
    adv = hershey.layout("FIRST LINE", size).advance
    assert (x0 + x1) / 2 == pytest.approx(50, abs=0.05 * adv)       # middle centre
    total = cap + 5 / 3 * cap
    assert y1 == pytest.approx(50 + total / 2)                       # F's top
    assert y0 >= 50 - total / 2 + hershey.metrics().descent * size - 1e-9
    # top left, rotated 90: the text runs up from the insertion point, lines to its right
    doc, msp = new()
    msp.add_mtext("ab\\Pcd", dxfattribs={"char_height": h, "insert": (0, 0), "rotation": 90})
    d, _ = read(tmp_path, doc)
    x0, y0, x1, y1 = box_of(d.strokes)
    assert x0 > 0 and y0 >= -1e-9 and x1 <= cap * 8 / 3 - hershey.metrics().descent * size


def test_mtext_wraps_at_its_width(tmp_path):
    doc, msp = new()
    words = "one two three four five six seven eight"
    msp.add_mtext(words, dxfattribs={"char_height": 2.0, "insert": (0, 0), "width": 30})
    d, _ = read(tmp_path, doc)
    x0, y0, x1, y1 = box_of(d.strokes)
    assert x1 - x0 <= 30 and y1 - y0 > 2.0            # wrapped (unwrapped: about 40 mm)


def test_text_in_block_with_attributes_and_missing_glyphs(tmp_path):
    doc, msp = new()
    blk = doc.blocks.new("TAG")
    blk.add_text("HELD", height=2, dxfattribs={"insert": (0, 0)})
    blk.add_attdef("NAME", insert=(0, -5), height=2)
    ref = msp.add_blockref("TAG", (100, 0), dxfattribs={"xscale": 2, "yscale": 2})
    ref.add_attrib("NAME", "Zoë ☃", insert=(100, -10), dxfattribs={"height": 2})
    ref.add_attrib("HIDE", "not shown", insert=(100, -20), dxfattribs={"flags": 1})
    d, warnings = read(tmp_path, doc)
    srcs = {s.src.split(" > ")[-1].split()[0] for s in d.strokes}
    assert srcs == {"TEXT", "ATTRIB"}
    text = [s for s in d.strokes if s.src.endswith(tuple("0123456789ABCDEF")) and "TEXT" in s.src]
    x0, y0, x1, y1 = box_of(text)
    cap = 2 * dxf_text.SIZE_PER_HEIGHT * hershey.CAP_HEIGHT
    assert x0 >= 100 - 1e-9 and y1 == pytest.approx(2 * cap)       # scaled by the block
    assert len(warnings) == 1 and "'☃'" in warnings[0] and "'ë'" in warnings[0]


def test_point_bound_and_non_finite(tmp_path):
    doc, msp = new()
    msp.add_circle((0, 0), 1e15)                    # chords of 0.01 mm: far too many
    with pytest.raises(InputError, match=f"more than {dxf.MAX_POINTS} points"):
        read(tmp_path, doc)
    doc, msp = new()
    doc.blocks.new("B").add_line((0, 0), (10, 0))
    msp.add_blockref("B", (0, 0), dxfattribs={"xscale": 1e308, "yscale": 1e308})
    msp.add_line((0, 0), (5, 0))
    # issue 33: an entity whose coordinates overflow is skipped and counted, not the file
    d, warnings = read(tmp_path, doc)
    assert [s.pts.tolist() for s in d.strokes] == [[[0, 0], [5, 0]]]
    assert len(warnings) == 1
    assert "1 broken entity not drawn: 1 with values that are not finite (INSERT" in warnings[0]
    assert "> LINE" in warnings[0]


# ------------------------------------------------------------------ bad files, CLI
@pytest.mark.parametrize("content", [b"", b"hello\nworld\n", bytes(range(256)) * 20,
                                     b"0\nSECTION\n2\nENTITIES\n0\nLINE\n10\n", "trunc", "bin"])
def test_bad_dxf_one_line_exit_2(tmp_path, capsys, config_path, content):
    if content in ("trunc", "bin"):
        doc, msp = new()
        msp.add_line((0, 0), (1, 0))
        doc.saveas(tmp_path / "ok.dxf", fmt="bin" if content == "bin" else "asc")
        data = (tmp_path / "ok.dxf").read_bytes()
        content = data[:len(data) // 2]
    p = tmp_path / "bad.dxf"
    p.write_bytes(content)
    code, _, err = run(capsys, ["--config", config_path, "estimate", p])
    assert code == 2 and err.count("\n") <= 2 and f"{p}: error:" in err
    assert "StopIteration" not in err            # a truncated file says so in words


def test_convert_info_and_binary_dxf(tmp_path, capsys, config_path):
    doc, msp = new()
    doc.layers.add("RED", color=1)
    msp.add_circle((0, 0), 40, dxfattribs={"layer": "RED"})
    msp.add_text("Hi", height=10, dxfattribs={"insert": (-20, -5)})
    p = tmp_path / "d.dxf"
    doc.saveas(p)
    out = tmp_path / "d.ngc"
    code, _, _ = run(capsys, ["--config", config_path, "convert", p, "-o", out])
    assert code == 0 and out.read_text().count("G1") > 50
    code, text, _ = run(capsys, ["--config", config_path, "info", "--json", p])
    import json

    info = json.loads(text)
    assert code == 0 and info["width_mm"] == pytest.approx(80) and info["strokes"] > 2
    assert [lay["label"] for lay in info["layers"]] == ["RED", "0"]
    doc.saveas(tmp_path / "b", fmt="bin")               # binary, no suffix: found by content
    code, text, _ = run(capsys, ["--config", config_path, "info", tmp_path / "b"])
    assert code == 0 and ": DXF, 80 x" in text
    code, _, _ = run(capsys, ["--config", config_path, "preview", p, "-o", tmp_path / "p.svg",
                              "--layer", "RED"])
    assert code == 0


# ------------------------------------------------------------------ hostile SVGs
SVG = '<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="10mm">{}</svg>'


def svg_error(tmp_path, text: str) -> str:
    p = tmp_path / "h.svg"
    p.write_text(text)
    with pytest.raises(InputError) as e:
        svg.read(str(p), TOL, warn=lambda m: None)
    msg = str(e.value)
    assert "\n" not in msg and f"{p}:" in msg and "error:" in msg
    return msg


def test_svg_entity_bomb(tmp_path):
    ents = ['<!ENTITY a0 "' + "x" * 50 + '">']
    ents += [f'<!ENTITY a{i} "' + f"&a{i - 1};" * 10 + '">' for i in range(1, 12)]
    text = f'<?xml version="1.0"?><!DOCTYPE svg [{"".join(ents)}]>' + SVG.format(
        '<path id="&a11;" d="M0 0L1 1"/><text>&a11;</text>')
    assert "refers to other entities" in svg_error(tmp_path, text)


def test_svg_quadratic_blowup(tmp_path):
    text = ('<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "' + "x" * 1000 + '">]>'
            + SVG.format("<desc>" + "&a;" * 20000 + "</desc>"))
    assert "expand to more than" in svg_error(tmp_path, text)


def test_svg_external_entities_are_never_read(tmp_path, capsys, config_path):
    secret = tmp_path / "secret.txt"
    secret.write_text("SECRET-CONTENT")
    (tmp_path / "ext.dtd").write_text('<!ENTITY y "SECRET-DTD">')
    cases = {
        "system": f'<!DOCTYPE svg [<!ENTITY x SYSTEM "file://{secret}">]>'
                  + SVG.format('<text x="1" y="5">&x;</text>'),
        "parameter": f'<!DOCTYPE svg [<!ENTITY % p SYSTEM "file://{secret}"> %p;]>'
                     + SVG.format(""),
        "dtd": f'<!DOCTYPE svg SYSTEM "file://{tmp_path / "ext.dtd"}">'
               + SVG.format('<text x="1" y="5">&y;</text>'),
    }
    for name, text in cases.items():
        p = tmp_path / f"{name}.svg"
        p.write_text('<?xml version="1.0"?>' + text)
        code, out, err = run(capsys, ["--config", config_path, "convert", p, "-o", "-"])
        assert code == 2 and "SECRET" not in out + err, name
        assert f"{p}:" in err


def test_svg_plain_doctype_and_illustrator_entities_still_read(tmp_path):
    std = ('<!DOCTYPE svg PUBLIC "-//W3C//DTD SVG 1.1//EN" '
           '"http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd">')
    ai = std[:-1] + ' [<!ENTITY ns_svg "http://www.w3.org/2000/svg">]>'
    for doctype, root in ((std, SVG), (ai, SVG.replace('"http://www.w3.org/2000/svg"',
                                                       '"&ns_svg;"'))):
        p = tmp_path / "ok.svg"
        p.write_text(f'<?xml version="1.0"?>{doctype}' + root.format('<path d="M0 0L5 5"/>'))
        assert len(svg.read(str(p), TOL, warn=lambda m: None).strokes) == 1


def test_svgz_decompression_bomb(tmp_path, capsys, config_path, monkeypatch):
    """An .svgz that inflates past the bound (GBs of whitespace in a few MB of gzip) is one
    error line, not minutes of parsing; a small one below the bound still reads."""
    import gzip

    from vplotter.inputs import xml_guard
    monkeypatch.setattr(xml_guard, "UNZIPPED_MAX", 1 << 16)
    ok = tmp_path / "ok.svgz"
    ok.write_bytes(gzip.compress(SVG.format('<path d="M0 0L5 5"/>').encode()))
    assert len(svg.read(str(ok), TOL, warn=lambda m: None).strokes) == 1
    p = tmp_path / "bomb.svgz"
    p.write_bytes(gzip.compress(SVG.format('<path d="M0 0L5 5"/>' + " " * (1 << 17)).encode()))
    code, out, err = run(capsys, ["--config", config_path, "info", p])
    lines = [ln for ln in err.splitlines() if not ln.startswith("note:")]
    assert code == 2 and lines == [f"{p}: error: decompresses to more than 0.0625 MB (a "
                                   "decompression bomb?): not read"]
