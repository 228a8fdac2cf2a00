"""From a file to the records the pipeline draws: read (G-code or SVG) -> Drawing ->
placement (`drawing/place.py`) -> ordering (`drawing/order.py`) -> records.

A G-code file drawn as it is (--order keep, no placement option) streams its own records
unchanged: exact arcs, dwells, feeds and line numbers, flat memory; resume and --from-line
count its lines. Everything else is read into strokes (arcs cut at the pipeline's chord
tolerance), placed, ordered and turned back into records. Those records are numbered one by
one in drawing order (that number is the "line" that progress, resume and --from-line use),
and `where(line)` names the file place (G-code line or SVG element) behind it.
"""

from __future__ import annotations

import argparse
import bisect
import math
import time
from dataclasses import dataclass, field
from typing import Callable, Iterable, Iterator

from vplotter.drawing import pen_options
from vplotter.errors import ConfigError, InputError
from vplotter.inputs.image import STYLES as PHOTO_STYLES

SVG_SUFFIXES = (".svg", ".svgz")
TEXT_SUFFIXES = (".txt",)       # plain text, drawn in a Hershey font (inputs/text.py)
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff", ".gif")
IMAGE_MAGIC = (b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff", b"GIF87a", b"GIF89a", b"II*\x00",
               b"MM\x00*")


def _stderr(msg: str) -> None:
    import sys

    print(msg, file=sys.stderr)


# ------------------------------------------------------------------ options
def _number(kind: str, lo: float | None = None, above: bool = False):
    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{kind} must be a number (got {text!r})") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{kind} must be finite (got {text!r})")
        if lo is not None and (v <= lo if above else v < lo):
            raise argparse.ArgumentTypeError(
                f"{kind} must be {'above' if above else 'at least'} {lo:g} (got {text!r})")
        return v
    parse.__name__ = kind
    return parse


def add_file_options(p: argparse.ArgumentParser) -> None:
    """Placement, order and layer options, for every command that takes a drawing file."""
    g = p.add_argument_group("placement (scale and rotate about the drawing's centre, then fit, "
                             "align, offset; the result is checked against the page)")
    size = g.add_mutually_exclusive_group()
    size.add_argument("--scale", type=_number("scale", 0, above=True), metavar="S",
                      help="scale about the drawing's centre")
    size.add_argument("--fit", action="store_true",
                      help="the largest size inside the page (aspect kept), centred")
    g.add_argument("--width", type=_number("width", 0, above=True), metavar="MM",
                   help="scale so the drawing is MM wide (a photo: its size on the wall)")
    g.add_argument("--height", type=_number("height", 0, above=True), metavar="MM",
                   help="scale so the drawing is MM high (with --width: the largest inside both)")
    g.add_argument("--rotate", type=_number("angle"), metavar="DEG",
                   help="rotate counter-clockwise about the drawing's centre")
    g.add_argument("--margin", type=_number("margin", 0), default=0.0, metavar="MM",
                   help="keep this far inside the page edges with --fit/--align/--valign")
    g.add_argument("--align", choices=("left", "center", "right"),
                   help="put the drawing on the page's left edge, centre or right edge")
    g.add_argument("--valign", choices=("top", "middle", "bottom"),
                   help="put the drawing on the page's top edge, middle or bottom edge")
    g.add_argument("--offset", type=_number("offset"), nargs=2, metavar=("X", "Y"),
                   help="move by X Y mm, last")
    o = p.add_argument_group("order and layers")
    o.add_argument("--order", choices=("keep", "greedy", "best"),
                   help="stroke order: keep the file's, greedy nearest neighbour, or best "
                        "(default: best for SVG and DXF, keep for G-code)")
    o.add_argument("--join", type=_number("join", 0), default=None, metavar="MM",
                   help="draw on without lifting the pen when the next stroke starts within MM "
                        "of where the previous one ended; at most (and by default) the "
                        "flattening tolerance, 0.75 x tolerance_mm (0.0075 mm at 0.01), so a "
                        "join never draws farther from the file than a chord; 0: never")
    o.add_argument("--layer", action="append", metavar="NAME",
                   help="draw only this SVG layer (label or id) or DXF layer; repeatable")
    o.add_argument("--pause-between-layers", action="store_true",
                   help="lift the pen after each layer and wait for Enter (change the pen)")
    pen_options.add(o)              # --pen-order, --refill-every (drawing/pens.py)
    ph = p.add_argument_group("photos (PNG, JPEG, WebP, BMP, TIFF, GIF: darkness drawn as line "
                              "art, at a density that fits the plot-time budget)")
    ph.add_argument("--style", choices=PHOTO_STYLES,
                    help="hatch: crosshatched tone bands; spiral: one pulsing spiral; stipple: "
                         "dots (--tsp: one tour); squiggle: rows of zigzags (default hatch)")
    ph.add_argument("--max-time", metavar="TIME",
                    help="plot-time budget, e.g. 2h, 45m, 1h30m (default for photos: 1h)")
    ph.add_argument("--spacing", type=_number("spacing", 0, above=True), metavar="MM",
                    help="a fixed line spacing instead of the budget")
    ph.add_argument("--pen-width", type=_number("pen width", 0, above=True), default=0.5,
                    metavar="MM", help="the line width the tone model assumes (default 0.5; "
                    "also --fill-spacing's default)")
    ph.add_argument("--contrast", type=_number("contrast", 0), default=1.0, metavar="K",
                    help="scale the tone about mid-grey (default 1)")
    ph.add_argument("--brightness", type=_number("brightness"), default=0.0, metavar="B",
                    help="add to the tone, -1 (black) to 1 (white) (default 0)")
    ph.add_argument("--invert", action="store_true", help="draw the light parts dark")
    ph.add_argument("--tsp", action="store_true",
                    help="stipple: one tour through the dots instead of dots (TSP art)")
    ph.add_argument("--cmyk", action="store_true",
                    help="a colour photo in four pens: yellow, cyan, magenta and black layers, "
                         "within one budget")
    ph.add_argument("--colours", metavar="PENS",
                    help="a colour photo in the pens you own: names from [pens] or colours, "
                         "comma-separated (black,red,#2050c0), within one budget")
    fl = p.add_argument_group("fills (SVG)")
    fl.add_argument("--fill", choices=("none", "outline", "hatch"),
                    help="filled shapes: none (only what has a stroke is drawn), outline (every "
                         "shape's outline, the default), hatch (outline and hatch lines)")
    fl.add_argument("--fill-spacing", type=_number("fill spacing", 0, above=True), metavar="MM",
                    help="hatch lines MM apart on the wall (default: --pen-width, 0.5)")
    fl.add_argument("--fill-angle", type=_number("fill angle"), metavar="DEG",
                    help="hatch lines at DEG counter-clockwise from +X on the wall (default 45)")


