"""The job queue: add (validated, one error line), list with plot times, move, remove, clear;
`queue run` draws the jobs one after another with a wait for fresh paper between two jobs and
between two copies (`vplotter continue` goes on), a stopped job stays first and the next run
resumes it; the files are copies, the queue is on disk.

Waits run on no clock: the wait's sleep is replaced by what another process does meanwhile
(continue, stop), as in test_pen_change_pauses.py."""

from __future__ import annotations

import io
import json
import os
import signal
import sys

import pytest

from support import REPO
from support.cli import run
from vplotter.backends.fake import FakeBackend
from vplotter.cli import COMMANDS, build_parser, main
from vplotter.commands import draw as draw_cmd
from vplotter.machine import history, live, queue, state

SQUARE = """G21 G90
G00 Z5
G00 X{x} Y0
G01 Z-1 F600
G01 X{x2} Y0
G01 X{x2} Y4
G01 X{x} Y4
G01 X{x} Y0
G00 Z5
G00 X0 Y0
M2
"""


def square(tmp_path, name: str, x: float) -> str:
    f = tmp_path / name
    f.write_text(SQUARE.format(x=x, x2=x + 4))
    return str(f)


@pytest.fixture
def cfg(tmp_path, capsys):
    path = str(REPO / "config.toml")
    assert main(["--config", path, "calibrate", "--at", "0", "0"]) == 0
    capsys.readouterr()
    return path


def vp(capsys, cfg, *argv):
    return run(capsys, ["--config", cfg, *map(str, argv)])


def nested(*argv) -> int:
    """A command run from inside the queue's run in this process, as another process would
    (main() would let go of the run's lock when it ends)."""
    args = build_parser().parse_args([str(a) for a in argv])
    return COMMANDS[args.command][0](args, list(argv))


# ---------------------------------------------------------------- adding
def test_a_job_is_validated_when_added_and_a_bad_one_is_one_error_line(capsys, cfg, tmp_path):
    bad = tmp_path / "bad.ngc"
    bad.write_text("G21 G90\nG01 X10 Y0 F600\nG01 X900 Y0\nM2\n")      # off the page
    cases = [(["queue", "add", bad], "bad.ngc:3:"),
             (["queue", "add", tmp_path / "none.svg"], "none.svg: error: no such file"),
             (["queue", "add", square(tmp_path, "a.ngc", 0), "--copies", "0"], "--copies"),
             (["queue", "add", square(tmp_path, "a.ngc", 0), "--width", "-3"], "width"),
             (["queue", "add", square(tmp_path, "a.ngc", 0), "--bogus"], "--bogus"),
             (["queue", "move", "7", "1"], "no job 7 in the queue"),
             (["queue", "remove", "7"], "no job 7 in the queue"),
             (["queue", "move", "x", "1"], "invalid int value")]
    for argv, said in cases:
        code, out, err = vp(capsys, cfg, *argv)
        assert code == 2 and len(err.splitlines()) == 1 and said in err, (argv, err)
    assert queue.jobs() == []


def test_jobs_list_their_plot_times_and_the_total_and_move_and_remove(capsys, cfg, tmp_path):
    a, b, c = (square(tmp_path, f"{n}.ngc", x) for n, x in (("a", 0), ("b", 10), ("c", 20)))
    code, out, _ = vp(capsys, cfg, "queue", "add", a, "--copies", "2")
    assert code == 0 and out.startswith("job 1: a.ngc, 2 copies, plot time ")
    assert vp(capsys, cfg, "queue", "add", b, "--order", "greedy")[0] == 0
    assert vp(capsys, cfg, "queue", "add", c, "--copies", "3", "--offset", "1", "2")[0] == 0
    assert vp(capsys, cfg, "queue", "move", "3", "1")[0] == 0
    code, out, _ = vp(capsys, cfg, "queue", "--json")
    data = json.loads(out)
    assert [(j["id"], j["copies"], j["done"]) for j in data["jobs"]] == [(3, 3, 0), (1, 2, 0),
                                                                         (2, 1, 0)]
    assert data["jobs"][2]["options"] == ["--order=greedy"]
    assert data["jobs"][0]["options"] == ["--offset", "1.0", "2.0"]
    for j in data["jobs"]:
        assert j["left_s"] == pytest.approx(j["estimate_s"] * j["copies"], abs=0.01)
    assert data["total_s"] == pytest.approx(sum(j["left_s"] for j in data["jobs"]), abs=0.01)
    code, out, _ = vp(capsys, cfg, "queue")
    lines = out.splitlines()
    assert lines[0].startswith("1. job 3: c.ngc --offset 1.0 2.0, copy 1 of 3 (3 copies left)")
    assert lines[-1].startswith("total: ") and lines[-1].endswith("for 3 jobs")
    assert vp(capsys, cfg, "queue", "move", "2", "99")[0] == 0            # past the end: last
    assert vp(capsys, cfg, "queue", "remove", "1")[0] == 0
    assert [j["id"] for j in queue.jobs()] == [3, 2]
    assert not (queue.queue_dir() / "1").exists()
    assert vp(capsys, cfg, "queue", "clear")[1] == "the queue is empty (2 jobs removed)\n"
    assert queue.jobs() == [] and vp(capsys, cfg, "queue")[1].startswith("the queue is empty")


