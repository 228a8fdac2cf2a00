"""The flow style's geometry: the picture's edge-tangent field and evenly spaced streamlines
along it, in nested generations (Jobard and Lefer 1997, run coarse to fine).

Field. The darkness is area-averaged to cells of CELL_PENS pen widths, blurred (sigma EDGE_MM)
and differentiated; the structure tensor of the gradient (gx², gx gy, gy²) is smoothed with a
Gaussian of SMOOTH_MM, so that the field follows shapes (a face's outline, a cat's fur) rather
than the texture of single pixels, and its minor eigenvector is the direction of the lines:
along the edges, across the gradient. Where the picture is flat the tensor is ~0 and its
direction noise, so a small constant tensor (BIAS x the mean one) pulls it towards
`angle_deg` there (45 degrees; --cmyk's layers their screen angles). All numpy/scipy over the
whole grid: a few hundredths of a second for a 300 mm picture.

Streamlines. Generation g has the separation d_g = pen x 2^(TOP_POW - g) (32 mm, 16 mm ...
down to the pen's width with a 0.5 mm pen). Generation 0 starts from a grid of seeds d_0
apart; every later round seeds J-L's way, at d_g either side of the lines already drawn,
where the distance to every line drawn (a Euclidean distance transform of them, cells of
its points) is at least d_g. All the round's seeds are integrated at once, both ways (midpoint
steps of STEP_SEP x d_g, at most 1 mm, the direction kept from the step before: the field is
a line field, its sign free), each step a few numpy operations on every live line: a line
stops at the picture's edge or near another line (a grid of cells TEST x d_g / 2 holding
the last line through each, a neighbouring cell's line counts): one of an earlier round, one of
its own round of higher priority or that was there before it, or itself where it closes a
loop. Lines shorter than MIN_SEPS x d_g (d_g at most SHORT_PENS pen widths) are dropped.
Up to ROUNDS rounds per generation, then the next, finer one between them: so a generation's
lines lie about half-way between the coarser ones, and the lines of generations 0..g together
are about d_g apart, the same nesting as the straight lines of `hatch.py` (every 16th, 8th ...
line). Generations are made when a drawing first asks for them and remembered per picture
(`flow.lines`): the budget's search and the tone curves tried all draw on the same streamlines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

CELL_PENS = 1.0          # the field's cells: this many pen widths
EDGE_MM = 0.75           # the darkness blurred this much before its gradient
SMOOTH_MM = 3.0          # the structure tensor smoothed this much
BIAS = 0.05              # a flat area's pull towards angle_deg (share of the mean tensor)
TOP_POW = 6              # generation 0: lines 2^TOP_POW pen widths apart
STEP_SEP, STEP_MAX_MM = 0.5, 1.0    # integration step: this share of d_g, at most this
TEST = 0.6               # a line stops this share of d_g from another
MIN_SEPS = 1.5           # lines shorter than this many d_g are dropped (d_g at most
SHORT_PENS = 8.0         # ... this many pen widths: a coarse generation keeps short lines)
ROUNDS = 8               # seeding rounds per generation
LAG = 2                  # a stamp this many steps old was there first


def tangents(darkness: np.ndarray, width_mm: float, height_mm: float, pen_mm: float,
             angle_deg: float = 45.0) -> tuple[np.ndarray, float, float]:
    """(the unit tangent per cell (rows from the top, cols) x 2 (x right, y up), cell width,
    cell height in mm): the smoothed structure tensor's minor eigenvector (see above)."""
    from PIL import Image
    from scipy import ndimage

    h, w = darkness.shape
    cols = max(2, round(width_mm / (CELL_PENS * pen_mm)))
    rows = max(2, round(height_mm / (CELL_PENS * pen_mm)))
    cols, rows = max(3, min(cols, w)), max(3, min(rows, h))
    d = np.asarray(Image.fromarray(np.asarray(darkness, dtype=np.float32), mode="F")
                   .resize((cols, rows), Image.BOX), dtype=np.float32)
    cw, ch = width_mm / cols, height_mm / rows
    g = ndimage.gaussian_filter(d, (EDGE_MM / ch, EDGE_MM / cw))
    gy, gx = np.gradient(g)
    gy = -gy / ch                                     # y up
    gx = gx / cw
    sig = (SMOOTH_MM / ch, SMOOTH_MM / cw)
    c2 = ndimage.gaussian_filter(gx * gx - gy * gy, sig)      # the gradient's doubled angle
    s2 = ndimage.gaussian_filter(2 * gx * gy, sig)
    bias = BIAS * float(np.hypot(c2, s2).mean()) + 1e-12
    normal2 = 2 * math.radians(angle_deg + 90.0)                # lines at angle_deg in the flat
    c2 += bias * math.cos(normal2)
    s2 += bias * math.sin(normal2)
    t = 0.5 * np.arctan2(s2, c2) + math.pi / 2
    return np.stack([np.cos(t), np.sin(t)], axis=-1).astype(np.float32), cw, ch


