"""SVG paint (the fill/stroke cascade, pens and colours) and hatch fills (--fill hatch): the
hatching checked against an independent point-in-polygon test and distances, on random
polygons with holes under both fill rules, and end to end through `vplotter convert`."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from vplotter.cli import main
from vplotter.inputs import svg, svg_paint
from vplotter.inputs.fill import FillOptions, Region, hatch

TOL = 0.0075
HAIR = 1e-6
OUT_OK = 0.05        # a hatch line may leave the shape by this much (mm)


# ---------------------------------------------------------------- independent geometry
def winding(pts: np.ndarray, rings: list[np.ndarray]) -> np.ndarray:
    """Winding number of each point about the closed rings (crossing count with signs)."""
    w = np.zeros(len(pts), dtype=int)
    x, y = pts[:, 0][:, None], pts[:, 1][:, None]
    for r in rings:
        a, b = r, np.roll(r, -1, axis=0)
        ax, ay, bx, by = a[:, 0][None], a[:, 1][None], b[:, 0][None], b[:, 1][None]
        up = (ay <= y) & (by > y)
        down = (by <= y) & (ay > y)
        side = (bx - ax) * (y - ay) - (x - ax) * (by - ay)     # > 0: point left of edge
        w += np.sum(up & (side > 0), axis=1) - np.sum(down & (side < 0), axis=1)
    return w


def inside(pts, rings, rule):
    w = winding(pts, rings)
    return w != 0 if rule == "nonzero" else w % 2 == 1


def seg_dist(pts: np.ndarray, segs: np.ndarray) -> np.ndarray:
    """Distance from each point to the nearest of the segments (M, 4)."""
    out = np.full(len(pts), np.inf)
    if len(segs) == 0:
        return out
    a, d = segs[:, :2], segs[:, 2:] - segs[:, :2]
    dd = np.maximum((d * d).sum(axis=1), 1e-300)
    for i in range(0, len(pts), 256):
        p = pts[i:i + 256][:, None, :]
        t = np.clip(((p - a) * d).sum(axis=2) / dd, 0, 1)
        q = a + t[..., None] * d
        out[i:i + 256] = np.sqrt(((p - q) ** 2).sum(axis=2)).min(axis=1)
    return out


def ring_segs(rings):
    return np.concatenate([np.column_stack([r, np.roll(r, -1, axis=0)]) for r in rings])


def stroke_segs(lines):
    parts = [np.column_stack([p[:-1], p[1:]]) for p in lines if len(p) > 1]
    return np.concatenate(parts) if parts else np.zeros((0, 4))


def along(lines, step=0.1):
    """Points every `step` mm along the strokes (their ends included)."""
    out = []
    for p in lines:
        for a, b in zip(p[:-1], p[1:]):
            n = max(1, math.ceil(np.hypot(*(b - a)) / step))
            t = np.arange(n + 1)[:, None] / n
            out.append(a + t * (b - a))
    return np.concatenate(out) if out else np.zeros((0, 2))


def check_hatch(rings, rule, spacing, angle, seed=0, n=1500):
    """The three promises of --fill hatch, measured; returns the hatch lines."""
    rings = [np.asarray(r, dtype=float) for r in rings]
    lines = [s.pts for s in hatch(Region(rings, rule, "black", "#000000", 0),
                                  FillOptions("hatch", spacing, angle))]
    assert lines
    edges = ring_segs(rings)
    hs = stroke_segs(lines)
    # 1. no hatch line leaves the shape (by more than 0.05 mm)
    on = along(lines)
    if len(on):
        out = ~inside(on, rings, rule)
        assert np.all(seg_dist(on[out], edges) <= OUT_OK)
    # 2. every interior point is within spacing / 2 of what is drawn (hatch and outline);
    #    away from the outline (by spacing / 2) within spacing / 2 of a hatch line
    allp = np.concatenate(rings)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pts = np.random.default_rng(seed).uniform(lo, hi, (n, 2))
    ins = inside(pts, rings, rule)
    d_edge = seg_dist(pts, edges)
    d_hatch = seg_dist(pts, hs)
    drawn = np.minimum(d_edge, d_hatch)
    assert np.all(drawn[ins] <= spacing / 2 + HAIR)
    deep = ins & (d_edge >= spacing / 2)
    assert np.all(d_hatch[deep] <= spacing / 2 + HAIR)
    # 3. holes and the outside stay empty: no hatch line nearer than the outline
    assert np.all(d_hatch[~ins] >= d_edge[~ins] - HAIR)
    return lines


def square(cx, cy, r, ccw=True, turn=0.0):
    a = np.radians(turn + np.array([45, 135, 225, 315]))
    p = np.column_stack([cx + r * np.cos(a), cy + r * np.sin(a)])
    return p if ccw else p[::-1]


# ---------------------------------------------------------------- the hatcher on polygons
@settings(max_examples=25)
@given(st.floats(10, 40), st.floats(0.2, 0.8), st.floats(-60, 60), st.floats(0.3, 3),
       st.floats(-180, 180), st.sampled_from(["evenodd", "nonzero"]), st.booleans())
def test_square_with_square_hole(r, k, turn, spacing, angle, rule, same_way):
    # nonzero needs the hole wound the other way; evenodd makes a hole either way
    hole_ccw = same_way if rule == "evenodd" else False
    check_hatch([square(3, -2, r, True, turn), square(3 + r * 0.1, -2, r * k * 0.8, hole_ccw,
                                                      turn * 0.5)],
                rule, spacing, angle)


@settings(max_examples=25)
@given(st.integers(5, 25), st.floats(0.3, 2.5), st.floats(-90, 90),
       st.sampled_from(["evenodd", "nonzero"]), st.booleans(), st.integers(0, 10_000))
def test_random_star_shaped_polygon_with_hole(n, spacing, angle, rule, hole_ccw, seed):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = rng.uniform(12, 30, n)
    outer = np.column_stack([rad * np.cos(t), rad * np.sin(t)])
    t2 = np.sort(rng.uniform(0, 2 * np.pi, max(3, n // 2)))
    hole = np.column_stack([rng.uniform(3, 9, len(t2)) * np.cos(t2),
                            rng.uniform(3, 9, len(t2)) * np.sin(t2)]) + rng.uniform(-2, 2, 2)
    if rule == "nonzero" or not hole_ccw:
        hole = hole[::-1]
    check_hatch([outer, hole], rule, spacing, angle, seed)


@pytest.mark.parametrize("rule", ["evenodd", "nonzero"])
def test_star_fill_rules(rule):
    """A pentagram: nonzero fills its centre, evenodd leaves it empty."""
    a = np.radians(90 + 144 * np.arange(5))
    star = 20 * np.column_stack([np.cos(a), np.sin(a)])
    lines = check_hatch([star], rule, 0.7, 30)
    centre = seg_dist(np.array([[0.0, 0.0]]), stroke_segs(lines))[0]
    if rule == "nonzero":
        assert centre <= 0.35 + HAIR
    else:
        assert centre > 3


def test_overlapping_rings_nonzero_is_the_union():
    lines = check_hatch([square(0, 0, 10), square(6, 0, 10)], "nonzero", 1.0, 45)
    assert seg_dist(np.array([[3.0, 0.0]]), stroke_segs(lines))[0] <= 0.5 + HAIR


def test_hatch_lines_are_joined_back_and_forth():
    lines = check_hatch([square(0, 0, 20)], "evenodd", 1.0, 0)
    assert len(lines) == 1 and len(lines[0]) > 40


# ---------------------------------------------------------------- SVG paint
def read(tmp_path, body, fill=None, head='width="100mm" height="100mm" viewBox="0 0 100 100"'):
    p = tmp_path / "t.svg"
    p.write_text(f'<svg xmlns="http://www.w3.org/2000/svg" '
                 f'xmlns:xlink="http://www.w3.org/1999/xlink" {head}>{body}</svg>')
    return svg.read_fills(str(p), TOL, None, lambda m: None, fill)


def pens(tmp_path, body, fill=None):
    d, _ = read(tmp_path, body, fill)
    return [(s.src, s.pen, s.colour) for s in d.strokes]


RECT = 'x="10" y="10" width="10" height="10"'


def test_paint_cascade(tmp_path):
    body = f"""
    <style>
      .c {{ stroke: #00F }}  rect#imp {{ stroke: green !important }}  .f {{ fill: Orange }}
    </style>
    <rect id="plain" {RECT}/>
    <rect id="attr" {RECT} stroke="RED"/>
    <rect id="cls" {RECT} class="c" stroke="red"/>
    <rect id="sty" {RECT} class="c" style="stroke: #F80"/>
    <rect id="imp" {RECT} style="stroke: #F80"/>
    <g stroke="purple" fill="none" color="teal">
      <rect id="inh" {RECT}/>
      <rect id="kw" {RECT} stroke="blue" style="stroke: inherit"/>
      <rect id="cur" {RECT} stroke="currentColor"/>
      <g color="navy"><rect id="cur2" {RECT} stroke="currentColor" color="maroon"/></g>
      <rect id="fillonly" {RECT} class="f" stroke="none"/>
      <rect id="nopaint" {RECT} stroke="none"/>
    </g>
    <g style="stroke: currentColor; color: lime"><rect id="kept" {RECT} color="olive"/></g>
    """
    got = {src: (pen, colour) for src, pen, colour in pens(tmp_path, body)}
    assert got == {
        "plain": ("black", "#000000"),          # fill black, stroke none: the fill's colour
        "attr": ("red", "#ff0000"),
        "cls": ("#0000ff", "#0000ff"),         # a rule beats a presentation attribute
        "sty": ("#ff8800", "#ff8800"),         # the style attribute beats a rule
        "imp": ("green", "#008000"),           # !important beats the style attribute
        "inh": ("purple", "#800080"),
        "kw": ("purple", "#800080"),
        "cur": ("teal", "#008080"),
        "cur2": ("maroon", "#800000"),
        "fillonly": ("orange", "#ffa500"),
        "nopaint": (None, None),                # drawn as today (--fill outline), no pen
        "kept": ("olive", "#808000"),           # currentColor inherits as a keyword
    }


def test_one_pen_per_colour_named_as_first_written(tmp_path):
    body = (f'<rect id="a" {RECT} fill="#F00"/><rect id="b" {RECT} fill="red"/>'
            f'<rect id="c" {RECT} fill="rgb(255, 0, 0)"/><rect id="d" {RECT} fill="hsl(120, 100%, 25%)"/>'
            f'<rect id="e" {RECT} fill="rgb(0 0 255)"/>')
    assert [p[1:] for p in pens(tmp_path, body)] == [("#ff0000", "#ff0000")] * 3 + [
        ("#008000", "#008000"), ("#0000ff", "#0000ff")]


def test_url_paint(tmp_path):
    body = f"""
    <defs>
      <linearGradient id="G0"><stop offset="0" style="stop-color: #123456"/></linearGradient>
      <linearGradient id="G1" xlink:href="#G0"/>
      <pattern id="P" width="1" height="1"/>
    </defs>
    <rect id="grad" {RECT} fill="url(#G1)"/>
    <rect id="fallback" {RECT} fill="url(#P) red"/>
    <rect id="pattern" {RECT} fill="url('#P')"/>
    <rect id="missing" {RECT} fill="url(#nothing)" stroke="url(#nothing) none"/>
    """
    got = {src: (pen, colour) for src, pen, colour in pens(tmp_path, body)}
    assert got == {"grad": ("#123456", "#123456"), "fallback": ("red", "#ff0000"),
                   "pattern": ("url(#P)", "#000000"), "missing": ("url(#nothing)", "#000000")}


def test_use_instances_inherit_from_the_use(tmp_path):
    body = (f'<defs><rect id="r" {RECT}/></defs><use id="u1" href="#r" fill="blue"/>'
            f'<g stroke="red"><use id="u2" xlink:href="#r" x="30"/></g>')
    assert [p[1:] for p in pens(tmp_path, body)] == [("blue", "#0000ff"), ("red", "#ff0000")]


def test_fill_modes(tmp_path):
    body = (f'<rect id="filled" {RECT} fill="red"/>'
            f'<rect id="stroked" {RECT} fill="none" stroke="blue"/>'
            f'<rect id="both" {RECT} fill="yellow" stroke="green"/>'
            f'<rect id="neither" {RECT} fill="none"/>')
    outline = [p[0] for p in pens(tmp_path, body)]
    assert outline == ["filled", "stroked", "both", "neither"]
    assert pens(tmp_path, body, FillOptions("outline")) == pens(tmp_path, body)
    assert [p[0] for p in pens(tmp_path, body, FillOptions("none"))] == ["stroked", "both"]
    warnings: list[str] = []
    svg.read_fills(str(tmp_path / "t.svg"), TOL, None, warnings.append, FillOptions("none"))
    assert warnings == [f"{tmp_path / 't.svg'}: warning: --fill none: 2 shapes without a stroke "
                        f"not drawn (--fill outline draws their outlines)"]
    d, regions = read(tmp_path, body, FillOptions("hatch", 1.0))
    assert [s.src for s in d.strokes] == outline
    assert [(r.src, r.pen, r.at) for r in regions] == [("filled", "red", 0), ("both", "yellow", 2)]


def test_outline_geometry_unchanged_by_paint(tmp_path):
    """--fill outline draws every shape as before: the same points, whatever the paint."""
    shapes = (f'<rect {RECT}/><circle cx="50" cy="50" r="20"/>'
              f'<path d="M0 0 L30 40 Q 60 0 90 40 Z M5 5 h3 v3z"/>')
    plain, _ = read(tmp_path, shapes)
    painted, _ = read(tmp_path, f'<g fill="none" stroke="red" fill-rule="evenodd">{shapes}</g>')
    assert len(plain.strokes) == len(painted.strokes) == 4
    for a, b in zip(plain.strokes, painted.strokes):
        assert np.array_equal(a.pts, b.pts)


def test_fill_rule_is_inherited(tmp_path):
    body = ('<g fill-rule="evenodd"><path id="p" d="M0 0 H40 V40 H0 Z M10 10 H30 V30 H10 Z"/>'
            '<path id="q" fill-rule="nonzero" d="M0 0 H40 V40 H0 Z"/></g>')
    _, regions = read(tmp_path, body, FillOptions("hatch", 1.0))
    assert [r.rule for r in regions] == ["evenodd", "nonzero"]


def test_paint_parser_rejects_what_is_not_a_colour():
    with pytest.raises(ValueError, match="not a colour"):
        svg_paint.paint("blu", "black", lambda i: None)
    assert svg_paint.paint("none", "black", lambda i: None) is None
    assert svg_paint.paint("transparent", "black", lambda i: None) is None
    assert svg_paint.paint(" #ABC ", "black", lambda i: None) == ("#aabbcc", "#aabbcc")


# ---------------------------------------------------------------- end to end
def read_gcode(path):
    """Pen-down segments (M, 4) of a convert output: G0/G1 X Y, pen Z5 up, Z-1 down."""
    x = y = 0.0
    down = False
    segs = []
    for line in path.read_text().splitlines():
        line = re.sub(r"\(.*?\)|;.*", "", line).strip()
        words = dict((w[0], float(w[1:])) for w in line.split()[1:])
        if "Z" in words:
            down = words["Z"] < 0
        if "X" in words or "Y" in words:
            nx, ny = words.get("X", x), words.get("Y", y)
            if down:
                segs.append((x, y, nx, ny))
            x, y = nx, ny
    return np.array(segs)


HOLED = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">
<style>.a { fill: red; fill-rule: evenodd }</style>
<path class="a" d="M20 20 H80 V80 H20 Z M35 35 H65 V65 H35 Z"/>
<circle cx="50" cy="50" r="5" fill="blue" stroke="none"/>
</svg>"""


@pytest.mark.parametrize("scale", [1.0, 2.0])
def test_convert_fill_hatch_end_to_end(tmp_path, config_path, capsys, scale):
    src, out = tmp_path / "holed.svg", tmp_path / "out.ngc"
    src.write_text(HOLED)
    spacing = 1.5
    code = main(["--config", str(config_path), "convert", str(src), "--fill", "hatch",
                 "--fill-spacing", str(spacing), "--scale", str(scale), "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    segs = read_gcode(out)
    # the drawing as placed: page centred on X0 Y0, y up, scaled about its centre (50, 50)
    outer = scale * np.array([[-30, -30], [30, -30], [30, 30], [-30, 30]], float)
    hole = outer / 2
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    dot = scale * 5 * np.column_stack([np.cos(t), np.sin(t)])
    pts = np.random.default_rng(1).uniform(-31 * scale, 31 * scale, (2000, 2))
    ring = inside(pts, [outer, hole], "evenodd")
    circle = inside(pts, [dot], "nonzero")
    d = seg_dist(pts, segs)
    assert np.all(d[ring] <= spacing / 2 + 1e-3)              # G-code has 4 decimals
    assert np.all(d[circle] <= spacing / 2 + 1e-3)
    gap = ~ring & ~circle
    edges = np.concatenate([ring_segs([outer, hole]), ring_segs([dot])])
    assert np.all(d[gap] >= seg_dist(pts[gap], edges) - 0.05)  # the hole stays empty
    # the hatch lines are spacing apart on the wall, on the grid fixed to X0 Y0, at 45 degrees
    v = (segs[:, 1] - segs[:, 0]) / math.sqrt(2)
    diag = np.abs(np.abs(segs[:, 2] - segs[:, 0]) - np.abs(segs[:, 3] - segs[:, 1])) < 1e-3
    long = np.hypot(segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]) > 2
    h = diag & long & (np.sign(segs[:, 2] - segs[:, 0]) == np.sign(segs[:, 3] - segs[:, 1]))
    assert h.sum() > 20
    frac = (v[h] / spacing - 0.5) % 1
    assert np.all(np.minimum(frac, 1 - frac) < 1e-3)


def test_fill_options_are_for_svg(tmp_path, config_path, capsys):
    g = tmp_path / "a.ngc"
    g.write_text("G1 X1 Y1\n")
    assert main(["--config", str(config_path), "info", str(g), "--fill", "hatch"]) == 2
    err = capsys.readouterr().err
    assert "error: --fill is for SVG files" in err and "Traceback" not in err


def test_bad_colour_is_one_line_with_its_place(tmp_path, config_path, capsys):
    p = tmp_path / "bad.svg"
    p.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="10mm">\n'
                 '  <rect width="5" height="5" fill="blu"/></svg>')
    assert main(["--config", str(config_path), "info", str(p)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and err[0].startswith(f"{p}:2:3: error: <rect> fill: not a colour")


@pytest.mark.parametrize("opts", [["--fit", "--rotate", "30"], ["--width", "37", "--rotate", "-70"]])
def test_hatch_spacing_and_angle_are_on_the_wall(tmp_path, config_path, capsys, opts):
    """Whatever the placement, the hatch lines are spacing apart at the angle on the wall: on
    the grid fixed to X0 Y0, and as long as the placed area over the spacing."""
    src, out = tmp_path / "holed.svg", tmp_path / "out.ngc"
    src.write_text(HOLED)
    spacing, angle = 0.8, 45.0
    code = main(["--config", str(config_path), "convert", str(src), "--fill", "hatch",
                 "--fill-spacing", str(spacing), "--fill-angle", str(angle), *opts,
                 "-o", str(out)])
    assert code == 0, capsys.readouterr().err
    segs = read_gcode(out)
    turn = math.radians(float(opts[-1]))
    width = np.ptp(segs[:, [0, 2]])              # the outer square's bounding box, as placed
    s = width / (60 * (abs(math.cos(turn)) + abs(math.sin(turn))))
    dx, dy = segs[:, 2] - segs[:, 0], segs[:, 3] - segs[:, 1]
    length = np.hypot(dx, dy)
    a = np.radians(angle)
    on_angle = np.abs(dx * math.sin(a) - dy * math.cos(a)) < 1e-3 * np.maximum(length, 1)
    hatch = on_angle & (length > 0.5)
    v = (-segs[hatch, 0] * math.sin(a) + segs[hatch, 1] * math.cos(a)) / spacing - 0.5
    assert np.all(np.abs(v - np.round(v)) < 2e-3)
    area = (60 ** 2 - 30 ** 2 + math.pi * 5 ** 2) * s * s
    assert length[hatch].sum() == pytest.approx(area / spacing, rel=0.03)


@given(st.integers(0, 255), st.integers(0, 255), st.integers(0, 255), st.integers(0, 4),
       st.booleans())
def test_every_spelling_of_a_colour_is_one_colour(r, g, b, form, upper):
    hexed = f"#{r:02x}{g:02x}{b:02x}"
    text = [hexed, f"rgb({r},{g},{b})", f"rgb( {r} {g} {b} )", f"rgba({r}, {g}, {b}, 0.5)",
            f"{hexed}ff"][form]
    text = text.upper() if upper else text
    assert svg_paint.paint(text, "black", lambda i: None) == (hexed, hexed)
    assert svg_paint.paint("currentColor", text, lambda i: None) == (hexed, hexed)
    assert svg_paint.paint(f"url(#g) {text}", "black", lambda i: "red") == (hexed, hexed)


def test_a_fill_spacing_far_too_fine_is_an_error(tmp_path, config_path, capsys):
    src = tmp_path / "holed.svg"
    src.write_text(HOLED)
    assert main(["--config", str(config_path), "info", str(src), "--fill", "hatch",
                 "--fill-spacing", "0.0001"]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and err[0].endswith(
        "error: --fill-spacing 0.0001 mm is too fine: path#3 would take more than 200,000 "
        "hatch lines")


def test_a_pens_own_width_is_its_fills_spacing_unless_given():
    """[pens.NAME] width_mm spaces the hatch of what that pen fills; --fill-spacing wins."""
    from vplotter.config.sections import PenSpec
    from vplotter.drawing.pens import width_of
    from vplotter.inputs.fill import merge
    from vplotter.inputs.strokes import Stroke

    owned = (PenSpec("fine", "#ff0000", width_mm=0.25), PenSpec("fat", "#000000", width_mm=2.0))
    ring = square(0, 0, 10)
    outline = [Stroke(ring, 1)]

    def lines(colour, given=False):
        reg = Region([ring], "nonzero", colour, colour, 0)
        opts = FillOptions("hatch", 1.0, 0.0, spacing_given=given)
        got = merge(outline, [reg], opts, None, width_of(owned))[:-1]
        return len(got), sum(s.length_mm() for s in got)

    _, mm_red = lines("#ee1100")        # nearest: fine, 0.25 mm
    _, mm_black = lines("#101010")    # nearest: fat, 2 mm
    _, mm_given = lines("#ee1100", given=True)
    area = 2 * 10 ** 2                     # the square's corners are 10 mm from its centre
    assert mm_red == pytest.approx(area / 0.25, rel=0.06)     # (the joins add a little)
    assert mm_given == pytest.approx(area / 1.0, rel=0.15)
    assert area / 2.0 < mm_black < 0.75 * mm_given
