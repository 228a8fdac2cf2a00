"""Plot time of the plan against the time-optimal reference, file by file, machine by machine.

For the seed machine (config.toml) and the two sized machines of tests/data (wall1m.toml,
wall2m.toml) prints, per file: lines, the planned plot time (`pipeline.validate(...).time_s`,
the time `estimate` prints), the time-optimal reference of bench/reference/topp.py at the planner's
derated limits, their ratio, the ratio against the raw limits too, and the worst ratio of the
set. The files: the samples, tests/data's small varied files and large ones generated for each
machine's page by bench/make/varied.py and bench/make/samples.py. Rows are sorted worst first.

Run: python -m bench.plan_optimal [--small] [--machine seed|wall1m|wall2m]
     python -m bench.plan_optimal --detail FILE [--machine ...]   (the runs that lose most)
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

import numpy as np

from bench import ROOT, start_of
from bench.make import samples, varied
from bench.reference import topp

from vplotter import config, pipeline
from vplotter.inputs import gcode
from vplotter.motion.steps import Dwell, Motion, PenMove, Wait

MACHINES = {"seed": os.path.join(ROOT, "config.toml"),
            "wall1m": os.path.join(ROOT, "tests", "data", "wall1m.toml"),
            "wall2m": os.path.join(ROOT, "tests", "data", "wall2m.toml")}
SMALL = ["tiny_shapes", "far_arcs", "micro_arcs", "gcodetools_far", "zigzag", "long_travel",
         "mixed", "corners"]
LARGE = {"tiny_shapes": 20, "far_arcs": 20, "micro_arcs": 20, "gcodetools_far": 60,
         "zigzag": 20, "long_travel": 20, "mixed": 20, "gcodetools_small": 20}


def records(path):
    return gcode.read(path, warn=lambda m: None)


def planned(cfg, path) -> float:
    counts, ref = start_of(cfg)
    return pipeline.validate(cfg, records(path), counts, ref, path).time_s


def box_of(cfg, margin=10.0):
    p = cfg.page
    return (p.x_min_mm + margin, p.x_max_mm - margin, p.y_min_mm + margin, p.y_max_mm - margin)


def files_for(name, cfg, tmp, small_only):
    out = [os.path.join(ROOT, "tests", "data", f"{f}.ngc") for f in SMALL]
    if name == "seed":
        out = [os.path.join(ROOT, "gcode_samples", f) for f in
               ("car.ngc", "strokes.ngc", "circles.ngc", "square.ngc", "long_line.ngc")] + out
    if small_only:
        return out
    box = box_of(cfg)
    for gen, n in LARGE.items():
        out.append(varied.GENERATORS[gen](os.path.join(tmp, f"{gen}_x{n}.ngc"), n, box))
    if name == "seed":
        out.append(samples.gcodetools_file(os.path.join(tmp, "gcodetools.ngc")))
    return out


def table(name, small_only=False):
    cfg = config.load(MACHINES[name])
    tmp = tempfile.mkdtemp()
    rows = []
    for path in files_for(name, cfg, tmp, small_only):
        lines = sum(1 for _ in open(path))
        plan = planned(cfg, path)
        best = topp.reference(cfg, path)
        raw = topp.reference(cfg, path, derated=False)
        rows.append((plan / best, os.path.basename(path), lines, plan, best, plan / raw))
    rows.sort(reverse=True)
    print(f"\n{name} ({os.path.relpath(MACHINES[name], ROOT)})")
    print(f"| file | lines | plot time | optimal | plan / optimal | plan / optimal at raw limits |")
    print("| --- | --- | --- | --- | --- | --- |")
    for ratio, base, lines, plan, best, raw in rows:
        print(f"| {base} | {lines:,} | {plan:.1f} s | {best:.1f} s | **{ratio:.3f}** | {raw:.3f} |")
    print(f"worst ratio ({name}): {rows[0][0]:.3f} ({rows[0][1]})")
    return rows[0][0]


def detail(name, path, top=15):
    """The runs (between full stops) that lose most against the reference."""
    cfg = config.load(MACHINES[name])
    counts, ref = start_of(cfg)
    ops = pipeline.plan(cfg, records(path), counts, ref, path, pipeline.Summary())
    runs, cur, lines = [], 0.0, []
    for op in ops:
        if isinstance(op, Motion):
            cur += float(op.block.durations.sum())
            lines.append(int(op.block.line[0]))
        elif isinstance(op, (PenMove, Dwell, Wait)) and cur:
            runs.append((cur, lines[0]))
            cur, lines = 0.0, []
    if cur:
        runs.append((cur, lines[0]))
    best, extra = topp.run_times(cfg, path)
    print(f"{len(runs)} planned runs, {len(best)} reference runs; stops {extra:.1f} s")
    if len(runs) != len(best):
        return
    loss = np.array([p - b for (p, _), b in zip(runs, best)])
    print(f"total loss {loss.sum():.2f} s")
    for i in np.argsort(-loss)[:top]:
        print(f"  run {i:5d} line {runs[i][1]:6d}: plan {runs[i][0]:8.3f} s  optimal {best[i]:8.3f} s"
              f"  +{loss[i]:.3f} s ({runs[i][0] / best[i]:.3f})")


def main(argv):
    ap = argparse.ArgumentParser()
    ap.add_argument("--machine", choices=list(MACHINES), action="append")
    ap.add_argument("--small", action="store_true", help="only the small files of tests/data")
    ap.add_argument("--detail", help="per-run losses of one file")
    args = ap.parse_args(argv)
    if args.detail:
        for name in args.machine or ["seed"]:
            detail(name, args.detail)
        return
    worst = {name: table(name, args.small) for name in args.machine or MACHINES}
    print("\nworst ratio of the set: " + ", ".join(f"{k} {v:.3f}" for k, v in worst.items()))


if __name__ == "__main__":
    main(sys.argv[1:])
