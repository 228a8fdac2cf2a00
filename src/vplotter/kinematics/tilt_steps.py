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

The sub-pieces are laid out a planned window at a time where the machine knows the window
(`TwoCord.inverse` keeps the last windows' vertices and balances: the planner asks for the
cords at every vertex of a window before it cuts it into blocks): one vectorised pass for all
its blocks, each block's call then only finds its steps' sub-pieces. A block the machine does
not know (another caller) is laid out on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.kinematics.tilt import cord_jets

SUB_MM = 3.0
END_MARGIN, END_MARGIN_MM = 0.03, 1.0     # a piece whose end is not known: past its last step
WINDOWS = 2                               # windows kept (the last ones the planner planned)


@dataclass
class Layout:
    """The sub-pieces of consecutive pieces: piece p has points first[p] .. first[p + 1] - 1
    (k[p] + 1 of them, t along the piece), its sub-pieces sub0[p] .. sub0[p] + k[p] - 1; per
    motor the cord at each point, each sub-piece's model (7 rows) and whether the model fails,
    and per piece whether the cord rises / falls anywhere along it."""

    k: np.ndarray
    first: np.ndarray
    sub0: np.ndarray
    q: tuple
    model: tuple
    bad: tuple
    up: tuple
    down: tuple
    inner: np.ndarray     # the points inside a piece (neither end)
    owner: np.ndarray     # each point's piece
    end: tuple = ()       # per motor the cord at each piece's end
    badp: tuple = ()      # per motor: a sub-piece of the piece fails
    longs: np.ndarray | None = None   # pieces with k > 1 before each piece (n + 1)
    spread: tuple = ()    # per motor the most the cord moves from each piece's start


@dataclass
class Window:
    """A planned window's vertices (a copy), their balance (Gondola.solve), its pieces'
    directions, and its layout once a block asked for it."""

    verts: np.ndarray
    state: tuple
    e: np.ndarray | None = None
    d: np.ndarray | None = None
    lay: Layout | None = None
    cursor: int = 0
    at: int = 0


_WINDOWS: list = []     # (machine, Window): the planner and the schedule have each a machine


def _machine(kin) -> tuple:
    g = kin.gondola
    return (g.d_mm, g.v, g.a, kin.stretch)


def _windows(kin) -> list:
    key = kin.__dict__.get("_tilt_key")
    if key is None:
        key = kin._tilt_key = _machine(kin)
    return [w for m, w in _WINDOWS if m == key]


def remember(kin, xy: np.ndarray, state: tuple) -> None:
    """Keep the balance at a window's vertices (from `inverse`) for its blocks' steps."""
    key = _machine(kin)
    mine = [i for i, (m, _) in enumerate(_WINDOWS) if m == key]
    for i in reversed(mine[:len(mine) - WINDOWS + 1]):
        del _WINDOWS[i]
    _WINDOWS.append((key, Window(xy.copy(), state)))
    del _WINDOWS[:-4 * WINDOWS]


def balance(kin, xy: np.ndarray) -> tuple:
    """Gondola.solve at the points xy (N, 2), reusing what the machine solved last: the same
    points, a window's vertices less the last or the first (the starts and the ends of its
    pieces), or the points of the last solve moved on by one (one new point solved)."""
    n = len(xy)
    seen = getattr(kin, "_tilt_solves", [])
    for m, st in reversed([*seen, *((w.verts, w.state) for w in _windows(kin))]):
        if len(m) == n + 1:
            for a in (0, 1):
                if np.array_equal(m[a:a + n], xy):
                    return tuple(_cut(v, a, a + n) for v in st)
        elif len(m) == n and n > 1 and np.array_equal(m, xy):
            return st
        elif len(m) == n and n > 1 and np.array_equal(m[1:], xy[:-1]):
            new = kin.gondola.solve(xy[-1:, 0], xy[-1:, 1])
            st = tuple(_joined(_cut(v, 1, n), w) for v, w in zip(st, new))
            break
        elif len(m) == n - 1 and n > 2 and np.array_equal(m, xy[1:]):
            new = kin.gondola.solve(xy[:1, 0], xy[:1, 1])
            st = tuple(_joined(w, v) for v, w in zip(st, new))
            break
        elif len(m) == n - 1 and n > 2 and np.array_equal(m, xy[:-1]):
            new = kin.gondola.solve(xy[-1:, 0], xy[-1:, 1])
            st = tuple(_joined(v, w) for v, w in zip(st, new))
            break
    else:
        st = kin.gondola.solve(xy[:, 0], xy[:, 1])
    if n > 2:
        kin._tilt_solves = [*seen[-2:], (xy.copy(), st)]
    return st


