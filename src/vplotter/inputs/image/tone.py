"""The tone curve every photo style shares, chosen from the budget, and its nested density levels.

A plot-time budget buys a length of line (about 14 m an hour on the seed machine). Spread
evenly over every tone at a pitch of 10 to 30 mm it is seen as separate lines, not as a tone
(the correlation of the ink with the darkness, at a 1 mm blur, was 0.1 on a photo of a cat in
an hour: bench/photo_tone.py). So the styles

- draw the target ink fraction f(d) = (1 - EPS) d^gamma + EPS d of the darkness d (0..1, linear
  light; `curve`), with gamma = 1 (f(d) = d) when the budget is generous (a spacing of at most
  FREE_PENS pen widths) and rising with the logarithm of the spacing up to GAMMA_MAX (at
  SCARCE_PENS pen widths and coarser): a scarce budget puts its line on the darker tones (most
  of a photograph is darker than 0.5 in linear light, so it takes a steep curve to make its
  darks stand out: d^8 against d^3 raised the correlation of the hatch on a cat in an hour
  from 0.39 to 0.55). The small linear floor EPS d keeps every tone above white inked: f is
  strictly rising, f(0) = 0, f(1) = 1, so a darker tone never gets less ink and none gets
  none;
- show a small f with sparse lines rather than with no line: the lines (tracks, rows) of a
  style lie on one grid at its finest pitch p, and line k takes part of the tone according to
  its nesting level (`level`): every 16th line (level 0) is drawn for a share of a full layer
  of lines from 0 to 1/16, the ones half-way between (level 1) from 1/16 to 1/8, every 4th
  from 1/8 to 1/4, every 2nd from 1/4 to 1/2 and the rest from 1/2 to 1, each level in dashes
  across its range (`dashed`: period DASH_LINES x p along the line, the part of each drawn
  rising linearly from nothing to the whole line; successive lines' dashes shifted by the
  golden ratio of a period so they do not line up) and whole above it. The lines drawn then
  cover the share asked for (binary-nested like the levels of `hatched`, but with no step:
  the sparser lines stay where they were when the denser ones join them), however small: any
  tone above white gets some line, and a darker tone more.

The exponent gamma here is where the choice starts: with a budget, `drawing/photo.py` also
tries gamma / 1.6 and gamma x 1.6 for the picture at hand, then curves fitted to the drawing's
own measured response (`calibrate.py`, a `Table` of values), and keeps the curve whose drawing
scores best (`score.py`). A style takes either kind as its `curve`: an exponent or a Table.

Chosen on bench/photo_tone.py (five photographs, a grey ramp, 1 h and 3 h, 300 mm wide): a
steeper curve wins at 1 h, a gentler one at 3 h (where the spacing is finer); a floor of 1/16
or 1/64 moved no figure by more than 0.01.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FREE_PENS = 3.0        # a spacing up to this many pen widths: gamma = 1 (a generous budget)
SCARCE_PENS = 8.0      # ... from this many on: gamma = GAMMA_MAX
GAMMA_MAX = 8.0

EPS = 1 / 32           # the curve's linear floor
LEVELS = 5             # nesting levels: the sparsest is every 2^(LEVELS - 1)th line (16th)
TOP = 2 ** (LEVELS - 1)
# (period, offset)
NEST = ((TOP, 0),) + tuple((TOP >> i, TOP >> (i + 1)) for i in range(LEVELS - 1))
# level i takes the share of a layer from LOW[i] to HIGH[i] (its lines drawn in dashes between)
LOW = (0.0,) + tuple(2 ** (i - 1) / TOP for i in range(1, LEVELS))
HIGH = tuple(2 ** i / TOP for i in range(LEVELS))
DASH_LINES = TOP       # the dashes' period along a line: this many times the finest pitch
PHI = 0.6180339887     # successive lines' dashes shifted by this much of a period


def gamma(spacing_mm: float, pen_mm: float, free_pens: float = FREE_PENS,
          scarce_pens: float = SCARCE_PENS) -> float:
    """The tone curve's exponent for this spacing (the budget's knob): 1 up to free_pens pen
    widths, GAMMA_MAX from scarce_pens, log-linear between (each style may set its own)."""
    e = spacing_mm / (free_pens * pen_mm)
    if e <= 1:
        return 1.0
    return float(min(GAMMA_MAX,
                     1 + (GAMMA_MAX - 1) * math.log(e) / math.log(scarce_pens / free_pens)))


@dataclass(frozen=True)
class Table:
    """A tone curve by its values at evenly spaced darkness 0, 1/(n-1), ..., 1 (linear between):
    f(0) = 0, rising. `label`: how it was made (for `info`)."""

    values: tuple[float, ...]
    label: str = "table"

    def __call__(self, d) -> np.ndarray:
        xs = np.linspace(0.0, 1.0, len(self.values))
        return np.interp(d, xs, self.values).astype(np.float32)


def name(g) -> str:
    """The curve as `info` names it: d^3.5, or a Table's label."""
    return g.label if isinstance(g, Table) else f"d^{g:.1f}"


def curve(d, g, eps: float | None = None) -> np.ndarray:
    """f(d) = (1 - eps) d^g + eps d (eps: EPS), darkness clipped to 0..1; g a Table: its values."""
    d = np.clip(np.asarray(d, dtype=np.float32), 0, 1)
    if isinstance(g, Table):
        return g(d)
    if g <= 1:
        return d
    eps = EPS if eps is None else eps
    return np.float32(1 - eps) * d ** np.float32(g) + np.float32(eps) * d


def level(k) -> np.ndarray:
    """Nesting level 0..LEVELS-1 of line index k (with 5 levels, 0: k = 0 mod 16, 1: 8 mod 16,
    2: 4 mod 8, 3: 2 mod 4, 4: odd)."""
    k = np.asarray(k, dtype=np.int64) % TOP
    out = np.full(k.shape, LEVELS - 1, dtype=np.int64)
    for i in range(1, LEVELS - 1):
        out[k % (2 ** i) == 0] = LEVELS - 1 - i
    out[k == 0] = 0
    return out


def duty(share, lvl) -> np.ndarray:
    """The part of its length a line of nesting level `lvl` is drawn at this share of a layer
    (0 below the level's range, 1 above it, linear across it)."""
    lo, hi = np.asarray(LOW)[lvl], np.asarray(HIGH)[lvl]
    return np.clip((np.asarray(share, dtype=np.float32) - lo) / (hi - lo), 0, 1)


def dashed(share, lvl, along_mm, line, period_mm: float) -> np.ndarray:
    """Is the pen down at `along_mm` along line number `line` (of nesting level `lvl`) where the
    share of a layer is `share`: dashes of period_mm, the duty's part of each drawn."""
    u = duty(share, lvl)
    phase = np.mod(np.asarray(along_mm) / period_mm + np.asarray(line) * PHI, 1.0)
    return (u >= 1) | ((u > 0) & (phase < u))
