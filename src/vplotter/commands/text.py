"""text: a line (or lines) of text in a single-stroke Hershey font, as G-code or a summary.

`vplotter text "Hello" --height 20 -o hello.ngc`: capitals 20 mm high, the first baseline on
Y0 with the text's start (or middle, end: --anchor) at X0, then the file options' placement
and order as for any drawing file (`prepare`), written as `convert` writes.
"""

from __future__ import annotations

import argparse

from vplotter.commands.common import eprint, load_config, position, say
from vplotter.errors import ConfigError, InputError

DEFAULT_CAP_MM = 10.0
NAME = "text"           # how messages and the G-code header name the drawing


def add_text(p: argparse.ArgumentParser) -> None:
    from vplotter.file_options import _number, add_file_options

    p.add_argument("text", help="the text; a newline or a literal \\n starts a new line")
    p.add_argument("-o", "--output", metavar="OUT.ngc",
                   help="write the G-code here ('-' for standard output); without it: print "
                        "the size, strokes and plot time")
    p.add_argument("--font", default="futural", metavar="NAME",
                   help="Hershey font: futural (default), futuram, timesr, timesrb, timesi, "
                        "timesib, rowmans, rowmand, scripts, scriptc, cursive, gothiceng, "
                        "gothicger, gothicita, greek, cyrillic, ...")
    p.add_argument("--anchor", choices=("start", "middle", "end"), default="start",
                   help="the point of each line that sits on X0: start (lines left-aligned), "
                        "middle (centred) or end (right-aligned)")
    p.add_argument("--letter-spacing", type=_number("letter spacing"), default=0.0,
                   metavar="MM", help="extra space between characters (default 0)")
    p.add_argument("--line-height", type=_number("line height", 0, above=True), default=1.25,
                   metavar="K", help="baselines K font sizes apart (default 1.25)")
    add_file_options(p)
    # --height here is the capitals' height: it replaces the placement option (the drawing's
    # height), whose dest it does not share
    size = p.add_argument_group("text size", conflict_handler="resolve")
    size.add_argument("--height", dest="cap_height", type=_number("height", 0, above=True),
                   metavar="MM", help=f"capital letters MM high (default {DEFAULT_CAP_MM:g}); "
                                      f"the font size is MM / 0.656")


def cmd_text(args, argv=None) -> int:
    from vplotter.commands import jog
    from vplotter.commands.files import _timed, save_gcode
    from vplotter.inputs import text as fonts
    from vplotter.prepare import prepare

    text = args.text.replace("\\n", "\n")
    if args.cap_height is not None and getattr(args, "width", None) is not None:
        raise ConfigError("error: give --height (the capitals) or --width (the whole text), "
                          "not both")
    font = args.font.strip().lower()
    if font not in fonts.font_names():
        raise ConfigError(f"error: --font: no Hershey font {args.font!r} "
                          f"(fonts: {', '.join(fonts.font_names())})")
    cap = args.cap_height or DEFAULT_CAP_MM
    drawing, shape = fonts.drawing(NAME, text, cap, font=font, anchor=args.anchor,
                                   letter_spacing=args.letter_spacing,
                                   line_height=args.line_height)
    msg = fonts.missing_warning(NAME, shape.missing, shape.substituted, font)
    if msg:
        eprint(msg)
    if not drawing.strokes:
        raise InputError(f"{NAME}: error: nothing to draw (no character of {text!r} has "
                         f"strokes in {font})")
    cfg = load_config(args)
    pos = position(cfg, args, True)
    xy = jog.pen_xy(cfg, pos, pos.counts)
    prep = prepare(NAME, cfg, args, start_xy=(float(xy[0]), float(xy[1])), drawing=drawing)
    if args.output:
        save_gcode(prep, cfg, args.output)
        return 0
    from vplotter.budget import clock_text
    from vplotter.drawing import place

    box = place.extent(prep.strokes)
    travel, time_s, problem = _timed(cfg, pos, prep)
    if problem:
        eprint(problem)
    drawn = sum(s.length_mm() for s in prep.strokes)
    say(f"{NAME}: {len(text.splitlines())} line(s) in {font}, capitals {cap:g} mm (font size "
        f"{cap / fonts.CAP_HEIGHT:.2f} mm) before placement")
    say(f"  drawn extent X {box.x_min:.2f}..{box.x_max:.2f} Y {box.y_min:.2f}..{box.y_max:.2f} "
        f"mm ({box.x_max - box.x_min:.2f} x {box.y_max - box.y_min:.2f} mm)")
    say(f"  {len(prep.strokes)} strokes, drawn {drawn / 1000:.2f} m"
        + ("" if time_s is None else f", travel {travel / 1000:.2f} m, plot time "
                                     f"{clock_text(time_s)} ({time_s:.1f} s)"))
    say("  write it with -o OUT.ngc; then vplotter preview/draw OUT.ngc")
    return 0
