"""Streaming to a grbl controller: the stand-in on a pty pair (tests/support/grbl_standin.py)
plays it.

What the user sees is checked: every line answered, nothing lost or reordered in the receive
buffer, the controller's end position, the drawn path (the motor-space moves it executed,
mapped back through tracecheck's own forward kinematics) against tracecheck's own reading of
the G-code, Ctrl+C and resume, errors and a vanished controller.
"""

import io
import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, strategies as st

from support import tracecheck as tc
from support.grbl_standin import GrblStandin
from vplotter import config, kinematics
from vplotter.motion import linestream, motorcut
from vplotter.machine import history, state
from vplotter.backends import grbl
from vplotter.cli import main

from support import REPO

CAR = REPO / "gcode_samples" / "car.ngc"
SQUARE = REPO / "gcode_samples" / "square.ngc"
CIRCLES = REPO / "gcode_samples" / "circles.ngc"


@pytest.fixture
def standins():
    made = []

    def make(**kw):
        g = GrblStandin(**kw)
        made.append(g)
        return g

    yield make
    for g in made:
        g.stop()


def serial_config(tmp_path, port, **serial):
    keys = {"port": port, "timeout_s": 2.0, **serial}
    text = (REPO / "config.toml").read_text() + "\n[serial]\n" + "".join(
        f"{k} = {json.dumps(v)}\n" for k, v in keys.items())
    path = tmp_path / "serial.toml"
    path.write_text(text)
    return path


def run(cfg_path, *argv):
    return main(["--config", str(cfg_path), *argv])


def calibrated(cfg_path):
    assert run(cfg_path, "calibrate", "--at", "0", "0") == 0


def drawn_polylines(cfg, segments):
    """The pen-down moves the controller executed (work coordinates = cords), densified in
    motor space to 0.005 mm and mapped to G-code X, Y by tracecheck's forward kinematics."""
    out = []
    for a, b, down in segments:
        if not down:
            continue
        a, b = np.asarray(a), np.asarray(b)
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / 0.005)))
        q = a + (np.arange(n + 1) / n)[:, None] * (b - a)
        x, y = tc.forward_kinematics(cfg, q[:, 0], q[:, 1])
        out.append(np.column_stack((x, y)))
    return out


def check_path(cfg_path, gfile, segments, tol=0.02):
    cfg = tc.load_config(str(cfg_path))
    drawn = drawn_polylines(cfg, segments)
    ref = tc.reference_path(str(gfile))
    assert drawn and ref
    off = tc.distances_to_polylines(np.concatenate(drawn), ref)
    miss = tc.distances_to_polylines(np.concatenate(ref), drawn)
    assert off.max() <= tol, f"drawn point {off.max():.4f} mm off the path"
    assert miss.max() <= tol, f"part of the path {miss.max():.4f} mm from the drawing"
    return off.max(), miss.max()


# ---------------------------------------------------------------- geometry
CFG = config.load(REPO / "config.toml")
KIN = kinematics.from_config(CFG)
page = st.tuples(st.floats(-200, 200), st.floats(-250, 300))


@given(a=page, b=page, tol=st.sampled_from([0.002, 0.0045, 0.02, 0.1]))
def test_motor_space_pieces_stay_within_tolerance_of_the_wall_line(a, b, tol):
    verts = KIN.to_machine(np.array([a, b]))
    pts, piece = motorcut.cut(KIN, verts, tol)
    assert np.allclose(pts[-1], verts[-1]) and (piece == 0).all()
    cords = KIN.inverse(np.vstack((verts[:1], pts)))
    # dense straight lines in motor space, back to the wall
    f = np.linspace(0.0, 1.0, 65)[None, :, None]
    dense = (cords[:-1, None, :] + f * (cords[1:, None, :] - cords[:-1, None, :])).reshape(-1, 2)
    wall = KIN.forward(dense)
    p0, e = verts[0], verts[1] - verts[0]
    d = np.linalg.norm(e)
    if d == 0:
        return
    e = e / d
    rel = wall - p0
    off = np.abs(rel[:, 0] * e[1] - rel[:, 1] * e[0])
    along = rel @ e
    assert off.max() <= tol * (1 + 1e-6) + 1e-9
    assert along.min() >= -1e-6 and along.max() <= d + 1e-6
    # adaptive, not a fixed tiny length: pieces are as long as the bound allows (>= 1 mm here)
    assert len(pts) <= max(1, d / 1.0) + 1


