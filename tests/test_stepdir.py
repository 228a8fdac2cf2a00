"""Step/dir drivers (A4988, DRV8825): the same drawing as with coil sequences, DIR set-up, pulse
widths and ENABLE in the trace (decoded by tracecheck, which knows nothing of vplotter), in
every backend, on Ctrl+C and on errors."""

from __future__ import annotations

import signal

import numpy as np
import pytest
from gpiozero.pins.mock import MockFactory
from hypothesis import given, strategies as st

from support import tracecheck as tc
from support.tracecheck import polar as tp
from support.fake_lgpio import FakeLgpio, SimClock
from vplotter import config, kinematics, pipeline
from vplotter.motion import drivers
from vplotter.machine import state
from vplotter.backends import create
from vplotter.cli import main
from vplotter.errors import ConfigError
from vplotter.inputs import gcode
from vplotter.machine.ahead import stretches as _split

from support import REPO
from support.signals import interrupt_after
from support.stepdir import stepdir_toml

SAMPLES = [REPO / "gcode_samples" / "circles.ngc", REPO / "tests" / "data" / "corners.ngc"]


@pytest.fixture
def sd_path(config_path, tmp_path):
    p = tmp_path / "stepdir.toml"
    p.write_text(stepdir_toml(config_path), encoding="utf-8")
    return p


def draw(cfg_path, gfile, trace, *extra):
    assert main(["--config", str(cfg_path), "calibrate", "--at", "0", "0"]) == 0
    return main(["--config", str(cfg_path), "draw", str(gfile), "--dry-run", "--trace", str(trace),
                 *extra])


@pytest.mark.parametrize("gfile", SAMPLES, ids=[p.name for p in SAMPLES])
def test_vplotter_with_stepdir_draws_what_the_coils_draw(gfile, config_path, sd_path, tmp_path):
    assert draw(config_path, gfile, tmp_path / "coils.csv") == 0
    assert draw(sd_path, gfile, tmp_path / "sd.csv") == 0
    c_cfg, s_cfg = tc.load_config(config_path), tc.load_config(sd_path)
    coils = tc.decode(tc.read_trace(tmp_path / "coils.csv"), c_cfg)
    sd_trace = tc.read_trace(tmp_path / "sd.csv")
    sd = tc.decode(sd_trace, s_cfg)
    for motor in ("left", "right"):
        a, b = coils.steps[motor], sd.steps[motor]
        assert len(a) > 1000 and len(a) == len(b)
        assert (a.dirs == b.dirs).all()                     # the same steps, the same way
        assert np.abs(a.t_us - b.t_us).max() <= 1           # at the same times
    # and the step/dir trace passes every check on its own (DIR set-up, pulse widths, ENABLE
    # low while stepping and high at the end, accuracy both ways, rate, acceleration)
    if gfile == SAMPLES[0]:
        assert tc.verify(sd_trace, gfile, s_cfg) == []
    order = np.argsort(sd_trace.t_us, kind="stable")
    assert tp.check_stepdir_timing(sd_trace.t_us[order], sd_trace.pin[order],
                                   sd_trace.value[order], s_cfg) == []
    assert set(np.unique(sd_trace.value[sd_trace.pin != 24])) == {0, 1}


def test_stepdir_config_keys_depend_on_the_driver(config_path, sd_path):
    import tomllib

    data = tomllib.loads(sd_path.read_text())
    cfg = config.from_dict(data)
    assert cfg.motors.out_pins == [17, 27, 22, 23, 4] and cfg.motors.idle_word == 1 << 4
    assert (cfg.motors.dir_setup_us, cfg.motors.step_pulse_us) == (1, 2)
    bad = {**data, "motors": {**data["motors"], "left_pins": [0, 5, 6, 13]}}
    with pytest.raises(ConfigError, match=r'\[motors\] left_pins is only for machine kind = '
                                          r'"vplotter" and driver = "uln2003"'):
        config.from_dict(bad)
    missing = {**data, "motors": {k: v for k, v in data["motors"].items() if k != "enable_pin"}}
    with pytest.raises(ConfigError, match=r"\[motors\] enable_pin is missing"):
        config.from_dict(missing)
    same = {**data, "motors": {**data["motors"], "right_dir_pin": 17}}
    with pytest.raises(ConfigError, match="pin 17 is already used by"):
        config.from_dict(same)
    coils = tomllib.loads(config_path.read_text())
    coils["motors"]["step_pulse_us"] = 3
    with pytest.raises(ConfigError, match=r'step_pulse_us is only for driver = "stepdir"'):
        config.from_dict(coils)


