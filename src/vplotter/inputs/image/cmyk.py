"""Colour photos in several pens: `--cmyk` (yellow, cyan, magenta, black) or `--colours`
(the pens a person owns, by name or colour).

CMYK separation, in linear light, with ideal inks that multiply on white paper: cyan takes red
away, magenta green, yellow blue, black all three, so a pixel (r, g, b) asks for the
coverages c0 = 1 - r, m0 = 1 - g, y0 = 1 - b of the three colour inks alone. Full grey
component replacement (GCR, the grey part of the colour all in black): k = min(c0, m0, y0),
and each colour ink covers what is left under the black, c = (c0 - k) / (1 - k) (likewise
m, y), so that (1 - c)(1 - k) = r exactly: a grey pixel is drawn in black alone, a saturated
colour in at most two colour inks (pure red: magenta and yellow), and no pixel asks for all
four. With line art that is also the cheapest split: one line of black in place of three
crossed colour lines.

Any other set of pens (`--colours black,red,#2050c0`, `separate_pens`): pen k with linear
colour p_k takes u_k = 1 - p_k of each channel away where it covers the paper, and the
coverages a (0..1 per pen) of a pixel are those whose absorption U a comes nearest the
pixel's, 1 - (r, g, b), with a small cost LAMBDA for every unit of coverage (least squares
on the box, a convex problem: FISTA, projected gradient with momentum, SOLVE_ROUNDS rounds).
The cost is what makes it choose as GCR does: grey in the black pen alone (one line where
three colour lines would do the same), and among pens that could make a colour, the fewest
lines. It is solved once per pen set for BINS levels of each sRGB-encoded channel and
interpolated (trilinear) per pixel. Colours no pen mix can make
come out as the nearest mix (with black and red pens, a green leaf is dark grey).

Each layer is then drawn in the chosen style as its own picture (`darkness` = that ink's
coverage), at one density for all (the budget's knob, so the plot-time budget covers the
pens together), at its own angle so the layers do not fall on each other's lines: hatch at the
printers' screen angles for CMYK (yellow 0, cyan 15, magenta 75, black 45 degrees, each with
its crossings) and 180/n degrees apart for n other pens (the darkest at 45), the spiral turned
by 1/n turn per layer (its tracks 1/n pitch apart), the squiggle's rows 1/n pitch apart,
stipples from their own random start. Every stroke names its pen (`Stroke.pen`: 'yellow',
'cyan', 'magenta', 'black', or the name given) and the pen's colour (`Stroke.colour`), its
layer the pen (so ordering keeps each pen's strokes together), and the layers come light to
dark (a dark line is not smeared by a later light pen).
"""

from __future__ import annotations

import numpy as np

from vplotter.inputs.image.picture import Picture

# (pen, colour, hatch screen angle in degrees), light to dark
INKS = (("yellow", "#ffff00", 0.0), ("cyan", "#00ffff", 15.0),
        ("magenta", "#ff00ff", 75.0), ("black", "#000000", 45.0))
LAMBDA = 0.02           # separate_pens: the cost of a unit of coverage (prefers fewer lines)
SOLVE_ROUNDS = 300      # ... FISTA rounds
BINS = 32               # ... levels per sRGB-encoded channel the table is solved for


def separate(rgb) -> np.ndarray:
    """(4, H, W) coverage 0..1 of yellow, cyan, magenta and black (INKS' order) of linear-light
    rgb (3, H, W) on white paper (full GCR, see the module's text)."""
    rgb = np.clip(np.asarray(rgb, dtype=np.float32), 0, 1)
    cmy = 1 - rgb                                   # c0, m0, y0
    k = cmy.min(axis=0)
    left = np.maximum(1 - k, np.float32(1e-6))
    c, m, y = np.clip((cmy - k) / left, 0, 1)
    c, m, y = (np.where(k >= 1 - 1e-6, 0, v) for v in (c, m, y))
    return np.stack([y, c, m, k]).astype(np.float32)


def inks_for(pens: list[tuple[str, str]]) -> tuple:
    """The inks (pen, colour, hatch angle) of `--colours` pens [(name, '#rrggbb')], light to
    dark; the darkest hatched at 45 degrees, the others 180/n apart from it."""
    from vplotter.inputs import colour as colours

    order = sorted(range(len(pens)), key=lambda i: -colours.lightness(pens[i][1]))
    n = len(pens)
    return tuple((pens[i][0], pens[i][1], (45.0 + 180.0 * (n - 1 - j) / n) % 180.0)
                 for j, i in enumerate(order))


