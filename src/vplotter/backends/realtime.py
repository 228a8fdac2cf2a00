"""Software timing shared by the real-time backends (gpiozero, fake with realtime=True).

`Player` plays rows against absolute deadlines: the first row it ever plays fixes the anchor
(wall clock = anchor + t_us), every later row is due at anchor + t_us, so sleep overshoot never
adds up. It sleeps until `spin_us` before a deadline (in slices of at most `poll_us`, checking
the stop flag) and spins the rest: sleeping overshoots by ~0.1 ms on an idle machine, by
milliseconds under load. Two refinements keep a late row from hurting the motors:

- catching up: a late row still waits `catchup` (0.75) of its planned gap after the previous
  change, so catching up raises the step rate by a third at most instead of firing a burst
  of steps that the motor would lose;
- standstill: when a row is late while the coils are released, or releases them (the motors
  stand unpowered: the caller was computing the next stroke, a pen change follows), the anchor
  moves by the lateness. A pause there is harmless and keeps the pen's settle time whole;
  racing through the start of the next stroke is not.
- stalls: a row more than `stall_us` (0.5 ms) late means the process did not run for a while
  (on a loaded machine, or a virtual one whose host takes the CPU away); the motors have
  stopped meanwhile, so the anchor moves too and they go on at the planned speed, instead of
  racing to make up time they cannot make up safely. Smaller lateness is made up as above.

Lateness (actual minus planned time of each output change, measured after the write) is
collected in `Lateness`. The clock and sleep are injectable so tests run on a simulated clock.
"""

from __future__ import annotations

import gc
import time
from array import array
from typing import Callable

import numpy as np

from vplotter.schedule import Rows


class Lateness:
    """Lateness samples in nanoseconds -> {"p50_ms", "p99_ms", "max_ms", "n"}."""

    def __init__(self):
        self.ns = array("q")

    def add(self, late_ns: int, count: int = 1) -> None:
        if count == 1:
            self.ns.append(late_ns)
        elif count > 1:
            self.ns.extend([late_ns] * count)

    def stats(self) -> dict | None:
        if not self.ns:
            return None
        ms = np.frombuffer(self.ns, dtype=np.int64) / 1e6
        p50, p99 = np.percentile(ms, [50, 99])
        return {"p50_ms": float(p50), "p99_ms": float(p99), "max_ms": float(ms.max()),
                "n": len(ms)}


class Player:
    """Plays rows in real time through two callables:
    write_coils(word, changed_bits) and write_pen(pulse_us) (0 = pulses off)."""

    def __init__(self, write_coils: Callable[[int, int], None], write_pen: Callable[[int], None],
                 clock: Callable[[], int] | None = None,
                 sleep: Callable[[float], None] | None = None,
                 spin_us: int = 2000, poll_us: int = 2000, catchup: float = 0.75,
                 stall_us: int = 500):
        self.write_coils = write_coils
        self.write_pen = write_pen
        self.clock = clock or time.perf_counter_ns
        self.sleep = sleep or time.sleep
        self.spin_ns = spin_us * 1000
        self.poll_ns = poll_us * 1000
        self.catchup_ns = int(round(catchup * 1000))  # per planned microsecond of gap
        self.stall_ns = stall_us * 1000
        self.anchor_ns: int | None = None
        self.coils = 0
        self.idle_word = 0            # the motors released (ENABLE high for step/dir drivers)
        self.pen_us = 0
        self.last_t_us = 0
        self.last_out_ns = 0
        self.lateness = Lateness()

    def play(self, rows: Rows, stop: Callable[[], bool]) -> int:
        """Output each row at its time; return the rows played (fewer when stop() turned true).
        The garbage collector is off meanwhile (a full collection can take milliseconds)."""
        if len(rows) == 0:
            return 0
        enabled = gc.isenabled()
        gc.disable()
        try:
            return self._play(rows, stop)
        finally:
            if enabled:
                gc.enable()

    def _play(self, rows: Rows, stop: Callable[[], bool]) -> int:
        n = len(rows)
        clock, sleep, late = self.clock, self.sleep, self.lateness.ns
        spin, poll, catchup = self.spin_ns, self.poll_ns, self.catchup_ns
        idle = self.idle_word
        ts, words, pens = rows.t_us.tolist(), rows.coils.tolist(), rows.pen_us.tolist()
        if self.anchor_ns is None:
            self.anchor_ns = clock() - ts[0] * 1000
            self.last_t_us, self.last_out_ns = ts[0], self.anchor_ns + ts[0] * 1000
        for i in range(n):
            if stop():
                return i
            t, word, pen = ts[i], words[i], pens[i]
            changed = word ^ self.coils
            if not changed and pen == self.pen_us:
                continue
            due = self.anchor_ns + t * 1000
            due = max(due, self.last_out_ns + (t - self.last_t_us) * catchup)
            now = clock()
            while due - now > spin:
                sleep(min(due - now - spin, poll) / 1e9)
                if stop():
                    return i
                now = clock()
            while now < due:
                now = clock()
            if changed:
                self.write_coils(word, changed)
            if pen != self.pen_us:
                self.write_pen(pen)
            out = clock()
            late_ns = out - (self.anchor_ns + t * 1000)
            late.append(late_ns)
            if late_ns > self.stall_ns or late_ns > 0 and (self.coils == idle or word == idle):
                self.anchor_ns += late_ns  # the motors stand (or stood) still: pause, never race
            self.coils, self.pen_us = word, pen
            self.last_t_us, self.last_out_ns = t, out
        return n
