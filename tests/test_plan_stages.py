"""The plan in stages (motion/plan_stages.py) and its steps (motion/steps.py): each stage on
its own, the steps of a pen change and of a resume through `pipeline.plan`, and the reach
check of the machine kinds naming the file place as the page check does."""

from __future__ import annotations

import numpy as np
import pytest

from vplotter import config, kinematics, pipeline
from vplotter.cli import main
from vplotter.inputs import gcode
from vplotter.inputs.gcode import Move, Pause, Pen
from vplotter.motion import plan_stages as stages
from vplotter.motion.steps import Finish, Motion, PenMove, Start, Wait

from conftest import REPO

CFG = config.load(REPO / "config.toml")
KIN = kinematics.from_config(CFG)
POLAR = REPO / "examples" / "polar.toml"
BLUE = Pause(5, 1, "", "blue", 2, 2)


def _where(line, col):
    return f"f:{line}:{col}"


def _pens(down: bool, records) -> list:
    return list(stages.PenChanges(CFG, (0.0, 0.0), down, (10.0, 20.0), _where).run(records))


def test_a_pen_change_with_the_pen_down_goes_to_the_change_point_and_back():
    out = _pens(False, [Pen(3, 1, True), Move(4, 1, 0.0, 0.0, 5.0, 0.0), BLUE,
                        Move(6, 1, 5.0, 0.0, 9.0, 0.0)])
    assert out[0] == PenMove(True, 3)
    assert isinstance(out[1], stages.Path) and out[1].draw and out[1].line == 4
    assert out[2:7] == [PenMove(False, 5), stages.Travel((10.0, 20.0), 5, 1), Wait(BLUE),
                        stages.Travel((5.0, 0.0), 5, 1), PenMove(True, 5)]
    assert out[7].draw and out[7].line == 6 and len(out) == 8


def test_with_the_pen_up_it_parks_and_goes_back_only_to_put_the_pen_down():
    out = _pens(False, [Move(4, 1, 0.0, 0.0, 5.0, 0.0), BLUE, Pen(6, 1, True)])
    assert out[1:] == [stages.Travel((10.0, 20.0), 5, 1), Wait(BLUE),
                       stages.Travel((5.0, 0.0), 6, 1), PenMove(True, 6)]
    # a move that goes somewhere takes the gondola off the change point: no travel back
    out = _pens(False, [BLUE, Move(6, 1, 0.0, 0.0, 7.0, 0.0), Pen(7, 1, True)])
    assert out[2:] == [out[2], PenMove(True, 7)] and isinstance(out[2], stages.Path)
    assert not out[2].draw and out[2].cap == CFG.motion.travel_speed_mm_s


def test_the_resume_filter_remembers_the_pen_and_the_last_change():
    recs = [Move(1, 1, 0.0, 0.0, 3.0, 4.0), Pen(2, 1, True), BLUE,
            Move(7, 1, 3.0, 4.0, 13.0, 4.0), Pen(8, 1, False)]
    at = pipeline.StartAt(7, (8.0, 4.0))
    out = list(stages.resumed(recs, at, (1.0, 1.0), False,
                              lambda m: np.array([[m.x1, m.y1]]), "f"))
    assert out[:5] == [stages.At(False, (3.0, 4.0)), BLUE, stages.At(True, (3.0, 4.0)),
                       stages.Travel((8.0, 4.0), 7, 1), stages.FULL_STOP]
    assert out[5] == PenMove(True, 7)
    assert isinstance(out[6], stages.CutMove) and out[6].pts.tolist() == [[13.0, 4.0]]
    assert out[7:] == [Pen(8, 1, False)]
    with pytest.raises(Exception, match="f: error: line 9 is past the last move of the file"):
        list(stages.resumed(recs, pipeline.StartAt(9), (1.0, 1.0), False, None, "f"))


