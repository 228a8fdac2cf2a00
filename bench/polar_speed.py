"""Planning speed of the polar plotter (examples/polar.toml, step/dir rows) on a dry run.

Prints, for each file (default: gcode_samples/polar/*.ngc): steps of each motor, output rows
(a step is up to three rows: DIR, STEP high, STEP low), the planning CPU time of the whole
pipeline (parse, segment, plan, turns at the centre, step times, step/dir words; no trace
writing), steps per CPU second and plot time / CPU time (a Pi Zero is about 20x slower).

Run: python -m bench.polar_speed [FILE ...]
"""

from __future__ import annotations

import glob
import os
import sys
import time

import numpy as np

from vplotter import config, kinematics, pipeline
from vplotter.inputs import gcode

from bench import ROOT


def main(files: list[str]) -> None:
    cfg = config.load(os.path.join(ROOT, "examples", "polar.toml"))
    kin = kinematics.from_config(cfg)
    q = kin.inverse(kin.to_machine(np.array([[0.0, 0.0]])))[0]
    print("| file | rotary steps | linear steps | rows | planning CPU | steps / CPU s | plot time "
          "| plot / CPU |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for path in files:
        summary = pipeline.Summary()
        rows = 0
        t0 = time.process_time()
        for r in pipeline.stream(cfg, gcode.read(path, warn=lambda *a, **k: None), (0, 0), q,
                                 path, summary=summary):
            rows += len(r)
        cpu = time.process_time() - t0
        steps = int(summary.steps.sum())
        print(f"| {os.path.relpath(path, ROOT)} | {summary.steps[0]:,} | {summary.steps[1]:,} | "
              f"{rows:,} | {cpu:.2f} s | {steps / cpu / 1e6:.2f} M | {summary.time_s:.1f} s | "
              f"{summary.time_s / cpu:,.0f}x |")


if __name__ == "__main__":
    main(sys.argv[1:] or sorted(glob.glob(os.path.join(ROOT, "gcode_samples", "polar", "*.ngc"))))
