"""Pen changes at draw time: the gondola parks at the change point (pen up, motors holding),
the prompt names the pen, a dry run lists the changes, a background draw waits for
`vplotter continue` (status shows it), a stop while waiting is clean, a resumed draw asks for
the pen in use first, and each pen's down_us is its pen-down pulse.

The pen-change pauses are made here by hand (the "pens" stage makes them from a drawing's
colours): a G-code file whose comment lines `(pen NAME)` become Pause(pen=NAME, index, count)
records before what follows. Waits run on no clock at all: the wait's sleep is replaced by
what another process would do meanwhile (status, continue, stop)."""

from __future__ import annotations

import io
import json
import os
import signal
import sys

import numpy as np
import pytest
from scipy.spatial import cKDTree

from support import tracecheck as tc
from support import REPO
from vplotter import config, kinematics
from vplotter.backends.fake import FakeBackend
from vplotter.cli import COMMANDS, build_parser, main
from vplotter.commands import draw as draw_cmd
from vplotter.inputs.gcode import Pause, Pen
from vplotter.machine import live, state
from vplotter.prepare import Prepared

PENS_GCODE = """G21 G90
(pen red)
G00 Z5
G00 X0 Y0
G01 Z-1 F600
G01 X4 Y0
G01 X4 Y4
G00 Z5
(pen blue)
G01 Z-1
G01 X8 Y4
G01 X8 Y8
G00 Z5
(pen green)
G00 X12 Y0
G01 Z-1
G01 X12 Y4
G00 Z5
M2
"""
PENS = {2: "red", 9: "blue", 14: "green"}      # the comment lines: where each pen starts
CHANGE = (-10.0, 12.0)


def pens_file(tmp_path, monkeypatch, text: str, pens: dict, lift: bool = False):
    """A G-code file, read with a pen-change Pause at each `(pen NAME)` line (pens); lift:
    a pen that is down is lifted before the pause and lowered after it on the pause's line,
    as the G-code reader does at a tool change."""
    f = tmp_path / "pens.ngc"
    f.write_text(text)
    orig = Prepared.records

    def records(self):
        todo = sorted(pens.items())
        down = False
        for rec in orig(self):
            while todo and todo[0][0] < rec.line:
                line, pen = todo.pop(0)
                k = sorted(pens).index(line) + 1
                around = lift and down
                if around:
                    yield Pen(line, 1, False)
                yield Pause(line, 1, f"put in the {pen} pen ({k} of {len(pens)})", pen=pen,
                            index=k, count=len(pens))
                if around:
                    yield Pen(line, 1, True)
            if isinstance(rec, Pen):
                down = rec.down
            yield rec

    monkeypatch.setattr(Prepared, "records", records)
    return f


@pytest.fixture
def pen_file(tmp_path, monkeypatch):
    return pens_file(tmp_path, monkeypatch, PENS_GCODE, PENS)


def write_config(tmp_path, extra: str = "") -> str:
    path = tmp_path / "config.toml"
    path.write_text((REPO / "config.toml").read_text() + "\n[pens]\n"
                    f"change_x_mm = {CHANGE[0]}\nchange_y_mm = {CHANGE[1]}\n" + extra)
    return str(path)


@pytest.fixture
def cfg_path(tmp_path):
    return write_config(tmp_path)


def nested(*argv) -> int:
    """A command run from inside a draw of this process, as another process would run it
    (main() would let go of the draw's lock when it ends)."""
    args = build_parser().parse_args([str(a) for a in argv])
    return COMMANDS[args.command][0](args, list(argv))


