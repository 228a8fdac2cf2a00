"""Choosing among drawings of a photo by how well each draws its tone: `--style auto` (every
style at the budget) and stipples at a budget (the dots, or the tour through them).

Each candidate is drawn as its own style would be (`photo._one`: the budget's search, the tone
curves, the final order), on the picture loaded once, and scored with the converter's own
measure (`inputs/image/score.py`: the ink at the pen's width blurred at 1 mm against the
picture's darkness blurred the same, the correlation bench/photo_tone.py reports, on 1 mm
cells); with several pens each pen's strokes against its own layer, weighted by the ink the
layer asks for. The best is kept and one note says which and why, with every candidate's score
and plot time (so `info` lists them).

`--style auto` at a budget (`auto`) does not finish every style: most of a style's convert is
fitting its tone curves to the budget (each curve several drawings, each ordered and timed by
the planner) and its final order. Every style's budget is searched on its own curve, from where
the style alone starts (a search started elsewhere, from the hatch's spacing, landed the tour
on another spacing 0.01 below its own drawing on two of the bench's pictures), then ranked by
`photo_curve.quick_score`: the curves fitted to
that drawing's measured response, drawn at its spacing, the best timed once. The first, the
next (of the rest, the one whose bound, the fitted curves' best score before timing, is
highest, if within MARGIN of the first's score) and the hatch (ALWAYS) are finished and the
best of those kept by its own score. The quick score came out within about 0.04 of the
finished one for every style (the spiral's and the tour's time jump with the spacing) but the
hatch, which its finish raised by up to 0.042: it is always finished (docs/measurements.md,
"Photos"). A style finished here is the drawing `--style` that style makes. The stipples (the
tour, the dearest to search and finish) go to a second process where there is a core for it
(`photo_fork`): searched, scored and finished there while this one does the other four (the
child's finish is made before the ranking knows whether it is needed, and stopped if not);
the same G-code as one process. The 12 MP photo at 1 h (docs/measurements.md, "Photos"), on
the idle machine: 9.0 s where one process took 14.6 s (about the same CPU: 15.5 s and 15.7 s;
this process's share is the longer, 8.5-9.4 s of CPU under load against the child's 7.7-8.5).

Stipples at a budget: a dot costs a pen lift (about 2 s on the seed machine), so an hour of
dots lays little ink; the tour (TSP art) draws a line through the same kind of stipples and
lays far more ink per second. With a budget and no --tsp, the tour is drawn; on line art (at
least LINE_ART of the picture white, darkness under WHITE) the dots are drawn too and the
better kept (said in the note): the dots won only there in bench/photo_tone.py (the line
drawing at 3 h), the tour on every photograph and the grey ramp (at most 2 % white), so a
photograph pays for one search, not two. --tsp asks for the tour alone.
"""

from __future__ import annotations

from dataclasses import replace

from vplotter.budget import clock_text

AUTO_STYLES = ("hatch", "squiggle", "spiral", "flow", "stipple")
WHITE, LINE_ART = 0.05, 0.5     # line art: at least LINE_ART of the picture darkness < WHITE
MARGIN = 0.015       # styles finished: the best by the quick score, the one of the rest whose
FINISHED = 2         # bound is highest if it is at most this under that score (FINISHED in all,
ALWAYS = ("hatch",)  # besides ALWAYS), and ALWAYS (the quick score misses most of what the
                     # hatch's finish gains: 0.02-0.04 on some pictures)
BESIDE = ("stipple",)  # styles `auto` draws in a second process (`photo_fork`): the tour


def white_share(picture) -> float:
    """The share of the picture that is white (darkness under WHITE)."""
    return float((picture.darkness < WHITE).mean())


def variants(opts, picture) -> list:
    """The drawings to choose among for these options (one: no choice)."""
    from vplotter.inputs.image import AUTO

    if opts.style == AUTO:
        out = []
        for s in AUTO_STYLES:
            out += variants(replace(opts, style=s), picture)
        return out
    if opts.style == "stipple" and not opts.tsp and opts.spacing_mm is None:
        tour = replace(opts, tsp=True)
        return [opts, tour] if white_share(picture) >= LINE_ART else [tour]
    return [opts]


