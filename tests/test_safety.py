"""Operating safely: signals mid-draw, resume, crash journal, one process per plotter, bad state.

Signals are raised from inside the fake backend after a chosen number of rows, so the tests
are deterministic and never sleep.
"""

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from support import tracecheck as tc
from vplotter.machine import lock, state
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main

from support import REPO
from support.signals import SHORT, hold_lock, interrupt_after

CIRCLES = REPO / "gcode_samples" / "circles.ngc"


def run(config_path, *argv):
    return main(["--config", str(config_path), *argv])


def cords_at_end(trace_path, cfg, start_xy):
    dec = tc.decode(tc.read_trace(trace_path), cfg, start_xy)
    return dec, np.array([dec.left_mm[-1], dec.right_mm[-1]])


@pytest.mark.parametrize("signum,rows", [(signal.SIGINT, 40_000), (signal.SIGTERM, 7_000),
                                         (signal.SIGHUP, 90_000)])
def test_signal_stops_lifts_saves_and_resume_completes(signum, rows, config_path, tmp_path,
                                                       monkeypatch, capsys):
    cfg = tc.load_config(config_path)
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    orig = interrupt_after(monkeypatch, rows, signum)
    t1, t2 = tmp_path / "t1.csv", tmp_path / "t2.csv"
    code = run(config_path, "draw", str(CIRCLES), "--backend", "fake", "--trace", str(t1))
    assert code == 128 + signum
    err = capsys.readouterr().err
    assert "--resume" in err and "Traceback" not in err
    tr1 = tc.read_trace(t1)
    assert tc.released_at_end(tr1, cfg) == []
    dec1, end1 = cords_at_end(t1, cfg, (0.0, 0.0))
    pos = state.load()
    assert pos.clean and pos.pen == "up"
    # the saved position is the position the trace reached, to the step
    assert np.allclose([pos.left_mm, pos.right_mm], end1, atol=1e-9)
    assert pos.extra["resume"]["line"] > 0

    monkeypatch.setattr(FakeBackend, "play", orig)
    status = run(config_path, "status", "--json")
    assert status == 0
    info = json.loads(capsys.readouterr().out)
    assert info["last_stop"] == "clean" and info["resume"]["line"] == pos.extra["resume"]["line"]
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake", "--resume", "--trace", str(t2)) == 0
    start2 = (info["x_mm"], info["y_mm"])
    dec2 = tc.decode(tc.read_trace(t2), cfg, start2)
    ref = tc.reference_path(CIRCLES)
    # each part draws only on the path (no pen-down jump) ...
    for dec in (dec1, dec2):
        assert tc.steps_while_settling(dec, cfg["pen"]["settle_s"]) == []
        pts = np.column_stack((dec.x, dec.y))[dec.pen_down]
        if len(pts):
            assert tc.distances_to_polylines(pts, ref).max() <= 0.02
    # ... and the two together cover the whole path
    drawn = np.vstack([np.column_stack((d.x, d.y))[d.pen_down] for d in (dec1, dec2)])
    from scipy.spatial import cKDTree

    gap = max(cKDTree(drawn).query(r)[0].max() for r in ref)
    assert gap <= 0.02
    assert "resume" not in state.load().extra


def test_moving_the_pen_keeps_the_place_to_resume(config_path, monkeypatch):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    orig = interrupt_after(monkeypatch, 20_000, signal.SIGINT)
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake") == 130
    monkeypatch.setattr(FakeBackend, "play", orig)
    resume = state.load().extra["resume"]
    assert run(config_path, "pen", "up", "--backend", "fake") == 0        # change the pen
    assert run(config_path, "jog", "--dx", "5", "--backend", "fake") == 0
    assert state.load().extra["resume"] == resume
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake", "--resume") == 0
    assert "resume" not in state.load().extra


def test_resume_refuses_a_changed_file(config_path, tmp_path, monkeypatch, capsys):
    gfile = tmp_path / "c.ngc"
    gfile.write_text(CIRCLES.read_text())
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    orig = interrupt_after(monkeypatch, 5000, signal.SIGINT)
    assert run(config_path, "draw", str(gfile), "--backend", "fake") == 130
    monkeypatch.setattr(FakeBackend, "play", orig)
    gfile.write_text(CIRCLES.read_text() + "G00 X0 Y0\n")
    capsys.readouterr()
    assert run(config_path, "draw", str(gfile), "--backend", "fake", "--resume") == 2
    assert "changed" in capsys.readouterr().err
    assert run(config_path, "draw", str(gfile), "--backend", "fake", "--resume", "--force") == 0


