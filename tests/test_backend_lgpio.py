"""The lgpio backend (and gpiozero on its lgpio pin factory) on the stand-in lgpio
(tests/support/fake_lgpio.py), which is as unkind as lgpio 0.2.2: catch-up bursts after a stall,
retained wave buffers, the head-free hang, servo trains cut by tx_servo(pin, 0), gpiozero's
whole-percent duty cycle, the notify FIFO, gpiochip errors. Nothing here really sleeps."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from support.backends import (cfg, concat, make_rows, parts, pen_changes,  # noqa: F401 (fixtures)
                              rechunk, row_changes)
from support.fake_lgpio import (COLD_WRITE_US, HOT_WRITE_US, FakeLgpio, SimClock,
                                expected_coil_changes, pulse)
from vplotter import config
from vplotter.machine import state
from vplotter.backends import create, lgpio_setup
from vplotter.backends.realtime import Folded
from vplotter.backends.lgpio_setup import load_lgpio
from vplotter.errors import BackendError
from vplotter.machine.job import Session

FRAME_US = 20_000


def lgpio_backend(cfg, clock, lg=None):
    lg = lg or FakeLgpio(clock)
    return create("lgpio", cfg, lgpio=lg, clock=clock.now, sleep=clock.sleep), lg


def play_all(b, parts):
    b.open()
    try:
        for part in parts:
            assert b.play(part) == len(part)
    finally:
        b.close()


def step_times(changes, motor: int) -> np.ndarray:
    """Times (us) at which one motor's nibble moves to another energised pattern: its steps."""
    out, prev = [], 0
    for t, w in changes:
        nib = w >> (4 * motor) & 0xF
        if nib and prev and nib != prev:
            out.append(t)
        prev = nib
    return np.array(out, dtype=np.int64)


# ---------------------------------------------------------------- coils: vplotter's timeline
@pytest.mark.parametrize("chunking", ["draw parts", "random 1", "random 2"])
def test_coils_play_the_planned_rows_in_one_group_write_each(cfg, parts, chunking):
    chunks = parts if chunking == "draw parts" else rechunk(parts, int(chunking[-1]))
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    play_all(b, chunks)
    expect = row_changes(chunks)             # row by row, rows at equal times included
    got = [(t, w) for t, who, w in lg.log if who == "group"][-len(expect) - 1:]
    assert [w for _, w in got] == [w for _, w in expect] + [0]     # + the release at close
    # on time: no interval shorter than planned (0.1 ms slack), the whole within 1 %
    played = np.diff([t for t, _ in got[:len(expect)]])
    planned = np.diff([t for t, _ in expect])
    assert (played >= planned - 100).all()
    assert abs(played.sum() - planned.sum()) <= 0.01 * planned.sum()
    # both motors in one write: every coil change is one group_write of the whole group
    writes = [c for c in lg.calls if c[0] == "group_write"]
    assert writes and all(c[2] == cfg.motors.left_pins[0] and c[4] == 0xFF for c in writes)
    assert ("group_claim_output", 100, [0, 5, 6, 13, 12, 16, 20, 21], [0] * 8) in lg.calls
    assert not [c for c in lg.calls if c[0] == "tx_wave"] and lg.retained_bytes == 0


@pytest.mark.parametrize("when", [0.35, 0.55, 0.8])
def test_no_burst_of_steps_after_a_stall(cfg, parts, when):
    """The process stops twice for 0.3 s mid-plot (SIGSTOP/SIGCONT): no motor steps faster
    than max_step_rate afterwards, and the steps are the planned ones."""
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    total_ns = int(concat(parts).t_us[-1] * 1000)
    start = clock.ns
    for k in (0, 1):
        clock.at(start + int(total_ns * when) + k * 700_000_000, lambda: lg.stall(300_000))
    play_all(b, parts)
    assert len(lg.stalls) == 2
    expect = row_changes(parts)
    got = [(t, w) for t, who, w in lg.log if who == "group"][-len(expect) - 1:]
    assert [w for _, w in got] == [w for _, w in expect] + [0]
    limit_us = 1e6 / cfg.motors.max_step_rate
    for motor in (0, 1):
        steps = step_times(got, motor)
        assert len(steps) == len(step_times(expect, motor)) > 100
        assert np.diff(steps).min() >= 0.98 * limit_us


