"""A stand-in for the `lgpio` module: records every call and simulates lgpio 0.2.2's tx thread,
as unkind as the real one (read from lgpio's src/lgPthTx.c, lgGpio.c, lgpio.py):

- catch-up: the thread keeps a timeline of its own. `stall(us)` stops it (and the process) for a
  while: every wave edge and servo edge due meanwhile is played back to back at the end of the
  stall (a servo pulse whose edges both fall in the stall gets width 0);
- retained buffers: a wave that finishes while another is queued behind it keeps its pulse
  buffer (24 bytes a pulse) forever: counted in `retained_bytes`;
- the head-free fault: jobs live in one list, newest first; freeing the job at the head while
  others are behind it (tx_servo(pin, 0), a finished train or wave) makes the thread skip the rest
  of the list; here the thread then hangs for good (`hung`; the real one does in ~2 % of such
  frees): nothing it times changes any more, tx_busy stays true;
- tx_servo(pin, 0) cuts the pulse in flight (`truncated` counts them) and fails when no pulses
  run; finite trains (pulse_cycles) end after their last whole pulse, the pin low; a train
  starts on the thread's 20 ms grid;
- wake-up latency: the thread sleeps between edges, and a wake-up after a long sleep (more than
  LONG_SLEEP_US) is later than one after a short sleep (WAKE_LONG_US against WAKE_SHORT_US, as
  measured with clock_nanosleep on the virtual machine these figures come from): a plain
  `tx_servo` pulse, whose rise follows a 19 ms sleep, comes out WAKE_LONG_US - WAKE_SHORT_US
  short; an entry with no high time (`tx_pulse(pin, 0, off)`) is a wake-up that changes nothing;
- the queue of a pulse job holds `queue_size` (10) entries; one more is LG_TX_QUEUE_FULL;
- a write (gpio_write, group_write) after the process slept reaches the pin COLD_WRITE_US late,
  and the call takes that long (measured over the shim: 30 us median against 0.7 us for a
  write right after another, HOT_WRITE_US here): a pulse whose rise follows a sleep comes out that much short;
- tx_pwm takes the duty cycle as given (gpiozero's lgpio pin rounds it to whole percent before);
- `import lgpio` makes the notify FIFO `.lgd-nfy0` in LG_WD (the C library chdirs the process
  there) or the working directory, and fails with FileNotFoundError('.lgd-nfy-3') when it
  cannot (`importer()`);
- gpiochip_open fails with "can not open gpiochip" for a missing chip and for a denied one
  alike; `chip_errno()` is what the device itself would say.

Everything runs on a `SimClock` that the backend under test shares (its clock and sleep), so
nothing really sleeps. Outputs are logged as (t_us, gpio or "group", value) in time order.
"""

from __future__ import annotations

import errno
import math
import os
from types import SimpleNamespace

import numpy as np

TX_PWM = 0
TX_WAVE = 1
GROUP_ALL = 2**64 - 1
FRAME_GRID_US = 20_000
CATCHUP_US = 15                 # one pass of lgpio's tx thread while it catches up
LONG_SLEEP_US = 5_000           # a wake-up after a sleep longer than this ...
WAKE_LONG_US = 45               # ... comes this late (clock_nanosleep, 19.5 ms: 117 us)
WAKE_SHORT_US = 5               # after a shorter one this late (0.5 ms: 69 us; the difference)
COLD_WRITE_US = 30              # the first write after a sleep reaches the pin this late
HOT_WRITE_US = 1                # a write right after another this late


