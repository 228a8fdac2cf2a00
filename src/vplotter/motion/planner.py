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

Junction rule (our "deviation" rule, in cord space): at a vertex the cord speeds change at
once by v x |slope change|. A change that lands inside one measurement window TAU counts as an
acceleration of jump / min(TAU, dt) where dt is the time to the next corner. A corner takes
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
the ramps need little); the quickest plan is kept (each keeps every limit).

Look-ahead: pieces are buffered (at most 2 x WINDOW); the buffer is planned with a stop at its
end (backward pass, then forward pass, both vectorised), and the first half is committed. Pen
changes and dwells are stops inside the buffer (`mark_stop`: speed 0 there, the events ride on
the piece that ends there), so a drawing of many short strokes is planned a window at a time,
not stroke by stroke. Memory stays flat however long the file is, and the machine can always
stop in what it knows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from vplotter.motion.refine import (CORNER_SHARE, MIN_SLOPE, SHARP_TRY, TAU_S,  # noqa: F401
                                    refine, sharp_shares)

RATE_MARGIN = 0.998    # of max_step_rate: step times are rounded to microseconds
ACCEL_MARGIN = 0.96    # of max_accel
SHARP_SHARE = 0.25     # what a chord's sharp corner is taken to get (pipeline._chord_turn)
BEND_SHARE = 0.4       # most of it the bending along a piece may take at the speed cap
RETRY_GAIN = 1.2       # later plans: corners keep what they take at this x the best plan's speed
RETRY_ROUNDS = 3       # plans after the first (the quickest is kept)
RETRY_MIN = 1e-3       # no further round after one that won less than this share of the time
CORNER_CEIL = 0.9      # a corner and the bending next to it take at most this together (first plan)
CORNER_TOP = 0.98      # and in later plans, on a curve, where the ramps next to it leave that

WINDOW = 2048          # pieces committed per planning round


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

    @property
    def e(self) -> np.ndarray:
        diff = np.diff(self.verts, axis=0)
        return diff / self.d[:, None]

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
        t_acc, t_cru, t_dec = self.phase_times()
        return t_acc + t_cru + t_dec

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
        return T[k] + 2.0 * sig / np.maximum(v + np.sqrt(np.maximum(v * v + 2.0 * A[k] * sig, 0.0)),
                                              1e-300)


@dataclass
class Turn:
    """The motors move to q (motor coordinates) while the pen stands still (the polar table
    turning at the centre), from rest to rest, between two Blocks."""

    q: np.ndarray
    line: int


