"""SVG file -> Drawing: the outline of every visible shape as strokes in G-code millimetres.

The XML is walked here (parsed by `svg_tree.py`: each element keeps its line and column for
messages); path data and transform lists are parsed by svgelements; units, viewBox and the
display/visibility cascade are in `svg_style.py`, curves in `svg_geom.py`. The rules (README,
section "SVG"):

- drawn: path, line, polyline, polygon, rect (rx/ry), circle, ellipse, and `<use>` instances,
  whatever their stroke and fill, as outlines; each subpath is one stroke (`--fill none`: only
  what has a stroke; `--fill hatch`: filled elements are also hatched, `inputs/fill.py`);
- paint (`svg_paint.py`): an outline's pen is its stroke colour as the file writes it, or its
  fill colour when it has no stroke; a hatch's is the fill colour; each colour is one pen,
  named as the file first writes it;
- text: <text> with its <tspan>s, and Inkscape's <flowRoot>, in single-stroke Hershey fonts
  (`svg_text.py`); a flowRoot whose frame is not a plain rect is counted as skipped text;
- skipped: <image> (counted), what sits in defs,
  symbol, clipPath, mask, marker, pattern unless a <use> places it, and anything hidden
  (display:none on itself or an ancestor; visibility:hidden, inherited, undone by
  visibility:visible below): hidden drawable elements are counted;
- default placement: the page (0..width, 0..height mm, y down) centred on G-code X0 Y0 with +Y
  up: X = x - width/2, Y = height/2 - y.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

from vplotter.errors import InputError
from vplotter.inputs import svg_paint
from vplotter.inputs.strokes import Drawing, Stroke
from vplotter.inputs.svg_tree import Node, load_tree

SHAPES = {"path", "rect", "circle", "ellipse", "line", "polyline", "polygon"}
TEXT = {"text", "flowRoot"}
CONTAINERS = {"g", "a", "svg", "switch"}
# Not drawn where they stand (only a <use> can place a symbol or what sits in defs).
NOT_RENDERED = {"defs", "symbol", "clipPath", "mask", "marker", "pattern", "style", "script",
                "linearGradient", "radialGradient", "filter", "foreignObject", "metadata",
                "title", "desc", "font", "font-face", "view", "cursor"}
MAX_INSTANCES = 2_000_000   # elements visited, <use> instances included (nested uses explode)
MM_PER_PX = 25.4 / 96.0

Warn = Callable[[str], None]


def _stderr(msg: str) -> None:
    import sys

    print(msg, file=sys.stderr)


@dataclass(frozen=True)
class _Ctx:
    """What an element inherits from where it stands."""

    m: object                     # 3x3 numpy: user units here -> G-code mm
    vp: tuple[float, float]       # viewport size in user units (for percentages)
    none: bool = False            # display:none on an ancestor
    vis: str = "visible"          # inherited visibility
    layer: str | None = None      # innermost Inkscape layer (label or id)
    selected: bool = True         # inside a layer that --layer asked for (or no --layer)
    use: Node | None = None       # outermost <use> this instance comes from
    stack: tuple = ()             # ids of <use> targets being expanded (cycle guard)
    font: tuple = ()              # inherited text properties (svg_text.inherit)
    paint: svg_paint.Paint = svg_paint.INITIAL    # fill, stroke, color, fill-rule here


class _Reader:
    def __init__(self, path: str, tol_mm: float, layers: list[str] | None, warn: Warn,
                 fill=None):
        from vplotter.inputs import svg_style
        from vplotter.inputs.fill import FillOptions

        self.path, self.tol_mm, self.wanted, self.warn = path, tol_mm, layers, warn
        self.style = svg_style
        self.sheet = svg_style.StyleSheet()
        self.strokes: list[Stroke] = []
        self.layers: list[dict] = []
        self.skipped = {"text": 0, "image": 0, "hidden": 0}
        self.missing: set[str] = set()
        self.visits = 0
        self.text = None              # svg_text.TextReader, made at the first text element
        self.fill = fill or FillOptions()
        self.regions: list = []
        self.unstroked = 0            # --fill none: shapes not drawn for want of a stroke

    def err(self, node: Node, msg: str) -> InputError:
        return InputError(f"{self.path}:{node.line}:{node.col}: error: <{node.tag}> {msg}")

    def length(self, node: Node, name: str, ref: float | None, default: float | None = 0.0):
        try:
            value = self.style.length(node.attrs.get(name), ref)
        except self.style.BadValue as e:
            raise self.err(node, f"{name}: {e}") from None
        return default if value is None else value

    # -------------------------------------------------------------- document
    def read(self) -> Drawing:
        import numpy as np

        root, self.ids = load_tree(self.path)
        self.collect_styles(root)
        st = self.style
        try:
            vb = st.view_box(root.attrs.get("viewBox"))
            w_mm = self.root_size(root, "width")
            h_mm = self.root_size(root, "height")
        except st.BadValue as e:
            raise self.err(root, str(e)) from None
        if w_mm is None or h_mm is None:
            if vb is None:
                raise self.err(root, "has no width/height (in mm, cm, in, pt, pc or px) and no "
                                     "viewBox: the size of the drawing is unknown")
            w_mm = vb[2] * MM_PER_PX if w_mm is None else w_mm
            h_mm = vb[3] * MM_PER_PX if h_mm is None else h_mm
        if not (w_mm > 0 and h_mm > 0):
            raise self.err(root, f"width and height must be above 0 (got {w_mm:g} x {h_mm:g} mm)")
        w_px, h_px = w_mm / MM_PER_PX, h_mm / MM_PER_PX
        if vb is None:
            user_to_mm = np.diag([MM_PER_PX, MM_PER_PX, 1.0])
            vp = (w_px, h_px)
        else:
            try:
                user_to_mm = st.viewport_matrix(vb, w_mm, h_mm,
                                                root.attrs.get("preserveAspectRatio"))
            except st.BadValue as e:
                raise self.err(root, str(e)) from None
            vp = (vb[2], vb[3])
        to_gcode = np.array([[1.0, 0.0, -w_mm / 2], [0.0, -1.0, h_mm / 2], [0.0, 0.0, 1.0]])
        ctx = _Ctx(to_gcode @ user_to_mm, vp, selected=not self.wanted)
        try:
            self.walk(root, ctx, root=True)
        except RecursionError:
            raise InputError(f"{self.path}: error: elements are nested too deeply") from None
        self.check_layers()
        if self.text is not None:
            self.text.finish()
        from vplotter.inputs import fill

        self.strokes, self.regions = fill.one_pen_per_colour(self.strokes, self.regions)
        return Drawing(self.path, self.strokes, w_mm, h_mm, self.layers, self.skipped)

    def root_size(self, root: Node, name: str) -> float | None:
        text = root.attrs.get(name)
        if text is None or text.strip() in ("", "auto") or text.strip().endswith("%"):
            return None
        return self.style.length_mm(text)

    def collect_styles(self, node: Node) -> None:
        todo = [node]
        while todo:
            n = todo.pop()
            if n.tag == "style" and n.svg and n.attrs.get("type", "text/css") in ("text/css", ""):
                self.sheet.add("".join(n.text))
            todo.extend(n.children)

    def check_layers(self) -> None:
        if not self.wanted:
            return
        names = {d["label"] for d in self.layers} | {d["id"] for d in self.layers if d["id"]}
        unknown = [w for w in self.wanted if w not in names]
        if unknown:
            have = ", ".join(repr(d["label"]) for d in self.layers) or "none"
            raise InputError(f"{self.path}: error: no layer {unknown[0]!r} (layers: {have})")
        for d in self.layers:
            if not d["visible"] and (d["label"] in self.wanted or d["id"] in self.wanted):
                self.warn(f"{self.path}: warning: layer {d['label']!r} is hidden: nothing of "
                          f"it is drawn")

    # -------------------------------------------------------------- walking
    def walk(self, node: Node, ctx: _Ctx, root: bool = False) -> None:
        if not node.svg or node.tag in NOT_RENDERED:
            return
        self.visits += 1
        if self.visits > MAX_INSTANCES:
            raise InputError(f"{self.path}: error: more than {MAX_INSTANCES} elements "
                             f"(<use> instances included)")
        tag = node.tag
        own = self.style.own_style(self.sheet, tag, node.attrs)
        vis = own.get("visibility", "inherit")
        ctx = replace(ctx, none=ctx.none or own.get("display") == "none",
                      vis=vis if vis in ("visible", "hidden", "collapse") else ctx.vis,
                      paint=svg_paint.cascade(ctx.paint, own))
        if any(prop in own for prop in self.style.TEXT_PROPS):
            from vplotter.inputs import svg_text

            ctx = replace(ctx, font=svg_text.inherit(ctx.font, own))
        if tag in TEXT:
            if ctx.selected:
                if ctx.none:
                    self.skipped["hidden"] += 1
                else:
                    self.draw_text(node, ctx)
            return
        if tag == "image":
            self.skipped["image"] += ctx.selected
            return
        if tag in SHAPES:
            if ctx.selected:
                if ctx.none or ctx.vis != "visible":
                    self.skipped["hidden"] += 1
                else:
                    self.draw(node, ctx)
            return
        if tag == "use":
            self.use(node, ctx)
            return
        if tag not in CONTAINERS:
            return                                   # unknown elements draw nothing
        m = ctx.m if root else ctx.m @ self.transform(node)
        ctx = replace(ctx, m=m)
        if tag == "svg" and not root:
            ctx = self.nested_viewport(node, ctx)
        if (tag == "g" and node.attrs.get("inkscape:groupmode") == "layer"
                and ctx.use is None):
            ctx = self.layer(node, ctx)
        children = node.children
        if tag == "switch":                          # the first child that can be shown
            children = [c for c in children if c.svg and c.tag != "foreignObject"][:1]
        for child in children:
            self.walk(child, ctx)

    def transform(self, node: Node):
        try:
            return self.style.transform(node.attrs.get("transform"))
        except self.style.BadValue as e:
            raise self.err(node, str(e)) from None

    def layer(self, node: Node, ctx: _Ctx) -> _Ctx:
        ident = node.attrs.get("id")
        label = node.attrs.get("inkscape:label") or ident or f"layer {len(self.layers) + 1}"
        self.layers.append({"id": ident, "label": label,
                            "visible": not ctx.none and ctx.vis == "visible"})
        selected = ctx.selected or label in (self.wanted or ()) or (
            ident is not None and ident in (self.wanted or ()))
        return replace(ctx, layer=label, selected=selected)

    def viewport(self, node: Node, ctx: _Ctx, x: float, y: float, w: float, h: float,
                 vb_node: Node) -> _Ctx:
        st = self.style
        try:
            vb = st.view_box(vb_node.attrs.get("viewBox"))
            m = ctx.m @ st.translate(x, y)
            if vb is not None:
                m = m @ st.viewport_matrix(vb, w, h, vb_node.attrs.get("preserveAspectRatio"))
        except st.BadValue as e:
            raise self.err(vb_node, str(e)) from None
        return replace(ctx, m=m, vp=(vb[2], vb[3]) if vb is not None else (w, h))

    def nested_viewport(self, node: Node, ctx: _Ctx) -> _Ctx:
        vw, vh = ctx.vp
        x, y = self.length(node, "x", vw), self.length(node, "y", vh)
        w, h = self.length(node, "width", vw, vw), self.length(node, "height", vh, vh)
        return self.viewport(node, ctx, x, y, w, h, node)

    def use(self, node: Node, ctx: _Ctx) -> None:
        href = node.attrs.get("href", node.attrs.get("xlink:href", "")).strip()
        target = self.ids.get(href[1:]) if href.startswith("#") else None
        if target is None:
            if href not in self.missing:
                self.missing.add(href)
                self.warn(f"{self.path}:{node.line}:{node.col}: warning: <use> target "
                          f"{href or '(none)'!r} not found: skipped")
            return
        if href in ctx.stack:
            raise self.err(node, f"refers to itself through {href!r}")
        vw, vh = ctx.vp
        x, y = self.length(node, "x", vw), self.length(node, "y", vh)
        inner = replace(ctx, m=ctx.m @ self.transform(node), use=ctx.use or node,
                        stack=ctx.stack + (href,))
        if target.tag == "symbol" and target.svg:
            # a symbol is a viewport of the <use>'s width/height (default: its own, or 100 %)
            w = self.length(node, "width", vw, None)
            h = self.length(node, "height", vh, None)
            w = self.length(target, "width", vw, vw) if w is None else w
            h = self.length(target, "height", vh, vh) if h is None else h
            inner = self.viewport(node, inner, x, y, w, h, target)
            own = self.style.own_style(self.sheet, "symbol", target.attrs)
            vis = own.get("visibility", "inherit")
            if vis in ("visible", "hidden", "collapse"):
                inner = replace(inner, vis=vis)
            inner = replace(inner, paint=svg_paint.cascade(inner.paint, own))
            for child in target.children:
                self.walk(child, inner)
            return
        inner = replace(inner, m=inner.m @ self.style.translate(x, y))
        if target.tag in NOT_RENDERED:              # e.g. <use href="#defs">: nothing
            return
        self.walk(target, inner)

    # -------------------------------------------------------------- text
    def draw_text(self, node: Node, ctx: _Ctx) -> None:
        if self.text is None:
            from vplotter.inputs import svg_text

            self.text = svg_text.TextReader(self)
        self.text.draw(node, ctx)

    # -------------------------------------------------------------- shapes
    def subpaths(self, node: Node, vp: tuple[float, float]):
        from vplotter.inputs import svg_geom as geo

        tag, a = node.tag, node.attrs
        vw, vh = vp
        diag = math.sqrt((vw * vw + vh * vh) / 2)
        L = self.length
        if tag == "path":
            try:
                return geo.path_data(a.get("d", ""))
            except ValueError as e:
                raise self.err(node, f"d: {e}") from None
        if tag == "rect":
            w, h = L(node, "width", vw), L(node, "height", vh)
            if w < 0 or h < 0:
                raise self.err(node, "width and height must not be negative")
            return geo.rect(L(node, "x", vw), L(node, "y", vh), w, h,
                            L(node, "rx", vw, None), L(node, "ry", vh, None))
        if tag == "circle":
            r = L(node, "r", diag)
            if r < 0:
                raise self.err(node, "r must not be negative")
            return geo.ellipse(L(node, "cx", vw), L(node, "cy", vh), r, r)
        if tag == "ellipse":
            rx, ry = L(node, "rx", vw, None), L(node, "ry", vh, None)
            rx, ry = (ry if rx is None else rx), (rx if ry is None else ry)  # SVG 2 auto
            if (rx or 0) < 0 or (ry or 0) < 0:
                raise self.err(node, "rx and ry must not be negative")
            return geo.ellipse(L(node, "cx", vw), L(node, "cy", vh), rx or 0.0, ry or 0.0)
        if tag == "line":
            return [((L(node, "x1", vw), L(node, "y1", vh)),
                     [("L", L(node, "x2", vw), L(node, "y2", vh))], False)]
        try:
            values = self.style.numbers(a.get("points"))
        except self.style.BadValue as e:
            raise self.err(node, f"points: {e}") from None
        if len(values) % 2:
            raise self.err(node, "points: an odd number of coordinates")
        return geo.poly(values, tag == "polygon")

    def draw(self, node: Node, ctx: _Ctx) -> None:
        from vplotter.inputs import svg_geom as geo

        m = ctx.m @ self.transform(node)
        polys = []
        for sub in self.subpaths(node, ctx.vp):
            try:
                pts = geo.flatten(sub, m, self.tol_mm)
            except ValueError as e:
                raise self.err(node, str(e)) from None
            if pts is not None:
                polys.append(pts)
        self.emit(node, ctx, polys)

    # -------------------------------------------------------------- paint
    def emit(self, node: Node, ctx: _Ctx, polys: list) -> None:
        """One element's polylines (G-code mm, each subpath one) as outline strokes and, with
        `--fill hatch`, its filled region, painted as its fill and stroke say."""
        from vplotter.inputs.fill import Region

        fill, stroke = svg_paint.pens(self, node, ctx)
        source = ctx.use or node
        line, src = source.num, source.src()
        if fill is not None and self.fill.mode == "hatch" and polys:
            self.regions.append(Region(polys, ctx.paint.rule, fill[0], fill[1],
                                       len(self.strokes), line, ctx.layer, src))
        if stroke is None and self.fill.mode == "none":
            self.unstroked += 1         # a fill alone (or no paint) draws nothing
            return
        pen, colour = stroke or fill or (None, None)
        for pts in polys:
            self.strokes.append(Stroke(pts, line, 0, None, ctx.layer, src, pen, colour))


def read(path: str, tol_mm: float, layers: list[str] | None = None,
         warn: Warn = _stderr) -> Drawing:
    """Read an SVG file into a Drawing in G-code mm with the default placement (the page
    centred on X0 Y0, +Y up). Curves stay within tol_mm of the true (transformed) curve.
    `layers`: draw only these Inkscape layers (label or id). Raises InputError."""
    return read_fills(path, tol_mm, layers, warn)[0]


def read_fills(path: str, tol_mm: float, layers: list[str] | None = None,
               warn: Warn = _stderr, fill=None) -> tuple[Drawing, list]:
    """`read` with fill options (`inputs.fill.FillOptions`): the Drawing and, for `--fill
    hatch`, the filled regions (`inputs.fill.Region`) that `fill.merge` hatches once the
    drawing is placed."""
    if not tol_mm > 0:
        raise ValueError("tol_mm must be above 0")
    r = _Reader(path, tol_mm, layers, warn, fill)
    drawing = r.read()
    if r.unstroked:
        n = r.unstroked
        warn(f"{path}: warning: --fill none: {n} shape{'s' if n > 1 else ''} without a stroke "
             f"not drawn (--fill outline draws {'their outlines' if n > 1 else 'its outline'})")
    return drawing, r.regions
