"""The Python API against the same moves in a G-code file (docs/measurements.md, "The Python
API"): dry-run traces compared row by row and decoded by tracecheck, plot times, and the host
time of each.

    python -m bench.api_script

Drawings: a spiral of 2,000 linetos (one stroke, one part) and 300 random walks of 20 linetos
(6,300 moves: parts at pen lifts once FLUSH_AT_LIFT moves are buffered)."""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from bench import ROOT, test_support

CONFIG = ROOT / "config.toml"
scripts = test_support("scripts")


def spiral() -> list[list[tuple[float, float]]]:
    return [scripts.spiral(2000)]


def walks() -> list[list[tuple[float, float]]]:
    return scripts.walks(300, 20)


def rows(path: Path) -> list[str]:
    return [line for line in path.read_text().splitlines() if not line.startswith("#")]


def measure(name: str, strokes, folder: Path) -> str:
    from vplotter import api
    from vplotter.cli import main

    tc = test_support("tracecheck")
    ngc, t_api, t_file = folder / f"{name}.ngc", folder / f"{name}.api.csv", folder / "f.csv"
    ngc.write_text(scripts.gcode_of(strokes))
    parts = []
    flush = api.Plotter.flush

    def counted(self):
        if self._records:
            parts.append(len(self._records))
        flush(self)

    api.Plotter.flush = counted
    t0 = time.perf_counter()
    with api.Plotter(CONFIG, dry_run=True, trace=t_api) as p:
        for pts in strokes:
            p.moveto(*pts[0])
            p.pendown()
            for x, y in pts[1:]:
                p.lineto(x, y)
            p.penup()
    s_api = time.perf_counter() - t0
    api.Plotter.flush = flush
    t0 = time.perf_counter()
    assert main(["--config", str(CONFIG), "draw", str(ngc), "--dry-run", "--trace",
                 str(t_file)]) == 0
    s_file = time.perf_counter() - t0
    cfg = tc.load_config(CONFIG)
    tr_api, tr_file = tc.read_trace(t_api), tc.read_trace(t_file)
    same = rows(t_api) == rows(t_file)
    problems = tc.verify(tr_api, ngc, cfg, tol_mm=0.02)
    moves = sum(len(s) for s in strokes)
    ratio = tc.plot_time(tr_api) / tc.plot_time(tr_file)
    return (f"| {name} | {moves:,} | {len(parts)} | {'yes' if same else 'no'} | "
            f"{'none' if not problems else len(problems)} | {tc.plot_time(tr_api):.1f} s | "
            f"{tc.plot_time(tr_file):.1f} s | **{ratio:.6f}** | {s_api:.2f} s | {s_file:.2f} s |")


def main() -> None:
    print("| drawing | moveto + lineto | parts | trace rows identical | tracecheck problems (0.02 mm) "
          "| plot time, API | plot time, file | ratio | host time, API | host time, draw |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        for name, strokes in (("spiral, 2,000 linetos", spiral()),
                              ("300 random walks", walks())):
            print(measure(name, strokes, Path(tmp)), flush=True)


if __name__ == "__main__":
    main()