@dataclass
class Lines:
    """A picture's streamlines so far, end to end: pts (N, 2) picture mm, line (N,) the line
    of each point (lines contiguous, numbered 0, 1, ...), arc (N,) mm along its line, normal
    (N, 2); gen (M,) each line's generation."""

    field: np.ndarray
    cw: float
    ch: float
    width_mm: float
    height_mm: float
    pen_mm: float
    phase: float = 0.0
    pts: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    line: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    arc: np.ndarray = field(default_factory=lambda: np.zeros(0))
    normal: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    gen: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    done: int = -1                        # the finest generation made

    def sep(self, g: int) -> float:
        return self.pen_mm * 2.0 ** (TOP_POW - g)

    def upto(self, g: int) -> "Lines":
        """Make the generations up to g (finer than the pen: the pen's)."""
        while self.done < min(g, TOP_POW):
            self.done += 1
            _generation(self, self.done)
        return self

    def tangent(self, p: np.ndarray) -> np.ndarray:
        rows, cols = self.field.shape[:2]
        c = np.clip((p[:, 0] / self.cw).astype(np.intp), 0, cols - 1)
        r = np.clip(((self.height_mm - p[:, 1]) / self.ch).astype(np.intp), 0, rows - 1)
        return self.field[r, c]

    def add(self, pts: np.ndarray, line: np.ndarray, g: int) -> None:
        """Append lines (points grouped by `line`, any numbering) of generation g."""
        if len(pts) == 0:
            return
        _, line = np.unique(line, return_inverse=True)
        first = np.r_[True, line[1:] != line[:-1]]
        seg = np.r_[0.0, np.hypot(*np.diff(pts, axis=0).T)]
        seg[first] = 0.0
        c = np.cumsum(seg)
        arc = c - np.maximum.accumulate(np.where(first, c, 0.0))
        last = np.r_[line[1:] != line[:-1], True]
        nxt = np.r_[pts[1:], pts[-1:]]
        prv = np.r_[pts[:1], pts[:-1]]
        t = np.where(last[:, None], pts - prv, nxt - pts)
        n = np.column_stack([-t[:, 1], t[:, 0]])
        n /= np.maximum(np.hypot(n[:, 0], n[:, 1]), 1e-9)[:, None]
        self.pts = np.vstack([self.pts, pts])
        self.line = np.concatenate([self.line, line + len(self.gen)])
        self.arc = np.concatenate([self.arc, arc])
        self.normal = np.vstack([self.normal, n])
        self.gen = np.concatenate([self.gen, np.full(int(line.max()) + 1, g)])


class _Grid:
    """A raster over the picture, cells `cell` mm (for distances and stamps)."""

    def __init__(self, lines: Lines, cell: float):
        self.cell = cell
        self.cols = max(1, math.ceil(lines.width_mm / cell))
        self.rows = max(1, math.ceil(lines.height_mm / cell))
        self.top = lines.height_mm

    def index(self, p: np.ndarray):
        c = np.clip((p[:, 0] / self.cell).astype(np.intp), 0, self.cols - 1)
        r = np.clip(((self.top - p[:, 1]) / self.cell).astype(np.intp), 0, self.rows - 1)
        return r, c


