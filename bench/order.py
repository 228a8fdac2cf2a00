"""Pen-up travel ordering: travel and plot time before and after, and the time ordering takes.

For car.ngc and two generated drawings (20,000 random short strokes; a grid of circles in a
shuffled order with random seams), prints pen-up travel in file order, after --order greedy
and after --order best, the CPU time of each ordering, the plot time (pipeline.validate, the
number `estimate` prints) in file order and after best, and, when vpype is importable, the
travel of vpype's `linesort` (greedy with reversal; vpype_cli.execute) on the same strokes,
measured the same way (from X0 Y0, no return). vpype's own pen_up_length leaves out the travel
from the start to the first stroke; the last two columns compare that way (between strokes).
Then, per layer, generated SVGs (tests/support/bezier_svg.py, 3 layers): --order best against
`vpype read FILE linesort`, between strokes.

Run: python -m bench.order          (vpype is optional: pip install vpype in a throwaway venv)
"""

from __future__ import annotations

import os
import time

import numpy as np


from vplotter import config, kinematics, pipeline
from vplotter.drawing import order
from vplotter.machine import state
from vplotter.inputs import gcode, strokes
from vplotter.motion.segment import CHORD_SHARE
from vplotter.prepare import Prepared, gcode_strokes

from bench import ROOT


def car(cfg) -> list[strokes.Stroke]:
    recs = gcode.read(os.path.join(ROOT, "gcode_samples", "car.ngc"), warn=lambda m: None)
    return gcode_strokes(recs, cfg.motion.tolerance_mm * CHORD_SHARE)


def random_strokes(n: int = 20_000) -> list[strokes.Stroke]:
    rng = np.random.default_rng(11)
    out = []
    for i in range(n):
        p = rng.uniform([-190, -240], [190, 290])
        k = int(rng.integers(2, 5))
        pts = p + np.cumsum(rng.normal(0, 1.5, (k, 2)), axis=0)
        out.append(strokes.Stroke(np.clip(pts, [-199, -249], [199, 299]), line=i + 1))
    return out


def circles(nx: int = 60, ny: int = 70, k: int = 48) -> list[strokes.Stroke]:
    rng = np.random.default_rng(12)
    out = []
    for i in range(nx):
        for j in range(ny):
            th = np.linspace(0, 2 * np.pi, k + 1) + rng.uniform(0, 2 * np.pi)
            pts = np.c_[-180 + 6 * i + 2.5 * np.cos(th), -230 + 7.5 * j + 2.5 * np.sin(th)]
            pts[-1] = pts[0]
            out.append(strokes.Stroke(pts, line=len(out) + 1))
    perm = rng.permutation(len(out))
    return [out[p] for p in perm]


def plot_time_s(cfg, pos, ss) -> float:
    prep = Prepared("bench", "svg", False, join_mm=cfg.motion.tolerance_mm * CHORD_SHARE)
    prep._strokes = ss
    return pipeline.validate(cfg, prep.records(), pos.counts, pos.ref_mm, "bench").time_s


def vpype_linesort(ss) -> list | None:
    """The strokes in the order vpype's `linesort` command (greedy, with reversal) gives them,
    run through vpype_cli.execute (None without vpype)."""
    try:
        import vpype as vp
        import vpype_cli
    except ImportError:
        return None
    # (vpype keeps no single-point lines: compare on drawings without dots)
    doc = vp.Document(vp.LineCollection([s.pts[:, 0] + 1j * s.pts[:, 1] for s in ss]))
    out = vpype_cli.execute("linesort", doc)
    lines = out.layers[1] if out.layers else []
    return [strokes.Stroke(np.c_[z.real, z.imag]) for z in lines]


def between(ss) -> float:
    """Pen-up travel between strokes only (vpype's pen_up_length)."""
    return order.travel_mm(ss, ss[0].pts[0]) if ss else 0.0


def svg_layers(cfg, seeds=(0, 1, 2), n_paths: int = 300) -> None:
    """Per layer, on SVGs from tests/support/bezier_svg.py (3 layers, smooth cubics under nested
    skewed
    matrices, many ends 0.01-0.1 mm apart): the travel between strokes of `vplotter --order
    best` (prepare(), default join) and of `vpype read FILE linesort` (vpype's own reading,
    pen_up_length of each layer)."""
    import tempfile
    import types

    from bench import test_support

    bezier_svg = test_support("bezier_svg")
    from vplotter.prepare import prepare

    try:
        import vpype_cli
    except ImportError:
        vpype_cli = None
    print()
    print("| generated SVG | layer | strokes | between strokes: best / vpype linesort | ratio |")
    print("| --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            text, _ = bezier_svg.make(seed, n_paths=n_paths, n_layers=3, pairs=n_paths // 3, n=2)
            path = os.path.join(tmp, f"gen{seed}.svg")
            with open(path, "w") as f:
                f.write(text)
            prep = prepare(path, cfg, types.SimpleNamespace(order="best"), warn=lambda m: None)
            theirs = {}
            if vpype_cli is not None:
                doc = vpype_cli.execute(f"read {path} linesort")
                theirs = {lc.property("vp_name"): float(lc.pen_up_length()[0]) * 25.4 / 96
                          for lc in doc.layers.values()}      # vpype's unit is the CSS px
            for name in dict.fromkeys(s.layer for s in prep.strokes):
                ours = [s for s in prep.strokes if s.layer == name]
                mine = between(ours)
                vp = theirs.get(name)
                vps = f"{vp / 1000:.3f} m" if vp is not None else "(no vpype)"
                ratio = f"{mine / vp:.3f}" if vp else "-"
                print(f"| gen{seed} | {name} | {len(ours)} | {mine / 1000:.3f} m / {vps} "
                      f"| {ratio} |", flush=True)


def main() -> None:
    cfg = config.load(os.path.join(ROOT, "config.toml"))
    kin = kinematics.from_config(cfg)
    cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
    pos = state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_unit)
    print("| drawing | strokes | travel file | greedy | best | vpype linesort | best / linesort "
          "| order CPU (greedy / best) | plot time file | plot time best "
          "| between strokes: best / linesort |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, ss in (("car.ngc", car(cfg)), ("20,000 random short strokes", random_strokes()),
                     ("4,200 circles, shuffled", circles())):
        t0 = time.process_time()
        greedy = order.order(ss, "greedy")
        t1 = time.process_time()
        best = order.order(ss, "best")
        t2 = time.process_time()
        tf, tg, tb = (order.travel_mm(x) for x in (ss, greedy, best))
        lines = vpype_linesort(ss)
        vp = order.travel_mm(lines) if lines is not None else None
        pf, pb = plot_time_s(cfg, pos, ss), plot_time_s(cfg, pos, best)
        vps = f"{vp / 1000:.2f} m" if vp is not None else "(no vpype)"
        ratio = f"{tb / vp:.3f}" if vp else "-"
        btw = (f"{between(best) / 1000:.2f} m / {between(lines) / 1000:.2f} m"
               if lines is not None else "-")
        print(f"| {name} | {len(ss)} | {tf / 1000:.2f} m | {tg / 1000:.2f} m | {tb / 1000:.2f} m "
              f"| {vps} | {ratio} | {t1 - t0:.2f} s / {t2 - t1:.2f} s | {pf:.0f} s | {pb:.0f} s "
              f"| {btw} |")
    svg_layers(cfg)


if __name__ == "__main__":
    main()