def test_lines_for_car_are_few_and_the_stream_is_what_a_dry_run_saves(tmp_path, capsys):
    out = tmp_path / "car.gcode"
    assert run(REPO / "config.toml", "draw", str(CAR), "--dry-run", "--backend", "serial",
               "--save-stream", str(out)) == 0
    text = capsys.readouterr().out
    lines = out.read_text().splitlines()
    assert f"{len(lines)} lines to stream" in text
    assert lines[:2] == ["G21G90G94", "G92X479.089Y479.089"]
    assert all(len(ln) < 127 for ln in lines)
    assert run(REPO / "config.toml", "estimate", str(CAR)) == 0
    pieces = int(capsys.readouterr().out.split(" pieces")[0].split()[-1])
    assert len(lines) <= 3 * pieces, (len(lines), pieces)
    # the feeds keep the pen within its speed caps: pen speed = F / |d cords / d path|
    cfg = tc.load_config(str(REPO / "config.toml"))
    here, feed, down, fast = np.array([479.089, 479.089]), None, False, 0.0
    for ln in lines[2:]:
        if ln.startswith("M3"):
            down = True
        elif ln.startswith("M5"):
            down = False
        elif ln.startswith("G1"):
            body, _, f = ln[3:].partition("F")
            feed = float(f) if f else feed
            new = np.array([float(v) for v in body.split("Y")])
            xy = np.column_stack(tc.forward_kinematics(cfg, [here[0], new[0]], [here[1], new[1]]))
            wall, cord = np.linalg.norm(xy[1] - xy[0]), np.linalg.norm(new - here)
            speed = feed / 60.0 * wall / cord
            assert speed <= (4.0 if down else 8.0) * 1.001, ln
            fast = max(fast, speed / (4.0 if down else 8.0))
            here = new
    assert fast > 0.97                            # and not needlessly slower


def test_xy_axes_send_gcode_coordinates(tmp_path):
    cfg_path = serial_config(tmp_path, "/dev/null", axes="xy", feed_scale=2.0)
    out = tmp_path / "sq.gcode"
    assert run(cfg_path, "draw", str(SQUARE), "--dry-run", "--backend", "serial",
               "--save-stream", str(out)) == 0
    lines = out.read_text().splitlines()
    assert lines[1] == "G92X0Y0"
    moves = [ln for ln in lines if ln.startswith("G1")]
    assert len(moves) <= 12                       # one line per piece: no motor-space cutting
    assert "F960.0" in moves[0]                   # travel 8 mm/s x 60 x feed_scale 2


# ---------------------------------------------------------------- streaming
def test_car_streams_every_line_without_overflow_and_draws_the_path(tmp_path, standins, capsys):
    g = standins(tick_s=2.0)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    sent = tmp_path / "sent.gcode"
    assert run(cfg_path, "draw", str(CAR), "--backend", "serial", "--save-stream", str(sent)) == 0
    lines = sent.read_text().splitlines()
    assert g.overflow == 0 and g.max_rx <= 127
    # character counting, not send-and-wait: the buffer was kept nearly full behind a full planner
    assert g.max_rx > 100 and g.max_planned == 15
    assert g.received == [ln.replace(" ", "").upper() for ln in lines]   # all, in order
    assert g.answered == len(lines)
    assert g.state == "Idle" and not g.pen_down
    # the controller ends where the plan ends (car.ngc ends at X0 Y0)
    end = KIN.inverse(KIN.to_machine(np.array([[0.0, 0.0]])))[0]
    assert np.allclose(g.wpos(), end, atol=1e-3)
    check_path(cfg_path, CAR, g.segments)
    pos = state.load()
    assert pos.clean and pos.pen == "up"
    assert abs(pos.left_mm - end[0]) < 0.01 and abs(pos.right_mm - end[1]) < 0.01


def test_slow_replies_and_a_tiny_buffer_still_never_overflow(tmp_path, standins):
    g = standins(tick_s=0.5, reply_delay=4, rx_buffer=64)
    cfg_path = serial_config(tmp_path, g.port, rx_buffer=64)
    calibrated(cfg_path)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 0
    assert g.overflow == 0 and g.max_rx <= 63
    check_path(cfg_path, SQUARE, g.segments)


def test_a_host_that_ignores_the_buffer_is_caught_by_the_standin(standins):
    """The stand-in is unkind: bytes beyond its receive buffer are lost and counted."""
    import serial

    g = standins(tick_s=0.0)
    port = serial.Serial(g.port, timeout=0.5)
    port.read_until(b"help]\r\n")
    port.write(b"G1X1Y1F100\n" * 40)
    port.read(20)
    port.close()
    assert g.overflow > 0


