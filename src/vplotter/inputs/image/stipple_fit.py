"""Stipples moved to draw the picture's tone best: the dots' positions fitted to the darkness
as it is seen (blurred at viewing distance), after the Lloyd relaxation that spread them.

A stipple drawing with a plot-time budget has few dots (on the seed machine a tap costs about
2.2 s: an hour buys about 1,500), several millimetres apart, and is seen at a blur of about a
millimetre (`score.py`), where each dot is a separate bump. How well the ink follows the tone
is the Pearson correlation r of the blurred ink I with the blurred darkness D. Lloyd
relaxation spreads the dots evenly over their density, but it does not know the blur: it does
not put a dot where the darkness has a small dark feature between two dots, nor pull it off a
light one. So the dots are moved by gradient ascent on r itself: with I = K * (sum of unit
impulses at the dots), K the Gaussian of SIGMA_MM (the viewing blur, and the pen's disc),

    dr/dI = D'/(|I'| |D'|) - r I'/|I'|²       (' : less the mean)
    dr/dx_i = grad (K * dr/dI) at x_i         (K is symmetric)

on a grid of CELL_MM cells (the dots splatted bilinearly; the blur a separable Gaussian,
SciPy's ndimage). Each round moves every dot along its gradient, the 90th percentile of the
moves STEP_MM long (step shrinking linearly to a fifth over the rounds) and none longer,
clipped into the picture. Gradient steps only move a dot locally; so every JUMP_EVERY rounds
(in the first JUMP_UNTIL of them) JUMP_SHARE of the dots, those where K * dr/dI is lowest (where
their ink is least wanted), jump to its highest local maxima (one per PEAK_MM square, where
ink is most wanted), kept if r rises, else half as many are tried (a direct-binary-search
swap, Analoui and Allebach 1992, on the continuous positions). Dots marked `stay` move but
never jump (the caller's floor per tone). A dot is never created or removed, so the plot time
(the number of taps and the travel between them) barely changes; deterministic (no random
numbers). ROUNDS rounds cost about a tenth of a second for 6,000 dots on a 300 mm picture.

What they gave at the budget's count of dots (bench/photo_tone.py's measure, 300 mm):
gradient steps alone camera 0.55 -> 0.60 at 1 h, coffee 0.50 -> 0.56, rocket 0.27 -> 0.31; the
jumps on top (with the same curve) camera 0.616 -> 0.654 (1 h) and 0.891 -> 0.920 (3 h),
coffee 0.563 -> 0.588 (1 h). More rounds (100 or 150 against 50, jumps every 10 or 5),
more or larger jumps, other peak sizes: within 0.003.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CELL_MM = 1.0      # the fitting grid
SIGMA_MM = 1.0     # the viewing blur (score.SIGMA_MM)
ROUNDS = 50
STEP_MM = 0.4
INSET = 1e-6
JUMP_EVERY = 5     # every this many rounds (in the first JUMP_UNTIL of them) JUMP_SHARE of the
JUMP_UNTIL = 0.7   # ... dots, where the field wants ink least, jump to its highest peaks (one
JUMP_SHARE = 0.02  # ... per PEAK_MM square), kept if r rises (else half as many are tried)
PEAK_MM = 5.0


def fitted(pts: np.ndarray, darkness, width_mm: float, height_mm: float,
           rounds: int = ROUNDS, step_mm: float = STEP_MM, cell_mm: float = CELL_MM,
           teleport: bool = True, stay: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """(the dots `pts` (N, 2), G-code mm, moved to raise the correlation of their blurred ink
    with `darkness` (a (H, W) array over the picture, row 0 at the top; blurred or not), the
    correlation they reached: on the fitting grid, the last round's, 0.0 when nothing could
    be fitted)."""
    from PIL import Image

    if len(pts) < 2:
        return pts, 0.0
    cols = max(2, round(width_mm / cell_mm))
    rows = max(2, round(height_mm / cell_mm))
    g = _Grid(cols, rows, width_mm / cols, height_mm / rows, height_mm)
    d = np.asarray(Image.fromarray(np.asarray(darkness, dtype=np.float32), mode="F")
                   .resize((cols, rows), Image.BOX), dtype=np.float32)
    dc = g.blur(d)
    g.dc = dc = dc - dc.mean()
    g.nd = float(np.sqrt((dc * dc).sum()))
    if not g.nd > 0:
        return pts, 0.0
    pts = np.array(pts, dtype=np.float64)
    hi = np.array([width_mm, height_mm]) - INSET
    peak = max(3, 2 * round(PEAK_MM / 2 / cell_mm) + 1)
    r = 0.0
    for k in range(rounds + 1):
        got = g.state(pts)
        r, field = got[0], got[1]
        if field is None or k == rounds:
            break
        if teleport and k % JUMP_EVERY == JUMP_EVERY - 1 and k < JUMP_UNTIL * rounds:
            pts, got = _jump(g, pts, got, peak, stay, hi)
            r = got[0]
        move = _step(g, got, step_mm * (1.0 - 0.8 * k / max(rounds - 1, 1)))
        if move is None:
            break
        pts = np.clip(pts + move, INSET, hi)
    return pts, r


@dataclass
class _Grid:
    """The fitting grid (cols x rows cells of cw x ch mm over a picture height_mm high) and
    the picture's blurred darkness on it, less its mean (dc; nd its norm)."""

    cols: int
    rows: int
    cw: float
    ch: float
    height_mm: float
    dc: np.ndarray | None = None
    nd: float = 0.0

    def blur(self, a: np.ndarray) -> np.ndarray:
        from scipy.ndimage import gaussian_filter

        sig = (SIGMA_MM / self.ch, SIGMA_MM / self.cw)
        return gaussian_filter(a, sig, mode="reflect", truncate=3.0)

    def state(self, pts: np.ndarray):
        """(r, the field dr/dI blurred, the dots' cells and bilinear weights)."""
        cols, rows, dc, nd = self.cols, self.rows, self.dc, self.nd
        x = pts[:, 0] / self.cw - 0.5
        y = (self.height_mm - pts[:, 1]) / self.ch - 0.5
        x0 = np.clip(np.floor(x).astype(np.intp), 0, cols - 2)
        y0 = np.clip(np.floor(y).astype(np.intp), 0, rows - 2)
        fx, fy = np.clip(x - x0, 0, 1), np.clip(y - y0, 0, 1)
        w = ((1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy)
        cells = (y0 * cols + x0, y0 * cols + x0 + 1, (y0 + 1) * cols + x0,
                 (y0 + 1) * cols + x0 + 1)
        acc = np.bincount(np.concatenate(cells), np.concatenate(w), rows * cols)
        ink = self.blur(acc.reshape(rows, cols).astype(np.float32))
        ic = ink - ink.mean()
        ni = float(np.sqrt((ic * ic).sum()))
        if not ni > 0:
            return 0.0, None, cells, w
        r = float((ic * dc).sum()) / (ni * nd)
        return r, self.blur((dc / (ni * nd) - r * ic / (ni * ni)).astype(np.float32)), cells, w


def _at(a: np.ndarray, cells, w) -> np.ndarray:
    """The grid values `a` at the dots (bilinear)."""
    return sum(a.ravel()[c] * wt for c, wt in zip(cells, w))


def _jump(g: _Grid, pts: np.ndarray, got, peak: int, stay, hi):
    """The dots where ink is least wanted to the places where it is most wanted, if r rises
    (else half as many are tried): (the dots, their state)."""
    from scipy.ndimage import maximum_filter

    r, field, cells, w = got
    top = np.flatnonzero(((field == maximum_filter(field, size=peak)) &
                          (field > 0)).ravel())
    top = top[np.argsort(-field.ravel()[top], kind="stable")]
    worst = np.argsort(_at(field, cells, w), kind="stable")
    if stay is not None:                     # these dots only move, never jump
        worst = worst[~stay[worst]]
    m = min(len(top), len(worst), max(1, int(JUMP_SHARE * len(pts))))
    while m >= 1:
        row, col = np.divmod(top[:m], g.cols)
        new = pts.copy()
        new[worst[:m]] = np.column_stack([(col + 0.5) * g.cw, g.height_mm - (row + 0.5) * g.ch])
        new = np.clip(new, INSET, hi)
        tried = g.state(new)
        if tried[0] > r:
            return new, tried
        m //= 2
    return pts, got


def _step(g: _Grid, got, step: float) -> np.ndarray | None:
    """Every dot's move along its gradient: the 90th percentile of the moves `step` long and
    none longer; None where there is no gradient."""
    _, field, cells, w = got
    gy, gx = np.gradient(field)
    grad = np.column_stack([_at(gx, cells, w) / g.cw, -_at(gy, cells, w) / g.ch])
    size = np.hypot(*grad.T)
    top = float(np.percentile(size, 90))
    if not top > 0:
        return None
    move = grad * (step / top)
    longest = np.hypot(*move.T)
    move *= np.minimum(1.0, step / np.maximum(longest, 1e-12))[:, None]
    return move


def correlation(pts: np.ndarray, darkness, width_mm: float, height_mm: float,
                cell_mm: float = 0.5) -> float:
    """The correlation the dots `pts` draw `darkness` with, as `fitted` measures it but on
    cells of cell_mm (finer: closer to the bench's rendering, which the 1 mm grid flatters
    where dots are close)."""
    return fitted(pts, darkness, width_mm, height_mm, rounds=0, cell_mm=cell_mm,
                  teleport=False)[1]
