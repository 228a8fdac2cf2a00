"""A stand-in for the `lgpio` module: records every call and simulates lgpio's C thread.

It follows lgpio 0.2's documented Python API and the behaviour of its C library (lgPthTx.c):
a group's waves play back to back from a queue of 10 (tx_room = 10 - waves not finished, the
playing one included); a wave submitted to an idle group starts at the next tick of the thread
(`start_latency_us`); each pulse sets the group bits selected by its mask, then waits its delay;
the queue is busy until the last delay of the last wave has passed; tx_servo(0) stops pulses
(and fails when none are running, as lgpio's does).

Everything runs on a `SimClock` that the backend under test shares (its clock and sleep), so
nothing really sleeps. Outputs are logged as (t_us, gpio or "group", value) in time order.
"""

from __future__ import annotations

import numpy as np

TX_PWM = 0
TX_WAVE = 1
GROUP_ALL = 2**64 - 1


class SimClock:
    """A simulated monotonic clock: every read advances `tick_ns`, every sleep its duration
    plus `oversleep_ns`; at(t_ns, fn) runs fn once the clock has passed t_ns."""

    def __init__(self, tick_ns: int = 200, oversleep_ns: int = 60_000):
        self.ns = 1_000_000_000
        self.tick_ns = tick_ns
        self.oversleep_ns = oversleep_ns
        self._at: list = []

    def now(self) -> int:
        self.ns += self.tick_ns
        self._fire()
        return self.ns

    def sleep(self, seconds: float) -> None:
        d = max(0, int(seconds * 1e9)) + self.oversleep_ns
        self.ns += d
        self._fire()

    def at(self, t_ns: int, fn) -> None:
        self._at.append((t_ns, fn))

    def _fire(self) -> None:
        due = [e for e in self._at if e[0] <= self.ns]
        for e in due:
            self._at.remove(e)
            e[1]()


class error(Exception):
    """lgpio.error"""


class pulse:
    def __init__(self, group_bits, group_mask, pulse_delay):
        self.group_bits = group_bits
        self.group_mask = group_mask
        self.pulse_delay = pulse_delay


class Wave:
    def __init__(self, start: int, pulses: list[tuple[int, int, int]]):
        self.start = start
        self.pulses = pulses
        self.times = (start + np.concatenate(([0], np.cumsum([d for _, _, d in pulses])[:-1]))
                      ).astype(np.int64).tolist()
        self.end = start + sum(d for _, _, d in pulses)
        self.emitted = 0


