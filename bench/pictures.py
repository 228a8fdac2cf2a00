"""How long the pictures take: trace decoding (rows/s) and painting, preview and simulate.

For car.ngc and a larger generated drawing (samples.py's rosettes, 10,000 moves): a dry-run
trace is written first (not timed), then timed:
- decode: trace.read_steps (numpy loadtxt, coil patterns -> steps, pen states);
- simulate: decode + forward kinematics + picture + PNG at 1600 px (what the command does);
- preview: read, validate (plot time), picture + PNG at 1600 px.
Also a preview of 2,000 short strokes (many shapes in one picture).

Times are CPU seconds of this process (the machine is shared). Run: python -m bench.pictures
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
import time

from bench import ROOT
from bench.make.samples import rosettes_file

from vplotter import config
from vplotter.machine import trace
from vplotter.cli import main


def quiet(argv: list[str]) -> float:
    t0 = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        rc = main(argv)
    if rc != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({rc})")
    return time.process_time() - t0


def strokes_file(path: str, n: int = 2000) -> str:
    with open(path, "w") as f:
        for k in range(n):
            x, y = -180 + (k % 50) * 7.2, 280 - (k // 50) * 12
            f.write(f"G0 X{x:.2f} Y{y:.2f}\nM3\nG1 X{x + 5:.2f} Y{y - 4:.2f}\nM5\n")
    return path


def run() -> None:
    cfg_path = os.path.join(ROOT, "config.toml")
    cfg = config.load(cfg_path)
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["XDG_STATE_HOME"] = tmp
        files = [os.path.join(ROOT, "gcode_samples", "car.ngc"),
                 rosettes_file(os.path.join(tmp, "rosettes.ngc"), 10_000)]
        print("| file | trace rows | decode CPU | rows/CPU s | simulate 1600 px CPU "
              "| preview 1600 px CPU |")
        print("| --- | --- | --- | --- | --- | --- |")
        for g in files:
            t = os.path.join(tmp, "t.csv")
            quiet(["--config", cfg_path, "draw", g, "--dry-run", "--trace", t])
            with open(t) as f:
                rows = sum(1 for line in f if not line.startswith(("#", "t,")))
            t0 = time.process_time()
            trace.read_steps(t, cfg.motors, cfg.pen)
            dec = time.process_time() - t0
            sim = quiet(["--config", cfg_path, "simulate", t, "-o", os.path.join(tmp, "s.png")])
            pre = quiet(["--config", cfg_path, "preview", g, "-o", os.path.join(tmp, "p.png")])
            print(f"| {os.path.basename(g)} | {rows:,} | {dec:.2f} s | {rows / dec / 1e6:.1f} M "
                  f"| {sim:.2f} s | {pre:.2f} s |")
        many = strokes_file(os.path.join(tmp, "many.ngc"))
        png = quiet(["--config", cfg_path, "preview", many, "-o", os.path.join(tmp, "m.png")])
        svg = quiet(["--config", cfg_path, "preview", many, "-o", os.path.join(tmp, "m.svg")])
        print(f"\npreview of 2,000 strokes: PNG {png:.2f} s, SVG {svg:.2f} s "
              f"(both include reading and validating the file)")


if __name__ == "__main__":
    run()
