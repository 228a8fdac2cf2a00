"""The file options (placement, order, layers, pens, photos, fills) that every command taking
a drawing file has: their argparse group, what they mean for `prepare` (placement, the photo and
fill options, the join limit), which readers take which of them (`GROUPS`), and the key a resume
compares (`options_key`)."""

from __future__ import annotations

import argparse
import math
from typing import Callable

from vplotter.drawing import pen_options
from vplotter.errors import ConfigError
from vplotter.inputs.image import CHOICES as PHOTO_STYLES

# ------------------------------------------------------------------ options
def _number(kind: str, lo: float | None = None, above: bool = False):
    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{kind} must be a number (got {text!r})") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{kind} must be finite (got {text!r})")
        if lo is not None and (v <= lo if above else v < lo):
            raise argparse.ArgumentTypeError(
                f"{kind} must be {'above' if above else 'at least'} {lo:g} (got {text!r})")
        return v
    parse.__name__ = kind
    return parse


VERBOSE_HELP = "say more: every warning, and a photo's tone details"


def add_file_options(p: argparse.ArgumentParser, verbose: bool = True) -> None:
    """Placement, order and layer options, for every command that takes a drawing file, and
    --verbose (verbose=False: the command has its own, `draw`'s)."""
    if verbose:
        p.add_argument("--verbose", action="store_true", help=VERBOSE_HELP)
    g = p.add_argument_group("placement (scale and rotate about the drawing's centre, then fit, "
                             "align, offset; the result is checked against the page)")
    size = g.add_mutually_exclusive_group()
    size.add_argument("--scale", type=_number("scale", 0, above=True), metavar="S",
                      help="scale about the drawing's centre")
    size.add_argument("--fit", action="store_true",
                      help="the largest size inside the page (aspect kept), centred")
    g.add_argument("--width", type=_number("width", 0, above=True), metavar="MM",
                   help="scale so the drawing is MM wide (a photo: its size on the wall)")
    g.add_argument("--height", type=_number("height", 0, above=True), metavar="MM",
                   help="scale so the drawing is MM high (with --width: the largest inside both)")
    g.add_argument("--rotate", type=_number("angle"), metavar="DEG",
                   help="rotate counter-clockwise about the drawing's centre")
    g.add_argument("--margin", type=_number("margin", 0), default=0.0, metavar="MM",
                   help="keep this far inside the page edges with --fit/--align/--valign")
    g.add_argument("--align", choices=("left", "center", "right"),
                   help="put the drawing on the page's left edge, centre or right edge")
    g.add_argument("--valign", choices=("top", "middle", "bottom"),
                   help="put the drawing on the page's top edge, middle or bottom edge")
    g.add_argument("--offset", type=_number("offset"), nargs=2, metavar=("X", "Y"),
                   help="move by X Y mm, last")
    o = p.add_argument_group("order and layers")
    o.add_argument("--order", choices=("keep", "greedy", "best"),
                   help="stroke order: keep the file's, greedy nearest neighbour, or best "
                        "(default: best for SVG and DXF, keep for G-code)")
    o.add_argument("--join", type=_number("join", 0), default=None, metavar="MM",
                   help="draw on without lifting the pen when the next stroke starts within MM "
                        "of where the previous one ended; at most (and by default) the "
                        "flattening tolerance, 0.75 x tolerance_mm (0.0075 mm at 0.01), so a "
                        "join never draws farther from the file than a chord; 0: never")
    o.add_argument("--layer", action="append", metavar="NAME",
                   help="draw only this SVG layer (label or id) or DXF layer; repeatable")
    o.add_argument("--pause-between-layers", action="store_true",
                   help="lift the pen after each layer and wait for Enter (change the pen)")
    pen_options.add(o)              # --pen-order, --refill-every (drawing/pens.py)
    ph = p.add_argument_group("photos (PNG, JPEG, WebP, BMP, TIFF, GIF: darkness drawn as line "
                              "art, at a density that fits the plot-time budget)")
    ph.add_argument("--style", choices=PHOTO_STYLES,
                    help="hatch: crosshatched tone bands; spiral: one pulsing spiral; stipple: "
                         "dots (--tsp: one tour); squiggle: rows of zigzags; flow: lines "
                         "along the picture's shapes; auto: each tried, the best kept "
                         "(default hatch)")
    ph.add_argument("--max-time", metavar="TIME",
                    help="plot-time budget, e.g. 2h, 45m, 1h30m (default for photos: 1h)")
    ph.add_argument("--spacing", type=_number("spacing", 0, above=True), metavar="MM",
                    help="a fixed line spacing instead of the budget")
    ph.add_argument("--pen-width", type=_number("pen width", 0, above=True), default=0.5,
                    metavar="MM", help="the line width the tone model assumes (default 0.5; "
                    "also --fill-spacing's default)")
    ph.add_argument("--contrast", type=_number("contrast", 0), default=1.0, metavar="K",
                    help="scale the tone about mid-grey (default 1)")
    ph.add_argument("--brightness", type=_number("brightness"), default=0.0, metavar="B",
                    help="add to the tone, -1 (black) to 1 (white) (default 0)")
    ph.add_argument("--invert", action="store_true", help="draw the light parts dark")
    ph.add_argument("--tsp", action="store_true",
                    help="stipple: one tour through the dots instead of dots (TSP art)")
    ph.add_argument("--cmyk", action="store_true",
                    help="a colour photo in four pens: yellow, cyan, magenta and black layers, "
                         "within one budget")
    ph.add_argument("--colours", metavar="PENS",
                    help="a colour photo in the pens you own: names from [pens] or colours, "
                         "comma-separated (black,red,#2050c0), within one budget")
    fl = p.add_argument_group("fills (SVG)")
    fl.add_argument("--fill", choices=("none", "outline", "hatch"),
                    help="filled shapes: none (only what has a stroke is drawn), outline (every "
                         "shape's outline, the default), hatch (outline and hatch lines)")
    fl.add_argument("--fill-spacing", type=_number("fill spacing", 0, above=True), metavar="MM",
                    help="hatch lines MM apart on the wall (default: --pen-width, 0.5)")
    fl.add_argument("--fill-angle", type=_number("fill angle"), metavar="DEG",
                    help="hatch lines at DEG counter-clockwise from +X on the wall (default 45)")