def _joined(a, b):
    return tuple(map(np.concatenate, zip(a, b))) if isinstance(a, tuple) else np.r_[a, b]


def _cut(v, a, b):
    return tuple(x[a:b] for x in v) if isinstance(v, tuple) else v[a:b]


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
        rel = np.array([kin.gondola.solve_one(float(x), float(y))[0][2 * motor:2 * motor + 2]
                        for x, y in p0[pc]]) * -1.0
        b = np.einsum("ij,ij->i", rel, e[pc])
        root = np.sqrt(np.maximum(b * b - np.einsum("ij,ij->i", rel, rel) + q[i] ** 2, 0.0))
        s = np.maximum(np.where(rising[i], root - b, -b - root), 0.0)
        d[pc] = s * (1.0 + END_MARGIN) + END_MARGIN_MM
    return np.nan_to_num(d, nan=0.0)


def _window(kin, p0, e, motor=0):
    """(layout, offset of the block's first piece in it) when the block is a run of pieces
    of a window the machine knows, else None."""
    n = len(p0)
    for w in reversed(_windows(kin)):
        m = len(w.verts)
        if n > m - 1:
            continue
        if w.e is None:
            diff = np.diff(w.verts, axis=0)
            w.d = np.hypot(diff[:, 0], diff[:, 1])
            with np.errstate(divide="ignore", invalid="ignore"):
                w.e = np.column_stack((diff[:, 0] / w.d, diff[:, 1] / w.d))
        # the block asked last (the other motor's call) or the next one, else a search
        i = -1
        for c in ((w.at, w.cursor) if motor else (w.cursor, w.at)):
            if (c + n <= m - 1 and np.array_equal(w.verts[c:c + n], p0)
                    and np.array_equal(w.e[c:c + n], e)):
                i = c
                break
        if i < 0:
            hits = np.flatnonzero((w.verts[:m - n, 0] == p0[0, 0])
                                  & (w.verts[:m - n, 1] == p0[0, 1]))
            hits = [h for h in hits.tolist() if np.array_equal(w.verts[h:h + n], p0)
                    and np.array_equal(w.e[h:h + n], e)]
            if not hits:
                continue
            i = hits[0]
        if w.lay is None:
            ok = w.d > 0
            w.lay = _lay(kin, w.verts[:-1], np.where(ok[:, None], w.e, 0.0),
                         np.where(ok, w.d, 0.0), w.state)
        w.at, w.cursor = i, i + n
        return w.lay, i
    return None


