"""The junction rule of the planner (see `planner`): what each corner of a window takes of the
motors' acceleration budget, and the vertex speed that allows.

At a vertex the cord speeds change at once by v x |slope change| (`jump`); inside one window
TAU_S that counts as an acceleration of jump x v x max(1 / TAU_S, v / ds), ds the shorter of
the two pieces, or on a curve cut into short chords (both passed within TAU_S / EVEN) the mean
of the two: the curve's own v^2 x curvature, so the pen can go round evenly (`Corners.takes`).
`corners` gives each corner its share of the budget for the first plan (CORNER_SHARE on a
curve, the quickest of SHARP_TRY at a lone sharp corner, never more than CORNER_CEIL with the
bending next to it) and the most it may keep in the later ones (`Corners.again`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.motion.refine import CORNER_SHARE, SHARP_TRY, TAU_S, least, sharp_shares

RETRY_GAIN = 1.2       # later plans: corners keep what they take at this x the best plan's speed
CORNER_CEIL = 0.9      # a corner and the bending next to it take at most this together (first plan)
CORNER_TOP = 0.98      # and in later plans, on a curve, where the ramps next to it leave that
EVEN = 1.5             # a corner counts as on a curve from v = EVEN x (shorter piece) / TAU_S


def _fleast(a: np.ndarray) -> np.ndarray:
    """The least value over the motors (M, N), NaN left out (all NaN: NaN)."""
    out = a[0]
    for j in range(1, a.shape[0]):
        out = np.fmin(out, a[j])
    return out


@dataclass
class Corners:
    """The n - 1 inner corners of a window of n pieces; per-motor arrays have one row per
    motor (M, ...: see `refine.least`)."""

    jump: np.ndarray       # (M, n-1) |slope change| of each motor's cord
    ds: np.ndarray         # (n-1,) the shorter of the two pieces
    dl: np.ndarray         # (n-1,) the longer one (on a curve: see `takes`)
    dm: np.ndarray         # (n-1,) their mean
    v_lo: np.ndarray       # (n-1,) from this speed on the shorter takes at most TAU_S / EVEN
    vc: np.ndarray         # (n-1,) the slower of the two pieces' speed caps
    corner: np.ndarray     # (M, n+1) the budget each vertex keeps in the first plan
    top: np.ndarray        # (M, n+1) the most it may keep in the later plans
    sgn_v: np.ndarray      # (M, n+1) the way each corner changes each cord's speed (+1, -1, 0)

    def takes(self, v: np.ndarray) -> np.ndarray:
        """What each corner takes passed at speeds v (n-1,): the jump over the shorter piece;
        but on a curve cut into chords, where the shorter piece is passed within TAU_S / EVEN
        (from v_lo on), over half of each piece (as the curve's own v^2 x curvature: the
        0.1 s window sees the chords' corners as one even bend), the longer one counted up to
        the path passed in TAU_S / EVEN. That keeps the window's worst sum of jumps what the
        shorter piece alone gives (1.125 x the budget at worst, an idealised bound), and what
        a corner takes still rises with v, from where the two rules meet (at v_lo)."""
        # below v_lo, v T < ds and the clip gives ds
        x = v * (TAU_S / EVEN)
        np.clip(x, self.ds, self.dl, out=x)
        x += self.ds
        np.divide(v, x, out=x)                  # v / cell, cell = x / 2
        x *= 2.0
        np.maximum(x, 1.0 / TAU_S, out=x)
        x *= v
        return self.jump * x

    def speed(self, budget: np.ndarray) -> np.ndarray:
        """The highest corner speeds within `budget` (M, n-1) or (M, 1), for every motor: the
        inverse of `takes`. That is the lesser of the shorter piece's rule and the curve's
        (each rising with v: the first is the lesser below v_lo, the second above), so its
        inverse is the larger of theirs: jump * v * max(1/TAU, v/ds) <= budget, and
        jump * v * max(1/TAU, 2 v / (ds + min(dl, v T))) <= budget (T = TAU_S / EVEN: a
        quadratic where v T < dl, 2 jump v^2 <= budget (ds + dl) beyond)."""
        t = TAU_S / EVEN
        # Each rule's speed rises with budget / jump, so the least over the motors is that of
        # the least budget / jump (where there is no jump: inf, or NaN for a zero budget, which
        # fmin leaves out as it would the inf it stands for; all NaN: no limit but vc).
        with np.errstate(divide="ignore", invalid="ignore"):
            q = _fleast(budget / self.jump)
            qds = q * self.ds
            v = q * t
            r = v * v
            r += 8.0 * qds
            np.sqrt(r, out=r)
            v += r
            v *= 0.25                           # the quadratic's root
            np.multiply(q, self.dm, out=r)
            np.sqrt(r, out=r)
            np.fmin(v, r, out=v)                # the curve's
            np.sqrt(qds, out=qds)
            np.fmax(v, qds, out=v)              # the larger of both rules'
            q *= TAU_S
            np.fmin(v, q, out=v)
        return np.fmin(v, self.vc)

    def again(self, u: np.ndarray, d: np.ndarray, slope: np.ndarray, bent: np.ndarray,
              acc: np.ndarray, ksgn: np.ndarray) -> np.ndarray:
        """The budgets of a later plan after the plan of squared vertex speeds u: each corner
        keeps what it takes at RETRY_GAIN x those speeds (within `top`), but no more than the
        ramps next to it leave at that plan (a ramp that changes a cord's speed the other way
        than the corner leaves it more), and at least what it takes at that plan."""
        n = len(d)
        v = np.sqrt(u[1:n])
        now = self.takes(v)
        v = np.minimum(v * RETRY_GAIN, self.vc)
        top = self.top
        again = top.copy()
        again[:, 1:n] = np.minimum(top[:, 1:n], self.takes(v))
        cord = (np.diff(u) / (2.0 * d)) * slope                 # (M, n) the ramps' |a| q'
        sgn = self.sgn_v[:, 1:n]
        signed = np.where(ksgn == 0, np.abs(cord), cord * ksgn)
        acc = acc[:, None]
        room = acc - np.maximum(sgn * signed[:, :-1] + bent[:, :-1],
                                sgn * signed[:, 1:] + bent[:, 1:])
        room = np.where(sgn == 0, acc - np.maximum(np.abs(cord[:, :-1]) + bent[:, :-1],
                                                   np.abs(cord[:, 1:]) + bent[:, 1:]), room)
        again[:, 1:n] = np.minimum(again[:, 1:n],
                                   np.maximum(room, np.minimum(now, again[:, 1:n])))
        return again


def corners(k0, k1, kmax, d, vcap, bent, acc, stop) -> Corners:
    """The corners of a window of n > 1 pieces: k0, k1 the slopes at each piece's ends, kmax
    the larger, d the lengths, vcap the speed caps, bent what bending takes at the cap, acc
    the budget (M,), stop the pieces after which the machine stands still."""
    n = len(d)
    change = k0[:, 1:] - k1[:, :-1]
    jump = np.abs(change)                                  # (M, n-1)
    ds = np.minimum(d[1:], d[:-1])
    dl = np.maximum(d[1:], d[:-1])
    dm = 0.5 * (ds + dl)
    v_lo = EVEN * ds / TAU_S
    vc = np.minimum(vcap[1:], vcap[:-1])
    m = len(acc)
    c = Corners(jump, ds, dl, dm, v_lo, vc, np.zeros((m, n + 1)), np.zeros((m, n + 1)),
                np.zeros((m, n + 1)))
    c.sgn_v[:, 1:n] = np.sign(change)
    acc = acc[:, None]
    # what the corner takes passed at the highest speed its pieces allow
    use = c.takes(vc)
    # A corner on a curve (the next one follows within TAU) may take much of the
    # budget: the pen goes round at that speed without speeding up or slowing down.
    # A lone sharp corner is passed slowly anyway; the pieces around it get more.
    v_hi = c.speed(CORNER_SHARE * acc)
    curve = v_hi * TAU_S >= ds
    share = _shares(c, curve, v_hi, acc, kmax, d, vcap) * acc
    # and never so much that the bending leaves the ramps nothing
    bent_end = np.maximum(bent[:, 1:], bent[:, :-1])
    ceil = np.maximum(CORNER_CEIL * acc - bent_end, 0.0)
    corner = np.minimum(np.minimum(use, share), ceil)
    corner[:, stop[:-1]] = 0.0                             # passed standing still
    c.corner[:, 1:n] = corner
    # the most a corner may keep in the later plans
    on_curve = np.maximum(CORNER_TOP * acc - bent_end, 0.0)
    top = np.minimum(use, np.where(curve, on_curve, np.minimum(share, ceil)))
    top[:, stop[:-1]] = 0.0
    c.top[:, 1:n] = top
    return c


def _shares(c: Corners, curve, v_hi, acc, kmax, d, vcap) -> np.ndarray:
    """Each corner's share of the budget: CORNER_SHARE on a curve; at a sharp corner the
    share that passes it and the pieces next to it quickest. acc: (M, 1)."""
    share = np.full(len(curve), CORNER_SHARE)
    # (where even the least share passes it at full speed, the least is quickest)
    low = c.speed(SHARP_TRY[0] * acc) >= c.vc
    share[~curve & low] = SHARP_TRY[0]
    sharp = np.flatnonzero(~curve & ~low)
    if len(sharp):
        far = np.concatenate(([np.inf], v_hi, [np.inf]))
        share[sharp] = sharp_shares(c.jump[:, sharp], acc, kmax[:, sharp], kmax[:, sharp + 1],
                                     d[sharp], d[sharp + 1], vcap[sharp], vcap[sharp + 1],
                                     c.vc[sharp], c.ds[sharp], far[sharp], far[sharp + 2])
    return share
