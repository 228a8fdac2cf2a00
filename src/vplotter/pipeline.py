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
from vplotter.errors import ConfigError
from vplotter.inputs import gcode
from vplotter.inputs.gcode import Pause
from vplotter.motion import plan_stages as stages, segment
from vplotter.motion.plan_stages import change_point  # noqa: F401  (public here)
from vplotter.motion.planner import Block, _slice
from vplotter.motion.schedule import Rows, Scheduler
from vplotter.motion.segment import CHORD_SHARE
from vplotter.motion.steps import Dwell, Finish, InPlace, Motion, PenMove, Start, Step, Wait


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
    """Rows for drawing `records` starting from the given step counts (cords = ref + counts /
    steps per unit).

    With `start_at`, records before that line are skipped (their pen changes still count), the
    pen travels up to the resume point and goes down again if the file has it down there.
    With `keep` (a Kept list), the plan (its steps) is appended to it, so that
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
    steps = plan(cfg, records, counts, ref_mm, name, summary, start_at, pen_down,
                 getattr(scheduler, "chord_share", CHORD_SHARE), where, park)
    if keep is not None:
        steps = _keeping(steps, keep)
    yield from _schedule(cfg, steps, counts, ref_mm, emit, summary, scheduler)


def replay(cfg: Config, ops: list[Step], counts, ref_mm) -> Iterator[Rows]:
    """The rows of a plan kept by `validate`; the same rows `stream` makes."""
    yield from _schedule(cfg, iter(ops), counts, ref_mm, True, Summary())


class Kept(list):
    """A plan being kept; `full` once it grew past PLAN_LIMIT pieces (then it is dropped)."""

    full = False
    pieces = 0


def _keeping(steps: Iterator[Step], keep: Kept) -> Iterator[Step]:
    for step in steps:
        if not keep.full:
            keep.append(step)
            if type(step) is Motion:
                keep.pieces += len(step.block.d)
                if keep.pieces > PLAN_LIMIT:      # too long to keep: the draw plans it again
                    keep.clear()
                    keep.full = True
        yield step


def _schedule(cfg, steps: Iterator[Step], counts, ref_mm, emit: bool, summary: Summary,
              scheduler=Scheduler) -> Iterator[Rows | Pause]:
    """The steps played: what `scheduler` makes of each (Rows), and each Wait's Pause."""
    kin = kinematics.from_config(cfg)
    yield from _scheduled(cfg, scheduler(cfg, kin, counts, ref_mm), steps, emit, summary)


def _scheduled(cfg, sched, steps: Iterator[Step], emit: bool,
               summary: Summary) -> Iterator[Rows | Pause]:
    """The steps played by a scheduler made already (`Chain` keeps one for all its parts)."""
    spu = np.asarray(cfg.motors.steps_per_unit, dtype=float)
    for step in steps:
        kind = type(step)
        if kind is Motion:
            if not emit and type(sched).motion is Scheduler.motion:  # as below, in one pass
                sched.quiet(step.block, _bounds(step.block, spu))
                continue
            for part in _parts(step.block, spu):
                rows = sched.motion(part, emit)
                if rows is not None and emit:
                    yield rows
                rows = None             # not kept alive while the player plays it
            continue
        elif kind is PenMove:
            rows = sched.pen(step.down, step.line, emit)
        elif kind is Dwell:
            rows = sched.dwell(step.seconds, step.line)
        elif kind is InPlace:
            if not hasattr(sched, "turn"):
                raise ConfigError("error: the polar table turns in place at its centre here, "
                                  "which this backend cannot send; use a GPIO backend")
            rows = sched.turn(step.turn, emit)
        elif kind is Start:
            rows = sched.start(step.pen_down)
        elif kind is Wait:
            yield from _wait(cfg, sched, step.pause, emit, summary)
            continue
        else:
            rows = sched.finish(lift=step.lift)
        if rows is not None and emit:
            yield rows
    summary.steps = sched.steps_total.copy()
    summary.time_s = sched.t_us / 1e6