def run(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


class Watch:
    """What the fake backend played (the last step counts, motor word and pen pulse after each
    chunk) and where the draw stood at each wait."""

    def __init__(self, monkeypatch, cfg_path):
        self.cfg = config.load(cfg_path)
        self.steps, self.word, self.pen, self.pulses, self.at_pause = None, None, 0, [], []
        orig = FakeBackend.play

        def play(backend, rows):
            n = orig(backend, rows)
            if n:
                done = rows[:n]
                self.steps, self.word = done.steps[-1].copy(), int(done.coils[-1])
                on = done.pen_us > 0
                if on.any():
                    self.pen = int(done.pen_us[on][-1])
                self.pulses += list(zip(done.line[on].tolist(), done.pen_us[on].tolist()))
            return n

        monkeypatch.setattr(FakeBackend, "play", play)

    def mark(self) -> None:
        self.at_pause.append((self.steps.copy(), self.word, self.pen))

    def xy(self, steps, pos) -> np.ndarray:
        kin = kinematics.from_config(self.cfg)
        cords = np.asarray(pos.ref_mm) + steps / np.asarray(self.cfg.motors.steps_per_unit)
        return kin.to_gcode(kin.forward(cords[None, :]))[0]


def enter_at_each_prompt(monkeypatch, watch, answers: int):
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n" * answers))
    orig = draw_cmd.wait_enter

    def wait(stdin, stop, **kw):
        watch.mark()
        return orig(stdin, stop, **kw)

    monkeypatch.setattr(draw_cmd, "wait_enter", wait)


def drawn(trace, cfg_path, start=(0.0, 0.0)) -> np.ndarray:
    dec = tc.decode(tc.read_trace(trace), tc.load_config(cfg_path), start)
    assert tc.illegal_transitions(dec) == []
    return np.column_stack((dec.x, dec.y))[dec.pen_down]


def covers(pts: np.ndarray, gfile) -> None:
    """The drawn points lie on the file's path and cover it: 0.02 mm both ways."""
    ref = tc.reference_path(gfile)
    assert tc.distances_to_polylines(pts, ref).max() <= 0.02
    assert max(cKDTree(pts).query(r)[0].max() for r in ref) <= 0.02


# ---------------------------------------------------------------- a draw with three pens
def test_each_pen_change_parks_pen_up_and_held_and_the_strokes_are_the_files(
        capsys, cfg_path, pen_file, tmp_path, monkeypatch):
    trace = tmp_path / "t.csv"
    watch = Watch(monkeypatch, cfg_path)
    enter_at_each_prompt(monkeypatch, watch, 3)
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    pos = state.load()
    code, out, _ = run(capsys, "--config", cfg_path, "draw", pen_file, "--backend", "fake",
                       "--trace", trace)
    assert code == 0
    prompts = [line for line in out.splitlines() if line.startswith("pause:")]
    assert prompts == [f"pause: put in the {p} pen ({k} of 3), then press Enter"
                       for k, p in enumerate(["red", "blue", "green"], 1)]
    assert "going on with the blue pen" in out
    assert len(watch.at_pause) == 3
    cfg = watch.cfg
    for steps, word, pen in watch.at_pause:
        assert np.hypot(*(watch.xy(steps, pos) - CHANGE)) <= 0.02     # parked
        assert pen == cfg.pen.up_us                                   # the pen is up
        assert word != cfg.motors.idle_word                           # the motors hold
    covers(drawn(trace, cfg_path), pen_file)
    assert tc.released_at_end(tc.read_trace(trace), tc.load_config(cfg_path)) == []
    # the plot time said includes the parking travel
    summary = next(line for line in out.splitlines() if "plot time" in line)
    said = float(summary.split("(")[-1].split(" s)")[0])
    assert abs(said - tc.plot_time(tc.read_trace(trace))) <= 0.05 + 0.001 * said
    end = state.load()
    assert end.clean and end.pen == "up" and end.extra["pen_in"]["pen"] == "green"
    assert "resume" not in end.extra and "pen_change" not in end.extra


def test_dry_run_lists_the_pen_changes_without_waiting(capsys, cfg_path, pen_file,
                                                       monkeypatch):
    class NoInput(io.StringIO):
        def readline(self, *a):
            raise AssertionError("a dry run does not wait")

    monkeypatch.setattr(sys, "stdin", NoInput())
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    code, out, _ = run(capsys, "--config", cfg_path, "draw", pen_file, "--dry-run")
    assert code == 0
    assert [line for line in out.splitlines() if line.startswith("pause:")] == [
        "pause: put in the red pen (1 of 3) (dry run: not waiting)",
        "pause: put in the blue pen (2 of 3) (dry run: not waiting)",
        "pause: put in the green pen (3 of 3) (dry run: not waiting)"]


def test_without_a_change_point_the_gondola_waits_where_the_plot_started(
        capsys, tmp_path, pen_file, monkeypatch):
    cfg_path = str(REPO / "config.toml")
    watch = Watch(monkeypatch, cfg_path)
    enter_at_each_prompt(monkeypatch, watch, 3)
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "5", "-20")[0] == 0
    pos = state.load()
    trace = tmp_path / "t.csv"
    assert run(capsys, "--config", cfg_path, "draw", pen_file, "--backend", "fake",
               "--trace", trace)[0] == 0
    for steps, _, _ in watch.at_pause:
        assert np.hypot(*(watch.xy(steps, pos) - (5.0, -20.0))) <= 0.02
    covers(drawn(trace, cfg_path, (5.0, -20.0)), pen_file)


