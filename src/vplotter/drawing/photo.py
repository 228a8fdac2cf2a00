"""A photograph on the page: its size, its strokes in a style, and the density that fits the plot-
time budget.

The picture is sized first (--width, --height, or the largest size about G-code X0 Y0 inside
the page less --margin, aspect kept; centred on X0 Y0 as every drawing is: `place.origin`),
because the line spacing only means something at the final size; it is loaded once at the
resolution the pen can show; then `budget.fit` tries densities of the style, each placed on the
page, put in a quick order (greedy; the stipples' own tour) and timed by the caller's planner,
and keeps the densest that fits (`searched`); then (`photo_curve.pick_curve`, in `finished`)
the same for other tone curves (exponents either side, and curves fitted to the drawing's own
measured response: `inputs/image/calibrate.py`), each drawing scored against the picture
(`inputs/image/score.py`), the best kept. Stipples search on each spacing's own curve (smooth
in spacing), then choose their curve once, at the spacing found, and search again with it.
Last, `budget.fill` puts the drawing in its final order (--order best: `order.py`'s; the
stipples keep their tour; never longer than the quick order) and spends the time that saves on
a denser spacing. A budgeted stipple (its dots or its tour) draws each candidate so and keeps
the one that draws the tone best; `--style auto` searches every style's budget and finishes
two or three of them (`photo_auto.py`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from vplotter import budget
from vplotter.drawing import advice, order, place
from vplotter.drawing.photo_curve import CURVE_TRIES, CURVES, POWER, pick_curve
from vplotter.errors import ConfigError
from vplotter.inputs.strokes import Stroke

# the first spacing tried, per style, in pen widths; time ~ spacing^-POWER (photo_curve.py)
START_PENS = {"hatch": 3.0, "spiral": 3.0, "squiggle": 3.0, "stipple": 8.0, "tsp": 5.0,
              "flow": 3.0}
DRAWN_KEPT = 16           # drawings remembered (by spacing and curve): the fitted curve's search


@dataclass(frozen=True)
class PhotoOptions:
    style: str = "hatch"
    max_time_s: float | None = None      # None: budget.DEFAULT_S, unless spacing_mm is given
    spacing_mm: float | None = None      # a fixed density instead of the budget
    pen_mm: float = 0.5
    contrast: float = 1.0
    brightness: float = 0.0
    invert: bool = False
    tsp: bool = False
    cmyk: bool = False                   # four pens: yellow, cyan, magenta, black layers
    colours: tuple[str, ...] = ()        # --colours: pens by name ([pens]) or colour
    width_mm: float | None = None
    height_mm: float | None = None

    @property
    def kind(self) -> str:
        """The style as the budget sees it: the tour's line takes time ~ 1 / spacing."""
        return "tsp" if self.tsp else self.style

    @classmethod
    def from_args(cls, args) -> "PhotoOptions":
        """The photo options of a command line (argparse namespace; absent ones default)."""
        limit = getattr(args, "max_time", None)
        colours = getattr(args, "colours", None)
        names = tuple(c.strip() for c in (colours or "").split(",") if c.strip())
        if colours is not None and not names:
            raise ConfigError("error: --colours: give the pens, e.g. --colours black,red,blue")
        return cls(style=getattr(args, "style", None) or "hatch",
                   max_time_s=budget.parse_duration(limit) if limit else None,
                   spacing_mm=getattr(args, "spacing", None),
                   pen_mm=getattr(args, "pen_width", None) or 0.5,
                   contrast=getattr(args, "contrast", 1.0),
                   brightness=getattr(args, "brightness", 0.0),
                   invert=bool(getattr(args, "invert", False)),
                   tsp=bool(getattr(args, "tsp", False)),
                   cmyk=bool(getattr(args, "cmyk", False)),
                   colours=names,
                   width_mm=getattr(args, "width", None),
                   height_mm=getattr(args, "height", None))


def size_mm(aspect: float, opts: PhotoOptions, page: place.Box, margin_mm: float):
    """(width, height) of the picture on the wall: --width or --height (the other follows
    the aspect; both: the largest inside that box), else the largest inside the page."""
    if opts.width_mm and opts.height_mm:
        box = np.array([opts.width_mm, opts.height_mm])
    elif opts.width_mm:
        return float(opts.width_mm), float(opts.width_mm / aspect)
    elif opts.height_mm:
        return float(opts.height_mm * aspect), float(opts.height_mm)
    else:               # the largest about X0 Y0 inside the page (a polar machine: its reach)
        k = place.largest((aspect, 1.0), page, margin_mm, place.origin(page))
        if (page.size - 2 * margin_mm <= 0).any() or not k > 0:
            raise ConfigError(f"error: --margin {margin_mm:g} leaves no room on the page")
        return float(k * aspect), float(k)
    k = min(box[0] / aspect, box[1])
    return float(k * aspect), float(k)