class _Stamps(_Grid):
    """Which line last passed through each cell (cells TEST x d_g / 2, padded by one): -1
    none, -2 a line of an earlier round; and at which step of this round."""

    def __init__(self, lines: Lines, cell: float):
        super().__init__(lines, cell)
        self.owner = np.full((self.rows + 2, self.cols + 2), -1, dtype=np.int64)
        self.stamp = np.zeros(self.owner.shape, dtype=np.int64)
        self.reset(lines)

    def reset(self, lines: Lines) -> None:
        """Every line drawn so far: -2."""
        self.owner[:] = -1
        if len(lines.pts):
            r, c = self.index(lines.pts)
            self.owner[r + 1, c + 1] = -2

    def free(self, p: np.ndarray, radius: float) -> np.ndarray:
        """(N,) bool: no line in the square of cells within `radius` of each point (an
        integral image of the cells taken)."""
        r, c = self.index(p)
        k = max(1, int(0.7 * radius / self.cell))
        taken = np.zeros((self.rows + 2 * k + 1, self.cols + 2 * k + 1), dtype=np.int32)
        taken[k + 1:k + 1 + self.rows, k + 1:k + 1 + self.cols] = \
            self.owner[1:-1, 1:-1] != -1
        s = taken.cumsum(0).cumsum(1)
        r0, c0, r1, c1 = r, c, r + 2 * k + 1, c + 2 * k + 1
        return s[r1, c1] - s[r0, c1] - s[r1, c0] + s[r0, c0] == 0


def _seeds(lines: Lines, g: int, first: bool) -> np.ndarray:
    """Candidate seeds: a grid d_0 apart (generation 0's first round), else points d_g either
    side of every line drawn (every d_g / 2 along them)."""
    d = lines.sep(g)
    w, h = lines.width_mm, lines.height_mm
    if first and not len(lines.pts):
        xs = np.arange((0.5 + lines.phase) * d, w, d)
        ys = np.arange((0.5 + lines.phase) * d, h, d)
        if len(xs) == 0 or len(ys) == 0:
            return np.array([[w / 2, h / 2]]), np.zeros(1, dtype=np.int64), np.zeros(1)
        gx, gy = np.meshgrid(xs, ys)
        return np.column_stack([gx.ravel(), gy.ravel()]), np.arange(gx.size), np.zeros(gx.size)
    if not len(lines.pts):
        return np.zeros((0, 2))
    bucket = np.floor(lines.arc / (d / 2)).astype(np.int64)
    pick = np.r_[True, (bucket[1:] != bucket[:-1]) | (lines.line[1:] != lines.line[:-1])]
    q, n, line = lines.pts[pick], lines.normal[pick], lines.line[pick]
    # how far from the middle of its line (a seed from the middle first)
    arc = lines.arc[pick]
    total = np.zeros(len(lines.gen))
    np.maximum.at(total, line, arc)
    off = np.abs(arc - total[line] / 2)
    return (np.vstack([q + d * n, q - d * n]), np.concatenate([2 * line, 2 * line + 1]),
            np.concatenate([off, off]))


