"""Spiral: one Archimedean spiral from the centre out to the corners, the pen zigzagging
across its track with an amplitude that follows darkness (Makelangelo's pulsing spiral, the
"Sandy Noble" style).

The track pitch is `spacing_mm` (at most 7 pen widths: `squiggle.track_pitch`); the spiral r = pitch
x theta / 2 pi starts at the picture's centre and runs until it has passed the farthest corner, so
it covers the whole rectangle. The zigzag's period is 2/3 of the pitch (2 pen widths for a 0.5 mm
pen at 1.5 mm), and its amplitude, up to half the pitch, makes the line drawn per mm of track linear
in darkness: the tone model of `squiggle.py` (`zigzag`, `toned`: the budget's tone curve d^gamma,
the pitch at most 7 pen widths), darkness blurred over half a track. Where the line asked for is
less than a straight track's, only some turns are drawn, straight, some in dashes (turn k by its
nesting level: `tone.dashed`), and where the picture is white the pen lifts (short gaps are drawn
straight through). Beyond the circle inscribed in the rectangle the spiral leaves it: the pen lifts
at the edge and comes back down where the spiral re-enters (about four lifts a turn out there).
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.inputs.image.squiggle import densest_period, toned, zigzag
from vplotter.inputs.strokes import Stroke


def _theta(s: np.ndarray, b: float) -> np.ndarray:
    """The angle at arc length s along r = b theta (Newton on the closed-form length)."""
    t = np.sqrt(2 * s / b)
    for _ in range(6):
        length = b / 2 * (t * np.sqrt(1 + t * t) + np.arcsinh(t))
        t = np.maximum(t - (length - s) / (b * np.sqrt(1 + t * t)), 0)
    return t


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5,
            period_mm: float | None = None, turn_deg: float = 0.0,
            curve=None) -> list[Stroke]:
    """The pulsing spiral (above); `period_mm` is the zigzag's period (2/3 of the spacing);
    `turn_deg` turns the whole spiral about the centre (its track moves out by that share of
    a turn's pitch: --cmyk's layers a quarter turn apart); curve: the tone curve
    (`squiggle.toned`)."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    w, h = picture.width_mm, picture.height_mm
    pic, spacing_mm = toned(picture, spacing_mm, pen_mm, curve)     # pitch capped (squiggle.py)
    period = densest_period(spacing_mm) if period_mm is None else period_mm
    b = spacing_mm / (2 * math.pi)
    r_max = math.hypot(w, h) / 2 + spacing_mm
    t_max = r_max / b
    s_max = b / 2 * (t_max * math.sqrt(1 + t_max * t_max) + math.asinh(t_max))
    s = np.arange(0.0, s_max, period / 2)
    t = _theta(s, b)
    turn = np.radians(turn_deg)
    radial = np.column_stack([np.cos(t + turn), np.sin(t + turn)])
    centre = np.array([w / 2, h / 2]) + (b * t)[:, None] * radial
    dark = pic.at(centre)
    per = np.full(len(s), period)
    track = np.floor(t / (2 * math.pi)).astype(np.int64)
    return [Stroke(p) for p in zigzag(centre, radial, s, dark, per, spacing_mm, pen_mm, w, h,
                                      track=track)]
