"""Strokes: what every input gives the shared pipeline once its own syntax is gone.

A stroke is one pen-down polyline in G-code millimetres (+Y up); a stroke of one point is a dot (pen
down and up at that point). Placement (`drawing/place.py`) and ordering (`drawing/order.py`) work on
strokes; `to_records` turns them back into the records the pipeline draws (travel with the pen up
between strokes), so G-code and SVG go through one pipeline.

`line`/`col` say where a stroke comes from (G-code line, or the SVG element's number) and
`src` names it in messages (an SVG element id); the pipeline reports errors and resume places
by `line`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Iterator

import numpy as np

from vplotter.inputs.gcode import Move, Pen, Record


@dataclass
class Stroke:
    pts: np.ndarray                  # (K, 2) G-code mm, K >= 1
    line: int = 0
    col: int = 0
    feed_mm_s: float | None = None   # pen speed cap from the input (G-code F), None: config's
    layer: str | None = None         # SVG layer label or id
    src: str | None = None           # SVG element id, for messages
    pen: str | None = None           # the pen as the file names it: an SVG colour as written
                                     # ('red', '#ff8800'), a layer, a G-code tool ('T2');
                                     # None: the one pen
    colour: str | None = None        # '#rrggbb' where the file gives a colour, else None

    @property
    def closed(self) -> bool:
        return len(self.pts) > 2 and bool(np.all(self.pts[0] == self.pts[-1]))

    def length_mm(self) -> float:
        return float(np.hypot(*np.diff(self.pts, axis=0).T).sum()) if len(self.pts) > 1 else 0.0


@dataclass
class Drawing:
    """An input file read into strokes, with what a reader knows about it: what every reader
    (`vplotter.readers`) returns."""

    name: str
    strokes: list[Stroke]
    width_mm: float | None = None        # document size (SVG), None for G-code
    height_mm: float | None = None
    layers: list[dict] = field(default_factory=list)      # [{"id", "label", "visible"}]
    skipped: dict = field(default_factory=lambda: {"text": 0, "image": 0, "hidden": 0})
    fills: list = field(default_factory=list)   # inputs.fill.Region: hatched once placed (SVG)
    notes: list[str] = field(default_factory=list)        # what was chosen (a photo)
    details: list[str] = field(default_factory=list)      # ... how and why (said --verbose)
    advice: list[str] = field(default_factory=list)       # what would draw it better
    placed: bool = False                 # the strokes are on the page already (a photo)
    ordered: bool = False                # ... and in their drawing order (a photo's, timed)


def to_records(strokes: Iterable[Stroke]) -> Iterator[Record]:
    """Records that draw the strokes in order: a pen-up travel to each stroke's start, pen
    down, its pieces, pen up. Every record carries the stroke's line/col."""
    x, y = 0.0, 0.0
    have = False
    for st in strokes:
        p = np.asarray(st.pts, dtype=float)
        x0, y0 = float(p[0, 0]), float(p[0, 1])
        if not have or (x0, y0) != (x, y):
            yield Move(st.line, st.col, x, y, x0, y0, rapid=True)
        have = True
        yield Pen(st.line, st.col, True)
        x, y = x0, y0
        for x1, y1 in p[1:].tolist():
            if (x1, y1) != (x, y):
                yield Move(st.line, st.col, x, y, x1, y1, feed_mm_s=st.feed_mm_s)
            x, y = x1, y1
        yield Pen(st.line, st.col, False)
