"""Tone curves fitted to a drawing's own response: ink that rises in a straight line with the
darkness, as a person sees it.

A style does not lay exactly the ink its curve asks for: layers overlap where they cross, the
sparse nested lines and their dashes, the smoothing before the levels are cut, line ends and
joins, and the 1 mm blur at which a drawing is seen all bend the ink that comes out away from
the ink asked for, differently in every style and at every spacing. So the converter measures
it on a drawing it has made (`response`): the picture's cells (`score.py`: 1 mm, blurred at
1 mm) are cut by their blurred darkness into BINS bins of equal area, and each bin's curve
value (the curve at the bin's mean darkness) is paired with the bin's mean blurred ink, the
pairs made rising (running maximum). `table` inverts that for the ink wanted:

    t(D) = beta max(D - d0, 0)

ink rising in a straight line with the darkness D above a threshold d0, the darkness below
which a share q of the picture lies (there: only the FLOOR, a trace of ink, so that a darker
tone never gets less), beta such that the mean ink stays the measured drawing's (about the
same length of line, so the budget fit that follows starts close). Why this shape: the
measure is a correlation of ink with darkness, which a straight line maximises; the lines'
texture is its noise, worst where they are sparse, so a scarce budget does better to leave the
light tones out (a higher q) than to spread its line thin. The best q depends on the picture
and the budget: `drawing/photo.py` scores a few at the measured drawing's spacing (`search`:
QUANTILES, on in steps of WALK while the best is at an end, then REFINE either side), fits
the best to the budget and keeps it if it scores above the exponent curves it started from.

On bench/photo_tone.py (300 mm, seed machine, at the same length of line, by the converter's
own score) the astronaut's squiggle at 3 h went from 0.864 (d^3.5, the best exponent) to 0.906,
its hatch from 0.833 to 0.865, the camera's squiggle from 0.891 to 0.948, the cat's hatch at
1 h from 0.626 to 0.754; where an exponent still does better (the rocket at 3 h: 0.766 against
0.662) the exponent is kept.
"""

from __future__ import annotations

import numpy as np

from vplotter.inputs.image import tone

BINS = 24                       # darkness bins of equal area for the response
STEPS = 33                      # values of a fitted curve (tone.Table), darkness 0..1
FLOOR = tone.EPS                 # every tone above white keeps this share of the top value
QUANTILES = (0.15, 0.3, 0.45)   # thresholds tried first: the share of the picture left light
WALK, MOST_Q = 0.15, 0.9        # ... then on in steps of WALK while an end is best (0..MOST_Q)
REFINE = 0.075                  # ... then this either side of the best


def response(curve, ink: np.ndarray, dark: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(curve values, blurred ink), rising, per darkness bin of a drawing made with `curve`;
    ink and dark on the same cells (`score.ink`, `score.darkness`)."""
    d, a = np.ravel(dark).astype(np.float64), np.ravel(ink).astype(np.float64)
    edges = np.quantile(d, np.linspace(0, 1, BINS + 1))
    idx = np.clip(np.searchsorted(edges, d, side="right") - 1, 0, BINS - 1)
    n = np.bincount(idx, None, BINS)
    ok = n > 0
    db = (np.bincount(idx, d, BINS)[ok] / n[ok])
    mb = (np.bincount(idx, a, BINS)[ok] / n[ok])
    fb = np.asarray(tone.curve(db, curve), dtype=np.float64)
    o = np.argsort(fb, kind="stable")
    return fb[o], np.maximum.accumulate(mb[o])


def threshold(dark: np.ndarray, q: float) -> float:
    """The darkness below which a share q of the picture lies."""
    return float(np.quantile(np.ravel(dark), q)) if q > 0 else 0.0


def table(resp: tuple[np.ndarray, np.ndarray], dark: np.ndarray, mean_ink: float,
          q: float) -> tone.Table:
    """The curve that makes a drawing's blurred ink beta max(D - d0, 0) (d0: `threshold`),
    by the measured response `resp`; mean ink `mean_ink` over the picture."""
    f_r, m_r = resp
    d0 = threshold(dark, q)
    lit = np.maximum(np.ravel(dark).astype(np.float64) - d0, 0).mean()
    beta = mean_ink / lit if lit > 0 else 0.0
    xs = np.linspace(0.0, 1.0, STEPS)
    t = beta * np.maximum(xs - d0, 0)
    f = np.interp(t, m_r, f_r)
    top, low = m_r[-1], m_r[0]
    if top > 0:                                   # beyond the measured: in proportion
        f = np.where(t > top, f_r[-1] * t / top, f)
    f = np.where(t < low, (f_r[0] * t / low) if low > 0 else 0.0, f)
    f = np.maximum.accumulate(np.clip(f, 0, None))
    peak = f[-1] if f[-1] > 0 else 1.0
    f = (1 - FLOOR) * f + FLOOR * peak * xs      # strictly rising, 0 at white
    return tone.Table(tuple(float(v) for v in f), f"fitted (ink from darkness {d0:.2f} up)")


def search(value, refine: bool = True) -> float:
    """The threshold share q with the highest value(q) (value: q -> a score, called about 5
    to 7 times): QUANTILES, then WALK further while the best is the lowest or the highest
    tried (within 0..MOST_Q), then REFINE either side of the best (refine False: not; 3 to 5
    calls)."""
    seen: dict[float, float] = {}

    def at(q: float) -> None:
        q = round(q, 6)
        if 0 <= q <= MOST_Q and q not in seen:
            seen[q] = value(q)

    for q in QUANTILES:
        at(q)
    while True:
        best = max(seen, key=seen.get)
        step = WALK if best == max(seen) else -WALK if best == min(seen) else 0.0
        if not step or round(best + step, 6) in seen or not 0 <= best + step <= MOST_Q:
            break
        at(best + step)
    best = max(seen, key=seen.get)
    if refine:
        at(best - REFINE)
        at(best + REFINE)
    return max(seen, key=seen.get)