class FakeLgpio:
    """Module-like stand-in: pass it as LgpioBackend(lgpio=...) or put it in sys.modules."""

    TX_PWM = TX_PWM
    TX_WAVE = TX_WAVE
    GROUP_ALL = GROUP_ALL
    error = error
    pulse = pulse

    def __init__(self, clock: SimClock, chips=(0,), queue_size: int = 10,
                 start_latency_us: int = 0):
        self.clock = clock
        self.chips = set(chips)
        self.queue_size = queue_size
        self.start_latency_us = start_latency_us
        self.calls: list[tuple] = []          # (name, args...)
        self.submitted: list[Wave] = []       # every wave, in submission order
        self.queue: list[Wave] = []           # waves not finished
        self.log: list[tuple[int, object, int]] = []   # (t_us, gpio | "group", value)
        self.servo: list[tuple[int, int]] = []  # (t_us, pulse width) tx_servo calls
        self.servo_on = 0                     # current servo width (0 = off)
        self.levels: dict[int, int] = {}
        self.group: list[int] = []
        self.claimed: set[int] = set()
        self.open_handles: set[int] = set()

    # -- time and the simulated C thread
    def _us(self) -> int:
        return self.clock.ns // 1000

    def _advance(self) -> None:
        now = self._us()
        while self.queue:
            w = self.queue[0]
            while w.emitted < len(w.pulses) and w.times[w.emitted] <= now:
                bits, mask, _ = w.pulses[w.emitted]
                self._write_group(w.times[w.emitted], bits, mask)
                w.emitted += 1
            if w.end <= now and w.emitted == len(w.pulses):
                self.queue.pop(0)
            else:
                break

    def _write_group(self, t: int, bits: int, mask: int) -> None:
        word = 0
        for i, g in enumerate(self.group):
            if mask >> i & 1:
                self.levels[g] = bits >> i & 1
            word |= self.levels.get(g, 0) << i
        if mask:
            self.log.append((t, "group", word))

    def _check(self, handle) -> None:
        if handle not in self.open_handles:
            raise error("unknown handle")

    # -- chips and claims
    def gpiochip_open(self, gpiochip):
        self.calls.append(("gpiochip_open", gpiochip))
        if gpiochip not in self.chips:
            raise error("can not open gpiochip")
        handle = 100 + gpiochip
        self.open_handles.add(handle)
        return handle

    def gpiochip_close(self, handle):
        self.calls.append(("gpiochip_close", handle))
        self._check(handle)
        self._advance()
        self.queue.clear()
        self.servo_on = 0
        self.claimed.clear()
        self.open_handles.discard(handle)
        return 0

    def group_claim_output(self, handle, gpio, levels=[0], lFlags=0):
        self.calls.append(("group_claim_output", handle, list(gpio), list(levels)))
        self._check(handle)
        if any(g in self.claimed for g in gpio):
            raise error("GPIO busy")
        levels = list(levels) + [0] * (len(gpio) - len(levels))
        self.group = list(gpio)
        self.claimed.update(gpio)
        for g, v in zip(gpio, levels):
            self.levels[g] = 1 if v else 0
            self.log.append((self._us(), g, self.levels[g]))
        return 0

    def gpio_claim_output(self, handle, gpio, level=0, lFlags=0):
        self.calls.append(("gpio_claim_output", handle, gpio, level))
        self._check(handle)
        if gpio in self.claimed:
            raise error("GPIO busy")
        self.claimed.add(gpio)
        self.levels[gpio] = 1 if level else 0
        self.log.append((self._us(), gpio, self.levels[gpio]))
        return 0

    def group_free(self, handle, gpio):
        self.calls.append(("group_free", handle, gpio))
        self._check(handle)
        self._advance()
        self.queue.clear()          # freeing the group stops its waves
        self.claimed.difference_update(self.group)
        return 0

    def gpio_free(self, handle, gpio):
        self.calls.append(("gpio_free", handle, gpio))
        self._check(handle)
        self.claimed.discard(gpio)
        if gpio == self._pen():
            self.servo_on = 0
        return 0

    def _pen(self):
        return next((c[2] for c in self.calls if c[0] == "gpio_claim_output"), None)

    # -- writes
    def group_write(self, handle, gpio, group_bits, group_mask=GROUP_ALL):
        self.calls.append(("group_write", handle, gpio, group_bits, group_mask))
        self._check(handle)
        self._advance()
        self._write_group(self._us(), group_bits, group_mask)
        return len(self.group)

    def gpio_write(self, handle, gpio, level):
        self.calls.append(("gpio_write", handle, gpio, level))
        self._check(handle)
        self._advance()
        self.levels[gpio] = 1 if level else 0
        self.log.append((self._us(), gpio, self.levels[gpio]))
        return 0

    # -- waves and servo pulses
    def tx_wave(self, handle, gpio, pulses):
        self._check(handle)
        self._advance()
        if gpio != (self.group[0] if self.group else None) or gpio not in self.claimed:
            raise error("GPIO not a claimed group leader")
        if len(self.queue) >= self.queue_size:
            raise error("tx queue full")
        now = self._us()
        start = self.queue[-1].end if self.queue else now + self.start_latency_us
        wave = Wave(start, [(p.group_bits, p.group_mask, p.pulse_delay) for p in pulses])
        self.calls.append(("tx_wave", handle, gpio, len(pulses)))
        self.queue.append(wave)
        self.submitted.append(wave)
        self._advance()
        return self.queue_size - len(self.queue)

    def tx_busy(self, handle, gpio, kind):
        self._check(handle)
        self._advance()
        if kind == TX_WAVE:
            return 1 if self.queue else 0
        return 1 if self.servo_on else 0

    def tx_room(self, handle, gpio, kind):
        self._check(handle)
        self._advance()
        if kind == TX_WAVE:
            return self.queue_size - len(self.queue)
        return 10

    def tx_servo(self, handle, gpio, pulse_width, servo_frequency=50, pulse_offset=0,
                 pulse_cycles=0):
        self.calls.append(("tx_servo", handle, gpio, pulse_width, servo_frequency))
        self._check(handle)
        self._advance()
        if gpio not in self.claimed:
            raise error("GPIO not an output")
        if not pulse_width and not self.servo_on:
            raise error("bad PWM micros")      # lgpio: stopping pulses that are not running
        if pulse_width and not 500 <= pulse_width <= 2500:
            raise error("bad servo pulse width")
        if pulse_width and not 40 <= servo_frequency <= 500:
            raise error("bad servo frequency")
        self.servo_on = pulse_width
        self.servo.append((self._us(), pulse_width))
        return 9

    # -- what the outputs did
    def coil_changes(self) -> list[tuple[int, int]]:
        """(t_us, coil word) at every time the group's word changed, last write per time."""
        self._advance()
        out: list[tuple[int, int]] = []
        for t, who, value in self.log:
            if who != "group":
                continue
            if out and out[-1][0] == t:
                out[-1] = (t, value)
            else:
                out.append((t, value))
        result, word = [], 0
        for t, value in out:
            if value != word:
                result.append((t, value))
                word = value
        return result


