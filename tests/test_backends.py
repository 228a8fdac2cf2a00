"""Backends without a Raspberry Pi: the shared software timing loop on a simulated clock, the
lgpio backend on a stand-in lgpio that simulates its C thread (tests/support/fake_lgpio.py),
gpiozero on its MockFactory, and one contract every backend keeps. Nothing here really sleeps.
The drawing, rows and mock pins the backends' tests share are in tests/support/backends.py."""

from __future__ import annotations

import numpy as np
import pytest
from gpiozero.pins.mock import MockFactory

from support.backends import (FIELDS, LogPin, cfg, concat, gpiozero_backend,  # noqa: F401
                              make_rows, mock_outputs, parts, pen_changes, row_changes, steady)
from support.fake_lgpio import FakeLgpio, SimClock
from vplotter.backends import create
from vplotter.backends.realtime import Player
from vplotter.errors import BackendError
from vplotter.motion.schedule import Rows


def index(parts, part) -> int:
    return next(i for i, p in enumerate(parts) if p is part)


def head(rows: Rows, n: int) -> Rows:
    return Rows(*(getattr(rows, f)[:n] for f in FIELDS))


# ---------------------------------------------------------------- the software timing loop
class Recorder:
    """Outputs of a Player: (clock ns, word, pen) after every change."""

    def __init__(self, clock: SimClock):
        self.clock, self.coils, self.pen, self.log = clock, 0, 0, []

    def coils_out(self, word, changed):
        assert changed == word ^ self.coils
        self.coils = word
        self.log.append((self.clock.ns, self.coils, self.pen))

    def pen_out(self, width):
        self.pen = width
        self.log.append((self.clock.ns, self.coils, self.pen))


def player(clock: SimClock, **kw):
    rec = Recorder(clock)
    return Player(rec.coils_out, rec.pen_out, clock.now, clock.sleep, **kw), rec


