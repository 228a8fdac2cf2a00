"""The software timing loop (realtime.Player) under load, on a simulated clock: stalls in the
sleep, in the spin, and in the middle of a pin write. Whatever they are, the pins (recorded
with the time of each single pin change, decoded by tests/support/tracecheck/) never show two
steps of
one motor closer than 1 / max_step_rate, an illegal coil transition, a pen change sooner than
planned after the last step, or a step sooner than planned after a pen change; lateness moves
the rest of the timeline instead of being made up."""

from __future__ import annotations

import random

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from support import tracecheck as tc
from support.backends import cfg, concat, make_rows, parts, steady  # noqa: F401 - fixtures
from support.fake_lgpio import SimClock
from vplotter import config
from vplotter.backends import create
from vplotter.backends.realtime import ORDER, Player, bit_order
from vplotter.motion.sequencer import TABLES

from support import REPO

CFG = config.load(REPO / "config.toml")
TC_CFG = tc.load_config(REPO / "config.toml")
PINS = [*CFG.motors.left_pins, *CFG.motors.right_pins]
MIN_STEP_US = 1e6 / CFG.motors.max_step_rate


class Pins:
    """Eight coil pins and the pen pin, written one call at a time like gpiozero does, each
    change logged with the simulated time at which the pin itself changed. `stalls` maps the
    number of a write call to (ns before the pin changes, ns after): the process losing the CPU
    in the middle of a write."""

    def __init__(self, clock: SimClock, stalls=None):
        self.clock, self.stalls = clock, stalls or {}
        self.word, self.calls, self.log = 0, 0, []

    def _stall(self, k: int) -> None:
        self.clock.ns += k

    def coils(self, word: int, changed: int) -> None:
        assert changed == word ^ self.word
        before, after = self.stalls.get(self.calls, (0, 0))
        self.calls += 1
        self._stall(before)
        for bit in range(8):
            if changed >> bit & 1:
                self.log.append((self.clock.ns, PINS[bit], word >> bit & 1))
        self.word = word
        self._stall(after)

    def pen(self, width: int) -> None:
        self.log.append((self.clock.ns, CFG.pen.pin, width))

    def trace(self, start_ns: int) -> tc.Trace:
        """The log as a trace (microseconds, like the trace format), every pin at 0 first."""
        t = [start_ns] * 9 + [t for t, _, _ in self.log]
        pin = [*PINS, CFG.pen.pin] + [p for _, p, _ in self.log]
        value = [0] * 9 + [v for _, _, v in self.log]
        t_us = (np.array(t, np.int64) - start_ns) // 1000
        return tc.Trace(t_us / 1e6, t_us, np.array(pin, np.int64), np.array(value, np.int64))


def gpiozero_player(clock, pins, **kw):
    """The player as the gpiozero backend makes it."""
    return Player(pins.coils, pins.pen, clock.now, clock.sleep, spin_us=200,
                  min_step_us=MIN_STEP_US, pin_at_a_time=True, **kw)


def planned_trace(parts) -> tc.Trace:
    fake = create("fake", CFG, record=True)
    fake.open()
    for p in parts:
        fake.play(p)
    rows = concat(fake.recorded)
    t, pin, value, word, pen = [], [], [], 0, 0
    for ti, w, p in zip(rows.t_us.tolist(), rows.coils.tolist(), rows.pen_us.tolist()):
        for bit in range(8):
            if (w ^ word) >> bit & 1:
                t.append(ti), pin.append(PINS[bit]), value.append(w >> bit & 1)
        if p != pen:
            t.append(ti), pin.append(CFG.pen.pin), value.append(p)
        word, pen = w, p
    t = np.array([0] * 9 + t, np.int64)
    pin = np.array([*PINS, CFG.pen.pin] + pin, np.int64)
    return tc.Trace(t / 1e6, t, pin, np.array([0] * 9 + value, np.int64))


def motor_patterns(trace: tc.Trace, motor: int, grouped: bool = True) -> list[int]:
    """Distinct successive coil patterns of one motor (tracecheck.coil_patterns)."""
    return tc.coil_patterns(trace, PINS[4 * motor:4 * motor + 4], grouped)


