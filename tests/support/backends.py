"""What the backend tests share: a short drawing in the parts `vplotter draw` hands to a
backend (the `cfg` and `parts` fixtures), rows made by hand, the changes a software-timed
backend writes, and gpiozero on MockFactory with its pins logged on a simulated clock.

The tests import these names (fixtures included) from here: test_backends.py, and the
backends' other tests (test_backend_lgpio.py, test_player.py, test_pen_change_pauses.py)."""

from __future__ import annotations

import random

import numpy as np
import pytest
from gpiozero.pins.mock import MockFactory, MockPWMPin

from vplotter import config, kinematics, pipeline
from vplotter.backends import create
from vplotter.inputs import gcode
from vplotter.machine import state
from vplotter.machine.ahead import stretches as _split
from vplotter.motion.schedule import Rows

from . import REPO
from .fake_lgpio import SimClock

SHORT = """G21
G0 X0 Y0
G1 Z-1 F100
G1 X3 Y0 F240
G1 X3 Y2
G4 P0.2
G1 X0 Y2
G0 Z5
G0 X1 Y1
M2
"""
FIELDS = ("t_us", "coils", "pen_us", "line", "steps")


@pytest.fixture(scope="module")
def cfg():
    return config.load(REPO / "config.toml")


@pytest.fixture(scope="module")
def parts(cfg, tmp_path_factory):
    """A short drawing (pen down, two lines, a dwell, pen up, travel: 4.8 s) in the parts
    `vplotter draw` hands to the backend."""
    path = tmp_path_factory.mktemp("g") / "short.ngc"
    path.write_text(SHORT)
    kin = kinematics.from_config(cfg)
    cords = kin.inverse(kin.to_machine(np.array([[0.0, 0.0]])))[0]
    pos = state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_unit)
    out = []
    for rows in pipeline.stream(cfg, gcode.read(str(path)), pos.counts, pos.ref_mm):
        out.extend(_split(rows))
    return out


def concat(parts) -> Rows:
    return Rows.concat(list(parts))


def rechunk(parts, seed: int) -> list[Rows]:
    """The same rows cut at random places (chunks of 1..40 rows)."""
    rows, rng, out, i = concat(parts), random.Random(seed), [], 0
    while i < len(rows):
        j = min(len(rows), i + rng.randint(1, 40))
        out.append(Rows(*(getattr(rows, f)[i:j] for f in FIELDS)))
        i = j
    return out


def make_rows(t, coils, pen) -> Rows:
    n = len(t)
    return Rows(np.asarray(t, np.int64), np.asarray(coils, np.uint8), np.asarray(pen, np.int32),
                np.zeros(n, np.int64), np.zeros((n, 2), np.int64))


def row_changes(parts) -> list[tuple[int, int]]:
    """(t_us, coil word) of every row that changes the coil word: what a software-timed
    backend writes, row by row (rows at equal times included)."""
    out, word = [], 0
    for t, w in zip(concat(parts).t_us.tolist(), concat(parts).coils.tolist()):
        if w != word:
            out.append((t, w))
            word = w
    return out


def pen_changes(parts) -> list[tuple[int, int]]:
    out, pen = [], 0
    for t, p in zip(concat(parts).t_us.tolist(), concat(parts).pen_us.tolist()):
        if p != pen:
            out.append((t, p))
            pen = p
    return out


def steady(n=400, gap_us=1500) -> Rows:
    """A motor stepping at a steady rate (energised throughout)."""
    t = np.arange(n, dtype=np.int64) * gap_us
    words = np.array([1, 3, 2, 6, 4, 12, 8, 9] * (n // 8 + 1), np.uint8)[:n]
    return make_rows(t, words, np.zeros(n))


class LogPin(MockPWMPin):
    """A mock pin that logs its changes with the simulated time."""

    log: list = []
    clock: SimClock | None = None

    def _change_state(self, value):
        changed = super()._change_state(value)
        if changed:
            LogPin.log.append((LogPin.clock.ns, self.info.name, value))
        return changed


def gpiozero_backend(cfg, clock, factory=None):
    LogPin.log, LogPin.clock = [], clock
    factory = factory or MockFactory(pin_class=LogPin)
    b = create("gpiozero", cfg, pin_factory=factory, clock=clock.now, sleep=clock.sleep,
               spin_us=200)
    return b, factory


def mock_outputs(cfg, factory) -> tuple[int, int]:
    """(coil word, pen pulse width) on the mock pins now."""
    pins = [*cfg.motors.left_pins, *cfg.motors.right_pins]
    word = sum(int(bool(factory.pin(f"GPIO{p}").state)) << i for i, p in enumerate(pins))
    pen = factory.pin(f"GPIO{cfg.pen.pin}")
    width = 0 if pen.frequency is None else int(round(pen.state * 1e6 / pen.frequency))
    return word, width
