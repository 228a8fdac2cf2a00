"""lgpio backend: the coils of both motors play as queued waves from lgpio's own C thread.

All eight coil pins are claimed as one group (bit i of the coil word = group bit i), so both
motors change in one write, on time, however busy Python is. Rows become wave pulses
(bits, mask, delay until the next pulse), cut into waves of at most 50 ms; Python keeps 0.25 s
to 0.3 s of waves queued (lgpio's queue holds 10 waves). The last pulse of a play() call goes
with no delay; the next call first queues a no-op filler up to its own first row, so the
timeline stays continuous across calls.

The pen is lgpio's servo pulse train (tx_servo, 50 Hz), driven from Python at the moment the C
thread reaches the pen row: waves are cut at pen rows, and a pen change is made once every wave
ending at or before its time has completed (tx_room/tx_busy). Pen changes only happen while the
motors stand released and the rows hold the settle time, so the coil waves after a pen row
can be queued before the pen change is made.

Timing model: schedule time t plays at anchor + t on the wall clock. If the queue ever runs dry
(Python did not refill it in time), the next wave starts late and the anchor moves by that gap:
the machine pauses, it never races. lateness() reports the pen changes as Python saw them and
the lateness at queue underruns ("underruns" counts them); the C thread's own jitter is not
visible from Python.

play() returns once its pulses are queued (up to ~0.3 s ahead of the motors) and its pen changes
are made, except those at its very last time (made by the next call, or close): waiting for
those would let the queue run dry at every pen row. On a stop it stops queueing, lets the queue
drain (at most ~0.35 s, making the pen changes it passes) and returns exactly the rows that were
output. drain() waits until everything handed over has been output; close() drains (unless a
stop was requested), then releases everything.
"""

from __future__ import annotations

import time
from collections import deque

import numpy as np

from vplotter.backends import Backend
from vplotter.backends.realtime import Lateness
from vplotter.errors import BackendError
from vplotter.schedule import Rows

WAVE_US = 50_000        # longest wave (and longest pulse: longer gaps get no-op pulses)
MAX_PULSES = 500        # most pulses in one wave
SERVO_HZ = 50
NOOP = -1               # pulse word of a no-op pulse (mask 0): a wave boundary or a filler


