"""Planning speed and plot-time quality of a dry run.

Prints, for car.ngc and a large generated file:
- planning speed: steps per CPU second and planned plot time / CPU time (the full dry-run
  pipeline: parse, segment, plan, step schedule, coil words; no trace writing);
- planned plot time versus the lower bound the limits allow (sum over pieces of
  max(left steps, right steps) / max_step_rate and length / speed cap, plus pen settle times)
  and versus a planner that stops at every corner.

Run: python bench/plan_speed.py [FILE ...]
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import time

import numpy as np

from vplotter import config, kinematics, pipeline, planner
from vplotter.inputs import gcode
from vplotter.schedule import Scheduler

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def big_file(path: str, n_lines: int = 40_000, per: int = 2000) -> str:
    """A dense drawing: rosettes of `per` moves each (short G1 lines, every tenth a G3 arc)."""
    rng = np.random.default_rng(1)
    out = ["G21 G90", "G00 Z5"]
    for k in range(max(1, n_lines // per)):
        cx, cy = rng.uniform(-120, 120), rng.uniform(-150, 200)
        r = rng.uniform(20, 45)
        out.append(f"G00 X{cx + r:.4f} Y{cy:.4f}")
        out.append("G01 Z-1 F600")
        for i in range(1, per):
            a = 2 * math.pi * i / per * 7
            rr = r * (0.6 + 0.4 * math.cos(5 * a / 7))
            x, y = cx + rr * math.cos(a), cy + rr * math.sin(a)
            if i % 10 == 0:
                out.append(f"G03 X{x:.4f} Y{y:.4f} R{rr:.4f}")
            else:
                out.append(f"G01 X{x:.4f} Y{y:.4f}")
        out.append("G00 Z5")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")
    return path


def records(path):
    return gcode.read(path, warn=lambda m: None)


def peak_memory_mb(cfg, path) -> float:
    """Peak Python heap while streaming the whole file through the planner (no steps)."""
    import tracemalloc

    counts, ref = start_of(cfg)
    tracemalloc.start()
    pipeline.validate(cfg, records(path), counts, ref, path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def start_of(cfg):
    kin = kinematics.from_config(cfg)
    cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
    return (0, 0), cords


def bound_and_plan(cfg, path):
    """Lower bound (s) and planned time (s), walking the planner's blocks once."""
    counts, ref = start_of(cfg)
    rate = cfg.motors.max_step_rate
    lower = 0.0
    orig = Scheduler.motion

    def motion(self, block, emit=True):
        nonlocal lower
        n = self.targets(block)
        steps = np.abs(np.diff(n, axis=0)).max(axis=1)
        lower += float(np.maximum(steps / rate, block.d / block.cap).sum())
        return orig(self, block, emit)

    Scheduler.motion = motion
    try:
        summary = pipeline.validate(cfg, records(path), counts, ref, path)
    finally:
        Scheduler.motion = orig
    settles = (2 * summary.pen_downs + 1) * cfg.pen.settle_s
    return lower + settles, summary.time_s


def speed(cfg, path):
    counts, ref = start_of(cfg)
    t0 = time.process_time()
    steps = 0
    summary = pipeline.Summary()
    for rows in pipeline.stream(cfg, records(path), counts, ref, path, summary=summary):
        steps += len(rows)
    cpu = time.process_time() - t0
    return cpu, int(summary.steps.sum()), summary.time_s


def main(argv):
    cfg = config.load(os.path.join(ROOT, "config.toml"))
    tmp = tempfile.mkdtemp()
    files = argv or [os.path.join(ROOT, "gcode_samples", "car.ngc"), big_file(os.path.join(tmp, "big.ngc"))]
    print(f"{'file':<14}{'steps':>10}{'cpu s':>8}{'steps/cpu s':>13}{'plot s':>10}{'plot/cpu':>10}"
          f"{'bound s':>10}{'plan/bound':>11}{'stop-each s':>12}{'stop/bound':>11}")
    for path in files:
        cpu, steps, plot = speed(cfg, path)
        bound, planned = bound_and_plan(cfg, path)
        saved = planner.TAU_S
        planner.TAU_S = 0.0          # every corner becomes a full stop
        try:
            _, stop_each = bound_and_plan(cfg, path)
        finally:
            planner.TAU_S = saved
        print(f"{os.path.basename(path):<14}{steps:>10}{cpu:>8.2f}{steps / cpu:>13.0f}{plot:>10.1f}"
              f"{plot / cpu:>10.0f}{bound:>10.1f}{planned / bound:>11.3f}{stop_each:>12.1f}"
              f"{stop_each / bound:>11.3f}")
    if not argv:
        print("\nmemory is flat in the length of the file (peak Python heap, planning pass):")
        for n in (20_000, 160_000):
            path = big_file(os.path.join(tmp, f"big{n}.ngc"), n)
            size = os.path.getsize(path) / 1e6
            print(f"  {n:>6} moves ({size:5.1f} MB of G-code): {peak_memory_mb(cfg, path):6.1f} MB")


if __name__ == "__main__":
    main(sys.argv[1:])