def test_resume_dry_run_shows_what_is_left(config_path, monkeypatch, capsys):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    orig = interrupt_after(monkeypatch, 30_000, signal.SIGINT)
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake") == 130
    monkeypatch.setattr(FakeBackend, "play", orig)
    before = state.load()
    capsys.readouterr()
    assert run(config_path, "draw", str(CIRCLES), "--dry-run", "--resume") == 0
    out = capsys.readouterr().out
    full = float(out.split("(")[-1].split(" s)")[0])
    assert 0 < full < 111
    assert state.load() == before          # a dry run stores nothing


def test_from_line_starts_there(config_path, tmp_path):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    t = tmp_path / "t.csv"
    assert run(config_path, "draw", str(CIRCLES), "--dry-run", "--from-line", "30") == 2
    assert run(config_path, "draw", str(CIRCLES), "--dry-run", "--from-line", "21", "--trace", str(t)) == 0
    cfg = tc.load_config(config_path)
    dec = tc.decode(tc.read_trace(t), cfg)
    ref = tc.reference_path(CIRCLES)
    pts = np.column_stack((dec.x, dec.y))[dec.pen_down]
    assert len(pts) and tc.distances_to_polylines(pts, ref).max() <= 0.02


CRASH = r"""
import os, sys
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main
n = {"rows": 0}
orig = FakeBackend.play
def play(self, rows):
    n["rows"] += len(rows)
    if n["rows"] > LIMIT:
        os._exit(137)          # like kill -9 or a power cut: no cleanup at all
    return orig(self, rows)
FakeBackend.play = play
sys.exit(main(sys.argv[1:]))
"""


def test_crash_leaves_an_unclean_stop_with_a_bound_that_holds(config_path, tmp_path, capsys):
    cfg = tc.load_config(config_path)
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    capsys.readouterr()
    t = tmp_path / "t.csv"
    env = dict(os.environ)
    proc = subprocess.run([sys.executable, "-c", CRASH.replace("LIMIT", "20000"), "--config",
                           str(config_path), "draw", str(CIRCLES), "--backend", "fake", "--trace", str(t)],
                          env=env, capture_output=True, text=True)
    assert proc.returncode == 137
    assert run(config_path, "status", "--json") == 0
    info = json.loads(capsys.readouterr().out)
    assert info["last_stop"] == "unclean" and 0 < info["uncertainty_mm"] < 5
    # the motors got at least as far as the trace shows (it is flushed as rows are played)
    dec, end = cords_at_end(t, cfg, (0.0, 0.0))
    pos = state.recovered(state.load())
    dev = np.array(pos.extra["uncertain_steps"]) / tc.steps_per_mm(cfg)
    assert (np.abs(end - [pos.left_mm, pos.right_mm]) <= dev + 1e-9).all()
    # a draw now asks for calibration or --trust-position
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake") == 2
    err = capsys.readouterr().err
    assert "calibrate" in err and "--trust-position" in err
    assert info["resume"]["line"] > 0 and info["resume"]["xy"] is None
    t2 = tmp_path / "t2.csv"
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake", "--trust-position",
               "--resume", "--trace", str(t2)) == 0
    saved = json.loads((state.state_dir() / "state.json").read_text())
    assert saved["clean"] is True and "resume" not in saved["extra"]
    # what the resumed draw puts on paper is on the path
    dec2 = tc.decode(tc.read_trace(t2), cfg, (info["x_mm"], info["y_mm"]))
    pts = np.column_stack((dec2.x, dec2.y))[dec2.pen_down]
    assert tc.distances_to_polylines(pts, tc.reference_path(CIRCLES)).max() <= 0.02


def test_second_process_is_refused_with_exit_3(config_path, capsys):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    holder = hold_lock("vplotter draw car.ngc")
    try:
        before = (state.state_dir() / "state.json").read_text()
        assert run(config_path, "draw", str(CIRCLES), "--backend", "fake") == 3
        err = capsys.readouterr().err.strip()
        assert err.startswith(f"plotter busy: pid {holder.pid} (vplotter draw car.ngc) since ")
        assert (state.state_dir() / "state.json").read_text() == before
        for argv in (["pen", "up"], ["jog", "--dx", "1"], ["goto", "1", "1"], ["home"],
                     ["calibrate", "--at", "1", "1"], ["calibrate", "steps", "--motor", "left"]):
            assert run(config_path, *argv, "--backend", "fake") == 3
            assert "plotter busy" in capsys.readouterr().err
        assert (state.state_dir() / "state.json").read_text() == before
    finally:
        holder.stdin.close()
        holder.wait()
    assert run(config_path, "pen", "up", "--backend", "fake") == 0


