"""info and convert: what a drawing file holds, and the placed, ordered drawing as G-code."""

from __future__ import annotations

import argparse
import json
import os

from vplotter.commands.common import eprint, load_config, position, say
from vplotter.budget import clock_text
from vplotter.errors import InputError


def prepare_file(args, cfg, pos, warn=None, start_xy=None, say_notes=True, **changes):
    """prepare() for a command (with some options changed): the travel starts where the pen
    is, or at start_xy (a resumed draw keeps the order it was started with). What a photo's
    budget chose is said on stderr (say_notes): `say_prepared`."""
    from vplotter.commands import jog, warnings
    from vplotter.prepare import prepare

    if changes:
        args = argparse.Namespace(**{**vars(args), **changes})
    xy = jog.pen_xy(cfg, pos, pos.counts) if start_xy is None else start_xy
    prep = prepare(args.file, cfg, args, start_xy=(float(xy[0]), float(xy[1])),
                   plot_time=_plot_time(cfg, pos, xy, args.file),
                   warn=warnings.warn if warn is None else warn)
    if say_notes:
        for line in said(prep, bool(getattr(args, "verbose", False))):
            eprint(line)
    return prep


def said(prep, verbose: bool = False, indent: str = "") -> list[str]:
    """What a prepared drawing (a photo) says: its notes (with --verbose the tone details
    too), then its advice, as lines ('note: ...', 'advice: ...' on stderr; indented, no
    'note:', in `info`)."""
    notes = list(prep.notes) + (list(prep.details) if verbose else [])
    return ([f"{indent}{n}" if indent else f"note: {n}" for n in notes] +
            [f"{indent}advice: {a}" for a in prep.advice])


def _plot_time(cfg, pos, xy, path: str):
    """records -> plot time with the draw's planner, from the pen at G-code point xy (the
    motors' counts follow from xy, so a resumed draw times and chooses as the first did); a
    problem is told as the file's (path:stroke:0, as a draw of it would)."""
    import numpy as np

    from vplotter import kinematics, pipeline

    counts: list = []           # made on the first call: only a photo's budget asks

    def plot_time(records) -> float:
        if not counts:
            kin = kinematics.from_config(cfg)
            q = kin.inverse(kin.to_machine(np.asarray(xy, dtype=float).reshape(1, 2)))[0]
            counts.extend(int(c) for c in np.rint((q - np.asarray(pos.ref_mm)) *
                                                  np.asarray(cfg.motors.steps_per_unit)))
        return pipeline.validate(cfg, records, tuple(counts), pos.ref_mm, path).time_s

    return plot_time


# ------------------------------------------------------------------ info
def add_info(p: argparse.ArgumentParser) -> None:
    from vplotter.file_options import add_file_options

    p.add_argument("file", help="the drawing: G-code, SVG, DXF, text (.txt) or a photo "
                                "(PNG, JPEG, WebP, BMP, TIFF, GIF)")
    p.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    p.add_argument("--strict", action="store_true", help="treat arc warnings as errors")
    add_file_options(p)


def _timed(cfg, pos, prep, with_summary: bool = False):
    """(travel_mm, time_s, problem) of the pipeline's validation pass; (None, None, the error
    as a warning) when the drawing does not fit the page (info still reports); with_summary:
    the pipeline's summary (or None) after them."""
    from vplotter import pipeline

    try:
        s = pipeline.validate(cfg, prep.records(), pos.counts, pos.ref_mm, prep.path,
                              where=prep.where)
    except InputError as e:
        if "outside the page" not in str(e):
            raise
        return (None, None, str(e).replace("error:", "warning:", 1)) + ((None,) * with_summary)
    return (s.travel_mm, s.time_s, None) + ((s,) * with_summary)


def _off_the_page(args, cfg, pos, off_keep: str | None, off_best: str | None) -> str | None:
    """A drawing off the page, said as draw, estimate and preview say it: the first point
    outside in the order they draw (--order, else the reader's), so that all name the same."""
    if off_keep is None and off_best is None:
        return None
    from vplotter.readers import reader_for

    reader = reader_for(args.file)
    method = getattr(args, "order", None) or reader.order
    if method == "keep" or reader.kind == "image":   # a photo: the order its budget timed
        return off_keep
    if method == "best":
        return off_best
    return _timed(cfg, pos, prepare_file(args, cfg, pos, warn=lambda m: None,
                                         say_notes=False))[2]


