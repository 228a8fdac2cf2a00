"""The page's answers come from values: the web handlers turn the result objects and errors of
the Machine (commands/serve.py) into JSON, and a command run in a subprocess hands its result
back on a pipe of its own (commands/common.answering), never as printed words to be parsed."""

from __future__ import annotations

import asyncio
import json
import os

import pytest

from vplotter.commands.common import RESULT_FD, answering
from vplotter.commands.draw import DrawStarted
from vplotter.commands.live import Continued, Stopped
from vplotter.commands.machine import Jogged, PenMoved
from vplotter.commands.serve import CommandFailed
from vplotter.errors import BusyError, MachineError, VplotterError

pytest.importorskip("starlette", reason="serve needs starlette")


class FakeMachine:
    """Answers with the values it is given (or raises them); never prints anything."""

    def __init__(self, **answers):
        self.answers = answers
        self.asked: list[tuple] = []

    def _give(self, name, *args):
        self.asked.append((name, *args))
        got = self.answers[name]
        if isinstance(got, BaseException):
            raise got
        return got

    def draw(self, path, resume, options=None):
        return self._give("draw", path, resume, *([options] if options else []))

    def stop(self):
        return self._give("stop")

    def continue_(self):
        return self._give("continue")

    def pen(self, state, up_us=None, down_us=None):
        return self._give("pen", state, *([up_us, down_us] if up_us or down_us else []))

    def jog(self, dx, dy):
        return self._give("jog", dx, dy)

    def options(self, path, wanted, taken_only=False):
        return dict(wanted or {})

    def holder(self):
        return None

    def busy_line(self, holder):
        return "plotter busy: never asked"

    def status(self):
        return {}

    def error_line(self, e):
        from vplotter.commands.serve import Machine

        return Machine.error_line(self, e)


class Request:
    def __init__(self, body: dict | None = None):
        self._body = json.dumps(body).encode() if body is not None else b""

    async def body(self):
        return self._body


def handlers(tmp_path, machine):
    from vplotter.web import api
    from vplotter.web.files import Folder

    folder = Folder(tmp_path / "uploads")
    (tmp_path / "uploads" / "a.ngc").write_text("G21\n")
    return api.Handlers(api.State(machine, folder, lambda: True))


def call(h, name: str, body: dict | None = None):
    r = asyncio.run(getattr(h, name)(Request(body)))
    return r.status_code, json.loads(r.body)


def test_draw_and_stop_answer_the_values_the_machine_returns(tmp_path):
    m = FakeMachine(draw=DrawStarted(4321, "/state/draw.log", "a.ngc: 12 strokes ordered "),
                    stop=Stopped(4321, command="vplotter draw a.ngc", where="pen at X1.000 Y2.000",
                                 clean=False, resume="/up/a.ngc"))
    h = handlers(tmp_path, m)
    assert call(h, "draw", {"file": "a.ngc"}) == (202, {"pid": 4321,
                                                         "message": "a.ngc: 12 strokes ordered"})
    assert m.asked[0] == ("draw", str(tmp_path / "uploads" / "a.ngc"), False)
    code, got = call(h, "stop")
    assert code == 200 and got == {
        "stopped": True, "message": "stopped pid 4321 (vplotter draw a.ngc): pen at X1.000 "
                                    "Y2.000 (not a clean stop: see vplotter status)"}
    m.answers["stop"] = Stopped(why="no vplotter is driving the plotter")
    assert call(h, "stop") == (200, {"stopped": False, "message": "nothing to stop: no vplotter "
                                                                  "is driving the plotter"})


def test_moves_answer_their_values_and_errors_as_the_command_line_says_them(tmp_path):
    m = FakeMachine(pen=PenMoved("down"), jog=Jogged(3.0, 4.0),
                    **{"continue": Continued(77, "put in the red pen (2 of 3)")})
    h = handlers(tmp_path, m)
    assert call(h, "pen", {"state": "down"}) == (200, {"pen": "down", "message": "pen down"})
    assert call(h, "jog", {"dx": 1, "dy": 0}) == (200, {"dx": 1.0, "dy": 0.0, "message": ""})
    assert call(h, "go_on") == (200, {"continued": True,
                                      "message": "continuing pid 77: put in the red pen (2 of 3)"})
    # errors: the exit status decides the HTTP status, the CLI's line is the message
    m.answers["draw"] = CommandFailed("vplotter: error: nothing to resume: no interrupted draw "
                                      "is stored", 2)
    assert call(h, "draw", {"file": "a.ngc", "resume": True}) == (
        400, {"error": "vplotter: error: nothing to resume: no interrupted draw is stored"})
    m.answers["pen"] = BusyError("plotter busy: pid 9 (vplotter draw b.ngc) since 10:00",
                                 {"pid": 9, "command": "vplotter draw b.ngc", "since": 0})
    code, got = call(h, "pen", {"state": "up"})
    assert code == 409 and got["error"].startswith("plotter busy: pid 9 (vplotter draw b.ngc)")
    m.answers["stop"] = VplotterError("pid 9 has not stopped within 60 s")
    assert call(h, "stop") == (500, {"error": "vplotter: error: pid 9 has not stopped within 60 s"})
    m.answers["continue"] = MachineError("error: nothing to continue: pid 9 is not waiting at a "
                                         "pause")
    assert call(h, "go_on") == (409, {"error": "error: nothing to continue: pid 9 is not waiting "
                                               "at a pause"})


def _answered(monkeypatch, run) -> dict:
    r, w = os.pipe()
    monkeypatch.setenv(RESULT_FD, str(w))
    try:
        run()
    finally:
        assert RESULT_FD not in os.environ         # not passed on to what the command starts
    with os.fdopen(r, "rb") as f:
        return json.loads(f.read())


def test_a_command_hands_its_result_or_its_error_line_on_the_pipe(monkeypatch):
    def ok():
        with answering() as answer:
            answer(PenMoved("up"))

    assert _answered(monkeypatch, ok) == {"result": {"action": "up"}}

    def fails():
        with pytest.raises(MachineError), answering():
            raise MachineError("error: jog target X900.000 Y0.000 is outside the page")

    assert _answered(monkeypatch, fails) == {
        "error": "vplotter: error: jog target X900.000 Y0.000 is outside the page", "exit_code": 2,
        "kind": "MachineError"}
