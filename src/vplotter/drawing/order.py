"""Pen-up travel optimisation: the order, direction and seam of strokes.

Never changes what is drawn (the set of segments): a stroke may be drawn backwards, a closed
stroke may start at any of its vertices (its seam), and strokes keep their points. Layers keep
their order (each layer is ordered on its own, starting where the previous one ended), because
a layer may be another pen. Deterministic: no clocks, no random numbers.

- `keep`: file order.
- `greedy`: nearest neighbour from the pen's position (either end of an open stroke, a few
  candidate seams of a closed one), found with a grid (`_Grid`: cells shrink where the
  drawing is dense, a numpy scan where it is sparse) that is rebuilt as it empties.
- `best`: greedy, then the tour improved by 2-opt (reversing a run of strokes, each drawn the
  other way) and or-opt (moving a run of up to three strokes, either way round) within a window
  of nearby tour positions, vectorised over all positions at once (every non-overlapping
  improving move of a round is made, then only the positions near a change are looked at
  again); seams of closed strokes are chosen to minimise the travel in and out. Up to
  ALL_TOURS_UP_TO strokes per layer, two more tours are improved the same way: one whose first
  leg costs nothing (then run from its nearer end), and one that starts with the file's first
  stroke as vpype's linesort does. Of these and the file order, the shortest travel from the
  pen is taken among those no longer *between strokes* than the file order and linesort's
  greedy order, so that best is no longer than either, from the pen or between strokes
  (vpype's pen_up_length) alike.

Joining (`joined`): a stroke that starts within join_mm of where the previous one ended is
drawn without lifting the pen. That pen-down bridge is a line that is not in the file, and
which ends meet depends on the order, so prepare() keeps join_mm within the flattening
tolerance (`prepare.join_limit`): every order then draws the file's own segments, plus bridges
that lie within half that tolerance of two stroke ends.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from vplotter.inputs.strokes import Stroke

METHODS = ("keep", "greedy", "best")
SEAM_SAMPLES = 16     # candidate seams per closed stroke in the greedy pass
WINDOW = 40           # tour positions looked at by 2-opt and or-opt
ALL_TOURS_UP_TO = 5000   # strokes of a layer; above, only the tour from the pen is improved
PASSES = 3            # improvement rounds at most


def travel_mm(strokes: list[Stroke], start_xy=(0.0, 0.0), join_mm: float = 0.0) -> float:
    """Pen-up travel drawing `strokes` in this order from start_xy (the ends are the strokes'
    first and last points; no return at the end). Gaps within join_mm are drawn, not travel."""
    if not strokes:
        return 0.0
    ends = np.array([s.pts[-1] for s in strokes[:-1]]).reshape(-1, 2)
    prev = np.vstack([np.asarray(start_xy, dtype=float)[None, :], ends])
    starts = np.array([s.pts[0] for s in strokes])
    d = np.hypot(*(starts - prev).T)
    return float(d[d > join_mm].sum()) if join_mm > 0 else float(d.sum())


def joined(strokes: list[Stroke], join_mm: float) -> np.ndarray:
    """(N,) bool: stroke k starts within join_mm of the end of stroke k-1 and is drawn on from
    it without lifting the pen (same layer; dots are never joined)."""
    out = np.zeros(len(strokes), dtype=bool)
    if join_mm <= 0:
        return out
    for k in range(1, len(strokes)):
        a, b = strokes[k - 1], strokes[k]
        if (a.layer == b.layer and len(a.pts) > 1 and len(b.pts) > 1
                and math.dist(a.pts[-1], b.pts[0]) <= join_mm):
            out[k] = True
    return out


def order(strokes: list[Stroke], method: str = "best", start_xy=(0.0, 0.0)) -> list[Stroke]:
    """Strokes in drawing order (new Stroke objects where direction or seam changed)."""
    if method not in METHODS:
        raise ValueError(method)
    if method == "keep" or len(strokes) < 2 and not any(s.closed for s in strokes):
        return list(strokes)
    out: list[Stroke] = []
    at = np.asarray(start_xy, dtype=float)
    for group in _layers(strokes):
        done = _order_group(group, method, at)
        out += done
        if done:
            at = done[-1].pts[-1]
    return out


def _layers(strokes: list[Stroke]) -> list[list[Stroke]]:
    groups: dict = {}
    for s in strokes:
        groups.setdefault(s.layer, []).append(s)
    return list(groups.values())


class _Tour:
    """A tour as arrays: stroke index, reversed flag and seam (closed strokes) per position."""

    def __init__(self, strokes: list[Stroke], start: np.ndarray, free: bool = False,
                 fixed_first: bool = False):
        self.strokes = strokes
        self.fixed_first = fixed_first            # strokes[0] stays first, as it is
        self.origin = start                       # where the pen is (the greedy starts there)
        self.start = np.full(2, np.nan) if free else start   # free: the first leg costs nothing
        self.closed = np.array([s.closed for s in strokes])
        self.first = np.array([s.pts[0] for s in strokes], dtype=float)
        self.last = np.array([s.pts[-1] for s in strokes], dtype=float)
        self.perm = np.arange(len(strokes))
        self.rev = np.zeros(len(strokes), dtype=bool)
        self.seam = np.zeros(len(strokes), dtype=np.int64)       # by stroke index

    def ends(self, lo: int = 0, hi: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Entry and exit point of each tour position (of positions lo..hi-1)."""
        p, r = self.perm[lo:hi], self.rev[lo:hi]
        a, b = self.first[p], self.last[p]
        entry = np.where(r[:, None], b, a)
        exit_ = np.where(r[:, None], a, b)
        return entry, exit_

    def length(self, first: int = 0) -> float:
        """Travel from the start (the first leg left out in a free tour); first=-1: the tour
        run backwards."""
        entry, exit_ = self.ends()
        if first == -1:
            entry, exit_ = exit_[::-1], entry[::-1]
        prev = np.vstack([self.start[None, :], exit_[:-1]])
        return float(np.nansum(np.hypot(*(entry - prev).T)))

    def between(self) -> float:
        """Travel between strokes only (vpype's pen_up_length)."""
        entry, exit_ = self.ends()
        return float(np.hypot(*(entry[1:] - exit_[:-1]).T).sum())

    def reverse(self) -> None:
        self.perm = self.perm[::-1].copy()
        self.rev = ~self.rev[::-1]

    def set_seam(self, i: int, v: int) -> None:
        """Closed stroke i enters and leaves at its vertex v."""
        self.seam[i] = v
        self.first[i] = self.last[i] = self.strokes[i].pts[v]

    def result(self) -> list[Stroke]:
        out = []
        for i, r in zip(self.perm.tolist(), self.rev.tolist()):
            s = self.strokes[i]
            if self.closed[i]:
                v = int(self.seam[i])
                if v:
                    q = s.pts[:-1]
                    s = replace(s, pts=np.concatenate([q[v:], q[:v], q[v:v + 1]]))
            elif r:
                s = replace(s, pts=s.pts[::-1].copy())
            out.append(s)
        return out


