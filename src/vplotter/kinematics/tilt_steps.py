"""The step solver of the tilting gondola: where along each straight piece a cord reaches
each of its step targets, about as fast as the level gondola's closed form.

The exact solve (bracketed Newton, the balance solved at every iterate) costs some fifty
times the closed form per step. Instead each piece is cut into sub-pieces of at most
SUB_MM, and at both ends of each the balance, the cord and its first two derivatives along
the piece are solved exactly (once per sub-piece, not per step). On a sub-piece the cord is
then the cord of a level gondola hanging from a virtual anchor, |w + t f| plus a constant,
osculating the true cord (same value, slope and bend) at the end where the cord turns least
(so a turning point at a piece's end, where the planner cuts pieces, is the model's own);
each step's target gives t in closed form, and a quadratic correction in t, exact at the
sub-piece's other end, takes up the rest. Cord error: below 1e-5 mm (a step is 6e-3 mm).
Sub-pieces the model cannot take (no bend where the cord barely moves) fall back to the
exact solve.
"""

from __future__ import annotations

import numpy as np

from vplotter.kinematics.tilt import cord_jets

SUB_MM = 3.0
END_MARGIN, END_MARGIN_MM = 0.03, 1.0     # a piece whose end is not known: past its last step


def _ends(kin, p0, e, motor, piece, q, rising):
    """Length of each piece that has steps: up to the next piece's start where the pieces
    follow one another, else a little beyond where the level model with the gondola turned as
    at the piece's start puts the last step (crossing() checks that it reaches it)."""
    n = len(p0)
    d = np.full(n, np.nan)
    if n > 1:
        gap = p0[1:] - p0[:-1]
        along = np.einsum("ij,ij->i", gap, e[:-1])
        off = np.hypot(*(gap - along[:, None] * e[:-1]).T)
        ok = (off <= 1e-9 * (1.0 + np.abs(along))) & (along >= 0)
        d[:-1] = np.where(ok, along, np.nan)
    last = np.flatnonzero(np.r_[piece[1:] != piece[:-1], True])
    need = np.isnan(d[piece[last]])
    if need.any():
        i = last[need]
        pc = piece[i]
        # a few points (the block's last piece): the balance in floats
        rel = np.array([kin.gondola.solve_one(float(x), float(y))[0][2 * motor:2 * motor + 2]
                        for x, y in p0[pc]]) * -1.0
        b = np.einsum("ij,ij->i", rel, e[pc])
        root = np.sqrt(np.maximum(b * b - np.einsum("ij,ij->i", rel, rel) + q[i] ** 2, 0.0))
        s = np.maximum(np.where(rising[i], root - b, -b - root), 0.0)
        d[pc] = s * (1.0 + END_MARGIN) + END_MARGIN_MM
    return d


def crossing(kin, p0, e, motor, piece, q, rising, exact) -> np.ndarray:
    """As TwoCord.crossing; `exact(p0, e, motor, piece, q, rising)` the exact solver."""
    if not len(q):
        return np.zeros(0)
    if np.any(piece[1:] < piece[:-1]):
        return exact(p0, e, motor, piece, q, rising)
    lay = _layout(kin, p0, e, motor, piece, q, rising)
    used, k, first, owner, j, t, pc, r = lay
    qj = cord_jets(r, kin.stretch)[motor]
    rx, ry = r[motor]
    # sub-pieces: from point i to point i + 1 of the same piece
    start = np.flatnonzero(j < k[owner])
    sub, bad = _models(t, qj, rx, ry, start)
    # which sub-piece each step is on: the cord runs one way along each piece
    rank = np.full(len(p0), -1)
    rank[used] = np.arange(len(used))
    sg = np.where(rising, 1.0, -1.0)
    if (k > 1).any():
        q0 = qj[0][first]
        span = 2.0 * np.abs(qj[0] - q0[owner]).max() + 1.0
        inner = np.flatnonzero((j > 0) & (j < k[owner]))
        up = np.sign(qj[0][first + k] - q0)
        key_in = rank[pc[inner]] * span + up[owner[inner]] * (qj[0][inner] - q0[owner[inner]])
        step_rank = rank[piece]
        key = step_rank * span + sg * (q - q0[step_rank])
        # the inner ends before the step's, less those of the pieces before (k - 1 each)
        idx = np.searchsorted(key_in, key) + step_rank
    else:
        idx = rank[piece]
    sx, d0, a, b, inv_a, kappa, c2 = (v[idx] for v in sub)
    g = q + kappa
    u = (sg * np.sqrt(np.maximum(d0 + a * g * g, 0.0)) - b) * inv_a
    s = sx + u + c2 * u * u
    slow = bad[idx]
    # a piece whose end was estimated: past a turning point, or short of a step: exactly
    turn = np.zeros(len(used), bool)
    step_sign = np.sign(np.diff(qj[0]))
    same = owner[1:] == owner[:-1]
    at = np.clip(np.searchsorted(piece, used), 0, len(q) - 1)     # a step of each piece
    dirn = np.where(rising[at], 1.0, -1.0)
    np.logical_or.at(turn, owner[1:][same], (step_sign[same] * dirn[owner[1:][same]]) < 0)
    last = np.clip(np.searchsorted(piece, used, side="right") - 1, 0, len(q) - 1)
    reach = dirn * (qj[0][first + k] - q[last])
    turn |= reach < 0
    slow |= turn[rank[piece]]
    if slow.any():
        i = np.flatnonzero(slow)
        s[i] = exact(p0, e, motor, piece[i], q[i], rising[i])
    return s