def strokes(path: str, opts: PhotoOptions, page: place.Box, placement: place.Placement,
            plot_time: Callable[[list[Stroke]], float] | None, start_xy=(0.0, 0.0),
            method: str = "best", owned: tuple = ()):
    """(placed strokes in their drawing order from start_xy, what is said: `advice.Said`).
    plot_time(strokes) -> s times an ordered drawing with the draw's own planner (None: no
    budget, only with a fixed --spacing). method: "best" improves the quick order the budget
    was searched in (`order.py`; the stipples' tour is already their best) and fills the time
    that saves (`fill`); "greedy" and "keep" leave the quick order. owned: the pens in
    config.toml, which --colours may name."""
    from vplotter.inputs import image
    from vplotter.inputs.image import load

    if opts.style != image.AUTO:
        try:
            image.style(opts.style)
        except ValueError as e:
            raise ConfigError(f"error: --style: {e}") from None
    if opts.tsp and opts.style != "stipple":
        raise ConfigError("error: --tsp is for --style stipple (one tour through the stipples)")
    if placement.scale != 1.0:
        raise ConfigError("error: a photo is sized with --width or --height (or the page), "
                          "not --scale")
    if opts.spacing_mm is not None and opts.max_time_s is not None:
        raise ConfigError("error: give --spacing or --max-time, not both")
    if opts.spacing_mm is None and plot_time is None:
        raise ConfigError("error: a photo needs --spacing here (no planner to time a budget)")
    w, h = size_mm(load.aspect(path), opts, page, placement.margin_mm)
    pictures = _pictures(path, opts, w, h, owned)
    frame = _frame(placement, page, w, h)

    def one(o: PhotoOptions):
        return _one(o, pictures, frame, w, h, plot_time, start_xy, method)

    from vplotter.drawing import photo_auto

    tries = photo_auto.variants(opts, pictures[0])
    if tries == [opts]:
        return one(opts)[:2]
    if opts.style == image.AUTO and opts.spacing_mm is None:
        return photo_auto.auto(tries, lambda o: _begun(o, pictures, frame, start_xy, method),
                               lambda d: searched(d, plot_time, w, h), finished,
                               pictures)
    return photo_auto.best(opts, tries, one, pictures)


def _one(opts: PhotoOptions, pictures, frame, w: float, h: float, plot_time, start_xy,
         method: str):
    """One style's drawing: (placed strokes in their drawing order, what is said, the style's
    own strokes in picture mm, the plot time or None)."""
    from vplotter.inputs import image

    d, said = _begun(opts, pictures, frame, start_xy, method)
    if opts.spacing_mm is not None:
        said.notes.insert(0, advice.chosen(opts.kind, w, h, opts.spacing_mm))
        said.details.append(image.describe(opts.style, opts.spacing_mm, opts.pen_mm, d.picture,
                                           **d.extra))
        said.advice = advice.advise(opts.kind, opts.pen_mm, opts.spacing_mm, w, h)
        placed, raw = d.make(opts.spacing_mm)
        return d.final(placed), said, raw, None
    return finished(searched(d, plot_time, w, h), said)


def _begun(opts: PhotoOptions, pictures, frame, start_xy, method: str):
    """(the style's `_Drawings`, what is said so far: the pen, the pens' layers)."""
    from vplotter.inputs import image

    picture, layers, inks = pictures
    put, shift, A, b = frame
    # the dots come in the order of their tour (`stipple._dots`), better than any other
    how = "keep" if opts.style == "stipple" and not opts.tsp else "greedy"
    d = _Drawings(image.style(opts.style), opts, picture, layers, inks, put, shift, A, b,
                  start_xy, how, method == "best" and how == "greedy")
    said = advice.Said(details=[f"pen {opts.pen_mm:g} mm wide (--pen-width): the line the tone "
                                f"model assumes"])
    if layers is not None:
        from vplotter.inputs.image import cmyk

        said.notes.append(f"{'cmyk' if opts.cmyk else 'colours'}: {len(inks)} pens, light to "
                          f"dark, ink asked for (mean coverage): {cmyk.shares(layers, inks)}")
    return d, said