class LgpioBackend(Backend):
    name = "lgpio"

    def __init__(self, cfg, realtime: bool = True, lgpio=None, clock=None, sleep=None,
                 lead_s: float = 0.25, poll_us: int = 1000):
        """lgpio: the lgpio module (default: import it); clock() -> ns and sleep(s) for tests;
        lead_s: the least time of waves kept queued ahead. realtime is accepted and ignored
        (this backend always plays in real time)."""
        super().__init__(cfg)
        self.chip = cfg.gpio.chip
        self.leader = self.coil_pins[0]
        self.mask = (1 << len(self.coil_pins)) - 1
        self.lg = lgpio
        self.clock = clock or time.perf_counter_ns
        self.sleep = sleep or time.sleep
        self.lead_us = int(lead_s * 1e6)
        self.poll_s = poll_us / 1e6
        self.handle: int | None = None
        self._pen = None
        self.capacity = 10
        self._late = Lateness()
        self.underruns = 0
        self._reset()

    def _reset(self) -> None:
        self.anchor_ns: int | None = None
        self.serial = 0                 # serial number of the next row handed to play()
        self.coils = self.idle_word     # coil word and pen width after the last row handed over
        self.pen_us = 0
        # pulses not yet queued: time, word (NOOP = no change), serial of the first row, cut
        self._pt = np.zeros(0, np.int64)
        self._pw = np.zeros(0, np.int64)
        self._ps = np.zeros(0, np.int64)
        self._pc = np.zeros(0, bool)
        self._events: deque = deque()   # pen changes not yet made: (t_us, pulse_us, serial)
        self._waves: deque = deque()    # end times of the waves that may still be queued
        self.queued_end: int | None = None  # schedule time where the queued waves end

    # ------------------------------------------------------------ open / close
    def open(self) -> None:
        lg = self.lg
        if lg is None:
            try:
                import lgpio as lg
            except ImportError:
                raise BackendError("error: the lgpio backend needs the lgpio package "
                                   "(pip install lgpio); use --dry-run to simulate") from None
            self.lg = lg
        servo = self.cfg.pen.kind == "servo"
        for w in (self.cfg.pen.up_us, self.cfg.pen.down_us) if servo else ():
            if not 500 <= w <= 2500:
                raise BackendError(f"error: lgpio makes servo pulses of 500..2500 us, not {w} "
                                   f"([pen] up_us/down_us)")
        try:
            h = lg.gpiochip_open(self.chip)
        except lg.error as e:
            h = -1
            why = str(e)
        else:
            why = "error code {}".format(h)
        if h < 0:
            raise BackendError(f"error: cannot open /dev/gpiochip{self.chip} ({why}): no GPIO "
                               f"here? use --dry-run to simulate ([gpio] chip = 4 on a Pi 5 "
                               f"with an older kernel)")
        self.handle = h
        try:
            lg.group_claim_output(h, list(self.coil_pins), self._idle_levels())
            lg.gpio_claim_output(h, self.pen_pin, 0)
            self._open_pen()
            self.capacity = lg.tx_room(h, self.leader, lg.TX_WAVE)
        except lg.error as e:
            self.close()
            raise BackendError(f"error: cannot claim GPIO {list(self.coil_pins)} and "
                               f"{self.pen_pin} on gpiochip{self.chip} ({e}); is another program "
                               f"using them?") from None
        self._reset()

    def close(self) -> None:
        """Play out what was handed over (unless a stop was requested), then all coils low,
        pen pulses off, pins and chip released. Never raises."""
        lg, h = self.lg, self.handle
        if h is None:
            return
        try:
            if not self.stop_requested:
                self.drain()
        except BaseException:  # noqa: BLE001 - an error or a second Ctrl+C: release now
            pass
        try:
            busy = lg.tx_busy(h, self.leader, lg.TX_WAVE)
        except Exception:  # noqa: BLE001
            busy = 1
        steps = []
        if busy:  # waves still queued: freeing the group stops them, claiming it again at 0
            steps += [lambda: lg.group_free(h, self.leader),
                      lambda: lg.group_claim_output(h, list(self.coil_pins),
                                                    self._idle_levels())]
        steps += [lambda: lg.group_write(h, self.leader, self.idle_word, self.mask),
                  self._pulses_off,
                  lambda: lg.group_free(h, self.leader),
                  lambda: lg.gpio_free(h, self.pen_pin),
                  lambda: lg.gpiochip_close(h)]
        for step in steps:
            try:
                step()
            except Exception:  # noqa: BLE001
                pass
        self.handle = None
        self._reset()

    def _open_pen(self) -> None:
        from vplotter import pens

        lg, h, pen = self.lg, self.handle, self.cfg.pen
        if pen.kind == "switch":
            lg.gpio_claim_input(h, pen.switch_pin, lg.SET_PULL_UP if pen.switch_active_low else 0)
        self._pen = pens.create(self.cfg, lambda level: lg.gpio_write(h, self.pen_pin, level),
                                lambda: bool(lg.gpio_read(h, pen.switch_pin)))

    def read_input(self, pin: int) -> bool:
        lg, h = self.lg, self.handle
        lg.gpio_claim_input(h, pin, lg.SET_PULL_UP)
        try:
            return bool(lg.gpio_read(h, pin))
        finally:
            lg.gpio_free(h, pin)

    def _idle_levels(self) -> list[int]:
        return [self.idle_word >> b & 1 for b in range(len(self.coil_pins))]

    def lateness(self) -> dict | None:
        stats = self._late.stats()
        if stats is not None:
            stats["underruns"] = self.underruns
        return stats

    # ------------------------------------------------------------ play
    def play(self, rows: Rows) -> int:
        n = len(rows)
        if n == 0 or self.stop_requested:
            return 0
        first, last_t = self.serial, int(rows.t_us[-1])
        self._add(rows)
        if self.anchor_ns is None:
            self.anchor_ns = self.clock() - int(rows.t_us[0]) * 1000
        try:
            while True:
                if self.stop_requested:
                    return self._stop(first, n)
                self._service()
                if not len(self._pt) and not (self._events and self._events[0][0] < last_t):
                    return n
                self.sleep(self.poll_s)
        except self.lg.error as e:
            raise BackendError(f"error: lgpio failed while drawing: {e}") from None

    def _now(self) -> int:
        return (self.clock() - self.anchor_ns) // 1000

    def _add(self, rows: Rows) -> None:
        """Rows -> pulses (one per time at which the coils or the pen change) and pen events."""
        n = len(rows)
        t = rows.t_us.astype(np.int64)
        w = rows.coils.astype(np.int64)
        p = rows.pen_us.astype(np.int64)
        cw = w != np.concatenate(([self.coils], w[:-1]))
        cp = p != np.concatenate(([self.pen_us], p[:-1]))
        serial = self.serial + np.arange(n, dtype=np.int64)
        for i in np.flatnonzero(cp).tolist():
            self._events.append((int(t[i]), int(p[i]), int(serial[i])))
        sel = cw | cp
        pt = np.concatenate((self._pt, t[sel]))
        pw = np.concatenate((self._pw, np.where(cw, w, NOOP)[sel]))
        ps = np.concatenate((self._ps, serial[sel]))
        pc = np.concatenate((self._pc, cp[sel]))
        self._pt, self._pw, self._ps, self._pc = _fill(*_collapse(pt, pw, ps, pc))
        self.coils, self.pen_us = int(w[-1]), int(p[-1])
        self.serial += n

    def _poll(self) -> int:
        """Forget the waves lgpio has finished; return the free queue slots."""
        lg, h = self.lg, self.handle
        busy = lg.tx_busy(h, self.leader, lg.TX_WAVE)
        queued = self.capacity - lg.tx_room(h, self.leader, lg.TX_WAVE) if busy else 0
        while len(self._waves) > queued:
            self._waves.popleft()
        return self.capacity - len(self._waves)

    def _reached(self, t: int) -> bool:
        """Has the C thread played the waves up to schedule time t?"""
        return (self.queued_end is not None and self.queued_end >= t
                and (not self._waves or self._waves[0] > t))

    def _fire_due(self, limit_serial: int | None = None) -> None:
        """Make the pen changes the C thread has reached (those of rows before limit_serial)."""
        lg, h = self.lg, self.handle
        while self._events and self._reached(self._events[0][0]):
            t, width, serial = self._events[0]
            if limit_serial is not None and serial >= limit_serial:
                return
            self._events.popleft()
            if self._pen is not None:            # a solenoid or the cam (pens.py)
                self._pen.set(width)
            elif width > 0:
                lg.tx_servo(h, self.pen_pin, width, SERVO_HZ)
            else:
                self._pulses_off()
            self._late.add(self.clock() - (self.anchor_ns + t * 1000))

    def _pulses_off(self) -> None:
        lg, h = self.lg, self.handle
        try:
            lg.tx_servo(h, self.pen_pin, 0)
        except lg.error:
            pass                                 # lgpio refuses to stop pulses already off
        lg.gpio_write(h, self.pen_pin, 0)        # a pulse may have been cut while high

    def _service(self) -> None:
        """Make due pen changes and keep lead_s to lead_s + 50 ms of waves queued."""
        room = self._poll()
        self._fire_due()
        while room > 0 and len(self._pt):
            now = self._now()
            if self._waves and self.queued_end - now >= self.lead_us + WAVE_US:
                break
            self._submit_next(now)
            room = self.capacity - len(self._waves)
        self._fire_due()

    def _submit_next(self, now: int) -> None:
        """Queue the next wave: pulses up to a pen change, 50 ms or MAX_PULSES; the last pulse
        handed over goes with no delay (a later play() queues a filler up to its rows)."""
        pt, m = self._pt, len(self._pt)
        t0 = int(pt[0])
        if not self._waves:                          # idle: the wave starts now
            if now > t0:                             # late: the machine pauses, never races
                self._late.add((now - t0) * 1000)
                self.underruns += self.queued_end is not None
                self.anchor_ns += (now - t0) * 1000
                now = t0
            self.queued_end = now
        if t0 > self.queued_end:                     # a gap before the next pulse: a filler
            self._queue([(0, 0, min(t0 - self.queued_end, WAVE_US))])
            return
        lim = min(m, MAX_PULSES + 1)
        k = lim - 1 if lim < m else m                # m: all of them, the last with no delay
        over = np.flatnonzero(pt[1:lim] > t0 + WAVE_US)
        if len(over):                                # end the wave by t0 + 50 ms
            k = min(k, max(1, int(over[0])))
        cut = np.flatnonzero(self._pc[1:lim])
        if len(cut):                                 # a pen row starts a new wave
            k = min(k, int(cut[0]) + 1)
        ts = pt[:k + 1].tolist() if k < m else pt[:m].tolist() + [int(pt[m - 1])]
        words = self._pw[:k].tolist()
        self._queue([(wd if wd >= 0 else 0, self.mask if wd >= 0 else 0, ts[j + 1] - ts[j])
                     for j, wd in enumerate(words)])
        self._late.add(0, sum(1 for wd in words if wd >= 0))
        self._pt, self._pw, self._ps, self._pc = (a[k:] for a in
                                                  (self._pt, self._pw, self._ps, self._pc))

    def _queue(self, pulses: list[tuple[int, int, int]]) -> None:
        lg = self.lg
        lg.tx_wave(self.handle, self.leader, [lg.pulse(b, m, d) for b, m, d in pulses])
        self.queued_end += sum(d for _, _, d in pulses)
        self._waves.append(self.queued_end)

    # ------------------------------------------------------------ stop / finish
    def _stop(self, first: int, n: int) -> int:
        """Stop queueing, let the queue drain (making the pen changes it passes) and return
        how many of this call's rows were output (earlier calls' rows all are)."""
        cut = int(self._ps[0]) if len(self._ps) else self.serial
        self._pt, self._pw, self._ps, self._pc = (a[:0] for a in
                                                  (self._pt, self._pw, self._ps, self._pc))
        self._drain(cut)
        self._events.clear()
        return max(0, min(n, cut - first))

    def _drain(self, limit_serial: int | None = None, timeout_s: float = 5.0) -> None:
        """Wait until the queue is empty, making the pen changes it passes."""
        end = self.clock() + int(timeout_s * 1e9)
        while True:
            self._poll()
            self._fire_due(limit_serial)
            if not self._waves or self.clock() > end:
                return
            self.sleep(self.poll_s)

    def drain(self) -> None:
        """Wait until every row handed to play() has been output (and its pen change made)."""
        if self.handle is None or self.anchor_ns is None:
            return
        last = max([self.queued_end or 0, *self._pt[-1:].tolist()])
        end = self.clock() + int((max(last - self._now(), 0) / 1e6 + 2.0) * 1e9)
        try:
            while not self.stop_requested and self.clock() < end:
                self._service()
                if not self._waves and not len(self._pt):
                    return
                self.sleep(self.poll_s)
        except self.lg.error as e:
            raise BackendError(f"error: lgpio failed while drawing: {e}") from None


