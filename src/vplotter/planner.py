"""Motion planner: straight pieces -> a speed profile that keeps every motor inside its limits.

Pure numpy, no I/O. Input: pieces in the machine frame (mm) with a pen speed cap each.
Output: `Block`s of pieces, each with an entry, cruise and exit speed and one path
acceleration (a trapezoid in path distance), such that for each motor

- the step rate never exceeds `max_step_rate` (x RATE_MARGIN): the motor's cord speed is
  |slope| x pen speed, slope = d(cord)/d(path) from the kinematics;
- the cord acceleration stays within `max_accel`: (1 - BEND_SHARE) of it is spent on speeding
  up and slowing down along the path (|slope| x path acceleration), BEND_SHARE on the bending
  of the path (d2 cord/ds2 x v^2 along a straight piece, and the jump of slope at a corner).

Junction rule (our "deviation" rule, in cord space): at a vertex the cord speeds change at
once by v x |slope change|. A change that lands inside one measurement window TAU counts as an
acceleration of jump / min(TAU, dt) where dt is the time to the next corner; the vertex speed
is the largest v for which that stays within BEND_SHARE x max_accel for both motors. On a
smooth curve cut into short chords this becomes the centripetal limit v^2 x curvature, on a
sharp corner it is a near stop, and where a cord turns round (passes through zero speed) it
costs nothing because the slope changes continuously there.

Look-ahead: pieces are buffered (at most 2 x WINDOW); the buffer is planned with a stop at its
end (backward pass, then forward pass, both vectorised), and the first half is committed. So
memory stays flat however long the file is, and the machine can always stop in what it knows.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

RATE_MARGIN = 0.99     # of max_step_rate: the trace rounds times to microseconds
ACCEL_MARGIN = 0.95    # of max_accel
BEND_SHARE = 0.35      # of the acceleration budget kept for corners and bending
TAU_S = 0.1            # acceleration measurement window for speed jumps at corners
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

    def time_at(self, piece: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Time since the piece started at which the pen has gone s mm along it."""
        v0, vp, a = self.v0[piece], self.vp[piece], self.a[piece]
        d_acc, d_dec, d = self.d_acc[piece], self.d_dec[piece], self.d[piece]
        d_cru = np.maximum(d - d_acc - d_dec, 0.0)
        t_acc = (vp - v0) / a
        t_cru = d_cru / vp
        s_acc = np.minimum(s, d_acc)
        t = 2 * s_acc / np.maximum(v0 + np.sqrt(v0 * v0 + 2 * a * s_acc), 1e-300)
        s_cru = np.clip(s - d_acc, 0.0, d_cru)
        t = np.where(s > d_acc, t_acc + s_cru / vp, t)
        sig = np.clip(s - d_acc - d_cru, 0.0, d_dec)
        t_d = 2 * sig / np.maximum(vp + np.sqrt(np.maximum(vp * vp - 2 * a * sig, 0.0)), 1e-300)
        return np.where(s > d_acc + d_cru, t_acc + t_cru + t_d, t)