def _order_group(strokes: list[Stroke], method: str, start: np.ndarray) -> list[Stroke]:
    if method == "greedy":
        tour = _Tour(strokes, start)
        _greedy(tour)
        return tour.result()
    keep = _Tour(strokes, start)
    # from the pen's position; then, for drawings small enough that the first leg weighs,
    # with a free start (run from its nearer end), and from the file's first stroke the way
    # vpype's linesort starts (greedy with reversal, ends only)
    tours = [keep, _improved(_Tour(strokes, start))]
    if len(strokes) <= ALL_TOURS_UP_TO:
        free = _improved(_Tour(strokes, start, free=True))
        free.start = start
        if free.length(-1) < free.length(0):
            free.reverse()
        tours += [free, _improved(_Tour(strokes, start, fixed_first=True), seams=False)]
        linesort = _Tour(strokes, start, fixed_first=True)
        _greedy(linesort, seams=False)
        bound = min(keep.between(), linesort.between())
    else:
        bound = np.inf
    # the shortest travel from the pen among those no longer between strokes than the file
    # order and the linesort-like order (the last tour improves on the latter by both
    # measures, so one always qualifies): then best is no longer than either, either way
    bound *= 1 + 1e-12
    pick = min((t for t in tours if t.between() <= bound), key=lambda t: t.length())
    return list(strokes) if pick is keep else pick.result()


def _improved(tour: "_Tour", seams: bool = True) -> "_Tour":
    _greedy(tour, seams)
    _seams(tour)
    ref = max(tour.length(), 1.0)
    for _ in range(PASSES):
        gain = _two_opt(tour) + _or_opt(tour)
        gain += _seams(tour)
        if gain <= 1e-9 * ref:
            break
    return tour


