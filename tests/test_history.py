"""The history of plots: every draw that moves the machine is kept (file, start, end, planned
and actual plot time, metres drawn, pens, how it ended) in an append-only file that survives
the process; a plot cut short by a crash or a power cut reads as such.

Real-time draws play through the real-time player on a simulated clock (support.fake_lgpio's
SimClock), which the history's clock reads too: no sleeping, no timing assertion on the
machine running the tests."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import pytest

from support import REPO
from support.cli import run
from support.fake_lgpio import SimClock
from support.signals import interrupt_after
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main
from vplotter.errors import BackendError
from vplotter.machine import history

DRAWING = """G21 G90
G00 Z5
G00 X-20 Y-10
G01 Z-1 F1200
G01 X20 Y-10
G02 X20 Y10 R10
G01 X-20 Y10
G03 X-20 Y-10 R10
G00 Z5
G00 X0 Y0
M2
"""


@pytest.fixture
def cfg(capsys):
    path = str(REPO / "config.toml")
    assert main(["--config", path, "calibrate", "--at", "0", "0"]) == 0
    capsys.readouterr()
    return path


@pytest.fixture
def drawing(tmp_path) -> str:
    f = tmp_path / "loop.ngc"
    f.write_text(DRAWING)
    return str(f)


def vp(capsys, cfg, *argv):
    return run(capsys, ["--config", cfg, *map(str, argv)])


@pytest.fixture
def sim_clock(monkeypatch):
    """The fake backend in real time on a simulated clock, and the history reading it."""
    clock = SimClock(tick_ns=1000, oversleep_ns=20_000)
    orig = FakeBackend.__init__

    def init(self, cfg, **kw):
        if kw.get("realtime"):
            kw.update(clock=clock.now, sleep=clock.sleep, spin_us=50)
        orig(self, cfg, **kw)

    monkeypatch.setattr(FakeBackend, "__init__", init)
    monkeypatch.setattr(history, "clock", lambda: clock.ns / 1e9)
    return clock


def test_a_real_time_draw_takes_what_was_planned_and_the_history_says_so(
        capsys, cfg, drawing, sim_clock):
    for _ in range(2):
        code, out, _ = vp(capsys, cfg, "draw", drawing, "--backend", "fake", "--realtime")
        assert code == 0
    said = float(out.splitlines()[-1].split("(")[-1].split(" s)")[0])
    plots = history.read()
    assert len(plots) == 2
    for p in plots:
        assert p["result"] == "done" and p["file"] == "loop.ngc" and p["error"] is None
        assert p["estimate_s"] == pytest.approx(said, abs=0.05)
        assert abs(p["actual_s"] - p["estimate_s"]) <= 0.02 * p["estimate_s"]
        assert p["end"] - p["start"] == pytest.approx(p["actual_s"], abs=1e-3)
        assert p["drawn_m"] == pytest.approx(0.08 + 0.02 * 3.14159265, abs=0.002)
        assert p["pens"] == [] and p["copy"] is None
    # a new process reads it as it was written (it is on disk, not in this process)
    env = dict(os.environ)
    got = subprocess.run([sys.executable, "-m", "vplotter", "--config", cfg, "history",
                          "--json"], capture_output=True, text=True, env=env, check=True)
    assert json.loads(got.stdout) == json.loads(json.dumps(plots))
    text = subprocess.run([sys.executable, "-m", "vplotter", "history"], capture_output=True,
                          text=True, env=env, check=True).stdout.splitlines()
    assert len(text) == 2 and all("loop.ngc: done; plot time " in t for t in text)
    assert all(" planned, took " in t and " m drawn" in t for t in text)


def test_a_stopped_draw_is_kept_with_the_part_drawn(capsys, cfg, drawing, monkeypatch):
    rows = []
    orig = FakeBackend.play
    monkeypatch.setattr(FakeBackend, "play", lambda self, r: rows.append(len(r)) or orig(self, r))
    assert main(["--config", cfg, "draw", drawing, "--dry-run"]) == 0
    monkeypatch.setattr(FakeBackend, "play", orig)
    interrupt_after(monkeypatch, sum(rows) // 2, signal.SIGINT)
    code = main(["--config", cfg, "draw", drawing, "--backend", "fake"])
    assert code == 128 + signal.SIGINT
    (p,) = history.read()
    assert p["result"] == "stopped" and p["error"] is None
    assert 0 < p["drawn_m"] < 0.08 + 0.02 * 3.14159265


def test_a_failed_draw_is_kept_with_its_error_line(capsys, cfg, drawing, monkeypatch):
    orig = FakeBackend.play
    played = []

    def play(self, rows):
        if played:
            raise BackendError("the GPIO chip went away")
        played.append(len(rows))
        return orig(self, rows)

    monkeypatch.setattr(FakeBackend, "play", play)
    code, _, err = vp(capsys, cfg, "draw", drawing, "--backend", "fake")
    assert code == 1
    (p,) = history.read()
    assert p["result"] == "failed" and p["error"] == err.splitlines()[-1]
    assert "the GPIO chip went away" in p["error"]


def test_a_dry_run_and_a_file_that_does_not_validate_are_no_plots(capsys, cfg, drawing, tmp_path):
    assert vp(capsys, cfg, "draw", drawing, "--dry-run")[0] == 0
    bad = tmp_path / "off.ngc"
    bad.write_text("G21 G90\nG01 X900 Y0 F600\nM2\n")
    assert vp(capsys, cfg, "draw", bad, "--backend", "fake")[0] == 2
    assert history.read() == [] and vp(capsys, cfg, "history")[1].startswith("no plots yet")


CRASH = """
import os, sys
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main
orig, n = FakeBackend.play, [0]
def play(self, rows):
    n[0] += 1
    if n[0] == 3:
        os._exit(9)          # the power goes: nothing more is written
    return orig(self, rows)
FakeBackend.play = play
main(["--config", sys.argv[1], "draw", sys.argv[2], "--backend", "fake"])
"""


def test_a_power_cut_mid_plot_shows_as_such(capsys, cfg, drawing):
    proc = subprocess.run([sys.executable, "-c", CRASH, cfg, drawing], capture_output=True,
                          text=True, env=dict(os.environ))
    assert proc.returncode == 9
    with open(history.history_path(), "ab") as f:
        f.write(b'{"event": "ended", "id": "torn')          # the last line, half written
    (p,) = history.read()
    assert p["result"] == "interrupted (power cut or crash)" and p["end"] is None
    assert p["file"] == "loop.ngc" and p["actual_s"] is None
    code, out, _ = vp(capsys, cfg, "history")
    assert code == 0 and "loop.ngc: interrupted (power cut or crash); plot time" in out
    # the next draw is kept after it, and the torn line stays harmless
    assert vp(capsys, cfg, "draw", drawing, "--backend", "fake", "--trust-position")[0] == 0
    assert [p["result"] for p in history.read()] == ["interrupted (power cut or crash)", "done"]


def test_a_running_plot_reads_as_running_while_its_process_drives_the_plotter(tmp_path):
    p = history.Plot(str(tmp_path / "x.ngc"))
    p.started(10.0, 100.0, ["red", "blue"])
    (got,) = history.read(running_pid=os.getpid())
    assert got["result"] == "running" and got["pens"] == ["red", "blue"]
    (got,) = history.read(running_pid=-1)
    assert got["result"] == history.INTERRUPTED