def _generation(lines: Lines, g: int) -> None:
    """Add generation g's lines (see the module's text)."""
    d = lines.sep(g)
    grid = _Grid(lines, d / 2)
    stamps = _Stamps(lines, TEST * d / 2)
    tried = np.zeros((grid.rows, grid.cols), dtype=bool)
    w, h = lines.width_mm, lines.height_mm
    for k in range(ROUNDS):
        cand, side, off = _seeds(lines, g, k == 0)
        inside = (cand[:, 0] > 0) & (cand[:, 0] < w) & (cand[:, 1] > 0) & (cand[:, 1] < h)
        r, c = grid.index(cand)
        free = inside & ~tried[r, c]
        free[free] = stamps.free(cand[free], 0.9 * d)
        cand, side, off, r, c = cand[free], side[free], off[free], r[free], c[free]
        if len(cand) == 0:
            return
        # one seed per side of a line (the one nearest its middle: few seeds on one path),
        # then one per cell of d x d
        o = np.lexsort((off, side))
        _, first = np.unique(side[o], return_index=True)
        pick = o[first]
        cell = ((r[pick] * grid.cell) // d).astype(np.int64) * (grid.cols + 1) + \
            ((c[pick] * grid.cell) // d).astype(np.int64)
        _, first = np.unique(cell, return_index=True)
        seeds = cand[pick[np.sort(first)]]
        pts, line = _integrate(lines, seeds, d, stamps)
        seg = np.r_[0.0, np.hypot(*np.diff(pts, axis=0).T)]
        seg[np.r_[True, line[1:] != line[:-1]]] = 0.0
        short = MIN_SEPS * min(d, SHORT_PENS * lines.pen_mm)
        long = np.bincount(line, seg, len(seeds)) >= short
        rr, cc = grid.index(seeds[~long])
        tried[rr, cc] = True
        keep = long[line]
        if keep.any():
            lines.add(pts[keep], line[keep], g)
        stamps.reset(lines)
        if not keep.any():
            return


def _integrate(lines: Lines, seeds: np.ndarray, d: float, lab: _Stamps):
    """Every seed's streamline, both ways at once (see the module's text)."""
    n = len(seeds)
    step = min(STEP_SEP * d, STEP_MAX_MM)
    test = TEST * d
    owner, stamp = lab.owner, lab.stamp
    offs = [(dr, dc) for dr in (-1, 0, 1) for dc in (-1, 0, 1)]
    ident = np.arange(n)
    # the seeds: one stamp each, a seed next to an earlier one's is dropped
    r, c = lab.index(seeds)
    owner[r[::-1] + 1, c[::-1] + 1] = ident[::-1]
    stamp[r + 1, c + 1] = 0
    ok = np.ones(n, dtype=bool)
    for dr, dc in offs:
        o = owner[r + 1 + dr, c + 1 + dc]
        ok &= ~((o != -1) & (o < ident))
    pos = np.vstack([seeds, seeds])
    t0 = lines.tangent(seeds)
    vel = np.vstack([t0, -t0])
    line = np.concatenate([ident, ident])
    alive = np.concatenate([ok, ok])
    trail_i, trail_p = [], []
    most = int(3 * (lines.width_mm + lines.height_mm) / step)
    w, h = lines.width_mm, lines.height_mm
    loop = 2 * LAG + int(2 * test / step)
    for k in range(1, most + 1):
        idx = np.flatnonzero(alive)
        if len(idx) == 0:
            break
        p, v = pos[idx], vel[idx]
        t = lines.tangent(p)
        t *= np.where((t * v).sum(1) < 0, -1.0, 1.0)[:, None]
        t2 = lines.tangent(p + 0.5 * step * t)
        t2 *= np.where((t2 * t).sum(1) < 0, -1.0, 1.0)[:, None]
        q = p + step * t2
        go = (q[:, 0] >= 0) & (q[:, 0] <= w) & (q[:, 1] >= 0) & (q[:, 1] <= h)
        r, c = lab.index(q)
        me = line[idx]
        for dr, dc in offs:
            o = owner[r + 1 + dr, c + 1 + dc]
            s = stamp[r + 1 + dr, c + 1 + dc]
            go &= ~((o != -1) & (o != me) & ((o < me) | (s < k - LAG)))
            go &= ~((o == me) & (s < k - loop))
        alive[idx[~go]] = False
        idx, q, t2, r, c = idx[go], q[go], t2[go], r[go], c[go]
        pos[idx], vel[idx] = q, t2
        owner[r + 1, c + 1] = line[idx]
        stamp[r + 1, c + 1] = k
        trail_i.append(idx)
        trail_p.append(q)
    return _assemble(seeds, ok, trail_i, trail_p)


def _assemble(seeds, ok, trail_i, trail_p):
    """(points, line) of every seed's line: its backward walk reversed, the seed, its forward
    walk (lines in the seeds' order)."""
    n = len(seeds)
    ii = np.concatenate(trail_i + [np.arange(n)]) if trail_i else np.arange(n)
    pp = np.concatenate(trail_p + [seeds]) if trail_p else seeds
    steps = np.concatenate([np.full(len(t), k + 1) for k, t in enumerate(trail_i)]
                           + [np.zeros(n, dtype=np.int64)])
    line = np.where(ii >= n, ii - n, ii)
    key = np.where(ii >= n, -steps, steps)
    order = np.lexsort((key, line))
    keep = ok[line[order]]
    return pp[order][keep], line[order][keep]