# ------------------------------------------------------------------ greedy nearest neighbour
def _greedy(tour: _Tour, seams: bool = True) -> None:
    """Nearest neighbour with reversal from the pen (or after strokes[0] with fixed_first).
    seams=False: closed strokes are entered at their first point only. Ties go to a first
    point before a last one, then to the stroke that comes first in the file."""
    n = len(tour.strokes)
    owner: list[int] = []
    which: list[int] = []     # 0 first point, 1 last point, >= 2: closed vertex index + 2
    pts: list[np.ndarray] = []
    for i, s in enumerate(tour.strokes):
        if tour.closed[i] and seams:
            k = len(s.pts) - 1
            vs = np.unique(np.linspace(0, k - 1, min(k, SEAM_SAMPLES)).round().astype(int))
            pts.append(s.pts[vs])
            owner += [i] * len(vs)
            which += (vs + 2).tolist()
        else:
            pts.append(np.array([s.pts[0], s.pts[-1]]))
            owner += [i, i]
            which += [0, 1]
    xy = np.concatenate(pts)
    owner_a = np.array(owner, dtype=np.int64)
    rank = np.where(np.array(which) == 1, n, 0) + owner_a
    alive = np.ones(n, dtype=bool)
    count = np.bincount(owner_a, minlength=n)
    alive_pts = len(xy)
    perm, rev = [], []
    x, y = float(tour.origin[0]), float(tour.origin[1])
    if tour.fixed_first:
        alive[0] = False
        alive_pts -= int(count[0])
        perm.append(0)
        rev.append(False)
        x, y = float(tour.last[0][0]), float(tour.last[0][1])
    grid = _Grid(xy, owner_a, rank, alive, np.arange(len(xy)))
    for left in range(n - len(perm), 0, -1):
        p = grid.nearest(x, y)
        i, w = owner[p], which[p]
        alive[i] = False
        alive_pts -= int(count[i])
        perm.append(i)
        if w >= 2:
            tour.set_seam(i, w - 2)
            rev.append(False)
        else:
            rev.append(w == 1)
        ex = tour.first[i] if w == 1 else tour.last[i]
        x, y = float(ex[0]), float(ex[1])
        if left > 1 and alive_pts * 2 < len(grid.ids):
            grid = _Grid(xy, owner_a, rank, alive, grid.ids)
    tour.perm = np.array(perm, dtype=np.int64)
    tour.rev = np.array(rev, dtype=bool)


