"""Squiggle: horizontal rows, each a zigzag whose amplitude and frequency follow darkness
(Polargraph's scribble, Makelangelo's pulse lines).

Tone model (shared with the spiral, which uses `zigzag` here). A track `pitch` wide (the
rows' spacing) is drawn as a zigzag of period P and amplitude A (half its peak-to-peak)
across the track: the pen moves P/2 along and 2A across between two turns, so it draws
L = sqrt(1 + (4A / P)^2) mm of line per mm of track and, with a pen w wide, covers about
L x w / pitch of the track. The darkest tone is the zigzag at full amplitude (A = pitch / 2)
and the densest period P0 = 2/3 x pitch (2 pen widths for a 0.5 mm pen at 1.5 mm: the legs
touch, solid ink): L_max = sqrt(1 + (2 pitch / P0)^2) = sqrt(10). The line drawn is linear
in darkness, L = darkness x L_max (darkness blurred over about half a track, so each track
carries the tone of its own strip), so the coverage is darkness x L_max x w / pitch (about
1.05 x darkness at 0.5 mm / 1.5 mm; a coarser spacing draws a lighter picture with less
line, a finer one more line: halving the spacing doubles the length, as for every style).
Coarser than COARSEST_PENS pen widths (3.5 mm), the rows stay that far apart and the line the
spacing asks for goes to the darker tones only (`concentrate`: the darkness is remapped
(d - t) / (1 - t) with t chosen so the line drawn is the same): lines 10 mm apart are seen as
lines, not as a tone.
A straight track (L = 1) is the least the pen can draw; where L is below 1/2 it lifts (the
nearer tone), so a white picture draws nothing. To keep the lifts few, gaps shorter than 4
pen widths are drawn straight through and pen-down runs shorter than 2 pen widths dropped.
The squiggle's period follows darkness too, from 2 P0 in the light to P0 in the dark (finer
teeth where the zigzag is steep); the spiral keeps P0.

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


MIN_CHORD_MM = 0.1         # no shorter piece between two points (keeps the count sane)
COARSEST_PENS = 7.0        # tracks never further apart than this (3.5 mm with a 0.5 mm pen)


def concentrate(d: np.ndarray, want: float, amount) -> np.ndarray:
    """Darkness remapped (d - t) / (1 - t), clipped to 0..1, with the smallest t whose
    amount(remapped) is at most `want` (d itself when it already is): the ink a coarse
    density would have spread thinly over every tone goes, at a finer one, to the darkest.

    Why (bench/photo_tone.py): a budget that asks for lines 10 to 20 mm apart draws them as
    separate lines that no viewer averages into a tone (the correlation of ink with darkness
    at a 1 mm blur was 0.1 on a photo of a cat in 1 h); the same length at a pitch of a few
    pen widths, only where the picture is darker than t, with the tone linear above it,
    gave 0.7 to 0.8. Every style caps its pitch and uses this above the cap."""
    d = np.asarray(d, dtype=np.float32)
    if not amount(d) > want:
        return d
    lo, hi = 0.0, 1.0
    for _ in range(24):
        t = (lo + hi) / 2
        if amount(np.clip((d - t) / (1 - t), 0, 1)) > want:
            lo = t
        else:
            hi = t
    hi = min(hi, float(d.max()) * (1 - 1e-6))       # the darkest pixels stay
    return np.clip((d - hi) / (1 - hi), 0, 1).astype(np.float32)


def line_per_track(d: np.ndarray) -> np.ndarray:
    """The zigzag's line per mm of track at darkness d (0 where the pen lifts): the model
    of `zigzag`, without its hysteresis."""
    ratio = np.clip(d, 0, 1) * math.sqrt(10)
    return np.where(ratio >= 0.5, np.maximum(ratio, 1.0), 0.0)


def toned(picture, spacing_mm: float, pen_mm: float) -> tuple[Picture, float]:
    """(the picture smoothed for its tracks, the pitch to draw): `spacing_mm` itself up to
    COARSEST_PENS pen widths; coarser, the capped pitch and the darkness `concentrate`d so
    that the line drawn is what `spacing_mm` would have drawn (halving the spacing still
    about doubles the line)."""
    cap = COARSEST_PENS * pen_mm
    if spacing_mm <= cap:
        return smoothed(picture, spacing_mm), spacing_mm
    want = float(line_per_track(smoothed(picture, spacing_mm).darkness[::2, ::2]).mean())
    want /= spacing_mm
    pic = smoothed(picture, cap)
    d = concentrate(pic.darkness, want * cap, lambda x: float(line_per_track(x[::2, ::2]).mean()))
    return Picture(d, picture.width_mm, picture.height_mm, picture.name), cap


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


def densest_period(pitch_mm: float) -> float:
    """P0: the zigzag's period at full darkness (2/3 of the pitch, at least 0.2 mm)."""
    return max(2 * pitch_mm / 3, 0.2)


