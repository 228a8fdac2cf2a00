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
The line drawn follows the budget's tone curve (`tone.py`): L = f(d) x L_max x p / spacing with
f(d) = d^gamma (gamma from the tracks' own ends, `tone_gamma`: 1 up to 6.5 pen widths, 8 from
20), the tracks p = min(spacing, CAP_PENS pen widths) apart (`track_pitch`: lines
10 mm apart are seen as lines, not as a tone), so a coarser spacing than the cap draws less
line, on the darker tones, and halving the spacing still about doubles the line.
A straight track (L = 1) is the most line a track can carry without zigzagging; a smaller L
is drawn with fewer tracks, straight: track k (row k, or turn k of the spiral) takes its part
by its nesting level (`tone.dashed`: every 16th track for L from 0 to 1/16, in dashes 16
pitches long whose drawn part grows with L, ..., every track from L = 1/2 to 1), so the
lightest tones get short dashes on every 16th track and a darker tone more; where no track is
drawn the pen lifts. To keep the lifts few, gaps shorter than 4
pen widths are drawn straight through and pen-down runs shorter than 2 pen widths dropped.
The squiggle's period follows darkness too, from 2 P0 in the light to P0 in the dark (finer
teeth where the zigzag is steep); the spiral keeps P0.

Rows are the track pitch apart, centred on the picture; consecutive rows run in opposite
directions and a row that ends at the picture's edge inked is joined to the next one that
starts there (one stroke across several rows: fewer lifts).
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.inputs.hatch import runs
from vplotter.inputs.image import tone
from vplotter.inputs.image.load import blur
from vplotter.inputs.image.picture import Picture
from vplotter.inputs.strokes import Stroke


MIN_CHORD_MM = 0.1         # no shorter piece between two points (keeps the count sane)
CAP_PENS = 7.0             # tracks never further apart than this (3.5 mm with a 0.5 mm pen)
FREE_PENS = 6.5            # the tone curve: d (gamma 1) up to this spacing (pen widths),
SCARCE_PENS = 20.0         # ... d^8 from this one


def tone_gamma(spacing_mm: float, pen_mm: float) -> float:
    """The tracks' tone curve exponent for this spacing (`tone.gamma` with the tracks' own
    ends: at 3 h on bench/photo_tone.py, about 9 pen widths, d^3.5 drew the astronaut's
    squiggle with a correlation of 0.84 where the shared curve's d^7 drew 0.80 at the same
    length, the camera's 0.89 for 0.85; at 1 h, about 20 pen widths, d^8 stays best)."""
    return tone.gamma(spacing_mm, pen_mm, FREE_PENS, SCARCE_PENS)


def track_pitch(spacing_mm: float, pen_mm: float) -> float:
    """The distance between tracks: the spacing, at most CAP_PENS pen widths."""
    return min(spacing_mm, CAP_PENS * pen_mm)


def toned(picture, spacing_mm: float, pen_mm: float,
          curve=None) -> tuple[Picture, float]:
    """(the picture to draw, smoothed for its tracks, its darkness replaced by the share of
    the line of black: f(d) x pitch / spacing; the track pitch). curve: the tone curve, an
    exponent or a tone.Table (default d^`tone_gamma`)."""
    p = track_pitch(spacing_mm, pen_mm)
    pic = smoothed(picture, p)
    g = tone_gamma(spacing_mm, pen_mm) if curve is None else curve
    d = tone.curve(pic.darkness, g) * np.float32(p / spacing_mm)
    return Picture(d, picture.width_mm, picture.height_mm, picture.name), p


def smoothed(picture, pitch_mm: float) -> Picture:
    """The picture blurred over about half a track (its tone per track)."""
    d = blur(picture.darkness, 0.35 * pitch_mm / picture.mm_per_px)
    return Picture(d, picture.width_mm, picture.height_mm, picture.name)


def _runs(flags: np.ndarray):
    """Start and end (exclusive) indices of the runs of True in a 1-D bool array."""
    return runs(np.asarray(flags)[None, :])[1:]


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


def zigzag(centre, normal, s, dark, period, pitch, pen, width_mm, height_mm, track=0):
    """Turning points of a zigzag along a track: centre (M, 2) the track's points at the
    turns, normal (M, 2) unit vectors across it, s (M,) arc length, dark (M,) darkness there
    (the share of the line of black), period (M,) the zigzag's period there, track (M,) or
    one: the track's index (its nesting level: where it is drawn at all). Returns the pen-down
    pieces (K, 2)."""
    l_max = math.sqrt(1 + (2 * pitch / densest_period(pitch)) ** 2)
    ratio = np.clip(np.asarray(dark, dtype=float), 0, 1) * l_max     # line per track length
    amp = np.minimum(period / 4 * np.sqrt(np.maximum(ratio * ratio - 1, 0)), pitch / 2)
    sign = np.where(np.arange(len(s)) % 2 == 0, 1.0, -1.0)
    pts = centre + normal * (sign * amp)[:, None]
    track = np.broadcast_to(track, ratio.shape)
    drawn = tone.dashed(ratio, tone.level(track), s, track, tone.DASH_LINES * pitch)
    on = hysteresis(drawn, s, 4 * pen, 2 * pen)
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


def strokes(picture, spacing_mm: float, pen_mm: float = 0.5, phase: float = 0.0,
            curve=None) -> list[Stroke]:
    """Rows of zigzags `spacing_mm` apart (the tone model above); `phase` (-1/2..1/2) moves
    every row down by that share of the pitch (--cmyk's layers a quarter pitch apart); curve:
    the tone curve (`toned`)."""
    if not spacing_mm > 0 or not pen_mm > 0:
        raise ValueError("spacing_mm and pen_mm must be > 0")
    w, h = picture.width_mm, picture.height_mm
    pic, spacing_mm = toned(picture, spacing_mm, pen_mm, curve)
    pitch = min(spacing_mm, h)
    rows = max(1, math.floor(h / pitch))
    margin = (h - rows * pitch) / 2
    p0 = densest_period(pitch)
    pieces: list[np.ndarray] = []
    for r in range(rows):                     # one loop turn per row; numpy along it
        y = h - margin - (r + 0.5 + min(max(phase, -0.5), 0.5)) * pitch
        x, s, per = _row_turns(pic, y, p0, w, backwards=bool(r % 2))
        centre = np.column_stack([x, np.full_like(x, y)])
        normal = np.tile([0.0, 1.0], (len(x), 1))
        dark = pic.at(centre)
        pieces.extend(zigzag(centre, normal, s, dark, per, pitch, pen_mm, w, h, track=r))
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