MID_STROKE = PENS_GCODE.replace("(pen blue)\n", "").replace("G01 X4 Y4\n",
                                                             "(pen blue)\nG01 X4 Y4\n")
MID_PENS = {2: "red", 7: "blue", 14: "green"}


@pytest.mark.parametrize("lift", [False, True])
def test_a_pen_change_in_the_middle_of_a_stroke_lifts_parks_and_goes_back_down(
        capsys, cfg_path, tmp_path, monkeypatch, lift):
    f = pens_file(tmp_path, monkeypatch, MID_STROKE, MID_PENS, lift)
    trace = tmp_path / "t.csv"
    watch = Watch(monkeypatch, cfg_path)
    enter_at_each_prompt(monkeypatch, watch, 3)
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    pos = state.load()
    assert run(capsys, "--config", cfg_path, "draw", f, "--backend", "fake", "--trace",
               trace)[0] == 0
    steps, word, pen = watch.at_pause[1]
    assert np.hypot(*(watch.xy(steps, pos) - CHANGE)) <= 0.02 and pen == 500
    covers(drawn(trace, cfg_path), f)


def test_a_change_point_off_the_page_is_an_error_before_anything_moves(capsys, tmp_path,
                                                                        pen_file):
    path = tmp_path / "off.toml"
    path.write_text((REPO / "config.toml").read_text()
                    + "\n[pens]\nchange_x_mm = 500\nchange_y_mm = 0\n")
    assert run(capsys, "--config", path, "calibrate", "--at", "0", "0")[0] == 0
    before = state.load()
    for argv in (["draw", pen_file, "--backend", "fake"], ["estimate", pen_file]):
        code, out, err = run(capsys, "--config", path, *argv)
        assert code == 2 and "plot time" not in out
        assert err.splitlines() == [f"{pen_file}:2:1: error: the pen change point X500.000 "
                                    f"Y0.000 ([pens] change_x_mm, change_y_mm) is outside the "
                                    f"page (X -200..200, Y -250..300)"]
    assert state.load() == before and not state.journal_path().exists()


def test_each_pen_draws_with_its_own_down_pulse(capsys, tmp_path, pen_file, monkeypatch):
    cfg_path = write_config(tmp_path, '[pens.blue]\ncolour = "#0000ff"\ndown_us = 1300\n')
    watch = Watch(monkeypatch, cfg_path)
    enter_at_each_prompt(monkeypatch, watch, 3)
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    trace = tmp_path / "t.csv"
    assert run(capsys, "--config", cfg_path, "draw", pen_file, "--backend", "fake", "--trace",
               trace)[0] == 0
    downs = {line: us for line, us in watch.pulses if us != 500}
    assert downs == {5: 1500, 10: 1300, 16: 1500}      # red, blue (its own), green
    from vplotter.machine.trace import read_steps     # what `simulate` reads: 3 strokes down

    down = read_steps(str(trace), watch.cfg.motors, watch.cfg.pen).down.astype(int)
    assert int((np.diff(down) == 1).sum()) == 3


# ---------------------------------------------------------------- in the background
def detached_draw(capsys, cfg_path, pen_file, monkeypatch, meanwhile, *extra):
    """draw --detached (what `draw --detach` runs in the background) in this process; each
    poll of a wait runs meanwhile(k) instead of sleeping (k: the polls so far)."""
    polls = []

    def sleep(s):
        polls.append(s)
        meanwhile(len(polls))

    monkeypatch.setattr(draw_cmd, "_sleep", sleep)
    monkeypatch.setattr(sys, "stdin", io.StringIO(""))       # no terminal
    return main(["--config", str(cfg_path), "draw", str(pen_file), "--backend", "fake",
                 "--detached", *map(str, extra)]), polls