def placement(args):
    from vplotter.drawing.place import Placement

    return Placement(scale=getattr(args, "scale", None) or 1.0,
                     rotate_deg=getattr(args, "rotate", None) or 0.0,
                     fit=bool(getattr(args, "fit", False)),
                     margin_mm=getattr(args, "margin", 0.0) or 0.0,
                     align=getattr(args, "align", None), valign=getattr(args, "valign", None),
                     offset_mm=tuple(getattr(args, "offset", None) or (0.0, 0.0)),
                     width_mm=getattr(args, "width", None), height_mm=getattr(args, "height", None))


def photo_options(args):
    from vplotter.drawing.photo import PhotoOptions

    return PhotoOptions.from_args(args)


def fill_options(args):
    from vplotter.inputs.fill import FillOptions

    return FillOptions.from_args(args)


# The option groups a reader may take (`Reader.options`): the args they are, whether a value
# counts as given when it is not None (else: when it is true), and the error for a file whose
# reader does not take them ({flag}: the first given, {path}: the file).
GROUPS = (
    ("layer", ("layer",), False, "error: --layer is for SVG and DXF files; {path} is neither"),
    ("photo", ("style", "max_time", "spacing", "tsp", "invert", "cmyk", "colours"), False,
     "error: {flag} is for photos (PNG, JPEG, ...); {path} is not one"),
    ("fill", ("fill", "fill_spacing", "fill_angle"), True,
     "error: {flag} is for SVG files; {path} is not one"),
)


def check_options(args, path: str, takes: tuple[str, ...]) -> None:
    """ConfigError for a file option given that the file's reader does not take (`takes`:
    its `Reader.options`), and for --width/--height with --scale or --fit."""
    for group, names, not_none, msg in GROUPS:
        if group in takes:
            continue
        for name in names:
            value = getattr(args, name, None)
            if value is not None if not_none else value:
                raise ConfigError(msg.format(flag="--" + name.replace("_", "-"), path=path))
    place = placement(args)
    if (place.width_mm or place.height_mm) and (place.fit or place.scale != 1.0):
        raise ConfigError("error: give --width/--height, --scale or --fit, not two of them")


def join_limit(join_mm: float | None, tol_mm: float, warn: Callable[[str], None]) -> float:
    """The gap a pen-down join may bridge: --join, by default and at most the flattening
    tolerance tol_mm. A bridge of g mm lies within g/2 of the two stroke ends it joins, so a
    join draws nothing farther from the file than a chord of a curve is, and any order draws the
    same segments within it (a longer bridge would be a line that is not in the file, and which
    ends are joined depends on the order)."""
    if join_mm is None:
        return tol_mm
    if join_mm > tol_mm:
        warn(f"warning: --join {join_mm:g} mm is more than the flattening tolerance "
             f"({tol_mm:g} mm, 0.75 x tolerance_mm): ends farther apart than that are not joined")
        return tol_mm
    return join_mm


def options_key(path: str, args, kind: str | None = None) -> str:
    """The options that decide what is drawn in which order (a resume needs the same).
    `kind`: file_kind(path), when the caller has it."""
    from vplotter import readers

    reader = readers.reader_of(kind) if kind else readers.reader_for(path)
    method = getattr(args, "order", None) or reader.order
    photo = photo_options(args) if "photo" in reader.options else None
    key = (method, placement(args), getattr(args, "join", None),
           getattr(args, "layer", None), bool(getattr(args, "pause_between_layers", False)),
           photo, getattr(args, "pen_order", None), getattr(args, "refill_every", None))
    if "fill" in reader.options and getattr(args, "fill", None) not in (None, "outline"):
        key += (fill_options(args),)
    return repr(key)
