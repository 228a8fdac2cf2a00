"""The step solver of the tilting gondola: where along each straight piece a cord reaches
each of its step targets, about as fast as the level gondola's closed form.

The exact solve (bracketed Newton, the balance solved at every iterate) costs some fifty
times the closed form per step. Instead each piece is cut into sub-pieces of at most
SUB_MM, and at both ends of each the balance, the cord and its first two derivatives along
the piece are solved exactly (once per sub-piece, not per step). On a sub-piece the cord is
then the cord of a level gondola hanging from a virtual anchor, |w + t f| plus a constant,
with the true cord's value and slope at the end where the cord turns least (so a turning
point at a piece's end, where the planner cuts pieces, is the model's own) and through its
value at the other end (where the tilted cord bends the other way than a level one's, the
same model of minus the cord); each step's target gives t in closed form,
s = s0 + s1 sqrt((q + kappa)^2 - h): four numbers per sub-piece, seven operations per step.
Cord error: below 1e-5 mm (a step is 6e-3 mm; 3.4e-6 mm at most on the samples).
Sub-pieces the model cannot take (no bend where the cord barely moves) fall back to the
exact solve.

The sub-pieces are laid out a planned window at a time where the machine knows the window
(`TwoCord.inverse` keeps each window's vertices and balances as long as its blocks live: the
planner asks for the cords at every vertex of a window before it cuts it into blocks, then
for their derivatives along the pieces at the pieces' starts and ends, which the layout
takes): one vectorised pass for all its blocks, each block's call then only finds its steps'
sub-pieces (steps counted per sub-piece from the steps' spacing, the models repeated). A
block the machine does not know (another caller's) is laid out on its own; steps whose
spacing is not given (not the schedule's) are solved exactly.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from vplotter.kinematics.tilt_along import cord_jets
from vplotter.kinematics.tilt_kept import brief, find, laid, layout_state

SUB_MM = 3.0
_ASKED: list = [None]     # (directions, window (weakly), offset) of the last call: its
#                           block's other motor asks next, with the same directions
END_MARGIN, END_MARGIN_MM = 0.03, 1.0     # a piece whose end is not known: past its last step


@dataclass
class Layout:
    """The sub-pieces of consecutive pieces: piece p has points first[p] .. first[p + 1] - 1
    (k[p] + 1 of them, t along the piece), its sub-pieces sub0[p] .. sub0[p + 1] - 1; per
    motor the cord at each point, each sub-piece's model (4 rows: _models) and whether the
    model fails."""

    k: np.ndarray
    first: np.ndarray
    sub0: np.ndarray
    q: tuple
    model: tuple
    bad: tuple
    inner: np.ndarray     # the points inside a piece (neither end)
    owner: np.ndarray     # each point's piece
    top: tuple = ()       # per motor the most rising steps may reach on each piece (its
    bottom: tuple = ()    # end, -inf where the cord falls), the least falling steps may
    badc: tuple = ()      # per motor the pieces before each with a sub-piece that fails, or
    #                       whose cord goes both ways (prefix counts, n + 1)
    longs: np.ndarray | None = None   # pieces with k > 1 before each piece (n + 1)
    # the inner points in order: the sub-piece each starts, its piece, and per motor its
    # cord signed the way the cord goes along the piece (+-q: rising along the piece)
    isub: np.ndarray | None = None
    iown: np.ndarray | None = None
    iupq: tuple = ()
    whole: bool = False   # the pieces' lengths are the true ones (a window's: _window)


def _ends(kin, p0, e, motor, piece, q, rising):
    """Length of each piece that has steps: up to the next piece's start where the pieces
    follow one another, else a little beyond where the level model with the gondola turned as
    at the piece's start puts the last step (crossing() checks that it reaches it); 0 for a
    piece without steps whose end is not known."""
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
        rel = np.array([kin.gondola.state_one(float(x), float(y))[6][2 * motor:2 * motor + 2]
                        for x, y in p0[pc]]) * -1.0
        b = np.einsum("ij,ij->i", rel, e[pc])
        root = np.sqrt(np.maximum(b * b - np.einsum("ij,ij->i", rel, rel) + q[i] ** 2, 0.0))
        s = np.maximum(np.where(rising[i], root - b, -b - root), 0.0)
        d[pc] = s * (1.0 + END_MARGIN) + END_MARGIN_MM
    return np.nan_to_num(d, nan=0.0)


def _window(kin, p0, e):
    """(layout, offset of the block's first piece in it) when the block is a run of pieces
    of a window the machine knows (its vertices a view of the window's: tilt_kept.find),
    else None."""
    last = _ASKED[0]
    if last is not None and last[0] is e:                  # the block's other motor
        w = last[1]()
        if w is not None and w.lay is not None:
            return w.lay, last[2]
    hit = find(kin, p0)
    if hit is None or hit[1] + len(p0) >= len(hit[0].verts):
        return None
    w, i = hit
    # the block's directions are its vertices' (one row checked against gross misuse)
    we = _directions(w)
    if not abs(we[i, 0] - e[0, 0]) + abs(we[i, 1] - e[0, 1]) < 1e-9:
        return None

    def make():
        ok = w.d > 0
        e = np.where(ok[:, None], we, 0.0)
        return _lay(kin, w.verts[:-1], e, np.where(ok, w.d, 0.0), layout_state(kin, w, e),
                    (w.jets0, w.jets1))

    _ASKED[0] = (e, weakref.ref(w), i)
    return laid(w, make), i


def _directions(w):
    """The window's pieces' directions (and lengths), found once."""
    if w.e is None:
        diff = np.diff(w.verts, axis=0)
        w.d = np.hypot(diff[:, 0], diff[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            w.e = np.column_stack((diff[:, 0] / w.d, diff[:, 1] / w.d))
    return w.e


def crossing(kin, p0, e, motor, piece, q, rising, exact, spacing=None) -> np.ndarray:
    """As TwoCord.crossing; `exact(p0, e, motor, piece, q, rising)` the exact solver, which
    takes the steps when their spacing is not given (not the schedule's)."""
    if not len(q):
        return np.zeros(0)
    if spacing is None:
        return exact(p0, e, motor, piece, q, rising)
    found = _window(kin, p0, e)
    if found is None:
        lay, i = _block_layout(kin, p0, e, motor, piece, q, rising), 0
    else:
        lay, i = found
    n = len(p0)
    lo, hi = lay.sub0[i], lay.sub0[i + n]                  # the block's sub-pieces
    if lay.longs[i + n] > lay.longs[i]:
        ends = np.searchsorted(piece, np.arange(n + 1))   # each piece's steps: ends[p]:ends[p+1]
        count = _counts(lay, motor, i, n, q, rising, ends, spacing)
    else:
        ends = None
        count = np.bincount(piece, minlength=n)            # one sub-piece per piece
    s0, s1, kappa, h = np.repeat(lay.model[motor][:, lo:hi], count, axis=1)
    s = q + kappa                        # s = s0 + s1 sqrt((q + kappa)^2 - h), in place
    s *= s
    s -= h
    np.maximum(s, 0.0, out=s)
    np.sqrt(s, out=s)
    s *= s1
    s += s0
    slow = _slow(lay, motor, i, n, piece, q, rising, ends, lo, hi, count)
    if slow is not None:
        s[slow] = exact(p0, e, motor, piece[slow], q[slow], rising[slow])
    return s


def _counts(lay, motor, i, n, q, rising, ends, spacing):
    """The number of steps on each of the block's sub-pieces (pieces i .. i + n - 1 of the
    layout), from where its inner points fall among the steps: how many of the piece's steps
    come before each point, from how far past the piece's first step its cord is, the way the
    steps go, and the steps' spacing."""
    s0 = lay.sub0[i]
    a, b = s0 - i, lay.sub0[i + n] - i - n               # the block's inner points
    own = lay.iown[a:b] - i
    first = ends[own]
    at = np.minimum(first, len(q) - 1)
    qa = q[at]
    u = lay.iupq[motor][a:b] - np.where(rising[at], qa, -qa)
    u /= spacing
    np.floor(u, out=u)
    u += 1.0
    np.maximum(u, 0.0, out=u)                     # (np.clip costs more on a few points)
    np.minimum(u, ends[own + 1] - first, out=u)
    pos = u.astype(np.intp)
    pos += first
    bounds = np.empty(lay.sub0[i + n] - s0 + 1, dtype=np.intp)
    bounds[lay.sub0[i:i + n] - s0] = ends[:-1]
    bounds[lay.isub[a:b] - s0] = pos
    bounds[-1] = ends[-1]
    np.maximum.accumulate(bounds, out=bounds)     # (a piece whose cord turns: see _slow)
    return bounds[1:] - bounds[:-1]


def _slow(lay, motor, i, n, piece, q, rising, ends, lo, hi, count):
    """The steps the model cannot take (None: none): on a sub-piece it fails on, or on a piece
    whose cord turns against its steps or ends short of its last step. On a window's pieces
    (their true lengths) whose cords go one way, only the first piece's steps can go against
    its cord (they start from the count the motor stands at, not from its cord rounded), and
    no piece's last step is past its end's cord but by rounding (the schedule's targets are
    the cords at the pieces' ends rounded: the last step is at most there): none is slow.
    ends: each piece's first step (n + 1), or None where each piece is one sub-piece (count
    is then per piece)."""
    badc = lay.badc[motor]
    if lay.whole and badc[i + n] == badc[i]:
        if piece[0] != 0 or not (lay.top[motor][i] == -np.inf if rising[0]
                                 else lay.bottom[motor][i] == np.inf):
            return None
    if ends is None:
        ends = np.concatenate(([0], np.cumsum(count)))
    last = ends[1:] - 1
    ql = q[last]
    turn = np.where(rising[last], ql > lay.top[motor][i:i + n], ql < lay.bottom[motor][i:i + n])
    turn &= last >= ends[:-1]                   # (the pieces with steps)
    if not turn.any() and badc[i + n] == badc[i]:
        return None
    bad = np.repeat(lay.bad[motor][lo:hi], count)
    slow = np.flatnonzero(turn[piece] | bad)
    return slow if len(slow) else None


def _block_layout(kin, p0, e, motor, piece, q, rising):
    """The layout of one block's pieces: kept on the machine for the other motor's call on
    the same pieces."""
    cache = getattr(kin, "_tilt_layout", None)
    if (cache is not None and cache[0].shape == p0.shape and np.array_equal(cache[0], p0)
            and np.array_equal(cache[1], e) and (cache[2][np.unique(piece)] > 0).all()):
        return cache[3]
    d = _ends(kin, p0, e, motor, piece, q, rising)
    lay = _lay(kin, p0, e, d)
    kin._tilt_layout = (p0.copy(), e.copy(), d, lay)
    return lay


def _lay(kin, p0, e, d, ends=None, known=(None, None)) -> Layout:
    """The sub-pieces of pieces p0 + t e, 0 <= t <= d, and the cords' triples at their ends;
    ends: the balance at the pieces' starts and the last one's end (Gondola.solve), when
    known (then only the points inside the pieces are solved); known: jets()'s (e, r, qj)
    at the pieces' starts and ends, when it kept them."""
    n = len(p0)
    whole = ends is not None
    k = np.maximum(1, np.ceil(d / SUB_MM - 1e-9)).astype(np.int64)
    first = np.concatenate(([0], np.cumsum(k + 1)))
    owner = np.repeat(np.arange(n), k + 1)
    j = np.arange(first[-1]) - first[owner]
    frac = j / k[owner]
    t = d[owner] * frac
    inner = (j > 0) & (j < k[owner])
    r = _vertex_jets(kin, p0, t, e, owner, inner, frac, ends, first, known)
    if r is None:
        pts = p0[owner] + t[:, None] * e[owner]
        state = None
        if ends is not None:
            vert = owner + (j > 0)                      # the vertex at each end point
            phi = ends[0]
            guess = phi[owner] + (phi[owner + 1] - phi[owner]) * frac
            state = _merged(kin.gondola, pts, inner, guess, ends, vert)
        r, _ = kin.gondola.jets(pts, e[owner], state)
        qj = cord_jets(r, kin.stretch)
    else:
        r, qj = r
    start = np.flatnonzero(j < k[owner])
    models, bads, ups, downs = [], [], [], []
    for m in (0, 1):
        rx, ry = r[m]
        model, bad = _models(t, qj[m], rx, ry, start)
        models.append(np.array(model))
        bads.append(bad & (d[owner[start]] > 0))
        dq = qj[m][0][start + 1] - qj[m][0][start]
        ups.append(np.bincount(owner[start], dq > 0, minlength=n) > 0)
        downs.append(np.bincount(owner[start], dq < 0, minlength=n) > 0)
    q = (qj[0][0], qj[1][0])
    ends = first[1:] - 1
    badc = tuple(np.concatenate(([0], np.cumsum((np.bincount(owner[start], b, minlength=n) > 0)
                                                | (u & dn))))
                 for b, u, dn in zip(bads, ups, downs))
    top = tuple(np.where(dn, -np.inf, v[ends]) for v, dn in zip(q, downs))
    bottom = tuple(np.where(u, np.inf, v[ends]) for v, u in zip(q, ups))
    ins = np.flatnonzero(inner)
    iown = owner[ins]
    iupq = tuple(np.where(v[ends] >= v[first[:-1]], 1.0, -1.0)[iown] * v[ins] for v in q)
    return Layout(k, first, first - np.arange(n + 1), q, tuple(models), tuple(bads),
                  inner, owner, top, bottom, badc,
                  np.concatenate(([0], np.cumsum(k > 1))), ins - iown, iown, iupq, whole)


def _vertex_jets(kin, p0, t, e, owner, inner, frac, ends, first, known):
    """(r, qj) at the layout's points (p0 + t e of their pieces) from the kept jets at the
    pieces' starts and ends, the points inside the pieces solved; None if jets() did not keep
    them (along e)."""
    if ends is None or not all(k is not None and np.array_equal(k[0], e) for k in known):
        return None
    at0, at1 = known[0][1:], known[1][1:]
    ins = np.flatnonzero(inner)
    own = owner[ins]
    pts = p0[own] + t[ins][:, None] * e[own]
    phi = ends[0]
    state = kin.gondola.solve(pts[:, 0], pts[:, 1],
                              phi[own] + (phi[own + 1] - phi[own]) * frac[ins])
    r_in, _ = kin.gondola.jets(pts, e[own], state)
    idx = (first[:-1], first[1:] - 1, ins)

    def put(a, b, c):
        if isinstance(a, (tuple, list)):
            return tuple(put(x, y, z) for x, y, z in zip(a, b, c))
        out = np.empty(len(owner))
        out[idx[0]], out[idx[1]], out[idx[2]] = a, b, c
        return out

    return put(at0, at1, brief(r_in, cord_jets(r_in, kin.stretch)))


def _merged(gondola, pts, inner, guess, ends, vert) -> tuple:
    """The balance at the points: solved inside the pieces, the vertices' known."""
    at = np.flatnonzero(inner)
    solved = gondola.solve(pts[at, 0], pts[at, 1], guess[at])
    out = []
    for known, new in zip(ends, solved):
        if isinstance(known, tuple):
            out.append(tuple(_put(a, b, vert, at) for a, b in zip(known, new)))
        else:
            out.append(_put(known, new, vert, at))
    return tuple(out)


def _put(known, new, vert, at):
    v = known[vert]
    v[at] = new
    return v


def _models(t, qj, rx, ry, start):
    """Per sub-piece (points start and start + 1): the level model through both ends with the
    true slope at the end where the cord turns least, as the rows (s0, s1, kappa, h) of
    s = s0 + s1 sqrt((q + kappa)^2 - h); and whether it fails."""
    i0, i1 = start, start + 1
    slope = np.abs(qj[1])
    at = np.where(slope[i0] <= slope[i1], i0, i1)
    other = np.where(at == i0, i1, i0)
    wx, wy = -rx[0][at], -ry[0][at]
    nw = np.hypot(wx, wy)
    u1 = t[other] - t[at]
    # the model of the cord (of minus the cord where it bends the other way, sigma = -1):
    # |w + u f| - kappa, f = k w/|w| + perp (w/|w| turned), k the true slope, perp as large
    # as takes it through the other end
    sigma = np.where(qj[0][other] - qj[0][at] >= u1 * qj[1][at], 1.0, -1.0)
    k = sigma * qj[1][at]
    kappa = nw - sigma * qj[0][at]
    reach, along = sigma * qj[0][other] + kappa, nw + u1 * k
    with np.errstate(divide="ignore", invalid="ignore"):
        perp2 = np.maximum((reach - along) * (reach + along), 0.0) / (u1 * u1)
        a = k * k + perp2
        bad = ~(a > 1e-12)
        a = np.where(bad, 1.0, a)
        # u = (sg sqrt(a g^2 - perp^2 |w|^2) - k |w|) / a, g = sigma q + kappa: the root on
        # the side the model's cord goes; scaled to be exact at the other end (rounding)
        sg = np.where(qj[0][i1] >= qj[0][i0], sigma, -sigma)
        h = perp2 * nw * nw / a
        s1 = sg / np.sqrt(a)
        b = k * nw / a
        u = s1 * np.sqrt(np.maximum(reach * reach - h, 0.0)) - b
        scale = np.where(np.abs(u) > 1e-12, u1 / u, 1.0)
        bad |= ~np.isfinite(scale) | (np.abs(scale - 1.0) > 0.5)
        scale = np.where(bad, 1.0, scale)
    return (t[at] - scale * b, scale * s1, sigma * kappa, h), bad