# ------------------------------------------------------------------ the driver, decoded
@st.composite
def events(draw_):
    n = draw_(st.integers(1, 60))
    gaps = draw_(st.lists(st.integers(0, 3000), min_size=n, max_size=n))
    motors = draw_(st.lists(st.integers(0, 1), min_size=n, max_size=n))
    dirs = draw_(st.lists(st.sampled_from([-1, 1]), min_size=n, max_size=n))
    t = 100 + np.cumsum(gaps)
    # one motor's steps at least one step interval (20 us here) apart
    last = {0: -10**9, 1: -10**9}
    out = []
    for ti, m, d in zip(t.tolist(), motors, dirs):
        ti = max(ti, last[m] + 20)
        last[m] = ti
        out.append((ti, m, d))
    out.sort(key=lambda e: e[0])
    return out, draw_(st.booleans()), draw_(st.integers(1, 5)), draw_(st.integers(1, 5))


@given(events())
def test_stepdir_rows_decode_to_the_same_steps(ev):
    evs, reverse, setup, width = ev
    cfg = config.from_dict({
        "machine": {"anchor_distance_mm": 400.0}, "origin": {"x_mm": 200.0, "y_mm": 300.0},
        "page": {"x_min_mm": -10.0, "x_max_mm": 10.0, "y_min_mm": -10.0, "y_max_mm": 10.0},
        "motors": {"driver": "stepdir", "steps_per_rev": 200, "spool_circumference_mm": 40.0,
                   "max_step_rate": 40000, "left_step_pin": 1, "left_dir_pin": 2,
                   "right_step_pin": 3, "right_dir_pin": 4, "enable_pin": 5,
                   "left_reverse": reverse, "dir_setup_us": setup, "step_pulse_us": width},
        "pen": {"pin": 6, "up_us": 500, "down_us": 1500}})
    drv = drivers.create(cfg.motors, (0, 0))
    t = np.array([e[0] for e in evs], dtype=np.int64)
    m = np.array([e[1] for e in evs], dtype=np.int64)
    d = np.array([e[2] for e in evs], dtype=np.int64)
    cl, cr = np.cumsum(np.where(m == 0, d, 0)), np.cumsum(np.where(m == 1, d, 0))
    t_rows, words, done, _ = drv.rows(t, m, d, 0, cl, cr)
    assert (np.diff(t_rows) > 0).all() and done[-1] == len(evs)
    # the rows as a trace: every pin at t = 0 (released), then the changes
    pins = cfg.motors.out_pins
    rows = [(0, p, drv.idle_word >> i & 1) for i, p in enumerate(pins)]
    rows += [(0, pins[4], 0)]                          # enabled
    prev = 0
    for ti, w in zip(t_rows.tolist(), words.tolist()):
        rows += [(ti, p, w >> i & 1) for i, p in enumerate(pins) if (w ^ prev) >> i & 1]
        prev = w
    rows += [(int(t_rows[-1]) + 10, pins[4], 1)]      # released
    tr = tc.Trace(np.array([r[0] for r in rows]) / 1e6, np.array([r[0] for r in rows]),
                  np.array([r[1] for r in rows]), np.array([r[2] for r in rows]))
    c = tc.load_config({"motors": {**{k: getattr(cfg.motors, k) for k in (
        "left_step_pin", "left_dir_pin", "right_step_pin", "right_dir_pin", "enable_pin",
        "dir_setup_us", "step_pulse_us", "left_reverse")}, "driver": "stepdir"}})
    assert tp.check_stepdir_timing(tr.t_us, tr.pin, tr.value, c) == []
    dec = tc.decode(tr, c)
    for k, motor in enumerate(("left", "right")):
        mine = m == k
        assert (dec.steps[motor].dirs == d[mine]).all()
        # the edge is at the event's time (or just after, if a DIR change had to come first)
        assert (dec.steps[motor].t_us - t[mine] >= 0).all()
        assert (dec.steps[motor].t_us - t[mine] <= setup).all()


