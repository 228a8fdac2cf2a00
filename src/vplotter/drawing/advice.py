"""What a person is told about a photo's drawing: one line of what was chosen, and advice when
the drawing will show the picture poorly, with the size or the time that would show it.

The criterion (`good_spacing`) is first the spacing in pen widths (`GOOD_PENS`, per style):
the share of the paper one line covers, which decides how many tones the drawing can lay. A
budget that leaves the line sparse makes the tone curve steep: only the darkest parts get
ink, and the mid-tones a face is made of stay blank. Measured by bench/photo_advice.py on
face pictures (the astronaut cut to a portrait, the camera man, the cat), the faces' own
correlation of ink with darkness (`inputs/image/score.py`, 1 mm blur) at each style's own
tone curve reaches about 0.8 (eyes, mouth and hair show, as in the 3 h drawings of
docs/drawing-files.md) at GOOD_PENS, and falls to 0.5-0.65 at the spacings a 300 x 400 mm
portrait gets in an hour (hatch 6.8, spiral 22, squiggle 21, stipple 14 pen widths), where
the face is blank. The same spacing in pen widths scores the same at 150 and 300 mm wide: there
the tone fails first, not the detail. On a small picture the detail fails too (the portrait's
hatch at 3 pen widths: 0.82 at 75 mm wide, 50 lines across, 0.73 at 40 mm, 27 across; the
spiral at 8: 0.83 at 150 mm, 0.79 at 75 mm, 21 tracks across): so also LINES lines (tracks,
dots) across the narrower side.

The suggestions use the budget's model: time ~ spacing^-k, k the secant of the budget's own
tries towards denser drawings (`time_power`; at least `TIME_POWER`, measured along the budget's
choices: steeper than the styles' line alone, because a longer budget also takes a gentler
tone curve, which spends line on more tones), and time ~ area at a given spacing. The time at
this size is t x (s / good)^k, the size in this time the largest whose spacing, s x (w' /
w)^(2 / k), passes at that size. Both are rounded to what a person types (up for the time,
down for the size) with a margin (`MARGIN`). No drawing is made: the advice costs nothing next
to the budget's search. bench/photo_advice.py --check follows the advice and checks it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

# the spacing (pen widths) at which a face shows, per style ("tsp": stipple --tsp)
GOOD_PENS = {"hatch": 3.2, "spiral": 10.0, "squiggle": 10.0, "stipple": 8.0, "tsp": 4.0,
             "flow": 3.2}
# time ~ spacing^-k along the budget's choices, k at least this (measured from 1 h to 3 h on
# a 300 x 400 mm portrait; the budget's own tries say more, `time_power`), at most MAX_POWER
TIME_POWER = {"hatch": 1.45, "spiral": 1.3, "squiggle": 1.3, "stipple": 2.0, "tsp": 1.3,
              "flow": 1.45}
MAX_POWER = 3.0
MARGIN = 1.1              # the time asked for x this (the size / its square root)
MAX_S = 30 * 86400.0      # --max-time's own limit
MIN_MM = 50.0             # no smaller picture is suggested
LINES = 40                # a face needs this many lines (tracks, dots) across the picture


@dataclass
class Said:
    """What a photo's drawing says: `notes` (what was chosen, always said), `details` (the
    tone details: the curves tried, the search, the pitches; said with --verbose) and `advice`
    (a drawing that will show the picture poorly: the size or time that would show it)."""

    notes: list[str] = field(default_factory=list)
    details: list[str] = field(default_factory=list)
    advice: list[str] = field(default_factory=list)


def chosen(kind: str, w_mm: float, h_mm: float, spacing_mm: float, time_s: float | None = None,
           budget_s: float | None = None, default: bool = False, densest: bool = False) -> str:
    """The one line of what was chosen: style, size, spacing, plot time (budget_s None: a
    fixed --spacing). default: the budget is the default one; densest: the spacing is the
    pen's minimum."""
    from vplotter.budget import clock_text

    name = "stipple --tsp" if kind == "tsp" else kind
    head = f"photo: {name}, {w_mm:.0f} x {h_mm:.0f} mm, {spaced(kind, spacing_mm)}"
    if budget_s is None or time_s is None:
        return f"{head} (--spacing)"
    head += f", plot time {clock_text(time_s)} within {clock_text(budget_s)}"
    if default:
        head += " (no --max-time: the default budget)"
    return head + ("; as dense as the pen can show" if densest else "")


def sparse(kind: str, spacing_mm: float, pen_mm: float | None = None) -> str:
    """A sparse drawing in a person's words (with pen_mm: and in pen widths)."""
    s = _mm(spacing_mm)
    pens = "" if pen_mm is None else f", {spacing_mm / pen_mm:.1f} pen widths"
    if kind in ("hatch", "flow"):
        return f"the lines are {s} mm apart{pens}"
    if kind in ("stipple", "tsp"):
        return f"the dots are {s} mm apart{pens}"
    return f"the line is spread thin (spacing {s} mm{pens})"


def pitch(kind: str, spacing_mm: float, pen_mm: float) -> float:
    """The distance between the style's lines (the spiral's and the squiggle's tracks are
    never further apart than squiggle.CAP_PENS pen widths, whatever the spacing)."""
    if kind in ("spiral", "squiggle"):
        from vplotter.inputs.image.squiggle import track_pitch

        return track_pitch(spacing_mm, pen_mm)
    return spacing_mm