def test_player_outputs_every_row_never_sooner_than_planned(parts):
    clock = SimClock(tick_ns=1000, oversleep_ns=80_000)
    p, rec = player(clock, spin_us=200)
    for part in parts:
        assert p.play(part, lambda: False) == len(part)
    rows = concat(parts)
    expect = row_changes(parts)
    got = [(t // 1000, w) for i, (t, w, _) in enumerate(rec.log)
           if w != (rec.log[i - 1][1] if i else 0)]
    assert [w for _, w in got] == [w for _, w in expect]
    gaps = np.diff([t for t, _ in got]) - np.diff([t for t, _ in expect])
    assert gaps.min() >= -1 and gaps.max() <= 10      # planned intervals, give or take ticks
    pens = [(t // 1000, p) for i, (t, _, p) in enumerate(rec.log)
            if p != (rec.log[i - 1][2] if i else 0)]
    assert [p for _, p in pens] == [p for _, p in pen_changes(parts)]
    s = p.lateness.stats()
    changed = (np.diff(rows.coils, prepend=0) != 0) | (np.diff(rows.pen_us, prepend=0) != 0)
    assert s["n"] == changed.sum() and s["max_ms"] < 0.01 and s["shifts"] == 0


def test_player_does_not_drift_when_sleep_overshoots(parts):
    # sleeps overshoot by 0.15 ms, yet the last row is as punctual as the first
    clock = SimClock(tick_ns=1000, oversleep_ns=150_000)
    p, _ = player(clock, spin_us=200)
    for part in parts:
        p.play(part, lambda: False)
    late = np.frombuffer(p.lateness.ns, dtype=np.int64)
    assert late.max() < 10_000 and abs(late[-50:].mean() - late[:50].mean()) < 5_000


def test_player_pauses_instead_of_racing_when_the_motors_stand_still():
    """Rows late while the coils are released shift the timeline: the next stroke starts
    with its planned timing, the settle after a pen change is kept whole."""
    clock = SimClock(tick_ns=1000, oversleep_ns=50_000)
    p, rec = player(clock, spin_us=200)
    pen = make_rows([0, 300_000], [0, 0], [1500, 0])
    p.play(pen, lambda: False)
    clock.ns += 50_000_000                           # the caller computes the stroke: 50 ms
    stroke = steady(40)
    stroke.t_us += 300_000
    p.play(stroke, lambda: False)
    times = np.array([t for t, _, _ in rec.log])[2:]
    assert np.all(np.abs(np.diff(times) / 1000 - 1500) < 5)   # no catching up at all


def test_player_stops_within_a_few_milliseconds():
    clock = SimClock(tick_ns=1000, oversleep_ns=50_000)
    stop = {"now": False}
    clock.at(1_000_000_000 + 200_000_000, lambda: stop.update(now=True))
    p, rec = player(clock, spin_us=200)
    rows = make_rows([0, 1_000_000], [1, 3], [0, 0])
    assert p.play(rows, lambda: stop["now"]) == 1
    assert clock.ns - 1_000_000_000 < 205_000_000


# ---------------------------------------------------------------- lgpio on the stand-in
def lgpio_backend(cfg, clock, lg=None, **kw):
    """The lgpio backend on the stand-in (more in test_backend_lgpio.py)."""
    lg = lg or FakeLgpio(clock)
    b = create("lgpio", cfg, lgpio=lg, clock=clock.now, sleep=clock.sleep, **kw)
    return b, lg


# ---------------------------------------------------------------- gpiozero on MockFactory
def coil_words_from_log(cfg, log, start_ns, grouped: bool = True):
    """Single-pin changes as (t_us, coil word) changes: grouped by time, or one per change."""
    bit = {f"GPIO{p}": i for i, p in enumerate([*cfg.motors.left_pins, *cfg.motors.right_pins])}
    word, out = 0, []
    for t, name, value in log:
        if name not in bit:
            continue
        word = word | (1 << bit[name]) if value else word & ~(1 << bit[name])
        t_us = (t - start_ns) // 1000
        if grouped and out and out[-1][0] == t_us:
            out[-1] = (t_us, word)
        else:
            out.append((t_us, word))
    return [c for i, c in enumerate(out) if c[1] != (out[i - 1][1] if i else 0)]


def motor_patterns(words: list[int], motor: int) -> list[int]:
    """Distinct successive coil patterns of one motor from successive coil words."""
    out = [0]
    for w in words:
        if (w >> 4 * motor & 15) != out[-1]:
            out.append(w >> 4 * motor & 15)
    return out


def test_gpiozero_on_mock_pins_plays_what_the_fake_records(cfg, parts):
    fake = create("fake", cfg, record=True)
    fake.open()
    for part in parts:
        fake.play(part)
    fake.close()
    clock = SimClock(tick_ns=1000, oversleep_ns=80_000)
    b, factory = gpiozero_backend(cfg, clock)
    b.open()
    start = clock.ns
    for part in parts:
        assert b.play(part) == len(part)
    got = coil_words_from_log(cfg, LogPin.log, start, grouped=False)
    expect = row_changes(fake.recorded)
    for m in (0, 1):              # the same coil sequence, pin by pin: nothing in between
        assert (motor_patterns([w for _, w in got], m)
                == motor_patterns([w for _, w in expect], m))
    assert got[-1][0] - expect[-1][0] < 0.01 * expect[-1][0]        # about the plot time
    pens = [(t, v) for t, name, v in LogPin.log if name == f"GPIO{cfg.pen.pin}"]
    widths = [round(v * 20_000) for _, v in pens]
    assert widths == [w for _, w in pen_changes(parts)]              # 500, 0, 1500, 0, ...
    b.close()
    assert mock_outputs(cfg, factory) == (0, 0)
    assert b.lateness()["p99_ms"] < 0.05


def test_gpiozero_pin_factory_mock_from_the_environment(cfg, monkeypatch):
    """GPIOZERO_PIN_FACTORY=mock: plain mock pins (no PWM) still give a simulated servo."""
    from gpiozero import Device

    monkeypatch.setenv("GPIOZERO_PIN_FACTORY", "mock")
    monkeypatch.delenv("GPIOZERO_MOCK_PIN_CLASS", raising=False)
    monkeypatch.setattr(Device, "pin_factory", None)
    clock = SimClock(tick_ns=1000)
    b = create("gpiozero", cfg, clock=clock.now, sleep=clock.sleep)
    b.open()
    try:
        rows = make_rows([0, 300_000], [0, 0], [cfg.pen.down_us, 0])
        assert b.play(rows) == 2
    finally:
        b.close()
        if Device.pin_factory is not None:
            Device.pin_factory.close()


def test_gpiozero_without_gpio_suggests_dry_run(cfg, monkeypatch):
    from gpiozero import Device

    monkeypatch.delenv("GPIOZERO_PIN_FACTORY", raising=False)
    monkeypatch.setattr(Device, "pin_factory", None)
    b = create("gpiozero", cfg)
    try:
        b.open()
    except BackendError as e:
        assert "--dry-run" in str(e) and "\n" not in str(e)
    else:
        b.close()
        pytest.skip("this machine has GPIO")


def test_gpiozero_refuses_a_factory_without_pwm(cfg):
    from gpiozero.pins.mock import MockPin

    class NoPwmFactory(MockFactory):   # not called MockFactory: gets no PWM pen pin
        pass

    b = create("gpiozero", cfg, pin_factory=NoPwmFactory(pin_class=MockPin))
    with pytest.raises(BackendError, match="servo"):
        b.open()
    b.close()


# ---------------------------------------------------------------- fake in real time
def test_fake_realtime_uses_the_timing_loop(cfg, parts):
    clock = SimClock(tick_ns=1000, oversleep_ns=80_000)
    b = create("fake", cfg, realtime=True, record=True, clock=clock.now, sleep=clock.sleep,
               spin_us=200)
    b.open()
    for part in parts:
        assert b.play(part) == len(part)
    b.close()
    span = (clock.ns - 1_000_000_000) / 1e3
    assert abs(span - int(concat(parts).t_us[-1])) < 2_000     # it took the plot time
    s = b.lateness()
    rows = concat(parts)
    changed = (np.diff(rows.coils, prepend=0) != 0) | (np.diff(rows.pen_us, prepend=0) != 0)
    assert s["n"] == changed.sum() and s["p99_ms"] < 0.01
    assert create("fake", cfg).lateness() is None


# ---------------------------------------------------------------- one contract, every backend
def machine(kind, cfg):
    """(backend, clock, outputs()) for each backend on its simulated machine."""
    clock = SimClock(tick_ns=1000, oversleep_ns=80_000)
    if kind == "fake":
        b = create("fake", cfg, realtime=True, clock=clock.now, sleep=clock.sleep, spin_us=200)
        return b, clock, lambda: (b.coils, b.pen_us)
    if kind == "gpiozero":
        b, factory = gpiozero_backend(cfg, clock)
        return b, clock, lambda: mock_outputs(cfg, factory)
    b, lg = lgpio_backend(cfg, clock)

    def outputs():
        lg._advance()
        word = sum(lg.levels.get(p, 0) << i for i, p in enumerate(lg.group))
        on = lg.servo_on(cfg.pen.pin)
        stuck_high = not on and lg.levels.get(cfg.pen.pin, 0)
        return word, -1 if stuck_high else on

    return b, clock, outputs


BACKENDS = ["fake", "gpiozero", "lgpio"]


@pytest.mark.parametrize("kind", BACKENDS)
def test_close_leaves_coils_low_and_pulses_off(cfg, parts, kind):
    b, clock, outputs = machine(kind, cfg)
    b.open()
    assert outputs() == (0, 0)
    mid = [p for p in parts if (p.coils > 0).all() and len(p) > 50][0]
    for part in parts[:index(parts, mid) + 1]:
        b.play(part)
    assert outputs()[0] != 0                       # the motors are energised
    b.close()
    assert outputs() == (0, 0)
    b.close()                                      # twice is fine


@pytest.mark.parametrize("kind", BACKENDS)
def test_stop_requested_makes_play_return_early_with_the_rows_played(cfg, parts, kind):
    b, clock, outputs = machine(kind, cfg)
    b.open()
    stroke = max(parts, key=len)
    before = parts[:index(parts, stroke)]
    for part in before:
        b.play(part)
    stop_at = clock.ns + int((stroke.t_us[len(stroke) // 2] - stroke.t_us[0]) * 1000)
    clock.at(stop_at, lambda: setattr(b, "stop_requested", True))
    n = b.play(stroke)
    assert 0 < n < len(stroke)
    assert clock.ns - stop_at < 400_000_000          # stopped within the queue's 0.35 s
    # the outputs are exactly those after the last row reported played
    assert outputs() == (int(stroke.coils[n - 1]), int(stroke.pen_us[n - 1]))
    assert b.play(stroke) == 0                       # stays stopped until cleared
    b.close()
    assert outputs() == (0, 0)
