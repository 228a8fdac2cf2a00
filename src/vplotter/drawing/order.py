"""Pen-up travel optimisation: the order, direction and seam of strokes.

Never changes what is drawn (the set of segments): a stroke may be drawn backwards, a closed
stroke may start at any of its vertices (its seam), and strokes keep their points. Layers keep
their order (each layer is ordered on its own, starting where the previous one ended), because
a layer may be another pen. Deterministic: no clocks, no random numbers.

- `keep`: file order.
- `greedy`: nearest neighbour from the pen's position (either end of an open stroke, a few
  candidate seams of a closed one), found with a grid (`order_greedy.py`: cells shrink where
  the drawing is dense, a numpy scan where it is sparse) that is rebuilt as it empties.
- `best`: greedy, then the tour improved (`order_improve.py`) by 2-opt (reversing a run of
  strokes, each drawn the other way) and or-opt (moving a run of up to three strokes, either
  way round) within a window of nearby tour positions, vectorised over all positions at once
  (every non-overlapping improving move of a round is made, then only the positions near a
  change are looked at again); seams of closed strokes are chosen to minimise the travel in
  and out. Up to ALL_TOURS_UP_TO strokes per layer, two more tours are improved the same way:
  one whose first leg costs nothing (then run from its nearer end), and one that starts with
  the file's first stroke as vpype's linesort does. Of these and the file order, the shortest
  travel from the pen is taken among those no longer *between strokes* than the file order
  and linesort's greedy order, so that best is no longer than either, from the pen or between
  strokes (vpype's pen_up_length) alike. A tour is an `order_tour.Tour`.

Joining (`joined`): a stroke that starts within join_mm of where the previous one ended is
drawn without lifting the pen. That pen-down bridge is a line that is not in the file, and
which ends meet depends on the order, so prepare() keeps join_mm within the flattening
tolerance (`prepare.join_limit`): every order then draws the file's own segments, plus bridges
that lie within half that tolerance of two stroke ends.
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.drawing.order_greedy import SEAM_SAMPLES, greedy  # noqa: F401
from vplotter.drawing.order_improve import WINDOW, best_seams, or_opt, two_opt  # noqa: F401
from vplotter.drawing.order_tour import Tour
from vplotter.inputs.strokes import Stroke

METHODS = ("keep", "greedy", "best")
ALL_TOURS_UP_TO = 5000   # strokes of a layer; above, only the tour from the pen is improved
PASSES = 3            # improvement rounds at most


def travel_mm(strokes: list[Stroke], start_xy=(0.0, 0.0), join_mm: float = 0.0) -> float:
    """Pen-up travel drawing `strokes` in this order from start_xy (the ends are the strokes'
    first and last points; no return at the end). Gaps within join_mm are drawn, not travel."""
    if not strokes:
        return 0.0
    ends = np.array([s.pts[-1] for s in strokes[:-1]]).reshape(-1, 2)
    prev = np.vstack([np.asarray(start_xy, dtype=float)[None, :], ends])
    starts = np.array([s.pts[0] for s in strokes])
    d = np.hypot(*(starts - prev).T)
    return float(d[d > join_mm].sum()) if join_mm > 0 else float(d.sum())


def joined(strokes: list[Stroke], join_mm: float) -> np.ndarray:
    """(N,) bool: stroke k starts within join_mm of the end of stroke k-1 and is drawn on from
    it without lifting the pen (same layer; dots are never joined)."""
    out = np.zeros(len(strokes), dtype=bool)
    if join_mm <= 0:
        return out
    for k in range(1, len(strokes)):
        a, b = strokes[k - 1], strokes[k]
        if (a.layer == b.layer and len(a.pts) > 1 and len(b.pts) > 1
                and math.dist(a.pts[-1], b.pts[0]) <= join_mm):
            out[k] = True
    return out


def order(strokes: list[Stroke], method: str = "best", start_xy=(0.0, 0.0)) -> list[Stroke]:
    """Strokes in drawing order (new Stroke objects where direction or seam changed)."""
    if method not in METHODS:
        raise ValueError(method)
    if method == "keep" or len(strokes) < 2 and not any(s.closed for s in strokes):
        return list(strokes)
    out: list[Stroke] = []
    at = np.asarray(start_xy, dtype=float)
    for group in _layers(strokes):
        done = _order_group(group, method, at)
        out += done
        if done:
            at = done[-1].pts[-1]
    return out


def _layers(strokes: list[Stroke]) -> list[list[Stroke]]:
    groups: dict = {}
    for s in strokes:
        groups.setdefault(s.layer, []).append(s)
    return list(groups.values())


def _order_group(strokes: list[Stroke], method: str, start: np.ndarray) -> list[Stroke]:
    if method == "greedy":
        tour = Tour(strokes, start)
        greedy(tour)
        return tour.result()
    keep = Tour(strokes, start)
    # from the pen's position; then, for drawings small enough that the first leg weighs,
    # with a free start (run from its nearer end), and from the file's first stroke the way
    # vpype's linesort starts (greedy with reversal, ends only)
    tours = [keep, _improved(Tour(strokes, start))]
    if len(strokes) <= ALL_TOURS_UP_TO:
        free = _improved(Tour(strokes, start, free=True))
        free.start = start
        if free.length(-1) < free.length(0):
            free.reverse()
        tours += [free, _improved(Tour(strokes, start, fixed_first=True), seams=False)]
        linesort = Tour(strokes, start, fixed_first=True)
        greedy(linesort, seams=False)
        bound = min(keep.between(), linesort.between())
    else:
        bound = np.inf
    # the shortest travel from the pen among those no longer between strokes than the file
    # order and the linesort-like order (the last tour improves on the latter by both
    # measures, so one always qualifies): then best is no longer than either, either way
    bound *= 1 + 1e-12
    pick = min((t for t in tours if t.between() <= bound), key=lambda t: t.length())
    return list(strokes) if pick is keep else pick.result()


def _improved(tour: Tour, seams: bool = True) -> Tour:
    greedy(tour, seams)
    best_seams(tour)
    ref = max(tour.length(), 1.0)
    for _ in range(PASSES):
        gain = two_opt(tour) + or_opt(tour)
        gain += best_seams(tour)
        if gain <= 1e-9 * ref:
            break
    return tour
