"""Crosshatching: tone bands hatched at one to four angles.

Tone model. One layer of parallel lines `spacing_mm` apart drawn with a pen `pen_mm` wide
covers c = pen_mm / spacing_mm of the paper (at most 1). Layers at different angles overlap
where they cross, the crossings covering the product of their coverages, so n layers cover
C(n) = 1 - (1 - c)^n. The darkest the style can draw is C(4) (with a 0.5 mm pen at 1.5 mm:
c = 1/3, C = 0, 0.33, 0.56, 0.70, 0.80), and the picture's darkness 0..1 is mapped linearly
onto 0..C(4): a pixel of darkness d gets the number of layers n whose C(n) is nearest to
d x C(4), so the thresholds are (C(n-1) + C(n)) / (2 C(4)) (0.21, 0.55, 0.79, 0.94 there).
Layer 1 is at `angle_deg` (45), layer 2 at angle - 90 (-45), layer 3 at angle - 45 (0),
layer 4 at angle + 45 (90). Layer n is hatched where the band is n or darker, so the bands
are nested and the first layer runs through every inked area in long strokes.

Before the bands are cut the darkness is blurred over about two pen widths (no single-pixel
specks, and bands with smooth edges: on the bench photo that halves the strokes, 1444 -> 742,
for a tone correlation of 0.951 instead of 0.957) and runs shorter than two pen widths are
dropped; the hatch lines of every band lie
on one grid per angle, so bands meet without seams. A white picture draws nothing.

A spacing coarser than COARSEST_PENS pen widths (3.5 mm: what a tight plot-time budget asks
for, 10 to 20 mm for a photo 300 mm wide in an hour on the seed machine) is drawn at that
pitch, with the same line spent on the darker tones only: the darkness is remapped
(d - t) / (1 - t) with t chosen so the layers drawn add up to the line the spacing asked for
(`squiggle.concentrate`). Lines 15 mm apart over every tone are seen as lines, not tone
(correlation of ink with darkness 0.11 at a 1 mm blur on a photo of a cat, against 0.73 so:
bench/photo_tone.py).
"""

from __future__ import annotations

import numpy as np

from vplotter.inputs.hatch import hatch_mask
from vplotter.inputs.image.load import blur
from vplotter.inputs.image.squiggle import concentrate
from vplotter.inputs.strokes import Stroke

TURNS = (0.0, -90.0, -45.0, 45.0)       # the layers' angles, from angle_deg
COARSEST_PENS = 7.0                     # lines never further apart than this (3.5 mm at 0.5)


def thresholds(spacing_mm: float, pen_mm: float, layers: int = 4) -> np.ndarray:
    """Darkness at which layer 1..layers starts (the tone model above)."""
    c = min(1.0, pen_mm / spacing_mm)
    cov = 1 - (1 - c) ** np.arange(layers + 1)
    return (cov[:-1] + cov[1:]) / (2 * cov[-1])


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5, angle_deg: float = 45.0,
            layers: int = 4, smooth_mm: float | None = None,
            min_run_mm: float | None = None) -> list[Stroke]:
    """Crosshatch the picture: `layers` (1..4) directions, lines `spacing_mm` apart."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    layers = int(min(max(layers, 1), len(TURNS)))
    px = picture.mm_per_px
    d = blur(picture.darkness, (2 * pen_mm if smooth_mm is None else smooth_mm) / px / 1.4)
    cap = COARSEST_PENS * pen_mm
    if spacing_mm > cap:                # the line of spacing_mm, at the cap, on the darker tones

        def line(x, sp):                # layers per pixel / spacing: line per mm²
            t = thresholds(sp, pen_mm, layers)
            return float(np.searchsorted(t, x[::2, ::2], side="right").mean()) / sp

        d = concentrate(d, line(d, spacing_mm), lambda x: line(x, cap))
        spacing_mm = cap
    band = np.searchsorted(thresholds(spacing_mm, pen_mm, layers), d, side="right")
    min_run = 2 * pen_mm if min_run_mm is None else min_run_mm
    out: list[Stroke] = []
    for n in range(1, layers + 1):
        mask = band >= n
        if not mask.any():
            break
        for pts in hatch_mask(mask, picture.width_mm, picture.height_mm, spacing_mm,
                              angle_deg + TURNS[n - 1], min_run_mm=min_run,
                              max_link_mm=4 * spacing_mm):
            out.append(Stroke(pts, layer=f"hatch {n}"))
    return out
