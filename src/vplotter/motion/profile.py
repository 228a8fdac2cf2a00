"""The speed profile of one look-ahead window (see `planner`): per piece the speed cap its
motors allow (step rate, bending), per vertex the corner budgets (`corners`), then the
trapezoids: the largest vertex speeds the ramps can reach between the limits (a backward and
a forward pass), planned again a few times with the corners keeping what they use (the
quickest plan is kept)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.motion.blocks import Block
from vplotter.motion.corners import Corners, corners
from vplotter.motion.refine import MIN_SLOPE, least, scaled

BEND_SHARE = 0.4       # most of it the bending along a piece may take at the speed cap
RETRY_ROUNDS = 3       # plans after the first (the quickest is kept)
RETRY_MIN = 1e-3       # no further round after one that won less than this share of the time


def motor_path(kin, verts: np.ndarray, q0) -> tuple[np.ndarray, np.ndarray]:
    """Motor coordinates before and after each vertex of a polyline that starts with the motors
    at q0 (the same where the kinematics has no place to turn in place)."""
    path = getattr(kin, "path", None)
    if path is not None:
        return path(verts, q0)
    q = kin.inverse(verts)
    return q, q


@dataclass
class Window:
    """The pieces of a window as the profile sees them; arrays have one entry per piece (N) or
    per vertex (N + 1), per-motor arrays one row per motor (M, ...: see `refine.least`)."""

    d: np.ndarray          # (N,) lengths mm
    kmax: np.ndarray       # (M, N) the larger |slope| of each cord at the piece's two ends
    ksgn: np.ndarray       # (M, N) the sign of each cord's slope along the piece (0: unknown)
    vcap: np.ndarray       # (N,) the speed cap: the G-code's, the step rate's, the bending's
    bent: np.ndarray       # (M, N) what the bending takes at the cap
    acc: np.ndarray        # (M,) the acceleration budget of each cord
    u_lim: np.ndarray      # (N+1,) squared vertex speed limits (the entry, then the caps)
    zero: np.ndarray       # (N+1,) the machine stands still there (stops, turns, the end)
    corners: Corners | None  # with more than one piece
    room: np.ndarray       # (M, N) acc - bent: what the ramps and corners share
    slope: np.ndarray      # (M, N) kmax, at least MIN_SLOPE
    against: tuple | None  # (M, N) 0/1: the corner at the start / end of each piece changes
    #                        the cord's speed the way the ramp up / down does (see _ramp_limits)


def _slope_bend(kin, xy, e):
    """kin.slope(xy, e) and kin.bend(xy, e), at once where the kind can, as (M, N)."""
    both = getattr(kin, "slope_bend", None)
    k, b = both(xy, e) if both is not None else (kin.slope(xy, e), kin.bend(xy, e))
    return k.T.copy(), b.T.copy()


def window(kin, v_cord, a_cord, verts, cap, stop, u_entry, turns) -> Window:
    """The speed caps, bends and corners of the pieces through verts."""
    diff = np.diff(verts, axis=0)
    d = np.hypot(diff[:, 0], diff[:, 1])
    e = scaled(diff, d, divide=True)
    both_ends = getattr(kin, "ends", None)
    got = both_ends(verts, e) if both_ends is not None else None
    if got is not None:
        k0, b0, k1, b1 = got
    else:
        k0, b0 = _slope_bend(kin, verts[:-1], e)
        k1, b1 = _slope_bend(kin, verts[1:], e)
    kmax = np.maximum(np.abs(k0), np.abs(k1))
    # the bend is largest at an end or (for other machine kinds) inside: ends and middle
    mid = 0.5 * (verts[:-1] + verts[1:])
    bend = np.maximum(np.abs(b0), np.abs(b1))
    inside = getattr(kin, "bend_inside", None)
    bend = np.maximum(bend, np.abs(inside(mid, e, d, k0, k1, b0, b1) if inside is not None
                                   else kin.bend(mid, e).T))
    acc = a_cord                                              # (M,)
    v_rate = least(v_cord[:, None] / np.maximum(kmax, 1e-9))
    v_bend = least(np.sqrt((BEND_SHARE * acc)[:, None] / np.maximum(bend, 1e-12)))
    vcap = np.minimum(np.minimum(cap, v_rate), v_bend)
    n = len(d)
    bent = bend * vcap ** 2
    c = corners(k0, k1, kmax, d, vcap, bent, acc, stop) if n > 1 else None
    u_lim = np.empty(n + 1)
    u_lim[0] = min(u_entry, vcap[0] ** 2)
    zero = np.zeros(n + 1, dtype=bool)
    zero[1:][stop] = True
    zero[n] = True
    zero[turns] = True                                        # the motors turn at rest
    ksgn = np.sign(k0 + k1)
    return Window(d, kmax, ksgn, vcap, bent, acc, u_lim, zero, c, acc[:, None] - bent,
                  np.maximum(kmax, MIN_SLOPE), None if c is None else _against(c.sgn_v, ksgn))


def _against(sgn: np.ndarray, ksgn: np.ndarray) -> tuple:
    """Where the corner at the start and at the end of each piece changes a cord's speed the
    way the ramp up does, and the way the ramp down does (as 0/1; an unknown slope sign
    counts as both ways)."""
    unknown = ksgn == 0
    up, down = [], []
    for s in (sgn[:, :-1], sgn[:, 1:]):
        same = s * ksgn
        either = unknown & (s != 0)
        up.append(((same > 0) | either).astype(float))
        down.append(((same < 0) | either).astype(float))
    return (*up, *down)


def profile(kin, v_cord, a_cord, verts, cap, line, draw, stop, u_entry, events, q0):
    """The planned Block of the pieces through verts, entered at squared speed u_entry with the
    motors at q0; and the squared vertex speeds, the motors before each vertex and the
    vertices where they turn in place."""
    q_in, q_out = motor_path(kin, verts, q0)
    if q_in is q_out:                       # (no place to turn in place)
        turns = np.zeros(0, dtype=np.intp)
    else:
        turns = np.flatnonzero(np.any(q_in != q_out, axis=1))
    w = window(kin, v_cord, a_cord, verts, cap, stop, u_entry, turns)
    if w.corners is None:
        u, a = _planned(w, np.zeros((len(w.acc), len(w.d) + 1)))
    else:
        u, a = _retried(w, *_planned(w, w.corners.corner))
    d, vcap = w.d, w.vcap
    inc = 2.0 * a * d
    u0, u1 = u[:-1], u[1:]
    up = np.minimum(vcap ** 2, (u0 + u1 + inc) / 2.0)
    up = np.maximum(up, np.maximum(u0, u1))
    block = Block(verts, q_out, d, np.sqrt(u0), np.sqrt(up), np.sqrt(u1), a, line, draw, cap,
                  stop, events)
    return block, u, q_in, turns


def _planned(w: Window, reserve: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertex speeds and ramp accelerations with `reserve` of the budget kept for
    each corner: the corner is passed at most at what that allows, the pieces next
    to it speed up and slow down with what bending and the corners at its ends leave.
    Then the corners take what they need at the speeds planned (no more: those speeds
    become limits) and the pieces next to them get the rest."""
    n, c, d = len(w.d), w.corners, w.d
    lim = w.u_lim.copy()
    if c is not None:
        lim[1:n] = c.speed(reserve[:, 1:n]) ** 2
    lim[w.zero] = 0.0
    up, dn = _ramp_limits(w, reserve)
    u = _passes(lim, 2.0 * up * d, 2.0 * dn * d)
    if c is not None:
        v = np.sqrt(u[1:n])
        used = reserve.copy()
        used[:, 1:n] = np.minimum(reserve[:, 1:n], c.takes(v))
        up, dn = _ramp_limits(w, used)
        u = _passes(np.minimum(lim, u), 2.0 * up * d, 2.0 * dn * d)
    return u, _ramp(u, up, dn, d)


