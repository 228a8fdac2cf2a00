"""Photographs -> line art: a picture's darkness drawn as strokes, in one of several styles.

`load.py` reads any image Pillow reads into a `Picture` (EXIF orientation applied,
transparency on white, tone in linear light, reduced to the resolution the pen can show).
Each style is a module here with one function `strokes(picture, spacing_mm, pen_mm, **opts)
-> list[Stroke]`; `spacing_mm` is the style's one density knob (the distance between tracks,
rows or hatch lines; for stipples the mean distance between dots): halving it roughly doubles
the line drawn, which is what the plot-time budget turns. Strokes are in G-code mm with the
picture's bottom-left corner at (0, 0) and its top-right at (width_mm, height_mm); every
pen-down point lies inside that rectangle.
"""

from __future__ import annotations

import importlib

SUFFIXES = (".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff", ".gif")
STYLES = ("spiral", "hatch", "stipple", "squiggle")     # module names in this package


def style(name: str):
    """The `strokes` function of a style (imported on first use)."""
    if name not in STYLES:
        raise ValueError(f"unknown style {name!r} (choose {', '.join(STYLES)})")
    return importlib.import_module(f"vplotter.inputs.image.{name}").strokes