def motor_path(kin, verts: np.ndarray, q0) -> tuple[np.ndarray, np.ndarray]:
    """Motor coordinates before and after each vertex of a polyline that starts with the motors
    at q0 (the same where the kinematics has no place to turn in place)."""
    path = getattr(kin, "path", None)
    if path is not None:
        return path(verts, q0)
    q = kin.inverse(verts)
    return q, q


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
        # commit the pieces that come from the first `window` input pieces
        n = int(np.searchsorted(origin, self.window, side="left"))
        n = max(n, 1)
        yield from _split(block, q_in, turns, n)
        raw_keep = int(origin[n]) if n < len(origin) else len(pts)
        self._u_entry = float(u[n])
        self._start_q = q_in[n]       # a turn at vertex n is made in the next round
        # the committed end vertex is exactly pts[raw_keep - 1], where the kept pieces start
        self._reset(pts[raw_keep:], raw_cap[raw_keep:], raw_line[raw_keep:], raw_draw[raw_keep:],
                    block.verts[n])

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
        e = diff / d[:, None]
        ext = self.kin.extrema(verts[:-1], e, d)                  # (N, M) or NaN
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
        new = verts[piece] + e[piece] * s[:, None]
        end = s == d[piece]
        new[end] = verts[1:][piece[end]]
        verts = np.vstack((verts[:1], new))
        return verts, cap[piece], line[piece], draw[piece], stop[piece] & end, origin[piece]

    def _profile(self, verts, cap, line, draw, stop, u_entry, events, q0):
        kin = self.kin
        q_in, q_out = motor_path(kin, verts, q0)
        turns = np.flatnonzero(np.any(q_in != q_out, axis=1))
        diff = np.diff(verts, axis=0)
        d = np.hypot(diff[:, 0], diff[:, 1])
        e = diff / d[:, None]
        k0 = kin.slope(verts[:-1], e)
        k1 = kin.slope(verts[1:], e)
        kmax = np.maximum(np.abs(k0), np.abs(k1))
        # the bend is largest at an end or (for other machine kinds) inside: ends and middle
        mid = 0.5 * (verts[:-1] + verts[1:])
        bend = np.maximum(np.maximum(np.abs(kin.bend(verts[:-1], e)), np.abs(kin.bend(verts[1:], e))),
                          np.abs(kin.bend(mid, e)))
        acc = self.a_cord                                         # (M,)
        v_rate = (self.v_cord / np.maximum(kmax, 1e-9)).min(axis=1)
        v_bend = np.sqrt(BEND_SHARE * acc / np.maximum(bend, 1e-12)).min(axis=1)
        vcap = np.minimum(np.minimum(cap, v_rate), v_bend)
        n = len(d)
        # corners: the budget each one takes, at most CORNER_SHARE, and the vertex speed
        corner = np.zeros((n + 1, len(acc)))
        u_lim = np.empty(n + 1)
        u_lim[0] = u_entry
        if n > 1:
            jump = np.abs(k0[1:] - k1[:-1])                       # (n-1, M)
            ds = np.minimum(d[1:], d[:-1])[:, None]
            vc = np.minimum(vcap[1:], vcap[:-1])
            # what the corner takes passed at the highest speed its pieces allow
            use = jump * vc[:, None] * np.maximum(1.0 / TAU_S, vc[:, None] / ds)

            def corner_speed(budget):
                # jump * v * max(1/TAU, v/ds) <= budget  <=>  both limits, for every motor
                with np.errstate(divide="ignore", invalid="ignore"):
                    v_tau = np.where(jump > 0, budget * TAU_S / jump, np.inf).min(axis=1)
                    v_ds = np.where(jump > 0, np.sqrt(budget * ds / jump), np.inf).min(axis=1)
                return np.minimum(np.minimum(v_tau, v_ds), vc)

            # A corner on a curve (the next one follows within TAU) may take much of the
            # budget: the pen goes round at that speed without speeding up or slowing down.
            # A lone sharp corner is passed slowly anyway; the pieces around it get more.
            v_hi = corner_speed(CORNER_SHARE * acc)
            curve = v_hi * TAU_S >= ds[:, 0]
            # a sharp corner: the share that passes it and the pieces next to it quickest
            share = np.full(n - 1, CORNER_SHARE)
            # (where even the least share passes it at full speed, the least is quickest)
            low = corner_speed(SHARP_TRY[0] * acc) >= vc
            share[~curve & low] = SHARP_TRY[0]
            sharp = np.flatnonzero(~curve & ~low)
            if len(sharp):
                far = np.concatenate(([np.inf], v_hi, [np.inf]))
                share[sharp] = sharp_shares(jump[sharp], acc, kmax[sharp], kmax[sharp + 1],
                                             d[sharp], d[sharp + 1], vcap[sharp], vcap[sharp + 1],
                                             vc[sharp], ds[sharp, 0], far[sharp], far[sharp + 2])
            share = share[:, None] * acc
            # and never so much that the bending leaves the ramps nothing
            bent_hi = (bend * (vcap ** 2)[:, None])
            bent_end = np.maximum(bent_hi[1:], bent_hi[:-1])
            ceil = np.maximum(CORNER_CEIL * acc - bent_end, 0.0)
            corner[1:n] = np.minimum(np.minimum(use, share), ceil)
            corner[1:n][stop[:-1]] = 0.0                         # passed standing still
            # the most a corner may keep in the later plans
            top = np.zeros_like(corner)
            top[1:n] = np.minimum(use, np.where(curve[:, None], np.maximum(CORNER_TOP * acc - bent_end, 0.0),
                                                np.minimum(share, ceil)))
            top[1:n][stop[:-1]] = 0.0
        bent = bend * (vcap ** 2)[:, None]
        u_lim[0] = min(u_lim[0], vcap[0] ** 2)
        zero = np.zeros(n + 1, dtype=bool)
        zero[1:][stop] = True
        zero[n] = True
        zero[turns] = True                                        # the motors turn at rest

        def planned(reserve):
            """Vertex speeds and ramp accelerations with `reserve` of the budget kept for
            each corner: the corner is passed at most at what that allows, the pieces next
            to it speed up and slow down with what bending and the corners at its ends leave.
            Then the corners take what they need at the speeds planned (no more: those speeds
            become limits) and the pieces next to them get the rest."""
            lim = u_lim.copy()
            if n > 1:
                lim[1:n] = corner_speed(reserve[1:n]) ** 2
            lim[zero] = 0.0
            a = ((acc - np.maximum(reserve[:-1], reserve[1:]) - bent)
                 / np.maximum(kmax, MIN_SLOPE)).min(axis=1)
            u = _passes(lim, 2.0 * a * d)
            if n > 1:
                v = np.sqrt(u[1:n])[:, None]
                used = reserve.copy()
                used[1:n] = np.minimum(reserve[1:n], jump * v * np.maximum(1.0 / TAU_S, v / ds))
                a = ((acc - np.maximum(used[:-1], used[1:]) - bent)
                     / np.maximum(kmax, MIN_SLOPE)).min(axis=1)
                u = _passes(np.minimum(lim, u), 2.0 * a * d)
            return u, a

        u, a = planned(corner)
        if n > 1:
            # Again, a few times, with each corner keeping what it takes a little above the
            # speed of the quickest plan so far, but no more than the ramps next to it leave
            # at that plan (and at least what it takes at that plan): where the ramps limited
            # a corner they get more, where the corner limited the speed it gets what the
            # ramps do not use (up to CORNER_TOP on a curve: the pen goes round at an even
            # speed). Every plan keeps every limit; the quickest is kept.
            best = _time(u, a, d, vcap)
            slope = np.maximum(kmax, MIN_SLOPE)
            for _ in range(int(RETRY_ROUNDS)):
                v = np.sqrt(u[1:n])[:, None]
                now = jump * v * np.maximum(1.0 / TAU_S, v / ds)
                v = np.minimum(v * RETRY_GAIN, vc[:, None])
                again = top.copy()
                again[1:n] = np.minimum(top[1:n], jump * v * np.maximum(1.0 / TAU_S, v / ds))
                need = np.abs(np.diff(u))[:, None] / (2.0 * d[:, None]) * slope + bent
                room = acc - np.maximum(need[1:], need[:-1])
                again[1:n] = np.minimum(again[1:n], np.maximum(room, np.minimum(now, again[1:n])))
                u2, a2 = planned(again)
                t2 = _time(u2, a2, d, vcap)
                if t2 >= best:
                    break                   # the next round would plan the same again
                u, a, best, gain = u2, a2, t2, best - t2
                if gain < RETRY_MIN * best:
                    break                   # little more to win
        inc = 2.0 * a * d
        u0, u1 = u[:-1], u[1:]
        up = np.minimum(vcap ** 2, (u0 + u1 + inc) / 2.0)
        up = np.maximum(up, np.maximum(u0, u1))
        block = Block(verts, q_out, d, np.sqrt(u0), np.sqrt(up), np.sqrt(u1), a, line, draw, cap,
                      stop, events)
        return block, u, q_in, turns