def name(opts) -> str:
    return "stipple --tsp" if opts.tsp else opts.style


def tone_score(raw, pictures, pen_mm: float) -> float:
    """The correlation of the strokes' ink with the picture's darkness (several pens: each
    against its layer, weighted by the layer's mean darkness)."""
    from vplotter.inputs.image import score

    picture, layers, inks = pictures
    if layers is None:
        return score.correlation(raw, picture, pen_mm)
    total = weight = 0.0
    for (pen, _, _), layer in zip(inks, layers):
        mine = [s for s in raw if s.pen == pen]
        w = float(layer.darkness.mean())
        total += w * score.correlation(mine, layer, pen_mm)
        weight += w
    return total / weight if weight > 0 else 0.0


def best(opts, tries: list, one, pictures):
    """(placed strokes, what is said) of the candidate that draws the tone best; its note
    first says which was chosen, and every candidate's score and plot time."""
    from vplotter.inputs.image import AUTO

    made = []
    for o in tries:
        placed, said, raw, time_s = one(o)
        made.append((tone_score(raw, pictures, o.pen_mm), o, placed, said, time_s))
    chosen = max(made, key=lambda m: m[0])
    _, o, placed, said, _ = chosen

    def figures(m) -> str:
        return f"{m[0]:.3f}" + ("" if m[4] is None else f", {clock_text(m[4])}")

    others = "; ".join(f"{name(m[1])} {figures(m)}" for m in made if m is not chosen)
    if len(made) == 1:                  # a budgeted stipple of a photograph: the tour alone
        said.notes.insert(0, f"stipple: the tour through the dots (tone {figures(chosen)}; "
                          f"dots not tried: {white_share(pictures[0]):.0%} of the picture is "
                          f"white, a photograph, where the tour lays more ink an hour; the "
                          f"dots are tried on line art, at least {LINE_ART:.0%} white)")
        return placed, said
    if opts.style == AUTO:
        head = f"--style auto chose {name(o)}"
    else:
        head = f"stipple: {'the tour through the dots' if o.tsp else 'dots'}"
    said.notes.insert(0, f"{head} (tone {figures(chosen)}; {others}): the drawing whose ink "
                      f"follows the darkness best (correlation at a 1 mm blur)")
    return placed, said


def auto(tries: list, begin, search, finish, pictures):
    """--style auto at a budget: (placed strokes, what is said). Every style's budget is
    searched on its own curve (`photo.searched`, as the style alone searches it) and ranked
    by `photo_curve.quick_score` (the curves fitted to that drawing's response, the best
    timed once); the first, the one of the rest whose bound (the fitted curves' best score
    before timing) is highest if within MARGIN of the first's score, and the hatch are
    finished (`photo.finished`: the curves fitted to the budget, the final order) and the best
    of those by its own score kept: one to three styles finished, not five. The stipples (the
    tour: the dearest to search and to finish) are searched, scored and finished in a second
    process where there is a core for it (`photo_fork`; finished whether or not they are
    chosen, since they take longer than the rest): the same drawing and note either way.
    begin(opts) -> (`photo._Drawings`, `advice.Said`); search(drawings) ->
    `photo.Searched`; finish: `photo.finished`."""
    from vplotter.drawing import photo_fork
    from vplotter.drawing.photo_curve import quick_score
    from vplotter.inputs.image import score

    dark = score.darkness(pictures[0])

    def ranked_one(o):
        """[quick score, options, Searched, Said, bound, plot time of the search]"""
        d, said = begin(o)
        s = search(d)
        q = (quick_score(s, dark) if pictures[1] is None else
             (tone_score(s.raw, pictures, o.pen_mm),) * 2)
        return [q[0], o, s, said, q[1], s.choice.time_s]

    def done(m):
        """(its own score, options, placed strokes, Said, plot time) of a ranked style"""
        placed, said, raw, time_s = finish(m[2], m[3])
        return tone_score(raw, pictures, m[1].pen_mm), m[1], placed, said, time_s

    aside = [o for o in tries if o.style in BESIDE]
    child = photo_fork.start(lambda send: _aside(aside, ranked_one, done, send)) if aside \
        else None
    beside = _Aside(child, aside, ranked_one, done)
    try:
        return _auto(tries, ranked_one, done, beside)
    finally:
        beside.close()