class SimClock:
    """A simulated monotonic clock: every read advances `tick_ns`, every sleep its duration
    plus `oversleep_ns`; at(t_ns, fn) runs fn once the clock has passed t_ns."""

    def __init__(self, tick_ns: int = 200, oversleep_ns: int = 60_000):
        self.ns = 1_000_000_000
        self.sleeps = 0                  # how many sleeps so far
        self.tick_ns = tick_ns
        self.oversleep_ns = oversleep_ns
        self._at: list = []
        self._next = math.inf            # the earliest time in _at: the player spins on now()

    def now(self) -> int:
        self.ns += self.tick_ns
        if self.ns >= self._next:
            self._fire()
        return self.ns

    def sleep(self, seconds: float) -> None:
        d = max(0, int(seconds * 1e9)) + self.oversleep_ns
        self.ns += d
        self.sleeps += 1
        self._fire()

    def at(self, t_ns: int, fn) -> None:
        self._at.append((t_ns, fn))
        self._next = min(self._next, t_ns)

    def _fire(self) -> None:
        due = [e for e in self._at if e[0] <= self.ns]
        for e in due:
            self._at.remove(e)
            e[1]()
        self._next = min((e[0] for e in self._at), default=math.inf)


class error(Exception):
    """lgpio.error"""


class pulse:
    def __init__(self, group_bits, group_mask, pulse_delay):
        self.group_bits = group_bits
        self.group_mask = group_mask
        self.pulse_delay = pulse_delay


class WaveJob:
    """The group's wave job: waves play back to back."""

    kind = TX_WAVE

    def __init__(self, gpio: int, start: int):
        self.gpio = gpio
        self.waves: list[list[tuple[int, int, int]]] = []
        self.next_t = start              # thread time of the next pulse
        self.pos = 0                     # next pulse in waves[0]
        self.active = True


class PulseJob:
    """A servo or PWM job on one pin: entries (on_us, off_us, cycles; -1 = forever)."""

    kind = TX_PWM

    def __init__(self, gpio: int, start: int, entry):
        self.gpio = gpio
        self.entries = [list(entry)]
        self.next_t = start              # thread time of the next cycle start
        self.active = True
        self.woke_t = start - FRAME_GRID_US    # thread time of its last wake-up