def interrupt_after_lines(monkeypatch, lines, signum=signal.SIGINT):
    """The signal arrives once the host has sent that many lines."""
    orig = grbl.Streamer.poll
    sent = {"done": False}

    def poll(self, now):
        if self.sent >= lines and not sent["done"]:
            sent["done"] = True
            os.kill(os.getpid(), signum)
        return orig(self, now)

    monkeypatch.setattr(grbl.Streamer, "poll", poll)
    return orig


@pytest.mark.parametrize("lost", [0, 1])
def test_ctrl_c_holds_lifts_resets_and_resume_completes(tmp_path, standins, monkeypatch, capsys,
                                                         lost):
    """lost: the controller drops that many `!` (grbl-sim can): the hold is sent again."""
    g = standins(tick_s=0.5, lose_holds=lost)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    orig = interrupt_after_lines(monkeypatch, 200)
    assert run(cfg_path, "draw", str(CIRCLES), "--backend", "serial") == 130
    err = capsys.readouterr().err
    assert "pen lifted" in err and "--resume" in err and "Traceback" not in err
    assert g.realtime.count(b"!") == 1 + lost and b"\x18" in g.realtime
    assert g.realtime.index(b"!") < g.realtime.index(b"\x18")
    assert not g.pen_down and g.state == "Idle"              # held before the reset: no alarm
    pos = state.load()
    assert pos.clean and pos.pen == "up"
    here = np.subtract(g.mpos, g.wco_lost)                  # cords where it stopped
    assert np.allclose([pos.left_mm, pos.right_mm], here, atol=0.01)   # the reported place
    first = list(g.segments)
    assert any(d for *_, d in first)
    done = KIN.to_gcode(KIN.forward(here[None, :]))[0]
    assert np.allclose(pos.extra["resume"]["xy"], done, atol=0.01)

    monkeypatch.setattr(grbl.Streamer, "poll", orig)
    assert run(cfg_path, "draw", str(CIRCLES), "--backend", "serial", "--resume") == 0
    assert g.overflow == 0
    # the history keeps both, as for the GPIO backends: stopped part way, then done
    stopped, done_ = history.read()
    assert (stopped["result"], done_["result"]) == ("stopped", "done")
    assert stopped["drawn_m"] > 0 and done_["drawn_m"] > 0
    # both parts together draw the whole file, and nothing else
    check_path(cfg_path, CIRCLES, g.segments)
    assert "resume" not in state.load().extra


def test_error_reply_stops_names_the_line_and_lifts_the_pen(tmp_path, standins, capsys):
    g = standins(tick_s=0.5)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    out = tmp_path / "s.gcode"
    assert run(cfg_path, "draw", str(SQUARE), "--dry-run", "--backend", "serial",
               "--save-stream", str(out)) == 0
    bad = out.read_text().splitlines()[40]
    g.error_on = bad.upper()
    capsys.readouterr()
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 1
    err = capsys.readouterr().err
    assert f"`{bad}`" in err and "error:20" in err and "line 41 of the stream" in err
    assert err.startswith(f"{SQUARE}:") and "Traceback" not in err
    assert not g.pen_down
    assert state.load().clean


def test_pulled_cable_saves_the_place_and_exits_1(tmp_path, standins, capsys):
    g = standins(tick_s=0.05, disconnect_after=80)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 1
    err = capsys.readouterr().err
    assert "lost the connection" in err or "stopped answering" in err
    assert "Traceback" not in err and "--resume" in err
    pos = state.load()
    assert not pos.clean                      # nobody knows what the motors did since
    rec = state.last_journal_record()
    assert rec is not None and rec["line"] > 0
    assert run(cfg_path, "status") == 0
    assert "UNCLEAN" in capsys.readouterr().out
    # a new controller on the same port: --resume --trust-position completes the drawing
    g2 = standins(tick_s=0.5)
    cfg_path = serial_config(tmp_path, g2.port)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 2    # refused: unclean
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial", "--resume",
               "--trust-position") == 0
    check_path(cfg_path, SQUARE, g.segments + g2.segments)   # both in cords (after G92)
    assert state.load().clean