def gaps_around_pen(trace: tc.Trace) -> list[tuple[float, float]]:
    """For every pen move (a change to a nonzero width): (time since the coil change before
    it, time until the coil change after it), in microseconds."""
    t, pin, value = trace.t_us[9:], trace.pin[9:], trace.value[9:]
    coil_t = t[pin != CFG.pen.pin]
    out = []
    for tp in t[(pin == CFG.pen.pin) & (value > 0)].tolist():
        before = coil_t[coil_t <= tp]
        after = coil_t[coil_t > tp]
        out.append((tp - before[-1] if len(before) else np.inf,
                    after[0] - tp if len(after) else np.inf))
    return out


stall_lists = st.lists(st.tuples(st.integers(0, 4000), st.integers(0, 30_000_000),
                                 st.sampled_from(["before", "after", "clock"])),
                       min_size=1, max_size=12)


@settings(max_examples=12)
@given(stalls=stall_lists)
def test_under_any_stalls_the_pins_keep_every_limit(parts, stalls):
    clock = SimClock(tick_ns=700, oversleep_ns=90_000)
    in_writes = {k: ((d, 0) if where == "before" else (0, d)) for k, d, where in stalls
                 if where != "clock"}
    pins = Pins(clock, in_writes)
    for k, d, where in stalls:          # the process stopped between two rows
        if where == "clock":
            clock.at(clock.ns + k * 1_500_000, lambda d=d: setattr(clock, "ns", clock.ns + d))
    p = gpiozero_player(clock, pins)
    start = clock.ns
    for part in parts:
        assert p.play(part, lambda: False) == len(part)
    got, plan = pins.trace(start), planned_trace(parts)
    dec, ref = tc.decode(got, TC_CFG), tc.decode(plan, TC_CFG)
    assert tc.illegal_transitions(dec) == []
    assert tc.check_step_rate(dec, CFG.motors.max_step_rate) == []
    assert tc.steps_while_settling(dec, CFG.pen.settle_s) == []
    # the same steps: pin by pin, no pattern in between that the plan does not have (motors
    # are energised and released in one-coil phases)
    for m in (0, 1):
        assert motor_patterns(got, m, grouped=False) == motor_patterns(plan, m)
    for motor in ("left", "right"):
        assert np.array_equal(dec.steps[motor].dirs, ref.steps[motor].dirs)
    assert (dec.left_mm[-1], dec.right_mm[-1]) == (ref.left_mm[-1], ref.right_mm[-1])
    # pen changes never sooner than planned after the last step, steps never sooner after them
    for (b, a), (pb, pa) in zip(gaps_around_pen(got), gaps_around_pen(plan)):
        assert b >= pb - 1 and a >= pa - 1
    # the time lost is what the stalls took and little more
    plot_us = int(concat(parts).t_us[-1])
    assert p.lost_ns <= sum(d for _, d, _ in stalls) + 0.02 * plot_us * 1000


def test_a_stall_moves_the_rest_of_the_timeline_instead_of_being_made_up():
    clock = SimClock(tick_ns=1000, oversleep_ns=50_000)
    clock.at(1_000_000_000 + 100_000_000, lambda: setattr(clock, "ns", clock.ns + 20_000_000))
    pins = Pins(clock)
    p = Player(pins.coils, pins.pen, clock.now, clock.sleep, spin_us=200)
    rows = steady()
    p.play(rows, lambda: False)
    times = np.array([t for t, _, _ in pins.log])
    gaps = np.diff(times) / 1000
    assert gaps.min() >= 1500 - 1                       # never faster than planned
    assert gaps.max() > 20_000                          # the stall itself
    assert p.shifts == 1 and 20.0 - 1.5 <= p.lost_ns / 1e6 < 20.0 + 0.01 * len(rows)
    stats = p.lateness.stats()
    assert stats["shifts"] == 1 and stats["lost_ms"] == pytest.approx(p.lost_ns / 1e6)
    # the rows after the stall are on the moved timeline, one interval apart again
    after = gaps[np.argmax(gaps) + 1:]
    assert np.all(np.abs(after - 1500) <= 3)


def test_a_write_stalled_before_the_pin_changes_delays_the_next_step_of_that_motor():
    """The process loses the CPU between reading the clock and the pin change: the next step of
    that motor waits a full step interval from the end of that write."""
    clock = SimClock(tick_ns=1000, oversleep_ns=50_000)
    pins = Pins(clock, {10: (1_400_000, 0)})        # 1.4 ms inside the 11th write
    p = Player(pins.coils, pins.pen, clock.now, clock.sleep, spin_us=200,
               min_step_us=MIN_STEP_US)
    rows = steady(60, gap_us=1510)
    p.play(rows, lambda: False)
    gaps = np.diff([t for t, _, _ in pins.log])
    assert gaps.min() >= MIN_STEP_US * 1000


