"""A newcomer's first hour (issue 36): the first-run checklists of README.md and
docs/getting-started.md, walked as written on the fake backend; the pen and the cords move
before any calibration, and the position stays unknown until `calibrate --at`.

No --dry-run here: the fake backend with the lock, the journal and the stored position.
"""

import json
import os
import re
import shlex
import subprocess
import sys

import numpy as np
import pytest

from support import REPO
from support import tracecheck as tc
from support.signals import hold_lock, interrupt_after
from vplotter.machine import lock, state
from vplotter.cli import main

UNKNOWN = ("error: the pen position is unknown: bring the pen to a known point "
           "(`vplotter jog --left MM` / `--right MM` move the cords) and run "
           "`vplotter calibrate --at X Y` first")


def run(config_path, *argv):
    return main(["--config", str(config_path), *argv])


def stored() -> dict | None:
    p = state.state_dir() / "state.json"
    return json.loads(p.read_text()) if p.exists() else None


def nothing_stored() -> bool:
    return stored() is None and not state.journal_path().exists()


# ------------------------------------------------------------------ the checklists as written
def checklist(doc: str) -> list[str]:
    """The vplotter commands of the numbered list under "First run on a real Pi", in the
    order written (an inline code span that starts with `vplotter `; the others, `groups`,
    `pip install`, `--up-us`, are not steps vplotter runs)."""
    text = (REPO / doc).read_text(encoding="utf-8")
    section = text.split("## First run on a real Pi", 1)[1].split("\n## ", 1)[0]
    items = re.findall(r"^\d+\. (.*?)(?=^\d+\. |^\s*$)", section + "\n\n", re.M | re.S)
    spans = [s for item in items for s in re.findall(r"`([^`]+)`", " ".join(item.split()))]
    return [s for s in spans if s.startswith("vplotter ")]


@pytest.fixture
def workshop(tmp_path, config_path, monkeypatch):
    """A fresh Pi: config.toml (the seed machine on the fake backend) and the samples in the
    working directory, nothing stored; `calibrate steps` gets measured cords typed in."""
    text = config_path.read_text(encoding="utf-8")
    text, n = re.subn(r'(?m)^backend = "lgpio"', 'backend = "fake"', text)
    assert n == 1
    (tmp_path / "config.toml").write_text(text, encoding="utf-8")
    (tmp_path / "gcode_samples").symlink_to(REPO / "gcode_samples")
    monkeypatch.chdir(tmp_path)
    # a tape measure that agrees with config.toml: 2000 steps are 2000 / 163.84 mm of cord
    answers = iter(["480", f"{480 + 2000 / 163.84:.3f}"] * 2)
    monkeypatch.setattr("builtins.input", lambda prompt="": next(answers))
    return tmp_path


@pytest.mark.parametrize("doc", ["README.md", "docs/getting-started.md"])
def test_the_checklist_runs_as_written(doc, workshop, capsys):
    steps = checklist(doc)
    assert any(s.startswith("vplotter calibrate --at") for s in steps), steps
    assert any(s.startswith("vplotter draw") for s in steps), steps
    assert nothing_stored()
    for step in steps:
        code = main(shlex.split(step)[1:])
        err = capsys.readouterr().err
        assert code == 0, f"{doc}: `{step}` exited {code}: {err}"
        if stored() is None:        # before `calibrate --at` nothing invents a position
            assert not state.journal_path().exists()
    assert stored()["clean"] is True and stored()["pen"] == "up"


# ------------------------------------------------------------------ the pen needs no position
@pytest.mark.parametrize("action", ["up", "down", "cycle"])
def test_pen_moves_without_a_position_and_makes_none(action, config_path, tmp_path):
    t = tmp_path / "t.csv"
    assert run(config_path, "pen", action, "--backend", "fake", "--trace", str(t)) == 0
    assert nothing_stored()
    tr = tc.read_trace(t)
    pen = tr.value[tr.pin == 24].tolist()
    cfg = tc.load_config(config_path)
    want = {"up": [cfg["pen"]["up_us"]], "down": [cfg["pen"]["down_us"]],
            "cycle": [cfg["pen"]["down_us"], cfg["pen"]["up_us"]]}[action]
    assert [v for v in pen if v] == want and pen[-1] == 0


def test_pen_keeps_a_stored_position_but_its_pen_state(config_path):
    assert run(config_path, "calibrate", "--at", "10", "20") == 0
    assert run(config_path, "jog", "--dx", "5", "--backend", "fake") == 0
    before = stored()
    assert run(config_path, "pen", "down", "--backend", "fake") == 0
    assert stored() == {**before, "pen": "down"}
    assert run(config_path, "pen", "up", "--backend", "fake") == 0
    assert stored() == before


def test_pen_after_a_crash_leaves_the_unclean_stop_as_it_is(config_path, capsys):
    """A power cut left an unclean stop: the pen still moves (no --trust-position needed for
    the pen), and the position stays unclean, with its journal, for calibrate to settle."""
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    pos = state.load()
    pos.clean = False
    state.save(pos)
    j = state.Journal()
    j.record((40, -30), (3, 2), 7, "down")
    j.close()
    journal = state.journal_path().read_text()
    before = stored()
    assert run(config_path, "pen", "up", "--backend", "fake") == 0
    assert stored() == {**before, "pen": "up"}
    assert state.journal_path().read_text() == journal
    capsys.readouterr()
    assert run(config_path, "goto", "0", "0", "--backend", "fake") == 2
    assert "--trust-position" in capsys.readouterr().err


