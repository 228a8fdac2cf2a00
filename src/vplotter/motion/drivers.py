"""Motor drivers: step events (time, motor, direction) -> output words on the motor pins.

The schedule finds when each motor steps; a driver turns those events into rows of an output
word over `Motors.out_pins` (bit i = out_pins[i]), so the step timing stays one code path:

- `Coils` (ULN2003 boards): the word is IN1..IN4 of both motors, one row per step, walking the
  half/full/wave table (see sequencer.py); released = all coils low.
- `StepDir` (A4988, DRV8825): the word is STEP, DIR of each motor and ENABLE (bit 4, active
  low). A step is a rising edge of STEP; DIR is set `dir_setup_us` before the edge when it
  changes, STEP falls again `step_pulse_us` after it. Released = ENABLE high (motors free).
  With `*_reverse` false, DIR high lengthens the cord / turns the table counter-clockwise /
  moves the pen away from the centre.

Drivers keep only their output state (coil phases, DIR levels); the step counts are the
schedule's.
"""

from __future__ import annotations

import numpy as np

from vplotter.motion.sequencer import TABLES, coil_words

ENABLE_BIT = 4


def create(motors, counts):
    return StepDir(motors) if motors.driver == "stepdir" else Coils(motors, counts)


class Coils:
    idle_word = 0

    def __init__(self, motors, counts):
        self.table = TABLES[motors.drive]
        self.sign = np.array([-1 if r else 1 for r in motors.reverse])
        self.phase = (np.asarray(counts, dtype=np.int64) * self.sign) % len(self.table)

    def hold_word(self) -> int:
        """The word that energises both motors where they stand."""
        return int(coil_words(self.table, self.phase[:1], self.phase[1:])[0])

    def advance(self, delta_steps) -> None:
        """The motors moved by delta_steps without rows (a validation pass)."""
        self.phase = (self.phase + np.asarray(delta_steps) * self.sign) % len(self.table)

    def to_one_coil(self) -> np.ndarray:
        """Per motor, the count change (-1, or 0) that takes a motor resting in a two-coil phase
        of the half-step table to its one-coil neighbour. Motors are energised and released
        only there: from or to a one-coil pattern that is one pin, so no pin written after
        another (gpiozero) ever shows a half step that the schedule does not have."""
        coils = np.array([bin(int(w)).count("1") for w in self.table])
        if coils.min() == coils.max():          # full or wave drive: nothing to choose
            return np.zeros(2, dtype=np.int64)
        return np.where(coils[self.phase] == 2, -1, 0).astype(np.int64)

    def rows(self, t_us: np.ndarray, motor: np.ndarray, dirn: np.ndarray, floor_us: int,
             cl: np.ndarray, cr: np.ndarray):
        """Rows for step events sorted by time (cl, cr: each motor's steps so far after each
        event): (t_us, words, done, event) where done[i] is how many events have stepped after
        row i and event[i] the event row i belongs to; None for both: one row per event."""
        words = coil_words(self.table, self.phase[0] + cl * self.sign[0],
                           self.phase[1] + cr * self.sign[1])
        self.advance((int(cl[-1]), int(cr[-1])))
        return t_us, words, None, None


class StepDir:
    idle_word = 1 << ENABLE_BIT

    def __init__(self, motors):
        self.high_is = np.array([-1 if r else 1 for r in motors.reverse])  # direction of DIR high
        self.setup_us = int(motors.dir_setup_us)
        self.pulse_us = int(motors.step_pulse_us)
        self.dir_level = np.zeros(2, dtype=np.int64)

    def hold_word(self) -> int:
        """ENABLE low, STEP low, DIR as last set."""
        return int(self.dir_level[0] << 1 | self.dir_level[1] << 3)

    def to_one_coil(self) -> np.ndarray:
        return np.zeros(2, dtype=np.int64)

    def advance(self, delta_steps) -> None:
        for m, d in enumerate(delta_steps):
            if d:
                self.dir_level[m] = int(np.sign(d) * self.high_is[m] > 0)

    def rows(self, t_us: np.ndarray, motor: np.ndarray, dirn: np.ndarray, floor_us: int,
             cl: np.ndarray, cr: np.ndarray):
        n = len(t_us)
        before = self.dir_level.copy()
        level = (dirn * self.high_is[motor] > 0).astype(np.int64)
        # the DIR level before each event: the motor's previous event's, or the current one
        prev = np.empty(n, dtype=np.int64)
        for m in (0, 1):
            idx = np.flatnonzero(motor == m)
            if len(idx):
                prev[idx] = np.concatenate(([self.dir_level[m]], level[idx[:-1]]))
                self.dir_level[m] = level[idx[-1]]
        change = level != prev
        # a DIR change must not come before what was already output
        rise = np.maximum(t_us, np.where(change, floor_us + self.setup_us, floor_us))
        ev = np.arange(n)
        cidx = np.flatnonzero(change)
        # row kinds: 0 DIR set, 1 STEP rise, 2 STEP fall
        t = np.concatenate((rise[cidx] - self.setup_us, rise, rise + self.pulse_us))
        bit = np.concatenate((2 * motor[cidx] + 1, 2 * motor, 2 * motor)).astype(np.int64)
        val = np.concatenate((level[cidx], np.ones(n, np.int64), np.zeros(n, np.int64)))
        src = np.concatenate((ev[cidx], ev, ev))
        kind = np.concatenate((np.zeros(len(cidx), np.int64), np.ones(n, np.int64),
                               np.full(n, 2, np.int64)))
        order = np.lexsort((kind, t))
        t, bit, val, src, kind = t[order], bit[order], val[order], src[order], kind[order]
        k = np.arange(len(t))
        word = np.zeros(len(t), dtype=np.int64)
        for b in range(4):
            init = int(before[b // 2]) if b % 2 else 0
            last = np.maximum.accumulate(np.where(bit == b, k, -1))
            word |= np.where(last >= 0, val[np.maximum(last, 0)], init) << b
        done = np.cumsum(kind == 1)
        # rows at the same time become one: the word after all of them
        keep = np.ones(len(t), dtype=bool)
        keep[:-1] = t[1:] != t[:-1]
        return t[keep], word[keep].astype(np.uint8), done[keep], src[keep]