def test_a_background_draw_waits_for_continue_and_status_shows_it(capsys, cfg_path, pen_file,
                                                                   monkeypatch):
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    code, out, err = run(capsys, "continue")
    assert code == 2 and err.strip() == ("vplotter: error: nothing to continue: no vplotter "
                                         "is driving the plotter")
    seen = []

    def meanwhile(k):
        out = capsys.readouterr().out
        seen.append(out)
        assert nested("--config", cfg_path, "status", "--json") == 0
        info = json.loads(capsys.readouterr().out)
        seen.append(info)
        assert nested("--config", cfg_path, "status") == 0
        seen.append(capsys.readouterr().out)
        assert nested("continue") == 0
        seen.append(capsys.readouterr().out)

    code, polls = detached_draw(capsys, cfg_path, pen_file, monkeypatch, meanwhile)
    assert code == 0 and len(polls) == 3               # one poll per pen change, no more
    log0, info, text, said = seen[4:8]                 # at the blue pen
    assert log0.splitlines()[-1] == ("pause: put in the blue pen (2 of 3); waiting: "
                                     "`vplotter continue` goes on")
    w = info["drawing"]["waiting"]
    assert info["last_stop"] == "running" and info["drawing"]["pid"] == os.getpid()
    assert info["drawing"]["state"] == "waiting" and seen[1]["drawing"]["state"] == "waiting"
    assert {k: w[k] for k in ("pen", "index", "count", "prompt")} == {
        "pen": "blue", "index": 2, "count": 3, "prompt": "put in the blue pen (2 of 3)"}
    assert "WAITING: put in the blue pen (2 of 3), then `vplotter continue`" in text
    assert said == f"continuing pid {os.getpid()}: put in the blue pen (2 of 3)\n"
    assert "finished at" in capsys.readouterr().out
    assert not live.continue_path().exists()


def test_stop_while_waiting_is_clean_and_resume_asks_for_that_pen_again(
        capsys, cfg_path, pen_file, tmp_path, monkeypatch):
    t1, t2 = tmp_path / "t1.csv", tmp_path / "t2.csv"
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0

    def meanwhile(k):
        if k == 1:
            assert nested("continue") == 0             # red: go on
        else:
            os.kill(os.getpid(), signal.SIGINT)        # blue: `vplotter stop`

    code, polls = detached_draw(capsys, cfg_path, pen_file, monkeypatch, meanwhile,
                                "--trace", t1)
    assert code == 130 and len(polls) == 2
    out, err = capsys.readouterr()
    assert "resume with:" in err
    pos = state.load()
    assert pos.clean and pos.pen == "up"
    assert pos.extra["resume"]["line"] == 9            # the pen change itself
    assert pos.extra["pen_change"]["pen"] == "blue" and pos.extra["pen_in"]["pen"] == "red"
    xy = watchless_xy(cfg_path, pos)
    assert np.hypot(*(xy - CHANGE)) <= 0.02            # still at the change point
    assert run(capsys, "--config", cfg_path, "status")[1].count(
        "stopped at a pen change: put in the blue pen (2 of 3)") == 1
    info = json.loads(run(capsys, "--config", cfg_path, "status", "--json")[1])
    assert info["pen_change"]["pen"] == "blue" and info["pen_in"]["pen"] == "red"
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n\n"))
    code, out, _ = run(capsys, "--config", cfg_path, "draw", pen_file, "--backend", "fake",
                       "--resume", "--trace", t2)
    assert code == 0
    assert [line for line in out.splitlines() if line.startswith("pause:")] == [
        "pause: put in the blue pen (2 of 3), then press Enter",
        "pause: put in the green pen (3 of 3), then press Enter"]
    both = np.vstack([drawn(t1, cfg_path), drawn(t2, cfg_path, tuple(xy))])
    covers(both, pen_file)


def watchless_xy(cfg_path, pos) -> np.ndarray:
    cfg = config.load(cfg_path)
    kin = kinematics.from_config(cfg)
    return kin.to_gcode(kin.forward(np.array([[pos.left_mm, pos.right_mm]])))[0]


def stop_in_line(monkeypatch, line: int):
    """SIGINT when the fake backend is about to play a row of `line` (a person's Ctrl+C)."""
    orig, sent = FakeBackend.play, []

    def play(backend, rows):
        hit = np.flatnonzero(rows.line == line)
        if not sent and len(hit) > 5:
            sent.append(True)
            n = orig(backend, rows[:int(hit[5])])
            os.kill(os.getpid(), signal.SIGINT)
            return n
        return orig(backend, rows)

    monkeypatch.setattr(FakeBackend, "play", play)
    return orig