def good_spacing(kind: str, pen_mm: float, w_mm: float | None = None,
                 h_mm: float | None = None) -> float:
    """The widest spacing at which a face shows (mm): GOOD_PENS pen widths, and at w x h mm
    LINES of the style's lines across the narrower side."""
    tone = GOOD_PENS[kind] * pen_mm
    if w_mm is None or h_mm is None:
        return tone
    detail = min(w_mm, h_mm) / LINES
    if pitch(kind, tone, pen_mm) <= detail:
        return tone
    return detail          # (tracks: a spacing under their cap is their pitch)


def spaced(kind: str, spacing_mm: float) -> str:
    """The spacing in a person's words."""
    s = _mm(spacing_mm)
    if kind in ("hatch", "flow"):
        return f"lines {s} mm apart"
    if kind in ("stipple", "tsp"):
        return f"dots {s} mm apart"
    return f"spacing {s} mm"


def advise(kind: str, pen_mm: float, spacing_mm: float, w_mm: float, h_mm: float,
           time_s: float | None = None, budget_s: float | None = None,
           tries=()) -> list[str]:
    """Advice for a drawing `kind` at this spacing, w x h mm, planned in time_s of budget_s
    (None: a fixed --spacing; tries: the budget's (spacing, time) drawings): [] when a face
    will show."""
    good = good_spacing(kind, pen_mm, w_mm, h_mm)
    if spacing_mm <= good * 1.0001:
        return []
    size = f"{w_mm:.0f} x {h_mm:.0f} mm"
    what = (f"at {size} in {duration(budget_s)}" if budget_s else f"at {size}")
    if spacing_mm > GOOD_PENS[kind] * pen_mm * 1.0001:
        said = (f"{what} {sparse(kind, spacing_mm, pen_mm)}: only the darkest parts will "
                f"show, not a face.")
    else:
        across = min(w_mm, h_mm) / pitch(kind, spacing_mm, pen_mm)
        said = (f"{what} {sparse(kind, spacing_mm)}, {across:.0f} across: too few for a face "
                f"({LINES} would do).")
    if budget_s is None or time_s is None:
        return [f"{said} --spacing {_mm(good)} would show one (and take longer)."]
    k = time_power(kind, spacing_mm, time_s, tries)
    need = needed_time(k, spacing_mm, good, budget_s)
    width = needed_width(kind, k, pen_mm, spacing_mm, w_mm, h_mm)
    ways = []
    if need <= MAX_S:
        ways.append(f"{duration(need)} (--max-time {option_time(need)})")
    if width is not None:
        ways.append(f"{width:.0f} mm wide (--width {width:.0f})")
    if not ways:
        return [f"{said} A smaller picture or another style would show more."]
    return [f"{said} {' or '.join(ways)} would show one."]


def time_power(kind: str, spacing_mm: float, time_s: float, tries=()) -> float:
    """k in time ~ spacing^-k towards denser drawings: the budget's secant from the drawing
    chosen to the densest it tried (its first, START_PENS: near GOOD_PENS), at least
    TIME_POWER[kind] (the secant mixes tone curves), at most MAX_POWER."""
    k = TIME_POWER[kind]
    denser = [(s, t) for s, t in tries if s < spacing_mm * 0.9 and t > time_s > 0]
    if denser:
        s0, t0 = min(denser)
        k = max(k, min(MAX_POWER, math.log(t0 / time_s) / math.log(spacing_mm / s0)))
    return k


def needed_time(k: float, spacing_mm: float, good_mm: float, budget_s: float) -> float:
    """The budget (s, rounded up) whose drawing at this size has the spacing good_mm, time ~
    spacing^-k, with MARGIN."""
    t = budget_s * (spacing_mm / good_mm) ** k * MARGIN
    step = 300 if t < 3600 else 900 if t < 3 * 3600 else 1800 if t < 12 * 3600 else 3600
    return math.ceil(t / step) * step


def needed_width(kind: str, k: float, pen_mm: float, spacing_mm: float, w_mm: float,
                 h_mm: float) -> float | None:
    """The largest width (mm, in steps a person types) at which the same budget draws a face
    (None: none from MIN_MM up). At a given spacing the time goes with the area, so in the
    same time the spacing goes as area^(1 / power): s x (w' / w)^(2 / power), and the margin
    in time asks it MARGIN^(1 / power) finer."""
    lo = pen_mm * (1.2 if kind == "stipple" else 1.0)        # the budget's densest
    w = float(math.floor(w_mm))
    while w >= MIN_MM:
        r = w / w_mm
        good = good_spacing(kind, pen_mm, w, h_mm * r)
        if spacing_mm * r ** (2 / k) * MARGIN ** (1 / k) <= good and good >= lo:
            return w
        w = (math.ceil(w / 10) - 1) * 10 if w > 100 else (math.ceil(w / 5) - 1) * 5
    return None


def duration(seconds: float) -> str:
    """'1 h', '2 h 30 min', '45 min'."""
    m = int(round(seconds / 60))
    h, m = divmod(m, 60)
    if h and m:
        return f"{h} h {m} min"
    return f"{h} h" if h else f"{m} min"


def option_time(seconds: float) -> str:
    """The --max-time a person types: '2h30m', '4h', '45m'."""
    m = int(round(seconds / 60))
    h, m = divmod(m, 60)
    return (f"{h}h" if h else "") + (f"{m}m" if m or not h else "")


def _mm(v: float) -> str:
    """3 significant figures, no trailing zeros: 3.38, 11.2, 0.75."""
    return f"{v:.3g}" if v < 100 else f"{v:.0f}"