def test_stale_lock_is_taken_over(config_path):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    (state.state_dir() / "lock").write_text('{"pid": 999999, "command": "vplotter draw x", "since": 0}')
    assert run(config_path, "goto", "5", "5", "--backend", "fake") == 0


@pytest.mark.parametrize("content", ["", '{"version": 1, "left_mm": 4', "garbage \x00\x01",
                                     '{"version": 1}', '{"version": 1, "left_mm": -1, "right_mm": 3, '
                                     '"left_steps": 0, "right_steps": 0, "steps_per_mm": 1}'])
def test_corrupt_state_gives_one_clear_line(content, config_path, capsys):
    state.state_dir().mkdir(parents=True, exist_ok=True)
    (state.state_dir() / "state.json").write_text(content)
    for argv in (["status"], ["draw", str(CIRCLES), "--backend", "fake"], ["goto", "1", "1", "--backend", "fake"]):
        assert run(config_path, *argv) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and "calibrate" in err and "Traceback" not in err
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    assert run(config_path, "status") == 0


def calibrate_steps(tmp_path, config_path, monkeypatch, motor, *answers):
    """Run `calibrate steps` on a copy of config.toml with scripted answers."""
    cfg_file = tmp_path / "config.toml"
    cfg_file.write_text(config_path.read_text())
    assert run(cfg_file, "calibrate", "--at", "0", "0") == 0
    replies = iter(answers)

    def ask(prompt=""):
        for reply in replies:
            return reply
        raise EOFError          # the person pressed Ctrl+D

    monkeypatch.setattr("builtins.input", ask)
    return cfg_file, run(cfg_file, "calibrate", "steps", "--motor", motor, "--backend", "fake")


def test_calibrate_steps_writes_the_circumference_keeping_comments(tmp_path, config_path,
                                                                   monkeypatch):
    cfg_file, code = calibrate_steps(tmp_path, config_path, monkeypatch, "left", "480.0", "492.5")
    assert code == 0
    text = cfg_file.read_text()
    assert "spool_circumference_mm = 25.6    # cord wound per revolution" in text
    assert text.replace("25.6 ", "25.0 ") == config_path.read_text()
    pos = state.load()
    assert pos.left_mm == pytest.approx(492.5) and pos.steps_per_unit == pytest.approx((4096 / 25.6, 4096 / 25.6))


@pytest.mark.parametrize("answers", [("480", "abc"), ("480", "700"), ("480",), ("-3", "4")])
def test_calibrate_steps_rejects_nonsense(answers, tmp_path, config_path, monkeypatch, capsys):
    cfg_file, code = calibrate_steps(tmp_path, config_path, monkeypatch, "right", *answers)
    assert code == 2
    assert cfg_file.read_text() == config_path.read_text()
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_jog_and_goto_refuse_leaving_the_page(config_path, capsys):
    assert run(config_path, "calibrate", "--at", "190", "0") == 0
    assert run(config_path, "jog", "--dx", "20", "--backend", "fake") == 2
    assert "outside the page" in capsys.readouterr().err
    assert run(config_path, "jog", "--dx", "-20", "--dy", "5", "--backend", "fake") == 0
    capsys.readouterr()
    out = run(config_path, "status", "--json")
    info = json.loads(capsys.readouterr().out)
    assert info["x_mm"] == pytest.approx(170, abs=0.01) and info["y_mm"] == pytest.approx(5, abs=0.01)
    assert run(config_path, "home", "--backend", "fake") == 0
    capsys.readouterr()
    assert run(config_path, "status", "--json") == 0
    info = json.loads(capsys.readouterr().out)
    assert info["x_mm"] == pytest.approx(190, abs=0.01) and out == 0


def test_jog_by_cord_lengths(config_path, capsys):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    before = state.load()
    assert run(config_path, "jog", "--left", "3", "--right", "-3", "--backend", "fake") == 0
    after = state.load()
    assert after.left_mm - before.left_mm == pytest.approx(3, abs=0.01)
    assert after.right_mm - before.right_mm == pytest.approx(-3, abs=0.01)


def test_pen_cycle_with_override(config_path, tmp_path):
    t = tmp_path / "t.csv"
    assert run(config_path, "pen", "cycle", "--down-us", "1700", "--dry-run", "--trace", str(t)) == 0
    tr = tc.read_trace(t)
    assert 1700 in tr.value[tr.pin == 24].tolist() and tr.value[-1] == 0


