"""Planning speed and plot-time quality of a dry run.

For car.ngc, a generated 15,000-line Inkscape gcodetools drawing (450 short strokes of arcs)
and a generated 40,000-move file of rosettes, prints:
- the planned plot time, the time-optimal reference of bench/reference/topp.py (same path, same
  motor
  limits) and their ratio;
- the wall time of the whole process `vplotter draw FILE --dry-run` (best of 3; Python start,
  imports, parsing, validation, planning, step schedule and the simulated machine) and how many
  times faster than the plot that is; the CPU (best of 5) of parsing the file, of planning it
  (`validate` from the parsed records: cut, plan, time) and of the step schedule;
- that memory stays flat in the length of the file.

Run: python -m bench.plan_speed [--cpu] [FILE ...]   (--cpu: only the CPU columns)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

from bench import ROOT, start_of
from bench.make.samples import gcodetools_file, rosettes_file
from bench.reference.topp import reference

from vplotter import config, pipeline
from vplotter.inputs import gcode


def records(path):
    return gcode.read(path, warn=lambda m: None)


def whole_process(path: str, runs: int = 3) -> float:
    env = dict(os.environ, XDG_STATE_HOME=tempfile.mkdtemp())
    best = float("inf")
    for _ in range(runs):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "vplotter", "--config", os.path.join(ROOT, "config.toml"),
                        "draw", path, "--dry-run"], env=env, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        best = min(best, time.perf_counter() - t)
    return best


def best_cpu(fn, runs: int = 5):
    """The least CPU time of `runs` calls of fn (the machine may be shared), and fn's result."""
    best, out = float("inf"), None
    for _ in range(runs):
        t = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t)
    return best, out


def cpu_split(cfg, path):
    """CPU (best of 5) of parsing the file, of validating it from the parsed records (cut,
    plan, time: `validate` less the parse) and of the step schedule."""
    counts, ref = start_of(cfg)
    t_parse, recs = best_cpu(lambda: list(records(path)))
    t_plan, summary = best_cpu(lambda: pipeline.validate(cfg, iter(recs), counts, ref, path))

    def steps():
        rows = (pipeline.replay(cfg, summary.plan, counts, ref) if summary.plan is not None
                else pipeline.stream(cfg, iter(recs), counts, ref, path))
        return sum(len(r) for r in rows)

    t_steps, _ = best_cpu(steps, 3)
    return t_parse, t_plan, t_steps, summary


def peak_memory_mb(cfg, path) -> float:
    """Peak Python heap while streaming the whole file through the planner (no steps; the
    plan is not kept past PLAN_LIMIT pieces)."""
    import tracemalloc

    counts, ref = start_of(cfg)
    tracemalloc.start()
    for _ in pipeline.stream(cfg, records(path), counts, ref, path, emit=False):
        pass
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 1e6


def cpu_only(cfg, files):
    """Only the CPU columns, quickly: to compare two versions of vplotter run one after the
    other (PYTHONPATH=OLD/src python -m bench.plan_speed --cpu, then without), several times."""
    import vplotter

    print(f"vplotter from {os.path.dirname(vplotter.__file__)}")
    for path in files:
        t_parse, t_plan, t_steps, summary = cpu_split(cfg, path)
        print(f"{os.path.basename(path):<16}plot {summary.time_s:9.3f} s  parse cpu {t_parse:.4f} s"
              f"  plan cpu {t_plan:.4f} s  steps cpu {t_steps:.3f} s")


def main(argv):
    cfg = config.load(os.path.join(ROOT, "config.toml"))
    tmp = tempfile.mkdtemp()
    quick = "--cpu" in argv
    argv = [a for a in argv if a != "--cpu"]
    files = argv or [os.path.join(ROOT, "gcode_samples", "car.ngc"),
                     gcodetools_file(os.path.join(tmp, "gcodetools.ngc")),
                     rosettes_file(os.path.join(tmp, "rosettes.ngc"))]
    if quick:
        cpu_only(cfg, files)
        return
    print(f"{'file':<16}{'lines':>7}{'steps':>10}{'plot s':>9}{'optimal s':>10}{'ratio':>7}"
          f"{'process s':>10}{'plot/proc':>10}{'parse cpu':>10}{'plan cpu':>10}{'steps cpu':>10}")
    for path in files:
        lines = sum(1 for _ in open(path))
        t_parse, t_plan, t_steps, summary = cpu_split(cfg, path)
        best = reference(cfg, path)
        wall = whole_process(path)
        print(f"{os.path.basename(path):<16}{lines:>7}{int(summary.steps.sum()):>10}"
              f"{summary.time_s:>9.1f}{best:>10.1f}{summary.time_s / best:>7.3f}{wall:>10.3f}"
              f"{summary.time_s / wall:>10.0f}{t_parse:>10.4f}{t_plan:>10.4f}{t_steps:>10.3f}")
    if not argv:
        print("\nmemory is flat in the length of the file (peak Python heap, planning pass):")
        for n in (20_000, 160_000):
            path = rosettes_file(os.path.join(tmp, f"big{n}.ngc"), n)
            size = os.path.getsize(path) / 1e6
            print(f"  {n:>6} moves ({size:5.1f} MB of G-code): {peak_memory_mb(cfg, path):6.1f} MB")


if __name__ == "__main__":
    main(sys.argv[1:])