def _time(u, a, d, vcap) -> float:
    """Time of the trapezoids through squared vertex speeds u."""
    u0, u1 = u[:-1], u[1:]
    up = np.maximum(np.minimum(vcap ** 2, (u0 + u1 + 2.0 * a * d) / 2.0), np.maximum(u0, u1))
    vp = np.sqrt(up)
    d_cru = np.maximum(d - (2.0 * up - u0 - u1) / (2.0 * a), 0.0)
    return float(((2.0 * vp - np.sqrt(u0) - np.sqrt(u1)) / a + d_cru / np.maximum(vp, 1e-300)).sum())


def _passes(u_lim: np.ndarray, inc: np.ndarray) -> np.ndarray:
    """Largest squared vertex speeds within u_lim that the pieces can speed up and slow down
    between (u[j+1] - u[j] <= inc[j] both ways): a backward and a forward pass."""
    r = np.concatenate((np.cumsum(inc[::-1])[::-1], [0.0]))   # r[j] = sum inc[j:]
    u = r + np.minimum.accumulate((u_lim - r)[::-1])[::-1]
    f = np.concatenate(([0.0], np.cumsum(inc)))
    u = f + np.minimum.accumulate(u - f)
    return np.maximum(u, 0.0)


def _slice(b: Block, i: int, j: int) -> Block:
    return Block(b.verts[i:j + 1], b.cords[i:j + 1], b.d[i:j], b.v0[i:j], b.vp[i:j], b.v1[i:j],
                 b.a[i:j], b.line[i:j], b.drawing[i:j], b.cap[i:j], b.stop[i:j],
                 b.events[int(b.stop[:i].sum()):int(b.stop[:j].sum())])


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
