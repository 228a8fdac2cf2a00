"""Crosshatching: nested hatch lines on one grid, one to three angles, along a tone curve.

Tone model. The budget's knob `spacing_mm` is the finest pitch p: all lines of an angle lie on one
grid p apart (line k at (k + 1/2) p from the origin along the normal). One full layer of lines p
apart drawn with a pen w wide covers c = w / p of the paper (at most 1); layers at different angles
overlap where they cross, so n full layers cover C(n) = 1 - (1 - c)^n, and a partial layer (a share
s of its lines) adds s x c of what is left. The darkest tone gets `full_layers` layers (3 at a
generous spacing of up to CROSS_PENS = 1.5 pen widths, falling log-linearly to 1 at ONE_LAYER_PENS =
2.5 pen widths and coarser: lines that cross overlap there and leave a coarser texture, so at the
same length of line one direction at a finer pitch reads better as tone; on bench/photo_tone.py,
with the fitted tone curves, one layer drew every photograph better at 3 h (the astronaut 0.868 ->
0.894, the camera 0.914 -> 0.931, same length; at 60 m still 0.949 -> 0.953). Crossing is kept where
the pitch is that fine anyway (on a 300 mm photo about 6 hours and more), where the look of
crosshatching costs little); a pixel of darkness d gets the coverage f(d) x C(full layers), f the
budget's tone curve (`tone.py`; d^`tone_gamma` to start with), turned into layer units F (0..full
layers) by inverting C. Layer n (1, 2, 3) draws where F > n - 1, its share F - (n - 1) of lines laid
by the binary nesting of `tone.py`: every 16th line takes the share from 0 to 1/16, the ones
half-way between from 1/16 to 1/8, every 4th from 1/8 to 1/4, every 2nd from 1/4 to 1/2 and the rest
from 1/2 to 1, each drawn in dashes (period 16 p, the dash that part of it) across its range and
whole above it, so the lines drawn cover the share asked for, however small, and a darker tone
always more. Layer 1 is at `angle_deg` (45), layer 2 at angle - 90 (-45), layer 3 at angle - 45 (0).

Each layer is one grid of lines p apart hatched on a mask in which every pixel carries the
decision of its nearest line (its level, its dashes), so the lines drawn next to each other
(all of them in the darks) are joined back and forth (`inputs/hatch.py`, moves of at most
4 p) and the sparse ones are single strokes. Before the levels are cut the darkness is blurred
over about two pen widths (no single-pixel specks, smooth edges) and runs shorter than two pen
widths are dropped. A white picture draws nothing. Figures against `hatched`, the vpype
plugin, at the same length: docs/measurements.md (Photos).
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.inputs.hatch import hatch_mask
from vplotter.inputs.image.load import blur
from vplotter.inputs.image import tone
from vplotter.inputs.strokes import Stroke

TURNS = (0.0, -90.0, -45.0)             # the layers' angles, from angle_deg
MAX_LAYERS = 3
CROSS_PENS = 1.5                        # up to this spacing (pen widths): MAX_LAYERS in black
ONE_LAYER_PENS = 2.5                    # from this spacing on (pen widths): one layer in black
SCARCE_PENS = 6.0                       # the tone curve d^8 from this spacing (pen widths)


def full_layers(spacing_mm: float, pen_mm: float) -> float:
    """Layers of lines in black (1 to MAX_LAYERS, continuous): MAX_LAYERS up to
    CROSS_PENS pen widths, 1 from ONE_LAYER_PENS, log-linear between."""
    e = spacing_mm / (CROSS_PENS * pen_mm)
    if e <= 1:
        return float(MAX_LAYERS)
    x = math.log(e) / math.log(ONE_LAYER_PENS / CROSS_PENS)
    return float(max(1.0, MAX_LAYERS - (MAX_LAYERS - 1) * x))


def tone_gamma(spacing_mm: float, pen_mm: float) -> float:
    """The hatch's tone curve exponent for this spacing (`tone.gamma` with its own ends: d^1 up
    to CROSS_PENS pen widths, d^8 from SCARCE_PENS; one layer draws a finer pitch than the
    crossed ones did for the same budget, so the curve steepens sooner)."""
    return tone.gamma(spacing_mm, pen_mm, CROSS_PENS, SCARCE_PENS)


def coverage(layers, c):
    """Paper covered by `layers` (fractional) layers of lines covering c each."""
    n = np.floor(layers)
    return 1 - (1 - c) ** n * (1 - (layers - n) * c)


def layer_units(cover, c, most: float) -> np.ndarray:
    """The inverse of `coverage`: layers (0..most) that cover `cover`."""
    cover = np.clip(cover, 0, coverage(most, c))
    if c >= 1:
        return np.minimum(cover, most)
    n = np.floor(np.log(1 - cover) / np.log(1 - c) + 1e-6)
    frac = (1 - (1 - cover) / (1 - c) ** n) / c
    return np.clip(n + np.clip(frac, 0, 1), 0, most)


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5, angle_deg: float = 45.0,
            layers: float | None = None, smooth_mm: float | None = None,
            min_run_mm: float | None = None, curve=None) -> list[Stroke]:
    """Crosshatch the picture: finest pitch `spacing_mm`, up to `layers` directions in black
    (default `full_layers`), tone curve `curve`: an exponent or a tone.Table (default
    d^`tone_gamma`)."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    p = spacing_mm
    most = full_layers(p, pen_mm) if layers is None else float(min(max(layers, 1), MAX_LAYERS))
    g = tone_gamma(p, pen_mm) if curve is None else curve
    px = picture.mm_per_px
    d = blur(picture.darkness, (2 * pen_mm if smooth_mm is None else smooth_mm) / px / 1.4)
    c = min(1.0, pen_mm / p)
    f = tone.curve(d, g)
    units = layer_units(f * coverage(most, c), c, most).astype(np.float32)
    min_run = 2 * pen_mm if min_run_mm is None else min_run_mm
    out: list[Stroke] = []
    hh, ww = d.shape
    x = ((np.arange(ww, dtype=np.float32) + 0.5) * (picture.width_mm / ww))[None, :]
    y = (picture.height_mm
         - (np.arange(hh, dtype=np.float32) + 0.5) * (picture.height_mm / hh))[:, None]
    for n in range(1, math.ceil(most - 1e-9) + 1):
        share = units - (n - 1)
        if not (share > 0).any():
            break
        a = math.radians(angle_deg + TURNS[n - 1])
        along = x * math.cos(a) + y * math.sin(a)           # u and v of the lines' frame
        k = np.rint((y * math.cos(a) - x * math.sin(a)) / p - 0.5)    # the nearest line
        mask = tone.dashed(share, tone.level(k), along, k, tone.DASH_LINES * p)
        for pts in hatch_mask(mask, picture.width_mm, picture.height_mm, p,
                              angle_deg + TURNS[n - 1], min_run_mm=min_run, max_link_mm=4 * p):
            out.append(Stroke(pts, layer=f"hatch {n}"))
    return out