def _ramp_limits(w: Window, used: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The largest path acceleration of each piece speeding up and slowing down, with the
    corners at its ends keeping `used` (M, N+1) of the budget. A corner changes a cord's
    speed one way (the sign of its slope change): the ramp that changes it the other way
    has that part of the budget too. (Each cord's slope keeps its sign along a piece.)"""
    if w.against is None:
        up = least(w.room / w.slope)
        return up, up
    up0, up1, dn0, dn1 = w.against
    u0, u1 = used[:, :-1], used[:, 1:]
    up = least((w.room - np.maximum(u0 * up0, u1 * up1)) / w.slope)
    dn = least((w.room - np.maximum(u0 * dn0, u1 * dn1)) / w.slope)
    return up, dn


def _ramp(u, up, dn, d) -> np.ndarray:
    """The one path acceleration of each trapezoid through squared vertex speeds u: the lesser
    of its two limits, or where the speed change needs more, just that (a ramp without a
    peak, within the limit of its direction)."""
    a = np.minimum(up, dn)
    du = np.abs(np.diff(u)) / (2.0 * d)
    return np.where(du > a, du, a)


def _retried(w: Window, u: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Again, a few times, with each corner keeping what it takes a little above the
    speed of the quickest plan so far, but no more than the ramps next to it leave
    at that plan (and at least what it takes at that plan): where the ramps limited
    a corner they get more, where the corner limited the speed it gets what the
    ramps do not use (up to CORNER_TOP on a curve: the pen goes round at an even
    speed). Every plan keeps every limit. The runs between the vertices where the machine
    stands still are planned independently of each other (nothing passes a standstill), so
    each run keeps its quickest plan; the rounds stop when none wins, or all together won
    less than RETRY_MIN of the time."""
    n = len(w.d)
    run = np.concatenate(([0], np.cumsum(w.zero[1:n])))      # (N,) run of each piece
    at = np.concatenate((run, run[-1:]))                     # (N+1,) of each vertex's speed
    best = np.bincount(run, _times(u, a, w.d, w.vcap))
    for _ in range(int(RETRY_ROUNDS)):
        u2, a2 = _planned(w, w.corners.again(u, w.d, w.slope, w.bent, w.acc, w.ksgn))
        t2 = np.bincount(run, _times(u2, a2, w.d, w.vcap), minlength=len(best))
        won = t2 < best
        if not won.any():
            break                   # the next round would plan the same again
        gain = float((best - t2)[won].sum())
        u = np.where(won[at], u2, u)
        a = np.where(won[run], a2, a)
        best = np.where(won, t2, best)
        if gain < RETRY_MIN * float(best.sum()):
            break                   # little more to win
    return u, a


def _times(u, a, d, vcap) -> np.ndarray:
    """Time of each trapezoid through squared vertex speeds u."""
    u0, u1 = u[:-1], u[1:]
    up = np.maximum(np.minimum(vcap ** 2, (u0 + u1 + 2.0 * a * d) / 2.0), np.maximum(u0, u1))
    vp = np.sqrt(up)
    d_cru = np.maximum(d - (2.0 * up - u0 - u1) / (2.0 * a), 0.0)
    ramps = (2.0 * vp - np.sqrt(u0) - np.sqrt(u1)) / a
    return ramps + d_cru / np.maximum(vp, 1e-300)


def _passes(u_lim: np.ndarray, inc: np.ndarray, dec: np.ndarray) -> np.ndarray:
    """Largest squared vertex speeds within u_lim that the pieces can speed up and slow down
    between (u[j+1] - u[j] <= inc[j], u[j] - u[j+1] <= dec[j]): a backward and a forward
    pass."""
    r = np.concatenate((np.cumsum(dec[::-1])[::-1], [0.0]))   # r[j] = sum dec[j:]
    u = r + np.minimum.accumulate((u_lim - r)[::-1])[::-1]
    f = np.concatenate(([0.0], np.cumsum(inc)))
    u = f + np.minimum.accumulate(u - f)
    return np.maximum(u, 0.0)