def _pictures(path: str, opts: PhotoOptions, w: float, h: float, owned: tuple):
    """(the picture the notes describe, the pens' layers or None, their inks or None): the
    image loaded at its size on the wall, one layer per pen with --cmyk or --colours."""
    from vplotter.inputs.image import load

    tone = dict(pen_mm=opts.pen_mm, contrast=opts.contrast, brightness=opts.brightness,
                invert=opts.invert)
    if opts.cmyk and opts.colours:
        raise ConfigError("error: give --cmyk or --colours, not both")
    if opts.cmyk or opts.colours:
        from vplotter.inputs.image import cmyk

        inks = cmyk.INKS if opts.cmyk else cmyk.inks_for(pens_of(opts.colours, owned))
        layers = cmyk.layers(load.load_rgb(path, w, h, **tone), w, h, os.path.basename(path),
                             inks)
        return layers[-1], layers, inks               # the darkest pen's layer: for the notes
    return load.load(path, w, h, **tone), None, None


def _frame(placement: place.Placement, page: place.Box, w: float, h: float):
    """(the placement, the shift of the picture's centre to the page's, and the matrix A, b
    that then rotates, aligns and offsets it as asked): the picture's frame is placed (the
    same for every density), and must lie on the page."""
    put = replace(placement, fit=False)
    shift = place.origin(page) - np.array([w / 2, h / 2])     # centred where every drawing is
    frame = np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]]) + shift
    A, b = place.matrix(put, frame, page)
    off = place.outside(frame @ A.T + b, page)
    if off >= 0:
        x, y = frame[off] @ A.T + b
        reach = ("" if page.reach is None else
                 f", within {page.reach[2]:g} mm of X{page.reach[0]:g} Y{page.reach[1]:g}")
        raise ConfigError(f"error: the picture ({w:.0f} x {h:.0f} mm) reaches X{x:.1f} Y{y:.1f}, "
                          f"off the page (X {page.x_min:g}..{page.x_max:g}, Y {page.y_min:g}.."
                          f"{page.y_max:g}{reach}): give a smaller --width or --height, or "
                          f"move it (--offset, --align)")
    return put, shift, A, b


@dataclass
class _Drawings:
    """A photo's drawings at a spacing and tone curve: the style's own strokes in picture mm
    (the last DRAWN_KEPT remembered: the fitted curve's first try is one its search already
    drew, and so may be a search's repeat; --style auto's quick score drew the fitted curves
    `pick_curve` draws again when the spacing's own exponent stays the best), placed on the
    page in a quick order (`make`), and in the order they are drawn in (`final`)."""

    style: Callable
    opts: PhotoOptions
    picture: object
    layers: list | None
    inks: tuple | None
    put: place.Placement
    shift: np.ndarray
    A: np.ndarray
    b: np.ndarray
    start_xy: tuple
    how: str                 # the quick order
    improve: bool            # the final order improves it ("best")
    drawn_last: dict = field(default_factory=dict)

    @property
    def extra(self) -> dict:
        return {"tsp": True} if self.opts.tsp else {}

    def draw(self, spacing: float, curve=None):
        """The style's own strokes in picture mm (curve: the tone curve, None: the style's)."""
        key = (spacing, curve)
        drawn_last, opts = self.drawn_last, self.opts
        if key not in drawn_last:
            if self.layers is not None:               # every pen's layer: one budget
                from vplotter.inputs.image import cmyk

                made = cmyk.strokes(self.style, opts.style, self.layers, spacing, opts.pen_mm,
                                    self.inks, **self.extra)
            else:
                made = self.style(self.picture, spacing, opts.pen_mm, **self.extra,
                                  **({} if curve is None else {"curve": curve}))
            while len(drawn_last) >= DRAWN_KEPT:
                drawn_last.pop(next(iter(drawn_last)))
            drawn_last[key] = made
        return drawn_last[key]

    def final(self, placed: list[Stroke]) -> list[Stroke]:
        """A drawing in its quick order -> in the order it is drawn in."""
        return order.order(placed, "best", self.start_xy) if self.improve else placed

    def make(self, spacing: float, curve=None):
        """(placed strokes in a quick order, the style's own strokes in picture mm)."""
        made = self.draw(spacing, curve)
        moved = [replace(s, pts=s.pts + self.shift, line=i + 1) for i, s in enumerate(made)]
        if not self.put.identity:
            moved = place.apply(moved, self.A, self.b)
        return order.order(moved, self.how, self.start_xy), made


@dataclass
class Searched:
    """A style's budget searched on its own tone curve (`searched`): the densest spacing
    within the budget; `finished` goes on from here (the curves, the final order)."""

    d: _Drawings
    plot_time: Callable
    budget_s: float
    lo: float
    hi: float
    w: float
    h: float
    drawn: list              # placed, in the quick order
    raw: list                # the style's own strokes
    choice: budget.Choice
    curve: object            # None: the spacing's own

    def timed(self, made) -> float:
        return self.plot_time(made[0])


