"""What a tilting gondola costs as a person meets it: every run in a process of its own.

Level and tilted runs in one process flatter the level planner: once the tilted runs have
grown the C heap, the level planner's arrays find room in it without asking the kernel, and
it takes up to 15 % less CPU than in a process of its own. A person's vplotter plans one machine
per process, so here each run is a child process, level and tilted in turn (the order flipped
every pair), pinned to one core where `taskset` is; the CPU is the child's (rusage).

- the commands: `vplotter estimate FILE` and `vplotter draw FILE --dry-run`, on config.toml
  with the gondola 40 mm wide and the pen 15 mm below the cords, level and with its centre of
  mass 30 mm below the pen;
- the planner alone: `pipeline.validate` from the parsed records (cut, plan, time: as
  bench.tilt_floor and bench.plan_speed call planning), the best of RUNS in the child after
  one run to warm up; the records parsed first are frozen out of the garbage collector's
  sight (gc.freeze: they are the bench's, not the planner's).
Files: car.ngc, the 16,000-line gcodetools-like file and one of 97,000 lines (the same maker,
2,700 strokes). Prints the best CPU of each, the median of the pairs' ratios and the largest
peak resident memory of each (the planner alone: its child process, the file parsed).
Run: python -m bench.tilt_cost [--pairs N] [--runs R] [--car-only]
"""

from __future__ import annotations

import dataclasses
import gc
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

from bench import ROOT, start_of
from bench.make.samples import gcodetools_file

GONDOLA = "\n[gondola]\ncord_spacing_mm = 40.0\npen_below_mm = 15.0\n"
TILT = "mass_below_pen_mm = 30.0\n"


def _pin() -> list:
    return ["taskset", "-c", "0"] if shutil.which("taskset") else []


def _pairs(make, pairs: int) -> tuple:
    """make(kind) -> (seconds, MB), level and tilted in turn: the best seconds of each, the
    median of the pairs' tilted / level, the largest MB of each."""
    got = {"level": [], "tilted": []}
    for i in range(pairs):
        for kind in ("level", "tilted") if i % 2 == 0 else ("tilted", "level"):
            got[kind].append(make(kind))
    (a, ma), (b, mb) = ([min(t for t, _ in got[k]), max(m for _, m in got[k])]
                        for k in ("level", "tilted"))
    ratio = statistics.median(t / u for (t, _), (u, _) in zip(got["tilted"], got["level"]))
    return a, b, ratio, ma, mb


def planner_alone(kind: str, path: str, runs: int) -> float:
    """In the child: the best CPU of `pipeline.validate` from the parsed records."""
    from vplotter import config, pipeline
    from vplotter.inputs import gcode

    base = config.load(os.path.join(ROOT, "config.toml"))
    cfg = dataclasses.replace(base, gondola=config.Gondola(
        40.0, 15.0, 30.0 if kind == "tilted" else None))
    recs = list(gcode.read(path, warn=lambda m: None))
    counts, cords = start_of(cfg)
    # the parsed records are this bench's fixture, not the planner's: out of the collector's
    # sight, or a full collection over them (23 ms on the 97k-line file) falls on whichever
    # side's allocations happen to cross its threshold (it fell on the tilted side)
    gc.collect()
    gc.freeze()
    best = float("inf")
    for i in range(runs + 1):
        t = time.process_time()
        pipeline.validate(cfg, iter(recs), counts, cords, path)
        if i:                                   # the first run warms up
            best = min(best, time.process_time() - t)
    return best


def main(argv) -> None:
    if argv[:1] == ["--child"]:
        with open(argv[4], "w") as f:
            f.write(repr(planner_alone(argv[1], argv[2], int(argv[3]))))
        return
    pairs = int(argv[argv.index("--pairs") + 1]) if "--pairs" in argv else 10
    runs = int(argv[argv.index("--runs") + 1]) if "--runs" in argv else 10
    tmp = tempfile.mkdtemp()
    with open(os.path.join(ROOT, "config.toml")) as f:
        text = f.read()
    configs = {}
    for kind, extra in (("level", GONDOLA), ("tilted", GONDOLA + TILT)):
        configs[kind] = os.path.join(tmp, f"{kind}.toml")
        with open(configs[kind], "w") as f:
            f.write(text + extra)
    files = [os.path.join(ROOT, "gcode_samples", "car.ngc")]
    if "--car-only" not in argv:
        files += [gcodetools_file(os.path.join(tmp, "gcodetools.ngc")),
                  gcodetools_file(os.path.join(tmp, "gcodetools_97k.ngc"), strokes=2700,
                                  seed=11)]
    env = dict(os.environ, XDG_STATE_HOME=tmp)        # no stored position of this machine's
    python = [sys.executable]
    print("| file | lines | run | level | tilted | best against best | median of pairs "
          "| peak memory, level / tilted |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for path in files:
        with open(path) as f:
            lines = sum(1 for _ in f)
        n = max(3, pairs // 2) if lines > 50_000 else pairs
        rows = [("`estimate`", lambda kind: _run(python + ["-m", "vplotter", "--config",
                                                           configs[kind], "estimate", path], env)),
                ("`draw --dry-run`", lambda kind: _run(python + [
                    "-m", "vplotter", "--config", configs[kind], "draw", path, "--dry-run"], env)),
                ("the planner alone", lambda kind: _planner(python, kind, path, runs, env))]
        for name, make in rows:
            a, b, ratio, ma, mb = _pairs(make, n)
            print(f"| {os.path.basename(path)} | {lines:,} | {name} | {_fmt(a)} | {_fmt(b)} "
                  f"| {(b / a - 1) * 100:+.1f} % | {(ratio - 1) * 100:+.1f} % "
                  f"| {ma:.0f} / {mb:.0f} MB |", flush=True)


def _run(args: list, env: dict) -> tuple:
    """CPU seconds and peak resident memory (MB) of one child process running args."""
    child = subprocess.Popen(_pin() + args, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL)
    _, status, use = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode:
        raise subprocess.CalledProcessError(child.returncode, args)
    return use.ru_utime + use.ru_stime, use.ru_maxrss / 1024.0


def _planner(python: list, kind: str, path: str, runs: int, env: dict) -> tuple:
    """The child's best CPU seconds of the planner alone, and its peak memory (MB)."""
    out = os.path.join(env["XDG_STATE_HOME"], "planner.txt")
    _, mb = _run(python + ["-m", "bench.tilt_cost", "--child", kind, path, str(runs), out], env)
    with open(out) as f:
        return float(f.read()), mb


def _fmt(seconds: float) -> str:
    return f"{seconds:.3f} s" if seconds >= 0.1 else f"{seconds * 1e3:.1f} ms"


if __name__ == "__main__":
    main(sys.argv[1:])
