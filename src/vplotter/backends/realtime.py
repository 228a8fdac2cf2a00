"""Software timing shared by the real-time backends (gpiozero, fake with realtime=True, and any
other backend that writes its outputs from Python).

`Player` plays rows against a timeline: row t_us is due at anchor + t_us on the wall clock. It
sleeps until `spin_us` before a deadline (in slices of at most `poll_us`, checking the stop flag)
and spins the rest: sleeping overshoots by ~0.1 ms on an idle machine, by milliseconds under
load. Whatever the load, it guarantees:

- lateness is never made up: a row written late moves the anchor by its lateness, so the rest of
  the timeline keeps its planned intervals from the row as it actually happened (the plot takes
  longer; the motors never race). `shifts` counts the moves of more than SHIFT_NS, `lost_ns` is
  the total (the plot took that much longer than planned);
- no two changes of one motor's coils closer than planned (start to start), nor than
  `min_step_us` (1 / max_step_rate) measured from the END of the earlier write to the START of
  the later one, so that the pins themselves can never show a shorter interval, even when the
  process is stopped in the middle of a write;
- a pen change never sooner than planned after the change before it, and the change after a pen
  change never sooner than planned after it (the settle time is kept whole).

pulse: a backend that can write the servo pin's level directly (lgpio) hands it over, and the
player times the servo's 50 Hz pulses itself, in the pen's settle time when no coil changes
(`_train`). For each pulse it sleeps until PULSE_LEAD_NS before the rise, writes the pin low
once (it is low already: the first write after a sleep reaches the pin ~30 us late, the ones
after it ~1 us), spins to the rise and writes it, writes the pin high again WARM_NS before the
fall (the fall then comes 0.8 us after its time, not 6.5 us; measured over the shim), spins to
the fall and writes it. The width is measured on the clock it spins on. While it spins it runs
at SCHED_FIFO priority where allowed (no other thread on the machine gets in between), and
while a train plays Python's switch interval is SWITCH_S: the player gives the GIL away in every
sleep between pulses and never has to give it up inside one (a planning thread that asked for
it there would stretch the pulse by milliseconds). Every pulse is whole and as wide as
configured, to the clock's resolution and the time one write takes; a sleep that wakes late
delays a pulse, never shortens or lengthens it. A pen change that lasts `d` gets the pulses
that fit in `d` whole; with width 0 the pulses stop.

pin_at_a_time: the backend sets one pin per call (gpiozero): every coil transition is written one
bit at a time in an order whose every intermediate pattern is a legal one (`bit_order`), so a
stall between two bit writes never leaves a two-phase jump on a motor.

The clock and sleep are injectable so tests run on a simulated clock. `written_us` gives, for the
rows of the last play() call, when each was actually written (microseconds since the first row
ever played: the real-time trace is what happened, not the plan).
"""

from __future__ import annotations

import gc
import os
import sys
import time
from array import array
from typing import Callable

import numpy as np

from vplotter.motion.schedule import Rows

SHIFT_NS = 100_000     # a move of the timeline by more than 0.1 ms counts as a shift
SERVO_FRAME_NS = 20_000_000     # 50 Hz servo pulses
PULSE_LEAD_NS = 300_000         # spin this long before a pulse's rise
WARM_NS = 40_000                # and write the level it has this long before each edge
SWITCH_S = 0.05                 # Python's switch interval while a pen train plays (default 5 ms)
PULSE_PRIORITY = 10             # SCHED_FIFO priority while spinning through a pulse: above every
                                # normal thread, below the kernel's interrupt threads (50)


