"""From a file to the records the pipeline draws: read (a reader of `vplotter.readers`) ->
Drawing -> placement (`drawing/place.py`) -> ordering (`drawing/order.py`) -> records.

A G-code file drawn as it is (--order keep, no placement option) streams its own records
unchanged: exact arcs, dwells, feeds and line numbers, flat memory; resume and --from-line
count its lines. Everything else is read into strokes (arcs cut at the pipeline's chord
tolerance), placed, ordered and turned back into records. Those records are numbered one by
one in drawing order (that number is the "line" that progress, resume and --from-line use),
and `where(line)` names the file place (G-code line or SVG element) behind it.
"""

from __future__ import annotations

import bisect
import time
from dataclasses import dataclass, field
from typing import Callable, Iterator

# the file options and the readers, where they were before (imported by name elsewhere)
from vplotter.file_options import (_number, add_file_options, join_limit,  # noqa: F401
                                   options_key, photo_options, placement)
from vplotter.readers import file_kind  # noqa: F401
from vplotter.readers.gcode import gcode_strokes  # noqa: F401


def _stderr(msg: str) -> None:
    import sys

    print(msg, file=sys.stderr)


# ------------------------------------------------------------------ the prepared drawing
@dataclass
class Prepared:
    path: str
    kind: str                     # the reader's: gcode | svg | dxf | image | text | ...
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
    notes: list[str] = field(default_factory=list)    # what was chosen (a photo), in words
    details: list[str] = field(default_factory=list)  # how and why: the tone (--verbose)
    advice: list[str] = field(default_factory=list)   # a photo that will show poorly: the
    #                                                   size or time that would show it
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
        from vplotter.readers.gcode import records

        warn = self.warn if self._reads == 0 else (lambda m: None)
        self._reads += 1
        return records(self.path, self.strict, warn, self.dialect)

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
        """The file place behind a pipeline line, as the file's reader names it: 'file:line:col'
        for G-code, 'file: element ID' for SVG, ..."""
        if self.passthrough:
            return f"{self.path}:{line}" + (f":{col}" if col is not None else "")
        if not self._firsts:
            for _ in self._stroke_records():
                pass
        k = max(bisect.bisect_right(self._firsts, line) - 1, 0)
        if k >= len(self.strokes):
            return f"{self.path}"
        from vplotter.readers import reader_of

        return reader_of(self.kind).place(self.path, self.strokes[k], k)


def prepare(path: str, cfg, args, warn: Callable[[str], None] = _stderr,
            start_xy=(0.0, 0.0), plot_time: Callable[[Iterator], float] | None = None,
            drawing=None) -> Prepared:
    """Read, place and order `path` as the file options in `args` say. The pen starts at
    start_xy (G-code mm) for the travel. plot_time(records) -> s times a drawing with the
    draw's planner (a photo's budget needs it). `drawing`: one already made (the text
    command's), placed and ordered as a text file's; `path` then only names it."""
    from vplotter import readers
    from vplotter.file_options import check_options, fill_options
    from vplotter.motion.segment import CHORD_SHARE

    reader = readers.reader_for(path) if drawing is None else readers.reader_of("text")
    check_options(args, path, reader.options)
    place_opts = placement(args)
    method = getattr(args, "order", None) or reader.order
    tol = cfg.motion.tolerance_mm * CHORD_SHARE
    join_mm = join_limit(getattr(args, "join", None), tol, warn)
    key = options_key(path, args, reader.kind)
    prep = Prepared(path, reader.kind, passthrough=False,
                    strict=bool(getattr(args, "strict", False)), join_mm=join_mm,
                    pause=bool(getattr(args, "pause_between_layers", False)), key=key, warn=warn,
                    start_xy=(float(start_xy[0]), float(start_xy[1])), tol_mm=tol,
                    dialect=getattr(cfg, "gcode", None),
                    fill=fill_options(args) if "fill" in reader.options else None,
                    refill_mm=getattr(args, "refill_every", None),
                    owned=tuple(getattr(getattr(cfg, "pens", None), "owned", ())))
    pen_order = getattr(args, "pen_order", None)
    if (reader.streams and method == "keep" and place_opts.identity and pen_order is None
            and prep.refill_mm is None):
        prep.passthrough = True
        return prep
    page = page_of(cfg)
    if drawing is None:
        timed = None if plot_time is None else (lambda strokes: _timed(prep, strokes, plot_time))
        ctx = readers.Context(
            tol, warn, layers=getattr(args, "layer", None), fill=prep.fill,
            photo=photo_options(args) if "photo" in reader.options else None,
            placement=place_opts, page=page, plot_time=timed, start_xy=prep.start_xy,
            order=method, owned=prep.owned, strict=prep.strict, dialect=prep.dialect)
        drawing = reader.read(path, ctx)
    _arrange(prep, drawing, page, place_opts, method, pen_order)
    return prep


def _arrange(prep: Prepared, drawing, page, place_opts, method: str, pen_order) -> None:
    """prep gets the drawing (its fills hatched as placed), and its strokes placed (unless the
    reader placed them), with the pens resolved and arranged, and ordered (unless the reader
    ordered them: a photo's order is the one its budget timed)."""
    from vplotter.drawing import order, pens, place

    if drawing.fills and drawing.strokes:          # hatched as placed: spacing in wall mm
        from vplotter.inputs import fill

        drawing.strokes = fill.merge(drawing.strokes, drawing.fills, prep.fill,
                                     lambda pts: place.matrix(place_opts, pts, page),
                                     pens.width_of(prep.owned))
    prep._drawing = drawing
    prep.notes = drawing.notes
    prep.details = drawing.details
    prep.advice = drawing.advice
    placed = drawing.strokes if drawing.placed else place.place(drawing.strokes, place_opts, page)
    placed = pens.resolve(placed, prep.owned, prep.warn, prep.path)
    t0 = time.perf_counter()
    if drawing.ordered:
        prep._strokes = pens.arrange(placed, pen_order or "light-to-dark")
    else:
        prep._strokes = pens.arrange(placed, pen_order or "light-to-dark",
                                     lambda group, at: order.order(group, method, at),
                                     prep.start_xy)
    prep.order_s = time.perf_counter() - t0


def page_of(cfg):
    """The page drawings are placed on (`place.Box`): [page], and on a polar machine the disc
    its arm reaches."""
    from vplotter.drawing import place

    pg, pol = cfg.page, getattr(cfg, "polar", None)
    reach = None if pol is None else (pol.centre_x_mm, pol.centre_y_mm, pol.radius_max_mm)
    return place.Box(pg.x_min_mm, pg.y_min_mm, pg.x_max_mm, pg.y_max_mm, reach)


def _timed(prep: Prepared, strokes: list, plot_time) -> float:
    """The plot time of strokes drawn as prep draws its own (a photo's budget)."""
    from dataclasses import replace as _replace
    from vplotter.drawing.pens import resolve

    strokes = resolve(strokes, prep.owned)      # the pens' speeds count (resolved: unchanged)
    return plot_time(_replace(prep, _strokes=strokes, _firsts=[], _drawing=None).records())