@pytest.mark.parametrize("power_cut", [False, True])
def test_a_draw_stopped_in_a_pens_strokes_resumes_asking_for_that_pen(
        capsys, cfg_path, pen_file, tmp_path, monkeypatch, power_cut):
    t1, t2 = tmp_path / "t1.csv", tmp_path / "t2.csv"
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n\n"))
    orig = stop_in_line(monkeypatch, 11)                # in the blue stroke
    code, out, _ = run(capsys, "--config", cfg_path, "draw", pen_file, "--backend", "fake",
                       "--trace", t1)
    assert code == 130 and out.count("pause:") == 2
    monkeypatch.setattr(FakeBackend, "play", orig)
    pos = state.load()
    resume = pos.extra["resume"]
    assert resume["line"] == 11 and pos.extra["pen_in"]["pen"] == "blue"
    _resume_asks_blue_then_green(monkeypatch, capsys, cfg_path, pen_file, pos, t1, t2,
                                 _cut_power(pos, 11, "down") if power_cut else [])


# ---------------------------------------------------------------- live.json and continue
def test_live_waiting_state_and_continue_requests(monkeypatch):
    now = {"t": 1000.0}
    pub = live.Publisher("vplotter draw a.svg", "/x/a.svg", 100.0, clock=lambda: now["t"])
    pub.update(40.0, 12, force=True)
    me = {"pid": os.getpid(), "command": "vplotter draw a.svg", "since": 1000.0}
    assert live.read(me, now=1000.0)["waiting"] is None
    assert live.read(me, now=1000.0)["state"] == "drawing"
    live.request_continue(os.getpid())                 # left over from before: dropped
    now["t"] = 1001.0
    pub.waiting(Pause(12, 0, "", pen="red", index=2, count=3))
    assert not live.continue_path().exists()
    d = live.read(me, now=1002.0)
    assert d["waiting"] == {"message": "", "pen": "red", "index": 2, "count": 3,
                            "since": 1001.0, "prompt": "put in the red pen (2 of 3)"}
    assert live.describe(d).startswith("waiting in a.svg line 12: put in the red pen (2 of 3)")
    live.request_continue(os.getpid() + 1)             # for someone else
    assert not live.take_continue()
    live.request_continue(os.getpid())
    assert live.take_continue() and not live.take_continue()
    assert d["state"] == "waiting"
    pub.waiting(None)
    assert live.read(me, now=1003.0)["waiting"] is None
    assert live.read(me, now=1003.0)["state"] == "drawing"
    assert live.pen_prompt(Pause(1, 0, "layer a done; next: layer b")) == \
        "layer a done; next: layer b"
    pub.close()


def test_without_a_terminal_a_pen_change_waits_for_continue(capsys, cfg_path, pen_file,
                                                             monkeypatch):
    """A draw whose standard input is closed (a systemd service) does not skip a pen change:
    it waits for `vplotter continue`; Enter's wait also ends on `continue`."""
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    polls = []

    def sleep(s):
        polls.append(s)
        assert nested("continue") == 0

    monkeypatch.setattr(draw_cmd, "_sleep", sleep)
    monkeypatch.setattr(sys, "stdin", io.StringIO(""))
    code, out, err = run(capsys, "--config", cfg_path, "draw", pen_file, "--backend", "fake")
    assert code == 0 and len(polls) == 3
    assert err.count("standard input is closed: waiting for `vplotter continue`") == 3
    assert out.count("continuing pid") == 3 and "going on with the green pen" in out
    r, w = os.pipe()                                  # a terminal where nobody types
    with os.fdopen(r) as f:
        calls = []
        assert draw_cmd.wait_enter(f, lambda: False, poll_s=0,
                                   go=lambda: calls.append(1) or len(calls) > 2)
    os.close(w)
    assert len(calls) == 3


