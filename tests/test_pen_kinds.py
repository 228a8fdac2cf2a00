"""Pen kinds: "output" (a solenoid held high while down) and "switch" (a cam motor run until its
switch closes, with a timeout that is a clear error), on the fake, gpiozero's MockFactory and
the lgpio stand-in; nothing sleeps."""

from __future__ import annotations

import numpy as np
import pytest
from gpiozero.pins.mock import MockFactory, MockPin

from support.fake_lgpio import FakeLgpio, SimClock
from vplotter import config, kinematics, pipeline
from vplotter.machine import state
from vplotter.backends import create
from vplotter.cli import main
from vplotter.errors import MachineError
from vplotter.inputs import gcode

from support import REPO

SHORT = "G21\nG0 X1 Y1\nM3\nG1 X3 Y1 F240\nM5\nG0 X0 Y0\n"


def pen_config(tmp_path, pen: str):
    text = (REPO / "examples" / "polar.toml").read_text(encoding="utf-8")
    head, rest = text.split("[pen]", 1)
    rest = rest.split("[motion]", 1)[1]
    p = tmp_path / "pen.toml"
    p.write_text(head + "[pen]\n" + pen.strip() + "\n\n[motion]" + rest, encoding="utf-8")
    return p


OUTPUT = 'kind = "output"\npin = 24\nsettle_s = 0.1'
SWITCH = 'kind = "switch"\npin = 24\nswitch_pin = 25\ntimeout_s = 1.0\ndown_s = 0.2'


def rows_for(cfg, tmp_path):
    kin = kinematics.from_config(cfg)
    q = kin.inverse(kin.to_machine(np.array([[0.0, 0.0]])))[0]
    pos = state.Position.at_cords(q[0], q[1], cfg.motors.steps_per_unit)
    g = tmp_path / "s.ngc"
    g.write_text(SHORT)
    return list(pipeline.stream(cfg, gcode.read(str(g)), pos.counts, pos.ref_mm))


def test_pen_kinds_config(tmp_path):
    cfg = config.load(pen_config(tmp_path, SWITCH))
    assert (cfg.pen.kind, cfg.pen.switch_pin, cfg.pen.up_us, cfg.pen.down_us) == ("switch", 25, 1, 2)
    with pytest.raises(config.ConfigError, match=r'\[pen\] up_us is only for pen kind = "servo"'):
        config.load(pen_config(tmp_path, OUTPUT + "\nup_us = 500"))
    with pytest.raises(config.ConfigError, match=r"\[pen\] switch_pin is missing"):
        config.load(pen_config(tmp_path, 'kind = "switch"\npin = 24'))
    with pytest.raises(config.ConfigError, match=r"\[pen\] switch_pin: pin 17 is already used"):
        config.load(pen_config(tmp_path, SWITCH.replace("25", "17")))


@pytest.mark.parametrize("pen", [OUTPUT, SWITCH], ids=["output", "switch"])
def test_dry_run_with_other_pens(pen, tmp_path):
    cfg_path = pen_config(tmp_path, pen)
    g = tmp_path / "s.ngc"
    g.write_text(SHORT)
    trace = tmp_path / "t.csv"
    assert main(["--config", str(cfg_path), "draw", str(g), "--dry-run", "--trace", str(trace)]) == 0
    pen_rows = [ln.split(",")[2] for ln in trace.read_text().splitlines() if ln.split(",")[1:2] == ["24"]]
    assert pen_rows == ["1", "0", "2", "0", "1", "0"]       # up, down, up: the commands' codes


def test_fake_cam_that_never_closes_is_a_clear_error(tmp_path):
    cfg = config.load(pen_config(tmp_path, SWITCH))
    b = create("fake", cfg, switch_after_s=3.0)          # the cam needs 3 s, the timeout is 1 s
    b.open()
    with pytest.raises(MachineError, match=r"switch \(GPIO25\) did not close within 1 s"):
        for rows in rows_for(cfg, tmp_path):
            b.play(rows)
    b.close()
    ok = create("fake", cfg, switch_after_s=0.5)
    ok.open()
    for rows in rows_for(cfg, tmp_path):
        assert ok.play(rows) == len(rows)
    ok.close()


class CamPin(MockPin):
    """The cam motor's pin: running it closes the switch (GPIO25, to ground) at once."""

    def _set_state(self, value):
        super()._set_state(value)
        if value and self.factory is not None:
            self.factory.pin("GPIO25").drive_low()


def test_gpiozero_output_and_switch_pens(tmp_path):
    clock = SimClock(tick_ns=1000)
    cfg = config.load(pen_config(tmp_path, OUTPUT))
    factory = MockFactory()
    b = create("gpiozero", cfg, pin_factory=factory, clock=clock.now, sleep=clock.sleep)
    b.open()
    levels = []
    for rows in rows_for(cfg, tmp_path):
        for i in range(len(rows)):
            b.play(rows[i:i + 1])
            levels.append(factory.pin("GPIO24").state)
    b.close()
    assert [k for i, k in enumerate(levels) if i == 0 or k != levels[i - 1]] == [0, 1, 0]

    cfg = config.load(pen_config(tmp_path, SWITCH))
    factory = MockFactory()
    factory.pin("GPIO24", pin_class=CamPin)
    factory.pin("GPIO25").drive_high()                   # open (pulled up)
    b = create("gpiozero", cfg, pin_factory=factory, clock=clock.now, sleep=clock.sleep)
    b.open()
    b._kind_pen.sleep = lambda s: None                   # the quarter turn down, simulated
    for rows in rows_for(cfg, tmp_path):
        b.play(rows)
    b.close()
    assert factory.pin("GPIO24").state == 0              # the cam motor stopped


def test_lgpio_refuses_other_pens_with_a_hint(tmp_path):
    from vplotter.errors import BackendError

    cfg = config.load(pen_config(tmp_path, SWITCH))
    b = create("lgpio", cfg, lgpio=FakeLgpio(SimClock()))
    with pytest.raises(BackendError, match='kind = "switch" use --backend gpiozero'):
        b.open()