def test_the_stand_in_bursts_like_lgpio_after_a_stall():
    """Waves queued in lgpio are played back to back after a stall (what the stand-in must
    show, so that a wave-based backend fails the test above)."""
    clock = SimClock()
    lg = FakeLgpio(clock)
    h = lg.gpiochip_open(0)
    lg.group_claim_output(h, [0, 5, 6, 13], [0] * 4)
    seq = [1, 3, 2, 6, 4, 12, 8, 9] * 20
    lg.tx_wave(h, 0, [pulse(w, 0xF, 1600) for w in seq])
    clock.ns += 50_000_000
    lg.stall(100_000)
    clock.ns += 300_000_000
    t = np.array([t for t, _ in lg.coil_changes()])
    assert len(t) == len(seq) and (np.diff(t) < 100).sum() > 50   # 62 steps in 1 ms


def test_the_stand_in_retains_finished_waves():
    clock = SimClock()
    lg = FakeLgpio(clock)
    h = lg.gpiochip_open(0)
    lg.group_claim_output(h, [0, 5, 6, 13], [0] * 4)
    for _ in range(3):
        lg.tx_wave(h, 0, [pulse(1, 0xF, 1000), pulse(3, 0xF, 1000)])
    clock.ns += 10_000_000
    lg.tx_busy(h, 0, lg.TX_WAVE)
    assert lg.retained_bytes == 2 * 2 * 24        # the two waves that had one behind them