def _wait(cfg, sched, pause: Pause, emit: bool, summary: Summary) -> Iterator[Rows | Pause]:
    """A Wait played: the pause passed on for the player; a plain one releases the coils, a
    pen change holds them and sets the new pen's pen-down pulse."""
    summary.pen_mark(pause, sched.t_us / 1e6)
    if pause.pen is None:
        rows = sched.release()
        if emit and rows is not None:
            yield rows
    else:
        sched.down_us = pen_down_us(cfg, pause.pen)
    if emit:
        yield pause


def pen_down_us(cfg: Config, pen: str | None) -> int:
    """The pen-down pulse while `pen` is in: its [pens.NAME] down_us (servo pens), else
    [pen] down_us."""
    spec = cfg.pens.get(pen) if pen is not None else None
    if cfg.pen.kind == "servo" and spec is not None and spec.down_us is not None:
        return int(spec.down_us)
    return cfg.pen.down_us


def _parts(block: Block, spu: np.ndarray) -> Iterator[Block]:
    """A block in parts of about STEPS_PER_PART steps (whole pieces), so that the rows of one
    part stay small however long the pieces are (a block holds up to 2 x 2048 pieces)."""
    bounds = _bounds(block, spu)
    if len(bounds) == 1:
        yield block
        return
    for i, j in bounds:
        yield _slice(block, i, j)


def _bounds(block: Block, spu: np.ndarray) -> list[tuple[int, int]]:
    """The parts of `_parts` as (first piece, end) pairs."""
    cords = block.cords
    steps = np.abs(np.diff(cords[:, 0])) * spu[0]      # motor by motor: see refine.least
    for m in range(1, cords.shape[1]):
        steps = steps + np.abs(np.diff(cords[:, m])) * spu[m]
    total = float(steps.sum())
    if total <= STEPS_PER_PART:
        return [(0, len(steps))]
    cum = np.cumsum(steps)
    cuts = np.unique(np.searchsorted(cum, np.arange(STEPS_PER_PART, total, STEPS_PER_PART)) + 1)
    ends = [*cuts[cuts < len(steps)].tolist(), len(steps)]
    return list(zip([0, *ends[:-1]], ends))


def plan(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str,
         summary: Summary, start_at: StartAt | None = None,
         pen_down: bool | None = None, chord_share: float = CHORD_SHARE,
         where=None, park=None) -> Iterator[Step]:
    """The plan: the steps (motion/steps.py) in the order the machine does them, from the
    stages of motion/plan_stages.py.

    Pen changes and dwells are stops inside the planner's look-ahead, so that many short
    strokes are planned together: they travel with the planned pieces as the steps of the
    stop they happen at, and come out right after the Motion that ends there. A Pause record
    gives Wait, a stop like a pen change; before a pen change (Pause.pen) the gondola travels
    pen up to the change point and goes on from there (`park`: see stream). A resumed plan
    asks for the pen in use at the resume point first (the last pen change before it), so
    that a stop or a power cut during or after a pen change goes on with the right pen."""
    where = where or (lambda line, col: f"{name}:{line}:{col}")
    kin = kinematics.from_config(cfg)
    planner, here_xy = stages.planner_at(cfg, kin, counts, ref_mm)
    park_xy = here_xy if park is None else (float(park[0]), float(park[1]))
    tol = cfg.motion.tolerance_mm * chord_share
    turn = segment.chord_turn(cfg)
    tally = stages.Tally(summary, kin.motors)
    yield Start(pen_down)
    down = bool(pen_down)
    items = records
    if start_at is not None:
        items = stages.resumed(records, start_at, here_xy, down,
                               lambda move: segment.points(move, tol, turn), name)
    items = stages.PenChanges(cfg, here_xy, down, park_xy, where).run(tally.records(items))
    planned = stages.Batcher(cfg, kin, planner, tol, turn, where).run(items)
    yield from stages.split(tally.blocks(planned))
    yield Finish(pen_down is None)


