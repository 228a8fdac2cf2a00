"""Planning speed of car.ngc and of a large gcodetools-like file (bench/make/samples.py's
gcodetools_file, 16,000 lines) under each machine model (the full dry-run pipeline: parse,
segment, plan, step schedule, coil words; no trace writing).

The plain machine and the gondola model solve each step in closed form; stretch solves it
by bracketed Newton steps; the tilting gondola ([gondola] mass_below_pen_mm) solves its balance
once per sub-piece of 3 mm, a planned window at a time, and each step in closed form on an
osculating level model (kinematics/tilt_steps.py). Each tilt row is printed beside the same
model without tilt, and the last column says how much slower tilt makes it (CPU time, the
best of 5 runs, 3 on the large file; the runs are interleaved, one of each model in turn, so
that a busy machine slows every model alike). "planning CPU" streams the plan (parse, plan and
schedule in one pass, as a drawing too large to keep is drawn); "as `draw`" is what `vplotter
draw` does: the whole file checked and planned first (pipeline.validate), the kept plan then
scheduled (pipeline.replay). Sagging cords ([cords] mass_g_per_m,
kinematics/sag.py) solve their balance at every Newton step of every step's crossing (the exact
step solver): those rows are printed beside the same machine without sag. Run:
python -m bench.models_speed [--car-only] [--tilt | --sag] [--runs N] (--tilt, --sag: only the
rows that compare tilt, or sag, and what they are compared with)
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import time

from vplotter import config, pipeline
from vplotter.inputs import gcode

from bench import ROOT, start_of
from bench.make import samples


def main() -> None:
    files = [os.path.join(ROOT, "gcode_samples", "car.ngc")]
    if "--car-only" not in sys.argv:
        files.append(samples.gcodetools_file(os.path.join(tempfile.mkdtemp(), "gcodetools.ngc")))
    runs = int(sys.argv[sys.argv.index("--runs") + 1]) if "--runs" in sys.argv else None
    for path in files:
        print(f"\n{os.path.basename(path)}:\n")
        table(path, runs or (5 if path == files[0] else 3), "--tilt" in sys.argv)


def table(path: str, runs: int, tilt_only: bool = False) -> None:
    base = config.load(os.path.join(ROOT, "config.toml"))
    models = {
        "plain": base,
        "gondola 40 mm, pen 15 mm below": dataclasses.replace(
            base, gondola=config.Gondola(40.0, 15.0)),
        "per-motor spools": dataclasses.replace(base, motors=dataclasses.replace(
            base.motors, left_spool_circumference_mm=25.3, right_spool_circumference_mm=24.7)),
        "stretch 0.004": dataclasses.replace(base, cords=config.Cords(0.004)),
        "all of them": dataclasses.replace(
            base, gondola=config.Gondola(40.0, 15.0), cords=config.Cords(0.004),
            motors=dataclasses.replace(base.motors, left_spool_circumference_mm=25.3,
                                       right_spool_circumference_mm=24.7)),
        "gondola, tilting (mass 30 mm below the pen)": dataclasses.replace(
            base, gondola=config.Gondola(40.0, 15.0, 30.0)),
        "all of them, tilting": dataclasses.replace(
            base, gondola=config.Gondola(40.0, 15.0, 30.0), cords=config.Cords(0.004),
            motors=dataclasses.replace(base.motors, left_spool_circumference_mm=25.3,
                                       right_spool_circumference_mm=24.7)),
        "sag (18 g/m cords, 200 g gondola)": dataclasses.replace(
            base, gondola=config.Gondola(0.0, 0.0, None, 200.0), cords=config.Cords(0.0, 18.0)),
        "all of them, tilting, sag": dataclasses.replace(
            base, gondola=config.Gondola(40.0, 15.0, 30.0, 200.0), cords=config.Cords(0.004, 18.0),
            motors=dataclasses.replace(base.motors, left_spool_circumference_mm=25.3,
                                       right_spool_circumference_mm=24.7)),
    }
    without = {"gondola, tilting (mass 30 mm below the pen)": "gondola 40 mm, pen 15 mm below",
               "all of them, tilting": "all of them",
               "sag (18 g/m cords, 200 g gondola)": "plain",
               "all of them, tilting, sag": "all of them, tilting"}
    if "--sag" in sys.argv:
        models = {k: models[k] for k in ("plain", "sag (18 g/m cords, 200 g gondola)",
                                         "all of them", "all of them, tilting",
                                         "all of them, tilting, sag")}
    elif tilt_only:
        tilt = ("gondola, tilting (mass 30 mm below the pen)", "all of them, tilting")
        models = {k: v for k, v in models.items()
                  if k in tilt or k in (without[t] for t in tilt)}
    print("| model | steps | planning CPU | steps / CPU s | plot time | tilt / sag costs "
          "| as `draw` | tilt / sag costs |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    best: dict = {}
    drawn: dict = {}
    summaries: dict = {}
    for _ in range(runs):                    # each round runs every model once, in turn
        for name, cfg in models.items():
            cpu, summaries[name] = _run(cfg, path)
            best[name] = min(cpu, best.get(name, cpu))
            cpu = _draw(cfg, path)
            drawn[name] = min(cpu, drawn.get(name, cpu))
    for name in models:
        summary, cpu = summaries[name], best[name]
        steps = int(summary.steps.sum())
        print(f"| {name} | {steps:,} | {cpu:.3f} s | {steps / cpu / 1e6:.1f} M | "
              f"{summary.time_s:.1f} s | {_costs(best, without, name)} | {drawn[name]:.3f} s "
              f"| {_costs(drawn, without, name)} |")


def _costs(cpu: dict, without: dict, name: str) -> str:
    return (f"{(cpu[name] / cpu[without[name]] - 1) * 100:+.0f} % on \"{without[name]}\""
            if name in without else "")


def _run(cfg, path: str) -> tuple:
    """CPU time of one dry run (parse, plan, schedule), and its summary."""
    cords = start_of(cfg)[1]
    summary = pipeline.Summary()
    t0 = time.process_time()
    for _rows in pipeline.stream(cfg, gcode.read(path, warn=lambda m: None), (0, 0), cords,
                                 path, summary=summary):
        pass
    return time.process_time() - t0, summary


def _draw(cfg, path: str) -> float:
    """CPU time of what `draw` does (the dry run's rows made, not written): the whole file
    validated and planned, then the kept plan replayed (streamed again if too long to keep)."""
    cords = start_of(cfg)[1]
    t0 = time.process_time()
    summary = pipeline.validate(cfg, gcode.read(path, warn=lambda m: None), (0, 0), cords, path)
    rows = (pipeline.replay(cfg, summary.plan, (0, 0), cords) if summary.plan is not None
            else pipeline.stream(cfg, gcode.read(path, warn=lambda m: None), (0, 0), cords,
                                 path))
    for _rows in rows:
        pass
    return time.process_time() - t0


if __name__ == "__main__":
    main()
