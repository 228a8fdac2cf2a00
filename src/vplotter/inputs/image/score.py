"""How well strokes draw a picture's tone: the converter's own quick version of the bench's
measure, to choose the tone curve per picture.

`correlation(strokes, picture, pen_mm)`: the strokes drawn as ink of the pen's width on a grid
of CELL_MM cells (each stroke sampled every STEP_MM along its length, each sample laying its
piece of line x the pen width of ink in its cell; a 1-point stroke, a dot, a disc of the pen;
coverage clipped at 1), both that ink and the picture's darkness (area-averaged to the same
cells) blurred with a Gaussian of SIGMA_MM (the viewing distance), and the Pearson correlation
of the two over the picture. bench/photo_tone.py measures the same thing finer (lines rendered
at 10 px/mm, 0.5 mm cells); at 1 mm cells this costs a few hundredths of a second for a 300 mm
picture (numpy only: np.bincount and two small matrix products).
"""

from __future__ import annotations

import math

import numpy as np

CELL_MM = 1.0
SIGMA_MM = 1.0
STEP_MM = 0.25


def _kernel(sigma: float) -> np.ndarray:
    """The 1-D Gaussian of sigma cells, cut at ceil(3 sigma) (at least 1) either side, summing
    to 1."""
    r = max(1, int(math.ceil(3 * sigma)))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    return k / k.sum()


def _blur1(a: np.ndarray, sigma: float, axis: int) -> np.ndarray:
    """a blurred along one axis by the Gaussian of sigma cells, edges mirrored (the cells
    beyond the edge are those inside it, edge first; clamped where the kernel is wider than
    the grid): the kernel's taps as shifted copies of the mirrored grid."""
    k = _kernel(sigma)
    r, n = len(k) // 2, a.shape[axis]
    j = np.arange(-r, n + r)
    j = np.where(j < 0, -j - 1, j)
    j = np.clip(np.where(j >= n, 2 * n - j - 1, j), 0, n - 1)
    b = np.take(np.asarray(a, dtype=np.float32), j, axis=axis)
    out = np.zeros(a.shape, dtype=np.float32)
    for t, w in enumerate(k):
        out += np.float32(w) * (b[t:t + n] if axis == 0 else b[:, t:t + n])
    return out


def grid(picture) -> tuple[int, int, float, float]:
    """(rows, cols, cell width mm, cell height mm) of the scoring grid."""
    cols = max(2, round(picture.width_mm / CELL_MM))
    rows = max(2, round(picture.height_mm / CELL_MM))
    return rows, cols, picture.width_mm / cols, picture.height_mm / rows


def blurred(a: np.ndarray, cw: float, ch: float) -> np.ndarray:
    """a (rows, cols of cells ch x cw mm) blurred by the Gaussian of SIGMA_MM, float32."""
    return _blur1(_blur1(a, SIGMA_MM / ch, 0), SIGMA_MM / cw, 1)


def darkness(picture) -> np.ndarray:
    """The picture's darkness on the scoring grid, blurred (compute once per picture)."""
    from PIL import Image

    rows, cols, cw, ch = grid(picture)
    d = np.asarray(Image.fromarray(np.asarray(picture.darkness, dtype=np.float32), mode="F")
                   .resize((cols, rows), Image.BOX), dtype=np.float32)
    return blurred(d, cw, ch)


def ink(strokes, picture, pen_mm: float) -> np.ndarray:
    """Ink coverage of the strokes (picture mm, as the styles make them) per cell, blurred."""
    rows, cols, cw, ch = grid(picture)
    acc = np.zeros(rows * cols, dtype=np.float64)
    if strokes:
        q, a = _samples([np.asarray(s.pts, dtype=np.float64) for s in strokes], pen_mm)
        c = np.clip((q[:, 0] / cw).astype(np.int64), 0, cols - 1)
        r = np.clip(((picture.height_mm - q[:, 1]) / ch).astype(np.int64), 0, rows - 1)
        acc = np.bincount(r * cols + c, a, rows * cols)
    cover = np.minimum(acc.reshape(rows, cols) / (cw * ch), 1.0).astype(np.float32)
    return blurred(cover, cw, ch)


def _samples(polys: list, pen_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """(points, ink mm² at each): every line sampled every STEP_MM or less (the middle of each
    piece, laying its length x the pen width), a dot (one point, or a stroke that does not
    move) the disc of the pen at its first point; all strokes at once."""
    lens = np.array([len(p) for p in polys])
    p = np.concatenate(polys)
    first = np.cumsum(lens) - lens
    ext = np.maximum.reduceat(p, first) - np.minimum.reduceat(p, first)
    dot = (lens == 1) | ~(ext.max(1) > 0)
    sid = np.repeat(np.arange(len(polys)), lens)
    inner = (sid[:-1] == sid[1:]) & ~dot[sid[:-1]]                # segments inside a line
    a, b = p[:-1][inner], p[1:][inner]
    seg = np.hypot(*(b - a).T)
    n = np.maximum(1, np.ceil(seg / STEP_MM)).astype(np.int64)
    idx = np.repeat(np.arange(len(seg)), n)
    start = np.cumsum(n) - n
    t = (np.arange(int(n.sum())) - np.repeat(start, n) + 0.5) / np.repeat(n, n)
    pts = a[idx] + (b[idx] - a[idx]) * t[:, None]
    amount = np.repeat(seg / n, n) * pen_mm
    dots = p[first[dot]]
    return (np.concatenate([pts, dots]),
            np.concatenate([amount, np.full(len(dots), math.pi * pen_mm * pen_mm / 4)]))


def correlation(strokes, picture, pen_mm: float, dark: np.ndarray | None = None) -> float:
    """Pearson correlation of the strokes' blurred ink with the picture's blurred darkness
    (0 when either is flat). `dark`: `darkness(picture)`, when already computed."""
    a = ink(strokes, picture, pen_mm).ravel()
    b = (darkness(picture) if dark is None else dark).ravel()
    if not a.std() > 0 or not b.std() > 0:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])
