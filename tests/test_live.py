"""Long plots over SSH: a running draw as other commands see it (busy, status), `draw --detach`
surviving the end of its terminal, `stop` and `--resume`, `log`, and what live.json says.

The real-time tests run gpiozero's MockFactory in subprocesses (a few seconds of wall-clock
time each, like the signal tests of test_safety.py); they wait on processes, never on sleeps.
"""

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest

from support import tracecheck as tc
from vplotter.machine import live, lock, state
from vplotter.cli import main

from support import REPO
from support.signals import SHORT  # the same short drawing as test_safety.py's

MEDIUM = """G21 G90
G01 Z-1 F600
G01 X4 Y0
G01 X4 Y3
G00 Z5
G00 X0 Y0
M2
"""
TINY = """G21 G90
G01 Z-1 F600
G01 X1.5 Y0
G01 X1.5 Y1.5
G00 Z5
M2
"""


def run(config_path, *argv):
    return main(["--config", str(config_path), *argv])


def vplotter(config_path, *argv, **kw):
    env = dict(os.environ, GPIOZERO_PIN_FACTORY="mock")
    return subprocess.Popen([sys.executable, "-m", "vplotter", "--config", str(config_path), *argv],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            **kw)


def status_json(config_path, capsys) -> tuple[dict, str]:
    capsys.readouterr()
    assert run(config_path, "status", "--json") == 0
    out = capsys.readouterr().out
    return json.loads(out), out


def drawn(trace, cfg, start=(0.0, 0.0)):
    dec = tc.decode(tc.read_trace(trace), cfg, start)
    return dec, np.column_stack((dec.x, dec.y))[dec.pen_down]


def test_a_running_draw_is_busy_for_movers_and_drawing_for_status(config_path, tmp_path, capsys):
    cfg = tc.load_config(config_path)
    gfile = tmp_path / "medium.ngc"
    gfile.write_text(MEDIUM)
    t1 = tmp_path / "t1.csv"
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    proc = vplotter(config_path, "draw", str(gfile), "--backend", "gpiozero", "--trace", str(t1))
    assert "plot time" in proc.stdout.readline()      # validated: drawing starts now
    capsys.readouterr()
    for argv in (["draw", str(gfile)], ["jog", "--dx", "1"], ["pen", "up"],
                 ["calibrate", "--at", "0", "0"], ["goto", "1", "1"], ["home"]):
        assert run(config_path, *argv, "--backend", "fake") == 3
        err = capsys.readouterr().err
        assert err.startswith(f"plotter busy: pid {proc.pid} (vplotter ") and "unclean" not in err
        assert "% done" in err and "left" in err
    info, out = status_json(config_path, capsys)
    assert "unclean" not in out and info["last_stop"] == "running"
    d = info["drawing"]
    assert d["pid"] == proc.pid and d["file"] == str(gfile)
    assert set(d) >= {"pid", "command", "file", "line", "percent", "elapsed_s", "remaining_s",
                      "finish"}
    assert 0 <= d["percent"] < 100 and 0 < d["remaining_s"] <= 5.0 and d["line"] >= 0
    assert run(config_path, "status") == 0
    text = capsys.readouterr().out
    assert "drawing now: pid" in text and "UNCLEAN" not in text and "left, finish at" in text
    assert proc.wait(timeout=300) == 0
    # nothing was disturbed: the drawing is on the path and the stored position is its end
    dec, pts = drawn(t1, cfg)
    assert tc.distances_to_polylines(pts, tc.reference_path(gfile)).max() <= 0.02
    pos = state.load()
    assert (pos.left_mm, pos.right_mm) == pytest.approx((dec.left_mm[-1], dec.right_mm[-1]), abs=1e-9)
    info, out = status_json(config_path, capsys)
    assert info["last_stop"] == "clean" and info["drawing"] is None and info["busy"] is None


def test_detach_survives_the_end_of_its_terminal_and_completes(config_path, tmp_path, capsys):
    cfg = tc.load_config(config_path)
    gfile = tmp_path / "tiny.ngc"
    gfile.write_text(TINY)
    dry, real = tmp_path / "dry.csv", tmp_path / "real.csv"
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    assert run(config_path, "draw", str(gfile), "--dry-run", "--trace", str(dry)) == 0
    # the "terminal": a shell leading its own session, which starts the draw and stays
    shell = subprocess.Popen(
        ["sh", "-c", f'"{sys.executable}" -m vplotter --config "{config_path}" draw "{gfile}" '
                     f'--backend gpiozero --detach --trace "{real}"; exec sleep 60'],
        env=dict(os.environ, GPIOZERO_PIN_FACTORY="mock"), stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True)
    assert "plot time" in shell.stdout.readline()
    line = shell.stdout.readline()
    assert line.startswith("drawing in the background: pid ")
    pid = int(line.split("pid ")[1].split(";")[0])
    assert "status --watch" in shell.stdout.readline()
    os.killpg(shell.pid, signal.SIGHUP)          # the SSH session ends
    assert shell.wait(timeout=10) == -signal.SIGHUP
    watch = vplotter(config_path, "status", "--watch")
    watch.wait(timeout=300)                       # ends when the draw ends
    assert not lock.alive(pid)
    out = watch.stdout.read()
    assert "last stop: clean" in out
    assert "finished at" in (state.state_dir() / "draw.log").read_text()
    capsys.readouterr()
    assert run(config_path, "log") == 0
    assert "finished at" in capsys.readouterr().out
    dec_dry, pts_dry = drawn(dry, cfg)
    dec, pts = drawn(real, cfg)
    assert tc.illegal_transitions(dec) == []
    assert tc.distances_to_polylines(pts, tc.drawn_polylines(dec_dry)).max() <= 0.02
    assert tc.distances_to_polylines(pts_dry, tc.drawn_polylines(dec)).max() <= 0.02
    pos = state.load()
    assert pos.clean and pos.pen == "up"