class _Grid:
    """Points in square cells; nearest() searches rings of cells outwards and drops the points
    of finished strokes on the way. The cells are made smaller until none holds more than
    CELL_MAX points (dense spots), and a search that goes more than RINGS_MAX rings out (a
    sparse spot) looks at every point at once with numpy instead: uneven drawings stay fast.
    `alive` (per stroke) is shared with the caller, which clears the strokes it takes."""

    CELL_MAX = 16
    RINGS_MAX = 6

    def __init__(self, xy, owner, rank, alive, ids):
        ids = ids[alive[owner[ids]]]
        self.ids, self.xy, self.owner, self.rank, self.alive = ids, xy, owner, rank, alive
        self.px, self.py = xy[:, 0].tolist(), xy[:, 1].tolist()
        self.owner_l, self.rank_l = owner.tolist(), rank.tolist()
        pts = xy[ids] if len(ids) else np.zeros((1, 2))
        self.x0, self.y0 = (float(v) for v in pts.min(axis=0))
        w, h = (float(v) for v in pts.max(axis=0) - pts.min(axis=0))
        cell = max(math.sqrt(max(w * h, 1e-12) / max(len(ids), 1) * 2.0), max(w, h) / 4096, 1e-9)
        for _ in range(24):
            nx, ny = int(w / cell) + 1, int(h / cell) + 1
            keys = ((pts[:, 0] - self.x0) // cell).astype(np.int64) * ny + \
                ((pts[:, 1] - self.y0) // cell).astype(np.int64)
            _, counts = np.unique(keys, return_counts=True)
            if counts.max() <= self.CELL_MAX or max(nx, ny) > 1 << 20 or cell < 1e-6:
                break
            cell /= 2
        self.cell, self.nx, self.ny = cell, nx, ny
        order = np.argsort(keys, kind="stable")
        keys, sorted_ids = keys[order], ids[order] if len(ids) else ids
        cuts = np.flatnonzero(np.diff(keys)) + 1
        # cells that stay crowded (points on one spot: the centre of a starburst) are numpy
        # arrays, looked at in one go
        self.cells: dict[int, list[int] | np.ndarray] = {
            int(k[0]): (v if len(v) > 4 * self.CELL_MAX else v.tolist())
            for k, v in zip(np.split(keys, cuts), np.split(sorted_ids, cuts)) if len(v)}

    def nearest(self, x: float, y: float) -> int:
        cell, nx, ny = self.cell, self.nx, self.ny
        cx = min(max(int((x - self.x0) // cell), 0), nx - 1)
        cy = min(max(int((y - self.y0) // cell), 0), ny - 1)
        px, py, owner, alive, cells, rank = (self.px, self.py, self.owner_l, self.alive,
                                             self.cells, self.rank_l)
        best, bp = math.inf, -1
        for r in range(self.RINGS_MAX + 1):
            if r == 0:
                ring = [(cx, cy)]
            else:
                ring = []
                x_lo, x_hi = max(cx - r, 0), min(cx + r, nx - 1)
                for j in (cy - r, cy + r):
                    if 0 <= j < ny:
                        ring += [(i, j) for i in range(x_lo, x_hi + 1)]
                for i in (cx - r, cx + r):
                    if 0 <= i < nx:
                        ring += [(i, j) for j in range(max(cy - r + 1, 0), min(cy + r - 1, ny - 1) + 1)]
            for i, j in ring:
                lst = cells.get(i * ny + j)
                if lst is None or len(lst) == 0:
                    continue
                if isinstance(lst, np.ndarray):
                    lst = cells[i * ny + j] = lst[self.alive[self.owner[lst]]]
                    if len(lst):
                        d2 = (self.xy[lst, 0] - x) ** 2 + (self.xy[lst, 1] - y) ** 2
                        p = int(lst[np.lexsort((self.rank[lst], d2))[0]])
                        d = (px[p] - x) ** 2 + (py[p] - y) ** 2
                        if d < best or (d == best and rank[p] < rank[bp]):
                            best, bp = d, p
                    continue
                dead = False
                for p in lst:
                    if alive[owner[p]]:
                        d = (px[p] - x) ** 2 + (py[p] - y) ** 2
                        if d < best or (d == best and rank[p] < rank[bp]):
                            best, bp = d, p
                    else:
                        dead = True
                if dead:
                    lst[:] = [p for p in lst if alive[owner[p]]]
            if bp >= 0 and (r * cell) ** 2 >= best:
                return bp
            if r >= nx and r >= ny:         # every cell seen
                return bp if bp >= 0 else self._scan(x, y)
        return self._scan(x, y)

    def _scan(self, x: float, y: float) -> int:
        """The nearest alive point by looking at all of them (ties: lowest rank)."""
        ids = self.ids[self.alive[self.owner[self.ids]]]
        if len(ids) == 0:
            raise RuntimeError("nearest() on an empty grid")
        d = (self.xy[ids, 0] - x) ** 2 + (self.xy[ids, 1] - y) ** 2
        return int(ids[np.lexsort((self.rank[ids], d))[0]])


# ------------------------------------------------------------------ tour improvement
def _d(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1])


def _context(tour: _Tour):
    """entry, exit (n, 2); P (n+1, 2): the point before position k (start, then exits);
    N (n, 2): the entry after position k (NaN after the last)."""
    entry, exit_ = tour.ends()
    P = np.vstack([tour.start[None, :], exit_])
    N = np.vstack([entry[1:], np.full((1, 2), np.nan)])
    return entry, exit_, P, N


def _nd(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance, 0 where a point is NaN (no next stroke; no start point in a free tour)."""
    return np.nan_to_num(_d(a, b), nan=0.0)


def _pick(gain: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[int]:
    """Candidates with positive gain, best first, whose position ranges lo..hi do not
    overlap (such moves are independent and can all be made at once)."""
    cand = np.flatnonzero(gain > 1e-9)
    if len(cand) == 0:
        return []
    cand = cand[np.lexsort((cand, -gain[cand]))]
    used = np.zeros(int(hi.max()) + 2, dtype=bool)
    out = []
    for c in cand.tolist():
        a, b = int(lo[c]), int(hi[c]) + 1
        if not used[a:b].any():
            used[a:b] = True
            out.append(c)
    return out


def _two_opt(tour: _Tour) -> float:
    """Reverse runs perm[i..j] (each stroke then drawn the other way) where that shortens the
    travel, j - i < WINDOW; all non-overlapping improving moves of a round at once."""
    n = len(tour.perm)
    saved = 0.0
    off = np.arange(WINDOW)
    first = int(tour.fixed_first)
    rows = np.arange(first, n)
    while len(rows):
        entry, exit_, P, N = _context(tour)
        i = rows[:, None]
        j = i + off[None, :]
        ok = j < n
        j = np.minimum(j, n - 1)
        old = _nd(P[i], entry[i]) + _nd(exit_[j], N[j])
        new = _nd(P[i], exit_[j]) + _nd(entry[i], N[j])
        gain = np.where(ok, old - new, -np.inf)
        best = np.argmax(gain, axis=1)
        g = gain[np.arange(len(rows)), best]
        moves = _pick(g, np.maximum(rows - 1, 0), rows + best + 1)
        active = np.zeros(n + 1, dtype=bool)
        for c in moves:
            a = int(rows[c])
            b = a + int(best[c]) + 1
            tour.perm[a:b] = tour.perm[a:b][::-1].copy()
            tour.rev[a:b] = ~tour.rev[a:b][::-1]
            saved += float(g[c])
            active[max(a - WINDOW, 0):b + 1] = True
        rows = np.flatnonzero(active[:n])
        rows = rows[rows >= first]
    return saved


def _or_opt(tour: _Tour) -> float:
    """Move a run of 1..3 strokes (either way round) to between two other positions at most
    WINDOW away, where that shortens the travel; non-overlapping moves of a round at once."""
    n = len(tour.perm)
    saved = 0.0
    for seg in (1, 2, 3):
        if n <= seg:
            break
        offs = np.concatenate([np.arange(-WINDOW, 0), np.arange(seg + 1, seg + 1 + WINDOW)])
        first = int(tour.fixed_first)
        i = np.arange(first, n - seg + 1)
        while len(i):
            entry, exit_, P, N = _context(tour)
            jj = i + seg - 1
            remove = _nd(P[i], entry[i]) + _nd(exit_[jj], N[jj]) - _nd(P[i], N[jj])
            k = i[:, None] + offs[None, :]
            ok = (k >= first) & (k <= n)
            k = np.clip(k, 0, n)
            a = P[k]
            b = np.vstack([entry, np.full((1, 2), np.nan)])[k]
            base = _nd(a, b)
            fwd = _nd(a, entry[i][:, None]) + _nd(exit_[jj][:, None], b) - base
            bwd = _nd(a, exit_[jj][:, None]) + _nd(entry[i][:, None], b) - base
            ins = np.where(ok, np.minimum(fwd, bwd), np.inf)
            m = np.argmin(ins, axis=1)
            rows = np.arange(len(i))
            g = remove - ins[rows, m]
            kk = k[rows, m]
            lo = np.maximum(np.minimum(kk - 1, i - 1), 0)
            hi = np.maximum(jj + 1, kk)
            moves = _pick(g, lo, hi)
            flip = bwd[rows, m] < fwd[rows, m]
            active = np.zeros(n + 1, dtype=bool)
            for c in moves:
                s = int(i[c])
                e, t = s + seg, int(kk[c])
                rp, rr = tour.perm[s:e].copy(), tour.rev[s:e].copy()
                if flip[c]:
                    rp, rr = rp[::-1], ~rr[::-1]
                if t < s:
                    tour.perm[t:e] = np.concatenate([rp, tour.perm[t:s]])
                    tour.rev[t:e] = np.concatenate([rr, tour.rev[t:s]])
                else:
                    tour.perm[s:t] = np.concatenate([tour.perm[e:t], rp])
                    tour.rev[s:t] = np.concatenate([tour.rev[e:t], rr])
                saved += float(g[c])
                active[max(min(s, t) - WINDOW - seg, 0):max(e, t) + WINDOW + 1] = True
            i = np.flatnonzero(active[:n - seg + 1])
            i = i[i >= first]
    return saved


def _seams(tour: _Tour) -> float:
    """Each closed stroke enters (and leaves) at the vertex nearest to the travel in and out."""
    saved = 0.0
    if not tour.closed.any():
        return saved
    entry, exit_ = tour.ends()
    n = len(tour.perm)
    for k in np.flatnonzero(tour.closed[tour.perm]).tolist():
        if k == 0 and tour.fixed_first:
            continue
        i = int(tour.perm[k])
        prev = tour.start if k == 0 else exit_[k - 1]
        q = tour.strokes[i].pts[:-1]
        cost = _nd(q, prev)
        if k + 1 < n:
            cost = cost + _d(q, entry[k + 1])
        v = int(np.argmin(cost))
        old = float(_nd(tour.first[i], prev)) + (float(_d(tour.first[i], entry[k + 1])) if k + 1 < n else 0.0)
        if cost[v] < old - 1e-12:
            saved += old - float(cost[v])
            tour.set_seam(i, v)
            entry[k] = exit_[k] = q[v]
    return saved