def test_a_pen_change_in_the_plan_stands_at_the_change_point():
    recs = [Pen(2, 1, True), Move(3, 1, 0.0, 0.0, 20.0, 0.0), BLUE,
            Move(6, 1, 20.0, 0.0, 20.0, 20.0), Pen(7, 1, False)]
    counts, ref = (0, 0), KIN.inverse(KIN.to_machine([[0.0, 0.0]]))[0]
    summary = pipeline.Summary()
    steps = list(pipeline.plan(CFG, recs, counts, ref, "f", summary, park=(-30.0, 10.0)))
    kinds = [type(s).__name__ for s in steps]
    assert kinds == ["Start", "PenMove", "Motion", "PenMove", "Motion", "Wait", "Motion",
                     "PenMove", "Motion", "PenMove", "Finish"]
    assert steps[0] == Start(None) and steps[-1] == Finish(True)
    to_change, back = steps[4].block, steps[6].block
    assert KIN.to_gcode(to_change.verts[-1]).tolist() == pytest.approx([-30.0, 10.0])
    assert not to_change.drawing.any() and to_change.v1[-1] == 0.0
    assert KIN.to_gcode(back.verts[-1]).tolist() == pytest.approx([20.0, 0.0])
    assert steps[3] == PenMove(False, 5) and steps[7] == PenMove(True, 5)
    assert (summary.moves, summary.pen_downs, summary.motors) == (2, 1, ("left", "right"))
    assert summary.pieces == sum(len(s.block.d) for s in steps if isinstance(s, Motion))
    assert summary.drawn_mm == pytest.approx(40.0) and summary.travel_mm > 60.0


def test_the_reach_check_belongs_to_the_machine_kind():
    pts = np.array([[10.0, 0.0], [70.0, 0.0], [80.0, 0.0]])
    assert KIN.check_move(KIN.to_machine(pts), np.zeros(2)) == -1
    polar = kinematics.from_config(config.load(POLAR))
    assert polar.check_move(pts, np.zeros(2)) == 1
    assert polar.cannot_reach(70.0, 0.0) == ("the pen cannot reach X70.000 Y0.000 or the line "
                                             "to it (the arm reaches 0..65 mm from the "
                                             "table's centre)")


def test_a_reach_error_in_a_placed_svg_names_the_element(tmp_path, capsys):
    svg = tmp_path / "far.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="120mm" height="120mm" '
                   'viewBox="0 0 120 120">\n<path id="near" d="M 50 50 L 60 60"/>\n'
                   '<path id="far" d="M 60 60 L 119 1"/>\n</svg>\n')
    assert main(["--config", str(POLAR), "calibrate", "--at", "0", "0"]) == 0
    capsys.readouterr()
    assert main(["--config", str(POLAR), "draw", str(svg), "--dry-run"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{svg}: element far: error: the pen cannot reach X59.000 Y59.000 or the "
                   "line to it (the arm reaches 0..65 mm from the table's centre)"]


def test_a_reach_error_in_gcode_drawn_as_it_is_names_line_and_column(tmp_path, capsys):
    g = tmp_path / "g.ngc"
    g.write_text("G21 G90\nG0 X10 Y10\n  G1 X60 Y40\n")
    assert main(["--config", str(POLAR), "calibrate", "--at", "0", "0"]) == 0
    assert main(["--config", str(POLAR), "draw", str(g), "--dry-run"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == (f"{g}:3:3: error: the pen cannot reach X60.000 Y40.000 or the line to "
                       "it (the arm reaches 0..65 mm from the table's centre)")


def test_the_plan_is_made_of_steps():
    recs = list(gcode.read(str(REPO / "gcode_samples" / "square.ngc"), warn=lambda m: None))
    counts, ref = (0, 0), KIN.inverse(KIN.to_machine([[0.0, 0.0]]))[0]
    steps = list(pipeline.plan(CFG, recs, counts, ref, "sq", pipeline.Summary()))
    assert all(type(s).__module__ == "vplotter.motion.steps" for s in steps)