def cmd_info(args, argv=None) -> int:
    from vplotter.commands import warnings
    from vplotter.drawing import pens, place

    cfg = load_config(args)
    pos = position(cfg, args, True)
    from dataclasses import replace

    from vplotter.readers import file_kind

    if file_kind(args.file) == "image":     # one budget search: its order is the file order
        best = prepare_file(args, cfg, pos, order="best", say_notes=False)
        keep = replace(best, _strokes=list(best.drawing.strokes), _firsts=[])
    else:
        keep = prepare_file(args, cfg, pos, order="keep")
        best = prepare_file(args, cfg, pos, warn=lambda m: None, order="best")
    drawing = best.drawing
    strokes = best.strokes
    box = place.extent(strokes)
    ext = [box.x_min, box.y_min, box.x_max, box.y_max] if box else [0.0, 0.0, 0.0, 0.0]
    width = drawing.width_mm if drawing.width_mm is not None else ext[2] - ext[0]
    height = drawing.height_mm if drawing.height_mm is not None else ext[3] - ext[1]
    t_keep, s_keep, off_keep = _timed(cfg, pos, keep)
    t_best, s_best, off_best, timed = _timed(cfg, pos, best, with_summary=True)
    problem = _off_the_page(args, cfg, pos, off_keep, off_best)
    warnings.flush()                # what reading the file found, then the problem, then info
    if problem:
        eprint(problem)
    skipped = {k: int(drawing.skipped.get(k, 0)) for k in ("text", "image", "hidden")}
    out = {
        "width_mm": _r(width), "height_mm": _r(height), "extent": [_r(v) for v in ext],
        "strokes": len(strokes),
        "drawn_mm": _r(float(sum(s.length_mm() for s in strokes))),
        "travel_mm": {"file": _r(t_keep), "best": _r(t_best)},
        "time_s": {"file": _r(s_keep), "best": _r(s_best)},
        "layers": [{"id": lay.get("id"), "label": lay.get("label"),
                    "visible": bool(lay.get("visible", True))} for lay in drawing.layers],
        "skipped": skipped,
        "notes": list(best.notes),
        "details": list(best.details),
        "advice": list(best.advice),
        "pens": [{**row, "drawn_mm": _r(row["drawn_mm"])} for row in pens.table(strokes)],
    }
    if args.json:
        say(json.dumps(out))
        return 0
    from vplotter.readers import reader_of

    say(f"{args.file}: {reader_of(best.kind).title}, {out['width_mm']:g} x "
        f"{out['height_mm']:g} mm; drawn extent X {ext[0]:.2f}..{ext[2]:.2f} "
        f"Y {ext[1]:.2f}..{ext[3]:.2f} mm")
    say(f"  {out['strokes']} strokes, drawn {out['drawn_mm'] / 1000:.2f} m")
    _say_pens(out["pens"], timed, getattr(args, "pen_order", None) or "light-to-dark")
    for line in said(best, args.verbose, "  "):
        say(line)
    for what, t, s in (("file order", t_keep, s_keep), ("--order best", t_best, s_best)):
        if t is None:
            say(f"  {what}: does not fit the page")
        else:
            say(f"  {what}: travel {t / 1000:.2f} m, plot time {clock_text(s)} ({s:.1f} s)")
    say(f"  ordering took {best.order_s:.2f} s")
    for lay in out["layers"]:
        say(f"  layer {lay['label'] or lay['id']!s} (id {lay['id']}): "
            f"{'visible' if lay['visible'] else 'hidden'}")
    notes = {"text": "text elements (flowed text without a rect frame: convert it to text)",
             "image": "images (bitmaps are not drawn)",
             "hidden": "hidden elements (display:none or visibility:hidden)"}
    for k, n in skipped.items():
        if n:
            say(f"  skipped {n} {notes[k]}")
    return 0


def _say_pens(rows: list[dict], timed, pen_order: str) -> None:
    """The pens in drawing order (none for a drawing in the one default pen), with the plot
    time of each from the pipeline's pen changes when it has them."""
    from vplotter.drawing import pens

    if len(rows) < 2 and all(r["name"] == "default" for r in rows):
        return
    times: dict = {}
    for pen, seconds, *_ in (pens.times(timed.pens, timed.time_s) if timed else []):
        times[pen] = times.get(pen, 0.0) + seconds
    order = f", {pen_order.replace('-', ' ')}" if len(rows) > 1 else ""
    say(f"  {len(rows)} pen{'s' if len(rows) > 1 else ''}{order}:")
    for r in rows:
        t = f", for {clock_text(times[r['name']])}" if r["name"] in times else ""
        say(f"    {r['name']} ({r['colour']}): "
            f"{r['strokes']} stroke{'s' if r['strokes'] != 1 else ''}, drawn "
            f"{r['drawn_mm'] / 1000:.2f} m{t}")


def _r(v):
    return None if v is None else round(float(v), 3)


# ------------------------------------------------------------------ convert
def add_convert(p: argparse.ArgumentParser) -> None:
    from vplotter.file_options import add_file_options

    p.add_argument("file", help="the drawing: G-code, SVG, DXF, text (.txt) or a photo "
                                "(PNG, JPEG, WebP, BMP, TIFF, GIF)")
    p.add_argument("-o", "--output", required=True, metavar="OUT.ngc",
                   help="G-code file to write ('-' for standard output)")
    p.add_argument("--strict", action="store_true", help="treat arc warnings as errors")
    add_file_options(p)