def _collapse(t, w, s, c):
    """Merge pulses at equal times: the last coil word wins, a pen change anywhere makes it a
    cut, the serial is the first row's."""
    if len(t) < 2:
        return t, w, s, c
    start = np.flatnonzero(np.concatenate(([True], t[1:] != t[:-1])))
    if len(start) == len(t):
        return t, w, s, c
    idx = np.where(w >= 0, np.arange(len(t)), -1)
    last = np.maximum.reduceat(idx, start)
    return (t[start], np.where(last >= 0, w[np.maximum(last, 0)], NOOP),
            np.minimum.reduceat(s, start), np.logical_or.reduceat(c, start))


def _fill(t, w, s, c):
    """No-op pulses every WAVE_US through longer gaps (a dwell), so no single wave is long."""
    if len(t) < 2:
        return t, w, s, c
    gap = np.diff(t)
    extra = np.maximum((gap - 1) // WAVE_US, 0)
    if not extra.any():
        return t, w, s, c
    at = np.repeat(np.arange(len(gap)), extra)
    k = np.arange(len(at)) - np.repeat(np.cumsum(extra) - extra, extra) + 1
    ft = t[at] + k * WAVE_US
    t2 = np.concatenate((t, ft))
    order = np.argsort(t2, kind="stable")
    return (t2[order], np.concatenate((w, np.full(len(ft), NOOP)))[order],
            np.concatenate((s, s[at + 1]))[order],
            np.concatenate((c, np.zeros(len(ft), bool)))[order])
