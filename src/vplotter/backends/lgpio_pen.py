"""The pen as lgpio servo pulse trains (lgpio backend, and gpiozero on its lgpio pin factory).

A pen change is a train of 50 Hz pulses of exactly the configured width (no duty cycle in whole
percent, as gpiozero's PWM would make it), as many as cover the time the pen stays at that width
in the schedule (the settle time). lgpio's tx thread sleeps between edges, and a wake-up after a
long sleep comes later than one after a short sleep (on the VM measured here 117 against 69 us:
a plain `tx_servo` pulse, whose rise follows a 19 ms sleep, came out 30-40 us short). So each
pulse is two queue entries, `tx_pulse(pin, 0, WARM_US)` (a wake-up that changes nothing) and
`tx_pulse(pin, width, frame - width - WARM_US)`: the rise and the fall both follow short sleeps
and their lateness cancels. lgpio's queue holds 10 entries (5 pulses); the rest of a train is
fed from the player's polls (`check`). A train ends after its last whole pulse, the pin low;
vplotter never stops one with `tx_servo(pin, 0)`, which cuts the pulse in flight short. A change
while a train runs is queued behind it (same job). With nothing else using lgpio's tx thread
there is at most one job in its list, so lgpio 0.2's fault (freeing the job at the head of a
longer list makes its thread skip the rest, and sometimes spin forever) has nothing to act on.

The watchdog: a train still running HANG_NS after it should have ended, seen twice (a stall of
this process is not a hang), means the tx thread has stopped. `emergency()` then stops the job,
and lifts the pen with pulses written from Python (gpio_write, spin-timed).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from vplotter.errors import BackendError
from vplotter.schedule import Rows

SERVO_HZ = 50
FRAME_US = 1_000_000 // SERVO_HZ
WARM_US = 1000                  # the tx thread wakes this long before each rise
QUEUE = 10                      # lgpio's queue of a pulse job (LG_TX_BUF): entries
FEED_NS = 10_000_000            # top up the queue at most this often
TRAIN_SLACK_NS = 60_000_000     # lgpio starts a train on its 20 ms grid: up to 40 ms late
HANG_NS = 1_000_000_000         # still running this long past its end (twice): a hang
HANG = ("error: lgpio's pulse thread stopped (an lgpio 0.2 fault): the pen was lifted and the "
        "coils released; the stored position is marked uncertain: check the pen, then `vplotter "
        "calibrate --at X Y` (or --trust-position)")


def train_cycles(duration_us: int) -> int:
    """Servo pulses (50 Hz) for a pen train of duration_us."""
    return max(1, int(round(duration_us / FRAME_US)))


def plan_trains(rows: Rows, pen_us: int, settle_us: int) -> list[tuple[int, int]]:
    """(width, cycles) for each pen change to a width in rows: as long as the pen stays at that
    width in these rows (pulses off or another width end it), else the settle time."""
    p = rows.pen_us.astype(np.int64)
    at = np.flatnonzero(p != np.concatenate(([pen_us], p[:-1])))
    t = rows.t_us
    out = []
    for k, i in enumerate(at.tolist()):
        if p[i] <= 0:
            continue
        dur = int(t[at[k + 1]] - t[i]) if k + 1 < len(at) else settle_us
        out.append((int(p[i]), train_cycles(dur)))
    return out


class PenTrains:
    def __init__(self, lg, handle: int, pin: int, up_us: int, settle_us: int, clock, sleep):
        self.lg, self.handle, self.pin = lg, handle, pin
        self.up_us, self.settle_us = up_us, settle_us
        self.clock, self.sleep = clock, sleep
        self._planned: deque = deque()
        self._width = 0                      # the train being fed, and its pulses not queued yet
        self._pending = 0
        self._fed_ns = 0
        self.end_ns: int | None = None       # when the queued trains should have ended
        self._suspect_ns: int | None = None
        self.hung = False

    def play(self, player, rows: Rows, stop) -> int:
        """Play rows on `player` with this pen's trains planned for them; an lgpio error is
        a BackendError; the caller checks `hung` afterwards."""
        self.plan(rows, player.pen_us)
        try:
            return player.play(rows, lambda: stop() or self.check())
        except self.lg.error as e:
            raise BackendError(f"error: lgpio failed while drawing: {e}") from None

    def plan(self, rows: Rows, pen_us: int) -> None:
        """Before rows are played: the pen changes they hold, pen_us the width before them."""
        self._planned = deque(plan_trains(rows, pen_us, self.settle_us))

    def start(self, width: int) -> None:
        """A pen change to width (0: pulses off, which the train's count already does)."""
        if width <= 0:
            return
        cycles = train_cycles(self.settle_us)
        while self._planned:
            w, c = self._planned.popleft()
            if w == width:
                cycles = c
                break
        start = max(self.clock(), self.end_ns or 0)   # queued behind a running train
        self._width, self._pending = width, cycles     # a train not fed yet gives way
        self._feed()
        self.end_ns = start + cycles * FRAME_US * 1000 + TRAIN_SLACK_NS
        self._suspect_ns = None

    def _feed(self) -> None:
        """Queue as many of the train's pulses as lgpio's queue has room for."""
        lg = self.lg
        room = lg.tx_room(self.handle, self.pin, lg.TX_PWM) // 2
        n = min(room, self._pending)
        w = self._width
        for _ in range(n):
            lg.tx_pulse(self.handle, self.pin, 0, WARM_US, 0, 1)
            lg.tx_pulse(self.handle, self.pin, w, FRAME_US - w - WARM_US, 0, 1)
        self._pending -= n
        now = self.clock()
        self._fed_ns = now
        if n and self.end_ns is not None:    # late feeding moves the end
            queued = (QUEUE - 2 * (room - n)) // 2
            self.end_ns = max(self.end_ns, now + (queued + self._pending) * FRAME_US * 1000
                              + TRAIN_SLACK_NS)

    def busy(self) -> bool:
        try:
            return bool(self.lg.tx_busy(self.handle, self.pin, self.lg.TX_PWM))
        except Exception:  # noqa: BLE001
            return False

    def check(self) -> bool:
        """The watchdog (cheap while no train is due): True once the tx thread has stopped."""
        if self.end_ns is None or self.hung:
            return self.hung
        now = self.clock()
        if self._pending and now - self._fed_ns >= FEED_NS:
            try:
                self._feed()
            except self.lg.error:
                pass                         # queue full meanwhile: the next poll
        if now < self.end_ns:
            return False
        if not self.busy():
            self.end_ns = self._suspect_ns = None
            return False
        if self._suspect_ns is None:
            self._suspect_ns = now
        elif now - self._suspect_ns >= HANG_NS:
            self.hung = True
        return self.hung

    def wait(self) -> bool:
        """Until the trains have ended (their last pulse whole); False on a hang."""
        while self.end_ns is not None:
            if self.check():
                return False
            if self.end_ns is not None:
                self.sleep(0.005)
        return not self.hung

    def release(self) -> None:
        """At close: a train still running (a second Ctrl+C, a hang) is stopped, the pin low.
        It is the only job in lgpio's list, so stopping it is safe."""
        lg = self.lg
        self._pending = 0
        if self.hung or self.busy():
            try:
                lg.tx_servo(self.handle, self.pin, 0)
            except Exception:  # noqa: BLE001
                pass
        self.end_ns = None

    def emergency(self) -> BackendError:
        """The tx thread hangs: stop its job, lift the pen by direct writes; the error to raise."""
        self.hung = True
        self._pending = 0
        for step in (lambda: self.lg.tx_servo(self.handle, self.pin, 0), self._lift_by_hand):
            try:
                step()
            except Exception:  # noqa: BLE001
                pass
        self.end_ns = None
        return BackendError(HANG)

    def _lift_by_hand(self) -> None:
        """Pen-up pulses written from here for the settle time (spin-timed, ~10 us)."""
        lg, h, pin = self.lg, self.handle, self.pin
        t0 = self.clock()
        for k in range(train_cycles(self.settle_us)):
            self._until(t0 + k * FRAME_US * 1000)
            lg.gpio_write(h, pin, 1)
            self._until(self.clock() + self.up_us * 1000)
            lg.gpio_write(h, pin, 0)

    def _until(self, t_ns: int) -> None:
        while (left := t_ns - self.clock()) > 0:
            if left > 2_000_000:
                self.sleep((left - 1_000_000) / 1e9)
