"""Colour photos as four pens: cyan, magenta, yellow and black layers (`--cmyk`).

Separation, in linear light, with ideal inks that multiply on white paper: cyan takes red
away, magenta green, yellow blue, black all three, so a pixel (r, g, b) asks for the
coverages c0 = 1 - r, m0 = 1 - g, y0 = 1 - b of the three colour inks alone. Full grey
component replacement (GCR, the grey part of the colour all in black): k = min(c0, m0, y0),
and each colour ink covers what is left under the black, c = (c0 - k) / (1 - k) (likewise
m, y), so that (1 - c)(1 - k) = r exactly: a grey pixel is drawn in black alone, a saturated
colour in at most two colour inks (pure red: magenta and yellow), and no pixel asks for all
four. With line art that is also the cheapest split: one line of black in place of three
crossed colour lines.

Each layer is then drawn in the chosen style as its own picture (`darkness` = that ink's
coverage), at one density for all four (the budget's knob, so the plot-time budget covers the
four together), at its own angle so the layers do not fall on each other's lines: hatch at the
printers' screen angles (yellow 0, cyan 15, magenta 75, black 45 degrees, each with its
crossings), the spiral turned a quarter turn per layer (its tracks a quarter pitch apart), the
squiggle's rows a quarter pitch apart, stipples from their own random start. Every stroke names
its pen (`Stroke.pen`, 'yellow', 'cyan', 'magenta', 'black') and the pen's colour
(`Stroke.colour`), its layer the pen (so ordering keeps each pen's strokes together), and the
layers come light to dark: yellow, cyan, magenta, black (a dark line is not smeared by a later
light pen).
"""

from __future__ import annotations

import numpy as np

from vplotter.inputs.image.picture import Picture

# (pen, colour, hatch screen angle in degrees), light to dark
INKS = (("yellow", "#ffff00", 0.0), ("cyan", "#00ffff", 15.0),
        ("magenta", "#ff00ff", 75.0), ("black", "#000000", 45.0))


def separate(rgb) -> np.ndarray:
    """(4, H, W) coverage 0..1 of yellow, cyan, magenta and black (INKS' order) of linear-light
    rgb (3, H, W) on white paper (full GCR, see the module's text)."""
    rgb = np.clip(np.asarray(rgb, dtype=np.float32), 0, 1)
    cmy = 1 - rgb                                   # c0, m0, y0
    k = cmy.min(axis=0)
    left = np.maximum(1 - k, np.float32(1e-6))
    c, m, y = np.clip((cmy - k) / left, 0, 1)
    c, m, y = (np.where(k >= 1 - 1e-6, 0, v) for v in (c, m, y))
    return np.stack([y, c, m, k]).astype(np.float32)


def layers(rgb, width_mm: float, height_mm: float, name: str = "<image>") -> list[Picture]:
    """One picture per ink (INKS' order), its darkness that ink's coverage."""
    return [Picture(np.ascontiguousarray(a), float(width_mm), float(height_mm), name)
            for a in separate(rgb)]


def layer_options(style: str, index: int) -> dict:
    """The keyword arguments that keep layer `index` off the others' lines in `style`."""
    if style == "hatch":
        return {"angle_deg": INKS[index][2]}
    if style == "spiral":
        return {"turn_deg": 90.0 * index}
    if style == "squiggle":
        return {"phase": (index + 0.5) / len(INKS) - 0.5}
    if style == "stipple":               # own random start; dots as Lloyd leaves them (fitting
        return {"seed": index, "fit": False}   # them per layer nearly doubled the time)
    return {}


def strokes(style_fn, style: str, pictures: list[Picture], spacing_mm: float, pen_mm: float,
            **extra) -> list:
    """Every layer in `style` at this spacing, light to dark, each stroke with its pen, colour
    and layer set."""
    from dataclasses import replace

    out = []
    for i, ((pen, colour, _), pic) in enumerate(zip(INKS, pictures)):
        if not pic.darkness.max() > 0:
            continue
        made = style_fn(pic, spacing_mm, pen_mm, **extra, **layer_options(style, i))
        out += [replace(s, pen=pen, colour=colour,
                        layer=f"{pen} {s.layer}" if s.layer else pen) for s in made]
    return out


def shares(pictures: list[Picture]) -> str:
    """The mean coverage each ink is asked for (for `info`)."""
    return ", ".join(f"{pen} {float(p.darkness.mean()):.2f}"
                     for (pen, _, _), p in zip(INKS, pictures))
