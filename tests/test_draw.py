"""End to end: draw files with the fake backend, decode the trace independently (tests/support/
tracecheck/ knows nothing of vplotter) and check what the motors would physically draw."""

import signal  # noqa: F401  (kept for symmetry with test_safety)

import pytest

from support import tracecheck as tc
from vplotter.cli import main

from support import REPO

SAMPLES = sorted((REPO / "gcode_samples").glob("*.ngc")) + [REPO / "tests" / "data" / "corners.ngc"]


def draw(config_path, gfile, trace, *extra):
    assert main(["--config", str(config_path), "calibrate", "--at", "0", "0"]) == 0
    return main(["--config", str(config_path), "draw", str(gfile), "--dry-run", "--trace", str(trace), *extra])


@pytest.mark.parametrize("gfile", SAMPLES, ids=[p.name for p in SAMPLES])
def test_trace_draws_the_gcode_path(gfile, config_path, tmp_path, capsys):
    trace = tmp_path / "t.csv"
    assert draw(config_path, gfile, trace) == 0
    cfg = tc.load_config(config_path)
    # decoding, illegal transitions, step rate, settling, release, 0.1 s-window acceleration,
    # page, and accuracy both ways (every pen-down point within 0.02 mm of the path, every part
    # of the path drawn within 0.02 mm)
    problems = tc.verify(tc.read_trace(trace), gfile, cfg, tol_mm=0.02)
    assert problems == []
    # the estimate printed before drawing is the trace's duration
    out = capsys.readouterr().out
    said = float(out.split("(")[-1].split(" s)")[0])
    assert abs(said - tc.plot_time(tc.read_trace(trace))) <= 0.05 + 0.001 * said


def test_estimate_equals_dry_run(config_path, tmp_path, capsys):
    gfile = REPO / "gcode_samples" / "circles.ngc"
    assert main(["--config", str(config_path), "estimate", str(gfile)]) == 0
    est = capsys.readouterr().out
    trace = tmp_path / "t.csv"
    assert draw(config_path, gfile, trace) == 0
    said = float(est.split("(")[-1].split(" s)")[0])
    assert abs(said - tc.plot_time(tc.read_trace(trace))) <= 0.001 * said + 0.05


def test_dry_run_does_not_touch_the_stored_position(config_path, tmp_path):
    from vplotter.machine import state

    trace = tmp_path / "t.csv"
    assert draw(config_path, REPO / "gcode_samples" / "square.ngc", trace) == 0
    pos = state.load()
    assert pos.counts == (0, 0)


def test_draw_on_the_fake_machine_stores_the_end_position(config_path, tmp_path):
    from vplotter.machine import state

    gfile = REPO / "gcode_samples" / "square.ngc"
    assert main(["--config", str(config_path), "calibrate", "--at", "0", "0"]) == 0
    trace = tmp_path / "t.csv"
    assert main(["--config", str(config_path), "draw", str(gfile), "--backend", "fake",
                 "--trace", str(trace)]) == 0
    cfg = tc.load_config(config_path)
    dec = tc.decode(tc.read_trace(trace), cfg)
    pos = state.load()
    assert pos.clean and pos.pen == "up"
    assert pos.left_mm == pytest.approx(dec.left_mm[-1], abs=1e-9)
    assert pos.right_mm == pytest.approx(dec.right_mm[-1], abs=1e-9)


def test_without_calibration_a_real_draw_refuses(config_path, capsys):
    gfile = REPO / "gcode_samples" / "square.ngc"
    assert main(["--config", str(config_path), "draw", str(gfile), "--backend", "fake"]) == 2
    err = capsys.readouterr().err
    assert "calibrate" in err and len(err.strip().splitlines()) == 1


def test_no_gpio_here_suggests_dry_run(config_path, capsys):
    gfile = REPO / "gcode_samples" / "square.ngc"
    assert main(["--config", str(config_path), "calibrate", "--at", "0", "0"]) == 0
    code = main(["--config", str(config_path), "draw", str(gfile), "--backend", "lgpio"])
    err = capsys.readouterr().err
    assert code != 0 and "--dry-run" in err and "Traceback" not in err
