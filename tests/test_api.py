"""The Python API (`from vplotter import Plotter`, docs/api.md): a script of lineto's draws
what the same G-code file draws (the same trace, the same plot time), drawn in parts without a
stop at each call; Ctrl+C and SIGTERM, during a play or between two calls, leave the machine as
`draw` leaves it; a second plotter process is refused as `draw` refuses it; errors name the
script's line; draw_file and estimate are draw's and estimate's."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from support import REPO
from support import tracecheck as tc
from support.scripts import gcode_of, spiral, walks
from support.signals import hold_lock, interrupt_after
from vplotter import api
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main
from vplotter.errors import BusyError, InputError
from vplotter.machine import state


def run(config_path, *argv):
    return main(["--config", str(config_path), *map(str, argv)])


def rows(path) -> list[str]:
    return [line for line in path.read_text().splitlines() if not line.startswith("#")]


def test_2000_linetos_draw_the_trace_of_the_same_gcode_file(config_path, tmp_path, capsys):
    pts = spiral(2000)
    ngc = tmp_path / "spiral.ngc"
    ngc.write_text(gcode_of([pts]))
    t_api, t_file = tmp_path / "api.csv", tmp_path / "file.csv"
    with api.Plotter(config_path, dry_run=True, trace=t_api) as p:
        p.moveto(*pts[0])
        p.pendown()
        for x, y in pts[1:]:
            p.lineto(x, y)
        p.penup()
        planned = p.estimate()
    assert run(config_path, "draw", ngc, "--dry-run", "--trace", t_file) == 0
    said = capsys.readouterr().out
    assert rows(t_api) == rows(t_file)              # byte for byte, every GPIO change
    assert planned.moves == 2001 and planned.text in said
    assert 0.98 <= planned.time_s / tc.plot_time(tc.read_trace(t_file)) <= 1.02


def test_a_script_in_parts_draws_the_file_within_tolerance(config_path, tmp_path, monkeypatch,
                                                           capsys):
    monkeypatch.setattr(api, "FLUSH_AT_LIFT", 150)     # a part every 15 strokes or so
    # 60 strokes of 10 steps of up to 1 mm in a 60 x 40 mm patch: the same calls, parts and
    # lifts as strokes of 3 mm steps across the page, a third of the ink, a fifth of the
    # travel (each trace written, read and decoded: 0.39 M rows, 1.78 M across the page)
    strokes = walks(60, 10, spread=(30.0, 20.0), step=1.0)
    ngc = tmp_path / "walks.ngc"
    ngc.write_text(gcode_of(strokes))
    t_api, t_file = tmp_path / "api.csv", tmp_path / "file.csv"
    parts = []
    orig = api.Plotter.flush

    def flush(self):
        parts.append(len(self._records))
        orig(self)

    monkeypatch.setattr(api.Plotter, "flush", flush)
    with api.Plotter(config_path, dry_run=True, trace=t_api) as p:
        for pts in strokes:
            p.draw_path(pts)
    assert run(config_path, "draw", ngc, "--dry-run", "--trace", t_file) == 0
    assert len([n for n in parts if n]) >= 4
    cfg = tc.load_config(config_path)
    tr_api, tr_file = tc.read_trace(t_api), tc.read_trace(t_file)
    assert tc.verify(tr_api, ngc, cfg, tol_mm=0.02) == []
    ratio = tc.plot_time(tr_api) / tc.plot_time(tr_file)
    assert 0.98 <= ratio <= 1.02


def test_calls_are_not_drawn_one_by_one(config_path, tmp_path, monkeypatch):
    """One play for a whole stroke of linetos, whatever its length."""
    plays = []
    orig = FakeBackend.play
    monkeypatch.setattr(FakeBackend, "play", lambda self, r: plays.append(1) or orig(self, r))
    with api.Plotter(config_path, dry_run=True) as p:
        p.moveto(0, 0)
        for x, y in spiral(500):
            p.lineto(x, y)
        assert plays == []          # buffered: nothing played yet
        p.flush()
        played = len(plays)
        assert p.position == pytest.approx(spiral(500)[-1])
    assert played >= 1


def calibrated(config_path):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0


def _left_safe(trace, cfg) -> None:
    """As `draw` leaves the machine when stopped: the pen up and the coils released at the
    trace's end, and the stored position clean, where the trace ends."""
    tr = tc.read_trace(trace)
    assert tc.released_at_end(tr, cfg) == []
    dec = tc.decode(tr, cfg, (0.0, 0.0))
    assert not dec.pen_down[-1]
    pos = state.load()
    assert pos.clean and pos.pen == "up"
    assert np.allclose([pos.left_mm, pos.right_mm], [dec.left_mm[-1], dec.right_mm[-1]],
                       atol=1e-9)


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_mid_play_leaves_the_machine_as_draw_does(signum, config_path, tmp_path,
                                                           monkeypatch):
    calibrated(config_path)
    cfg = tc.load_config(config_path)
    interrupt_after(monkeypatch, 3000, signum)
    trace = tmp_path / "t.csv"
    with pytest.raises(api.Stopped) as stopped:
        with api.Plotter(config_path, backend="fake", trace=trace) as p:
            p.draw_path(spiral(2000))
    assert stopped.value.exit_code == 128 + signum
    assert isinstance(stopped.value, KeyboardInterrupt)
    assert "pen lifted, coils released, position saved" in str(stopped.value)
    _left_safe(trace, cfg)


