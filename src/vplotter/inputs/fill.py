"""Fills: the filled regions a reader finds, hatched on the wall.

A reader (SVG) gives each filled element as a `Region`: its rings (all its subpaths, flattened, in
the G-code mm of the default placement; an open subpath is closed for the fill), its fill rule, its
pen and colour, and where in the drawing's strokes its hatching goes (just before its outline: SVG
paints the fill, then the stroke). Once the placement (A, b: x -> A x + b) is known, `merge` hatches
the rings as placed and maps the lines back into the drawing's frame, so that placing the drawing
puts them where they were made: `spacing_mm` and `angle_deg` are on the wall whatever `--scale`,
`--fit`, `--width` or `--rotate` do: lines `spacing_mm` apart, at `angle_deg` counter-clockwise from
+X, on a grid fixed to G-code X0 Y0 (two shapes side by side share their lines). The hatcher is
`inputs/hatch.py`, the one the photos' hatch style uses; its lines are joined back and forth where
the move stays inside the region and is at most `LINK_SPACINGS` spacings long.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from vplotter.errors import ConfigError
from vplotter.inputs.strokes import Stroke

MODES = ("none", "outline", "hatch")
LINK_SPACINGS = 4.0
MAX_LINES = 200_000           # hatch lines across one shape: beyond, --fill-spacing is a typo


@dataclass(frozen=True)
class FillOptions:
    mode: str = "outline"         # none | outline | hatch
    spacing_mm: float = 0.5       # between hatch lines, on the wall
    angle_deg: float = 45.0       # of the hatch lines, on the wall
    spacing_given: bool = False   # --fill-spacing given (else a pen's own width may replace it)

    @classmethod
    def from_args(cls, args) -> "FillOptions":
        """--fill, --fill-spacing (default --pen-width, else 0.5), --fill-angle (default 45)."""
        spacing = getattr(args, "fill_spacing", None) or getattr(args, "pen_width", None) or 0.5
        angle = getattr(args, "fill_angle", None)
        return cls(mode=getattr(args, "fill", None) or "outline", spacing_mm=spacing,
                   angle_deg=45.0 if angle is None else angle,
                   spacing_given=getattr(args, "fill_spacing", None) is not None)


@dataclass
class Region:
    rings: list                   # (K, 2) arrays, G-code mm (default placement)
    rule: str                     # "nonzero" | "evenodd"
    pen: str | None
    colour: str | None
    at: int                       # its hatching goes before drawing.strokes[at]
    line: int = 0
    layer: str | None = None
    src: str | None = None


def hatch(region: Region, opts: FillOptions, A=None, b=None) -> list[Stroke]:
    """The hatch strokes of one region, made on its rings mapped by x -> A x + b (the wall)
    and given back in the rings' own frame, `opts.spacing_mm` apart."""
    from vplotter.inputs.hatch import hatch_polygons

    A = np.eye(2) if A is None else np.asarray(A, dtype=float)
    b = np.zeros(2) if b is None else np.asarray(b, dtype=float)
    rings = [r @ A.T + b for r in region.rings if len(r) >= 3]
    if not rings:
        return []
    a = np.radians(opts.angle_deg)
    v = np.concatenate(rings) @ np.array([-np.sin(a), np.cos(a)])
    if np.ptp(v) / opts.spacing_mm > MAX_LINES:
        raise ConfigError(f"error: --fill-spacing {opts.spacing_mm:g} mm is too fine: "
                          f"{region.src or 'a shape'} would take more than {MAX_LINES:,} "
                          f"hatch lines")
    lines = hatch_polygons(rings, opts.spacing_mm, opts.angle_deg, region.rule,
                           max_link_mm=LINK_SPACINGS * opts.spacing_mm)
    back = np.linalg.inv(A).T
    return [Stroke((p - b) @ back, region.line, 0, None, region.layer, region.src, region.pen,
                   region.colour) for p in lines]


def merge(strokes: list[Stroke], regions: list[Region], opts: FillOptions,
          placement=None, spacing_of=None) -> list[Stroke]:
    """The strokes with each region's hatching (in their frame) before its outline.
    `placement(points) -> (A, b)`: the placement the strokes will get (None: none);
    `spacing_of(region) -> mm or None`: a region's own spacing (its pen's width) where
    --fill-spacing was not given."""
    if not regions or opts.mode != "hatch" or not strokes:
        return strokes
    A, b = None, None
    if placement is not None:
        A, b = placement(np.concatenate([s.pts for s in strokes]))
    out: list[Stroke] = []
    k = 0
    for reg in sorted(regions, key=lambda r: r.at):
        out.extend(strokes[k:reg.at])
        k = max(k, reg.at)
        own = None if spacing_of is None or opts.spacing_given else spacing_of(reg)
        out.extend(hatch(reg, opts if own is None else replace(opts, spacing_mm=own), A, b))
    out.extend(strokes[k:])
    return out


def one_pen_per_colour(strokes: list[Stroke], regions: list[Region]):
    """(strokes, regions) with each colour one pen, named as the file first writes it."""
    from vplotter.inputs.svg_paint import unify

    names = unify([(s.pen, s.colour) if s.pen else None for s in strokes] +
                  [(r.pen, r.colour) if r.pen else None for r in regions])
    if not names:
        return strokes, regions
    return ([replace(s, pen=names.get(s.pen, s.pen)) for s in strokes],
            [replace(r, pen=names.get(r.pen, r.pen)) for r in regions])
