"""Flow: long lines that follow the shapes of the picture, spaced by its tone (the flow-field
style of DrawingBotV3; Jobard and Lefer's evenly spaced streamlines along the edge-tangent
flow).

The lines are evenly spaced streamlines of the picture's smoothed structure tensor (its edges'
direction), made in nested generations, each about half-way between the coarser ones
(`flow_lines.py`): the lines of generations 0..g lie about d_g = pen x 2^(6 - g) apart.

Tone model: that of the hatch in one direction (`hatch.py`, `tone.py`). The budget's knob
`spacing_mm` is the finest pitch p; the finest generation drawn is the one whose d_G is the
largest at most p, and it stands for p by taking the share d_G / p of the tone: a pixel of
darkness d asks for the share s = f(d) x d_G / p of the lines, f the budget's tone curve
(d^`tone_gamma`, or the curve the budget chose). Generation G takes the nesting level 4 (the
share from 1/2 to 1), G - 1 level 3 (1/4 to 1/2) ... and G - 4 and every coarser one level 0
(0 to 1/16): each line is drawn in dashes (period DASH_LINES d_G along it, d_G at least
DASH_PENS pen widths there so that the lightest tones' dashes are not shorter than the shortest
piece drawn; the dash the part of its range the share has reached; level 0, the lightest tones,
16 d_G with d_G at least LIGHT_PENS, as the hatch; the denser levels 8 d_G, d_G at least 2 pen
widths: finer dashes where the lines are dense, docs/measurements.md) across its level's range
and whole above it (`tone.dashed`), so the separation of the lines drawn follows the tone: d_G
in black, 2 d_G where s = 1/2, 16 d_G in the lightest tones, in dashes; halving p about doubles
the line (the jump from one generation to the next is seamless: the same lines at the same
shares). The darkness is blurred over about two pen widths first; gaps shorter than 4 pen
widths are drawn through and pieces
shorter than MIN_RUN_PENS pen widths dropped, so the strokes are long and the lifts few.
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.inputs.image import flow_lines, tone
from vplotter.inputs.image.load import blur
from vplotter.inputs.image.picture import Picture
from vplotter.inputs.strokes import Stroke

CROSS_PENS, SCARCE_PENS = 1.5, 6.0     # the tone curve: d up to this pitch, d^8 from this
MIN_RUN_PENS = 2.0                     # pen-down pieces shorter than this are dropped
GAP_PENS = 4.0                         # gaps shorter than this are drawn through
DASH_LINES = 8                         # the dashes' period: this many d_G, d_G at least
DASH_PENS = 2.0                        # ... this many pen widths (level 0: the hatch's period,
LIGHT_PENS = 4.0                       # 16 d_G, d_G at least this many pen widths)
EVEN_CELLS = 3.0                       # `evenness`: the density blurred over this many d_G / 2
MEMO = 8                               # pictures whose streamlines are remembered
_memo: list = []                       # (picture, key, flow_lines.Lines)


def tone_gamma(spacing_mm: float, pen_mm: float) -> float:
    """The tone curve's exponent for this spacing (the hatch's: one direction of lines)."""
    return tone.gamma(spacing_mm, pen_mm, CROSS_PENS, SCARCE_PENS)


def lines(picture, pen_mm: float, angle_deg: float = 45.0, phase: float = 0.0):
    """The picture's streamlines (`flow_lines.Lines`, generations made as asked), remembered
    for the last MEMO pictures (the object itself: a budget search draws one many times)."""
    key = (pen_mm, angle_deg, phase)
    for pic, k, made in _memo:
        if pic is picture and k == key:
            return made
    field, cw, ch = flow_lines.tangents(picture.darkness, picture.width_mm, picture.height_mm,
                                        pen_mm, angle_deg)
    made = flow_lines.Lines(field, cw, ch, picture.width_mm, picture.height_mm, pen_mm, phase)
    _memo[:] = _memo[-(MEMO - 1):] + [(picture, key, made)]
    return made


def generation(spacing_mm: float, pen_mm: float) -> int:
    """The finest generation drawn at this spacing: the largest d_G at most the spacing."""
    g = math.ceil(flow_lines.TOP_POW - math.log2(spacing_mm / pen_mm) - 1e-9)
    return int(min(max(g, 0), flow_lines.TOP_POW))


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5, angle_deg: float = 45.0,
            phase: float = 0.0, curve=None) -> list[Stroke]:
    """The flow lines drawn at the finest pitch `spacing_mm` (the tone model above); angle_deg:
    the lines' direction where the picture is flat; phase: generation 0's seeds moved by that
    share of its separation (--cmyk's layers); curve: the tone curve, an exponent or a
    tone.Table (default d^`tone_gamma`)."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    if not picture.darkness.max() > 0:
        return []
    g_top = generation(spacing_mm, pen_mm)
    made = lines(picture, pen_mm, angle_deg, phase).upto(g_top)
    d_top = made.sep(g_top)
    keep = made.gen[made.line] <= g_top
    if not keep.any():
        return []
    g = tone_gamma(spacing_mm, pen_mm) if curve is None else curve
    px = picture.mm_per_px
    smooth = Picture(blur(picture.darkness, 2 * pen_mm / px / 1.4), picture.width_mm,
                     picture.height_mm)
    pts, line, arc = made.pts[keep], made.line[keep], made.arc[keep]
    level = np.maximum(made.gen[line] - (g_top - (tone.LEVELS - 1)), 0)
    share = tone.curve(smooth.at(pts), g) * np.float32(min(1.0, d_top / spacing_mm))
    share *= _evenness(made, g_top, keep)
    period = np.where(level == 0, tone.DASH_LINES * max(d_top, LIGHT_PENS * pen_mm),
                      DASH_LINES * max(d_top, DASH_PENS * pen_mm))
    on = tone.dashed(share, level, arc, line, period)
    return [Stroke(p) for p in _runs(pts, line, arc, on, pen_mm)]


def _evenness(made, g_top: int, keep) -> np.ndarray:
    """Per point (of the lines kept): the lines' nominal density (1 / d_G) over their own,
    measured over about d_G (length per area, blurred), clipped to 1/2..2: where the
    streamlines came closer than d_G each carries less of the tone, where further more."""
    from scipy import ndimage

    d = made.sep(g_top)
    cell = d / 2
    cols = max(1, int(np.ceil(made.width_mm / cell)))
    rows = max(1, int(np.ceil(made.height_mm / cell)))
    pts, line = made.pts[keep], made.line[keep]
    seg = np.r_[0.0, np.hypot(*np.diff(pts, axis=0).T)]
    seg[np.r_[True, line[1:] != line[:-1]]] = 0.0
    c = np.clip((pts[:, 0] / cell).astype(np.intp), 0, cols - 1)
    r = np.clip(((made.height_mm - pts[:, 1]) / cell).astype(np.intp), 0, rows - 1)
    dens = np.bincount(r * cols + c, seg, rows * cols).reshape(rows, cols) / (cell * cell)
    dens = ndimage.gaussian_filter(dens, EVEN_CELLS, mode="nearest")
    return np.clip((1 / d) / np.maximum(dens[r, c], 1e-9), 0.5, 2.0).astype(np.float32)


def _runs(pts: np.ndarray, line: np.ndarray, arc: np.ndarray, on: np.ndarray, pen_mm: float):
    """The pen-down pieces: gaps under GAP_PENS pen widths closed within a line, pieces under
    MIN_RUN_PENS pen widths dropped; none runs from one line into the next."""
    from vplotter.inputs.image.squiggle import hysteresis

    start = np.r_[True, line[1:] != line[:-1]]
    s = arc + np.cumsum(start) * 1e6              # each line far from the next
    on = hysteresis(on, s, GAP_PENS * pen_mm, MIN_RUN_PENS * pen_mm - 1e-6)
    first = on & (start | ~np.r_[False, on[:-1]])                 # a piece starts here
    last = on & (np.r_[start[1:], True] | ~np.r_[on[1:], False])   # ... and ends here
    a, b = np.flatnonzero(first), np.flatnonzero(last)
    long = arc[b] - arc[a] >= MIN_RUN_PENS * pen_mm - 1e-9
    return [pts[i:j + 1] for i, j in zip(a[long].tolist(), b[long].tolist()) if j > i]
