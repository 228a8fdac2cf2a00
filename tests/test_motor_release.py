"""Motors are energised and released only in one-coil phases of the half-step table, so a
board written one pin at a time (gpiozero) shows exactly the rows' patterns: checked on the
traces of whole draws, of stops by Ctrl+C and of the scheduler's own rows."""

from __future__ import annotations

import signal

import numpy as np
import pytest

from support import tracecheck as tc
from support.signals import interrupt_after
from vplotter.motion import drivers
from vplotter.cli import main
from vplotter.config import load

from support import REPO

SAMPLES = REPO / "gcode_samples"


def draw(config_path, tmp_path, name, *extra):
    trace = tmp_path / f"{name}.csv"
    code = main(["--config", str(config_path), "draw", str(SAMPLES / name), "--trace",
                 str(trace), *extra])
    return code, tc.read_trace(trace)


@pytest.mark.parametrize("name", ["car.ngc", "circles.ngc", "square.ngc", "strokes.ngc"])
def test_a_whole_draw_energises_and_releases_in_one_coil_phases(name, config_path, tmp_path):
    cfg = tc.load_config(config_path)
    assert main(["--config", str(config_path), "calibrate", "--at", "0", "0"]) == 0
    code, trace = draw(config_path, tmp_path, name, "--backend", "fake")
    assert code == 0
    assert tc.two_coil_edges(trace, cfg) == []
    assert tc.released_at_end(trace, cfg) == []
    dec = tc.decode(trace, cfg)
    assert tc.illegal_transitions(dec) == []


@pytest.mark.parametrize("rows", [3_000, 7_001, 12_345, 20_002, 33_333])
def test_ctrl_c_releases_in_a_one_coil_phase_and_resume_draws_on(rows, config_path, tmp_path,
                                                               monkeypatch):
    cfg = tc.load_config(config_path)
    assert main(["--config", str(config_path), "calibrate", "--at", "0", "0"]) == 0
    orig = interrupt_after(monkeypatch, rows, signal.SIGINT)
    code, trace = draw(config_path, tmp_path, "circles.ngc", "--backend", "fake")
    assert code == 130
    assert tc.two_coil_edges(trace, cfg) == []
    dec = tc.decode(trace, cfg)
    assert tc.illegal_transitions(dec) == []
    assert tc.steps_while_settling(dec, cfg["pen"]["settle_s"]) == []
    from vplotter.backends.fake import FakeBackend
    monkeypatch.setattr(FakeBackend, "play", orig)
    code, rest = draw(config_path, tmp_path, "circles.ngc", "--backend", "fake", "--resume")
    # the resumed draw starts where the stop stored the position: in a one-coil phase
    assert code == 0 and tc.two_coil_edges(rest, cfg) == []


@pytest.mark.parametrize("counts", [(0, 0), (1, 0), (0, 1), (3, -5), (-1, 7)])
def test_the_driver_names_the_half_step_back_to_one_coil(counts, config_path):
    m = load(config_path).motors
    drv = drivers.create(m, counts)
    d = drv.to_one_coil()
    drv.advance(d)
    word = drv.hold_word()
    for motor in (0, 1):
        assert bin(word >> 4 * motor & 15).count("1") == 1
        assert d[motor] == (-1 if counts[motor] % 2 else 0)
    assert np.array_equal(drivers.create(m.__class__(**{**m.__dict__, "drive": "full"}),
                                         counts).to_one_coil(), [0, 0])