def placement(args):
    from vplotter.drawing.place import Placement

    return Placement(scale=getattr(args, "scale", None) or 1.0,
                     rotate_deg=getattr(args, "rotate", None) or 0.0,
                     fit=bool(getattr(args, "fit", False)),
                     margin_mm=getattr(args, "margin", 0.0) or 0.0,
                     align=getattr(args, "align", None), valign=getattr(args, "valign", None),
                     offset_mm=tuple(getattr(args, "offset", None) or (0.0, 0.0)),
                     width_mm=getattr(args, "width", None), height_mm=getattr(args, "height", None))


def photo_options(args):
    from vplotter.drawing.photo import PhotoOptions

    return PhotoOptions.from_args(args)


def _fill(args):
    from vplotter.inputs.fill import FillOptions

    return FillOptions.from_args(args)


def file_kind(path: str) -> str:
    """"svg", "dxf", "image", "text" or "gcode": by suffix, else by the first bytes (read
    once)."""
    low = path.lower()
    if low.endswith(SVG_SUFFIXES):
        return "svg"
    if low.endswith(".dxf"):
        return "dxf"
    if low.endswith(IMAGE_SUFFIXES):
        return "image"
    try:
        with open(path, "rb") as f:
            head = f.read(256)
    except OSError:
        head = None         # the reader reports it
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n") if head is not None else b""
    if low.endswith(TEXT_SUFFIXES):        # unless it holds SVG
        return "svg" if text.startswith((b"<?xml", b"<svg", b"<!--", b"<!DOCTYPE")) else "text"
    if head is None:
        return "gcode"
    if head.startswith(IMAGE_MAGIC) or (head[:4] == b"RIFF" and head[8:12] == b"WEBP"):
        return "image"
    if head.startswith(b"AutoCAD Binary DXF") or head.split()[:2] == [b"0", b"SECTION"]:
        return "dxf"        # group code 0, SECTION: a DXF file; or a binary DXF's sentinel
    if head.startswith(b"\x1f\x8b") or text.startswith(b"<"):
        return "svg"        # gzip (svgz), or markup
    return "gcode"


