"""preview and simulate: pictures of what will be drawn and of what a trace drew."""

from __future__ import annotations

import argparse

from vplotter.commands.common import load_config, position, say
from vplotter.budget import clock_text
from vplotter.errors import ConfigError


def _add_picture_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", required=True, metavar="OUT.png|OUT.svg",
                   help="the picture to write: PNG, or SVG for the same picture as vectors")
    p.add_argument("--size", type=int, default=1600, metavar="PX",
                   help="pixels on the picture's long side (default 1600)")


def _check_picture_options(args) -> None:
    if not 100 <= args.size <= 20000:
        raise ConfigError(f"error: --size must be 100..20000 px (got {args.size})")
    if not args.output.lower().endswith((".png", ".svg")):
        raise ConfigError(f"error: -o {args.output}: the picture must be a .png or .svg file")


def add_preview(p: argparse.ArgumentParser) -> None:
    from vplotter.file_options import add_file_options

    p.add_argument("file", help="the drawing to preview: G-code, SVG, DXF, text (.txt) or a "
                   "photo (PNG, JPEG, WebP, BMP, TIFF, GIF)")
    _add_picture_options(p)
    p.add_argument("--strict", action="store_true",
                   help="treat warnings about inconsistent arcs as errors")
    p.add_argument("--ink", action="store_true",
                   help="the drawing as ink on paper: black lines of the pen's width "
                        "(--pen-width, default 0.5 mm), no travel: judge a photo's tone")
    add_file_options(p)


def cmd_preview(args, argv=None) -> int:
    import numpy as np

    from vplotter import kinematics, pipeline
    from vplotter.motion.segment import CHORD_SHARE
    from vplotter.drawing import render
    from vplotter.commands import warnings
    from vplotter.commands.files import prepare_file

    _check_picture_options(args)
    cfg = load_config(args)
    pos = position(cfg, args, True)
    kin = kinematics.from_config(cfg)
    start = kin.to_gcode(kin.forward(np.array([[pos.left_mm, pos.right_mm]])))[0]
    # the planned drawing: placed and ordered strokes, and the records the draw plays (the
    # same as `estimate` times)
    prep = prepare_file(args, cfg, pos, start_xy=start)
    strokes = prep.strokes
    travel: list = []
    tol = cfg.motion.tolerance_mm * CHORD_SHARE
    summary = pipeline.validate(cfg, _tap_travel(prep.records(), start, tol, travel), pos.counts,
                                pos.ref_mm, args.file, where=prep.where)
    legend = f"{args.file}: {_legend(summary)}"
    if args.ink:
        pen_mm = getattr(args, "pen_width", None) or 0.5
        pic = render.ink([s.pts for s in strokes], kin, cfg.page, pen_mm, legend, args.size,
                         colours=[s.colour for s in strokes])
        what = f"ink of a pen {pen_mm:g} mm wide"
    else:
        pic = render.preview([s.pts for s in strokes], start, kin, cfg.page, legend, args.size,
                             np.concatenate(travel) if travel else np.zeros((0, 2, 2)))
        what = "strokes from red (first) to violet (last), travel in grey"
    render.write(pic, args.output)
    warnings.flush()
    say(f"{args.file}: {summary.text()}")
    say(f"{args.output}: {pic.width_px} x {pic.height_px} px, {what}")
    return 0


def _tap_travel(records, start_xy, tol_mm: float, out: list):
    """Pass the records on unchanged while collecting their pen-up line pieces ((K, 2, 2)
    arrays into `out`), from where the pen starts, as the pipeline moves: the grey lines are
    the travel the legend counts."""
    import numpy as np

    from vplotter.motion import segment
    from vplotter.inputs.gcode import Move, Pen

    here = np.asarray(start_xy, dtype=float).reshape(1, 2)
    down = False
    for rec in records:
        if isinstance(rec, Pen):
            down = rec.down
        elif isinstance(rec, Move):
            pts = segment.points(rec, tol_mm)
            if len(pts):
                if not down:
                    chain = np.vstack((here, pts))
                    out.append(np.stack((chain[:-1], chain[1:]), axis=1))
                here = pts[-1:]
        yield rec