def test_a_job_is_a_copy_of_the_file_and_the_queue_is_on_disk(capsys, cfg, tmp_path):
    a = square(tmp_path, "a.ngc", 0)
    text = open(a).read()
    assert vp(capsys, cfg, "queue", "add", a)[0] == 0
    open(a, "w").write("this is no drawing any more\n")
    job = json.loads(queue.queue_path().read_text())["jobs"][0]      # what a reboot finds
    assert open(job["file"]).read() == text and job["source"] == a
    os.unlink(a)
    assert vp(capsys, cfg, "queue", "run", "--backend", "fake")[0] == 0
    assert queue.jobs() == [] and [p["result"] for p in history.read()] == ["done"]


def test_a_corrupt_queue_is_one_line_and_clear_empties_it(capsys, cfg):
    queue.queue_path().parent.mkdir(parents=True, exist_ok=True)
    queue.queue_path().write_text("{not json")
    code, _, err = vp(capsys, cfg, "queue")
    assert code == 2 and "the queue is corrupt" in err and "queue clear" in err
    assert vp(capsys, cfg, "queue", "clear")[0] == 0 and queue.jobs() == []


# ---------------------------------------------------------------- running
class Plotter:
    """The fake backend's rows, counted; stop_after(n): a SIGINT once n more rows are played
    (as `vplotter stop` sends it), from inside the backend."""

    def __init__(self, monkeypatch):
        self.rows, self.armed = 0, None
        orig = FakeBackend.play

        def play(backend, rows):
            if backend.stop_requested:
                return 0
            if self.armed is not None and self.armed < len(rows):
                part, self.armed = rows[:self.armed], None
                os.kill(os.getpid(), signal.SIGINT)
                n = orig(backend, part) if len(part) else 0
                self.rows += n
                return n
            if self.armed is not None:
                self.armed -= len(rows)
            n = orig(backend, rows)
            self.rows += n
            return n

        monkeypatch.setattr(FakeBackend, "play", play)

    def stop_after(self, n: int) -> None:
        self.armed = n


def test_three_jobs_with_copies_reordered_run_with_continue_and_one_stopped_and_resumed(
        capsys, cfg, tmp_path, monkeypatch):
    a, b, c = (square(tmp_path, f"{n}.ngc", x) for n, x in (("a", 0), ("b", 10), ("c", 20)))
    for f, n in ((a, 2), (b, 1), (c, 2)):
        assert vp(capsys, cfg, "queue", "add", f, "--copies", n)[0] == 0
    assert vp(capsys, cfg, "queue", "move", "3", "1")[0] == 0          # c, a, b
    plotter = Plotter(monkeypatch)
    waits, seen = [], []

    def meanwhile(k):              # each poll of a wait: someone reads the status and goes on
        out = capsys.readouterr().out
        seen.append(out)
        assert nested("--config", cfg, "status", "--json") == 0
        info = json.loads(capsys.readouterr().out)
        waits.append(info["drawing"]["waiting"]["prompt"])
        assert info["drawing"]["state"] == "waiting"
        if len(waits) == 2:        # at a's first copy: stopped part-way through it
            plotter.stop_after(3)
        assert nested("continue") == 0
        capsys.readouterr()

    monkeypatch.setattr(draw_cmd, "_sleep", lambda s: meanwhile(len(waits)))
    monkeypatch.setattr(sys, "stdin", io.StringIO(""))                   # no terminal
    code = main(["--config", cfg, "queue", "run", "--backend", "fake", "--detached"])
    out, err = capsys.readouterr()
    assert code == 128 + signal.SIGINT
    assert waits == ["put in fresh paper for c.ngc (2 of 2)",
                     "put in fresh paper for a.ngc (1 of 2)"]
    assert seen[0].splitlines()[-1] == ("pause: put in fresh paper for c.ngc (2 of 2); "
                                        "waiting: `vplotter continue` goes on")
    assert "queue: stopped in a.ngc (1 of 2): `vplotter queue run` goes on from there" in out
    assert err.splitlines()[-1] == "vplotter: stopped by SIGINT"
    jobs = queue.jobs()
    assert [(j["id"], j["done"], j["stopped"]) for j in jobs] == [(1, 0, True), (2, 0, False)]
    assert state.load().extra["resume"]["file"] == jobs[0]["file"]
    # the next run resumes a's first copy at once (no paper wait), then goes on
    code = main(["--config", cfg, "queue", "run", "--backend", "fake", "--detached"])
    out, err = capsys.readouterr()
    out = "".join(seen[2:]) + out
    assert code == 0, err
    assert "queue: job 1: a.ngc (1 of 2), resumed" in out and "the queue is done" in out
    assert waits[2:] == ["put in fresh paper for a.ngc (2 of 2)",
                         "put in fresh paper for b.ngc"]
    assert queue.jobs() == [] and sorted(os.listdir(queue.queue_dir())) == ["lock", "queue.json"]
    plots = history.read()
    assert [(p["file"], p["copy"], p["result"]) for p in plots] == [
        ("c.ngc", "1 of 2", "done"), ("c.ngc", "2 of 2", "done"),
        ("a.ngc", "1 of 2", "stopped"), ("a.ngc", "1 of 2", "done"),
        ("a.ngc", "2 of 2", "done"), ("b.ngc", None, "done")]
    assert plots[2]["drawn_m"] < plots[4]["drawn_m"]