class Folded:
    """Lateness samples (ns) folded into fixed bins: 1 us bins up to 2 ms, then 1 % wide bins
    up to 1000 s; p50/p99 to the bin, max and n exact, memory fixed."""

    EDGES = np.concatenate((np.arange(0, 2_000_001, 1000),
                            np.geomspace(2_000_000, 1e12, 1300)[1:])).astype(np.float64)

    def __init__(self):
        self.counts = np.zeros(len(self.EDGES) + 1, dtype=np.int64)
        self.max_ns: int | None = None
        self.n = 0

    def add(self, ns: np.ndarray) -> None:
        if not len(ns):
            return
        self.counts += np.bincount(np.searchsorted(self.EDGES, ns, side="right"),
                                   minlength=len(self.counts))
        m = int(ns.max())
        self.max_ns = m if self.max_ns is None else max(self.max_ns, m)
        self.n += len(ns)

    def stats(self) -> dict | None:
        if not self.n:
            return None
        cum = np.cumsum(self.counts)
        upper = np.concatenate((self.EDGES, [np.inf]))

        def pct(q):
            k = int(np.searchsorted(cum, q * self.n, side="left"))
            return min(float(upper[k]), self.max_ns) / 1e6

        return {"p50_ms": pct(0.5), "p99_ms": pct(0.99), "max_ms": self.max_ns / 1e6, "n": self.n}


class Lateness:
    """Lateness samples in nanoseconds (start of each write minus its due time) and the shifts
    of the timeline -> {"p50_ms", "p99_ms", "max_ms", "n", "shifts", "lost_ms"}. New samples
    gather in `ns` and are folded into fixed bins once there are FOLD of them (the player
    checks after every play), so memory stays flat however long the plot."""

    FOLD = 1 << 12          # 32 kB of samples: RSS stays flat within a few seconds

    def __init__(self):
        self.ns = array("q")
        self.folded = Folded()
        self.shifts = 0
        self.lost_ns = 0

    def add(self, late_ns: int, count: int = 1) -> None:
        if count == 1:
            self.ns.append(late_ns)
        elif count > 1:
            self.ns.extend([late_ns] * count)

    def fold(self) -> None:
        if len(self.ns):
            self.folded.add(np.frombuffer(self.ns, dtype=np.int64))
            del self.ns[:]

    def stats(self) -> dict | None:
        self.fold()
        stats = self.folded.stats()
        if stats is not None:
            stats.update(shifts=self.shifts, lost_ms=self.lost_ns / 1e6)
        return stats


def _first_coil(pattern: int) -> int:
    """Of two neighbouring coils i and i+1 (mod 4), i."""
    bits = [b for b in range(4) if pattern >> b & 1]
    return bits[1] if bits == [0, 3] else bits[0]


def bit_order(old: int, new: int) -> tuple[int, ...]:
    """The 4-bit coil patterns to write, one bit at a time, to go from `old` to `new` (the last one
    is `new`). Every pattern in between is one a stepper (and tests/support/tracecheck/) accepts:

    - release of two neighbouring coils i, i+1: i+1 goes first, so the pattern left for a moment
      is coil i alone (a neighbour in the half-step table), and
    - energising two coils i, i+1: coil i first: the same pattern the release left, so release
      and energise at one phase pass through the same half-step neighbour;
    - a step: new coils on before old coils off (half steps change one bit anyway).
    """
    on = [b for b in range(4) if new >> b & 1 and not old >> b & 1]
    off = [b for b in range(4) if old >> b & 1 and not new >> b & 1]
    if new == 0 and len(off) == 2:
        off.sort(key=lambda b: b == _first_coil(old))
    if old == 0 and len(on) == 2:
        on.sort(key=lambda b: b != _first_coil(new))
    out, x = [], old
    for b in on:
        x |= 1 << b
        out.append(x)
    for b in off:
        x &= ~(1 << b)
        out.append(x)
    return tuple(out)


ORDER = [[bit_order(a, b) for b in range(16)] for a in range(16)]