def _legend(summary) -> str:
    return (f"drawn {summary.drawn_mm / 1000:.2f} m, travel "
            f"{summary.travel_mm / 1000:.2f} m, {summary.pen_downs} pen lifts, plot time "
            f"{clock_text(summary.time_s)} ({summary.time_s:.1f} s)")


def add_simulate(p: argparse.ArgumentParser) -> None:
    p.add_argument("trace", metavar="TRACE.csv", help="a GPIO trace v1 (draw --trace)")
    _add_picture_options(p)
    p.add_argument("--at", nargs=2, type=float, metavar=("X", "Y"),
                   help="G-code point the pen was at when the trace started (default: the "
                        "stored position, or X0 Y0 without one, as the dry run assumes)")


def cmd_simulate(args, argv=None) -> int:
    import numpy as np

    from vplotter import kinematics
    from vplotter.drawing import render
    from vplotter.machine import trace

    _check_picture_options(args)
    cfg = load_config(args)
    if cfg.machine.kind != "vplotter" or cfg.motors.driver != "uln2003":
        raise ConfigError(f"{cfg.path}: error: simulate decodes the coil traces of a V-plotter on "
                          f"ULN2003 boards, not yet [machine] kind = \"{cfg.machine.kind}\" with "
                          f"[motors] driver = \"{cfg.motors.driver}\"")
    kin = kinematics.from_config(cfg)
    if args.at is not None:
        if not all(np.isfinite(v) and abs(v) < 1e5 for v in args.at):
            raise ConfigError(f"error: --at {args.at[0]:g} {args.at[1]:g} is not a position on "
                              f"a wall")
        xy0 = kin.to_machine(np.array([args.at], dtype=float))
        if not xy0[0, 1] > 0:
            raise ConfigError(f"error: --at: G-code point X{args.at[0]:g} Y{args.at[1]:g} is not "
                              f"below the anchors")
        cords0 = kin.inverse(xy0)[0]
    else:
        pos = position(cfg, args, True)
        cords0 = np.array([pos.left_mm, pos.right_mm])
    steps = trace.read_steps(args.trace, cfg.motors, cfg.pen)
    cords = cords0 + steps.steps / np.asarray(cfg.motors.steps_per_unit)
    xy = kin.to_gcode(kin.forward(cords))
    drawn_mm, up_mm = _lengths(xy, steps.down)
    lifts = int(np.count_nonzero(steps.down[:-1] & ~steps.down[1:]) + steps.down[-1])
    end_s = float(steps.t_s[-1])
    legend = (f"{args.trace}: pen down {drawn_mm / 1000:.2f} m, pen up {up_mm / 1000:.2f} m, "
              f"{lifts} pen lifts, {clock_text(end_s)} ({end_s:.1f} s)")
    x0, y0 = np.round(xy[0], 2) + 0.0          # no "-0.00"
    start = f"start X{x0:.2f} Y{y0:.2f}" + (" (--at)" if args.at else "")
    pic = render.simulate(xy, steps.down, kin, cfg.page, legend, args.size, start)
    render.write(pic, args.output)
    say(f"{args.output}: {pic.width_px} x {pic.height_px} px; {legend}")
    return 0


def _lengths(xy, down, every: int = 32) -> tuple[float, float]:
    """Pen-down and pen-up path length of decoded steps. Step by step the pen zigzags (one
    cord, then the other), so the path is measured through every 32nd point and the points
    where the pen changes: the zigzag is gone, the chords stay within a fraction of a mm."""
    import numpy as np

    n = len(xy)
    if n < 2:
        return 0.0, 0.0
    i = np.arange(n)
    change = np.concatenate(([True], down[1:] != down[:-1]))
    keep = (i % every == 0) | change | (i == n - 1)
    k = np.flatnonzero(keep)
    d = np.hypot(*np.diff(xy[k], axis=0).T)
    on = down[k[:-1]]
    return float(d[on].sum()), float(d[~on].sum())
