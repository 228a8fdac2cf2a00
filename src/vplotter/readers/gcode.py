"""The G-code reader (inputs/gcode.py): any file no other reader takes. Read into strokes
(`gcode_strokes`, arcs cut at the chord tolerance) to be placed and reordered; drawn as it is
(--order keep, no placement or pen option) it streams its own records (`Prepared.records`)."""

from __future__ import annotations

from typing import Iterable

from vplotter.readers.base import Reader


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


def records(path: str, strict: bool, warn, dialect=None):
    """The file's own records (inputs/gcode.py's reader), with the config's pen dialect."""
    from vplotter.inputs import gcode

    extra = {"dialect": dialect} if dialect is not None else {}
    return gcode.read(path, strict=strict, warn=warn, **extra)


def read(path: str, ctx):
    from vplotter.inputs.strokes import Drawing

    return Drawing(path, gcode_strokes(records(path, ctx.strict, ctx.warn, ctx.dialect),
                                       ctx.tol_mm, ctx.warn, path))


def place(path: str, stroke, k: int) -> str:
    return f"{path}:{stroke.line}:{stroke.col}"


READER = Reader("gcode", "G-code", (), read, place, sniff=lambda head: True, order="keep",
                streams=True)
