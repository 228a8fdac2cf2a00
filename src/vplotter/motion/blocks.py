"""The planner's output: `Block`s of straight pieces, each a trapezoid in path distance (entry,
cruise and exit speed, one path acceleration), with the timing of their phases; `Turn`s, where
the motors move with the pen standing still; and the cutting of a planned window into them."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from vplotter.motion.refine import scaled


@dataclass
class Block:
    """Planned straight pieces; arrays have one row per piece (N) or per vertex (N + 1)."""

    verts: np.ndarray      # (N+1, 2) machine mm
    cords: np.ndarray      # (N+1, M) motor coordinates at the vertices (mm)
    d: np.ndarray          # (N,) piece lengths mm
    v0: np.ndarray         # entry speed mm/s
    vp: np.ndarray         # peak (cruise) speed
    v1: np.ndarray         # exit speed
    a: np.ndarray          # path acceleration mm/s^2 used on the ramps
    line: np.ndarray       # (N,) G-code line of each piece
    drawing: np.ndarray    # (N,) pen down?
    cap: np.ndarray        # (N,) pen speed cap from the G-code and config (mm/s)
    stop: np.ndarray       # (N,) the machine stops at the end of this piece (pen, dwell)
    events: list           # what happens at each stop, in order (one list per True in stop)
    dur: np.ndarray | None = field(default=None, repr=False, compare=False)   # `durations`

    @property
    def e(self) -> np.ndarray:
        diff = np.diff(self.verts, axis=0)
        return scaled(diff, self.d, divide=True)

    @property
    def d_acc(self) -> np.ndarray:
        return (self.vp ** 2 - self.v0 ** 2) / (2 * self.a)

    @property
    def d_dec(self) -> np.ndarray:
        return (self.vp ** 2 - self.v1 ** 2) / (2 * self.a)

    def phase_times(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Durations of the accelerate, cruise and decelerate phases of each piece."""
        t_acc = (self.vp - self.v0) / self.a
        t_dec = (self.vp - self.v1) / self.a
        d_cru = np.maximum(self.d - self.d_acc - self.d_dec, 0.0)
        return t_acc, d_cru / self.vp, t_dec

    @property
    def durations(self) -> np.ndarray:
        """Each piece's time (found once: a block is not changed once planned)."""
        if self.dur is None:
            t_acc, t_cru, t_dec = self.phase_times()
            self.dur = t_acc + t_cru + t_dec
        return self.dur

    def phase_table(self, t_start: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
        """Per piece and phase (row 3 * piece + phase: accelerate, cruise, decelerate): the
        time the phase starts (from t_start of each piece, default 0), the path distance it
        starts at, the speed it starts with and its path acceleration; and per piece the
        distances where cruising and decelerating start."""
        n = len(self.d)
        t_acc, t_cru, t_dec = self.phase_times()
        d_acc = self.d_acc
        d_cru = np.maximum(self.d - d_acc - self.d_dec, 0.0)
        t0 = np.zeros(n) if t_start is None else t_start
        T = np.column_stack((t0, t0 + t_acc, t0 + t_acc + t_cru)).ravel()
        S = np.column_stack((np.zeros(n), d_acc, d_acc + d_cru)).ravel()
        V = np.column_stack((self.v0, self.vp, self.vp)).ravel()
        A = np.column_stack((self.a, np.zeros(n), -self.a)).ravel()
        return T, S, V, A, d_acc, d_acc + d_cru

    def time_at(self, piece: np.ndarray, s: np.ndarray, table=None) -> np.ndarray:
        """Time since the piece started (or since the table's t_start) at which the pen has
        gone s mm along it: t = T + 2 sigma / (v + sqrt(v^2 + 2 a sigma)), sigma = s - S, in the
        phase that holds s (one formula for the three phases; a = 0 while cruising)."""
        T, S, V, A, s_cru, s_dec = table if table is not None else self.phase_table()
        k = 3 * piece + (s > s_cru[piece]) + (s > s_dec[piece])
        sig = s - S[k]
        v = V[k]
        root = np.sqrt(np.maximum(v * v + 2.0 * A[k] * sig, 0.0))
        return T[k] + 2.0 * sig / np.maximum(v + root, 1e-300)


@dataclass
class Turn:
    """The motors move to q (motor coordinates) while the pen stands still (the polar table
    turning at the centre), from rest to rest, between two Blocks."""

    q: np.ndarray
    line: int


def _slice(b: Block, i: int, j: int, events: list | None = None) -> Block:
    """Pieces i to j of b (events: the events of its stops, if the caller knows them)."""
    if events is None:
        events = b.events[int(b.stop[:i].sum()):int(b.stop[:j].sum())]
    return Block(b.verts[i:j + 1], b.cords[i:j + 1], b.d[i:j], b.v0[i:j], b.vp[i:j], b.v1[i:j],
                 b.a[i:j], b.line[i:j], b.drawing[i:j], b.cap[i:j], b.stop[i:j], events,
                 None if b.dur is None else b.dur[i:j])


def _split(b: Block, q_in: np.ndarray, turns: np.ndarray, n: int) -> Iterator[Block | Turn]:
    """The first n pieces of b, cut into Blocks at the vertices where the motors turn in place
    (a Turn between them); a turn at vertex n is left for the next round."""
    i = 0
    for j in [*turns[turns < n].tolist(), n]:
        if j > i:
            part = _slice(b, i, j)
            part.cords = part.cords.copy()
            part.cords[-1] = q_in[j]       # the motors before the turn at j
            yield part
        if j < n:
            yield Turn(b.cords[j].copy(), int(b.line[min(j, len(b.line) - 1)]))
        i = j