class FakeLgpio:
    """Module-like stand-in: pass it as LgpioBackend(lgpio=...) or put it in sys.modules."""

    TX_PWM = TX_PWM
    TX_WAVE = TX_WAVE
    GROUP_ALL = GROUP_ALL
    SET_PULL_NONE = 0
    BOTH_EDGES = 3
    RISING_EDGE = 1
    FALLING_EDGE = 2
    error = error
    pulse = pulse

    def __init__(self, clock: SimClock, chips=(0,), denied=(), queue_size: int = 10):
        self.clock = clock
        self.chips = set(chips)
        self.denied = set(denied)
        self.queue_size = queue_size
        self.calls: list[tuple] = []          # (name, args...)
        self.log: list[tuple[int, object, int]] = []   # (t_us, gpio | "group", value)
        self.pulses: list[tuple[int, int, int]] = []   # (gpio, rise t_us, width us) played
        self.jobs: list = []                  # the tx thread's list, newest first
        self.levels: dict[int, int] = {}
        self.group: list[int] = []
        self.claimed: set[int] = set()
        self.outputs: set[int] = set()
        self.open_handles: set[int] = set()
        self.stalls: list[tuple[int, int]] = []  # (from, to) us: the thread did not run
        self.retained_bytes = 0
        self.truncated = 0
        self.skips = 0
        self.hung = False
        self._late_emit: int | None = None    # the last change made late (catching up)
        self._woke = 0                        # clock.sleeps at the last write
        self._notify_thread = SimpleNamespace(_notify=0)

    # -- `import lgpio`
    def importer(self):
        """A stand-in for `import lgpio` (load_lgpio(importer=...)): the notify FIFO."""
        def do_import():
            where = os.environ.get("LG_WD") or os.getcwd()
            os.chdir(where)                          # the C library's lguGetWorkDir()
            try:
                os.mkfifo(os.path.join(where, ".lgd-nfy0"), 0o664)
            except OSError:
                self._notify_thread._notify = -3
                raise FileNotFoundError(errno.ENOENT, "No such file or directory",
                                        ".lgd-nfy-3") from None
            return self
        return do_import

    def chip_errno(self, chip: int) -> int:
        if chip in self.denied:
            return errno.EACCES
        return 0 if chip in self.chips else errno.ENOENT

    # -- time and the simulated tx thread
    def _us(self) -> int:
        return self.clock.ns // 1000

    def stall(self, us: int) -> None:
        """The process (the tx thread with it) does not run for us microseconds."""
        self._advance()
        now = self._us()
        self.stalls.append((now, now + us))
        self.clock.ns += us * 1000

    def _when(self, t: int) -> int:
        """When the thread really makes a change due at thread time t: the ones a stall made
        late come back to back (CATCHUP_US apart) from its end until lgpio has caught up."""
        late = next((b for a, b in self.stalls if a < t <= b), None)
        if late is None and (self._late_emit is None or t > self._late_emit):
            return t
        t = max(late or t, (self._late_emit or 0) + CATCHUP_US)
        self._late_emit = t
        return t

    def _advance(self) -> None:
        """Play everything due by now, in time order, job by job."""
        if self.hung:
            return
        now = self._us()
        while True:
            due = [j for j in self.jobs if j.active and j.next_t <= now]
            if not due:
                break
            job = min(due, key=lambda j: j.next_t)
            (self._step_wave if job.kind == TX_WAVE else self._step_pulse)(job)
            if not job.active:
                self._free(job)
                if self.hung:
                    return

    def _step_wave(self, job: WaveJob) -> None:
        if job.pos >= len(job.waves[0]):
            if len(job.waves) > 1:
                done = job.waves.pop(0)
                self.retained_bytes += 24 * len(done)   # lgpio never frees it
                job.pos = 0
            else:
                job.active = False
                return
        bits, mask, delay = job.waves[0][job.pos]
        self._write_group(self._when(job.next_t), bits, mask)
        job.next_t += delay
        job.pos += 1

    def _step_pulse(self, job: PulseJob) -> None:
        if len(job.entries) > 1 and job.entries[0][2] <= 0:   # a cycle start: the next entry
            job.entries.pop(0)
        on, off, cycles = job.entries[0]
        if cycles == 0:                              # its count is done: the job ends
            job.active = False
            self._pin(job.gpio, 0, self._when(job.next_t))
            return
        slept = job.next_t - job.woke_t
        rise = self._when(job.next_t) + (WAKE_LONG_US if slept > LONG_SLEEP_US else WAKE_SHORT_US)
        fall = max(self._when(job.next_t + on) + WAKE_SHORT_US, rise)
        if on:
            self._pin(job.gpio, 1, rise)
            self._pin(job.gpio, 0, fall)
            self.pulses.append((job.gpio, rise, fall - rise))
            job.woke_t = job.next_t + on
        else:
            job.woke_t = job.next_t
        job.next_t += on + off
        if cycles > 0:
            job.entries[0][2] = cycles - 1

    def _free(self, job) -> None:
        """lgpio deletes an inactive job on its next pass; at the head of a longer list the
        pass skips the rest: here the thread hangs for good."""
        head = self.jobs[0] is job
        self.jobs.remove(job)
        if head and self.jobs:
            self.skips += 1
            self.hung = True

    def _pin(self, gpio: int, value: int, t: int) -> None:
        self.levels[gpio] = value
        self.log.append((t, gpio, value))

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

    def _job(self, gpio, kind):
        return next((j for j in self.jobs if j.gpio == gpio and j.kind == kind and j.active),
                    None)

    # -- chips and claims
    def gpiochip_open(self, gpiochip):
        self.calls.append(("gpiochip_open", gpiochip))
        if gpiochip not in self.chips or gpiochip in self.denied:
            raise error("can not open gpiochip")
        handle = 100 + gpiochip
        self.open_handles.add(handle)
        return handle

    def gpiochip_close(self, handle):
        self.calls.append(("gpiochip_close", handle))
        self._check(handle)
        self._advance()
        for j in self.jobs:
            j.active = False
        self.jobs.clear()
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
        self.outputs.update(gpio)
        for g, v in zip(gpio, levels):
            self._pin(g, 1 if v else 0, self._us())
        return 0

    def gpio_claim_output(self, handle, gpio, level=0, lFlags=0):
        self.calls.append(("gpio_claim_output", handle, gpio, level))
        self._check(handle)
        if gpio in self.group and gpio in self.claimed:
            raise error("GPIO busy")
        self.claimed.add(gpio)
        self.outputs.add(gpio)
        self._pin(gpio, 1 if level else 0, self._us())
        return 0

    def gpio_claim_input(self, handle, gpio, lFlags=0):
        self.calls.append(("gpio_claim_input", handle, gpio))
        self._check(handle)
        self.claimed.add(gpio)
        self.outputs.discard(gpio)
        return 0

    def gpio_get_mode(self, handle, gpio):
        self._check(handle)
        return 2 if gpio in self.outputs else 0

    def gpio_read(self, handle, gpio):
        self._check(handle)
        self._advance()
        return self.levels.get(gpio, 0)

    def group_free(self, handle, gpio):
        self.calls.append(("group_free", handle, gpio))
        self._check(handle)
        self._advance()
        for j in [j for j in self.jobs if j.kind == TX_WAVE]:
            j.active = False
            self._free(j)
        self.claimed.difference_update(self.group)
        self.outputs.difference_update(self.group)
        return 0

    def gpio_free(self, handle, gpio):
        self.calls.append(("gpio_free", handle, gpio))
        self._check(handle)
        self._advance()
        self.claimed.discard(gpio)
        self.outputs.discard(gpio)
        return 0

    # -- writes
    def group_write(self, handle, gpio, group_bits, group_mask=GROUP_ALL):
        self.calls.append(("group_write", handle, gpio, group_bits, group_mask))
        self._check(handle)
        self._advance()
        if gpio != (self.group[0] if self.group else None):
            raise error("GPIO not a group leader")
        self._write_group(self._cold(), group_bits, group_mask)
        return len(self.group)

    def gpio_write(self, handle, gpio, level):
        self.calls.append(("gpio_write", handle, gpio, level))
        self._check(handle)
        self._advance()
        self._pin(gpio, 1 if level else 0, self._cold())
        return 0

    def _cold(self) -> int:
        """When a write called now reaches the pin, at the end of the call: COLD_WRITE_US
        later after a sleep, HOT_WRITE_US after another write."""
        cold = self.clock.sleeps != self._woke
        self._woke = self.clock.sleeps
        self.clock.ns += (COLD_WRITE_US if cold else HOT_WRITE_US) * 1000
        return self._us()

    # -- waves and pulses
    def tx_wave(self, handle, gpio, pulses):
        self._check(handle)
        self._advance()
        if gpio != (self.group[0] if self.group else None) or gpio not in self.claimed:
            raise error("GPIO not a claimed group leader")
        job = self._job(gpio, TX_WAVE)
        if job is not None and len(job.waves) >= self.queue_size:
            raise error("tx queue full")
        wave = [(p.group_bits, p.group_mask, p.pulse_delay) for p in pulses]
        self.calls.append(("tx_wave", handle, gpio, len(pulses)))
        if job is None:
            job = WaveJob(gpio, self._us())
            self.jobs.insert(0, job)
        job.waves.append(wave)
        self._advance()
        return self.queue_size - len(job.waves)

    def tx_busy(self, handle, gpio, kind):
        self._check(handle)
        self._advance()
        return 1 if self._job(gpio, kind) is not None else 0

    def tx_room(self, handle, gpio, kind):
        self._check(handle)
        self._advance()
        job = self._job(gpio, kind)
        if job is None:
            return self.queue_size
        return self.queue_size - (len(job.waves) if kind == TX_WAVE else len(job.entries))

    def tx_servo(self, handle, gpio, pulse_width, servo_frequency=50, pulse_offset=0,
                 pulse_cycles=0):
        self.calls.append(("tx_servo", handle, gpio, pulse_width, servo_frequency,
                           pulse_cycles))
        self._check(handle)
        if pulse_width and not 500 <= pulse_width <= 2500:
            raise error("bad servo pulse width")
        if pulse_width and not 40 <= servo_frequency <= 500:
            raise error("bad servo frequency")
        if not pulse_width:
            return self._pulses(handle, gpio, 0, 0, 0)
        frame = int(1e6 / servo_frequency + 0.5)
        return self._pulses(handle, gpio, pulse_width, frame - pulse_width, pulse_cycles)

    def tx_pulse(self, handle, gpio, pulse_on, pulse_off, pulse_offset=0, pulse_cycles=0):
        self.calls.append(("tx_pulse", handle, gpio, pulse_on, pulse_off, pulse_cycles))
        self._check(handle)
        if (pulse_on or pulse_off) and pulse_on + pulse_off <= 10:
            raise error("bad PWM micros")
        return self._pulses(handle, gpio, pulse_on, pulse_off, pulse_cycles)

    def tx_pwm(self, handle, gpio, pwm_frequency, pwm_duty_cycle, pulse_offset=0,
               pulse_cycles=0):
        self.calls.append(("tx_pwm", handle, gpio, pwm_frequency, pwm_duty_cycle))
        self._check(handle)
        if pwm_frequency == 0:
            return self._pulses(handle, gpio, 0, 0, 0)
        micros = int(1e6 / pwm_frequency + 0.5)
        on = int(pwm_duty_cycle / 100 * micros + 0.5)
        return self._pulses(handle, gpio, on, micros - on, pulse_cycles)

    def _pulses(self, handle, gpio, on, off, cycles):
        self._advance()
        if gpio not in self.outputs:
            raise error("GPIO not an output")
        job = self._job(gpio, TX_PWM)
        if not on and not off:                       # stop now
            if job is None:
                raise error("bad PWM micros")        # lgpio: no pulses to stop
            self._cut(job)
            return 0
        entry = (on, off, cycles if cycles else -1)
        if job is not None:                          # queued behind the running entry
            if len(job.entries) > 1 and job.entries[-1][2] == -1:
                job.entries.pop()
            if len(job.entries) >= self.queue_size:
                raise error("tx queue full")
            job.entries.append(list(entry))
            return self.queue_size - len(job.entries)
        now = self._us()
        start = (now // FRAME_GRID_US + 1) * FRAME_GRID_US  # the thread's 20 ms grid
        self.jobs.insert(0, PulseJob(gpio, start, entry))
        return self.queue_size - 1

    def _cut(self, job) -> None:
        """tx_servo(pin, 0): the job stops now; the pulse in flight is cut short."""
        now, g = self._us(), job.gpio
        flight = [p for p in self.pulses if p[0] == g and p[1] <= now < p[1] + p[2]]
        if flight:
            self.truncated += 1
            self.pulses = [p for p in self.pulses if p not in flight]
            self.pulses.append((g, flight[0][1], now - flight[0][1]))
        self.log = [e for e in self.log if not (e[1] == g and e[0] > now)]
        self._pin(g, 0, now)
        job.active = False
        self._free(job)

    # -- what the outputs did
    def coil_changes(self) -> list[tuple[int, int]]:
        """(t_us, coil word) at every time the group's word changed, last write per time."""
        self._advance()
        out: list[tuple[int, int]] = []
        for t, who, value in sorted((e for e in self.log if e[1] == "group"),
                                    key=lambda e: e[0]):
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

    def widths(self, gpio: int) -> list[tuple[int, int]]:
        """(rise t_us, width us) of every pulse the pin's log shows, however it was made."""
        out, rise, level = [], None, 0
        for t, who, value in sorted((e for e in self.log if e[1] == gpio), key=lambda e: e[0]):
            if value and not level:
                rise = t
            elif level and not value and rise is not None:
                out.append((rise, t - rise))
            level = value
        return out

    def servo_on(self, gpio: int) -> int:
        """Width of the pulses running on gpio now (0: none)."""
        self._advance()
        job = self._job(gpio, TX_PWM)
        return job.entries[0][0] if job is not None and not self.hung else 0


def expected_coil_changes(parts) -> list[tuple[int, int]]:
    """(t_us, coil word) at every planned time the coil word changes (from 0), last row per
    time: what the outputs must reproduce."""
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