def _layout(kin, p0, e, motor, piece, q, rising):
    """The sub-pieces of the pieces and the cords' triples at their ends, both motors: kept
    on the machine for the other motor's call on the same pieces."""
    cache = getattr(kin, "_tilt_layout", None)
    if (cache is not None and cache[0].shape == p0.shape and np.array_equal(cache[0], p0)
            and np.array_equal(cache[1], e) and np.isfinite(cache[2][piece]).all()):
        return cache[3]
    d = _ends(kin, p0, e, motor, piece, q, rising)
    used = np.flatnonzero(np.isfinite(d))
    k = np.maximum(1, np.ceil(d[used] / SUB_MM - 1e-9)).astype(np.int64)
    # sub-piece ends: piece start + d j / k, j = 0..k
    first = np.cumsum(k + 1) - (k + 1)
    owner = np.repeat(np.arange(len(used)), k + 1)
    j = np.arange(len(owner)) - first[owner]
    t = d[used][owner] * j / k[owner]
    pc = used[owner]
    r, _ = kin.gondola.jets(p0[pc] + t[:, None] * e[pc], e[pc])
    lay = (used, k, first, owner, j, t, pc, r)
    kin._tilt_layout = (p0.copy(), e.copy(), d, lay)
    return lay


def _models(t, qj, rx, ry, start):
    """Per sub-piece (points start and start + 1): the osculating level model at its end where
    the cord turns least, and the correction that makes the other end exact."""
    i0, i1 = start, start + 1
    slope = np.abs(qj[1])
    at = np.where(slope[i0] <= slope[i1], i0, i1)
    other = np.where(at == i0, i1, i0)
    wx, wy = -rx[0][at], -ry[0][at]
    nw = np.hypot(wx, wy)
    hx, hy = wx / nw, wy / nw
    # f: slope q' along w, and the perpendicular part that gives the bend q'' (f_perp^2 / |w|),
    # on the side the true cord moves to
    fpx, fpy = -rx[1][at], -ry[1][at]
    side = np.where(fpx * -hy + fpy * hx >= 0, 1.0, -1.0)
    perp = side * np.sqrt(np.maximum(qj[2][at] * nw, 0.0))
    fx = qj[1][at] * hx - perp * hy
    fy = qj[1][at] * hy + perp * hx
    a = fx * fx + fy * fy
    b = wx * fx + wy * fy
    bad = ~(a > 1e-12)
    a = np.where(bad, 1.0, a)
    d0 = b * b - a * nw * nw
    kappa = nw - qj[0][at]
    sx = t[at]
    inv_a = 1.0 / a
    # the other end: where the model puts its cord, and the correction that moves it there
    sg = np.where(qj[0][i1] >= qj[0][i0], 1.0, -1.0)
    g = qj[0][other] + kappa
    u = (sg * np.sqrt(np.maximum(d0 + a * g * g, 0.0)) - b) * inv_a
    want = t[other] - sx
    with np.errstate(divide="ignore", invalid="ignore"):
        c2 = np.where(np.abs(u) > 1e-12, (want - u) / (u * u), 0.0)
    bad |= ~np.isfinite(c2) | (np.abs(c2 * u) > 0.5)
    return (sx, d0, a, b, inv_a, kappa, c2), bad
