"""The tone curve a photo's drawing takes (`drawing/photo.py`): the exponent a style takes from
its spacing, the curve that draws this picture best within the budget (`pick_curve`), and the
quick estimate of it `--style auto` ranks the styles by (`quick_score`).
"""

from __future__ import annotations

from dataclasses import replace

from vplotter.errors import ConfigError

POWER = {"hatch": 1.0, "spiral": 1.0, "squiggle": 1.0, "stipple": 2.0, "tsp": 1.0, "flow": 1.0}
CURVES = ("hatch", "spiral", "squiggle", "flow")    # whose tone curve is chosen per picture
CURVE_TRIES = 3           # drawings made per other curve (from the spacing already found)
CURVE_STEP = 1.6          # the curves tried: the spacing's own exponent, / and x this
CURVE_MAX = 16.0
FITTED_TRIES = 5          # drawings made for the fitted curve (the likely winner: the budget)


def default_gamma(style: str, spacing_mm: float, pen_mm: float, picture=None,
                  tsp: bool = False) -> float:
    """The tone curve's exponent a style takes from the spacing (the tour: and the picture)."""
    from vplotter.inputs.image import flow, hatch, squiggle, stipple

    if tsp:
        return stipple.cap_gamma(picture, spacing_mm, pen_mm, True)
    if style == "hatch":
        return hatch.tone_gamma(spacing_mm, pen_mm)
    if style == "flow":
        return flow.tone_gamma(spacing_mm, pen_mm)
    return squiggle.tone_gamma(spacing_mm, pen_mm)


def pick_curve(picture, opts, draw, make, timed, budget_s: float, lo: float,
               hi: float, raw, drawn, choice):
    """The tone curve that draws this picture best within the budget. First exponents: the
    spacing's own g0, g0 / CURVE_STEP and g0 x CURVE_STEP (within 1..CURVE_MAX), each fitted
    to the budget (a few tries from the spacing already found). Then curves fitted to the best
    drawing's measured response (`calibrate.py`: ink rising straight with darkness above a
    threshold): a few thresholds drawn at that drawing's spacing (`calibrate.search`), the
    best of them fitted to the budget. Every drawing is scored
    against the picture (`score.correlation`: ink at the pen width, blurred at 1 mm, against
    the blurred darkness). (placed strokes, budget.Choice, the curve, a note for `info`)."""
    from vplotter import budget
    from vplotter.inputs.image import calibrate, score, tone

    dark = score.darkness(picture)
    g0 = default_gamma(opts.style, choice.spacing_mm, opts.pen_mm, picture, opts.tsp)
    best = (score.correlation(raw, picture, opts.pen_mm, dark), g0, drawn, choice, raw)
    said = [f"{tone.name(g0)} {best[0]:.3f}"]
    made_tries = list(choice.tries)

    def attempt(g, most: int = CURVE_TRIES) -> bool:
        """Try the curve g (an exponent or a tone.Table), at most `most` drawings to fit the
        budget; True if it is the best so far."""
        nonlocal best
        try:
            (placed, made), c = budget.fit(lambda sp: make(sp, g), timed, budget_s,
                                           best[3].spacing_mm, lo, hi, POWER[opts.kind],
                                           most=most)
        except ConfigError:                   # even the widest spacing is too long
            return False
        made_tries.extend(c.tries)
        r = score.correlation(made, picture, opts.pen_mm, dark)
        said.append(f"{tone.name(g)} {r:.3f}")
        if r > best[0]:
            best = (r, g, placed, c, made)
            return True
        return False

    for step in (1 / CURVE_STEP, CURVE_STEP):
        g = min(max(g0 * step, 1.0), CURVE_MAX)
        if abs(g - g0) > 1e-6:
            attempt(g)
    if dark.std() > 0:                        # curves fitted to the best drawing's response
        _, g, _, c, made = best
        ink = score.ink(made, picture, opts.pen_mm)
        resp, mean = calibrate.response(g, ink, dark), float(ink.mean())

        def fitted(q: float) -> float:
            """The score of the curve for threshold q, drawn at the measured drawing's spacing
            (`draw` remembers it: the same curve for several q, or the fit's first try)."""
            t = calibrate.table(resp, dark, mean, q)
            return score.correlation(draw(c.spacing_mm, t), picture, opts.pen_mm, dark)

        attempt(calibrate.table(resp, dark, mean, calibrate.search(fitted)), FITTED_TRIES)
    r, g, placed, c, _ = best
    c = replace(c, tries=made_tries)          # every drawing made counts
    note = (f"tone curve {tone.name(g)} chosen for this picture (correlation of ink with "
            f"darkness at a 1 mm blur, each curve fitted to the budget: {', '.join(said)})")
    return placed, c, g, note


def quick_score(s, dark) -> tuple[float, float]:
    """What `pick_curve` will about reach from a budget's search (`photo.Searched`), and how high
    it might: (the estimate, the bound). The search's drawing is scored, and the curves fitted
    to its measured response (`calibrate.search`: 3 to 5) are drawn at its spacing, no planner;
    the best of those is the bound (a fitted curve mostly lays more ink than the spacing's own,
    so it takes longer than the budget). That curve is then timed once and, over the budget,
    drawn at the spacing time ~ spacing^-POWER says fits and scored there: the estimate (a
    spiral's time jumps with the spacing, so it may come out well under). `--style auto`
    ranks the styles by it (`photo_auto.auto`); dark: `score.darkness` of the picture."""
    from vplotter.inputs.image import calibrate, score

    d, opts, picture = s.d, s.d.opts, s.d.picture
    r = score.correlation(s.raw, picture, opts.pen_mm, dark)
    if not ((opts.style in CURVES or opts.tsp) and d.layers is None and dark.std() > 0):
        return r, r
    sp = s.choice.spacing_mm
    g = s.curve if s.curve is not None else default_gamma(opts.style, sp, opts.pen_mm, picture,
                                                          opts.tsp)
    ink = score.ink(s.raw, picture, opts.pen_mm)
    resp, mean = calibrate.response(g, ink, dark), float(ink.mean())
    seen: dict = {}

    def fitted(q: float) -> float:
        t = calibrate.table(resp, dark, mean, q)
        seen[t] = score.correlation(d.draw(sp, t), picture, opts.pen_mm, dark)
        return seen[t]

    calibrate.search(fitted, refine=False)
    table = max(seen, key=seen.get)
    if seen[table] <= r:
        return r, r
    t = s.timed(d.make(sp, table))
    if t > s.budget_s:
        sp = min(s.hi, sp * (t / s.budget_s) ** (1 / POWER[opts.kind]))
        return max(r, score.correlation(d.draw(sp, table), picture, opts.pen_mm, dark)), seen[table]
    return seen[table], seen[table]