class Player:
    """Plays rows in real time through two callables:
    write_coils(word, changed_bits) and write_pen(pulse_us) (0 = pulses off).

    min_step_us: the shortest time between two coil changes of one motor (0: only the planned
    intervals are kept); pin_at_a_time: write one coil bit per write_coils call, in a legal order;
    pulse(level): writes the servo pin; given, the player times the servo pulses itself and
    write_pen is not called.
    catchup and stall_us (the old rules for making up lateness) are accepted and ignored:
    lateness is never made up.
    """

    def __init__(self, write_coils: Callable[[int, int], None], write_pen: Callable[[int], None],
                 clock: Callable[[], int] | None = None,
                 sleep: Callable[[float], None] | None = None,
                 spin_us: int = 2000, poll_us: int = 2000, min_step_us: float = 0,
                 pin_at_a_time: bool = False, catchup: float | None = None,
                 stall_us: int | None = None, pulse: Callable[[int], None] | None = None):
        self.write_coils = write_coils
        self.write_pen = write_pen
        self.pulse = pulse
        self.train_ns = 0                    # width of the servo pulses being played (0: none)
        self.next_rise_ns = 0                # and when the next one rises
        self.fifo: bool | None = None        # may the player spin at real-time priority?
        self._switch: float | None = None    # the switch interval to go back to
        self.clock = clock or time.perf_counter_ns
        self.sleep = sleep or time.sleep
        self.spin_ns = spin_us * 1000
        self.poll_ns = poll_us * 1000
        self.min_step_ns = int(np.ceil(min_step_us * 1000))
        self.pin_at_a_time = pin_at_a_time
        self.anchor_ns: int | None = None    # wall clock of schedule time 0 (moves on shifts)
        self.origin_ns = 0                   # the first anchor: time 0 of written_us
        self.coils = 0
        self.pen_us = 0
        # per motor: when its last coil write started and ended, and the schedule time of that row
        self.motor_start_ns = [-(1 << 62), -(1 << 62)]
        self.motor_end_ns = [-(1 << 62), -(1 << 62)]
        self.motor_t_us = [0, 0]
        self.last_end_ns = 0                 # the last row written: end of its writes, its time
        self.last_t_us = 0
        self.last_pen = False                # did it change the pen?
        self.lateness = Lateness()
        self.written_us = np.zeros(0, np.int64)

    @property
    def shifts(self) -> int:
        return self.lateness.shifts

    @property
    def lost_ns(self) -> int:
        return self.lateness.lost_ns

    def play(self, rows: Rows, stop: Callable[[], bool]) -> int:
        """Output each row at its time; return the rows played (fewer when stop() turned true).
        The garbage collector is off meanwhile (a full collection can take milliseconds)."""
        if len(rows) == 0:
            self.written_us = np.zeros(0, np.int64)
            return 0
        enabled = gc.isenabled()
        gc.disable()
        written = array("q")
        try:
            return self._play(rows, stop, written)
        finally:
            self.written_us = np.maximum.accumulate(np.frombuffer(written, dtype=np.int64)) \
                if len(written) else np.zeros(0, np.int64)
            if len(self.lateness.ns) >= Lateness.FOLD:
                self.lateness.fold()
            if enabled:
                gc.enable()
            self._share_gil()

    def _play(self, rows: Rows, stop: Callable[[], bool], written: array) -> int:
        n = len(rows)
        clock, sleep, late = self.clock, self.sleep, self.lateness
        spin, poll, min_step = self.spin_ns, self.poll_ns, self.min_step_ns
        ts, words, pens = rows.t_us.tolist(), rows.coils.tolist(), rows.pen_us.tolist()
        if self.anchor_ns is None:
            self.anchor_ns = self.origin_ns = clock() - ts[0] * 1000
            self.last_t_us, self.last_end_ns = ts[0], self.anchor_ns + ts[0] * 1000
        motor_start, motor_end, motor_t = self.motor_start_ns, self.motor_end_ns, self.motor_t_us
        for i in range(n):
            if stop():
                return i
            t, word, pen = ts[i], words[i], pens[i]
            changed = word ^ self.coils
            pen_changed = pen != self.pen_us
            plan = self.anchor_ns + t * 1000
            if not changed and not pen_changed:
                written.append((plan - self.origin_ns) // 1000)
                continue
            due = plan
            for m in (0, 1):
                if changed >> (4 * m) & 15:
                    due = max(due, motor_start[m] + (t - motor_t[m]) * 1000,
                              motor_end[m] + min_step)
            if pen_changed or self.last_pen:
                due = max(due, self.last_end_ns + (t - self.last_t_us) * 1000)
            if self.train_ns and not self._train(due, stop):
                return i
            now = clock()
            while due - now > spin:
                sleep(min(due - now - spin, poll) / 1e9)
                if stop():
                    return i
                now = clock()
            while now < due:
                now = clock()
            start = now
            late.ns.append(start - due)
            if start > plan:                  # never made up: the rest of the timeline moves
                shift = start - plan
                self.anchor_ns += shift
                late.lost_ns += shift
                if shift > SHIFT_NS:
                    late.shifts += 1
            written.append((start - self.origin_ns) // 1000)
            if changed:
                self._write(word, changed, clock)
            if pen_changed:
                if self.pulse is None:
                    self.write_pen(pen)
                else:
                    self.train_ns, self.next_rise_ns = max(pen, 0) * 1000, start
                    if not self.train_ns:
                        self._share_gil()
                self.pen_us = pen
            self.last_end_ns = clock()
            self.last_t_us, self.last_pen = t, pen_changed
            for m in (0, 1):
                if changed >> (4 * m) & 15:
                    motor_t[m] = t
                    if not self.pin_at_a_time:
                        motor_start[m], motor_end[m] = start, self.last_end_ns
        return n

    def _train(self, due: int, stop: Callable[[], bool]) -> bool:
        """The servo pulses of the running train that fit whole before `due`; False if stop()
        turned true first (between two pulses, never inside one)."""
        clock, sleep, width = self.clock, self.sleep, self.train_ns
        self._hold_gil()
        while self.next_rise_ns + width <= due:
            rise = self.next_rise_ns
            now = clock()
            slept = False
            while rise - now > PULSE_LEAD_NS:
                sleep(min(rise - now - PULSE_LEAD_NS, self.poll_ns) / 1e9)
                slept = True
                if stop():
                    return False
                now = clock()
            if not slept:                    # let the other threads have the GIL now, so that
                sleep(0)                     # none can ask for it back during the pulse
            before = self._urgent()
            try:
                self.pulse(0)                # the pin is low: this only warms the write path (the
                now = clock()                # first write after a sleep takes ~30 us longer)
                while now < rise:            # the width counts from the read just before the rise
                    now = clock()
                self.pulse(1)
                fall = now + width
                while clock() < fall - WARM_NS:
                    pass
                self.pulse(1)                # warms the path again (the fall came ~5 us late)
                while clock() < fall:
                    pass
                self.pulse(0)
            finally:
                self._relax(before)
            self.next_rise_ns = now + SERVO_FRAME_NS     # a late rise moves the ones after it
        return True

    def _hold_gil(self) -> None:
        """While a pen train plays, another thread asks for the GIL only after SWITCH_S (the
        player releases it in every sleep between pulses): a request during a pulse would
        stretch it by as long as that thread then keeps the GIL."""
        if self._switch is None:
            self._switch = sys.getswitchinterval()
            sys.setswitchinterval(max(self._switch, SWITCH_S))

    def _share_gil(self) -> None:
        if self._switch is not None:
            sys.setswitchinterval(self._switch)
            self._switch = None

    def _urgent(self):
        """Real-time priority for this thread, where allowed: the policy to go back to."""
        if self.fifo is False:
            return None
        try:
            before = (os.sched_getscheduler(0), os.sched_getparam(0))
            if before[0] != os.SCHED_FIFO:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(PULSE_PRIORITY))
                self.fifo = True
                return before
        except (OSError, AttributeError):
            self.fifo = False
        return None

    @staticmethod
    def _relax(before) -> None:
        if before is not None:
            try:
                os.sched_setscheduler(0, before[0], before[1])
            except OSError:
                pass

    def _write(self, word: int, changed: int, clock) -> None:
        if not self.pin_at_a_time:
            self.write_coils(word, changed)
            self.coils = word
            return
        for m in (0, 1):
            shift = 4 * m
            if not changed >> shift & 15:
                continue
            old, cur = self.coils >> shift & 15, self.coils
            self.motor_start_ns[m] = clock()
            for pattern in ORDER[old][word >> shift & 15]:
                nxt = cur & ~(15 << shift) | pattern << shift
                self.write_coils(nxt, nxt ^ cur)
                cur = self.coils = nxt
            self.motor_end_ns[m] = clock()
