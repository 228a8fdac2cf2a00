"""Stipples: the picture's darkness as dots (weighted Voronoi stippling), or as one line
through them (TSP art).

Density model. Dots are placed with a density (dots per mm²) of rho(d) / spacing_mm², d the
darkness: rho(d) = d for dots, so that every dot lays the same ink and the ink per area follows
the darkness (dot area x density), and the mean distance between dots is about spacing_mm where
the picture is black (a hexagonal packing of that density has neighbours 1.07 spacing apart).
For the line (tsp=True) the ink per area is the line length per area times the pen width, and a
tour through points of density D has about 0.7 sqrt(D) mm of line per mm²: rho(d) = d² keeps that
proportional to the darkness. N = sum(rho) x pixel area / spacing_mm² dots in all (or `dots`),
so halving spacing_mm quadruples the dots (and doubles the tour's length).

Placement (Secord 2002): N points by inverse-CDF sampling of rho, stratified along a Hilbert
curve through the pixels (an even start: each dot is drawn from its own share of the ink,
visited in a space-filling order), then Lloyd relaxation with rho as the density: the Voronoi
cells are found for a fixed set of SAMPLES_PER_DOT x N samples of rho, drawn the same stratified
way, by a k-d tree query (SciPy's cKDTree), each point moves to its cell's centroid (np.bincount)
until the mean move is under STOP x spacing_mm or after MAX_ITER rounds. The picture is first
reduced (area average) to PX_PER_SPACING pixels per spacing_mm: finer detail than the dots
cannot show.

The tour (Kaplan and Bosch 2005): nearest neighbour (a k-d tree's neighbour lists), improved by
2-opt and or-opt moves between each point and its K nearest neighbours, cut open at its longest
edge. An edge much longer than the spacing the darkness at its ends asks for (GAP times
spacing_mm / sqrt(rho)), or longer than MAX_EDGE x spacing_mm, or running over paper for half a
spacing is a pen lift: the stroke is split there, so no straight line crosses a white area, and
the sparse light areas are drawn in short pieces (the long straight lines of a tour there lay
more ink than the tone asks for: bench/image_stipple.py).

The budget's tone curve (`tone.py`): up to CAP_PENS pen widths (2.5 mm) the dots follow the darkness
as above. A coarser spacing (a scarce budget) places as many dots as it asks for with the density
rho(f(d)), f(d) = (1 - tone.EPS) d^gamma + tone.EPS d, gamma the smallest from FLOOR_GAMMA up that
brings them CAP_PENS pen widths together in black (`cap_gamma`): dots 6 mm apart over every tone are
seen as dots, not tone (correlation of ink with darkness 0.08 at a 1 mm blur on a photo of a cat in
1 h; 0.49 so), and the floor tone.EPS d keeps a few dots in every tone above white, more where
darker. The dots' count does not depend on gamma (nor on any `curve` given: as many dots, placed on
the curve's density). This is the dots' curve with fit=False, where `chosen` starts for the dots,
and where the tour's choice starts: the tour's curve is chosen per picture as the line styles' are
(`drawing/photo.py`: this exponent, / and x 1.6, then curves fitted to the tour's own measured
response, each fitted to the budget and scored), which put it ahead of `hatched` at 3 h
(bench/photo_tone.py, 300 mm, 3 h: the camera 0.725 -> 0.936, the Hubble deep field 0.233 -> 0.519;
by the converter's own score the retina 0.39 -> 0.88).

The dots (not the tour; `chosen`) are then fitted to the picture per picture, as it is seen:
each of a few tone curves d^gamma (gamma 1, 2, 4 ... 64, walked from the spacing's own / 2
while a neighbour gains) places the dots as above and `stipple_fit` moves them by gradient
ascent on the correlation of their ink, blurred at about a millimetre, with the blurred
darkness of the picture as given (before any curve), letting the dots where ink is least
wanted jump to where it is most wanted; the curve whose dots reach the best correlation (on
0.5 mm cells, within 0.003 of bench/photo_tone.py) is kept, and its dots get a few finer
rounds. A floor of dots per tone never jumps (`_floor`), so every tone above white keeps a
few dots, more where darker. Same count of dots, so about the same plot time; at a budget's
few dots this raised the correlation by a tenth to a fifth (bench/photo_tone.py, 300 mm, 1 h:
camera 0.56 -> 0.65, coffee 0.49 -> 0.59, rocket 0.27 -> 0.36; 3 h: camera 0.83 -> 0.91).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from vplotter.errors import ConfigError
from vplotter.inputs.image import stipple_fit, tone
from vplotter.inputs.image.picture import Picture
from vplotter.inputs.image.stipple_tour import kdtree, split, tour
from vplotter.inputs.strokes import Stroke

PX_PER_SPACING = 4      # reduced grid: pixels per spacing_mm
SAMPLES_PER_DOT = 8     # Lloyd: density samples per dot (the Voronoi cells are measured by them)
MAX_ITER = 30           # Lloyd rounds at most
STOP = 0.05             # ... or until the root-mean-square move is below STOP x spacing_mm
INSET = 1e-6            # mm: points strictly inside the picture
CAP_PENS = 5.0          # a coarser spacing: the same dots on the darker tones, this far apart
                        # in black
GAMMA_MAX = 64.0        # ... by the tone curve d^gamma, gamma at most this
FLOOR_GAMMA = 8.0       # ... and at least this


def strokes(picture: Picture, spacing_mm: float, pen_mm: float, tsp: bool = False,
            seed: int = 0, dots: int | None = None, dot_mm: float | None = None,
            fit: bool = True, curve=None, **_) -> list[Stroke]:
    """Stipples of `picture`: one 1-point stroke (a dot: the pen taps) per stipple, on the
    tone curve that draws this picture best (or d^curve; the tour and fit=False: an exponent
    or a tone.Table, default the spacing's own, `cap_gamma`) and moved to draw its tone best as
    seen (`chosen`; fit=False: the spacing's own curve, as Lloyd left them); with
    dot_mm > pen_mm a small filled circle of that diameter instead; with tsp=True the tour
    through all of them, split where it would cross light paper (see the module's text)."""
    gamma, given, asked = (2.0 if tsp else 1.0), picture, spacing_mm
    if fit and not tsp:
        if not spacing_mm > 0:
            raise ConfigError(f"error: stipple spacing must be > 0 mm (got {spacing_mm})")
        return _dots(chosen(picture, spacing_mm, pen_mm, seed, dots, curve)[1], picture,
                     pen_mm, dot_mm)
    if curve is None and dots is None and spacing_mm > CAP_PENS * pen_mm:
        curve = cap_gamma(picture, spacing_mm, pen_mm, tsp)      # on the darker tones
    if curve is not None and not (isinstance(curve, (int, float)) and curve <= 1):
        dots = _dot_count(picture, spacing_mm, gamma) if dots is None else dots
        if dots <= 0:                     # as many dots as the spacing asks for, on the curve
            return []
        picture = Picture(tone.curve(picture.darkness, curve), picture.width_mm,
                          picture.height_mm, picture.name)
        spacing_mm = _black_spacing(picture, spacing_mm, dots, gamma)
    pts = points(picture, spacing_mm, seed=seed, dots=dots, gamma=gamma)
    if len(pts) == 0:
        return []
    if tsp:
        path = pts[tour(pts)]
        return [Stroke(p) for p in split(path, picture, spacing_mm, gamma, given, asked)]
    return _dots(pts, picture, pen_mm, dot_mm)


def _dots(pts: np.ndarray, picture: Picture, pen_mm: float, dot_mm: float | None) -> list[Stroke]:
    """One stroke per dot, in the order of the tour through them (its 2-opt looks at every
    dot's nearest neighbours: on random dots the hops are 13 % shorter than a greedy order and
    5 % to 7 % shorter than `order.py`'s best; on the camera's hour of dots 7 % shorter than
    the best): a tap of the pen, or with dot_mm > pen_mm a small filled circle."""
    if len(pts) == 0:
        return []
    pts = pts[tour(pts)]
    if dot_mm is not None and dot_mm > pen_mm:
        return _circles(pts, picture, dot_mm, pen_mm)
    return [Stroke(p[None, :].copy()) for p in pts]


def _ink_area(picture: Picture, spacing_mm: float, gamma: float) -> float:
    """The picture's area weighted by its density rho^gamma (mm²), on the grid of spacing_mm:
    that area / spacing² dots put them spacing_mm apart where the picture is black."""
    rho, gx, gy = _grid(picture, spacing_mm)
    return float((np.clip(rho, 0, 1) ** gamma).sum()) * gx * gy


def _dot_count(picture: Picture, spacing_mm: float, gamma: float) -> int:
    return int(round(_ink_area(picture, spacing_mm, gamma) / spacing_mm ** 2))


def _black_spacing(picture: Picture, spacing_mm: float, dots: int, gamma: float) -> float:
    """The distance between `dots` dots where the picture is black (density rho / spacing²)."""
    return max(math.sqrt(_ink_area(picture, spacing_mm, gamma) / max(dots, 1)), 1e-3)


def chosen(picture: Picture, spacing_mm: float, pen_mm: float, seed: int = 0,
           dots: int | None = None, gamma: float | None = None
           ) -> tuple[float, np.ndarray, float]:
    """(gamma, the dots, their correlation) of the tone curve d^gamma that draws `picture`
    best with the dots `spacing_mm` asks for (or `dots`): each curve tried places them (Lloyd
    over the curve's density, the spacing in black from the count as in `strokes`), moves them
    with `stipple_fit` to follow the picture's own tone as seen, and is judged by the
    correlation that reaches. A walk over gamma in factors of CHOICE_STEP from the spacing's
    own exponent / CHOICE_STEP (`cap_gamma`; at least 1, at most GAMMA_MAX): that one and its
    two neighbours, then on while a neighbour gains; `gamma` given: that curve alone (the
    budget's search keeps one curve, so that the plot time does not jump with the spacing
    where the walk would change its mind). A pure function of its arguments (the last
    answers for a picture are remembered: `describe` asks again for the spacing the budget
    chose)."""
    n = _dot_count(picture, spacing_mm, 1.0) if dots is None else int(dots)
    key = (spacing_mm, pen_mm, seed, n, gamma)
    walked = key[:-1] + (None,)
    for pic, k, answer in _memo:          # (a curve the walk chose here: the same dots)
        if pic is picture and (k == key or k == walked and answer[0] == gamma):
            return answer
    if n <= 0:
        return 1.0, np.zeros((0, 2)), 0.0
    tried: dict[int, tuple[float, np.ndarray, float]] = {}

    def placed(g: float) -> tuple[float, np.ndarray, float]:
        q = picture if g == 1 else Picture(tone.curve(picture.darkness, g),
                                           picture.width_mm, picture.height_mm)
        pts = points(q, _black_spacing(q, spacing_mm, n, 1.0), seed=seed, dots=n)
        pts = stipple_fit.fitted(pts, picture.darkness, picture.width_mm,
                                 picture.height_mm, stay=_floor(pts, picture, g))[0]
        return g, pts, stipple_fit.correlation(pts, picture.darkness, picture.width_mm,
                                               picture.height_mm)

    def at(k: int) -> float:
        if k not in tried:
            tried[k] = placed(min(CHOICE_STEP ** k, GAMMA_MAX))
        return tried[k][2]

    if gamma is not None:
        g, pts, r = placed(float(gamma))
    else:
        top = int(math.ceil(math.log(GAMMA_MAX) / math.log(CHOICE_STEP) - 1e-9))
        g0 = cap_gamma(picture, spacing_mm, pen_mm, False, n)
        k = min(max(int(round(math.log(g0) / math.log(CHOICE_STEP))) - 1, 0), top)
        for way in (-1, 1):                              # on while a neighbour gains
            while 0 <= k + way <= top and at(k + way) > at(k):
                k += way
        g, pts, r = tried[max(tried, key=lambda j: (tried[j][2], -j))]
    pts, r = stipple_fit.fitted(pts, picture.darkness, picture.width_mm, picture.height_mm,
                                FINE_ROUNDS, FINE_STEP_MM, FINE_CELL_MM, teleport=False)
    best = (g, pts, r)
    _memo[:] = [m for m in _memo if m[0] is picture][-(MEMO - 1):] + [(picture, key, best)]
    return best


def _floor(pts: np.ndarray, picture: Picture, g: float) -> np.ndarray:
    """(N,) bool: the dots that stay in their tone (`stipple_fit` moves them but never makes
    them jump), so that every tone above white keeps a few dots, more where darker: the curve's
    floor tone.EPS d of f(d) = (1 - EPS) d^g + EPS d, each dot one with the chance
    max(1 - d, 1/2) EPS d / f(d) at its darkness d (a golden-ratio sequence: deterministic,
    even). The factor frees up to half of the floor in the darker tones, which their own dots
    keep inked (the full floor cost the correlation 0.01 to 0.03 at 1 h: camera 0.657 ->
    0.623; without it the two lightest bands of the grey ramp were blank at 1 h), and keeps
    the floor's dots rising with darkness (with 1 - d alone, d (1 - d) falls above d = 1/2:
    the ramp's bands of darkness 0.21 and 0.55 got 5 and 7 dots at 1 h, now 3 and 11; the
    camera's dots score 0.656 against 0.658)."""
    d = np.clip(picture.at(pts), 0.0, 1.0)
    f = (1 - tone.EPS) * d ** g + tone.EPS * d
    share = np.divide(tone.EPS * d, f, out=np.zeros_like(d), where=f > 0)
    share *= np.maximum(1 - d, 0.5)
    return np.modf((np.arange(len(pts)) + 1) * 0.6180339887498949)[0] < share


_memo: list = []              # (picture, key, answer) of the last MEMO `chosen` of a picture
MEMO = 12
CHOICE_STEP = 2.0             # the curves `chosen` tries: gamma 1, 2, 4 ... GAMMA_MAX
FINE_ROUNDS, FINE_STEP_MM, FINE_CELL_MM = 40, 0.2, 0.5   # the chosen dots' last rounds


def tone_gamma(picture: Picture, spacing_mm: float, pen_mm: float, tsp: bool = False,
               dots: int | None = None) -> float:
    """The tone curve's exponent the stipples take: the dots' `chosen` one; the tour's the
    spacing's own (`cap_gamma`)."""
    if tsp:
        return cap_gamma(picture, spacing_mm, pen_mm, True, dots)
    return chosen(picture, spacing_mm, pen_mm, dots=dots)[0]


def cap_gamma(picture: Picture, spacing_mm: float, pen_mm: float, tsp: bool = False,
               dots: int | None = None) -> float:
    """The tone curve's exponent: 1 up to CAP_PENS pen widths; coarser, the smallest from
    FLOOR_GAMMA to GAMMA_MAX that brings the dots the spacing asks for to CAP_PENS pen widths
    apart in black (the dots a scarce budget buys read as a tone only that close). Cheap, and
    it changes smoothly with the spacing: the curve the budget's search draws the dots on."""
    cap = CAP_PENS * pen_mm
    if not spacing_mm > cap:
        return 1.0
    gamma = 2.0 if tsp else 1.0
    dots = max(1, _dot_count(picture, spacing_mm, gamma) if dots is None else dots)
    small = _grid(picture, cap)[0][::2, ::2]

    def black(g):
        q = Picture(tone.curve(small, g), picture.width_mm, picture.height_mm)
        return _black_spacing(q, cap, dots, gamma)

    lo, hi = FLOOR_GAMMA, GAMMA_MAX
    if black(hi) > cap:
        return hi
    if black(lo) <= cap:
        return lo
    for _ in range(10):                      # bisection on log(gamma)
        mid = math.sqrt(lo * hi)
        if black(mid) > cap:
            lo = mid
        else:
            hi = mid
    return hi


# ------------------------------------------------------------------ placement
def points(picture: Picture, spacing_mm: float, seed: int = 0, dots: int | None = None,
           gamma: float = 1.0, iterations: int = MAX_ITER) -> np.ndarray:
    """(N, 2) stipple positions in G-code mm, strictly inside the picture (iterations=0: the
    initial sample, before Lloyd)."""
    if not spacing_mm > 0:
        raise ConfigError(f"error: stipple spacing must be > 0 mm (got {spacing_mm})")
    cKDTree = kdtree()
    rho, gx, gy = _grid(picture, spacing_mm)
    rho = np.clip(rho, 0.0, 1.0) ** gamma
    n = int(round(float(rho.sum()) * gx * gy / spacing_mm ** 2)) if dots is None else int(dots)
    if n <= 0 or not rho.max() > 0:
        return np.zeros((0, 2))
    rng = np.random.default_rng(seed)
    cdf = _Cdf(rho, gx, gy, picture.height_mm)
    pts = cdf.sample(n, rng)
    if iterations > 0:
        samples = cdf.sample(SAMPLES_PER_DOT * n, rng)
        for _ in range(iterations):
            _, idx = cKDTree(pts).query(samples, workers=-1)
            cnt = np.bincount(idx, minlength=n)
            has = cnt > 0
            new = pts.copy()
            new[has, 0] = np.bincount(idx, samples[:, 0], n)[has] / cnt[has]
            new[has, 1] = np.bincount(idx, samples[:, 1], n)[has] / cnt[has]
            move = math.sqrt(float(np.mean(np.sum((new - pts) ** 2, axis=1))))
            pts = new
            if move < STOP * spacing_mm:
                break
    hi = np.array([picture.width_mm, picture.height_mm]) - INSET
    return np.clip(pts, INSET, hi)


def _grid(picture: Picture, spacing_mm: float) -> tuple[np.ndarray, float, float]:
    """The darkness area-averaged to about PX_PER_SPACING pixels per spacing_mm (never finer
    than the picture), with the pixel's width and height in mm."""
    d = np.asarray(picture.darkness, dtype=np.float32)
    h, w = d.shape
    f = spacing_mm / PX_PER_SPACING / picture.mm_per_px
    if f > 1.5:
        from PIL import Image
        w2, h2 = max(1, round(w / f)), max(1, round(h / f))
        d = np.asarray(Image.fromarray(d, mode="F").resize((w2, h2), Image.BOX))
        h, w = d.shape
    return d, picture.width_mm / w, picture.height_mm / h


class _Cdf:
    """Inverse-CDF sampling of a density grid, stratified along a Hilbert curve: sample k of m
    falls in the k-th m-th of the ink, pixels visited in a space-filling order, so samples are
    spread evenly (no clumps, no holes) and each is uniform within its pixel."""

    def __init__(self, rho: np.ndarray, gx: float, gy: float, height_mm: float):
        h, w = rho.shape
        every = _pixel_order(h, w)
        self.order = every[rho.ravel()[every] > 0]
        self.cum = np.cumsum(rho.ravel()[self.order], dtype=np.float64)
        self.w, self.gx, self.gy, self.top = w, gx, gy, height_mm

    def sample(self, m: int, rng: np.random.Generator) -> np.ndarray:
        t = (np.arange(m) + rng.random(m)) * (self.cum[-1] / m)
        k = np.minimum(np.searchsorted(self.cum, t, side="right"), len(self.cum) - 1)
        r, c = np.divmod(self.order[k], self.w)
        u = rng.random((m, 2))
        return np.column_stack([(c + u[:, 0]) * self.gx, self.top - (r + u[:, 1]) * self.gy])


@functools.lru_cache(maxsize=3)
def _pixel_order(h: int, w: int) -> np.ndarray:
    """The flat indices of an (h, w) grid's pixels along a Hilbert curve (the budget's tries
    and the tone curves tried draw on the same grid: computed once)."""
    r, c = np.divmod(np.arange(h * w), w)
    out = np.argsort(_hilbert(c, r, max(h, w)), kind="stable").astype(np.int32)
    out.flags.writeable = False
    return out


def _hilbert(x: np.ndarray, y: np.ndarray, size: int) -> np.ndarray:
    """Position along a Hilbert curve of integer cells (x, y) in [0, size)²."""
    n = 1 << max(1, int(math.ceil(math.log2(max(size, 2)))))
    x, y = np.asarray(x, dtype=np.int64).copy(), np.asarray(y, dtype=np.int64).copy()
    d = np.zeros(x.shape, dtype=np.int64)
    s = n >> 1
    while s > 0:
        rx = (x & s) > 0
        ry = (y & s) > 0
        d += s * s * ((3 * rx.astype(np.int64)) ^ ry.astype(np.int64))
        flip = ~ry & rx
        x = np.where(flip, n - 1 - x, x)
        y = np.where(flip, n - 1 - y, y)
        swap = ~ry
        x, y = np.where(swap, y, x), np.where(swap, x, y)
        s >>= 1
    return d


def _circles(pts: np.ndarray, picture: Picture, dot_mm: float, pen_mm: float) -> list[Stroke]:
    """A filled disc of diameter dot_mm per point: a spiral out from the centre (turns at most
    0.9 pen apart) closed by a full circle whose line's outer edge is the disc's edge."""
    r = (dot_mm - pen_mm) / 2
    turns = max(1, math.ceil(r / (0.9 * pen_mm)))
    per_turn = max(8, math.ceil(2 * math.pi * r / 0.3))
    a = np.linspace(0, 2 * math.pi * turns, turns * per_turn + 1)
    rad = a / a[-1] * r
    ring = np.linspace(0, 2 * math.pi, per_turn + 1)[1:]
    a, rad = np.concatenate([a, a[-1] + ring]), np.concatenate([rad, np.full(per_turn, r)])
    shape = np.column_stack([rad * np.cos(a), rad * np.sin(a)])
    lo = r + INSET
    hi = np.array([picture.width_mm, picture.height_mm]) - lo
    if np.any(hi < lo):
        raise ConfigError(f"error: stipple dots of {dot_mm} mm do not fit the picture")
    pts = np.clip(pts, lo, hi)
    return [Stroke(p + shape) for p in pts]