def test_ctrl_c_between_two_calls_lifts_releases_and_stores(config_path, tmp_path):
    calibrated(config_path)
    cfg = tc.load_config(config_path)
    trace = tmp_path / "t.csv"
    with pytest.raises(KeyboardInterrupt):
        with api.Plotter(config_path, backend="fake", trace=trace) as p:
            p.moveto(10, 10)
            p.lineto(40, 10)
            p.lineto(40, 40)
            p.flush()               # drawn, the pen still down
            assert p.pen_is_down
            os.kill(os.getpid(), signal.SIGINT)     # the script's own code runs
            p.lineto(10, 40)        # pragma: no cover - never reached
    _left_safe(trace, cfg)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler    # given back


def test_a_second_plotter_process_gets_draws_refusal(config_path, tmp_path, capsys):
    calibrated(config_path)
    holder = hold_lock("vplotter draw car.ngc")
    try:
        assert run(config_path, "draw", REPO / "gcode_samples" / "circles.ngc",
                   "--backend", "fake") == 3
        cli_line = capsys.readouterr().err.strip()
        with pytest.raises(BusyError) as busy:
            with api.Plotter(config_path, backend="fake"):
                pass                # pragma: no cover - never entered
        assert str(busy.value) == cli_line
        assert cli_line.startswith(f"plotter busy: pid {holder.pid} (vplotter draw car.ngc)")
    finally:
        holder.stdin.close()
        holder.wait()


def test_draw_is_refused_while_a_script_holds_the_plotter(config_path, tmp_path):
    calibrated(config_path)
    env = dict(os.environ)
    with api.Plotter(config_path, backend="fake") as p:
        p.moveto(5, 5)
        p.flush()
        out = subprocess.run([sys.executable, "-m", "vplotter", "--config", str(config_path),
                              "draw", str(REPO / "gcode_samples" / "circles.ngc"),
                              "--backend", "fake"], capture_output=True, text=True, env=env)
    assert out.returncode == 3
    line = out.stderr.strip()
    assert line.startswith(f"plotter busy: pid {os.getpid()} (") and "(vplotter API)" in line


def test_a_point_off_the_page_names_the_scripts_line_before_that_part_moves(config_path,
                                                                            monkeypatch):
    played = []
    orig = FakeBackend.play
    monkeypatch.setattr(FakeBackend, "play", lambda self, r: played.append(1) or orig(self, r))
    with pytest.raises(InputError) as bad:
        with api.Plotter(config_path, dry_run=True) as p:
            p.moveto(0, 0)
            p.lineto(10, 0)
            line = sys._getframe().f_lineno + 1
            p.lineto(5000, 0)
    assert str(bad.value).startswith(f"{__file__}:{line}: error: point X5000.000 Y0.000 is "
                                     f"outside the page")
    assert played == []             # nothing of that part was played


