"""--style auto in two processes (`drawing/photo_fork.py`): the stipples searched, scored and
finished in a forked child give the drawing and note one process gives; a child's vplotter
error is the convert's; a child that fails otherwise is redone here."""

from __future__ import annotations

import os

import numpy as np
import pytest

from vplotter.drawing import advice, photo, photo_auto, photo_fork
from vplotter.errors import ConfigError
from vplotter.inputs.image.picture import Picture

QUICK = {"hatch": 0.70, "squiggle": 0.75, "spiral": 0.74, "flow": 0.60, "stipple": 0.73}
BOUND = {"hatch": 0.70, "squiggle": 0.75, "spiral": 0.74, "flow": 0.74, "stipple": 0.745}
FINAL = {"hatch": 0.71, "squiggle": 0.71, "spiral": 0.72, "flow": 0.99, "stipple": 0.99}
PIC = Picture(np.linspace(0, 1, 64, dtype=np.float32).reshape(8, 8), 8.0, 8.0)


class _Searched:
    def __init__(self, style, d):
        self.style, self.d = style, d
        self.choice = type("C", (), {"time_s": 60.0, "spacing_mm": 2})


def _auto(monkeypatch, workers: int, search=None, finished=None):
    """(placed, note) of the fake styles' --style auto; placed: [style, pid that finished]."""
    monkeypatch.setattr(photo_fork, "WORKERS", workers)
    monkeypatch.setattr("vplotter.drawing.photo_curve.quick_score",
                        lambda s, dark: (QUICK[s.style], BOUND[s.style]))
    monkeypatch.setattr(photo_auto, "tone_score", lambda raw, pictures, pen: FINAL[raw])
    opts = [photo.PhotoOptions(style=s) for s in photo_auto.AUTO_STYLES]

    def begin(o):
        return type("D", (), {"style": o.style, "drawn_last": {}})(), advice.Said()

    def finish(s, said):
        return [s.style, os.getpid()], said, s.style, 55.0

    placed, said = photo_auto.auto(opts, begin, search or (lambda d: _Searched(d.style, d)),
                                   finished or finish, (PIC, None, None))
    return placed, said.notes[0]


@pytest.fixture
def forks():
    child = photo_fork.start(lambda send: send(os.getpid()))
    if child is None:
        pytest.skip("no fork here (another thread, one core or not Linux)")
    try:
        assert child.get() != os.getpid()
    finally:
        child.close()


def test_the_child_draws_the_stipples_and_the_drawing_is_the_same(monkeypatch, forks):
    one, note = _auto(monkeypatch, 1)
    two, note2 = _auto(monkeypatch, 2)
    assert note2 == note and note.startswith("--style auto chose stipple (tone 0.990")
    assert one == ["stipple", os.getpid()] and two[0] == "stipple" and two[1] != os.getpid()


def test_a_childs_error_is_the_converts(monkeypatch, forks):
    def search(d):
        if d.style == "stipple":
            raise ConfigError("error: --max-time 1:00 is too short for this picture")
        return _Searched(d.style, d)

    with pytest.raises(ConfigError, match="too short for this picture"):
        _auto(monkeypatch, 2, search=search)


@pytest.mark.parametrize("how", ["raises", "dies"])
def test_a_child_that_fails_is_redone_here(monkeypatch, forks, how):
    me = os.getpid()

    def finish(s, said):
        if os.getpid() != me and how == "raises":
            raise RuntimeError("a bug in the child")
        if os.getpid() != me:
            os._exit(3)                 # killed: nothing sent
        return [s.style, os.getpid()], said, s.style, 55.0

    placed, note = _auto(monkeypatch, 2, finished=finish)
    assert placed == ["stipple", me] and note.startswith("--style auto chose stipple")