class Planner:
    """Feed pieces with `add`, end a stroke with `stop`; both yield planned Blocks."""

    def __init__(self, kin, max_step_rate: float, max_accel: float, steps_per_unit,
                 start_xy: np.ndarray, window: int = WINDOW):
        """steps_per_unit: steps per unit of each motor's coordinate (one value or one per
        motor); the limits are per motor in steps."""
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
        self._count = 0
        self._start = self.last.copy()
        self._u_entry = 0.0

    @property
    def position(self) -> np.ndarray:
        return self.last

    def add(self, pts: np.ndarray, cap_mm_s, line, drawing) -> Iterator[Block]:
        """Append pieces from the current position through pts (K, 2) machine mm; cap, line and
        drawing are scalars or one value per point."""
        k = len(pts)
        if k == 0:
            return
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

    def _take(self):
        pts = np.concatenate(self._pts)
        cap = np.concatenate(self._cap)
        line = np.concatenate(self._line)
        draw = np.concatenate(self._draw)
        return pts, cap, line, draw

    def _plan(self, final: bool) -> Iterator[Block]:
        pts, raw_cap, raw_line, raw_draw = self._take()
        verts = np.vstack((self._start[None, :], pts))
        verts, cap, line, draw, origin = self._pieces(verts, raw_cap, raw_line, raw_draw)
        if len(verts) < 2 or final:
            entry = self._u_entry
            self._reset(pts[:0], raw_cap[:0], raw_line[:0], raw_draw[:0], pts[-1])
            self._u_entry = 0.0 if final else entry
            if len(verts) >= 2:
                yield self._profile(verts, cap, line, draw, entry)[0]
            return
        block, u = self._profile(verts, cap, line, draw, self._u_entry)
        # commit the pieces that come from the first `window` input pieces
        n = int(np.searchsorted(origin, self.window, side="left"))
        n = max(n, 1)
        yield _slice(block, 0, n)
        raw_keep = int(origin[n]) if n < len(origin) else len(pts)
        self._u_entry = float(u[n])
        # the committed end vertex is exactly pts[raw_keep - 1], where the kept pieces start
        self._reset(pts[raw_keep:], raw_cap[raw_keep:], raw_line[raw_keep:], raw_draw[raw_keep:],
                    block.verts[n])

    def _reset(self, pts, cap, line, draw, start) -> None:
        self._pts = [pts] if len(pts) else []
        self._cap = [cap] if len(pts) else []
        self._line = [line] if len(pts) else []
        self._draw = [draw] if len(pts) else []
        self._count = len(pts)
        self._start = np.asarray(start, dtype=float).copy()

    def _pieces(self, verts, cap, line, draw):
        """Drop zero-length pieces and cut pieces where a motor turns round.

        Returns the vertices, per-piece attributes and, per piece, the index of the input
        piece it came from.
        """
        diff = np.diff(verts, axis=0)
        d = np.hypot(diff[:, 0], diff[:, 1])
        keep = d > 1e-9
        origin = np.flatnonzero(keep)
        verts = np.vstack((verts[:1], verts[1:][keep]))
        diff = np.diff(verts, axis=0)
        d = np.hypot(diff[:, 0], diff[:, 1])
        cap, line, draw = cap[keep], line[keep], draw[keep]
        if len(d) == 0:
            return verts, cap, line, draw, origin
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
        return verts, cap[piece], line[piece], draw[piece], origin[piece]

    def _profile(self, verts, cap, line, draw, u_entry):
        kin = self.kin
        diff = np.diff(verts, axis=0)
        d = np.hypot(diff[:, 0], diff[:, 1])
        e = diff / d[:, None]
        k0 = kin.slope(verts[:-1], e)
        k1 = kin.slope(verts[1:], e)
        kmax = np.maximum(np.abs(k0), np.abs(k1))
        bend = np.maximum(np.abs(kin.bend(verts[:-1], e)), np.abs(kin.bend(verts[1:], e)))
        v_rate = (self.v_cord / np.maximum(kmax, 1e-9)).min(axis=1)
        bend_budget = BEND_SHARE * self.a_cord                    # (M,)
        v_bend = np.sqrt(bend_budget / np.maximum(bend, 1e-12)).min(axis=1)
        vcap = np.minimum(np.minimum(cap, v_rate), v_bend)
        a = ((1.0 - BEND_SHARE) * self.a_cord / np.maximum(kmax, 0.25)).min(axis=1)
        # vertex limits
        n = len(d)
        u_lim = np.empty(n + 1)
        u_lim[0] = u_entry
        u_lim[n] = 0.0
        if n > 1:
            jump = np.abs(k0[1:] - k1[:-1])                       # (n-1, M)
            ds = np.minimum(d[1:], d[:-1])[:, None]
            # jump * v <= budget * min(TAU, ds / v)  <=>  both limits below, for every motor
            with np.errstate(divide="ignore", invalid="ignore"):
                v_tau = np.where(jump > 0, bend_budget * TAU_S / jump, np.inf).min(axis=1)
                v_ds = np.where(jump > 0, np.sqrt(bend_budget * ds / jump), np.inf).min(axis=1)
            v_vert = np.minimum(np.minimum(v_tau, v_ds), np.minimum(vcap[1:], vcap[:-1]))
            u_lim[1:n] = v_vert ** 2
        u_lim[0] = min(u_lim[0], vcap[0] ** 2)
        inc = 2.0 * a * d
        # backward pass: u[j] <= u[j+1] + inc[j]
        r = np.concatenate((np.cumsum(inc[::-1])[::-1], [0.0]))   # r[j] = sum inc[j:]
        u = r + np.minimum.accumulate((u_lim - r)[::-1])[::-1]
        # forward pass: u[j+1] <= u[j] + inc[j]
        f = np.concatenate(([0.0], np.cumsum(inc)))
        u = f + np.minimum.accumulate(u - f)
        u = np.maximum(u, 0.0)
        u0, u1 = u[:-1], u[1:]
        up = np.minimum(vcap ** 2, (u0 + u1 + inc) / 2.0)
        up = np.maximum(up, np.maximum(u0, u1))
        cords = kin.inverse(verts)
        block = Block(verts, cords, d, np.sqrt(u0), np.sqrt(up), np.sqrt(u1), a, line, draw, cap)
        return block, u


def _slice(b: Block, i: int, j: int) -> Block:
    return Block(b.verts[i:j + 1], b.cords[i:j + 1], b.d[i:j], b.v0[i:j], b.vp[i:j], b.v1[i:j],
                 b.a[i:j], b.line[i:j], b.drawing[i:j], b.cap[i:j])