def crossing(kin, p0, e, motor, piece, q, rising, exact) -> np.ndarray:
    """As TwoCord.crossing; `exact(p0, e, motor, piece, q, rising)` the exact solver."""
    if not len(q):
        return np.zeros(0)
    if np.any(piece[1:] < piece[:-1]):
        return exact(p0, e, motor, piece, q, rising)
    found = _window(kin, p0, e, motor)
    if found is None:
        lay, i = _block_layout(kin, p0, e, motor, piece, q, rising), 0
    else:
        lay, i = found
    n = len(p0)
    qv = lay.q[motor]
    if lay.longs[i + n] > lay.longs[i]:
        k = lay.k[i:i + n]
        fst = lay.first[i:i + n + 1]
        q0 = qv[fst[:-1]]
        span = 2.0 * lay.spread[motor][i:i + n].max() + 1.0
        pts = fst[0] + np.flatnonzero(lay.inner[fst[0]:fst[-1]])
        own = lay.owner[pts] - i
        up = np.sign(qv[fst[1:] - 1] - q0)
        key_in = own * span + up[own] * (qv[pts] - q0[own])
        key = piece * span + np.where(rising, 1.0, -1.0) * (q - q0[piece])
        # the inner ends before the step's, less those of the pieces before (k - 1 each)
        idx = np.searchsorted(key_in, key) + piece + lay.sub0[i]
    else:
        idx = piece + lay.sub0[i]
    sx, d0, a, b_a, sg_a, kappa, c2 = np.take(lay.model[motor], idx, axis=1)   # C order
    g = q + kappa
    u = sg_a * np.sqrt(np.maximum(d0 + a * g * g, 0.0)) - b_a
    s = sx + u + c2 * u * u
    slow = _slow(lay, motor, i, n, piece, q, rising, idx)
    if slow is not None:
        s[slow] = exact(p0, e, motor, piece[slow], q[slow], rising[slow])
    return s


def _slow(lay, motor, i, n, piece, q, rising, idx):
    """The steps the model cannot take (None: none): on a sub-piece it fails on, or on a piece
    whose cord turns against its steps or ends short of its last step."""
    count = np.bincount(piece, minlength=n)
    last = np.cumsum(count) - 1
    rl = rising[last]
    ql, end = q[last], lay.end[motor][i:i + n]
    turn = np.where(rl, (end < ql) | lay.down[motor][i:i + n], (end > ql) | lay.up[motor][i:i + n])
    turn &= count > 0
    if not (turn | lay.badp[motor][i:i + n]).any():
        return None
    bad = lay.bad[motor]
    slow = np.flatnonzero(turn[piece] | bad[idx])
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


def _lay(kin, p0, e, d, ends=None) -> Layout:
    """The sub-pieces of pieces p0 + t e, 0 <= t <= d, and the cords' triples at their ends;
    ends: the balance at the pieces' starts and the last one's end (Gondola.solve), when
    known (then only the points inside the pieces are solved)."""
    n = len(p0)
    k = np.maximum(1, np.ceil(d / SUB_MM - 1e-9)).astype(np.int64)
    first = np.concatenate(([0], np.cumsum(k + 1)))
    owner = np.repeat(np.arange(n), k + 1)
    j = np.arange(first[-1]) - first[owner]
    frac = j / k[owner]
    t = d[owner] * frac
    pts = p0[owner] + t[:, None] * e[owner]
    inner = (j > 0) & (j < k[owner])
    state = None
    if ends is not None:
        vert = owner + (j > 0)                      # the vertex at each end point
        phi = ends[0]
        guess = phi[owner] + (phi[owner + 1] - phi[owner]) * frac
        state = _merged(kin.gondola, pts, inner, guess, ends, vert)
    r, _ = kin.gondola.jets(pts, e[owner], state)
    qj = cord_jets(r, kin.stretch)
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
    badp = tuple(np.bincount(owner[start], b, minlength=n) > 0 for b in bads)
    return Layout(k, first, first[:-1] - np.arange(n), q, tuple(models), tuple(bads),
                  tuple(ups), tuple(downs), inner, owner, (q[0][ends], q[1][ends]), badp,
                  np.concatenate(([0], np.cumsum(k > 1))),
                  tuple(_spread(v, first, owner, n) for v in q))


def _spread(q, first, owner, n):
    out = np.zeros(n)
    np.maximum.at(out, owner, np.abs(q - q[first[:-1]][owner]))
    return out


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
    # the steps on a sub-piece go the way its cord goes (else the piece turns: see _slow)
    return (sx, d0, a, b * inv_a, sg * inv_a, kappa, c2), bad
