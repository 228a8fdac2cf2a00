"""A tour of strokes for the ordering (`order`): per position the stroke, whether it is drawn
reversed and, for a closed stroke, its seam; its travel, and the strokes it draws."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from vplotter.inputs.strokes import Stroke


class Tour:
    """A tour as arrays: stroke index, reversed flag and seam (closed strokes) per position."""

    def __init__(self, strokes: list[Stroke], start: np.ndarray, free: bool = False,
                 fixed_first: bool = False):
        self.strokes = strokes
        self.fixed_first = fixed_first            # strokes[0] stays first, as it is
        self.origin = start                       # where the pen is (the greedy starts there)
        self.start = np.full(2, np.nan) if free else start   # free: the first leg costs nothing
        self.closed = np.array([s.closed for s in strokes])
        self.first = np.array([s.pts[0] for s in strokes], dtype=float)
        self.last = np.array([s.pts[-1] for s in strokes], dtype=float)
        self.perm = np.arange(len(strokes))
        self.rev = np.zeros(len(strokes), dtype=bool)
        self.seam = np.zeros(len(strokes), dtype=np.int64)       # by stroke index

    def ends(self, lo: int = 0, hi: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Entry and exit point of each tour position (of positions lo..hi-1)."""
        p, r = self.perm[lo:hi], self.rev[lo:hi]
        a, b = self.first[p], self.last[p]
        entry = np.where(r[:, None], b, a)
        exit_ = np.where(r[:, None], a, b)
        return entry, exit_

    def length(self, first: int = 0) -> float:
        """Travel from the start (the first leg left out in a free tour); first=-1: the tour
        run backwards."""
        entry, exit_ = self.ends()
        if first == -1:
            entry, exit_ = exit_[::-1], entry[::-1]
        prev = np.vstack([self.start[None, :], exit_[:-1]])
        return float(np.nansum(np.hypot(*(entry - prev).T)))

    def between(self) -> float:
        """Travel between strokes only (vpype's pen_up_length)."""
        entry, exit_ = self.ends()
        return float(np.hypot(*(entry[1:] - exit_[:-1]).T).sum())

    def reverse(self) -> None:
        self.perm = self.perm[::-1].copy()
        self.rev = ~self.rev[::-1]

    def set_seam(self, i: int, v: int) -> None:
        """Closed stroke i enters and leaves at its vertex v."""
        self.seam[i] = v
        self.first[i] = self.last[i] = self.strokes[i].pts[v]

    def result(self) -> list[Stroke]:
        out = []
        for i, r in zip(self.perm.tolist(), self.rev.tolist()):
            s = self.strokes[i]
            if self.closed[i]:
                v = int(self.seam[i])
                if v:
                    q = s.pts[:-1]
                    s = replace(s, pts=np.concatenate([q[v:], q[:v], q[v:v + 1]]))
            elif r:
                s = replace(s, pts=s.pts[::-1].copy())
            out.append(s)
        return out