# ---------------------------------------------------------------- the pen
def test_pen_pulses_are_exact_whole_and_written_by_the_player(cfg, parts):
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    before = os.sched_getscheduler(0), os.sched_getparam(0).sched_priority
    switch = sys.getswitchinterval()
    play_all(b, parts)
    pin, (up, down) = cfg.pen.pin, (cfg.pen.up_us, cfg.pen.down_us)
    pulses = lg.widths(pin)
    assert pulses and all(min(abs(w - up), abs(w - down)) <= 1 for _, w in pulses)
    # each pen change gets the pulses that fit whole in its settle time, 20 ms apart
    per_train = int(cfg.pen.settle_s * 1e6 // FRAME_US)
    trains = sum(1 for _, w in pen_changes(parts) if w > 0)
    assert len(pulses) == per_train * trains
    gaps = np.diff([t for t, _ in pulses])
    assert gaps.min() >= FRAME_US - 1
    # lgpio's tx thread never gets a job: nothing it could play late, cut short or hang on
    assert not [c for c in lg.calls if c[0].startswith("tx_")] and not lg.jobs
    assert lg.levels[pin] == 0 and lg.truncated == 0
    assert (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority) == before
    assert sys.getswitchinterval() == switch


def test_without_the_warm_up_write_the_stand_in_makes_pulses_short(cfg, monkeypatch):
    """The first write after a sleep reaches the pin late (stand-in, as measured): a pulse
    whose rise follows a sleep directly is short, which the test above would catch."""
    from vplotter.backends import realtime

    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    orig = realtime.Player._train

    def no_warm_up(self, due, stop):
        pulse = self.pulse
        self.pulse = lambda level: None if level == 0 and lg.levels.get(cfg.pen.pin) == 0 \
            else pulse(level)
        try:
            return orig(self, due, stop)
        finally:
            self.pulse = pulse

    monkeypatch.setattr(realtime.Player, "_train", no_warm_up)
    play_all(b, [make_rows([0, 300_000], [0, 0], [cfg.pen.up_us, 0])])
    widths = [w for _, w in lg.widths(cfg.pen.pin)]
    assert widths.count(cfg.pen.up_us - (COLD_WRITE_US - HOT_WRITE_US)) >= 13        # all but the first pulse or two


def test_pen_changes_at_one_time_are_one_train_behind_the_other(cfg):
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    up, down = cfg.pen.up_us, cfg.pen.down_us
    rows = make_rows([0, 300_000, 300_000, 600_000, 900_000],
                     [0, 0, 0, 0, 0], [up, 0, down, 0, 0])
    play_all(b, [rows])
    pulses = lg.widths(cfg.pen.pin)
    assert [w for _, w in pulses] == [up] * 15 + [down] * 15
    gaps = np.diff([t for t, _ in pulses])
    assert gaps.min() >= FRAME_US - 1 and gaps.max() <= FRAME_US + 200   # no gap, no overlap


def test_a_stop_comes_between_two_pulses(cfg):
    """Ctrl+C in the middle of a pen change: the pulses end whole, the pin low."""
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    b.open()
    for k in range(1, 12):                   # a stop request at odd moments, inside pulses too
        clock.at(clock.ns + k * 13_700_000, lambda: setattr(b, "stop_requested", True))
    n = b.play(make_rows([0, 300_000, 600_000], [0, 0, 0], [cfg.pen.up_us, 0, 0]))
    b.close()
    assert n < 3
    pulses = lg.widths(cfg.pen.pin)
    assert pulses and all(abs(w - cfg.pen.up_us) <= 1 for _, w in pulses)
    assert lg.levels[cfg.pen.pin] == 0


def test_the_stand_in_hangs_when_the_head_job_is_freed():
    clock = SimClock()
    lg = FakeLgpio(clock)
    h = lg.gpiochip_open(0)
    lg.group_claim_output(h, [0, 5, 6, 13], [0] * 4)
    lg.gpio_claim_output(h, 24, 0)
    lg.tx_wave(h, 0, [pulse(1, 0xF, 50_000)] * 4)
    lg.tx_servo(h, 24, 1500)
    clock.ns += 30_000_000
    lg.tx_servo(h, 24, 0)                     # frees the head job, the waves behind it
    before = len(lg.log)
    clock.ns += 500_000_000
    assert lg.hung and lg.tx_busy(h, 0, lg.TX_WAVE) and len(lg.log) == before


def test_the_stand_in_makes_plain_servo_pulses_short():
    """lgpio's own servo train: its tx thread wakes later after the long sleep before a rise
    than after the short one before a fall (why vplotter times the pulses itself)."""
    clock = SimClock()
    lg = FakeLgpio(clock)
    h = lg.gpiochip_open(0)
    lg.gpio_claim_output(h, 24, 0)
    lg.tx_servo(h, 24, 1500, 50, 0, 10)
    clock.ns += 300_000_000
    lg.tx_busy(h, 24, lg.TX_PWM)
    widths = {w for _, w in lg.widths(24)}
    assert widths == {1500 - (45 - 5)}


# ---------------------------------------------------------------- memory
def test_lateness_is_kept_in_fixed_memory(cfg, parts, monkeypatch):
    from vplotter.backends.realtime import Lateness

    monkeypatch.setattr(Lateness, "FOLD", 16)
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)
    b.open()
    for part in parts:
        b.play(part)
        assert len(b._player.lateness.ns) < 16 + len(part)   # folded once there are FOLD
    size = b._player.lateness.folded.counts.nbytes
    b.close()
    stats = b.lateness()
    coil_writes = len([c for c in lg.calls if c[0] == "group_write"]) - 1    # - the one at close
    assert stats["n"] >= coil_writes > 100                  # every change measured, none lost
    assert stats["max_ms"] >= stats["p99_ms"] >= stats["p50_ms"]
    assert b._player.lateness.folded.counts.nbytes == size


def test_freed_pages_are_given_back_between_parts_at_most_every_few_seconds(monkeypatch):
    from vplotter.backends import memory

    calls = []
    libc = type("libc", (), {"malloc_trim": lambda self, pad: calls.append(("trim", pad)),
                             "mallopt": lambda self, k, v: calls.append((k, v))})()
    monkeypatch.setattr(memory, "_libc", libc)
    monkeypatch.setattr(memory, "_last", 0.0)
    memory.lean_malloc()
    assert (memory.M_ARENA_MAX, 1) in calls and (memory.M_MMAP_THRESHOLD, memory.MMAP_FROM) in calls
    for t in (100.0, 101.0, 104.9, 105.0, 106.0):
        memory.give_back(t)
    assert calls.count(("trim", 0)) == 2


