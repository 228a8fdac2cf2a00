"""Squiggle: horizontal rows, each a zigzag whose amplitude and frequency follow darkness
(Polargraph's scribble, Makelangelo's pulse lines).

Tone model (shared with the spiral, which uses `zigzag` here). A track `pitch` wide (the
rows' spacing) is drawn as a zigzag of period P and amplitude A (half its peak-to-peak)
across the track: the pen moves P/2 along and 2A across between two turns, so it draws
L = sqrt(1 + (4A / P)^2) mm of line per mm of track, and with a pen w wide covers
L x w / pitch of the track (the legs of a steep zigzag P = 2w touch: solid ink). For the
wanted coverage t = darkness (blurred over about half a track, so each track carries the
tone of its own strip): L = t x pitch / w and A = P/4 x sqrt(L^2 - 1), at most pitch / 2.
A straight track (A = 0) already covers w / pitch; where t is below half of that the pen
lifts (nothing is the nearer tone), so a white picture draws nothing. To keep the lifts
few, gaps shorter than 4 pen widths are drawn straight through and pen-down runs shorter
than 2 pen widths are dropped. The squiggle's period follows darkness too, from 4 pen widths
in the light to 2 in the dark (finer teeth where the zigzag is steep); the spiral keeps 2.

Rows are `spacing_mm` apart, centred on the picture; consecutive rows run in opposite
directions and a row that ends at the picture's edge inked is joined to the next one that
starts there (one stroke across several rows: fewer lifts).
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.inputs.image.load import blur
from vplotter.inputs.image.picture import Picture
from vplotter.inputs.strokes import Stroke


def smoothed(picture, pitch_mm: float) -> Picture:
    """The picture blurred over about half a track (its tone per track)."""
    d = blur(picture.darkness, 0.35 * pitch_mm / picture.mm_per_px)
    return Picture(d, picture.width_mm, picture.height_mm, picture.name)


def _runs(flags: np.ndarray):
    f = np.zeros(len(flags) + 2, dtype=np.int8)
    f[1:-1] = flags
    dd = np.diff(f)
    return np.nonzero(dd == 1)[0], np.nonzero(dd == -1)[0]       # start, end (exclusive)


def hysteresis(on: np.ndarray, s: np.ndarray, gap_mm: float, min_mm: float) -> np.ndarray:
    """Close gaps shorter than gap_mm between pen-down runs, then drop runs shorter than
    min_mm (`s`: arc length at each point)."""
    on = on.copy()
    a, b = _runs(~on)
    inner = (a > 0) & (b < len(on))
    a, b = a[inner], b[inner]
    close = s[np.minimum(b, len(s) - 1)] - s[np.maximum(a - 1, 0)] < gap_mm
    fill = np.zeros(len(on) + 1, dtype=np.int32)
    np.add.at(fill, a[close], 1)
    np.add.at(fill, b[close], -1)
    on |= np.cumsum(fill[:-1]) > 0
    a, b = _runs(on)
    short = s[b - 1] - s[a] < min_mm
    cut = np.zeros(len(on) + 1, dtype=np.int32)
    np.add.at(cut, a[short], 1)
    np.add.at(cut, b[short], -1)
    on &= ~(np.cumsum(cut[:-1]) > 0)
    return on


def zigzag(centre, normal, s, dark, period, pitch, pen, width_mm, height_mm):
    """Turning points of a zigzag along a track: centre (M, 2) the track's points at the
    turns, normal (M, 2) unit vectors across it, s (M,) arc length, dark (M,) the wanted
    coverage there, period (M,) the zigzag's period. Returns the pen-down pieces (K, 2)."""
    ratio = np.asarray(dark, dtype=float) * pitch / pen
    amp = period / 4 * np.sqrt(np.maximum(ratio * ratio - 1, 0))
    amp = np.minimum(amp, pitch / 2)
    sign = np.where(np.arange(len(s)) % 2 == 0, 1.0, -1.0)
    pts = centre + normal * (sign * amp)[:, None]
    on = hysteresis(ratio >= 0.5, s, 4 * pen, 2 * pen)
    eps = 1e-9
    on &= ((pts[:, 0] >= -eps) & (pts[:, 0] <= width_mm + eps) &
           (pts[:, 1] >= -eps) & (pts[:, 1] <= height_mm + eps))
    pts[:, 0] = np.clip(pts[:, 0], 0, width_mm)
    pts[:, 1] = np.clip(pts[:, 1], 0, height_mm)
    a, b = _runs(on)
    return [pts[i:j] for i, j in zip(a.tolist(), b.tolist()) if j - i >= 2]


def _row_turns(pic: Picture, y: float, pen: float, w: float):
    """Arc length of the turns along a row at height y (the period follows darkness)."""
    ds = pen / 4
    x = np.arange(0.0, w + ds / 2, ds)
    d = pic.at(np.column_stack([x, np.full_like(x, y)]))
    per = pen * (4 - 2 * np.clip(d, 0, 1))
    phase = np.concatenate([[0.0], np.cumsum(2 * ds / per[:-1])])      # half periods
    turns = np.searchsorted(phase, np.arange(1, math.floor(phase[-1]) + 1))
    idx = np.unique(np.concatenate([[0], turns, [len(x) - 1]]))
    return x[idx], per[idx]


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5) -> list[Stroke]:
    """Rows of zigzags `spacing_mm` apart (the tone model above)."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    w, h = picture.width_mm, picture.height_mm
    pic = smoothed(picture, spacing_mm)
    pitch = min(spacing_mm, h)
    rows = max(1, math.floor(h / pitch))
    margin = (h - rows * pitch) / 2
    pieces: list[np.ndarray] = []
    for r in range(rows):                     # one loop turn per row; numpy along it
        y = h - margin - (r + 0.5) * pitch
        x, per = _row_turns(pic, y, pen_mm, w)
        if r % 2:
            x, per = (w - x)[::-1], per[::-1]
        centre = np.column_stack([x, np.full_like(x, y)])
        s = np.abs(x - x[0])
        normal = np.tile([0.0, 1.0], (len(x), 1))
        dark = pic.at(centre)
        pieces.extend(zigzag(centre, normal, s, dark, per, pitch, pen_mm, w, h))
    return [Stroke(p) for p in _join_rows(pieces, w, pitch)]


def _join_rows(pieces, w, pitch):
    """Join a piece that ends at the left or right edge to the next that starts there on the
    next row (the move runs along the picture's edge)."""
    out: list[np.ndarray] = []
    tol = pitch * 0.5 + 1e-6
    for p in pieces:
        if out:
            q = out[-1]
            ex, sx = q[-1, 0], p[0, 0]
            at_edge = (ex <= tol and sx <= tol) or (ex >= w - tol and sx >= w - tol)
            if at_edge and abs(q[-1, 0] - sx) <= tol and 0 < q[-1, 1] - p[0, 1] <= 2 * pitch:
                out[-1] = np.concatenate([q, p])
                continue
        out.append(p)
    return out