def test_a_controller_that_stops_moving_is_an_error_not_a_hang(tmp_path, standins, capsys,
                                                              monkeypatch):
    """It answers `?` with Run and the same position for ever (grbl-sim can do that)."""
    monkeypatch.setattr(grbl, "STALL_S", 1.0)
    g = standins(tick_s=0.05, freeze_after=40)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 1
    err = capsys.readouterr().err
    assert "has not moved for 1 s" in err and "Traceback" not in err and "--resume" in err
    assert not state.load().clean
    assert state.last_journal_record()["line"] > 0


def test_alarm_stops_with_the_alarm_named_and_an_unclean_position(tmp_path, standins, capsys):
    g = standins(tick_s=0.5, alarm_after=30)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 1
    err = capsys.readouterr().err
    assert "ALARM:2" in err and "soft limit" in err and "Traceback" not in err
    assert not g.pen_down
    assert not state.load().clean


def test_a_controller_that_never_answers_is_an_error_not_a_hang(tmp_path, standins, capsys):
    g = standins(silent=True)
    cfg_path = serial_config(tmp_path, g.port, timeout_s=0.2)
    calibrated(cfg_path)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 1
    err = capsys.readouterr().err
    assert "no answer from a grbl controller" in err and "Traceback" not in err
    assert b"\x18" in g.realtime              # it tried a soft reset half-way
    assert state.load().clean                 # nothing moved


def test_a_second_vplotter_is_refused_before_the_port_is_opened(tmp_path, standins, capsys):
    g = standins()
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys; from vplotter.machine import lock; lock.acquire('vplotter "
         "draw car.ngc'); print('held', flush=True); sys.stdin.read()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(REPO / "src")})
    try:
        assert holder.stdout.readline() == "held\n"
        assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 3
    finally:
        holder.stdin.close()
        holder.wait()
    assert "plotter busy" in capsys.readouterr().err
    assert g.resets == 0 and g.received == []      # the controller was never touched


def test_missing_port_is_a_clear_error(tmp_path, capsys):
    cfg_path = serial_config(tmp_path, str(tmp_path / "ttyNONE"))
    calibrated(cfg_path)
    assert run(cfg_path, "draw", str(SQUARE), "--backend", "serial") == 1
    err = capsys.readouterr().err
    assert "cannot open the serial port" in err and "Traceback" not in err


# ---------------------------------------------------------------- check and console
def test_check_prints_settings_and_warns_where_they_contradict_config(tmp_path, standins, capsys):
    g = standins(settings={110: 900.0, 100: 80.0})
    cfg_path = serial_config(tmp_path, g.port)
    assert run(cfg_path, "serial", "check") == 0
    cap = capsys.readouterr()
    assert "Grbl 1.1h" in cap.out and "[VER:1.1h" in cap.out and "$110=900" in cap.out
    assert "$110=900" in cap.err and "max_step_rate" in cap.err
    assert "$100=80" in cap.err and "$101" not in cap.err and "$120" not in cap.err
    assert g.received == ["$I", "$$"]          # only asked, never set


def test_console_sends_lines_and_realtime_commands(tmp_path, standins):
    from vplotter.commands.serial import console

    g = standins(tick_s=0.5)
    cfg = config.load(serial_config(tmp_path, g.port))
    out = io.StringIO()
    assert console(cfg, io.StringIO("?\nG92X0Y0\nG1X5Y0F600\n!\n?\n~\n\x18\n"), out) == 0
    text = out.getvalue()
    assert "<Idle|MPos:" in text and "ok" in text
    assert [b"?", b"!", b"?", b"~", b"\x18"] == [c for c in g.realtime if c != b"\x9e"]
    assert g.received == ["G92X0Y0", "G1X5Y0F600"]
    assert g.resets == 2 and text.count("Grbl 1.1h") >= 1


# ---------------------------------------------------------------- config and protocol
@pytest.mark.parametrize("key,value,words", [
    ("axes", "polar", "[serial] axes must be one of motors | xy"),
    ("pen_up", "M5\nM3", "[serial] pen_up must be one line"),
    ("rx_buffer", 4, "[serial] rx_buffer must be between 64"),
    ("feed_scale", 0, "[serial] feed_scale must be above 0"),
])
def test_bad_serial_config_names_the_key(tmp_path, capsys, key, value, words):
    cfg_path = serial_config(tmp_path, "/dev/null", **{key: value})
    assert run(cfg_path, "draw", str(SQUARE), "--dry-run", "--backend", "serial") == 2
    assert words in capsys.readouterr().err


def test_parse_status_reports():
    s = grbl.parse_status("<Hold:0|MPos:1.000,-2.500,0.000|Bf:15,128|FS:0,0|WCO:0.5,0.5,0>")
    assert s.state == "Hold:0" and s.mpos == (1.0, -2.5, 0.0) and s.bf == (15.0, 128.0)
    assert s.wco == (0.5, 0.5, 0.0)
    assert grbl.parse_status("ok") is None
    assert grbl.BANNER.match("Grbl 1.1h ['$' for help]")
    assert grbl.BANNER.match("GrblHAL 1.1f ['$' or '$HELP' for help]")


def test_help_does_not_import_pyserial():
    code = ("import sys; from vplotter.cli import main; rc = main(['serial', '--help']); "
            "print([m for m in ('serial', 'numpy') if m in sys.modules]); sys.exit(rc)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": str(REPO / "src")})
    assert r.returncode == 0 and r.stdout.strip().endswith("[]")


