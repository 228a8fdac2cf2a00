"""The tour through the stipples (TSP art, Kaplan and Bosch 2005; `stipple.py` places them):
nearest neighbour over a k-d tree's neighbour lists, improved by 2-opt and or-opt moves between
each point and its K nearest neighbours, cut open at its longest edge; then `split` where an
edge is much longer than the local spacing or runs over white paper (a pen lift there)."""

from __future__ import annotations

import math

import numpy as np

from vplotter.errors import ConfigError
from vplotter.inputs.image.picture import Picture

K = 8                   # tour: neighbours looked at per point
GAP = 3.0               # tour: an edge longer than GAP local spacings is a pen lift,
MAX_EDGE = 5.0          # ... and so is one longer than MAX_EDGE x spacing_mm
WHITE, WHITE_RUN = 0.02, 0.5    # ... or one over paper (darkness < WHITE) for WHITE_RUN spacings
EDGE_SAMPLES = 7        # tour: darkness looked at along each edge


def kdtree():
    """SciPy's cKDTree (imported here, on first use: only stipples need SciPy)."""
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        raise ConfigError("error: --style stipple needs SciPy: pip install scipy "
                          "(Pi OS: sudo apt install python3-scipy)") from None
    return cKDTree


def tour(pts: np.ndarray) -> np.ndarray:
    """An open path through all points (indices, each once): nearest neighbour, then 2-opt
    and or-opt among the K nearest neighbours (as a closed tour), cut at its longest edge."""
    n = len(pts)
    if n <= 3:
        return np.arange(n)
    nbr = _neighbours(pts)
    t = nearest_neighbour(pts, nbr)
    t = _improve(pts, t, nbr)
    e = np.hypot(*(pts[t] - pts[np.roll(t, -1)]).T)
    cut = int(np.argmax(e)) + 1
    return np.roll(t, -cut)


def _neighbours(pts: np.ndarray) -> np.ndarray:
    k = min(K, len(pts) - 1)
    _, nbr = kdtree()(pts).query(pts, k=k + 1)
    return nbr[:, 1:]


def nearest_neighbour(pts: np.ndarray, nbr: np.ndarray | None = None) -> np.ndarray:
    """Nearest-neighbour path from the point nearest (0, 0): the neighbour lists first, a k-d
    tree of the points not yet visited (rebuilt as it empties) when all neighbours are."""
    cKDTree = kdtree()
    n = len(pts)
    if nbr is None:
        nbr = _neighbours(pts)
    near = nbr.tolist()
    seen = np.zeros(n, dtype=bool)
    seen_l = [False] * n
    left = np.arange(n)
    tree = cKDTree(pts)
    cur = int(np.argmin(np.hypot(*pts.T)))
    out = [cur]
    seen[cur] = seen_l[cur] = True
    for done in range(1, n):
        nxt = -1
        for j in near[cur]:
            if not seen_l[j]:
                nxt = j
                break
        if nxt < 0:
            if 2 * (n - done) < len(left):
                left = np.flatnonzero(~seen)
                tree = cKDTree(pts[left])
            k = 8
            while nxt < 0:
                k = min(k, len(left))
                _, ii = tree.query(pts[cur], k=k)
                for i in np.atleast_1d(ii).tolist():
                    if not seen_l[left[i]]:
                        nxt = int(left[i])
                        break
                k *= 4
        out.append(nxt)
        seen[nxt] = seen_l[nxt] = True
        cur = nxt
    return np.array(out, dtype=np.int64)


def _improve(pts: np.ndarray, t: np.ndarray, nbr: np.ndarray, rounds: int = 30) -> np.ndarray:
    """2-opt (a, next a) (b, next b) -> (a, b) (next a, next b), both ways round, and or-opt
    (point a moved between b and its successor or predecessor) for b among a's neighbours, on
    the closed tour t. Candidates are found vectorised; the moves are made one at a time in
    order of gain (each checked again first), reversing the shorter side of the tour."""
    ring = _Ring(pts, t)
    X, Y = pts[:, 0], pts[:, 1]
    A = np.repeat(np.arange(len(t)), nbr.shape[1])
    B = nbr.ravel()
    dab = np.hypot(X[A] - X[B], Y[A] - Y[B])
    for _ in range(rounds):
        found = _candidates(ring.t, X, Y, A, B, dab)
        if found is None:
            break
        made = 0
        for kd, ci in zip(*found):
            made += ring.try_move(kd, int(A[ci]), int(B[ci]))
        if made == 0:
            break
    return ring.t