def zigzag(centre, normal, s, dark, period, pitch, pen, width_mm, height_mm):
    """Turning points of a zigzag along a track: centre (M, 2) the track's points at the
    turns, normal (M, 2) unit vectors across it, s (M,) arc length, dark (M,) darkness there,
    period (M,) the zigzag's period there. Returns the pen-down pieces (K, 2)."""
    l_max = math.sqrt(1 + (2 * pitch / densest_period(pitch)) ** 2)
    ratio = np.clip(np.asarray(dark, dtype=float), 0, 1) * l_max     # line per track length
    amp = np.minimum(period / 4 * np.sqrt(np.maximum(ratio * ratio - 1, 0)), pitch / 2)
    sign = np.where(np.arange(len(s)) % 2 == 0, 1.0, -1.0)
    pts = centre + normal * (sign * amp)[:, None]
    on = hysteresis(ratio >= 0.5, s, 4 * pen, 2 * pen)
    eps = 1e-9
    on &= ((pts[:, 0] >= -eps) & (pts[:, 0] <= width_mm + eps) &
           (pts[:, 1] >= -eps) & (pts[:, 1] <= height_mm + eps))
    pts[:, 0] = np.clip(pts[:, 0], 0, width_mm)
    pts[:, 1] = np.clip(pts[:, 1], 0, height_mm)
    a, b = _runs(on)
    return [q for q in (_min_chord(pts[i:j]) for i, j in zip(a.tolist(), b.tolist()))
            if len(q) >= 2]


def _min_chord(p: np.ndarray, least: float = MIN_CHORD_MM) -> np.ndarray:
    """Drop points closer than `least` to the one before (a few vectorised passes; a tight
    spiral's first turn, a fine spacing)."""
    for _ in range(4):
        if len(p) < 2:
            return p
        short = np.hypot(*np.diff(p, axis=0).T) < least
        if not short.any():
            return p
        keep = np.r_[True, ~short]
        keep[-1] = True                                   # the end stays where it is
        if short[-1] and len(p) > 2:
            keep[-2] = False
        p = p[keep]
    return p


def _row_turns(pic: Picture, y: float, p0: float, w: float, backwards: bool):
    """x of the turns along a row at height y, and the period there (it follows darkness:
    2 p0 in white, p0 in black), from x = 0 (or from x = w when backwards)."""
    ds = p0 / 8
    along = np.arange(0.0, w + ds / 2, ds)
    along[-1] = w
    x = w - along if backwards else along
    d = pic.at(np.column_stack([x, np.full_like(x, y)]))
    per = p0 * (2 - np.clip(d, 0, 1))
    phase = np.concatenate([[0.0], np.cumsum(np.diff(along) * 2 / per[:-1])])   # half periods
    turns = np.searchsorted(phase, np.arange(1, math.floor(phase[-1]) + 1))
    idx = np.unique(np.concatenate([[0], turns, [len(x) - 1]]))
    if len(idx) > 2 and along[idx[-1]] - along[idx[-2]] < p0 / 2:       # no stub at the end
        idx = np.delete(idx, -2)
    return x[idx], along[idx], per[idx]


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5) -> list[Stroke]:
    """Rows of zigzags `spacing_mm` apart (the tone model above)."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    w, h = picture.width_mm, picture.height_mm
    pic, spacing_mm = toned(picture, spacing_mm, pen_mm)
    pitch = min(spacing_mm, h)
    rows = max(1, math.floor(h / pitch))
    margin = (h - rows * pitch) / 2
    p0 = densest_period(pitch)
    pieces: list[np.ndarray] = []
    for r in range(rows):                     # one loop turn per row; numpy along it
        y = h - margin - (r + 0.5) * pitch
        x, s, per = _row_turns(pic, y, p0, w, backwards=bool(r % 2))
        centre = np.column_stack([x, np.full_like(x, y)])
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
            if at_edge and abs(q[-1, 0] - sx) <= tol and -1e-9 <= q[-1, 1] - p[0, 1] <= 2 * pitch:
                if np.hypot(*(q[-1] - p[0])) < 0.1:                # the same point
                    p = p[1:]
                out[-1] = np.concatenate([q, p])
                continue
        out.append(p)
    return out