def test_interactive_jog_in_a_terminal(config_path, tmp_path):
    """Arrow keys, step size, pen and quit, typed into a pseudo-terminal like over SSH."""
    import pty
    import select

    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    pid, fd = pty.fork()
    if pid == 0:   # child: the real command line
        os.execvpe(sys.executable, [sys.executable, "-m", "vplotter", "--config", str(config_path),
                                    "jog", "--backend", "fake", "--step", "2"], os.environ)
    out = b""

    def wait_for(text: bytes) -> None:
        nonlocal out
        while text not in out:
            ready, _, _ = select.select([fd], [], [], 10)
            assert ready, out.decode(errors="replace")
            out += os.read(fd, 4096)

    wait_for(b"step   2.0 mm")
    for key, seen in ((b"\x1b[C", b"X    2.00"), (b"+", b"step   4.0"), (b"\x1b[A", b"Y    4.00"),
                      (b"d", b"pen down"), (b"u", b"pen up"), (b"\x1b[D", b"X   -2.00")):
        os.write(fd, key)
        wait_for(seen)
    os.write(fd, b"q")
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    from vplotter import config
    from vplotter.commands import jog

    pos = state.load()
    xy = jog.pen_xy(config.load(config_path), pos, pos.counts)
    assert xy == pytest.approx([-2.0, 4.0], abs=0.01)




@pytest.mark.parametrize("signum,after_s", [(signal.SIGINT, 1.3), (signal.SIGTERM, 2.1)])
def test_real_time_draw_on_mock_pins_stops_within_a_second(signum, after_s, config_path, tmp_path,
                                                             capsys):
    """The acceptance check of the safety issue, in real time: gpiozero on its MockFactory in a
    subprocess, a signal mid-stroke, then --resume. (Waits about 3 s of wall-clock time.)"""
    import time

    cfg = tc.load_config(config_path)
    gfile = tmp_path / "short.ngc"
    gfile.write_text(SHORT)
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    t1, t2 = tmp_path / "t1.csv", tmp_path / "t2.csv"
    env = dict(os.environ, GPIOZERO_PIN_FACTORY="mock")
    proc = subprocess.Popen([sys.executable, "-m", "vplotter", "--config", str(config_path), "draw",
                             str(gfile), "--backend", "gpiozero", "--trace", str(t1)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.readline()                    # the summary: validation done, drawing starts
    with pytest.raises(subprocess.TimeoutExpired):
        proc.wait(timeout=after_s)
    sent = time.monotonic()
    proc.send_signal(signum)
    proc.wait(timeout=5)
    assert time.monotonic() - sent < 1.0
    assert proc.returncode == 128 + signum
    assert "--resume" in proc.stderr.read()
    tr = tc.read_trace(t1)
    assert tc.released_at_end(tr, cfg) == []
    dec1, end = cords_at_end(t1, cfg, (0.0, 0.0))
    pos = state.load()
    assert np.allclose([pos.left_mm, pos.right_mm], end, atol=1e-9)
    capsys.readouterr()
    assert run(config_path, "status", "--json") == 0
    info = json.loads(capsys.readouterr().out)
    assert run(config_path, "draw", str(gfile), "--backend", "fake", "--resume", "--trace", str(t2)) == 0
    dec2 = tc.decode(tc.read_trace(t2), cfg, (info["x_mm"], info["y_mm"]))
    ref = tc.reference_path(gfile)
    drawn = np.vstack([np.column_stack((d.x, d.y))[d.pen_down] for d in (dec1, dec2)])
    assert tc.distances_to_polylines(drawn, ref).max() <= 0.02
    from scipy.spatial import cKDTree

    assert max(cKDTree(drawn).query(r)[0].max() for r in ref) <= 0.02


def test_hangup_with_the_terminal_gone_still_stops_and_saves(config_path, monkeypatch, capsys):
    """After SIGHUP writing to the SSH terminal fails; the stop must still be clean."""
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    interrupt_after(monkeypatch, 9000, signal.SIGHUP)

    class Gone:
        def write(self, text):
            raise OSError(5, "Input/output error")

        def flush(self):
            raise OSError(5, "Input/output error")

    import vplotter.commands.draw as cli

    real = cli.eprint
    monkeypatch.setattr(cli, "eprint", lambda msg: cli.say(msg, Gone()))
    assert run(config_path, "draw", str(CIRCLES), "--backend", "fake") == 128 + signal.SIGHUP
    monkeypatch.setattr(cli, "eprint", real)
    pos = state.load()
    assert pos.clean and pos.pen == "up" and pos.extra["resume"]["line"] > 0