def validate(cfg: Config, records: Iterable[gcode.Record], counts, ref_mm, name: str = "<input>",
             start_at: StartAt | None = None, stop=lambda: False,
             scheduler=Scheduler, where=None, park=None,
             pen_down: bool | None = None) -> Summary | None:
    """The validation pass: every record checked, planned and timed, no step computed.
    Returns the summary, or None if stop() turned true first. pen_down: as for `stream`."""
    summary = Summary()
    kept = Kept()
    steps = _keeping(plan(cfg, records, counts, ref_mm, name, summary, start_at, pen_down,
                          chord_share=getattr(scheduler, "chord_share", CHORD_SHARE),
                          where=where, park=park),
                     kept)
    watched = _Watched(steps, stop)
    for _ in _schedule(cfg, iter(watched), counts, ref_mm, False, summary, scheduler):
        pass
    if watched.stopped:
        return None
    summary.plan = None if kept.full else kept
    return summary


class _Watched:
    """The steps, until stop() turns true (then `stopped`)."""

    def __init__(self, steps: Iterator[Step], stop):
        self.steps = steps
        self.stop = stop
        self.stopped = False

    def __iter__(self) -> Iterator[Step]:
        for step in self.steps:
            if self.stop():
                self.stopped = True
                return
            yield step


class Chain:
    """Records drawn in parts as one drawing: what the Python API (`vplotter.api`) plays.

    One scheduler serves every part, so that the schedule's clock, the coils held and the pen
    carry on from one part to the next as within one file. Each part is validated first (all
    of it planned, timed and checked against the page before it moves: `validate`), planned
    from where the last part ended, and ends stopped (its last move ends at rest, as at a pen
    lift). `finish` ends the drawing as a file ends: pen up, coils released."""

    def __init__(self, cfg: Config, counts, ref_mm, name: str = "<script>", where=None,
                 park=None):
        self.cfg, self.ref_mm, self.name, self.where, self.park = cfg, ref_mm, name, where, park
        self.sched = Scheduler(cfg, kinematics.from_config(cfg), counts, ref_mm)
        self.summary = Summary()
        self.started = False

    @property
    def counts(self) -> tuple[int, int]:
        """The step counts where the last part ends."""
        return int(self.sched.counts[0]), int(self.sched.counts[1])

    def _pen(self) -> bool | None:
        return self.sched.pen_down if self.started else None     # None: lift it first

    def validate(self, records: list[gcode.Record], stop=lambda: False) -> Summary | None:
        """The validation pass of the next part (None: stop() turned true first)."""
        return validate(self.cfg, records, self.counts, self.ref_mm, self.name, stop=stop,
                        where=self.where, park=self.park, pen_down=self._pen())

    def rows(self, part: Summary, records: list[gcode.Record]) -> Iterator[Rows | Pause]:
        """The rows of a validated part: its kept plan, else `records` planned again."""
        steps: Iterable[Step] = part.plan if part.plan is not None else plan(
            self.cfg, records, self.counts, self.ref_mm, self.name, Summary(), None,
            self._pen(), where=self.where, park=self.park)
        self.started = True
        s = self.summary
        s.moves, s.pieces, s.pen_downs = (s.moves + part.moves, s.pieces + part.pieces,
                                          s.pen_downs + part.pen_downs)
        s.drawn_mm, s.travel_mm = s.drawn_mm + part.drawn_mm, s.travel_mm + part.travel_mm
        s.motors = part.motors
        kept = (step for step in steps if type(step) is not Finish)   # no lift, no release
        yield from _scheduled(self.cfg, self.sched, kept, True, Summary())
        s.steps, s.time_s = self.sched.steps_total.copy(), self.sched.t_us / 1e6

    def finish(self) -> Iterator[Rows]:
        """The end of the drawing: pen up, coils released."""
        rows = self.sched.finish(lift=True)
        if rows is not None:
            yield rows
        self.summary.time_s = self.sched.t_us / 1e6