@pytest.mark.parametrize("power_cut", [False, True])
def test_a_resume_on_a_tool_change_line_asks_for_that_pen_once(
        capsys, cfg_path, tmp_path, monkeypatch, power_cut):
    """A G-code tool change lifts the pen, pauses and lowers it on one line: stopped while
    waiting there, or a power cut on the way back from the change point (the journal names
    that line), the resumed draw asks for that pen, not the one before it."""
    f = pens_file(tmp_path, monkeypatch, MID_STROKE, MID_PENS, lift=True)
    t1, t2 = tmp_path / "t1.csv", tmp_path / "t2.csv"
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0

    def meanwhile(k):
        if k == 1:
            assert nested("continue") == 0
        else:
            os.kill(os.getpid(), signal.SIGINT)

    code, polls = detached_draw(capsys, cfg_path, f, monkeypatch, meanwhile, "--trace", t1)
    assert code == 130 and len(polls) == 2
    capsys.readouterr()
    pos = state.load()
    assert pos.extra["resume"]["line"] == 7
    _resume_asks_blue_then_green(monkeypatch, capsys, cfg_path, f, pos, t1, t2,
                                 _cut_power(pos, 7, "up") if power_cut else [])


def test_the_servo_backends_take_each_pens_own_pulse(tmp_path):
    """gpiozero's servo spans every pulse width the pens use; lgpio refuses one it cannot make
    when it opens, before anything moves."""
    from support.fake_lgpio import FakeLgpio, SimClock
    from support.backends import gpiozero_backend, make_rows, mock_outputs
    from vplotter.backends import create
    from vplotter.errors import BackendError

    cfg = config.load(write_config(tmp_path, '[pens.blue]\ncolour = "#0000ff"\ndown_us = 2000\n'))
    clock = SimClock(tick_ns=1000)
    b, factory = gpiozero_backend(cfg, clock)
    with b:
        b.play(make_rows([0, 10], [0, 0], [2000, 2000]))
        assert mock_outputs(cfg, factory)[1] == 2000
    bad = config.load(write_config(tmp_path, '[pens.blue]\ncolour = "#0000ff"\ndown_us = 2600\n'))
    with pytest.raises(BackendError, match="not 2600"):
        create("lgpio", bad, lgpio=FakeLgpio(clock), clock=clock.now, sleep=clock.sleep).open()


def _cut_power(pos, line: int, pen: str) -> list[str]:
    """Turn a clean stop's state into what a power cut leaves (an unclean stop, the journal's
    last record at `line` with the pen `pen`); the draw options that resume from it."""
    resume = pos.extra.pop("resume")
    pos.clean = False
    pos.extra["drawing"] = {k: resume[k] for k in ("file", "sha256", "options", "start")}
    state.save(pos)
    j = state.Journal()
    j.record(pos.counts, (0, 0), line, pen)
    j.close()
    return ["--trust-position"]


def _resume_asks_blue_then_green(monkeypatch, capsys, cfg_path, f, pos, t1, t2, extra):
    """`draw --resume` (Enter at each prompt) asks for the blue pen, then the green one, and
    the two traces together draw the file."""
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n\n"))
    code, out, _ = run(capsys, "--config", cfg_path, "draw", f, "--backend", "fake",
                       "--resume", "--trace", t2, *extra)
    assert code == 0
    assert [line for line in out.splitlines() if line.startswith("pause:")] == [
        "pause: put in the blue pen (2 of 3), then press Enter",
        "pause: put in the green pen (3 of 3), then press Enter"]
    xy = watchless_xy(cfg_path, pos)
    covers(np.vstack([drawn(t1, cfg_path), drawn(t2, cfg_path, tuple(xy))]), f)


def test_a_background_draw_waits_for_continue_at_a_plain_pause_too(capsys, cfg_path,
                                                                   monkeypatch, tmp_path):
    """M0 (or --pause-between-layers) in a background draw: it waits for `vplotter continue`
    as at a pen change, instead of being refused or skipped."""
    f = tmp_path / "m0.ngc"
    f.write_text("G1 X0 Y0 Z-1 F600\nG1 X10\nG0 Z5\nM0 (turn the paper)\nG1 Z-1\nG1 Y10\nG0 Z5\n")
    assert run(capsys, "--config", cfg_path, "calibrate", "--at", "0", "0")[0] == 0
    seen = []

    def meanwhile(k):
        seen.append(capsys.readouterr().out)
        assert nested("continue") == 0

    code, polls = detached_draw(capsys, cfg_path, f, monkeypatch, meanwhile)
    assert code == 0 and len(polls) == 1
    assert seen[0].splitlines()[-1] == ("pause: turn the paper; waiting: `vplotter continue` "
                                        "goes on")
