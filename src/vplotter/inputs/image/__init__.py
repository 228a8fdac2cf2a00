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
STYLES = ("spiral", "hatch", "stipple", "squiggle", "flow")     # module names in this package
AUTO = "auto"          # --style auto: every style tried, the best kept (drawing/photo_auto.py)
CHOICES = STYLES + (AUTO,)


def style(name: str):
    """The `strokes` function of a style (imported on first use)."""
    if name not in STYLES:
        raise ValueError(f"unknown style {name!r} (choose {', '.join(STYLES)})")
    return importlib.import_module(f"vplotter.inputs.image.{name}").strokes


def describe(name: str, spacing_mm: float, pen_mm: float, picture=None, **extra) -> str:
    """What a style draws at this spacing (for `info`); extra "curve": the tone curve chosen."""
    from vplotter.inputs.image import tone

    chosen = extra.get("curve")
    if name == "hatch":
        from vplotter.inputs.image.hatch import full_layers, tone_gamma
        g = tone_gamma(spacing_mm, pen_mm) if chosen is None else chosen
        return (f"finest pitch {spacing_mm:.2f} mm (the spacing; every {tone.TOP}th line, dashed, "
                f"in the lightest tones, up to {full_layers(spacing_mm, pen_mm):.1f} crossed "
                f"layers in black), tone curve {tone.name(g)}")
    if name == "flow":
        from vplotter.inputs.image.flow import generation, tone_gamma
        from vplotter.inputs.image.flow_lines import TOP_POW
        g = tone_gamma(spacing_mm, pen_mm) if chosen is None else chosen
        d = pen_mm * 2.0 ** (TOP_POW - generation(spacing_mm, pen_mm))
        return (f"streamlines along the picture's edges, {d:g} mm apart in black (finest "
                f"pitch {spacing_mm:.2f} mm; every {tone.TOP}th line, dashed, in the lightest "
                f"tones), tone curve {tone.name(g)}")
    if name in ("spiral", "squiggle"):
        from vplotter.inputs.image.squiggle import tone_gamma, track_pitch
        g = tone_gamma(spacing_mm, pen_mm) if chosen is None else chosen
        return (f"track pitch {track_pitch(spacing_mm, pen_mm):.2f} mm (every {tone.TOP}th track, "
                f"dashed, in the lightest tones), tone curve {tone.name(g)}")
    if name == "stipple":
        from vplotter.inputs.image import stipple
        g = (chosen if chosen is not None else
             stipple.tone_gamma(picture, spacing_mm, pen_mm, bool(extra.get("tsp")))
             if picture else 1.0)
        tour = "a tour through " if extra.get("tsp") else ""
        return (f"{tour}as many dots as a spacing of {spacing_mm:.2f} mm spreads evenly, tone "
                f"curve {tone.name(g)}")
    g = tone.gamma(spacing_mm, pen_mm) if chosen is None else chosen
    return f"tone curve {tone.name(g)}"
