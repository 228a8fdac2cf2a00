"""The drawing pipeline wired together: G-code -> pieces -> plan -> step schedule rows.

`stream()` is a generator of Rows (or, with emit=False, only advances the clock so that a
validation pass gives the exact plot time without computing a single step). Errors raised here
carry file:line:col and come before anything has moved when the caller validates first.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, Iterator

import numpy as np

from vplotter import kinematics
from vplotter.config import Config
from vplotter.errors import ConfigError, InputError
from vplotter.inputs import gcode
from vplotter.inputs.gcode import Pause
from vplotter.motion import segment
from vplotter.motion.planner import (ACCEL_MARGIN, CORNER_SHARE, SHARP_SHARE, TAU_S, Block,
                                     Planner, Turn, _slice)
from vplotter.motion.schedule import Rows, Scheduler
from vplotter.motion.segment import CHORD_SHARE


BATCH = 512  # moves per batch handed to the planner


@dataclass
class Summary:
    moves: int = 0
    pieces: int = 0
    steps: np.ndarray = field(default_factory=lambda: np.zeros(2, dtype=np.int64))
    drawn_mm: float = 0.0
    travel_mm: float = 0.0
    time_s: float = 0.0
    pen_downs: int = 0
    motors: tuple[str, str] = ("left", "right")
    plan: list | None = None     # the validated plan, for `replay` (None: plan again)
    pens: list = field(default_factory=list)    # [pen, start s, fresh pens, index, count]

    def pen_mark(self, pause: Pause, t_s: float) -> None:
        """A pause came at t_s: a pen change starts the next pen's time, a pause for a fresh
        pen of the same kind (--refill-every) is counted with it."""
        if pause.pen is None:
            return
        if self.pens and self.pens[-1][0] == pause.pen:
            self.pens[-1][2] += 1
        elif not self.pens and pause.count == 1:      # the one pen, in from the start
            self.pens.append([pause.pen, 0.0, 1, pause.index, pause.count])
        else:
            self.pens.append([pause.pen, t_s, 0, pause.index, pause.count])

    def pen_lines(self) -> list[str]:
        """One line per pen (drawing/pens.time_lines); none for a drawing in one pen."""
        from vplotter.drawing.pens import time_lines

        return time_lines(self.pens, self.time_s)

    def text(self) -> str:
        m, s = divmod(int(round(self.time_s)), 60)
        h, m = divmod(m, 60)
        hms = f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"
        return (f"{self.moves} moves, {self.pieces} pieces, {self.pen_downs} pen lifts, "
                f"steps {self.motors[0]} {self.steps[0]} {self.motors[1]} {self.steps[1]}, "
                f"drawn {self.drawn_mm / 1000:.2f} m, travel {self.travel_mm / 1000:.2f} m, "
                f"plot time {hms} ({self.time_s:.1f} s)")


@dataclass(frozen=True)
class StartAt:
    """Where a resumed drawing starts: G-code line, and the pen point on that line's move
    (None: the start of the line)."""

    line: int
    xy: tuple[float, float] | None = None


STEPS_PER_PART = 10_000  # steps: the rows of one part of a block are about 400 kB
PLAN_LIMIT = 100_000   # pieces (about 11 MB): a validated plan up to this size is kept for the draw


def stream(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str = "<input>",
           emit: bool = True, summary: Summary | None = None,
           start_at: StartAt | None = None, pen_down: bool | None = None,
           keep: Kept | None = None, scheduler=Scheduler, where=None,
           park=None) -> Iterator[Rows | Pause]:
    """Rows for drawing `records` starting from the given step counts (cords = ref + counts / steps per unit).

    With `start_at`, records before that line are skipped (their pen changes still count), the
    pen travels up to the resume point and goes down again if the file has it down there.
    With `keep` (a Kept list), the plan (pen events and planned blocks) is appended to it, so that
    `replay` can make the same rows later without parsing and planning again.
    `scheduler` makes what is played from the plan (Rows for GPIO; the serial backend's
    `linestream.LineScheduler` makes G-code lines); its `chord_share` cuts arcs.
    A Pause record is passed on as it is, for the player to wait: a plain one with the pen up
    and the coils released; a pen change (Pause.pen) with the gondola parked at the change
    point (`park`, G-code mm: where pen changes happen when config.toml [pens] has no change
    point; None: where this plan starts), the pen up and the motors holding.
    where(line, col) names the file place of a line in errors (default: name:line:col).
    """
    summary = summary if summary is not None else Summary()
    ops = plan(cfg, records, counts, ref_mm, name, summary, start_at, pen_down,
               getattr(scheduler, "chord_share", CHORD_SHARE), where, park)
    if keep is not None:
        ops = _keeping(ops, keep)
    yield from _schedule(cfg, ops, counts, ref_mm, emit, summary, scheduler)


def replay(cfg: Config, ops: list, counts, ref_mm) -> Iterator[Rows]:
    """The rows of a plan kept by `validate`; the same rows `stream` makes."""
    yield from _schedule(cfg, iter(ops), counts, ref_mm, True, Summary())


class Kept(list):
    """A plan being kept; `full` once it grew past PLAN_LIMIT pieces (then it is dropped)."""

    full = False
    pieces = 0


def _keeping(ops, keep: Kept):
    for op in ops:
        if not keep.full:
            keep.append(op)
            if op[0] == "motion":
                keep.pieces += len(op[1].d)
                if keep.pieces > PLAN_LIMIT:      # too long to keep: the draw plans it again
                    keep.clear()
                    keep.full = True
        yield op


def _schedule(cfg, ops, counts, ref_mm, emit: bool, summary: Summary,
              scheduler=Scheduler) -> Iterator[Rows]:
    kin = kinematics.from_config(cfg)
    sched = scheduler(cfg, kin, counts, ref_mm)
    spu = np.asarray(cfg.motors.steps_per_unit, dtype=float)
    for op in ops:
        kind = op[0]
        if kind == "motion":
            for part in _parts(op[1], spu):
                rows = sched.motion(part, emit)
                if rows is not None and emit:
                    yield rows
                rows = None             # not kept alive while the player plays it
            continue
        elif kind == "pen":
            rows = sched.pen(op[1], op[2], emit)
        elif kind == "dwell":
            rows = sched.dwell(op[1], op[2])
        elif kind == "turn":
            if not hasattr(sched, "turn"):
                raise ConfigError("error: the polar table turns in place at its centre here, "
                                  "which this backend cannot send; use a GPIO backend")
            rows = sched.turn(op[1], emit)
        elif kind == "start":
            rows = sched.start(op[1])
        elif kind == "pause":
            summary.pen_mark(op[1], sched.t_us / 1e6)
            if op[1].pen is None:            # a plain pause: the coils are released
                rows = sched.release()
                if emit and rows is not None:
                    yield rows
            else:                            # a pen change: held; the new pen's pen-down pulse
                sched.down_us = pen_down_us(cfg, op[1].pen)
            if emit:
                yield op[1]
            continue
        else:
            rows = sched.finish(lift=op[1])
        if rows is not None and emit:
            yield rows
    summary.steps = sched.steps_total.copy()
    summary.time_s = sched.t_us / 1e6


def pen_down_us(cfg: Config, pen: str | None) -> int:
    """The pen-down pulse while `pen` is in: its [pens.NAME] down_us (servo pens), else
    [pen] down_us."""
    spec = cfg.pens.get(pen) if pen is not None else None
    if cfg.pen.kind == "servo" and spec is not None and spec.down_us is not None:
        return int(spec.down_us)
    return cfg.pen.down_us


def change_point(cfg: Config, park, where: str) -> tuple[float, float]:
    """Where the gondola waits at a pen change (G-code mm): config.toml [pens] change_x_mm,
    change_y_mm, else `park` (where the plot started); checked against the page."""
    xy = cfg.pens.change_at
    what = "[pens] change_x_mm, change_y_mm"
    if xy is None:
        xy, what = park, f"where the plot started; set {what} to choose one"
    x, y = float(xy[0]), float(xy[1])
    page = cfg.page
    if not (page.x_min_mm <= x <= page.x_max_mm and page.y_min_mm <= y <= page.y_max_mm):
        raise ConfigError(f"{where}: error: the pen change point X{x:.3f} Y{y:.3f} ({what}) is "
                          f"outside the page (X {page.x_min_mm:g}..{page.x_max_mm:g}, "
                          f"Y {page.y_min_mm:g}..{page.y_max_mm:g})")
    return (x, y)


def _parts(block: Block, spu: np.ndarray) -> Iterator[Block]:
    """A block in parts of about STEPS_PER_PART steps (whole pieces), so that the rows of one
    part stay small however long the pieces are (a block holds up to 2 x 2048 pieces)."""
    steps = (np.abs(np.diff(block.cords, axis=0)) * spu).sum(axis=1)
    total = float(steps.sum())
    if total <= STEPS_PER_PART:
        yield block
        return
    cum = np.cumsum(steps)
    cuts = np.unique(np.searchsorted(cum, np.arange(STEPS_PER_PART, total, STEPS_PER_PART)) + 1)
    i = 0
    for j in [*cuts[cuts < len(steps)].tolist(), len(steps)]:
        yield _slice(block, i, j)
        i = j


def _chord_turn(cfg: Config):
    """How far a chord of an arc may turn (radians) on a two-cord machine, by radius: the pen
    goes round an arc of radius r at up to v = min(draw speed, sqrt(CORNER_SHARE a r)) (a: the
    smallest cord acceleration; a cord's slope is at most 1). The planner counts the speed jump
    at a chord's corner against the 0.1 s acceleration window: it takes the corners of a curve
    as the centripetal v^2 / r when a chord is passed well within TAU_S (chord <= v TAU_S / 2),
    or the jump alone as SHARP_SHARE of the budget otherwise (turn <= SHARP_SHARE a TAU_S / v).
    Where the tolerance alone would cut coarser chords than either, the arc is cut finer, so
    that tiny arcs on a slow machine are not passed at a crawl. None for other machines."""
    if cfg.machine.kind != "vplotter":
        return None
    m = cfg.motors
    acc = float(np.min(m.max_accel * ACCEL_MARGIN / np.asarray(m.steps_per_unit, dtype=float)))
    cap = cfg.motion.draw_speed_mm_s

    def turn(r):
        r = np.maximum(r, 1e-9)
        v = np.minimum(cap, np.sqrt(CORNER_SHARE * acc * r))
        return np.maximum(0.5 * v * TAU_S / r, SHARP_SHARE * acc * TAU_S / v)

    return turn


def plan(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str,
         summary: Summary, start_at: StartAt | None = None,
         pen_down: bool | None = None, chord_share: float = CHORD_SHARE,
         where=None, park=None) -> Iterator[tuple]:
    """The plan: ("start", pen_down), ("motion", Block), ("turn", Turn), ("pen", down, line),
    ("dwell", seconds, line) and ("finish", lift) in the order the machine does them.

    Pen changes and dwells are stops inside the planner's look-ahead, so that many short
    strokes are planned together: they travel with the planned pieces as the events of the
    stop they happen at, and come out right after the block that ends there. A Pause record
    gives ("pause", record), a stop like a pen change; before a pen change (Pause.pen) the
    gondola travels pen up to the change point and goes on from there (`park`: see stream).
    A resumed plan asks for the pen in use at the resume point first (the last pen change
    before it), so that a stop or a power cut during or after a pen change goes on with the
    right pen."""
    where = where or (lambda line, col: f"{name}:{line}:{col}")
    kin = kinematics.from_config(cfg)
    spu = np.asarray(cfg.motors.steps_per_unit)
    summary.motors = tuple(kin.motors)
    cords = np.asarray(ref_mm, dtype=float) + np.asarray(counts, dtype=float) / spu
    start = kin.forward(cords[None, :])[0]
    planner = Planner(kin, cfg.motors.max_step_rate, cfg.motors.max_accel, spu, start,
                      start_q=cords)
    reach = getattr(kin, "first_unreachable", None)
    page = cfg.page
    tol = cfg.motion.tolerance_mm * chord_share
    turn = _chord_turn(cfg)
    mo = cfg.motion
    file_xy = (0.0, 0.0)
    here_xy = tuple(kin.to_gcode(start[None, :])[0].tolist())   # the file's pen point
    park_xy = here_xy if park is None else (float(park[0]), float(park[1]))
    parked = False                       # at the change point, not where the file's pen is
    pending: Pause | None = None         # resume: the pen change of the records skipped

    def blocks(bs: Iterator[Block | Turn]) -> Iterator[tuple]:
        for b in bs:
            if isinstance(b, Turn):
                yield ("turn", b)
                continue
            summary.pieces += len(b.d)
            drawn = float(b.d[b.drawing].sum())
            summary.drawn_mm += drawn
            summary.travel_mm += float(b.d.sum()) - drawn
            i = 0
            for j, events in zip(np.flatnonzero(b.stop).tolist(), b.events):
                yield ("motion", _slice(b, i, j + 1))
                yield from events
                i = j + 1
            if i < len(b.d):
                yield ("motion", _slice(b, i, len(b.d)) if i else b)

    # Moves are batched so that segmenting, page checks and coordinate maps are vector
    # operations. A batch holds moves (cut all at once) or, after a resume, points already cut;
    # each with its cap, line, column, pen, and the events of a stop right after it.
    batch: list[gcode.Move | np.ndarray] = []
    meta: list[tuple[float, int, int, bool]] = []
    after: dict[int, list] = {}          # batch entry -> events at the stop after it

    def stop_for(op: tuple) -> Iterator[tuple]:
        """A pen change or a dwell: after the motion so far, at a standstill."""
        if batch:
            after.setdefault(len(batch) - 1, []).append(op)
        elif not planner.mark_stop([op]):
            yield op                     # standing already

    def flush(stop: bool) -> Iterator[tuple]:
        if batch:
            if all(isinstance(b, gcode.Move) for b in batch):
                pts, n = segment.points_many(batch, tol, turn)
            else:
                parts = [segment.points(b, tol, turn) if isinstance(b, gcode.Move) else b
                         for b in batch]
                pts, n = np.concatenate(parts), np.array([len(p) for p in parts])
            cap, line, col, draw = (np.array(v) for v in zip(*meta))
            bad = segment.first_outside(pts, page.x_min_mm, page.x_max_mm, page.y_min_mm, page.y_max_mm)
            if bad >= 0:
                move = int(np.searchsorted(np.cumsum(n), bad, side="right"))
                x, y = pts[bad]
                raise InputError(
                    f"{where(int(line[move]), int(col[move]))}: error: point X{x:.3f} Y{y:.3f} is outside "
                    f"the page (X {page.x_min_mm:g}..{page.x_max_mm:g}, "
                    f"Y {page.y_min_mm:g}..{page.y_max_mm:g})")
            mpts = kin.to_machine(pts)
            bad = reach(mpts, planner.position) if reach is not None else -1
            if bad >= 0:
                move = int(np.searchsorted(np.cumsum(n), bad, side="right"))
                x, y = pts[bad]
                raise InputError(f"{name}:{line[move]}:{col[move]}: error: the pen cannot reach "
                                 f"X{x:.3f} Y{y:.3f} or the line to it (the arm reaches "
                                 f"{kin.r_min:g}..{kin.r_max:g} mm from the table's centre)")
            keep = planner.nonzero(mpts)
            cap, line, draw = (np.repeat(v, n)[keep] for v in (cap, line, draw))
            # the events after entry i go to the last point kept up to the end of entry i
            last = np.cumsum(keep) - 1
            ends = np.cumsum(n) - 1
            stops: dict[int, list] = {}
            for i, events in after.items():
                at = int(last[ends[i]]) if ends[i] >= 0 else -1
                if at < 0 and not planner.mark_stop(events):
                    yield from events    # before anything of the batch moved, standing still
                elif at >= 0:
                    stops.setdefault(at, []).extend(events)
            batch.clear()
            meta.clear()
            after.clear()
            yield from blocks(planner.add(mpts[keep], cap, line, draw, stops))
        if stop:
            yield from blocks(planner.stop())

    def travel_to(xy, line: int, col: int) -> None:
        batch.append(np.array([xy], dtype=float))
        meta.append((mo.travel_speed_mm_s, line, col, False))

    def change(p: Pause, down: bool) -> Iterator[tuple]:
        """A pen change: pen up, to the change point, wait; a pen that was down (a file that
        changes pens mid-stroke) goes back and down again."""
        nonlocal parked
        xy = change_point(cfg, park_xy, where(p.line, p.col))
        if down:
            yield from stop_for(("pen", False, p.line))
        travel_to(xy, p.line, p.col)
        yield from stop_for(("pause", p))
        if down:
            travel_to(here_xy, p.line, p.col)
            yield from stop_for(("pen", True, p.line))
        parked = not down

    keep_pen = pen_down is not None
    yield ("start", pen_down)
    pen_down = bool(pen_down)
    pairs = ((r, False) for r in records) if start_at is None else \
        _before_resume(records, start_at.line)
    for rec, before in pairs:
        pts = None
        if start_at is not None:
            if before:
                if isinstance(rec, gcode.Pen):
                    pen_down = rec.down
                elif isinstance(rec, gcode.Move):
                    file_xy = here_xy = (rec.x1, rec.y1)
                elif isinstance(rec, Pause) and rec.pen is not None:
                    pending = rec
                continue
            at_change = isinstance(rec, Pause) and rec.pen is not None
            if pending is not None and not at_change:
                yield from change(pending, False)       # the pen is up here (start lifts it)
            parked = False
            if at_change and not pen_down:     # resumed at a pen change: it parks, goes on
                start_at = None
        if start_at is not None:
            # travel pen up to where the drawing goes on, then put the pen as the file has it
            there = file_xy
            if isinstance(rec, gcode.Move):
                pts = segment.points(rec, tol, turn)
                there = (rec.x0, rec.y0)
                if rec.line == start_at.line and start_at.xy is not None and len(pts):
                    there, pts = segment.cut(np.vstack(([[rec.x0, rec.y0]], pts)), start_at.xy)
            start_at = None
            batch.append(np.array([there], dtype=float))
            meta.append((mo.travel_speed_mm_s, rec.line, rec.col, False))
            yield from flush(True)
            if pen_down:
                yield ("pen", True, rec.line)
        if isinstance(rec, gcode.Move):
            summary.moves += 1
            here_xy = (rec.x1, rec.y1)
            if rec.arc or (rec.x1, rec.y1) != (rec.x0, rec.y0):
                parked = False         # pen up from the change point to where the move ends
            if pts is not None and len(pts) == 0:
                continue
            if pen_down:
                cap = mo.draw_speed_mm_s
                if rec.feed_mm_s is not None and not rec.rapid:
                    cap = min(cap, rec.feed_mm_s)
            else:
                cap = mo.travel_speed_mm_s
            batch.append(rec if pts is None else pts)
            meta.append((cap, rec.line, rec.col, pen_down))
            if len(meta) >= BATCH:
                yield from flush(False)
        elif isinstance(rec, gcode.Pen):
            summary.pen_downs += int(rec.down)
            if rec.down and parked:    # back from the change point to where the pen goes down
                travel_to(here_xy, rec.line, rec.col)
            parked = False
            yield from stop_for(("pen", rec.down, rec.line))
            pen_down = rec.down
        elif isinstance(rec, gcode.Dwell):
            yield from stop_for(("dwell", rec.seconds, rec.line))
        elif isinstance(rec, Pause) and rec.pen is not None:
            yield from change(rec, pen_down)
        elif isinstance(rec, Pause):
            yield from stop_for(("pause", rec))
    if start_at is not None:
        raise InputError(f"{name}: error: line {start_at.line} is past the last move of the file")
    yield from flush(True)
    yield ("finish", not keep_pen)


def _before_resume(records, line: int) -> Iterator[tuple]:
    """(record, whether it lies before the place a resume starts at `line`). Those of the
    resume line itself do when a pen-change pause follows on it (a G-code tool change lifts
    the pen, pauses and lowers it on one line): a resume there begins with that change."""
    held: list = []
    it = iter(records)
    for rec in it:
        if rec.line < line:
            yield rec, True
        elif rec.line == line and not (isinstance(rec, Pause) and rec.pen is not None):
            held.append(rec)
        else:
            change = rec.line == line
            yield from ((h, change) for h in held)
            yield rec, False
            yield from ((r, False) for r in it)
            return
    yield from ((h, False) for h in held)


def validate(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str = "<input>",
             start_at: StartAt | None = None, stop=lambda: False,
             scheduler=Scheduler, where=None, park=None) -> Summary | None:
    """The validation pass: every record checked, planned and timed, no step computed.
    Returns the summary, or None if stop() turned true first."""
    summary = Summary()
    kept = Kept()
    ops = _keeping(plan(cfg, records, counts, ref_mm, name, summary, start_at,
                        chord_share=getattr(scheduler, "chord_share", CHORD_SHARE), where=where,
                        park=park),
                   kept)
    stopped = False

    def watched():
        nonlocal stopped
        for op in ops:
            if stop():
                stopped = True
                return
            yield op

    for _ in _schedule(cfg, watched(), counts, ref_mm, False, summary, scheduler):
        pass
    if stopped:
        return None
    summary.plan = None if kept.full else kept
    return summary
