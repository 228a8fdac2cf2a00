"""The plan in stages: records -> steps (motion/steps.py). `pipeline.plan` chains them:

1. `resumed`: the records from the resume point on (those before it only remembered: the pen,
   where the file's pen is, the last pen change), led by the pen's state there, the pen change
   still to make, the travel to the resume point and the pen put back;
2. `PenChanges`: records -> `Path`s (moves, with their speed cap and pen), `Travel`s (pen up)
   and stop steps (`PenMove`, `Dwell`, `Wait`); a pen change becomes pen up if down, travel to
   the change point, the wait, and back with the pen down again if it was down;
3. `Batcher`: paths in batches of BATCH moves, cut (arcs into chords), checked against the page
   and the machine's reach, mapped to the machine frame and fed to the planner, the stop steps
   put at the standstill after the motion so far; yields the planner's Blocks and Turns, and
   the stop steps that happen standing;
4. `split`: Blocks cut at their stops into `Motion`s with the stop's steps after each, Turns
   as `InPlace`.
`Tally` counts records and blocks for the Summary on the way (stages 1-2 and 3-4).
"""

from __future__ import annotations

from typing import Iterable, Iterator, NamedTuple

import numpy as np

from vplotter.errors import ConfigError, InputError
from vplotter.inputs import gcode
from vplotter.inputs.gcode import Move, Pause
from vplotter.motion import segment
from vplotter.motion.planner import Block, Planner, Turn, _slice
from vplotter.motion.steps import Dwell, InPlace, Motion, PenMove, Step, Wait

BATCH = 512  # moves per batch handed to the planner


class Path(NamedTuple):
    """A move to plan: a G-code Move (cut in the batch) or its points already cut (G-code mm,
    without its start), at up to `cap` mm/s, from file place line:col, with the pen down or up
    (`draw`)."""

    what: Move | np.ndarray
    cap: float
    line: int
    col: int
    draw: bool


class Travel(NamedTuple):
    """Pen up, at the travel speed, to xy (G-code mm); line:col name the record it is for."""

    xy: tuple[float, float]
    line: int
    col: int


class CutMove(NamedTuple):
    """The move a resume goes on in: the record and its points from the resume point on."""

    move: Move
    pts: np.ndarray


class At(NamedTuple):
    """Where a resume goes on: the pen down or not, the file's pen point (G-code mm); nothing
    is parked at the change point."""

    pen_down: bool
    xy: tuple[float, float]


class FullStop:
    """Plan everything so far, with the machine standing still at its end."""


FULL_STOP = FullStop()


def planner_at(cfg, kin, counts, ref_mm) -> tuple[Planner, tuple[float, float]]:
    """A planner starting where the motors stand (cords = ref + counts / steps per unit), and
    that point in G-code mm (the file's pen point before the first move)."""
    spu = np.asarray(cfg.motors.steps_per_unit)
    cords = np.asarray(ref_mm, dtype=float) + np.asarray(counts, dtype=float) / spu
    start = kin.forward(cords[None, :])[0]
    planner = Planner(kin, cfg.motors.max_step_rate, cfg.motors.max_accel, spu, start,
                      start_q=cords)
    return planner, tuple(kin.to_gcode(start[None, :])[0].tolist())


def change_point(cfg, park, where: str) -> tuple[float, float]:
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


# ------------------------------------------------------------------- 1. the resume filter

def resumed(records: Iterable[gcode.Record], start_at, here_xy, pen_down: bool, points,
            name: str) -> Iterator:
    """Stage 1 (only for a resumed plan; start_at: pipeline.StartAt): the records from the
    place `start_at` names on, led by what `_resume_at` gives. here_xy, pen_down: the pen
    point and pen at the plan's start; points(move): a move's cut points."""
    file_xy = (0.0, 0.0)             # where the file's pen is; (0, 0) before any move
    pending: Pause | None = None     # the last pen change before the resume point
    pairs = _before_resume(records, start_at.line)
    for rec, before in pairs:
        if not before:
            yield from _resume_at(rec, start_at, here_xy, file_xy, pen_down, pending, points)
            yield from (r for r, _ in pairs)
            return
        if isinstance(rec, gcode.Pen):
            pen_down = rec.down
        elif isinstance(rec, Move):
            file_xy = here_xy = (rec.x1, rec.y1)
        elif isinstance(rec, Pause) and rec.pen is not None:
            pending = rec
    raise InputError(f"{name}: error: line {start_at.line} is past the last move of the file")


def _resume_at(rec, start_at, here_xy, file_xy, pen_down: bool, pending, points) -> Iterator:
    """The first record of a resumed plan, led by the pen change made before it (pen up: the
    plan's Start lifts it), the pen state there, the travel pen up to where the drawing goes
    on (the start of its move; on the resume line, the point of start_at) and the pen put
    down again if the file has it down there. Resumed at a pen change with the pen up, the
    gondola goes to the change point straight away instead."""
    at_change = isinstance(rec, Pause) and rec.pen is not None
    if pending is not None and not at_change:
        yield At(False, here_xy)
        yield pending
    yield At(pen_down, here_xy)
    if at_change and not pen_down:
        yield rec
        return
    there, line, col = file_xy, rec.line, rec.col
    if isinstance(rec, Move):
        pts = points(rec)
        there = (rec.x0, rec.y0)
        if rec.line == start_at.line and start_at.xy is not None and len(pts):
            there, pts = segment.cut(np.vstack(([[rec.x0, rec.y0]], pts)), start_at.xy)
        rec = CutMove(rec, pts)
    yield Travel(there, line, col)
    yield FULL_STOP
    if pen_down:
        yield PenMove(True, line)
    yield rec


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