def expected_coil_changes(parts) -> list[tuple[int, int]]:
    """(t_us, coil word) at every planned time the coil word changes (from 0), last row per
    time: what the waves must reproduce."""
    t = np.concatenate([p.t_us for p in parts]).tolist()
    w = np.concatenate([p.coils for p in parts]).tolist()
    last: list[tuple[int, int]] = []
    for ti, wi in zip(t, w):
        if last and last[-1][0] == ti:
            last[-1] = (ti, wi)
        else:
            last.append((ti, wi))
    out, word = [], 0
    for ti, wi in last:
        if wi != word:
            out.append((ti, wi))
            word = wi
    return out


def shifted(changes, offset: int) -> list[tuple[int, int]]:
    return [(t - offset, w) for t, w in changes]


def _moves(pulses) -> bool:
    return any(p.group_mask for p in pulses)


class DroppingLgpio(FakeLgpio):
    """A broken C thread that silently loses the `drop`-th wave with coil changes (0-based)."""

    def __init__(self, *args, drop: int = 10, **kw):
        super().__init__(*args, **kw)
        self.drop = drop
        self.count = 0

    def tx_wave(self, handle, gpio, pulses):
        self.count += _moves(pulses)
        if _moves(pulses) and self.count - 1 == self.drop:
            self._advance()
            return self.queue_size - len(self.queue)
        return super().tx_wave(handle, gpio, pulses)


class SwappingLgpio(FakeLgpio):
    """A broken C thread that plays the `swap`-th wave with coil changes after the next one."""

    def __init__(self, *args, swap: int = 10, **kw):
        super().__init__(*args, **kw)
        self.swap = swap
        self.count = 0
        self.held = None

    def tx_wave(self, handle, gpio, pulses):
        self.count += _moves(pulses)
        if _moves(pulses) and self.count - 1 == self.swap and self.held is None:
            self.held = pulses
            self._advance()
            return self.queue_size - len(self.queue) - 1
        room = super().tx_wave(handle, gpio, pulses)
        if self.held is not None:
            held, self.held = self.held, None
            room = super().tx_wave(handle, gpio, held)
        return room