def _aside(aside: list, ranked_one, done, send) -> None:
    """The child's work: the styles aside searched and ranked (one message: each one's quick
    score, bound and plot time), then each finished (a message each: its score, placed
    strokes, Said, plot time)."""
    got = [ranked_one(o) for o in aside]
    send([(m[0], m[4], m[5]) for m in got])
    for m in got:
        r = done(m)
        send((r[0],) + r[2:])


class _Aside:
    """The styles ranked and finished in the child (`photo_fork`), or here if it is lost."""

    def __init__(self, child, aside: list, ranked_one, done):
        self.child, self.aside, self.ranked_one, self.done = child, aside, ranked_one, done
        self.got: list = []

    def ranked(self) -> dict:
        """{id(options): the ranked entry} of the styles aside."""
        from vplotter.drawing.photo_fork import Lost

        if self.child is not None:
            try:
                return {id(o): [q, o, None, None, b, t]
                        for o, (q, b, t) in zip(self.aside, self.child.get())}
            except Lost:
                self.child = None
        return {id(o): self.ranked_one(o) for o in self.aside}

    def close(self) -> None:
        if self.child is not None:
            self.child.close()
            self.child = None

    def finished(self, m):
        """done(m) of a style aside."""
        from vplotter.drawing.photo_fork import Lost

        k = next(i for i, o in enumerate(self.aside) if o is m[1])
        while self.child is not None and len(self.got) <= k:
            try:
                self.got.append(self.child.get())
            except Lost:
                self.child = None
        if k < len(self.got):
            r = self.got[k]
            return (r[0], m[1]) + tuple(r[1:])
        if m[2] is None:                    # ranked in the child, which was lost: again here
            m[2:4] = self.ranked_one(m[1])[2:4]
        return self.done(m)


def _auto(tries: list, ranked_one, done, aside: _Aside):
    """`auto` once the child (if any) is started: rank, finish, choose, say."""
    mine = {id(o): ranked_one(o) for o in tries if not any(o is a for a in aside.aside)}
    theirs = aside.ranked() if aside.aside else {}
    ranked = [mine.get(id(o)) or theirs[id(o)] for o in tries]
    ranked.sort(key=lambda m: -m[0])
    rest = sorted((m for m in ranked[1:] if m[1].kind not in ALWAYS and
                   m[4] >= ranked[0][0] - MARGIN), key=lambda m: -m[4])
    finishing = {id(m[1]) for m in ranked[:1] + rest[:FINISHED - 1]} | {
        id(m[1]) for m in ranked if m[1].kind in ALWAYS}
    if not finishing & set(theirs):
        aside.close()                         # the child's finish: not needed
    made = {}
    for m in ranked:                        # those here first, then the child's
        if id(m[1]) in mine and id(m[1]) in finishing:
            made[id(m[1])] = done(m)
        elif id(m[1]) in mine:
            m[2].d.drawn_last.clear()         # its drawings: not needed again
    for m in ranked:
        if id(m[1]) in theirs and id(m[1]) in finishing:
            made[id(m[1])] = aside.finished(m)
    made = [made[id(m[1])] for m in ranked if id(m[1]) in made]
    chosen = max(made, key=lambda m: m[0])
    _, o, placed, said, _ = chosen

    def figures(m) -> str:
        return f"{m[0]:.3f}, {clock_text(m[4])}"

    others = [f"{name(m[1])} {figures(m)}" for m in made if m is not chosen]
    quick = [f"{name(m[1])} {m[0]:.3f}, {clock_text(m[5])}" for m in ranked
             if id(m[1]) not in finishing]
    said.notes.insert(0, f"--style auto chose {name(o)} (tone {figures(chosen)}"
                      f"{''.join('; ' + x for x in others)}; quick: "
                      f"{'; '.join(quick) or 'none'}): the drawing whose ink follows the "
                      f"darkness best (correlation at a 1 mm blur); every style's budget "
                      f"searched and its fitted curve scored at that spacing (quick), the best "
                      f"{len(made)} finished")
    return placed, said