def _candidates(t: np.ndarray, X: np.ndarray, Y: np.ndarray, A: np.ndarray, B: np.ndarray,
                dab: np.ndarray):
    """The moves of a round that gain on the tour t, best first: (kinds, candidates) as lists
    (kind 0, 1: 2-opt from a's successor or predecessor side; 2, 3: a moved next to b's
    successor or predecessor; candidate: an index into the pairs A, B), None if none gains."""
    n = len(t)

    def dv(p, q):
        return np.hypot(X[p] - X[q], Y[p] - Y[q])

    succ, pred = np.empty_like(t), np.empty_like(t)
    succ[t], pred[t] = np.roll(t, -1), np.roll(t, 1)
    es, ep = dv(np.arange(n), succ), dv(np.arange(n), pred)
    rem = es + ep - dv(pred, succ)            # saved by taking a point out
    kinds, cands, gains = [], [], []
    # a 2-opt move gains only if one of its new edges (a, b) is shorter than the old
    # edge at a: from a's successor side, or from its predecessor side
    for kd, (near, fn) in enumerate(((es, succ), (ep, pred))):
        c = np.flatnonzero(dab < near[A])
        a, b = A[c], B[c]
        g = near[a] + near[b] - dab[c] - dv(fn[a], fn[b])
        kinds.append(np.full(len(c), kd)), cands.append(c), gains.append(g)
    c = np.flatnonzero(dab < rem[A])
    a, b = A[c], B[c]
    for kd, (near, fn) in ((2, (es, succ)), (3, (ep, pred))):
        g = rem[a] - dab[c] + near[b] - dv(a, fn[b])
        kinds.append(np.full(len(c), kd)), cands.append(c), gains.append(g)
    kind, c, g = np.concatenate(kinds), np.concatenate(cands), np.concatenate(gains)
    keep = g > 1e-9
    if not keep.any():
        return None
    kind, c, g = kind[keep], c[keep], g[keep]
    sel = np.argsort(-g, kind="stable")
    return kind[sel].tolist(), c[sel].tolist()


class _Ring:
    """A closed tour being improved: t (the points in tour order) and pos (each point's
    position in t), changed in place."""

    def __init__(self, pts: np.ndarray, t: np.ndarray):
        self.n = n = len(t)
        self.xs, self.ys = pts[:, 0].tolist(), pts[:, 1].tolist()
        self.t = t.copy()
        self.pos = np.empty(n, dtype=np.int64)
        self.pos[self.t] = np.arange(n)

    def d(self, a: int, b: int) -> float:
        xs, ys = self.xs, self.ys
        return math.hypot(xs[a] - xs[b], ys[a] - ys[b])

    def reverse(self, i: int, j: int) -> None:
        """Reverse positions i..j (cyclic, i <= j as positions)."""
        t, pos, n = self.t, self.pos, self.n
        ln = (j - i) % n + 1
        if 2 * ln > n:                 # the other side instead: same tour, fewer to move
            i, j = (j + 1) % n, (i - 1) % n
            ln = n - ln
        if ln < 2:
            return
        if i <= j:
            seg = t[i:j + 1][::-1].copy()
            t[i:j + 1] = seg
            pos[seg] = np.arange(i, j + 1)
        else:
            idx = np.r_[i:n, 0:j + 1]
            seg = t[idx][::-1].copy()
            t[idx] = seg
            pos[seg] = idx

    def try_move(self, kd: int, x: int, y: int) -> bool:
        """Make the move of kind kd for points x, y if it still gains on the tour as it is."""
        t, n, d = self.t, self.n, self.d
        i, j = int(self.pos[x]), int(self.pos[y])
        if kd == 0:                # (x, sx) (y, sy) -> (x, y) (sx, sy)
            sx, sy = int(t[(i + 1) % n]), int(t[(j + 1) % n])
            if sx == y or sy == x:
                return False
            if d(x, sx) + d(y, sy) - d(x, y) - d(sx, sy) > 1e-9:
                self.reverse((i + 1) % n, j)
                return True
        elif kd == 1:              # (px, x) (py, y) -> (x, y) (px, py)
            px, py = int(t[(i - 1) % n]), int(t[(j - 1) % n])
            if px == y or py == x:
                return False
            if d(x, px) + d(y, py) - d(x, y) - d(px, py) > 1e-9:
                self.reverse(j, (i - 1) % n)
                return True
        else:                      # x moved between y and its successor/predecessor
            px, sx = int(t[(i - 1) % n]), int(t[(i + 1) % n])
            z = int(t[(j + 1) % n]) if kd == 2 else int(t[(j - 1) % n])
            if x in (y, z) or n < 4:
                return False
            g = d(px, x) + d(x, sx) - d(px, sx) + d(y, z) - d(y, x) - d(x, z)
            if g > 1e-9:
                _move(t, self.pos, i, j if kd == 2 else (j - 1) % n, n)
                return True
        return False