def searched(d: _Drawings, plot_time, w: float, h: float):
    """The budget's search on the style's own curve (`_search`) -> `Searched`."""
    opts = d.opts
    s = Searched(d, plot_time, opts.max_time_s or budget.DEFAULT_S,
                 opts.pen_mm * (1.2 if opts.style == "stipple" else 1.0), max(w, h) / 4, w, h,
                 [], [], None, None)
    s.drawn, s.raw, s.choice, s.curve = _search(d, s.timed, s.budget_s, s.lo, s.hi)
    return s


def finished(s: Searched, said: advice.Said):
    """The drawing that fits the budget (and what is said, the style's own strokes, the plot
    time), from its search: the tone curve that draws the picture best, the final order and
    the time it saves spent on density."""
    from vplotter.inputs import image

    d, w, h = s.d, s.w, s.h
    opts, picture, budget_s = d.opts, d.picture, s.budget_s
    drawn, choice, curve = s.drawn, s.choice, s.curve
    if (opts.style in CURVES or opts.tsp) and d.layers is None:
        drawn, choice, curve, why = pick_curve(picture, opts, d.draw, d.make, s.timed,
                                               budget_s, s.lo, s.hi, s.raw, drawn, choice)
        said.details.append(why)
    drawn, choice = budget.fill(drawn, choice, lambda sp: d.make(sp, curve)[0], d.final,
                                s.plot_time, budget_s, s.lo, POWER[opts.kind])
    said.details.append(choice.text())
    said.details.append(image.describe(opts.style, choice.spacing_mm, opts.pen_mm, picture,
                                       **d.extra, **({} if curve is None else {"curve": curve})))
    said.notes.insert(0, advice.chosen(opts.kind, w, h, choice.spacing_mm, choice.time_s,
                                       budget_s, opts.max_time_s is None,
                                       choice.limit.startswith("as dense")))
    said.advice = advice.advise(opts.kind, opts.pen_mm, choice.spacing_mm, w, h, choice.time_s,
                                budget_s, choice.tries)
    return drawn, said, d.draw(choice.spacing_mm, curve), choice.time_s


def _search(d: _Drawings, timed, budget_s: float, lo: float, hi: float):
    """(placed strokes, the style's own strokes, budget.Choice, the tone curve or None): the
    densest spacing within the budget, on the style's own curve, from START_PENS. Stipples
    search on each spacing's own curve (smooth in spacing), then take the walk's curve once,
    at the spacing found, and search again with it."""
    opts = d.opts
    start = START_PENS[opts.kind] * opts.pen_mm
    if not (opts.style == "stipple" and not opts.tsp and d.layers is None):
        (drawn, raw), choice = budget.fit(d.make, timed, budget_s, start, lo, hi,
                                          POWER[opts.kind])
        return drawn, raw, choice, None
    from vplotter.inputs.image import stipple

    def own(sp: float) -> float:
        return stipple.cap_gamma(d.picture, sp, opts.pen_mm)

    (drawn, raw), choice = budget.fit(lambda sp: d.make(sp, own(sp)), timed, budget_s, start,
                                      lo, hi, POWER[opts.kind])
    curve = own(choice.spacing_mm)
    g = stipple.tone_gamma(d.picture, choice.spacing_mm, opts.pen_mm)
    try:
        (drawn, raw), again = budget.fit(lambda sp: d.make(sp, g), timed, budget_s,
                                         choice.spacing_mm, lo, hi, POWER[opts.kind],
                                         most=CURVE_TRIES)
        choice, curve = replace(again, tries=choice.tries + again.tries), g
    except ConfigError:                       # the walk's curve takes longer even sparser
        pass
    return drawn, raw, choice, curve


def pens_of(names: tuple[str, ...], owned: tuple = ()) -> list[tuple[str, str]]:
    """--colours: [(pen, '#rrggbb')], each name a pen in [pens] (its colour) or a colour (a
    pen of that name)."""
    from vplotter.drawing import pens
    from vplotter.inputs import colour as colours

    out: list[tuple[str, str]] = []
    for name in names:
        spec = pens.by_name(owned, name)
        if spec is not None:
            pen = (spec.name, spec.colour)
        else:
            try:
                c = colours.parse(name)
            except ValueError:
                c = None
            if c is None:
                known = f" ([pens]: {', '.join(p.name for p in owned)})" if owned else ""
                raise ConfigError(f"error: --colours: {name!r} is neither a pen in [pens] nor a "
                                  f"colour{known}")
            pen = (name, c)
        if pens.is_white(pen[1]):              # the rule white strokes are left out by
            raise ConfigError(f"error: --colours: {name} is white: it draws nothing on white "
                              f"paper")
        if any(pen[0] == p[0] or pen[1] == p[1] for p in out):
            raise ConfigError(f"error: --colours: {name} is given twice")
        out.append(pen)
    return out