# ------------------------------------------------------------------- 2. the pen and its changes

class PenChanges:
    """Stage 2: records -> Paths, Travels and stop steps (and FULL_STOP passed on), with the
    pen's state: down or not, the file's pen point, and whether the gondola is parked at the
    change point rather than there (pen up after a change: it goes back when the pen next goes
    down, or on with the next move that goes anywhere). park_xy: the change point when
    [pens] has none (G-code mm); where(line, col): the file place of a line."""

    def __init__(self, cfg, here_xy, pen_down: bool, park_xy, where):
        self.cfg = cfg
        self.down = pen_down
        self.here = here_xy
        self.park = park_xy
        self.where = where
        self.parked = False

    def run(self, items: Iterable) -> Iterator:
        travel_cap = self.cfg.motion.travel_speed_mm_s
        draw_cap = self.cfg.motion.draw_speed_mm_s
        new = tuple.__new__           # a Path per move, without NamedTuple's slower __new__
        for rec in items:
            kind = type(rec)
            if kind is Move:
                self.here = (rec.x1, rec.y1)
                if self.parked and (rec.arc or self.here != (rec.x0, rec.y0)):
                    self.parked = False    # pen up from the change point to where it ends
                if not self.down:
                    yield new(Path, (rec, travel_cap, rec.line, rec.col, False))
                elif rec.feed_mm_s is None or rec.rapid:
                    yield new(Path, (rec, draw_cap, rec.line, rec.col, True))
                else:
                    yield new(Path, (rec, min(draw_cap, rec.feed_mm_s), rec.line, rec.col, True))
            elif kind is gcode.Pen:
                if rec.down and self.parked:   # back from the change point to put it down
                    yield Travel(self.here, rec.line, rec.col)
                self.parked = False
                yield PenMove(rec.down, rec.line)
                self.down = rec.down
            elif kind is gcode.Dwell:
                yield Dwell(rec.seconds, rec.line)
            elif kind is Pause:
                yield from (self.change(rec) if rec.pen is not None else (Wait(rec),))
            elif kind is CutMove:     # the resume's move: as its Move, with the points cut
                for path in self.run((rec.move,)):
                    if len(rec.pts):
                        yield path._replace(what=rec.pts)
            elif kind is At:
                self.down, self.here, self.parked = rec.pen_down, rec.xy, False
            elif kind is Travel or kind is FullStop or isinstance(rec, Step):
                yield rec                  # from the resume filter

    def change(self, p: Pause) -> Iterator:
        """A pen change: pen up, to the change point, wait; a pen that was down (a file that
        changes pens mid-stroke) goes back and down again."""
        xy = change_point(self.cfg, self.park, self.where(p.line, p.col))
        if self.down:
            yield PenMove(False, p.line)
        yield Travel(xy, p.line, p.col)
        yield Wait(p)
        if self.down:
            yield Travel(self.here, p.line, p.col)
            yield PenMove(True, p.line)
        self.parked = not self.down


# ------------------------------------------------------------------- 3. batches to the planner

