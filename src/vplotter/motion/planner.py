"""Motion planner: straight pieces -> a speed profile that keeps every motor inside its limits.

Pure numpy, no I/O. Input: pieces in the machine frame (mm) with a pen speed cap each.
Output: `Block`s of pieces, each with an entry, cruise and exit speed and one path
acceleration (a trapezoid in path distance), such that for each motor

- the step rate never exceeds `max_step_rate` (x RATE_MARGIN): the motor's cord speed is
  |slope| x pen speed, slope = d(cord)/d(path) from the kinematics;
- the cord acceleration stays within `max_accel` (x ACCEL_MARGIN). It is q'' v^2 + q' a along a
  piece (q' = slope, q'' = bend, a = path acceleration), plus the jumps of q' v at corners.
  Each piece is bounded with its own bend (largest of its ends and middle) at its speed cap
  (at most BEND_SHARE of the budget, which lowers the cap on a tightly bending piece), and
  with what the corners at its two ends take; its ramps get the rest: no fixed reserve.
  With signs: a corner changes each cord's speed one way (its slope change), a ramp the way
  of the slope speeding up and the other way slowing down, so a ramp that works against a
  corner has that corner's part of the budget too (`profile._ramp_limits`: each piece has a
  limit speeding up and one slowing down, the passes use each its own).

Junction rule (our "deviation" rule, in cord space): at a vertex the cord speeds change at
once by v x |slope change|. A change that lands inside one measurement window TAU counts as an
acceleration of jump / min(TAU, dt) where dt is the time to the next corner (over the shorter
piece; on a curve of chords each passed within TAU / 1.5, over half of each: `corners`,
EVEN). A corner takes
what that is at the highest speed its pieces allow, but at most CORNER_SHARE of the budget on
a curve (the next corner comes within TAU: the pen goes round at that speed, hardly speeding
up or slowing down) and at a lone sharp corner the share of SHARP_TRY that passes it and the
two pieces next to it quickest (a lower share, a slower corner, more for the pieces around it
to brake and speed up with: a near reversal is best passed nearly stopped); the vertex speed is the
largest v within that for both motors. After the passes the corners give back what they do
not use at the speeds planned (those speeds become limits) and the ramps are planned again
with it. On a smooth curve cut into short chords this is the centripetal limit
v^2 x curvature, on a sharp corner a near stop, and where a cord turns round (passes through
zero speed) it costs nothing because the slope changes continuously there.

Before planning, pieces are cut further on the same straight lines (`_refine`): next to a
sharp corner, the part covered within NEAR_TAU x TAU of it is a piece of its own, so that only
it shares the budget with the corner's jump (the 0.1 s windows further away never see the
jump); and a long piece along which the step-rate limit changes is cut in equal parts, so that
the speed follows the limit. Each window with corners is planned up to 1 + RETRY_ROUNDS
times: once with every corner keeping its share, then with each keeping what it takes at
RETRY_GAIN x the speeds of the quickest plan so far, but no more than the ramps next to it
leave at that plan (up to CORNER_TOP on a curve, where the pen goes round at an even speed and
the ramps need little); each run between two standstills keeps its quickest plan (each keeps
every limit, and nothing passes a standstill).

Look-ahead: pieces are buffered (at most 2 x WINDOW); the buffer is planned with a stop at its
end (backward pass, then forward pass, both vectorised), and what comes before its last
standstill is committed, at least its first half (`_committed`: only the rest is planned
again). Pen changes and dwells are stops inside the buffer (`mark_stop`: speed 0 there, the
events ride on the piece that ends there), so a drawing of many short strokes is planned a
window at a time, not stroke by stroke. Memory stays flat however long the file is, and the
machine can always stop in what it knows.
"""

from __future__ import annotations

from typing import Iterator

import numpy as np

# The blocks, the corner rule and the profile are modules of their own; their names stay
# importable from here.
from vplotter.motion.blocks import Block, Turn, _slice, _split  # noqa: F401
from vplotter.motion.corners import CORNER_CEIL, CORNER_TOP, RETRY_GAIN  # noqa: F401
from vplotter.motion.profile import BEND_SHARE, RETRY_MIN, RETRY_ROUNDS  # noqa: F401
from vplotter.motion.profile import motor_path, profile  # noqa: F401
from vplotter.motion.refine import CORNER_SHARE, MIN_SLOPE, SHARP_TRY, TAU_S  # noqa: F401
from vplotter.motion.refine import put_in, refine, scaled, sharp_shares  # noqa: F401