def test_fmt_never_writes_minus_zero():
    assert linestream.fmt(-0.0001) == "0" and linestream.fmt(12.5) == "12.5"
    assert linestream.fmt(-3.0) == "-3"


def test_a_position_on_a_closed_shape_names_the_earlier_line():
    """At the point where a loop starts and ends, the line being drawn is the loop's first."""

    class Chunk:
        def __init__(self, q, lines):
            self.text = [f"G1X{x}Y{y}" for x, y in q]
            self.q = np.array(q, dtype=float)
            self.line = np.array(lines)
            self.down = np.ones(len(q), dtype=bool)
            self.t_us = np.arange(len(q))

        def __len__(self):
            return len(self.text)

    s = grbl.Streamer(link=None, rx_buffer=128)
    s.start_q = (0.0, 0.0)
    s._add(Chunk([(10, 0), (10, 10), (0, 10), (0, 0), (-5, 0)], [1, 2, 3, 4, 5]))
    s.acked = 5
    assert s.locate((0.004, -0.003)) == 0            # at the start, not the end of the loop
    assert s.locate((10, 5)) == 1
    s.current = 1
    assert s.locate((0.0, 0.003)) == 3               # later on, the loop's end
    assert s.locate((-2.0, 0.0)) == 4


@given(st.text(max_size=80))
def test_parse_status_never_raises(text):
    s = grbl.parse_status(text)
    assert s is None or (text.startswith("<") and text.endswith(">"))


@given(st.lists(st.tuples(st.sampled_from(["Idle", "Run", "Hold:0", "Hold:1", "Alarm"]),
                          st.floats(-1e4, 1e4), st.floats(-1e4, 1e4)), min_size=1, max_size=5))
def test_parse_status_reads_what_grbl_prints(reports):
    for state_, x, y in reports:
        s = grbl.parse_status(f"<{state_}|MPos:{x:.3f},{y:.3f},0.000|FS:0,0|Pn:XYZ>")
        assert s.state == state_ and s.mpos[:2] == (float(f"{x:.3f}"), float(f"{y:.3f}"))


TWO_PENS = """G21 G90
M0 (pen: black)
G0 Z5
G0 X0 Y0
G1 Z-1 F600
G1 X20
G1 Y20
G0 Z5
M0 (pen: red)
G0 X-20 Y0
G1 Z-1
G1 X-40
G1 Y-10
G0 Z5
"""


def test_pen_changes_wait_until_the_controller_has_run_all_before_them(tmp_path, standins,
                                                                      monkeypatch, capsys):
    """An M0 / pen change over serial: everything before it runs (Idle, pen up), then the
    prompt names the pen; Enter goes on, and the whole file is drawn."""
    g = standins(tick_s=0.5)
    cfg_path = serial_config(tmp_path, g.port)
    calibrated(cfg_path)
    f = tmp_path / "two.ngc"
    f.write_text(TWO_PENS)
    seen = []

    class Person:
        def readline(self):
            seen.append((g.state, g.pen_down, g.answered))
            return "\n"

    monkeypatch.setattr(sys, "stdin", Person())
    capsys.readouterr()
    assert run(cfg_path, "draw", str(f), "--backend", "serial") == 0
    out = capsys.readouterr().out
    assert [ln for ln in out.splitlines() if ln.startswith("pause:")] == [
        "pause: put in the black pen (1 of 2), then press Enter",
        "pause: put in the red pen (2 of 2), then press Enter"]
    assert len(seen) == 2 and all(st == "Idle" and not down for st, down, _ in seen)
    assert seen[0][2] < seen[1][2] < g.answered        # lines ran between and after the waits
    check_path(cfg_path, f, g.segments)