# ------------------------------------------------------------------ G-code as strokes
def gcode_strokes(records: Iterable, tol_mm: float, warn=None, path: str = "") -> list:
    """Group the pen-down moves of a record stream into strokes (arcs cut within tol_mm).
    Pen-up moves are travel and are dropped: ordering and placement make their own. A plain
    M0/M1 has no place among reordered strokes: it is left out, with one warning."""
    import numpy as np

    from vplotter.inputs.gcode import Move, Pause, Pen
    from vplotter.inputs.strokes import Stroke
    from vplotter.motion import segment

    strokes: list = []
    down = False
    cur: list[np.ndarray] = []
    first = None
    feed = None
    pen = None

    def close() -> None:
        if first is not None and cur:
            strokes.append(Stroke(np.concatenate(cur), first.line, first.col, feed, pen=pen))

    xy = np.zeros((1, 2))
    plain: list = []
    for rec in records:
        if isinstance(rec, Pen):
            if rec.down and not down:
                cur, first, feed = [xy.copy()], rec, None
            elif down and not rec.down:
                close()
                cur, first = [], None
            down = rec.down
        elif isinstance(rec, Move):
            pts = segment.points(rec, tol_mm)
            if down and len(pts):
                cur.append(pts)
                if rec.feed_mm_s is not None and not rec.rapid:
                    feed = rec.feed_mm_s if feed is None else min(feed, rec.feed_mm_s)
            xy = np.array([[rec.x1, rec.y1]])
        elif isinstance(rec, Pause) and rec.pen is not None:
            pen = rec.pen           # the pen a pen change put in (T2, `(pen: NAME)`)
        elif isinstance(rec, Pause):
            plain.append(rec)
    if down:
        close()
    if plain and warn is not None:
        n = len(plain)
        warn(f"{path}:{plain[0].line}: warning: {n} M0/M1 pause{'s' if n > 1 else ''} left out: "
             f"the file is placed or reordered (drawn as it is, it stops there)")
    return strokes


# ------------------------------------------------------------------ the prepared drawing
@dataclass
class Prepared:
    path: str
    kind: str                     # gcode | svg | dxf | image | text
    passthrough: bool             # G-code streamed as it is
    strict: bool = False
    join_mm: float = 0.0075       # the joins: within this, never above tol_mm (see prepare)
    pause: bool = False
    order_s: float = 0.0
    key: str = ""                 # the options that make the order; resume checks them
    start_xy: tuple[float, float] = (0.0, 0.0)   # where the travel starts (G-code mm)
    tol_mm: float = 0.0075        # chords of G-code arcs read into strokes
    dialect: object = None        # config.toml [gcode] pen dialect, when the config has one
    warn: Callable[[str], None] = _stderr
    notes: list[str] = field(default_factory=list)    # what was chosen and why (a photo)
    fill: object = None           # SVG: inputs.fill.FillOptions (--fill, --fill-spacing ...)
    refill_mm: float | None = None    # --refill-every: a fresh pen after this much drawn
    owned: tuple = ()             # config.toml [pens]: the pens owned (drawing/pens.py)
    _drawing: object = None
    _strokes: list | None = None
    _firsts: list[int] = field(default_factory=list)
    _reads: int = 0

    @property
    def is_gcode(self) -> bool:
        return self.kind == "gcode"

    @property
    def drawing(self):
        if self._drawing is None:
            from vplotter.inputs.strokes import Drawing

            self._drawing = Drawing(self.path, self._read_gcode_strokes())
        return self._drawing

    @property
    def strokes(self) -> list:
        if self._strokes is None:
            self._strokes = self.drawing.strokes
        return self._strokes

    def _read_gcode_strokes(self) -> list:
        return gcode_strokes(self._gcode(), self.tol_mm, self.warn, self.path)

    def _gcode(self):
        from vplotter.inputs import gcode

        warn = self.warn if self._reads == 0 else (lambda m: None)
        self._reads += 1
        extra = {"dialect": self.dialect} if self.dialect is not None else {}
        return gcode.read(self.path, strict=self.strict, warn=warn, **extra)

    def records(self) -> Iterator:
        """A fresh iterator of pipeline records (warnings are given on the first read only)."""
        if self.passthrough:
            from vplotter.drawing import pens     # [pens]: the pens' names and speeds

            warn = self.warn if self._reads == 0 else None
            return pens.passthrough(self._gcode(), self.owned, warn, self.path)
        return self._stroke_records()

    def _stroke_records(self) -> Iterator:
        from vplotter.drawing.records import stroke_records

        firsts: list[int] = []
        yield from stroke_records(self.strokes, self.join_mm, self.refill_mm, self.pause, firsts)
        self._firsts = firsts

    def where(self, line: int, col: int | None = None) -> str:
        """The file place behind a pipeline line: 'file:line:col' for G-code, 'file: element
        ID' for SVG."""
        if self.passthrough:
            return f"{self.path}:{line}" + (f":{col}" if col is not None else "")
        if not self._firsts:
            for _ in self._stroke_records():
                pass
        k = max(bisect.bisect_right(self._firsts, line) - 1, 0)
        if k >= len(self.strokes):
            return f"{self.path}"
        st = self.strokes[k]
        if self.is_gcode:
            return f"{self.path}:{st.line}:{st.col}"
        if self.kind == "image":
            return f"{self.path}: stroke {k + 1}"
        if self.kind == "text":
            return f"{self.path}:{st.line}"
        if self.kind == "dxf":
            return f"{self.path}: entity {st.src}"
        return f"{self.path}: element {st.src}" if st.src else f"{self.path}: element {st.line}"