def test_the_trace_of_a_real_time_play_is_when_rows_were_written(parts):
    clock = SimClock(tick_ns=1000, oversleep_ns=80_000)
    clock.at(1_000_000_000 + 1_000_000_000, lambda: setattr(clock, "ns", clock.ns + 50_000_000))
    b = create("fake", CFG, realtime=True, clock=clock.now, sleep=clock.sleep, spin_us=200)
    b.open()
    written = []
    for part in parts:
        assert b.play(part) == len(part)
        written.append(b.written_us())
    b.close()
    w, t = np.concatenate(written), concat(parts).t_us
    assert np.all(np.diff(w) >= 0) and len(w) == len(t)
    late = w - t
    assert late[:10].max() < 100 and late[-10:].min() >= 50_000 - 2_000   # the stall moved the rest
    assert create("fake", CFG).written_us() is None


def test_half_step_bit_order_passes_only_through_legal_patterns():
    table = TABLES["half"].tolist()
    n = len(table)
    code = {p: i for i, p in enumerate(table)}
    for i, a in enumerate(table):
        for d in (1, -1):
            b = table[(i + d) % n]
            assert ORDER[a][b] == (b,)                 # a half step is one pin
        # release at phase i, then energise at phase i: both pass through the same neighbour
        rel, ene = bit_order(a, 0), bit_order(0, a)
        assert rel[-1] == 0 and ene[-1] == a
        for seq in (rel[:-1], ene[:-1]):
            for pattern in seq:
                assert pattern in code and (code[pattern] - i) % n in (1, n - 1)
        assert rel[:-1] == ene[:-1]


@pytest.mark.parametrize("drive", ["full", "wave"])
def test_full_and_wave_steps_energise_the_new_coil_before_releasing_the_old(drive):
    table = TABLES[drive].tolist()
    for i, a in enumerate(table):
        b = table[(i + 1) % len(table)]
        seq = bit_order(a, b)
        assert seq[-1] == b and all(p != 0 for p in seq)
        assert all(bin(p).count("1") >= min(bin(a).count("1"), bin(b).count("1")) for p in seq)


def test_the_pen_waits_the_planned_time_after_a_late_last_step():
    """A step written late moves the pen change after it by as much (the settle after it too)."""
    clock = SimClock(tick_ns=1000, oversleep_ns=50_000)
    pins = Pins(clock, {2: (0, 5_000_000)})      # the third step's write takes 5 ms more
    p = Player(pins.coils, pins.pen, clock.now, clock.sleep, spin_us=200,
               min_step_us=MIN_STEP_US)
    rows = make_rows([0, 1600, 3200, 3500, 303_500, 305_100],
                     [1, 3, 2, 0, 0, 2], [0, 0, 0, 1500, 0, 0])
    p.play(rows, lambda: False)
    t = [t for t, _, _ in pins.log]
    third, release, pen, off, energise = t[2], t[3], t[4], t[5], t[6]
    assert pen - third >= 300_000 and release - third >= MIN_STEP_US * 1000
    assert off - pen >= 300_000_000 and energise - off >= 1_600_000


def test_stop_is_checked_while_waiting():
    clock = SimClock(tick_ns=1000, oversleep_ns=50_000)
    stop = {"now": False}
    clock.at(1_000_000_000 + 200_000_000, lambda: stop.update(now=True))
    pins = Pins(clock)
    p = Player(pins.coils, pins.pen, clock.now, clock.sleep, spin_us=200)
    rows = make_rows([0, 1_000_000], [1, 3], [0, 0])
    assert p.play(rows, lambda: stop["now"]) == 1
    assert clock.ns - 1_000_000_000 < 205_000_000


def test_random_chunking_changes_nothing(parts):
    """The timeline runs on across play() calls whatever their sizes."""
    rows = concat(parts)
    rng = random.Random(3)
    clock = SimClock(tick_ns=500, oversleep_ns=80_000)
    pins = Pins(clock)
    p = gpiozero_player(clock, pins)
    i = 0
    start = clock.ns
    while i < len(rows):
        j = min(len(rows), i + rng.randint(1, 60))
        p.play(rows[i:j], lambda: False)
        i = j
    dec = tc.decode(pins.trace(start), TC_CFG)
    assert tc.check_step_rate(dec, CFG.motors.max_step_rate) == [] and not dec.illegal
    assert p.shifts == 0