def _trace(rows):
    rows = sorted(rows, key=lambda r: r[0])
    t = np.array([r[0] for r in rows])
    return t, np.array([r[1] for r in rows]), np.array([r[2] for r in rows])


SD = {"motors": {"driver": "stepdir", "left_step_pin": 17, "left_dir_pin": 27,
                 "right_step_pin": 22, "right_dir_pin": 23, "enable_pin": 4}}
INIT = [(0, 17, 0), (0, 27, 0), (0, 22, 0), (0, 23, 0), (0, 4, 0)]


@pytest.mark.parametrize("what,rows,message", [
    ("DIR at the edge", [(100, 27, 1), (100, 17, 1), (103, 17, 0), (200, 4, 1)], "DIR changes"),
    ("short pulse", [(99, 27, 1), (100, 17, 1), (101, 17, 0), (200, 4, 1)], "STEP level held 1 us"),
    ("enable high", [(50, 4, 1), (99, 27, 1), (100, 17, 1), (103, 17, 0)], "steps while ENABLE"),
    ("never released", [(99, 27, 1), (100, 17, 1), (103, 17, 0)], "ENABLE does not end high"),
])
def test_the_timing_check_catches(what, rows, message):
    c = tc.load_config(SD)
    t, pin, value = _trace(INIT + rows)
    assert any(message in p for p in tp.check_stepdir_timing(t, pin, value, c))
    good = [(99, 27, 1), (100, 17, 1), (102, 17, 0), (200, 4, 1)]
    t, pin, value = _trace(INIT + good)
    assert tp.check_stepdir_timing(t, pin, value, c) == []


# ------------------------------------------------------------------ every backend
@pytest.fixture
def sd_parts(sd_path):
    cfg = config.load(sd_path)
    kin = kinematics.from_config(cfg)
    cords = kin.inverse(kin.to_machine(np.array([[0.0, 0.0]])))[0]
    pos = state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_unit)
    text = "G21\nG0 X0 Y0\nM3\nG1 X3 Y0 F240\nG1 X3 Y2\nM5\nG0 X0 Y0\n"
    out = []
    for rows in pipeline.stream(cfg, _records(text, sd_path), pos.counts, pos.ref_mm):
        out.extend(_split(rows))
    return cfg, out


def _records(text, sd_path):
    p = sd_path.parent / "short.ngc"
    p.write_text(text)
    return gcode.read(str(p))


def _changes(seq, word=1 << 4):
    """(t, word) where the word changes from the idle word, the last write per time."""
    last: list = []
    for t, w in seq:
        if last and last[-1][0] == t:
            last[-1] = (t, w)
        else:
            last.append((t, w))
    out = []
    for t, w in last:
        if w != word:
            out.append((t, w))
            word = w
    return out


def test_lgpio_plays_step_dir_waves_and_leaves_enable_high(sd_parts):
    cfg, parts = sd_parts
    clock = SimClock()
    lg = FakeLgpio(clock)
    b = create("lgpio", cfg, lgpio=lg, clock=clock.now, sleep=clock.sleep)
    b.open()
    assert ("group_claim_output", 100, [17, 27, 22, 23, 4], [0, 0, 0, 0, 1]) in lg.calls
    for part in parts:
        assert b.play(part) == len(part)
    b.close()
    lg._advance()
    got = _changes([(t, w) for t, who, w in lg.log if who == "group"])
    expect = _changes(list(zip(np.concatenate([p.t_us for p in parts]).tolist(),
                               np.concatenate([p.coils for p in parts]).tolist())))
    assert [w for _, w in got] == [w for _, w in expect]   # every STEP/DIR/ENABLE change
    # the player writes in real time: never an interval shorter than planned (pulse widths,
    # DIR set-up), lateness only moves the timeline on
    gaps = np.diff([t for t, _ in got]) - np.diff([t for t, _ in expect])
    assert gaps.min() >= -1                               # (the pin log is in whole us)
    assert lg.levels[4] == 1                              # ENABLE high: motors free