RATE_MARGIN = 0.998    # of max_step_rate: step times are rounded to microseconds
ACCEL_MARGIN = 0.96    # of max_accel
SHARP_SHARE = 0.25     # what a chord's sharp corner is taken to get (segment.chord_turn)

WINDOW = 2048          # pieces committed per planning round


def _committed(origin: np.ndarray, stop: np.ndarray, window: int) -> int:
    """How many of a window's pieces to commit: up to its last standstill inside (where the
    plan of what comes before no longer depends on what comes after: planned again, the
    next round would plan them the same), but at least those from its first `window` input
    pieces."""
    n = max(int(np.searchsorted(origin, window, side="left")), 1)
    last = np.flatnonzero(stop[:-1])
    return max(n, int(last[-1]) + 1) if len(last) else n


class Planner:
    """Feed pieces with `add`, end a stroke with `stop`; both yield planned Blocks (and Turns
    where the motors must move with the pen standing still)."""

    def __init__(self, kin, max_step_rate: float, max_accel: float, steps_per_unit,
                 start_xy: np.ndarray, window: int = WINDOW, start_q=None):
        """steps_per_unit: steps per unit of each motor's coordinate (one value or one per
        motor); the limits are per motor in steps. start_q: the motor coordinates at start_xy
        (where an angle is unwrapped from)."""
        self.kin = kin
        spu = np.broadcast_to(np.asarray(steps_per_unit, dtype=float), (len(kin.motors),))
        self.v_cord = max_step_rate * RATE_MARGIN / spu       # (M,) motor units/s
        self.a_cord = max_accel * ACCEL_MARGIN / spu          # (M,) motor units/s^2
        self.window = window
        self.last = np.asarray(start_xy, dtype=float).reshape(2)
        self._pts: list[np.ndarray] = []
        self._cap: list[np.ndarray] = []
        self._line: list[np.ndarray] = []
        self._draw: list[np.ndarray] = []
        self._stops: dict[int, list] = {}   # buffered input piece -> what happens after it
        self._count = 0
        self._start = self.last.copy()
        self._start_q = (kin.inverse(self._start[None, :])[0] if start_q is None
                         else np.asarray(start_q, dtype=float).copy())
        self._u_entry = 0.0

    @property
    def position(self) -> np.ndarray:
        return self.last

    def add(self, pts: np.ndarray, cap_mm_s, line, drawing,
            stops: dict[int, list] | None = None) -> Iterator[Block]:
        """Append pieces from the current position through pts (K, 2) machine mm; cap, line and
        drawing are scalars or one value per point; stops {i: events}: the machine stands
        still at point i, where the events (pen changes, dwells) happen (see `mark_stop`).
        No piece may be shorter than 1 nm (see `nonzero`)."""
        k = len(pts)
        if k == 0:
            return
        for i, events in (stops or {}).items():
            self._stops.setdefault(self._count + i, []).extend(events)
        self._pts.append(pts)
        self._cap.append(np.broadcast_to(np.asarray(cap_mm_s, dtype=float), (k,)))
        self._line.append(np.broadcast_to(np.asarray(line, dtype=np.int64), (k,)))
        self._draw.append(np.broadcast_to(np.asarray(drawing, dtype=bool), (k,)))
        self._count += k
        self.last = pts[-1]
        while self._count >= 2 * self.window:
            yield from self._plan(final=False)

    def stop(self) -> Iterator[Block]:
        """Plan everything buffered with a full stop at its end."""
        if self._count:
            yield from self._plan(final=True)

    def mark_stop(self, events: list) -> bool:
        """The machine stops where the pieces added so far end, and the events happen there:
        the block holding that piece has `stop` set on it and carries the events. False if
        nothing is buffered (the machine is standing already: the events can happen now)."""
        if not self._count:
            return False
        self._stops.setdefault(self._count - 1, []).extend(events)
        return True

    def nonzero(self, pts: np.ndarray) -> np.ndarray:
        """Which of pts (K, 2) to keep so that no piece from the current position on is
        shorter than 1 nm."""
        step = np.diff(np.vstack((self.last[None, :], pts)), axis=0)
        keep = np.hypot(step[:, 0], step[:, 1]) > 1e-9
        if keep.all():
            return keep
        last = self.last                    # rare: against the last point kept, one by one
        for i, p in enumerate(pts):
            keep[i] = bool(np.hypot(*(p - last)) > 1e-9)
            if keep[i]:
                last = p
        return keep

    def _take(self):
        pts = np.concatenate(self._pts)
        cap = np.concatenate(self._cap)
        line = np.concatenate(self._line)
        draw = np.concatenate(self._draw)
        stop = np.zeros(len(pts), dtype=bool)
        stop[list(self._stops)] = True
        return pts, cap, line, draw, stop

    def _plan(self, final: bool) -> Iterator[Block]:
        pts, raw_cap, raw_line, raw_draw, raw_stop = self._take()
        verts = np.vstack((self._start[None, :], pts))
        verts, cap, line, draw, stop, origin = refine(
            self.kin, self.v_cord, self.a_cord,
            *self._pieces(verts, raw_cap, raw_line, raw_draw, raw_stop))
        events = [self._stops[int(i)] for i in origin[stop]]
        if len(verts) < 2 or final:
            entry = self._u_entry
            q0 = self._start_q
            self._reset(pts[:0], raw_cap[:0], raw_line[:0], raw_draw[:0], pts[-1])
            self._u_entry = 0.0 if final else entry
            if len(verts) >= 2:
                block, _, q_in, turns = self._profile(verts, cap, line, draw, stop, entry,
                                                      events, q0)
                self._start_q = q_in[-1]
                yield from _split(block, q_in, turns, len(block.d))
            return
        block, u, q_in, turns = self._profile(verts, cap, line, draw, stop, self._u_entry,
                                              events, self._start_q)
        n = _committed(origin, stop, self.window)
        yield from _split(block, q_in, turns, n)
        raw_keep = int(origin[n]) if n < len(origin) else len(pts)
        self._u_entry = float(u[n])
        self._start_q = q_in[n]       # a turn at vertex n is made in the next round
        # the committed end vertex is exactly pts[raw_keep - 1], where the kept pieces start
        self._reset(pts[raw_keep:], raw_cap[raw_keep:], raw_line[raw_keep:],
                    raw_draw[raw_keep:], block.verts[n])

    def _reset(self, pts, cap, line, draw, start) -> None:
        self._pts = [pts] if len(pts) else []
        self._cap = [cap] if len(pts) else []
        self._line = [line] if len(pts) else []
        self._draw = [draw] if len(pts) else []
        cut = self._count - len(pts)
        self._stops = {i - cut: ev for i, ev in self._stops.items() if i >= cut}
        self._count = len(pts)
        self._start = np.asarray(start, dtype=float).copy()

    def _pieces(self, verts, cap, line, draw, stop):
        """Cut pieces where a motor turns round (`add` keeps no zero-length pieces).

        Returns the vertices, per-piece attributes and, per piece, the index of the input
        piece it came from. A stop stays at the end of the last part of its piece.
        """
        diff = np.diff(verts, axis=0)
        d = np.hypot(diff[:, 0], diff[:, 1])
        origin = np.arange(len(d))
        if len(d) == 0:
            return verts, cap, line, draw, stop, origin
        e = scaled(diff, d, divide=True)
        ext = self.kin.extrema(verts[:-1], e, d)                  # (N, M) or NaN
        if np.isnan(ext).all():
            return verts, cap, line, draw, stop, origin           # (most windows)
        cuts = np.concatenate((ext, d[:, None]), axis=1)
        cuts.sort(axis=1)                                         # NaN last
        ok = ~np.isnan(cuts)
        piece = np.repeat(np.arange(len(d)), ok.sum(axis=1))
        s = cuts[ok]
        # drop cuts that would make pieces shorter than 1 nm
        prev = np.concatenate(([0.0], s[:-1]))
        first = np.concatenate(([True], piece[1:] != piece[:-1]))
        prev[first] = 0.0
        good = (s - prev > 1e-9) | (s == d[piece])
        good &= ~((s != d[piece]) & (d[piece] - s <= 1e-9))
        piece, s = piece[good], s[good]
        end = s == d[piece]
        verts = put_in(self.kin, verts, e, piece, s, end)
        return verts, cap[piece], line[piece], draw[piece], stop[piece] & end, origin[piece]

    def _profile(self, verts, cap, line, draw, stop, u_entry, events, q0):
        """The planned Block of a window and its vertex speeds (`profile.profile`)."""
        return profile(self.kin, self.v_cord, self.a_cord, verts, cap, line, draw, stop,
                       u_entry, events, q0)
