"""The validation pass times a block in one go (`Scheduler.quiet`): the same plot time, steps
and motor phases as the block timed part by part (`Scheduler.motion(part, emit=False)`), also
when a block is cut into many parts."""

from __future__ import annotations

import os

import numpy as np
import pytest

from vplotter import config, kinematics, pipeline
from vplotter.inputs import gcode
from vplotter.motion.schedule import Scheduler

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class PartByPart(Scheduler):
    """The scheduler timed part by part (its motion is not Scheduler's, so no quiet pass)."""

    last = None

    def __init__(self, *args):
        super().__init__(*args)
        type(self).last = self

    def motion(self, block, emit=True):
        return super().motion(block, emit)


class Quiet(PartByPart):
    motion = Scheduler.motion


def timed(cfg, path, scheduler):
    kin = kinematics.from_config(cfg)
    ref = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
    recs = gcode.read(path, warn=lambda m: None)
    s = pipeline.validate(cfg, recs, (0, 0), ref, path, scheduler=scheduler)
    sched = scheduler.last
    return s.time_s, s.steps.tolist(), sched.counts.tolist(), sched.t_us, str(vars(sched.drv))


@pytest.mark.parametrize("name", ["car.ngc", "strokes.ngc", "circles.ngc"])
@pytest.mark.parametrize("part_steps", [10_000, 300])
def test_quiet_is_part_by_part(name, part_steps, monkeypatch):
    monkeypatch.setattr(pipeline, "STEPS_PER_PART", part_steps)
    cfg = config.load(os.path.join(ROOT, "config.toml"))
    path = os.path.join(ROOT, "gcode_samples", name)
    assert Quiet.motion is Scheduler.motion and PartByPart.motion is not Scheduler.motion
    quiet = timed(cfg, path, Quiet)
    assert quiet == timed(cfg, path, PartByPart)
    assert quiet[0] > 0 and np.sum(quiet[1]) > 0