def test_gpiozero_writes_step_dir_and_leaves_enable_high(sd_parts):
    cfg, parts = sd_parts
    clock = SimClock(tick_ns=1000, oversleep_ns=80_000)
    factory = MockFactory()
    b = create("gpiozero", cfg, pin_factory=factory, clock=clock.now, sleep=clock.sleep,
               spin_us=200)
    b.open()
    assert factory.pin("GPIO4").state == 1                # released until the first move
    rises, prev = 0, 0
    for part in parts:
        for i in range(len(part)):
            assert b.play(part[i:i + 1]) == 1
            step = factory.pin("GPIO17").state
            rises += int(step == 1 and prev == 0)
            prev = step
    b.close()
    assert factory.pin("GPIO4").state == 1
    words = np.concatenate([p.coils for p in parts])
    assert rises == int(((words[1:] & 1) > (words[:-1] & 1)).sum())


def test_fake_backend_idles_with_enable_high(sd_parts):
    cfg, parts = sd_parts
    b = create("fake", cfg)
    b.open()
    assert b.coils == 1 << 4
    b.play(parts[1])
    b.close()
    assert b.coils == 1 << 4


def interrupt_after_step_high(monkeypatch, after_rows: int) -> None:
    """SIGINT once the fake backend has played a part (after `after_rows` rows) that ends with
    a STEP pin high: the stop then comes in the middle of a pulse."""
    import os

    from vplotter.backends.fake import FakeBackend

    orig, seen = FakeBackend.play, {"n": 0, "sent": False}

    def play(self, rows):
        high = np.flatnonzero(rows.coils & 0b101)
        if seen["sent"] or seen["n"] < after_rows or not len(high):
            n = orig(self, rows)
            seen["n"] += n
            return n
        # the signal comes while this part is played, right after a rising STEP edge
        n = orig(self, rows[:int(high[0]) + 1])
        seen["sent"] = True
        os.kill(os.getpid(), signal.SIGINT)
        return n

    monkeypatch.setattr(FakeBackend, "play", play)


@pytest.mark.parametrize("where", ["anywhere", "STEP high"])
def test_ctrl_c_mid_draw_releases_the_step_dir_motors(where, sd_path, tmp_path, monkeypatch):
    trace = tmp_path / "t.csv"
    assert main(["--config", str(sd_path), "calibrate", "--at", "0", "0"]) == 0
    if where == "anywhere":
        interrupt_after(monkeypatch, 20_000, signal.SIGINT)
    else:
        interrupt_after_step_high(monkeypatch, 20_000)
    code = main(["--config", str(sd_path), "draw", str(SAMPLES[0]), "--backend", "fake",
                 "--trace", str(trace)])
    assert code == 130
    c = tc.load_config(sd_path)
    tr = tc.read_trace(trace)
    order = np.argsort(tr.t_us, kind="stable")
    assert tp.check_stepdir_timing(tr.t_us[order], tr.pin[order], tr.value[order], c) == []
    assert tc.released_at_end(tr, c) == []                # ENABLE high, STEP low, pen up


def test_an_error_mid_draw_releases_the_step_dir_motors(sd_path, tmp_path, monkeypatch):
    from vplotter.backends.fake import FakeBackend
    from vplotter.errors import MachineError

    trace = tmp_path / "t.csv"
    assert main(["--config", str(sd_path), "calibrate", "--at", "0", "0"]) == 0
    orig, calls = FakeBackend.play, {"n": 0}

    def play(self, rows):
        calls["n"] += 1
        if calls["n"] == 5:
            raise MachineError("error: the stand-in failed")
        return orig(self, rows)

    monkeypatch.setattr(FakeBackend, "play", play)
    code = main(["--config", str(sd_path), "draw", str(SAMPLES[0]), "--backend", "fake",
                 "--trace", str(trace)])
    assert code == 2
    assert tc.released_at_end(tc.read_trace(trace), tc.load_config(sd_path)) == []