class Batcher:
    """Stage 3: Paths and Travels batched (BATCH moves; a Travel fills a batch but does not end
    one) so that cutting, the page and reach checks and the coordinate map are vector
    operations, then fed to the planner; each stop step goes with the batch entry before it
    (the machine stands still there), or happens at once when nothing is buffered. Yields
    the planner's Blocks and Turns and the stop steps that happen standing."""

    def __init__(self, cfg, kin, planner: Planner, tol: float, turn, where):
        self.kin = kin
        self.planner = planner
        self.page = cfg.page
        self.travel_cap = cfg.motion.travel_speed_mm_s
        self.tol = tol
        self.turn = turn
        self.where = where
        self.batch: list[Path] = []
        self.after: dict[int, list] = {}     # batch entry -> the steps at the stop after it

    def run(self, items: Iterable) -> Iterator[Block | Turn | Step]:
        batch = self.batch
        for it in items:
            kind = type(it)
            if kind is Path:
                batch.append(it)
                if len(batch) >= BATCH:
                    yield from self.flush(False)
            elif kind is Travel:
                batch.append(Path(np.array([it.xy], dtype=float), self.travel_cap, it.line,
                                  it.col, False))
            elif kind is FullStop:
                yield from self.flush(True)
            else:
                yield from self.stop_for(it)
        yield from self.flush(True)

    def stop_for(self, step: Step) -> Iterator[Step]:
        """A pen move, dwell or wait: after the motion so far, at a standstill."""
        if self.batch:
            self.after.setdefault(len(self.batch) - 1, []).append(step)
        elif not self.planner.mark_stop([step]):
            yield step                   # standing already

    def flush(self, stop: bool) -> Iterator[Block | Turn | Step]:
        """The batch to the planner (`stop`: and plan everything, to a standstill)."""
        if self.batch:
            what, cap, line, col, draw = zip(*self.batch)
            pts, n = self._points(what)
            k = len(cap)
            cap, line, col, draw = (np.fromiter(v, t, k) for v, t in
                                    ((cap, float), (line, np.int64), (col, np.int64), (draw, bool)))
            ends = np.cumsum(n)
            mpts = self._checked(pts, ends, line, col)
            planner = self.planner
            keep = planner.nonzero(mpts)
            cap, line, draw = (np.repeat(v, n)[keep] for v in (cap, line, draw))
            # the steps after entry i go to the last point kept up to the end of entry i
            last = np.cumsum(keep) - 1
            stops: dict[int, list] = {}
            for i, events in self.after.items():
                at = int(last[ends[i] - 1]) if ends[i] - 1 >= 0 else -1
                if at < 0 and not planner.mark_stop(events):
                    yield from events    # before anything of the batch moved, standing still
                elif at >= 0:
                    stops.setdefault(at, []).extend(events)
            self.batch.clear()
            self.after.clear()
            yield from planner.add(mpts[keep], cap, line, draw, stops)
        if stop:
            yield from self.planner.stop()

    def _points(self, what) -> tuple[np.ndarray, np.ndarray]:
        """The cut points of the batch's entries (G-code mm) and how many each has."""
        if all(isinstance(w, Move) for w in what):
            return segment.points_many(what, self.tol, self.turn)
        parts = [segment.points(w, self.tol, self.turn) if isinstance(w, Move) else w
                 for w in what]
        return np.concatenate(parts), np.array([len(p) for p in parts])

    def _checked(self, pts: np.ndarray, ends: np.ndarray, line, col) -> np.ndarray:
        """The points in the machine frame, checked against the page and the machine's reach
        (an error names the file place of the entry of the first bad point)."""
        page = self.page
        bad = segment.first_outside(pts, page.x_min_mm, page.x_max_mm, page.y_min_mm,
                                    page.y_max_mm)
        if bad >= 0:
            x, y = pts[bad]
            raise InputError(
                f"{self._place(bad, ends, line, col)}: error: point X{x:.3f} Y{y:.3f} is "
                f"outside the page (X {page.x_min_mm:g}..{page.x_max_mm:g}, "
                f"Y {page.y_min_mm:g}..{page.y_max_mm:g}): give --fit to scale the drawing onto "
                f"the page, or move it (--offset, --align)")
        mpts = self.kin.to_machine(pts)
        bad = self.kin.check_move(mpts, self.planner.position)
        if bad >= 0:
            x, y = pts[bad]
            raise InputError(f"{self._place(bad, ends, line, col)}: error: "
                             f"{self.kin.cannot_reach(x, y)}")
        return mpts

    def _place(self, point: int, ends: np.ndarray, line, col) -> str:
        move = int(np.searchsorted(ends, point, side="right"))
        return self.where(int(line[move]), int(col[move]))


# ------------------------------------------------------------------- 4. blocks split at stops

def split(planned: Iterable[Block | Turn | Step]) -> Iterator[Step]:
    """Stage 4: each Block as Motions ending at its stops, the steps of each stop right after
    its Motion; a Turn as InPlace; steps as they come."""
    for b in planned:
        if isinstance(b, Block):
            i = 0
            if b.events:
                b.durations        # once for the block: its Motions take their part of it
            for j, events in zip(np.flatnonzero(b.stop).tolist(), b.events):
                yield Motion(_slice(b, i, j + 1, [events]))   # one stop: at its end
                yield from events
                i = j + 1
            if i < len(b.d):
                yield Motion(_slice(b, i, len(b.d), []) if i else b)
        elif isinstance(b, Turn):
            yield InPlace(b)
        else:
            yield b


class Tally:
    """What the plan counts for the Summary, the one place it does: `records` (after stage 1)
    counts the moves and pen-downs of the file from the resume point on, `blocks` (after
    stage 3) the pieces and the mm drawn and travelled; the machine's motors are named at the
    start. (The schedule adds steps, time and the pens' times.)"""

    def __init__(self, summary, motors):
        self.summary = summary
        summary.motors = tuple(motors)

    def records(self, items: Iterable) -> Iterator:
        s = self.summary
        for rec in items:
            kind = type(rec)
            if kind is Move or kind is CutMove:
                s.moves += 1
            elif kind is gcode.Pen:
                s.pen_downs += int(rec.down)
            yield rec

    def blocks(self, planned: Iterable) -> Iterator:
        s = self.summary
        for b in planned:
            if isinstance(b, Block):
                s.pieces += len(b.d)
                drawn = float(b.d[b.drawing].sum())
                s.drawn_mm += drawn
                s.travel_mm += float(b.d.sum()) - drawn
            yield b
