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


def _gauss(n: int, sigma: float) -> np.ndarray:
    """(n, n) matrix of a 1-D Gaussian blur of sigma cells, edges mirrored."""
    r = max(1, int(math.ceil(3 * sigma)))
    k = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    k /= k.sum()
    m = np.zeros((n, n), dtype=np.float32)
    rows = np.arange(n)
    for off, wgt in zip(range(-r, r + 1), k):
        j = rows + off
        j = np.where(j < 0, -j - 1, j)
        j = np.clip(np.where(j >= n, 2 * n - j - 1, j), 0, n - 1)
        np.add.at(m, (rows, j), np.float32(wgt))
    return m


def grid(picture) -> tuple[int, int, float, float]:
    """(rows, cols, cell width mm, cell height mm) of the scoring grid."""
    cols = max(2, round(picture.width_mm / CELL_MM))
    rows = max(2, round(picture.height_mm / CELL_MM))
    return rows, cols, picture.width_mm / cols, picture.height_mm / rows


def blurred(a: np.ndarray, cw: float, ch: float) -> np.ndarray:
    return _gauss(a.shape[0], SIGMA_MM / ch) @ a @ _gauss(a.shape[1], SIGMA_MM / cw).T


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
    pts, amount = [], []
    for s in strokes:
        p = np.asarray(s.pts, dtype=np.float64)
        if len(p) == 1 or not np.ptp(p, axis=0).max() > 0:
            pts.append(p[:1])
            amount.append(np.array([math.pi * pen_mm * pen_mm / 4]))
            continue
        seg = np.hypot(*np.diff(p, axis=0).T)
        n = np.maximum(1, np.ceil(seg / STEP_MM)).astype(np.int64)
        idx = np.repeat(np.arange(len(seg)), n)
        first = np.cumsum(n) - n
        t = (np.arange(int(n.sum())) - np.repeat(first, n) + 0.5) / np.repeat(n, n)
        pts.append(p[idx] + (p[idx + 1] - p[idx]) * t[:, None])
        amount.append(np.repeat(seg / n, n) * pen_mm)
    if pts:
        q, a = np.concatenate(pts), np.concatenate(amount)
        c = np.clip((q[:, 0] / cw).astype(np.int64), 0, cols - 1)
        r = np.clip(((picture.height_mm - q[:, 1]) / ch).astype(np.int64), 0, rows - 1)
        acc = np.bincount(r * cols + c, a, rows * cols)
    cover = np.minimum(acc.reshape(rows, cols) / (cw * ch), 1.0).astype(np.float32)
    return blurred(cover, cw, ch)


def correlation(strokes, picture, pen_mm: float, dark: np.ndarray | None = None) -> float:
    """Pearson correlation of the strokes' blurred ink with the picture's blurred darkness
    (0 when either is flat). `dark`: `darkness(picture)`, when already computed."""
    a = ink(strokes, picture, pen_mm).ravel()
    b = (darkness(picture) if dark is None else dark).ravel()
    if not a.std() > 0 or not b.std() > 0:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])