# ------------------------------------------------------------------ jog by the cords
def cord_change(trace, cfg) -> np.ndarray:
    """How much longer the cords got (mm) in a trace (from any start: only differences)."""
    dec = tc.decode(tc.read_trace(trace), cfg, (0.0, 0.0))
    return np.array([dec.left_mm[-1] - dec.left_mm[0], dec.right_mm[-1] - dec.right_mm[0]])


def test_jog_by_cords_moves_without_a_position_and_makes_none(config_path, tmp_path, capsys):
    cfg = tc.load_config(config_path)
    for n, (side, mm, want) in enumerate((("--left", "5", [5, 0]), ("--right", "5", [0, 5]),
                                          ("--left", "-12.5", [-12.5, 0]))):
        t = tmp_path / f"t{n}.csv"
        assert run(config_path, "jog", side, mm, "--backend", "fake", "--trace", str(t)) == 0
        # mm are rounded to steps, and a release from a two-coil phase takes a half step back
        assert cord_change(t, cfg) == pytest.approx(want, abs=2 / 163.84)
        # the coils released (the pen is not touched by a jog)
        assert tc.released_at_end(tc.read_trace(t), cfg) == ["pen was never commanded"]
        assert nothing_stored()
        err = capsys.readouterr().err.strip().splitlines()
        assert err == ["note: the pen position stays unknown; once the pen is on a known point, "
                       "run `vplotter calibrate --at X Y`"]
    # the position is still unknown, and what needs it says how to get one
    for argv in (["jog", "--dx", "5"], ["jog", "--dy", "-1"], ["jog"], ["goto", "1", "1"],
                 ["home"], ["draw", str(REPO / "gcode_samples" / "square.ngc")]):
        assert run(config_path, *argv, "--backend", "fake") == 2
        assert capsys.readouterr().err.strip().splitlines() == [f"vplotter: {UNKNOWN}"]
    assert nothing_stored()
    # then calibrate, and jog by the cords follows the stored position as before
    assert run(config_path, "calibrate", "--at", "0", "0") == 0
    before = state.load()
    assert run(config_path, "jog", "--left", "5", "--backend", "fake") == 0
    assert state.load().left_mm - before.left_mm == pytest.approx(5, abs=0.01)
    assert "stays unknown" not in capsys.readouterr().err


def test_jog_without_a_position_takes_the_lock(config_path, capsys):

    holder = hold_lock("vplotter draw car.ngc")
    try:
        for argv in (["jog", "--left", "5"], ["pen", "cycle"]):
            assert run(config_path, *argv, "--backend", "fake") == 3
            assert "plotter busy" in capsys.readouterr().err
    finally:
        holder.stdin.close()
        holder.wait()
    assert lock.holder() is None and nothing_stored()


def test_ctrl_c_in_a_jog_without_a_position_lifts_releases_and_stores_nothing(
        config_path, tmp_path, monkeypatch, capsys):
    import signal


    cfg = tc.load_config(config_path)
    t = tmp_path / "t.csv"
    interrupt_after(monkeypatch, 400, signal.SIGINT)
    assert run(config_path, "jog", "--left", "50", "--backend", "fake", "--trace", str(t)) == 130
    moved = cord_change(t, cfg)
    assert 0 < moved[0] < 50 and moved[1] == 0
    tr = tc.read_trace(t)
    assert tc.released_at_end(tr, cfg) == []         # pen lifted, coils released
    assert nothing_stored()
    assert capsys.readouterr().err.strip().splitlines()[-1] == "vplotter: stopped by SIGINT"


CRASH = r"""
import os, sys
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main
n = {"rows": 0}
orig = FakeBackend.play
def play(self, rows):
    n["rows"] += len(rows)
    if n["rows"] > 300:
        os._exit(137)          # like kill -9 or a power cut: no cleanup at all
    return orig(self, rows)
FakeBackend.play = play
sys.exit(main(sys.argv[1:]))
"""


def test_a_crash_in_a_jog_without_a_position_leaves_no_position(config_path, capsys):
    proc = subprocess.run([sys.executable, "-c", CRASH, "--config", str(config_path), "jog",
                           "--left", "50", "--backend", "fake"], env=dict(os.environ),
                          capture_output=True, text=True)
    assert proc.returncode == 137, proc.stderr
    assert nothing_stored() and lock.holder() is None
    assert run(config_path, "status") == 0
    assert "position unknown" in capsys.readouterr().out.lower()
    assert run(config_path, "jog", "--dx", "1", "--backend", "fake") == 2
    assert run(config_path, "pen", "up", "--backend", "fake") == 0      # the pen still moves


def test_calibrate_steps_without_a_position_makes_none(tmp_path, config_path, monkeypatch):
    cfg_file = tmp_path / "config.toml"
    cfg_file.write_text(config_path.read_text())
    answers = iter(["480", "492.5"])
    monkeypatch.setattr("builtins.input", lambda prompt="": next(answers))
    assert run(cfg_file, "calibrate", "steps", "--motor", "left", "--backend", "fake") == 0
    assert "spool_circumference_mm = 25.6 " in cfg_file.read_text()
    assert nothing_stored()
