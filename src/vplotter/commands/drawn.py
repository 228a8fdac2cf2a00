"""The running draw's path, for the page to show the drawing growing on its preview.

The page gets the planned path once per drawing (GET /api/now/paths): every point the pen
passes, in drawing order, with the record (`line`) it belongs to and whether the pen is down
on the way to it; the status events it already follows carry the record being drawn (`line`),
so the part already drawn is the points before that record's first one. Nothing is polled.

The path is made as `draw` made it: the file and options from the running draw's command line
(live.json), the pen's start from the stored position (during a draw, where its motors
started; a resumed draw's own start from the stored drawing), placed, ordered and cut into
chords by the same code.
"""

from __future__ import annotations

import argparse

from vplotter.errors import ConfigError

MAX_POINTS = 400_000       # a larger path is sent thinned (every k-th point of each record)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise ConfigError(f"error: {message}")


def draw_args(command: str):
    """The draw's arguments from its command line (`vplotter --config C draw FILE ...`), or
    None when it is no draw (the queue waiting for paper)."""
    from vplotter.commands import draw

    words = command.split(" ")
    if "draw" not in words:
        return None
    p = _Parser(prog="vplotter draw", add_help=False)
    draw.add_draw(p)
    try:
        args, _ = p.parse_known_args(words[words.index("draw") + 1:])
    except ConfigError:
        return None
    return args


def paths(cfg, running: dict) -> dict | None:
    """{"file", "page", "start", "x", "y", "line", "down"} of the draw live.read() describes
    (None when it is no draw or its file no longer reads)."""
    import numpy as np

    from vplotter import kinematics
    from vplotter.commands.files import prepare_file
    from vplotter.errors import VplotterError
    from vplotter.machine import state

    args = draw_args(str(running.get("command", "")))
    if args is None:
        return None
    pos = state.load()
    if pos is None:
        return None
    extra = pos.extra.get("drawing") or {}
    kin = kinematics.from_config(cfg)
    spu = np.asarray(pos.steps_per_unit)
    here = kin.to_gcode(kin.forward((np.asarray(pos.ref_mm) + np.asarray(pos.counts) / spu)
                                    [None, :]))[0]
    start = extra.get("start") or here
    try:
        prep = prepare_file(args, cfg, pos, warn=lambda *_: None, start_xy=start,
                            say_notes=False)
        x, y, line, down = _walk(prep.records(), cfg.motion.tolerance_mm)
    except (VplotterError, OSError):
        return None
    pg = cfg.page
    return {"file": running.get("file", ""), "start": [round(float(v), 2) for v in start],
            "page": {"x_min_mm": pg.x_min_mm, "x_max_mm": pg.x_max_mm,
                     "y_min_mm": pg.y_min_mm, "y_max_mm": pg.y_max_mm},
            "x": np.round(x, 2).tolist(), "y": np.round(y, 2).tolist(),
            "line": line.tolist(), "down": down.astype(int).tolist()}


def _walk(records, tol_mm: float):
    """The moves' chord end points (x, y), their records' lines and pen states."""
    import numpy as np

    from vplotter.inputs.gcode import Move, Pen
    from vplotter.motion import segment

    moves, downs, down = [], [], False
    for rec in records:
        if isinstance(rec, Pen):
            down = rec.down
        elif isinstance(rec, Move):
            moves.append(rec)
            downs.append(down)
    if not moves:
        e = np.zeros(0)
        return e, e, e.astype(np.int64), e.astype(bool)
    pts, counts = segment.points_many(moves, tol_mm * segment.CHORD_SHARE)
    line = np.repeat(np.array([m.line for m in moves], dtype=np.int64), counts)
    down_at = np.repeat(np.array(downs, dtype=bool), counts)
    if len(pts) > MAX_POINTS:            # thinned, keeping each record's last point
        k = -(-len(pts) // MAX_POINTS)
        last = np.r_[line[1:] != line[:-1], True]
        keep = last | (np.arange(len(pts)) % k == 0)
        pts, line, down_at = pts[keep], line[keep], down_at[keep]
    return pts[:, 0], pts[:, 1], line, down_at
