"""Step schedule: planned motion + pen events -> rows of output states on one timeline.

A `Rows` chunk says: at time t_us (microseconds since the start) the outputs become
(motor output word, pen pulse width); drivers.py makes the words (coils or step/dir).
Backends play rows and compute no geometry; the trace is written from them. Each motor
steps when its coordinate (a cord length, the polar table's angle or arm's radius), computed
from the pen's planned position through the inverse kinematics, crosses the next step
boundary (half-way between two step counts), so step targets are absolute and rounding never
accumulates.

Motors are energised from the first move on and hold the gondola through pen changes and
dwells; they are released at a pause and at the end. A motor is energised and released only in
a one-coil phase of the half-step table: one resting in a two-coil phase is energised at its
one-coil neighbour (one half step back, which its next move takes up) and takes that half step
before it is released. Every energise and release is then one pin, so a board written one pin
at a time never shows a half step that the rows do not have. Energised motors are held for one
step interval before they move, so no step is lost. A `Turn` (the polar table at its centre)
moves the motors from rest to rest with the pen standing still. A pause for a new pen (a pen
change) is not released: the motors hold the gondola while the pen is put in.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vplotter.motion import drivers
from vplotter.config import Config
from vplotter.motion.planner import ACCEL_MARGIN, RATE_MARGIN, Block, Turn


@dataclass
class Rows:
    t_us: np.ndarray     # int64
    coils: np.ndarray    # uint8 motor output word after the row (Motors.out_pins, drivers.py)
    pen_us: np.ndarray   # int32 pen pulse width after the row (0 = pulses off)
    line: np.ndarray     # int64 G-code line being drawn
    steps: np.ndarray    # (n, 2) int64 step counts of both motors after the row

    def __len__(self) -> int:
        return len(self.t_us)

    def __getitem__(self, rows: slice) -> "Rows":
        return Rows(self.t_us[rows], self.coils[rows], self.pen_us[rows], self.line[rows],
                    self.steps[rows])

    def copy(self) -> "Rows":
        return Rows(self.t_us.copy(), self.coils.copy(), self.pen_us.copy(), self.line.copy(),
                    self.steps.copy())

    @staticmethod
    def concat(parts: list["Rows"]) -> "Rows":
        return Rows(*(np.concatenate([getattr(p, f) for p in parts])
                      for f in ("t_us", "coils", "pen_us", "line", "steps")))


class Scheduler:
    """Turns a stream of planned blocks, turns and pen events into Rows. Keeps the clock and
    the step counts (the driver keeps the output state)."""

    one_coil_rest = True      # energise and release in one-coil phases (see the module doc)

    def __init__(self, cfg: Config, kin, counts, ref_mm):
        m = cfg.motors
        self.cfg = cfg
        self.kin = kin
        self.spu = np.asarray(m.steps_per_unit, dtype=float)
        self.hold_us = int(np.ceil(1e6 / m.max_step_rate))
        self.min_interval_us = self.hold_us + 1
        self.last_step_us = [-(10 ** 12), -(10 ** 12)]
        self.settle_us = int(round(cfg.pen.settle_s * 1e6))
        self.ref = np.asarray(ref_mm, dtype=float)
        self.counts = np.asarray(counts, dtype=np.int64).copy()
        self.drv = drivers.create(m, self.counts)
        self.idle = self.drv.idle_word
        self.t_us = 0
        self.energized = False
        self.pen_down = False
        self.pen_us = 0
        self.down_us = cfg.pen.down_us    # the pen-down pulse of the pen that is in
        self.line = 0
        self.steps_total = np.zeros(2, dtype=np.int64)
        self.t_us_floor = 0       # rows before this time were output already

    # -- rows helpers
    def _row(self, t_us: int, coils: int, pen_us: int) -> Rows:
        return Rows(np.array([t_us], dtype=np.int64), np.array([coils], dtype=np.uint8),
                    np.array([pen_us], dtype=np.int32), np.array([self.line], dtype=np.int64),
                    self.counts[None, :].copy())

    def _energize(self, rows: list, emit: bool = True) -> None:
        """Energise the motors where they stand and hold them one step interval."""
        if not self.energized:
            if emit:
                rows.append(self._row(self.t_us, self.drv.hold_word(), 0))
            self.energized = True
            self.t_us += self.hold_us

    def _take_up(self, rows: list, start: np.ndarray, emit: bool) -> None:
        """Just energised a half step away from where the next move starts (released at the
        one-coil neighbour at a pause): take that half step now, and hold again."""
        d = np.clip(start - self.counts, -1, 1)
        if not d.any():
            return
        self.drv.advance(d)
        self.counts = self.counts + d
        if emit:
            rows.append(self._row(self.t_us, self.drv.hold_word(), 0))
        for m in (0, 1):
            if d[m]:
                self.last_step_us[m] = self.t_us
        self.t_us += self.hold_us

    def _steps(self, t_us, motor, dirn, line, head: Rows | None = None) -> Rows:
        """Rows for step events sorted by time (line: G-code line of each event), after the
        row `head` if given (built in place: no copy of the step rows)."""
        is_l = motor == 0
        cl = np.cumsum(np.where(is_l, dirn, 0))
        cr = np.cumsum(np.where(is_l, 0, dirn))
        t, words, done, ev = self.drv.rows(t_us, motor, dirn, self.t_us_floor, cl, cr)
        if done is not None:                  # several rows per step event (step/dir)
            cl, cr = np.concatenate(([0], cl))[done], np.concatenate(([0], cr))[done]
            line = np.asarray(line)[ev]
        for m in (0, 1):
            mine = t_us[motor == m]
            if len(mine):
                self.last_step_us[m] = max(self.last_step_us[m], int(mine[-1]))
        self.t_us = max(self.t_us, int(t[-1]))
        k = 0 if head is None else len(head)
        n = len(t) + k
        rows = Rows(np.empty(n, np.int64), np.empty(n, np.uint8), np.zeros(n, np.int32),
                    np.empty(n, np.int64), np.empty((n, 2), np.int64))
        if head is not None:
            for f in ("t_us", "coils", "pen_us", "line", "steps"):
                getattr(rows, f)[:k] = getattr(head, f)
        rows.t_us[k:] = t
        rows.coils[k:] = words
        rows.line[k:] = line
        rows.steps[k:, 0] = self.counts[0] + cl
        rows.steps[k:, 1] = self.counts[1] + cr
        return rows

    def start(self, pen_down: bool | None = None) -> Rows | None:
        """Lift the pen (wherever it is) and let it settle, coils released. With pen_down
        given, the pen is known to be in that state already and nothing is sent."""
        if pen_down is not None:
            self.pen_down = pen_down
            return None
        up = self.cfg.pen.up_us
        rows = [self._row(0, self.idle, up), self._row(self.settle_us, self.idle, 0)]
        self.t_us = self.settle_us
        self.pen_us = 0
        return Rows.concat(rows)

    def pen(self, down: bool, line: int = 0, emit: bool = True) -> Rows | None:
        """The pen's pulse and its settle; with emit=False only the clock advances."""
        if down == self.pen_down:
            return None
        self.line = line
        self.pen_down = down
        t = self.t_us
        self.t_us += self.settle_us
        if not emit:
            return None
        width = self.down_us if down else self.cfg.pen.up_us
        coils = self.drv.hold_word() if self.energized else self.idle
        return Rows.concat([self._row(t, coils, width), self._row(t + self.settle_us, coils, 0)])

    def release(self) -> Rows | None:
        """Release the motors, from a one-coil phase: a motor in a two-coil phase first takes
        the half step back to its neighbour (one step interval after its last step)."""
        if not self.energized:
            return None
        self.energized = False
        d = self.drv.to_one_coil() if self.one_coil_rest else np.zeros(2, np.int64)
        rows = []
        if d.any():
            t = max([self.t_us] + [self.last_step_us[m] + self.min_interval_us
                                   for m in (0, 1) if d[m]])
            self.drv.advance(d)
            self.counts = self.counts + d
            for m in (0, 1):
                if d[m]:
                    self.last_step_us[m] = t
            rows.append(self._row(t, self.drv.hold_word(), 0))
            self.t_us = t + self.hold_us
        rows.append(self._row(self.t_us, self.idle, 0))
        return Rows.concat(rows)

    def dwell(self, seconds: float, line: int = 0) -> Rows | None:
        """Wait with the pen as it is and the motors held."""
        self.line = line
        self.t_us += int(round(seconds * 1e6))
        return None

    def finish(self, lift: bool = True) -> Rows | None:
        parts = [r for r in (self.pen(False, self.line) if lift else None, self.release())
                 if r is not None]
        return Rows.concat(parts) if parts else None

    def targets(self, block: Block) -> np.ndarray:
        """Absolute step count of each motor at each vertex (rounded, never accumulated)."""
        cords = block.cords
        n = np.empty(cords.shape, dtype=np.int64)
        for m in range(cords.shape[1]):    # motor by motor: see refine.least
            n[:, m] = np.rint((cords[:, m] - self.ref[m]) * self.spu[m])
        n[0] = self.counts
        return n

    def motion(self, block: Block, emit: bool = True) -> Rows | None:
        """Rows for one planned block; with emit=False only the clock and counts advance."""
        rows = []
        if not self.energized:
            self._energize(rows, emit)
            start = np.rint((block.cords[0] - self.ref) * self.spu).astype(np.int64)
            self._take_up(rows, start, emit)
        targets = self.targets(block)
        dur = block.durations
        self.steps_total += np.abs(np.diff(targets, axis=0)).sum(axis=0)
        t0 = self.t_us
        self.t_us_floor = t0
        self.t_us = t0 + int(round(float(dur.sum()) * 1e6))
        if not emit:
            self.drv.advance(targets[-1] - targets[0])
            self._advance(targets, block)
            return None
        starts = np.concatenate(([0.0], np.cumsum(dur)[:-1]))
        e = block.e
        T, S, V, A, s_cru, s_dec = block.phase_table(starts)
        table = (T * 1e6 + t0, S, V * 1e-6, A * 1e-12, s_cru, s_dec)   # in microseconds
        times, dirs, pieces = [], [], []
        for m in (0, 1):
            ns, ne = targets[:-1, m], targets[1:, m]
            c = np.abs(ne - ns)
            total = int(c.sum())
            if total == 0:
                times.append(np.zeros(0, np.int64))
                dirs.append(np.zeros(0, np.int8))
                pieces.append(np.zeros(0, np.intp))
                continue
            piece = np.repeat(np.arange(len(c)), c)
            j = np.arange(total) - np.repeat(np.cumsum(c) - c, c)
            step = np.sign(ne - ns)                                # per piece: +1 / -1
            rising = step[piece] > 0
            # step k of a piece crosses half-way to the next count: ns + step (k + 1/2)
            q = ((self.ref[m] + (ns + 0.5 * step) / self.spu[m])[piece]
                 + (step / self.spu[m])[piece] * j)
            s = self.kin.crossing(block.verts[:-1], e, m, piece, q, rising, 1.0 / self.spu[m])
            np.clip(s, 0.0, block.d[piece], out=s)
            t_us = np.rint(block.time_at(piece, s, table)).astype(np.int64)
            t_us, dirn, piece = self._spaced(m, t_us, step[piece].astype(np.int8), piece)
            times.append(t_us)
            dirs.append(dirn)
            pieces.append(piece)
        if sum(len(t) for t in times):
            t_all = np.concatenate(times)
            order = np.argsort(t_all, kind="stable")
            motor = np.repeat(np.arange(2), [len(t) for t in times])[order]
            dirn = np.concatenate(dirs)[order].astype(np.int64)
            piece = np.concatenate(pieces)[order]
            head = Rows.concat(rows) if rows else None
            rows = [self._steps(t_all[order], motor, dirn, block.line[piece], head)]
        self._advance(targets, block)
        return Rows.concat(rows) if len(rows) > 1 else (rows[0] if rows else None)

    def quiet(self, block: Block, parts: list[tuple[int, int]]) -> None:
        """`motion(block[i:j], emit=False)` for each part (i, j) in turn, in one pass over the
        block: the clock, the counts, the steps and the drivers end as they would."""
        if not self.energized:
            rows: list = []
            self._energize(rows, False)
            start = np.rint((block.cords[0] - self.ref) * self.spu).astype(np.int64)
            self._take_up(rows, start, False)
        targets = self.targets(block)
        self.steps_total += [int(np.abs(np.diff(targets[:, m])).sum())
                             for m in range(targets.shape[1])]
        dur = block.durations
        for i, j in parts:   # a part's durations are dur[i:j], its targets targets[i:j + 1]
            self.t_us_floor = self.t_us
            self.t_us += int(round(float(dur[i:j].sum()) * 1e6))
            self.drv.advance(targets[j] - targets[i])
        self._advance(targets, block)

    def _advance(self, targets: np.ndarray, block: Block) -> None:
        self.counts = targets[-1].copy()
        self.line = int(block.line[-1])

    def _spaced(self, m: int, t_us, dirn, piece):
        """Keep one motor's steps at least one step interval apart.

        Where a cord turns round at a corner right at a step boundary it would step there and
        straight back; such a pair is dropped (the count is the same and the cord stays within
        half a step of its ideal length). Whatever is still too close (only across blocks) is
        delayed just enough: t'_i = max(t_i, t'_(i-1) + interval), a running maximum.
        """
        gap = self.min_interval_us
        while len(t_us) > 1:
            quick = (np.diff(t_us) < gap) & (dirn[1:] != dirn[:-1])
            idx = np.flatnonzero(quick)
            if not len(idx):
                break
            idx = idx[np.concatenate(([True], np.diff(idx) > 1))]   # pairs that do not overlap
            keep = np.ones(len(t_us), dtype=bool)
            keep[idx] = keep[idx + 1] = False
            t_us, dirn, piece = t_us[keep], dirn[keep], piece[keep]
        if len(t_us):
            i = np.arange(len(t_us)) * gap
            u = t_us - i
            u[0] = max(u[0], self.last_step_us[m] + gap)
            t_us = np.maximum.accumulate(u) + i
            self.last_step_us[m] = int(t_us[-1])
        return t_us, dirn, piece

    def cord_move(self, delta_steps, rate_share: float = 0.5) -> Rows | None:
        """Move both motors by whole steps, linearly in motor space, rest to rest (jog by cord,
        calibration), then release. The leading motor runs at most rate_share x max_step_rate."""
        m = self.cfg.motors
        rows = self._rest_move(delta_steps, m.max_step_rate * rate_share, m.max_accel * 0.95)
        if rows is None:
            return None
        return Rows.concat([rows, self.release()])

    def turn(self, turn: Turn, emit: bool = True) -> Rows | None:
        """The motors move to turn.q with the pen standing still (the polar table turning at the
        centre), from rest to rest within the rate and acceleration limits."""
        target = np.rint((np.asarray(turn.q) - self.ref) * self.spu).astype(np.int64)
        self.line = turn.line
        head = []
        if np.any(target != self.counts):
            self._energize(head, emit)
        delta = target - self.counts
        self.steps_total += np.abs(delta)
        m = self.cfg.motors
        v, a = m.max_step_rate * RATE_MARGIN, m.max_accel * ACCEL_MARGIN
        if not emit:
            lead = int(np.abs(delta).max())
            if lead:
                self._energize([], False)
                self.t_us += int(round(
                    float(_rest_to_rest(np.array([float(lead)]), lead, v, a)[0]) * 1e6))
                self.drv.advance(delta)
                self.counts = self.counts + delta
            return None
        return self._rest_move(delta, v, a, head)

    def _rest_move(self, delta_steps, v: float, a: float, head: list | None = None) -> Rows | None:
        delta = np.asarray(delta_steps, dtype=np.int64)
        lead = int(np.abs(delta).max())
        rows = head or []
        if lead == 0:
            return Rows.concat(rows) if rows else None
        self._energize(rows)
        times, motors, dirs = [], [], []
        for k in (0, 1):
            n = abs(int(delta[k]))
            if n == 0:
                continue
            x = (np.arange(n) + 0.5) * lead / n
            times.append(_rest_to_rest(x, float(lead), v, a))
            motors.append(np.full(n, k))
            dirs.append(np.full(n, 1 if delta[k] > 0 else -1))
        total = float(_rest_to_rest(np.array([float(lead)]), float(lead), v, a)[0])
        t = np.concatenate(times)
        order = np.argsort(t, kind="stable")
        t0 = self.t_us
        self.t_us_floor = t0
        t_us = t0 + np.rint(t[order] * 1e6).astype(np.int64)
        motor, dirn = np.concatenate(motors)[order], np.concatenate(dirs)[order]
        rows.append(self._steps(t_us, motor, dirn, np.full(len(t_us), self.line)))
        self.t_us = max(self.t_us, t0 + int(round(total * 1e6)))
        self.counts = self.counts + delta
        return Rows.concat(rows)


def _rest_to_rest(x: np.ndarray, d: float, v: float, a: float) -> np.ndarray:
    """Times at which a trapezoidal move of length d (speed v, acceleration a, from rest to
    rest) reaches the positions x."""
    d_acc = min(v * v / (2 * a), d / 2)
    vp = np.sqrt(2 * a * d_acc)
    t_acc = vp / a
    d_cru = d - 2 * d_acc
    t_cru = d_cru / vp
    rest = np.maximum(vp * vp - 2 * a * (x - d_acc - d_cru), 0.0)
    return np.where(x < d_acc, np.sqrt(2 * np.maximum(x, 0) / a),
                    np.where(x < d_acc + d_cru, t_acc + (x - d_acc) / vp,
                             t_acc + t_cru + (vp - np.sqrt(rest)) / a))
