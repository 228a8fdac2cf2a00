"""Strokes -> the records the pipeline draws (prepare.py's stroke records): a pen-up travel
to each stroke, pen down, its moves, pen up; a stroke that starts within join_mm of where the
previous one ended is drawn on without lifting; the pauses `pens.Breaks` asks for (a pen
change, a fresh pen, the next layer) with the pen up. The records are numbered one by one in
drawing order (that number is the "line" that progress, resume and --from-line use)."""

from __future__ import annotations

from typing import Iterator

from vplotter.drawing import order, pens
from vplotter.inputs.gcode import Move, Pause, Pen
from vplotter.inputs.strokes import Stroke


def stroke_records(strokes: list[Stroke], join_mm: float, refill_mm: float | None = None,
                   layer_pauses: bool = False, firsts: list[int] | None = None
                   ) -> Iterator[Move | Pen | Pause]:
    """The records of `strokes`; `firsts` gets the number of each stroke's first record."""
    firsts = firsts if firsts is not None else []
    joined = order.joined(strokes, join_mm).copy()
    breaks = pens.Breaks(strokes, refill_mm, layer_pauses)
    pause = breaks.before(0) if strokes else None
    n = 0
    x, y = 0.0, 0.0
    have = False
    for k, st in enumerate(strokes):
        if pause:                   # a pen change, a fresh pen, the next layer
            n += 1
            yield Pause(n, 0, *pause)
        n += 1
        firsts.append(n)
        p = st.pts
        x0, y0 = float(p[0, 0]), float(p[0, 1])
        if joined[k]:
            if (x0, y0) != (x, y):
                yield Move(n, 0, x, y, x0, y0, feed_mm_s=st.feed_mm_s)
                n += 1
        else:
            if not have or (x0, y0) != (x, y):
                yield Move(n, 0, x, y, x0, y0, rapid=True)
                n += 1
            yield Pen(n, 0, True)
            n += 1
        have = True
        x, y = x0, y0
        p, cuts = breaks.split(k)
        for i, (x1, y1) in enumerate(p[1:].tolist(), 1):
            if (x1, y1) != (x, y):
                yield Move(n, 0, x, y, x1, y1, feed_mm_s=st.feed_mm_s)
                n += 1
            x, y = x1, y1
            if i in cuts:           # a fresh pen inside the stroke
                yield from (Pen(n, 0, False), Pause(n + 1, 0, *cuts[i]), Pen(n + 2, 0, True))
                n += 3
        pause = breaks.before(k + 1) if k + 1 < len(strokes) else None
        if pause:                   # the pen is up at a pause
            joined[k + 1] = False
        if k + 1 == len(strokes) or not joined[k + 1]:
            yield Pen(n, 0, False)
