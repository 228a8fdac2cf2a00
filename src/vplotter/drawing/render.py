"""Pictures: the planned drawing (`preview`) and what a trace draws (`simulate`), PNG or SVG.

A picture is built once as a list of shapes in picture pixels (y down); `write` paints it with
Pillow (drawn at 2x and downsampled, so lines are anti-aliased) or writes the same shapes as SVG
text, so both files show the same picture. `View` maps G-code mm (+Y up) to pixels: the top of
the drawing is at the top of the picture. Pure functions over numpy arrays; Pillow is imported
only when a PNG is written.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import escape

import numpy as np

from vplotter.errors import InputError

WALL = "#e4e4e0"          # outside the page
PAPER = "#ffffff"
INK = "#202020"           # frame, labels, pen-down path of a trace
BLACK = "#000000"         # ink of the --ink preview
TRAVEL = "#7c7c7c"        # pen-up travel of a preview
TRAVEL_TRACE = "#a9bfd8"  # pen-up path of a trace (light)
SUPERSAMPLE = 2


@dataclass(frozen=True)
class View:
    """G-code mm -> picture px: x_px = margin + (X - x_min) * scale, y_px = margin + (y_max - Y)
    * scale. The legend band lies below the drawing area."""

    scale: float          # px per mm
    x_min_mm: float
    y_max_mm: float
    margin_px: float
    width_px: int
    height_px: int

    @classmethod
    def fit(cls, lo_mm, hi_mm, size_px: int, legend_px: float) -> "View":
        """The view of the box lo..hi (G-code mm) whose long side is size_px, aspect kept."""
        span = np.maximum(np.asarray(hi_mm, float) - np.asarray(lo_mm, float), 1e-6)
        margin = max(8.0, 0.03 * size_px)
        # the long side of the picture is size_px; the short side follows the aspect
        scale = min((size_px - 2 * margin) / span[0],
                    (size_px - 2 * margin - legend_px) / span[1])
        width = int(round(span[0] * scale + 2 * margin))
        height = int(round(span[1] * scale + 2 * margin + legend_px))
        return cls(float(scale), float(lo_mm[0]), float(hi_mm[1]), margin, width, height)

    def px(self, xy_mm) -> np.ndarray:
        p = np.asarray(xy_mm, dtype=float).reshape(-1, 2)
        return np.stack((self.margin_px + (p[:, 0] - self.x_min_mm) * self.scale,
                         self.margin_px + (self.y_max_mm - p[:, 1]) * self.scale), axis=1)


@dataclass
class Shape:
    """kind: "lines" (polyline; one point is a dot), "segments" (pairs of points), "rect" (two
    corners), "circle" (centre, radius `width`), "text" (anchor point; `anchor` start/middle/end).
    Sizes in picture px."""

    kind: str
    pts: np.ndarray
    colour: str = INK
    width: float = 1.0
    fill: str | None = None
    text: str = ""
    anchor: str = "start"
    name: str = ""        # SVG class: what the shape is


@dataclass
class Picture:
    width_px: int
    height_px: int
    view: View
    shapes: list[Shape] = field(default_factory=list)

    def add(self, kind: str, pts, **kw) -> None:
        self.shapes.append(Shape(kind, np.asarray(pts, dtype=float).reshape(-1, 2), **kw))


def order_colours(n: int) -> list[str]:
    """Colours for n strokes in drawing order: the hue runs through the spectrum from red
    (first) to violet (last), as the seed's bitmaps did; yellow and green are darkened so that
    they read on white paper."""
    out = []
    for i in range(n):
        h = 0.78 * i / max(n - 1, 1)
        v = 0.92 - 0.30 * np.exp(-(((h * 360.0) - 95.0) / 45.0) ** 2)
        r, g, b = colorsys.hsv_to_rgb(h, 1.0, float(v))
        out.append(f"#{int(r * 255):02x}{int(g * 255):02x}{int(b * 255):02x}")
    return out


def _anchors(kin) -> np.ndarray:
    """The cord anchors in G-code mm (none for a machine kind without them)."""
    return kin.to_gcode(getattr(kin, "anchors", np.zeros((0, 2))))


def _frame(view: View, kin, page) -> tuple[Picture, float]:
    """The page, the anchors, the G-code origin: what every picture shows around the drawing.
    Returns the picture and the line width unit (px) for the drawing."""
    pic = Picture(view.width_px, view.height_px, view)
    u = _unit_px(view)
    pic.add("rect", [[0, 0], [view.width_px, view.height_px]], fill=WALL, colour=WALL, width=0)
    pic.add("rect", view.px([[page.x_min_mm, page.y_max_mm], [page.x_max_mm, page.y_min_mm]]),
            fill=PAPER, colour="#606060", width=u / 2, name="page")
    where = _anchors(kin)
    anchors = view.px(where)
    if len(anchors) > 1:
        pic.add("lines", anchors, colour="#b0b0b0", width=u / 2, name="anchor-line")
    font = _font_px(view)
    for (x, y), (gx, gy), side, anchor in zip(anchors, where, ("left", "right"), ("start", "end")):
        pic.add("circle", [[x, y]], colour=INK, fill=INK, width=3 * u, name="anchor")
        pic.add("text", [[x, y + 3 * u + font]], width=font, anchor=anchor,
                text=f"{side} anchor (X{gx:g} Y{gy:g})")
    ox, oy = view.px([[0.0, 0.0]])[0]
    r = 6 * u
    pic.add("segments", [[ox - r, oy], [ox + r, oy], [ox, oy - r], [ox, oy + r]],
            colour=INK, width=u / 2, name="origin")
    pic.add("text", [[ox + r / 2, oy + r / 2 + font]], text="X0 Y0", width=font * 0.85)
    px0, py0 = view.px([[page.x_min_mm, page.y_max_mm]])[0]
    pic.add("text", [[px0 + font / 2, py0 + 1.4 * font]], colour="#707070", width=font * 0.85,
            text=f"page X {page.x_min_mm:g}..{page.x_max_mm:g}, "
                 f"Y {page.y_min_mm:g}..{page.y_max_mm:g} mm")
    return pic, u


def _unit_px(view: View) -> float:
    """Width of a drawn line: 2 px on a 1600 px picture."""
    return max(1.0, max(view.width_px, view.height_px) / 800.0)


def _font_px(view: View) -> float:
    return max(10.0, round(max(view.width_px, view.height_px) / 90.0))


def _view(kin, page, pts_mm, size_px: int) -> View:
    """A view that covers the page, the anchors and the drawing."""
    corners = np.array([[page.x_min_mm, page.y_min_mm], [page.x_max_mm, page.y_max_mm]])
    pts = np.vstack([corners, _anchors(kin), np.zeros((1, 2)),
                     np.asarray(pts_mm, float).reshape(-1, 2)])
    pts = pts[np.isfinite(pts).all(axis=1)]
    legend = LEGEND_LINES * max(10.0, round(size_px / 90.0))
    return View.fit(pts.min(axis=0), pts.max(axis=0), size_px, legend)


LEGEND_LINES = 3.4     # height of the legend band in font sizes


def _legend(pic: Picture, view: View, text: str, key: list[tuple[str, object, str]]) -> None:
    """The legend: one line of figures, then a key line of (kind, colour(s), label) items,
    kind "line" (a short line in that colour), "ring" or "order" (the order's colours)."""
    font = _font_px(view)
    u = _unit_px(view)
    # on a narrow picture the legend's font shrinks to fit (text width estimated: sans-serif
    # glyphs average about half the font size)
    key_em = sum((5.0 if kind == "order" else 2.5) + 1 / 3 + 0.425 * len(label) + 1.2
                 for kind, _, label in key)
    font *= min(1.0, (view.width_px - 2 * view.margin_px) / (font * max(0.52 * len(text), key_em)))
    y2 = view.height_px - view.margin_px / 2
    y1 = y2 - 1.4 * font
    pic.add("text", [[view.margin_px, y1]], text=text, width=font, name="legend")
    x, mid, small = view.margin_px, y2 - 0.35 * font, font * 0.85
    for kind, colour, label in key:
        w = 2.5 * font
        if kind == "order":
            cs = list(colour) or [INK]
            xs = np.linspace(x, x + 2 * w, len(cs) + 1)
            for c, a, b in zip(cs, xs[:-1], xs[1:]):
                pic.add("lines", [[a, mid], [b, mid]], colour=c, width=3 * u, name="key")
            w *= 2
        elif kind == "ring":
            pic.add("circle", [[x + w / 2, mid]], colour=colour, width=3 * u, name="key")
        else:
            pic.add("lines", [[x, mid], [x + w, mid]], colour=colour, width=u, name="key")
        pic.add("text", [[x + w + font / 3, y2]], text=label, width=small, name="key")
        x += w + font / 3 + 0.5 * small * len(label) + 1.2 * font


def preview(strokes, start_xy, kin, page, legend: str, size_px: int = 1600,
            travel=None) -> Picture:
    """The planned drawing: `strokes` (point arrays, G-code mm) in drawing order coloured from
    red to violet, the pen-up travel as thin grey lines, on the page with the anchors and the
    origin. `travel`: (K, 2, 2) pen-up line pieces in G-code mm; None: from `start_xy`
    through each stroke's start, in order."""
    pts = [np.asarray(s, dtype=float).reshape(-1, 2) for s in strokes]
    if travel is None:
        ends = [np.asarray(start_xy, float)] + [p[-1] for p in pts[:-1]]
        travel = [(a, p[0]) for a, p in zip(ends, pts)]
    travel = np.asarray(travel, dtype=float).reshape(-1, 2)
    allpts = np.vstack([np.asarray(start_xy, float).reshape(1, 2), travel] + pts)
    view = _view(kin, page, allpts, size_px)
    pic, u = _frame(view, kin, page)
    colours = order_colours(len(pts))
    for i, (p, c) in enumerate(zip(pts, colours)):
        pic.add("lines", view.px(p), colour=c, width=u, name="stroke")
    if len(travel):
        pic.add("segments", view.px(travel), colour=TRAVEL, width=u / 2, name="travel")
    sx, sy = view.px(start_xy)[0]
    pic.add("circle", [[sx, sy]], colour=TRAVEL, fill=None, width=3 * u, name="pen-start")
    _legend(pic, view, legend, [("order", order_colours(min(len(pts), 24)),
                                 "drawing order: first to last"),
                                ("line", TRAVEL, "pen-up travel"), ("ring", TRAVEL, "pen start")])
    return pic


def ink(strokes, kin, page, pen_mm: float, legend: str, size_px: int = 1600,
        colours=None) -> Picture:
    """The drawing as ink on paper: every stroke a line of the pen's width (a one-point
    stroke a dot of that diameter), no travel: the tone a photo style will give, to judge
    before a long plot. `colours[i]` ('#rrggbb' or None: black) is stroke i's pen colour
    (--cmyk's layers, an SVG's stroke colours)."""
    pts = [np.asarray(s, dtype=float).reshape(-1, 2) for s in strokes]
    cols = [c or BLACK for c in (colours or [None] * len(pts))]
    allpts = np.vstack(pts) if pts else np.zeros((1, 2))
    view = _view(kin, page, allpts, size_px)
    pic, u = _frame(view, kin, page)
    width = pen_mm * view.scale
    for p, c in zip(pts, cols):
        pic.add("lines", view.px(p), colour=c, width=width, name="ink")
    inks = list(dict.fromkeys(cols)) or [BLACK]
    label = f"ink: a pen {pen_mm:g} mm wide" + (f", {len(inks)} colours" if len(inks) > 1 else "")
    _legend(pic, view, legend, [("order" if len(inks) > 1 else "line",
                                 inks if len(inks) > 1 else inks[0], label)])
    return pic


def simulate(xy_mm: np.ndarray, down: np.ndarray, kin, page, legend: str,
             size_px: int = 1600, start_label: str = "start") -> Picture:
    """What a decoded trace draws: pen positions `xy_mm` (N, 2) in G-code mm, `down[i]` the pen
    state from point i to point i+1. Pen-down parts dark, pen-up parts light."""
    xy = np.asarray(xy_mm, dtype=float).reshape(-1, 2)
    down = np.asarray(down, dtype=bool)
    view = _view(kin, page, xy, size_px)
    pic, u = _frame(view, kin, page)
    p = view.px(xy)
    for d in (False, True):
        for run in _runs(p, down, d, 1.0 / SUPERSAMPLE):
            pic.add("lines", run, colour=INK if d else TRAVEL_TRACE, width=u if d else u / 2,
                    name="down" if d else "up")
    if len(p):
        pic.add("circle", p[:1], colour=TRAVEL, width=3 * u, name="pen-start")
    _legend(pic, view, legend, [("line", INK, "pen down"), ("line", TRAVEL_TRACE, "pen up"),
                                ("ring", TRAVEL, start_label)])
    return pic


def _runs(p: np.ndarray, down: np.ndarray, state: bool, px: float) -> list[np.ndarray]:
    """The polylines along which the pen state is `state` (segment i runs from point i to i+1
    with down[i]); a point in the same `px` grid cell as the one before is dropped."""
    if len(p) < 2:
        return [p] if len(p) and down[0] == state else []
    on = down[:-1] == state
    # a run of segments i..j covers points i..j+1
    edges = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    q = np.rint(p / px).astype(np.int64)
    moved = np.concatenate(([True], np.any(q[1:] != q[:-1], axis=1)))
    out = []
    for a, b in zip(first.tolist(), last.tolist()):
        keep = moved[a:b + 1].copy()
        keep[0] = keep[-1] = True
        out.append(p[a:b + 1][keep])
    return out


def write(pic: Picture, path: str) -> None:
    """PNG or SVG by the file name's suffix."""
    kind = Path(path).suffix.lower()
    try:
        if kind == ".svg":
            Path(path).write_text(svg(pic), encoding="utf-8")
        elif kind == ".png":
            png(pic).save(path, format="PNG", optimize=False)
        else:
            raise InputError(f"{path}: error: the picture must be a .png or .svg file")
    except OSError as e:
        raise InputError(f"{path}: error: cannot write: {e.strerror or e}") from None


def png(pic: Picture):
    """Paint the picture with Pillow at SUPERSAMPLE x, then downsample (anti-aliasing)."""
    from PIL import Image, ImageDraw

    k = SUPERSAMPLE
    img = Image.new("RGB", (pic.width_px * k, pic.height_px * k), PAPER)
    draw = ImageDraw.Draw(img)
    texts = []
    for s in pic.shapes:
        p = s.pts * k - 0.5      # Pillow's integer coordinates are pixel centres
        w = max(1, int(round(s.width * k)))
        if s.kind == "rect":
            (x0, y0), (x1, y1) = np.sort(p, axis=0)
            draw.rectangle([x0, y0, x1, y1], fill=s.fill,
                           outline=s.colour if s.width > 0 else None, width=w)
        elif s.kind == "circle":
            (x, y), r = p[0], s.width * k
            draw.ellipse([x - r, y - r, x + r, y + r], fill=s.fill, outline=s.colour,
                         width=max(1, int(k * s.width / 3)))
        elif s.kind == "lines":
            if len(p) == 1 or np.all(p == p[0]):
                r = w / 2 + 0.5
                draw.ellipse([p[0, 0] - r, p[0, 1] - r, p[0, 0] + r, p[0, 1] + r], fill=s.colour)
            else:
                draw.line(p.ravel().tolist(), fill=s.colour, width=w,
                          joint="curve" if w > 2 else None)
        elif s.kind == "segments":
            for a, b in zip(p[0::2].tolist(), p[1::2].tolist()):
                draw.line(a + b, fill=s.colour, width=w)
        elif s.kind == "text":
            texts.append(s)
    img = img.resize((pic.width_px, pic.height_px), getattr(Image, "Resampling", Image).LANCZOS)
    draw = ImageDraw.Draw(img)
    for s in texts:      # text at the final size: FreeType anti-aliases it already
        font = _pil_font(s.width)
        (x, y) = s.pts[0].tolist()
        try:
            draw.text((x, y), s.text, fill=s.colour, font=font,
                      anchor={"start": "ls", "middle": "ms", "end": "rs"}[s.anchor])
        except (ValueError, TypeError):     # Pillow < 10.1 without FreeType: a bitmap font
            w = draw.textlength(s.text, font=font)
            x -= {"start": 0.0, "middle": w / 2, "end": w}[s.anchor]
            draw.text((x, y - 10), s.text, fill=s.colour, font=font)
    return img


def _pil_font(size_px: float):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size_px)     # Pillow >= 10.1 with FreeType
    except (TypeError, AttributeError, OSError):
        return ImageFont.load_default()


