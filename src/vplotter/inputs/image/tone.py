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
  style lie on one grid at its finest pitch and line k is drawn only where f, in units of one
  full layer of lines, passes the threshold of its nesting level (`level`): every 64th line
  from 1/128 of a layer, the ones half-way between from 3/128, then every 16th from 3/64, ...,
  every 2nd from 3/8 and all of them from 3/4, so that the share of the lines drawn (1/64,
  1/32, ..., 1/2, 1) follows f in LEVELS binary-nested steps (the sparser lines stay where they
  were when the denser ones join them).

Chosen on bench/photo_tone.py (five photographs, a grey ramp, 1 h and 3 h, 300 mm wide): a
steeper curve wins at 1 h, a gentler one at 3 h, and the floor and the sparsest level keep the
ramp's lightest band (darkness 0 to 0.4) inked.
"""

from __future__ import annotations

import math

import numpy as np

FREE_PENS = 3.0        # a spacing up to this many pen widths: gamma = 1 (a generous budget)
SCARCE_PENS = 8.0      # ... from this many on: gamma = GAMMA_MAX
GAMMA_MAX = 8.0

EPS = 1 / 32           # the curve's linear floor
LEVELS = 7             # nesting levels: the sparsest is every 2^(LEVELS - 1)th line
TOP = 2 ** (LEVELS - 1)
NEST = ((TOP, 0),) + tuple((TOP >> i, TOP >> (i + 1)) for i in range(LEVELS - 1))   # (period, offset)
THRESH = (1 / (2 * TOP),) + tuple(3 / 2 ** (LEVELS + 1 - i) for i in range(1, LEVELS))


def gamma(spacing_mm: float, pen_mm: float) -> float:
    """The tone curve's exponent for this spacing (the budget's knob): 1 up to FREE_PENS pen
    widths, GAMMA_MAX from SCARCE_PENS, log-linear between."""
    e = spacing_mm / (FREE_PENS * pen_mm)
    if e <= 1:
        return 1.0
    return float(min(GAMMA_MAX, 1 + (GAMMA_MAX - 1) * math.log(e) / math.log(SCARCE_PENS / FREE_PENS)))


def curve(d, g: float, eps: float | None = None) -> np.ndarray:
    """f(d) = (1 - eps) d^g + eps d (eps: EPS), darkness clipped to 0..1."""
    d = np.clip(np.asarray(d, dtype=np.float32), 0, 1)
    if g <= 1:
        return d
    eps = EPS if eps is None else eps
    return np.float32(1 - eps) * d ** np.float32(g) + np.float32(eps) * d


def level(k) -> np.ndarray:
    """Nesting level 0..4 of line index k (0: k = 0 mod 16, 1: 8 mod 16, 2: 4 mod 8, 3: 2 mod 4,
    4: odd)."""
    k = np.asarray(k, dtype=np.int64) % TOP
    out = np.full(k.shape, LEVELS - 1, dtype=np.int64)
    for i in range(1, LEVELS - 1):
        out[k % (2 ** i) == 0] = LEVELS - 1 - i
    out[k == 0] = 0
    return out


def threshold(k) -> np.ndarray:
    """The share of a full layer above which line k is drawn."""
    return np.asarray(THRESH)[level(k)]


def text(name: str, spacing_mm: float, pen_mm: float, picture=None, **extra) -> str:
    """What a style draws at this spacing (for `info`)."""
    g = gamma(spacing_mm, pen_mm)
    if name == "hatch":
        from vplotter.inputs.image.hatch import full_layers
        return (f"finest pitch {spacing_mm:.2f} mm (the spacing; every {TOP}th line in the "
                f"lightest tones, up to {full_layers(spacing_mm, pen_mm):.1f} crossed layers "
                f"in black), tone curve d^{g:.1f}")
    if name in ("spiral", "squiggle"):
        from vplotter.inputs.image.squiggle import track_pitch
        return (f"track pitch {track_pitch(spacing_mm, pen_mm):.2f} mm (every {TOP}th track "
                f"in the lightest tones), tone curve d^{g:.1f}")
    if name == "stipple":
        from vplotter.inputs.image import stipple
        g = stipple.tone_gamma(picture, spacing_mm, pen_mm, bool(extra.get("tsp"))) if picture else 1.0
        return (f"as many dots as a spacing of {spacing_mm:.2f} mm spreads evenly, tone curve "
                f"d^{g:.1f}")
    return f"tone curve d^{g:.1f}"