def join_limit(join_mm: float | None, tol_mm: float, warn: Callable[[str], None]) -> float:
    """The gap a pen-down join may bridge: --join, by default and at most the flattening
    tolerance tol_mm. A bridge of g mm lies within g/2 of the two stroke ends it joins, so a
    join draws nothing farther from the file than a chord of a curve is, and any order draws the
    same segments within it (a longer bridge would be a line that is not in the file, and which
    ends are joined depends on the order)."""
    if join_mm is None:
        return tol_mm
    if join_mm > tol_mm:
        warn(f"warning: --join {join_mm:g} mm is more than the flattening tolerance "
             f"({tol_mm:g} mm, 0.75 x tolerance_mm): ends farther apart than that are not joined")
        return tol_mm
    return join_mm


def options_key(path: str, args, kind: str | None = None) -> str:
    """The options that decide what is drawn in which order (a resume needs the same).
    `kind`: file_kind(path), when the caller has it."""
    kind = kind or file_kind(path)
    method = getattr(args, "order", None) or ("keep" if kind == "gcode" else "best")
    photo = photo_options(args) if kind == "image" else None
    key = (method, placement(args), getattr(args, "join", None),
           getattr(args, "layer", None), bool(getattr(args, "pause_between_layers", False)),
           photo, getattr(args, "pen_order", None), getattr(args, "refill_every", None))
    if kind == "svg" and getattr(args, "fill", None) not in (None, "outline"):
        key += (_fill(args),)
    return repr(key)


