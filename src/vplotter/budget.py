"""A plot-time budget: choose a drawing's density so that its planned plot time fits.

A photo style has one density knob, `spacing_mm` (the distance between tracks, rows, hatch
lines or stipples): halving it roughly doubles the line drawn (and quadruples the stipples).
`fit` searches it: each try makes the strokes, and the caller's `plot_time` (the same planner
as `draw`, without computing a single step) times them; the search works on log(time) against
log(spacing), a straight line for a pure power law, so a few tries land within a few per cent
under the budget. The search times a quick order (greedy); `fill` then puts the drawing in
its final order (`order.py`'s best) and spends the time that saves on a denser spacing, so the
drawing lands within 1.5 % under the budget. Pure functions: the styles, the order and the
planner come in as callbacks.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Callable

from vplotter.errors import ConfigError

DEFAULT_S = 3600.0          # a photo without --max-time: about an hour
UNDER = 0.96                # land between UNDER x budget and the budget
TRIES = 9
FILL_UNDER = 0.985          # `fill`: the final order's plot time at least this share of the budget,
FILL_TRIES = 3              # ... with at most this many denser drawings


def parse_duration(text: str) -> float:
    """'2h', '45m', '1h30m', '90s', '1h 5m 10s', '1.5h' or plain seconds ('5400') -> seconds."""
    s = text.strip().lower().replace(" ", "")
    if re.fullmatch(r"\d+(\.\d+)?", s):
        value = float(s)
    else:
        m = re.fullmatch(r"(?:(\d+(?:\.\d+)?)h)?"
                         r"(?:(\d+(?:\.\d+)?)m(?:in)?)?"
                         r"(?:(\d+(?:\.\d+)?)s)?", s)
        if not s or m is None or not any(m.groups()):
            raise ConfigError(f"error: --max-time: {text!r} is not a duration (examples: 2h, "
                              f"45m, 1h30m, 5400)")
        h, mi, se = (float(g) if g else 0.0 for g in m.groups())
        value = 3600 * h + 60 * mi + se
    if not 60 <= value <= 30 * 86400:
        raise ConfigError(f"error: --max-time must be 1 minute to 30 days (got {text!r})")
    return value


@dataclass
class Choice:
    """What the search chose and why (for `info` and the draw's notes)."""

    spacing_mm: float
    time_s: float
    budget_s: float
    tries: list[tuple[float, float]] = field(default_factory=list)    # (spacing, time)
    limit: str = ""         # "" or why it stopped short of the budget

    def text(self) -> str:
        why = f"; {self.limit}" if self.limit else ""
        return (f"spacing {self.spacing_mm:.3f} mm for a plot time of {clock_text(self.time_s)} "
                f"within {clock_text(self.budget_s)} ({len(self.tries)} tries){why}")


def fit(make: Callable[[float], object], plot_time: Callable[[object], float], budget_s: float,
        start_mm: float, min_mm: float, max_mm: float, power: float = 1.0, most: int = TRIES):
    """(result of make(spacing), Choice): the densest spacing in [min_mm, max_mm] whose plot
    time is at most budget_s, found to within UNDER of it. make(spacing) builds the drawing;
    plot_time(drawing) times it. `power`: time ~ spacing^-power, the first guess's slope;
    `most`: drawings made at most."""
    tries: list[tuple[float, float]] = []
    best = None                                  # (spacing, drawing, time) under the budget

    def attempt(s: float):
        nonlocal best
        s = min(max(s, min_mm), max_mm)
        for done_s, done_t in tries:             # never the same spacing twice
            if abs(math.log(done_s / s)) < 1e-6:
                return s, done_t
        drawing = make(s)
        t = plot_time(drawing)
        tries.append((s, t))
        if t <= budget_s and (best is None or s < best[0]):
            best = (s, drawing, t)
        return s, t

    s, t = attempt(start_mm)
    slope = -power
    for _ in range(most - 1):
        if UNDER * budget_s <= t <= budget_s:
            break
        if s <= min_mm and t <= budget_s:
            break                                # as dense as the pen can show
        if s >= max_mm and t > budget_s:
            break                                # even the sparsest does not fit
        under = [(a, b) for a, b in tries if b <= budget_s]
        over = [(a, b) for a, b in tries if b > budget_s]
        if under and over:                       # secant in log-log between the bracket
            (s0, t0) = min(under, key=lambda p: p[0])
            (s1, t1) = max(over, key=lambda p: p[0])
            if t0 != t1 and s0 != s1:
                slope = math.log(t0 / t1) / math.log(s0 / s1)
            target = math.log(budget_s * (1 + UNDER) / 2)
            guess = math.exp(math.log(s0) + (target - math.log(t0)) / min(slope, -0.2))
            lo, hi = sorted((s0, s1))
            if not lo < guess < hi:
                guess = math.sqrt(s0 * s1)
        else:
            aim = budget_s * (1 + UNDER) / 2
            guess = s * (t / aim) ** (1 / -min(slope, -0.2))
        s, t = attempt(guess)
    if best is None:
        s_max, t_max = max(tries)
        raise ConfigError(f"error: --max-time {clock_text(budget_s)} is too short for this "
                          f"picture: even at the widest spacing ({s_max:.2f} mm) it takes "
                          f"{clock_text(t_max)}; give more time or a smaller --width")
    s, drawing, t = best
    return drawing, Choice(s, t, budget_s, tries, _short(s, t, budget_s, min_mm, UNDER))


def _short(s: float, t: float, budget_s: float, min_mm: float, share: float) -> str:
    """Why a choice takes less than `share` of the budget ("" if it does not)."""
    if t >= share * budget_s:
        return ""
    return ("as dense as the pen can show (spacing at its minimum)" if s <= min_mm * 1.0001
            else "the closest try under the budget")


def fill(quick, choice: Choice, remake, final, plot_time,
         budget_s: float, lo: float, power: float):
    """(the drawing in its final order, its Choice). The quick order the budget was
    searched in is improved (`final`; kept if that takes longer); when that leaves more than
    1 - FILL_UNDER of the budget unused, denser spacings are drawn, ordered and timed, at most
    FILL_TRIES: the first from time ~ spacing^-power, then by the secant (log time against
    log spacing) between the longest try within the budget and the sparsest over it. The
    longest within the budget is kept; if that is still short of FILL_UNDER (the time jumps
    with the spacing: a hatch line or a squiggle row more or less), the Choice says so."""
    drawn = final(quick)
    t = plot_time(drawn) if drawn is not quick else choice.time_s
    if t > choice.time_s:
        drawn, t = quick, choice.time_s
    s, tries = choice.spacing_mm, list(choice.tries)
    over = None                                       # (spacing, time) of the sparsest over
    aim = budget_s * (1 + FILL_UNDER) / 2
    for _ in range(FILL_TRIES):
        if t >= FILL_UNDER * budget_s or s <= lo * 1.0001 or t <= 0:
            break
        slope = -power
        if over is not None and over[1] != t and over[0] != s:
            slope = min(math.log(over[1] / t) / math.log(over[0] / s), -0.2)
        guess = max(lo, s * math.exp(math.log(aim / t) / slope))
        if over is not None and not over[0] < guess < s:
            guess = math.sqrt(s * over[0])
        placed = final(remake(guess))
        t2 = plot_time(placed)
        tries.append((guess, t2))
        if t2 > budget_s:
            over = (guess, t2) if over is None or guess > over[0] else over
        elif t2 > t:                                  # (a spiral's time can fall as it
            drawn, t, s = placed, t2, guess           # gets denser: its tracks are dashed)
    limit = (choice.limit if s == choice.spacing_mm else "") or _short(s, t, budget_s, lo,
                                                                        FILL_UNDER)
    return drawn, replace(choice, spacing_mm=s, time_s=t, tries=tries, limit=limit)


def clock_text(seconds: float) -> str:
    """1:02:03 or 2:03 (the form status, progress and budgets print)."""
    s = int(round(seconds))
    h, m = divmod(s // 60, 60)
    return f"{h}:{m:02d}:{s % 60:02d}" if h else f"{m}:{s % 60:02d}"