def test_enter_on_the_terminal_goes_on_and_a_stop_while_waiting_keeps_the_job(
        capsys, cfg, tmp_path, monkeypatch):
    a, b = square(tmp_path, "a.ngc", 0), square(tmp_path, "b.ngc", 10)
    assert vp(capsys, cfg, "queue", "add", a, "--copies", "2")[0] == 0
    assert vp(capsys, cfg, "queue", "add", b)[0] == 0

    def sigint(s):
        os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(sys, "stdin", io.StringIO("\n"))        # Enter once, then closed
    monkeypatch.setattr(draw_cmd, "_sleep", sigint)
    code = main(["--config", cfg, "queue", "run", "--backend", "fake"])
    out, err = capsys.readouterr()
    assert code == 128 + signal.SIGINT
    assert "pause: put in fresh paper for a.ngc (2 of 2), then press Enter" in out
    assert "pause: put in fresh paper for b.ngc, then press Enter" in out
    assert "queue: stopped before b.ngc: `vplotter queue run` goes on from there" in out
    assert [(j["name"], j["stopped"]) for j in queue.jobs()] == [("b.ngc", False)]
    assert live.read() is None and state.load().clean


def test_a_dry_run_of_the_queue_draws_nothing_and_keeps_the_queue(capsys, cfg, tmp_path):
    a = square(tmp_path, "a.ngc", 0)
    assert vp(capsys, cfg, "queue", "add", a, "--copies", "2")[0] == 0
    before = queue.queue_path().read_text()
    code, out, _ = vp(capsys, cfg, "queue", "run", "--dry-run")
    assert code == 0
    assert "pause: put in fresh paper for a.ngc (2 of 2) (dry run: not waiting)" in out
    assert queue.queue_path().read_text() == before and history.read() == []


def test_a_job_that_no_longer_validates_fails_with_its_line_and_stays(capsys, cfg, tmp_path):
    a = square(tmp_path, "a.ngc", 150)          # on the page, but not from where the pen is
    assert vp(capsys, cfg, "queue", "add", a)[0] == 0
    assert vp(capsys, cfg, "calibrate", "--at", "0", "0")[0] == 0
    path = tmp_path / "small.toml"
    path.write_text((REPO / "config.toml").read_text().replace("x_max_mm = 200",
                                                               "x_max_mm = 100"))
    code, out, err = vp(capsys, str(path), "queue", "run", "--backend", "fake")
    assert code == 2 and "outside the page" in err
    assert [j["name"] for j in queue.jobs()] == ["a.ngc"]
    (plot,) = history.read()
    assert plot["result"] == "failed" and plot["error"] == err.strip()


CRASH = """
import os, sys
from vplotter.backends.fake import FakeBackend
from vplotter.cli import main
orig, n = FakeBackend.play, [0]
def play(self, rows):
    n[0] += 1
    if n[0] == 3:
        os._exit(9)          # the power goes in the middle of the job
    return orig(self, rows)
FakeBackend.play = play
main(["--config", sys.argv[1], "queue", "run", "--backend", "fake"])
"""


def test_a_job_cut_short_by_a_power_cut_is_resumed_by_the_next_run(capsys, cfg, tmp_path):
    import subprocess

    a = square(tmp_path, "a.ngc", 0)
    assert vp(capsys, cfg, "queue", "add", a, "--copies", "2")[0] == 0
    proc = subprocess.run([sys.executable, "-c", CRASH, cfg], capture_output=True, text=True,
                          env=dict(os.environ))
    assert proc.returncode == 9
    assert [(j["done"], j["stopped"]) for j in queue.jobs()] == [(0, False)]
    assert [p["result"] for p in history.read()] == ["interrupted (power cut or crash)"]
    code, _, err = vp(capsys, cfg, "queue", "run", "--backend", "fake")    # not trusted yet
    assert code == 2 and "not clean" in err
    monkey_stdin = io.StringIO("\n")
    sys_stdin, sys.stdin = sys.stdin, monkey_stdin
    try:
        code, out, _ = vp(capsys, cfg, "queue", "run", "--backend", "fake", "--trust-position")
    finally:
        sys.stdin = sys_stdin
    assert code == 0 and "queue: job 1: a.ngc (1 of 2), resumed" in out
    assert [p["result"] for p in history.read()] == ["interrupted (power cut or crash)",
                                                     "failed", "done", "done"]