def save_gcode(prep, cfg, output: str) -> None:
    """Write the prepared drawing as G-code to `output` ('-': standard output), whole or not at
    all (a .part file renamed into place)."""
    import os
    import sys

    if output == "-":
        write_gcode(prep, cfg, sys.stdout)
        return
    tmp = f"{output}.part"
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            write_gcode(prep, cfg, f)
        os.replace(tmp, output)
    except OSError as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise InputError(f"{output}: error: cannot write: {e.strerror}") from None


def cmd_convert(args, argv=None) -> int:
    cfg = load_config(args)
    pos = position(cfg, args, True)
    prep = prepare_file(args, cfg, pos)
    save_gcode(prep, cfg, args.output)
    return 0


def pen_words(cfg) -> tuple[str, str]:
    """(up, down) pen commands: Z5 / Z-1, or what config.toml [gcode] says the files of this
    setup use (pen = "m3": M5 / M3, or the reverse with m3_down = false; "m280": M280 at the
    middle of the up and down angle ranges; Z relative to z_down_below_mm)."""
    d = getattr(cfg, "gcode", None)          # [gcode] (pen dialects), when the config has it
    mode = getattr(d, "pen", "z")
    if mode == "m3":
        return ("M5", "M3") if getattr(d, "m3_down", True) else ("M3", "M5")
    if mode == "m280":
        servo = getattr(d, "m280_servo", 0)
        up, down = (sum(getattr(d, k)) / 2 for k in ("m280_up_s", "m280_down_s"))
        return f"M280 P{servo} S{_num(up)}", f"M280 P{servo} S{_num(down)}"
    z = getattr(d, "z_down_below_mm", 0.0)
    return f"G0 Z{_num(z + 5)}", f"G1 Z{_num(z - 1)}"


def _num(v: float) -> str:
    t = f"{round(float(v), 4) + 0.0:.4f}".rstrip("0").rstrip(".")
    return "0" if t in ("-0", "") else t


def write_gcode(prep, cfg, f) -> None:
    """The strokes as G-code: G0 travel, G1 drawing, the pen by `pen_words`; a stroke that
    starts within --join of the previous end is drawn on without lifting. A drawing in two
    pens or more has `M0 (pen: NAME)` before each pen's strokes (the first included), which
    the reader reads back as the same pen change; a fresh pen (--refill-every) and the next
    layer (--pause-between-layers) are an `M0 (what to do)`."""
    from vplotter.drawing import order, pens

    strokes = prep.strokes
    joined = order.joined(strokes, prep.join_mm).copy()
    breaks = pens.Breaks(strokes, getattr(prep, "refill_mm", None), prep.pause)
    pause = breaks.before(0) if strokes else None
    pen = None
    pen_up, pen_down = pen_words(cfg)
    f.write(f"(vplotter convert {os.path.basename(prep.path)}: {len(strokes)} strokes)\n")
    f.write(f"G21\nG90\n{pen_up}\n")
    feeds = any(s.feed_mm_s is not None for s in strokes)
    feed = None
    layer = object()
    at = ""
    for k, st in enumerate(strokes):
        if pause:
            f.write(_m0(pause, pen, st.colour) + "\n")
            pen = pause[1] if len(pause) > 1 else pen
        if st.layer is not None and st.layer != layer:
            f.write(f"(layer {_safe(str(st.layer))})\n")
        layer = st.layer
        pts, cuts = breaks.split(k)
        xy = [f"X{_num(x)} Y{_num(y)}" for x, y in pts.tolist()]
        if not joined[k]:
            f.write(f"G0 {xy[0]}\n{pen_down}\n")
            at = xy[0]
        lines = []
        for i, w in enumerate(xy):      # no zero-length moves: they would not read back,
            if w != at or len(xy) == 1:  # but a dot's (the pen taps): readers that keep only
                lines.append(f"G1 {w}")  # moves see it as a point
                at = w
            if i in cuts:
                lines += [pen_up, _m0(cuts[i], pen, st.colour), pen_down]
        want = st.feed_mm_s if st.feed_mm_s is not None else cfg.motion.draw_speed_mm_s
        if feeds and lines and len(xy) > 1 and lines[0].startswith("G1") and want != feed:
            lines[0] += f" F{_num(want * 60)}"
            feed = want
        if lines:
            f.write("\n".join(lines) + "\n")
        pause = breaks.before(k + 1) if k + 1 < len(strokes) else None
        if pause:
            joined[k + 1] = False
        if k + 1 == len(strokes) or not joined[k + 1]:
            f.write(f"{pen_up}\n")
    f.write("M2\n")


def _m0(pause: tuple, pen: str | None, colour: str | None) -> str:
    """M0 for a pause of the records (drawing/pens.Breaks): `M0 (pen: NAME)` at a pen change
    (a name with parentheses, `rgb(...)`, as its colour), else `M0 (what to do)`."""
    if len(pause) > 1 and pause[1] != pen:
        name = colour if colour and ("(" in pause[1] or ")" in pause[1]) else pause[1]
        return f"M0 (pen: {_safe(name)})"
    return f"M0 ({_safe(pause[0])})"


def _safe(text: str) -> str:
    return text.replace("(", "[").replace(")", "]").replace("\n", " ")