def coverages(absorb: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(M, K) coverages 0..1 of K pens whose absorption per channel is absorb (K, 3), for
    M wanted absorptions target (M, 3): min |a U - t|^2 / 2 + LAMBDA sum(a) on the box (FISTA)."""
    u = np.asarray(absorb, dtype=np.float64)
    t = np.asarray(target, dtype=np.float64)
    gram = u @ u.T
    step = 1.0 / max(float(np.linalg.eigvalsh(gram).max()), 1e-9)
    lin = t @ u.T - LAMBDA                       # the gradient is a gram - lin
    a = np.zeros((len(t), len(u)))
    y, q = a.copy(), 1.0
    for _ in range(SOLVE_ROUNDS):
        nxt = np.clip(y - step * (y @ gram - lin), 0.0, 1.0)
        q2 = (1 + np.sqrt(1 + 4 * q * q)) / 2
        y = nxt + ((q - 1) / q2) * (nxt - a)
        a, q = nxt, q2
    return a


def separate_pens(rgb, inks) -> np.ndarray:
    """(n, H, W) coverage 0..1 of each of the inks (pen, '#rrggbb', angle) of linear-light rgb
    (3, H, W) on white paper (see the module's text)."""
    from vplotter.inputs import colour as colours
    from vplotter.inputs.image.load import srgb_decode, srgb_encode

    absorb = np.array([[1.0 - c for c in colours.linear_rgb(colour)] for _, colour, _ in inks])
    levels = srgb_decode(np.arange(BINS) / (BINS - 1))
    grid = np.stack(np.meshgrid(levels, levels, levels, indexing="ij"), -1).reshape(-1, 3)
    table = coverages(absorb, 1.0 - grid).astype(np.float32)          # (BINS**3, n)
    x = srgb_encode(np.clip(np.asarray(rgb, dtype=np.float32), 0, 1)) * (BINS - 1)
    lo = np.minimum(np.floor(x).astype(np.int64), BINS - 2)
    f = (x - lo).astype(np.float32)
    out = np.zeros((len(inks),) + x.shape[1:], dtype=np.float32)
    for corner in range(8):                        # trilinear between the table's levels
        bits = [(corner >> c) & 1 for c in range(3)]
        idx = ((lo[0] + bits[0]) * BINS + lo[1] + bits[1]) * BINS + lo[2] + bits[2]
        w = np.prod([f[c] if bits[c] else 1 - f[c] for c in range(3)], axis=0)
        out += np.moveaxis(table[idx], -1, 0) * w
    return np.where(out < 1e-3, np.float32(0), np.minimum(out, 1))     # (the solver's dust)


def layers(rgb, width_mm: float, height_mm: float, name: str = "<image>",
           inks: tuple = INKS) -> list[Picture]:
    """One picture per ink (in the inks' order), its darkness that ink's coverage."""
    parts = separate(rgb) if inks == INKS else separate_pens(rgb, inks)
    return [Picture(np.ascontiguousarray(a), float(width_mm), float(height_mm), name)
            for a in parts]


def layer_options(style: str, index: int, inks: tuple = INKS) -> dict:
    """The keyword arguments that keep layer `index` of len(inks) off the others' lines in
    `style`."""
    n = len(inks)
    if style == "hatch":
        return {"angle_deg": inks[index][2]}
    if style == "flow":                  # own flat-area direction, own seeds
        return {"angle_deg": inks[index][2], "phase": index / n}
    if style == "spiral":
        return {"turn_deg": 360.0 * index / n}
    if style == "squiggle":
        return {"phase": (index + 0.5) / n - 0.5}
    if style == "stipple":               # own random start; dots as Lloyd leaves them (fitting
        return {"seed": index, "fit": False}   # them per layer nearly doubled the time)
    return {}


def strokes(style_fn, style: str, pictures: list[Picture], spacing_mm: float, pen_mm: float,
            inks: tuple = INKS, **extra) -> list:
    """Every layer in `style` at this spacing, light to dark, each stroke with its pen, colour
    and layer set."""
    from dataclasses import replace

    out = []
    for i, ((pen, colour, _), pic) in enumerate(zip(inks, pictures)):
        if not pic.darkness.max() > 0:
            continue
        made = style_fn(pic, spacing_mm, pen_mm, **extra, **layer_options(style, i, inks))
        out += [replace(s, pen=pen, colour=colour,
                        layer=f"{pen} {s.layer}" if s.layer else pen) for s in made]
    return out


def shares(pictures: list[Picture], inks: tuple = INKS) -> str:
    """The mean coverage each ink is asked for (for `info`)."""
    return ", ".join(f"{pen} {float(p.darkness.mean()):.2f}"
                     for (pen, _, _), p in zip(inks, pictures))