def test_folded_percentiles_match_the_exact_ones():
    rng = np.random.default_rng(1)
    ns = np.concatenate((rng.exponential(30_000, 5000), rng.exponential(5e6, 50))).astype(np.int64)
    f = Folded()
    for chunk in np.array_split(ns, 7):
        f.add(chunk)
    s = f.stats()
    p50, p99 = np.percentile(ns, [50, 99], method="inverted_cdf") / 1e6
    assert s["n"] == len(ns) and s["max_ms"] == ns.max() / 1e6
    assert 0 <= s["p50_ms"] - p50 <= 0.001 and 0 <= s["p99_ms"] - p99 <= 0.01 * p99 + 0.001


# ---------------------------------------------------------------- import, chip, errors
def test_import_puts_the_notify_fifo_in_the_state_directory(tmp_path, monkeypatch):
    user = tmp_path / "user"
    user.mkdir()
    monkeypatch.chdir(user)
    lg = FakeLgpio(SimClock())
    assert load_lgpio(importer=lg.importer()) is lg
    assert os.getcwd() == str(user)                      # a relative --trace lands here
    assert not list(user.glob(".lgd-nfy*"))
    assert not list(state.state_dir().glob(".lgd-nfy*"))  # its name removed once open
    assert "LG_WD" not in os.environ


def test_import_without_lgpio_says_how_to_get_it(monkeypatch):
    def missing():
        raise ImportError("No module named 'lgpio'")

    with pytest.raises(BackendError) as e:
        load_lgpio(importer=missing)
    msg = str(e.value)
    assert "\n" not in msg and "python3-lgpio" in msg and "[pi]" in msg and "--dry-run" in msg
    want = "adafruit-lgpio" if sys.version_info >= (3, 13) else "`pip install lgpio`"
    assert want in msg and f"Python {sys.version_info[0]}.{sys.version_info[1]}" in msg


@pytest.mark.parametrize("version, package", [((3, 11), "lgpio"), ((3, 12), "lgpio"),
                                              ((3, 13), "adafruit-lgpio"),
                                              ((3, 14), "adafruit-lgpio")])
def test_the_missing_message_names_the_package_for_the_python(version, package):
    from vplotter.backends.lgpio_setup import missing

    assert f"`pip install {package}`" in missing(version)
    assert f"Python {version[0]}.{version[1]}" in missing(version)


def test_import_failing_on_the_fifo_is_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    lg = FakeLgpio(SimClock())
    monkeypatch.setattr(os, "mkfifo", lambda *a: (_ for _ in ()).throw(PermissionError(13, "no")))
    with pytest.raises(BackendError) as e:
        load_lgpio(importer=lg.importer())
    assert "\n" not in str(e.value) and "--dry-run" in str(e.value)
    assert os.getcwd() == str(tmp_path)


def test_unusable_state_directory_is_one_line(tmp_path, monkeypatch):
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("XDG_STATE_HOME", str(tmp_path / "file"))
    with pytest.raises(BackendError, match="XDG_STATE_HOME"):
        load_lgpio(importer=FakeLgpio(SimClock()).importer())


@pytest.mark.parametrize("chips, denied, words", [
    ((), (), ["no /dev/gpiochip0", "--dry-run", "[gpio] chip = 4"]),
    ((0,), (0,), ["permission denied", "gpio group", "--dry-run"]),
])
def test_gpiochip_errors_say_what_to_do(cfg, monkeypatch, chips, denied, words):
    clock = SimClock()
    lg = FakeLgpio(clock, chips=chips, denied=denied)
    monkeypatch.setattr(lgpio_setup, "chip_errno", lg.chip_errno)
    b, _ = lgpio_backend(cfg, clock, lg)
    with pytest.raises(BackendError) as e:
        b.open()
    assert "\n" not in str(e.value) and all(w in str(e.value) for w in words)
    b.close()