def svg(pic: Picture) -> str:
    """The same shapes as an SVG document (px units, one element per shape)."""
    def pts(p: np.ndarray) -> str:
        return " ".join(f"{x:.2f},{y:.2f}" for x, y in p.tolist())

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{pic.width_px}" '
           f'height="{pic.height_px}" viewBox="0 0 {pic.width_px} {pic.height_px}">']
    for s in pic.shapes:
        ident = f' class="{escape(s.name)}"' if s.name else ""
        stroke = f'stroke="{s.colour}" stroke-width="{s.width:.2f}"'
        if s.kind == "rect":
            (x0, y0), (x1, y1) = np.sort(s.pts, axis=0)
            line = (f' {stroke}' if s.width > 0 else ' stroke="none"')
            out.append(f'<rect{ident} x="{x0:.2f}" y="{y0:.2f}" width="{x1 - x0:.2f}" '
                       f'height="{y1 - y0:.2f}" fill="{s.fill or "none"}"{line}/>')
        elif s.kind == "circle":
            (x, y) = s.pts[0]
            out.append(f'<circle{ident} cx="{x:.2f}" cy="{y:.2f}" r="{s.width:.2f}" '
                       f'fill="{s.fill or "none"}" stroke="{s.colour}" '
                       f'stroke-width="{s.width / 3:.2f}"/>')
        elif s.kind == "lines":
            p = s.pts if len(s.pts) > 1 else np.vstack((s.pts, s.pts))   # a dot: round caps
            out.append(f'<polyline{ident} points="{pts(p)}" fill="none" {stroke} '
                       f'stroke-linecap="round" stroke-linejoin="round"/>')
        elif s.kind == "segments":
            d = " ".join(f"M{a[0]:.2f},{a[1]:.2f} L{b[0]:.2f},{b[1]:.2f}"
                         for a, b in zip(s.pts[0::2].tolist(), s.pts[1::2].tolist()))
            out.append(f'<path{ident} d="{d}" fill="none" {stroke}/>')
        elif s.kind == "text":
            (x, y) = s.pts[0]
            out.append(f'<text{ident} x="{x:.2f}" y="{y:.2f}" font-family="sans-serif" '
                       f'font-size="{s.width:.1f}" text-anchor="{s.anchor}" '
                       f'fill="{s.colour}">{escape(s.text)}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"
