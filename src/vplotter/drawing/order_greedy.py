"""The greedy pass of the ordering (`order`): nearest neighbour from the pen, either end of an
open stroke and a few candidate seams of a closed one, found with a grid (`Grid`: cells shrink
where the drawing is dense, a numpy scan where it is sparse) that is rebuilt as it empties."""

from __future__ import annotations

import math

import numpy as np

from vplotter.drawing.order_tour import Tour

SEAM_SAMPLES = 16     # candidate seams per closed stroke in the greedy pass


def greedy(tour: Tour, seams: bool = True) -> None:
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
    grid = Grid(xy, owner_a, rank, alive, np.arange(len(xy)))
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
            grid = Grid(xy, owner_a, rank, alive, grid.ids)
    tour.perm = np.array(perm, dtype=np.int64)
    tour.rev = np.array(rev, dtype=bool)


class Grid:
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
                        y_lo, y_hi = max(cy - r + 1, 0), min(cy + r - 1, ny - 1)
                        ring += [(i, j) for j in range(y_lo, y_hi + 1)]
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