def _move(t: np.ndarray, pos: np.ndarray, i: int, j: int, n: int) -> None:
    """Move the point at position i to just after position j (cyclic), shifting those between."""
    x = t[i]
    if (j - i) % n <= (i - j) % n:     # forwards: i+1..j shift back one
        idx = (np.arange(i, i + (j - i) % n) % n)
        src = (idx + 1) % n
        last = (i + (j - i) % n) % n
    else:                              # backwards: j+1..i-1 shift on one
        idx = (np.arange(i, i - (i - j) % n + 1, -1) % n)
        src = (idx - 1) % n
        last = (j + 1) % n
    t[idx] = t[src]
    t[last] = x
    pos[t[idx]] = idx
    pos[x] = last


def split(path: np.ndarray, picture: Picture, spacing_mm: float, gamma: float,
          paper: Picture | None = None, asked_mm: float | None = None) -> list[np.ndarray]:
    """The path cut into pieces at its long edges: an edge longer than GAP x the local spacing
    (spacing_mm / sqrt(rho), rho = darkness ** gamma, spacing_mm the spacing where `picture`
    is black) at the lighter of its ends, or than MAX_EDGE x asked_mm (the spacing asked for,
    before a tone curve gathered the dots on the darker tones; default spacing_mm), or that
    runs over paper (darkness under WHITE in `paper`, the picture before its tone curve;
    default `picture`) for more than WHITE_RUN x asked_mm (judged at EDGE_SAMPLES points
    along it). On the logo at 1 h, whose darkest tones are a few thin lines, the spacing in
    black was 0.37 mm of the 3.5 asked for: caps on that cut the whole tour into dots."""
    if len(path) < 2:
        return [path]
    a, b = path[:-1], path[1:]
    length = np.hypot(*(b - a).T)
    asked = spacing_mm if asked_mm is None else asked_mm
    rho_ends = np.minimum(picture.at(a), picture.at(b)).clip(0.0, 1.0) ** gamma
    with np.errstate(divide="ignore"):
        allowed = np.minimum(GAP * spacing_mm / np.sqrt(rho_ends), MAX_EDGE * asked)
    f = (np.arange(EDGE_SAMPLES) + 0.5) / EDGE_SAMPLES
    along = a[:, None, :] + (b - a)[:, None, :] * f[None, :, None]
    seen = picture if paper is None else paper
    dark = seen.at(along.reshape(-1, 2)).reshape(len(a), EDGE_SAMPLES)
    white = np.mean(dark < WHITE, axis=1) * length
    cuts = np.flatnonzero((length > allowed) | (white > WHITE_RUN * asked)) + 1
    return np.split(path, cuts)