def prepare(path: str, cfg, args, warn: Callable[[str], None] = _stderr,
            start_xy=(0.0, 0.0), plot_time: Callable[[Iterator], float] | None = None,
            drawing=None) -> Prepared:
    """Read, place and order `path` as the file options in `args` say. The pen starts at
    start_xy (G-code mm) for the travel. plot_time(records) -> s times a drawing with the
    draw's planner (a photo's budget needs it). `drawing`: one already made (the text
    command's), placed and ordered as a text file's; `path` then only names it."""
    from vplotter.motion.segment import CHORD_SHARE

    kind = file_kind(path) if drawing is None else "text"
    svg = kind == "svg"
    place_opts = placement(args)
    method = getattr(args, "order", None) or ("keep" if kind == "gcode" else "best")
    layers = getattr(args, "layer", None)
    if layers and not (svg or kind == "dxf"):
        raise ConfigError(f"error: --layer is for SVG and DXF files; {path} is neither")
    if kind != "image":
        _no_photo_options(args, path)
    for name in ("fill", "fill_spacing", "fill_angle"):
        if getattr(args, name, None) is not None and not svg:
            raise ConfigError(f"error: --{name.replace('_', '-')} is for SVG files; {path} is "
                              f"not one")
    if (place_opts.width_mm or place_opts.height_mm) and (place_opts.fit or
                                                          place_opts.scale != 1.0):
        raise ConfigError("error: give --width/--height, --scale or --fit, not two of them")
    strict = bool(getattr(args, "strict", False))
    pause = bool(getattr(args, "pause_between_layers", False))
    tol = cfg.motion.tolerance_mm * CHORD_SHARE
    join_mm = join_limit(getattr(args, "join", None), tol, warn)
    key = options_key(path, args, kind)
    prep = Prepared(path, kind, passthrough=False, strict=strict, join_mm=join_mm,
                    pause=pause, key=key, warn=warn,
                    start_xy=(float(start_xy[0]), float(start_xy[1])), tol_mm=tol,
                    dialect=getattr(cfg, "gcode", None), fill=_fill(args) if svg else None,
                    refill_mm=getattr(args, "refill_every", None),
                    owned=tuple(getattr(getattr(cfg, "pens", None), "owned", ())))
    pen_order = getattr(args, "pen_order", None)
    if (kind == "gcode" and method == "keep" and place_opts.identity and pen_order is None
            and prep.refill_mm is None):
        prep.passthrough = True
        return prep
    from vplotter.drawing import order, pens, place

    page = page_of(cfg)
    if kind == "image":
        placed = _photo(prep, args, page, place_opts, plot_time)
    else:
        fills = []
        if drawing is not None:
            pass
        elif svg:
            from vplotter.inputs import svg as svg_reader

            if prep.fill.mode == "outline":
                drawing, fills = svg_reader.read(path, tol, layers=layers, warn=warn), []
            else:
                drawing, fills = svg_reader.read_fills(path, tol, layers, warn, prep.fill)
        elif kind == "text":
            from vplotter.inputs import text as text_reader

            drawing = text_reader.read(path, warn)
        elif kind == "dxf":
            from vplotter.inputs import dxf

            drawing = dxf.read(path, tol, layers=layers, warn=warn)
        else:
            from vplotter.inputs.strokes import Drawing

            drawing = Drawing(path, prep._read_gcode_strokes())
        if fills and drawing.strokes:          # hatched as placed: spacing in wall mm
            from vplotter.inputs import fill

            drawing.strokes = fill.merge(drawing.strokes, fills, prep.fill,
                                         lambda pts: place.matrix(place_opts, pts, page),
                                         pens.width_of(prep.owned))
        prep._drawing = drawing
        placed = place.place(drawing.strokes, place_opts, page)
    placed = pens.resolve(placed, prep.owned, warn, path)
    t0 = time.perf_counter()
    if kind == "image":                        # ordered as timed (`photo.strokes`)
        prep._strokes = pens.arrange(placed, pen_order or "light-to-dark")
    else:
        prep._strokes = pens.arrange(placed, pen_order or "light-to-dark",
                                     lambda group, at: order.order(group, method, at), start_xy)
    prep.order_s = time.perf_counter() - t0
    return prep


def page_of(cfg):
    """The page drawings are placed on (`place.Box`): [page], and on a polar machine the disc
    its arm reaches."""
    from vplotter.drawing import place

    pg, pol = cfg.page, getattr(cfg, "polar", None)
    reach = None if pol is None else (pol.centre_x_mm, pol.centre_y_mm, pol.radius_max_mm)
    return place.Box(pg.x_min_mm, pg.y_min_mm, pg.x_max_mm, pg.y_max_mm, reach)


def _timed(prep: Prepared, strokes: list, plot_time) -> float:
    from dataclasses import replace as _replace
    from vplotter.drawing.pens import resolve

    strokes = resolve(strokes, prep.owned)      # the pens' speeds count (resolved: unchanged)
    return plot_time(_replace(prep, _strokes=strokes, _firsts=[], _drawing=None).records())


def _photo(prep: Prepared, args, page, place_opts, plot_time) -> list:
    """A photo's placed strokes at the density its budget allows (prep gets the drawing and
    the notes on what was chosen)."""
    from dataclasses import replace as _replace

    from vplotter.drawing import photo
    from vplotter.inputs.strokes import Drawing

    def timed(strokes: list) -> float:
        return _timed(prep, strokes, plot_time)

    placed, prep.notes = photo.strokes(
        prep.path, photo_options(args), page, _replace(place_opts, width_mm=None, height_mm=None),
        timed if plot_time is not None else None, prep.start_xy,
        getattr(args, "order", None) or "best", prep.owned)
    prep._drawing = Drawing(prep.path, placed)
    return placed


def _no_photo_options(args, path: str) -> None:
    given = [name for name in ("style", "max_time", "spacing", "tsp", "invert", "cmyk",
                               "colours")
             if getattr(args, name, None)]
    if given:
        flag = "--" + given[0].replace("_", "-")
        raise ConfigError(f"error: {flag} is for photos (PNG, JPEG, ...); {path} is not one")


def check_readable(path: str) -> None:
    """The same one-line errors for a missing file or a directory, whatever its type."""
    import os

    if os.path.isdir(path):
        raise InputError(f"{path}: error: is a directory, not a drawing file")
    if not os.path.exists(path):
        raise InputError(f"{path}: error: no such file")