def test_bad_values_and_options_are_one_line_errors(config_path):
    from vplotter.errors import ConfigError

    with api.Plotter(config_path, dry_run=True) as p:
        with pytest.raises(ConfigError, match="x and y must be finite"):
            p.lineto(float("nan"), 0)
        with pytest.raises(ConfigError, match="scale must be above 0"):
            p.estimate(REPO / "gcode_samples" / "circles.ngc", scale=-1)
        with pytest.raises(TypeError, match="dry_run is the Plotter's"):
            p.draw_file(REPO / "gcode_samples" / "circles.ngc", dry_run=True)
    with pytest.raises(Exception, match="not open"):
        p.lineto(0, 0)


def test_draw_file_and_estimate_are_draws_and_estimates(config_path, tmp_path, capsys):
    car = REPO / "gcode_samples" / "circles.ngc"
    assert run(config_path, "estimate", car, "--fit", "--order", "best") == 0
    said = capsys.readouterr().out.strip().splitlines()[-1]
    t_api, t_cli = tmp_path / "api.csv", tmp_path / "cli.csv"
    with api.Plotter(config_path, dry_run=True, trace=t_api) as p:
        est = p.estimate(car, fit=True, order="best")
        assert said.endswith(est.text)
        p.draw_file(car, fit=True, order="best")
        after = p.position
        p.lineto(after[0] + 5, after[1])
    assert run(config_path, "draw", car, "--dry-run", "--fit", "--order", "best",
               "--trace", t_cli) == 0
    cfg = tc.load_config(config_path)
    end = tc.decode(tc.read_trace(t_cli), cfg, (0.0, 0.0))
    assert after == pytest.approx((end.x[-1], end.y[-1]), abs=0.02)


def test_importing_vplotter_stays_light():
    code = ("import sys, vplotter; assert 'vplotter.api' not in sys.modules; "
            "assert 'numpy' not in sys.modules; print(vplotter.Plotter.__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "Plotter", out.stderr
    assert (REPO / "src" / "vplotter" / "py.typed").exists()


def test_a_bad_file_ends_the_plotter_and_frees_the_lock(config_path, tmp_path):
    from vplotter.machine import lock

    calibrated(config_path)
    with pytest.raises(InputError, match="no such file"):
        with api.Plotter(config_path, backend="fake") as p:
            p.moveto(5, 5)
            p.draw_file(tmp_path / "missing.svg", fit=True)
    assert lock.holder() is None and state.load().clean
    with api.Plotter(config_path, backend="fake") as p:     # the plotter is free again
        p.lineto(6, 5)


def test_a_pen_change_parks_waits_and_comes_back(config_path, tmp_path, capsys):
    assert run(config_path, "calibrate", "--at", "0", "30") == 0    # the change point
    trace = tmp_path / "t.csv"
    with api.Plotter(config_path, dry_run=True, trace=trace) as p:
        p.draw_path([(10, 10), (40, 10), (40, 40)])
        p.moveto(-20, -20)
        p.change_pen("red")
        p.lineto(-50, -20)
        p.lineto(-50, -50)
        p.change_pen("blue")
        p.flush()               # the part ends at the change point ...
        p.lineto(0, 0)          # ... and the pen goes back to (-50, -50) before it goes down
    said = capsys.readouterr().out
    assert "pause: put in the red pen" in said and "pause: put in the blue pen" in said
    ngc = ("G0 X10 Y10\nM3\nG1 X40 Y10\nG1 X40 Y40\nM5\nG0 X-20 Y-20\nM3\nG1 X-50 Y-20\n"
           "G1 X-50 Y-50\nM5\nM3\nG1 X0 Y0\nM5\n")
    cfg = tc.load_config(config_path)
    tr = tc.read_trace(trace)
    assert tc.verify(tr, ngc, cfg, start_xy=(0.0, 30.0), tol_mm=0.02) == []
    dec = tc.decode(tr, cfg, (0.0, 30.0))
    up = np.column_stack((dec.x, dec.y))[~np.asarray(dec.pen_down, bool)]
    k = int(np.argmax(np.hypot(up[:, 0] - 40, up[:, 1] - 40) < 0.02))   # after stroke 1
    assert np.hypot(up[k:, 0], up[k:, 1] - 30).min() < 0.02           # parked there
