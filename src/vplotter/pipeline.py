"""The drawing pipeline wired together: G-code -> pieces -> plan -> step schedule rows.

`stream()` is a generator of Rows (or, with emit=False, only advances the clock so that a
validation pass gives the exact plot time without computing a single step). Errors raised here
carry file:line:col and come before anything has moved when the caller validates first.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Iterator

import numpy as np

from vplotter import kinematics, segment
from vplotter.inputs import gcode
from vplotter.config import Config
from vplotter.errors import InputError
from vplotter.planner import Block, Planner
from vplotter.schedule import Rows, Scheduler


BATCH = 512  # moves per batch handed to the planner
# Share of tolerance_mm given to the chords of arcs; the rest is left for the step quantisation
# (half a step of each cord moves the pen by up to ~0.008 mm on the seed machine's page).
CHORD_SHARE = 0.75


@dataclass
class Summary:
    moves: int = 0
    pieces: int = 0
    steps: np.ndarray = field(default_factory=lambda: np.zeros(2, dtype=np.int64))
    drawn_mm: float = 0.0
    travel_mm: float = 0.0
    time_s: float = 0.0
    pen_downs: int = 0

    def text(self) -> str:
        m, s = divmod(int(round(self.time_s)), 60)
        h, m = divmod(m, 60)
        hms = f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"
        return (f"{self.moves} moves, {self.pieces} pieces, {self.pen_downs} strokes, "
                f"steps left {self.steps[0]} right {self.steps[1]}, "
                f"drawn {self.drawn_mm / 1000:.2f} m, travel {self.travel_mm / 1000:.2f} m, "
                f"plot time {hms} ({self.time_s:.1f} s)")


@dataclass(frozen=True)
class StartAt:
    """Where a resumed drawing starts: G-code line, and the pen point on that line's move
    (None: the start of the line)."""

    line: int
    xy: tuple[float, float] | None = None


def stream(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str = "<input>",
           emit: bool = True, summary: Summary | None = None,
           start_at: StartAt | None = None, pen_down: bool | None = None) -> Iterator[Rows]:
    """Rows for drawing `records` starting from the given step counts (cords = ref + counts / steps per unit).

    With `start_at`, records before that line are skipped (their pen changes still count), the
    pen travels up to the resume point and goes down again if the file has it down there.
    """
    kin = kinematics.from_config(cfg)
    spu = np.asarray(cfg.motors.steps_per_unit)
    summary = summary if summary is not None else Summary()
    cords = np.asarray(ref_mm, dtype=float) + np.asarray(counts, dtype=float) / spu
    start = kin.forward(cords[None, :])[0]
    planner = Planner(kin, cfg.motors.max_step_rate, cfg.motors.max_accel, spu, start)
    sched = Scheduler(cfg, kin, counts, ref_mm)
    page = cfg.page
    tol = cfg.motion.tolerance_mm * CHORD_SHARE
    mo = cfg.motion
    file_xy = (0.0, 0.0)

    def blocks(bs: Iterator[Block]) -> Iterator[Rows]:
        for b in bs:
            summary.pieces += len(b.d)
            drawn = float(b.d[b.drawing].sum())
            summary.drawn_mm += drawn
            summary.travel_mm += float(b.d.sum()) - drawn
            rows = sched.motion(b, emit)
            if rows is not None:
                yield rows

    # Moves are batched so that page checks and coordinate maps are vector operations.
    batch: list[np.ndarray] = []
    meta: list[tuple[int, float, int, int, bool]] = []   # points, cap, line, col, drawing

    def flush(stop: bool) -> Iterator[Rows]:
        if batch:
            pts = np.concatenate(batch)
            n, cap, line, col, draw = (np.array(v) for v in zip(*meta))
            bad = segment.first_outside(pts, page.x_min_mm, page.x_max_mm, page.y_min_mm, page.y_max_mm)
            if bad >= 0:
                move = int(np.searchsorted(np.cumsum(n), bad, side="right"))
                x, y = pts[bad]
                raise InputError(
                    f"{name}:{line[move]}:{col[move]}: error: point X{x:.3f} Y{y:.3f} is outside "
                    f"the page (X {page.x_min_mm:g}..{page.x_max_mm:g}, "
                    f"Y {page.y_min_mm:g}..{page.y_max_mm:g})")
            batch.clear()
            meta.clear()
            yield from blocks(planner.add(kin.to_machine(pts), np.repeat(cap, n),
                                          np.repeat(line, n), np.repeat(draw, n)))
        if stop:
            yield from blocks(planner.stop())

    keep_pen = pen_down is not None
    first = sched.start(pen_down)
    pen_down = bool(pen_down)
    if emit and first is not None:
        yield first
    for rec in records:
        pts = None
        if start_at is not None:
            if rec.line < start_at.line:
                if isinstance(rec, gcode.Pen):
                    pen_down = rec.down
                elif isinstance(rec, gcode.Move):
                    file_xy = (rec.x1, rec.y1)
                continue
            # travel pen up to where the drawing goes on, then put the pen as the file has it
            there = file_xy
            if isinstance(rec, gcode.Move):
                pts = segment.points(rec, tol)
                there = (rec.x0, rec.y0)
                if rec.line == start_at.line and start_at.xy is not None and len(pts):
                    there, pts = segment.cut(np.vstack(([[rec.x0, rec.y0]], pts)), start_at.xy)
            start_at = None
            batch.append(np.array([there], dtype=float))
            meta.append((1, mo.travel_speed_mm_s, rec.line, rec.col, False))
            yield from flush(True)
            if pen_down:
                rows = sched.pen(True, rec.line)
                if rows is not None and emit:
                    yield rows
        if isinstance(rec, gcode.Move):
            summary.moves += 1
            if pts is None:
                pts = segment.points(rec, tol)
            if len(pts) == 0:
                continue
            if pen_down:
                cap = mo.draw_speed_mm_s
                if rec.feed_mm_s is not None and not rec.rapid:
                    cap = min(cap, rec.feed_mm_s)
            else:
                cap = mo.travel_speed_mm_s
            batch.append(pts)
            meta.append((len(pts), cap, rec.line, rec.col, pen_down))
            if len(meta) >= BATCH:
                yield from flush(False)
        elif isinstance(rec, gcode.Pen):
            yield from flush(True)
            rows = sched.pen(rec.down, rec.line)
            pen_down = rec.down
            summary.pen_downs += int(rec.down)
            if rows is not None and emit:
                yield rows
        elif isinstance(rec, gcode.Dwell):
            yield from flush(True)
            rows = sched.dwell(rec.seconds, rec.line)
            if rows is not None and emit:
                yield rows
    if start_at is not None:
        raise InputError(f"{name}: error: line {start_at.line} is past the last move of the file")
    yield from flush(True)
    rows = sched.finish(lift=not keep_pen)
    if rows is not None and emit:
        yield rows
    summary.steps = sched.steps_total.copy()
    summary.time_s = sched.t_us / 1e6


def validate(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str = "<input>",
             start_at: StartAt | None = None, stop=lambda: False) -> Summary | None:
    """The validation pass: every record checked, planned and timed, no step computed.
    Returns the summary, or None if stop() turned true first."""
    summary = Summary()
    for _ in stream(cfg, records, counts, ref_mm, name, False, summary, start_at):
        if stop():
            return None
    return summary