def test_pins_in_use_is_one_line(cfg, monkeypatch):
    clock = SimClock()
    b, lg = lgpio_backend(cfg, clock)

    def busy(*a):                                       # another program holds the pen pin
        raise lg.error("GPIO busy")

    monkeypatch.setattr(lg, "gpio_claim_output", busy)
    with pytest.raises(BackendError, match="another program") as e:
        b.open()
    assert "\n" not in str(e.value) and not lg.open_handles


def test_the_configured_chip_is_used(cfg):
    clock = SimClock()
    pi5 = config.Config(**{**cfg.__dict__, "gpio": config.Gpio("lgpio", 4)})
    b, lg = lgpio_backend(pi5, clock, FakeLgpio(clock, chips=(4,)))
    b.open()
    b.close()
    assert lg.calls[0] == ("gpiochip_open", 4) and lg.calls[-1] == ("gpiochip_close", 104)


def test_the_stand_in_takes_the_module_s_place(cfg, parts, monkeypatch):
    clock = SimClock()
    lg = FakeLgpio(clock)
    monkeypatch.setitem(sys.modules, "lgpio", lg)
    b = create("lgpio", cfg, clock=clock.now, sleep=clock.sleep)
    play_all(b, parts[:6])
    assert [w for t, who, w in lg.log if who == "group"][-len(row_changes(parts[:6])) - 1:] \
        == [w for _, w in row_changes(parts[:6])] + [0]


# ---------------------------------------------------------------- gpiozero on its lgpio factory
@pytest.fixture
def lgpio_factory(monkeypatch):
    """gpiozero's own LGPIOFactory, running on the stand-in."""
    clock = SimClock()
    lg = FakeLgpio(clock)
    monkeypatch.setitem(sys.modules, "lgpio", lg)
    saved = sys.modules.pop("gpiozero.pins.lgpio", None)
    try:
        import gpiozero.pins.lgpio as gl

        monkeypatch.setattr(gl.LGPIOFactory, "_get_revision", lambda self: 0xC03111)
        factory = gl.LGPIOFactory(chip=0)
        yield factory, lg, clock
        factory.close()
    finally:
        sys.modules.pop("gpiozero.pins.lgpio", None)
        if saved is not None:
            sys.modules["gpiozero.pins.lgpio"] = saved


def test_the_stand_in_rounds_where_gpiozero_rounds(cfg, lgpio_factory):
    """gpiozero's Servo on its lgpio factory: duty cycle in whole percent (issue 1209)."""
    from gpiozero import Servo

    factory, lg, clock = lgpio_factory
    servo = Servo(cfg.pen.pin, initial_value=None, min_pulse_width=cfg.pen.up_us / 1e6,
                  max_pulse_width=cfg.pen.down_us / 1e6, frame_width=0.02, pin_factory=factory)
    servo.value = -1
    clock.ns += 100_000_000
    servo.value = 1
    clock.ns += 100_000_000
    servo.close()
    widths = {w for _, w in lg.widths(cfg.pen.pin) if w}
    assert widths and cfg.pen.up_us not in widths and cfg.pen.down_us not in widths


def test_gpiozero_on_its_lgpio_factory_makes_exact_pulses(cfg, parts, lgpio_factory):
    factory, lg, clock = lgpio_factory
    b = create("gpiozero", cfg, pin_factory=factory, clock=clock.now, sleep=clock.sleep,
               spin_us=200)
    play_all(b, parts)
    widths = [w for _, w in lg.widths(cfg.pen.pin)]
    up, down = cfg.pen.up_us, cfg.pen.down_us
    assert widths and all(min(abs(w - up), abs(w - down)) <= 1 for w in widths)
    assert {up, down} <= set(widths)
    assert not [c for c in lg.calls if c[0].startswith("tx_")]
    assert lg.truncated == 0 and lg.levels[cfg.pen.pin] == 0