def test_stop_pauses_a_detached_draw_and_resume_completes_it(config_path, tmp_path, capsys):
    cfg = tc.load_config(config_path)
    gfile = tmp_path / "short.ngc"
    gfile.write_text(SHORT)
    t1, t2 = tmp_path / "t1.csv", tmp_path / "t2.csv"
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    start = vplotter(config_path, "draw", str(gfile), "--backend", "gpiozero", "--detach",
                     "--trace", str(t1))
    assert start.wait(timeout=60) == 0
    follow = vplotter(config_path, "log", "-f")
    assert "plot time" in follow.stdout.readline()    # the background draw has validated
    with pytest.raises(subprocess.TimeoutExpired):
        follow.wait(timeout=2.5)                      # let it draw for a while
    capsys.readouterr()
    assert run(config_path, "stop") == 0
    out = capsys.readouterr().out
    assert "stopped pid" in out and "pen up" in out and "--resume" in out
    assert follow.wait(timeout=10) == 0               # log -f ends with the draw
    assert "--resume" in follow.stdout.read()
    pos = state.load()
    assert pos.clean and pos.pen == "up" and pos.extra["resume"]["line"] > 0
    dec1, end = (d := tc.decode(tc.read_trace(t1), cfg)), (d.left_mm[-1], d.right_mm[-1])
    assert (pos.left_mm, pos.right_mm) == pytest.approx(end, abs=1e-9)
    assert tc.released_at_end(tc.read_trace(t1), cfg) == []
    info, _ = status_json(config_path, capsys)
    assert run(config_path, "draw", str(gfile), "--backend", "fake", "--resume", "--trace",
               str(t2)) == 0
    dec2 = tc.decode(tc.read_trace(t2), cfg, (info["x_mm"], info["y_mm"]))
    ref = tc.reference_path(gfile)
    pts = np.vstack([np.column_stack((d.x, d.y))[d.pen_down] for d in (dec1, dec2)])
    assert tc.distances_to_polylines(pts, ref).max() <= 0.02
    from scipy.spatial import cKDTree

    assert max(cKDTree(pts).query(r)[0].max() for r in ref) <= 0.02
    capsys.readouterr()
    assert run(config_path, "stop") == 0
    assert "nothing to stop" in capsys.readouterr().out


def test_detach_reports_bad_input_in_the_terminal(config_path, tmp_path, capsys):
    bad = tmp_path / "bad.ngc"
    bad.write_text("G01 X1 Y1\nG01 X1 Q5\n")
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    capsys.readouterr()
    assert run(config_path, "draw", str(bad), "--backend", "fake", "--detach") == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:2:") and lock.holder() is None
    assert not live.log_path().exists()
    assert run(config_path, "draw", str(bad), "--dry-run", "--detach") == 2


def test_dry_run_after_an_unclean_stop_says_how_uncertain(config_path, capsys):
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    pos = state.load()
    pos.clean = False
    state.save(pos)
    j = state.Journal()
    j.record(pos.counts, (30, 40), 3, "up")
    j.close()
    capsys.readouterr()
    assert run(config_path, "draw", str(REPO / "gcode_samples" / "square.ngc"), "--dry-run") == 0
    err = capsys.readouterr().err
    from vplotter import config
    from vplotter.machine import job

    mm = job.uncertainty_mm(config.load(config_path),
                            state.recovered(state.load()).rebased(pos.steps_per_unit))
    assert 0.2 < mm < 1 and "not clean" in err and f"uncertain by up to {mm:.2f} mm" in err
    assert run(config_path, "draw", str(REPO / "gcode_samples" / "square.ngc"),
               "--backend", "fake") == 2


# ---------------------------------------------------------------- live.json and the lock file
def test_live_file_says_what_runs_and_a_dead_writer_means_nothing(monkeypatch):
    now = {"t": 1000.0}
    pub = live.Publisher("vplotter draw a.ngc", "/x/a.ngc", 100.0, clock=lambda: now["t"])
    pub.update(0.0, 0, force=True)
    now["t"] = 1010.0
    pub.update(25.0, 12)
    me = {"pid": os.getpid(), "command": "vplotter draw a.ngc", "since": 1000.0}
    d = live.read(me, now=1010.0)
    assert d["line"] == 12 and d["percent"] == 25.0 and d["remaining_s"] == 75.0
    assert d["elapsed_s"] == 10.0 and d["pid"] == os.getpid()
    now["t"] = 1010.1
    pub.update(30.0, 13)                       # too soon after the last write: not written
    assert live.read(me, now=1010.1)["line"] == 12
    pub.update(30.0, 13, force=True)
    assert live.read(me, now=1010.1)["line"] == 13
    assert live.read({"pid": 1}) is None       # written by someone who is not the holder
    assert "line 13, 30.0 % done" in live.describe(live.read(me, now=1010.1))
    pub.close()
    assert live.read(me) is None and not live.live_path().exists()


def test_holder_reads_the_lock_file_without_locking(tmp_path):
    assert lock.holder() is None
    held = lock.acquire("vplotter draw x")
    try:
        h = lock.holder()
        assert h["pid"] == os.getpid() and h["command"] == "vplotter draw x"
        assert lock.acquire("vplotter jog") is held and held.count == 2   # shared in-process
        held.release()
        assert lock.holder() is not None
    finally:
        lock.release_all()
    assert lock.holder() is None                  # released: the file names nobody
    lock.lock_path().write_text(json.dumps({"pid": 999_999_9, "command": "x", "since": 0}))
    assert lock.holder() is None                  # a crashed holder is no holder
