"""What planning with a tilting gondola cannot get below: the exact arithmetic every plan needs.

For car.ngc and the 16,000-line gcodetools-like file (bench/make/samples.py), on config.toml
with a gondola 40 mm wide, the pen 15 mm below the cords, prints:

- the planner alone (`pipeline.validate` from the parsed records: cut, plan, time, as
  bench.plan_speed calls planning), level against tilted (centre of mass 30 mm below the pen),
  best CPU of interleaved runs;
- the floor: on the windows the planner made (their vertices, captured from the planner's own
  calls), the work no exact plan can skip, tilted against level, as a share of the level
  planner:
  - "all vertices": the balance at every vertex of the planned windows (the points put in
    included) and the motor coordinates' value, slope and bend at both ends of every piece
    (what the profile takes), against the level gondola's closed forms for the same;
  - "input vertices": the same on the vertices before refine puts points in (a plan that took
    the points put in from a curve through the pieces' ends, not from the balance).

Whatever else the planner does with tilt (the search for the cords' turns, refine's slopes,
the bends at long pieces' middles, keeping the balances between its calls) comes on top.

Then the same planner with its tilt arithmetic cut back step by step (`--designs`), each as
a share over the level planner, all runs interleaved (the planner's own code throughout;
only the machine's answers change, so the plans differ a little):
- "exact": the planner as it is;
- "bends without phi''": the profile's slopes exact, its bends from the ends' first-order
  terms (phi' exact, phi'' left out: not exact), the larger end's bend for a long piece;
- "and level turns, slopes": also the cords' turns and refine's slopes from the level
  gondola's closed forms (wrong cuts: no plan could ship this);
- "least": the balance solved once at every vertex of the planned window and the exact
  slopes at both ends of every piece, everything else the level gondola's: what any plan
  with exact cords and step rates pays, whatever it borrows for the rest.
Run: python -m bench.tilt_floor [--runs N] [--designs]
"""

from __future__ import annotations

import dataclasses
import os
import sys
import tempfile
import time

import numpy as np

from bench import ROOT, start_of
from bench.make.samples import gcodetools_file

from vplotter import config, kinematics, pipeline
from vplotter.inputs import gcode
from vplotter.kinematics import tilt_along, tilt_kept, vplotter


def _planner(cfg, recs, path):
    counts, cords = start_of(cfg)
    return lambda: pipeline.validate(cfg, iter(recs), counts, cords, path)


def _best(fns, runs):
    """Best CPU of each function, the functions run in turn (a busy spell slows them alike)."""
    best = [float("inf")] * len(fns)
    for _ in range(runs):
        for i, fn in enumerate(fns):
            t = time.process_time()
            fn()
            best[i] = min(best[i], time.process_time() - t)
    return best


def _windows(run):
    """The planned windows' vertices (inverse of more than two points: the profile's call, after
    refine) and the pieces' starts before refine (extrema's call), from one tilted run."""
    seen = {"refined": [], "input": []}
    inverse, extrema = vplotter.TwoCord.inverse, vplotter.TwoCord.extrema

    def keep_inverse(self, xy):
        if self.gondola is not None and np.ndim(xy) == 2 and len(xy) > 2:
            seen["refined"].append(np.array(xy, dtype=float))
        return inverse(self, xy)

    def keep_extrema(self, p0, e, d):
        if self.gondola is not None and len(p0) > 2:
            seen["input"].append(np.vstack((p0, p0[-1] + e[-1] * d[-1])))
        return extrema(self, p0, e, d)

    vplotter.TwoCord.inverse, vplotter.TwoCord.extrema = keep_inverse, keep_extrema
    try:
        run()
    finally:
        vplotter.TwoCord.inverse, vplotter.TwoCord.extrema = inverse, extrema
    return seen


def _pieces(verts):
    diff = np.diff(verts, axis=0)
    d = np.hypot(diff[:, 0], diff[:, 1])
    ok = d > 0
    return verts, diff[ok] / d[ok, None], ok


def exact_tilted(kin, windows):
    """The balance at every vertex, the motor coordinates' value, slope and bend at both ends
    of each piece (Gondola.solve, Gondola.vertex_terms, tilt_along.along: the planner's own
    arithmetic)."""
    g = kin.gondola
    for verts in windows:
        verts, e, ok = _pieces(verts)
        state = g.solve(verts[:, 0], verts[:, 1])
        tilt_along.cords_value(state[6], kin.stretch)
        terms = g.vertex_terms(verts[:, 0], verts[:, 1], state)
        rows = np.flatnonzero(ok)
        tilt_along.along(terms, rows, e)
        tilt_along.along(terms, rows + 1, e)


def exact_level(kin, windows):
    """The same for the level gondola: its cords at the vertices, the slopes and bends at both
    ends of each piece (its closed forms)."""
    for verts in windows:
        verts, e, ok = _pieces(verts)
        kin.inverse(verts)
        rows = np.flatnonzero(ok)
        kin.slope_bend(verts[rows], e)
        kin.slope_bend(verts[rows + 1], e)


class _NoPhi2(vplotter.TwoCord):
    """The profile's slopes exact, its bends from the ends' first-order terms (phi'' left out)."""

    def ends(self, verts, e):
        state = tilt_kept.balance(self, verts)
        n = len(e)
        return (*_first_order(self, verts[:-1], e, _rows(state, slice(0, n))),
                *_first_order(self, verts[1:], e, _rows(state, slice(1, n + 1))))

    def bend_inside(self, mid, e, d, k0, k1, b0, b1):
        return np.maximum(np.abs(b0), np.abs(b1))


class _LevelTurns(_NoPhi2):
    """And the cords' turns and refine's slopes from the level gondola's closed forms."""

    def slope(self, xy, e):
        return self._along(xy, e)[0]

    def extrema(self, p0, e, d):
        a = self.anchors
        s = np.stack([-((p0[:, 0] - a[m, 0]) * e[:, 0] + (p0[:, 1] - a[m, 1]) * e[:, 1])
                      for m in (0, 1)], axis=-1)
        return np.where((s > 1e-9) & (s < d[:, None] - 1e-9), s, np.nan)


class _Least(_LevelTurns):
    """The balance once at every vertex of the window (the profile's cords), the exact slopes
    at both ends of every piece from it; bends, turns and refine's slopes level."""

    def inverse(self, xy):
        m = np.asarray(xy, dtype=float)
        if m.ndim != 2 or len(m) <= 2:
            return super().inverse(xy)
        self._solved = (m, self.gondola.solve(m[:, 0], m[:, 1]))
        return tilt_along.cords_value(self._solved[1][6], self.stretch)

    def ends(self, verts, e):
        state = self._solved[1]
        out = []
        for xy, at in ((verts[:-1], slice(0, len(e))), (verts[1:], slice(1, len(e) + 1))):
            k, g = self._along(xy, e)
            out += [self.gondola.slopes(xy, e, _rows(state, at)).T, ((1.0 - k * k) / g).T]
        return tuple(out)

    def carry(self, old, new, piece, end):
        pass


def _rows(state, at):
    return tuple(tilt_kept._rows(v, at) for v in state)


def _first_order(kin, xy, e, state):
    """Slopes and bends (2, N) at xy along e with phi'' taken as 0."""
    x, y = xy[:, 0], xy[:, 1]
    _, _, _, df, fx, fy, r = state
    ex, ey = e[:, 0], e[:, 1]
    p1 = -(fx * ex + fy * ey) / df
    ks, bs = [], []
    for rx, ry, anchor in ((r[0], r[1], 0.0), (r[2], r[3], kin.gondola.d_mm)):
        ux, uy = anchor - x - rx, -y - ry                 # the gondola's arm to the cord
        inv = 1.0 / np.sqrt(rx * rx + ry * ry)
        dx, dy = p1 * uy - ex, -ey - p1 * ux              # the cord's derivative
        k = (rx * dx + ry * dy) * inv
        ks.append(k)
        bs.append((dx * dx + dy * dy - k * k + p1 * p1 * (rx * ux + ry * uy)) * inv)
    return np.stack(ks), np.stack(bs)


def _as(cls, cfg, recs, path):
    """The planner on cfg with its machine of class cls (a TwoCord)."""
    counts, cords = start_of(cfg)
    made = kinematics.from_config

    def run():
        kin = made(cfg)
        kin.__class__ = cls
        kinematics.from_config = lambda _cfg: kin
        try:
            pipeline.validate(cfg, iter(recs), counts, cords, path)
        finally:
            kinematics.from_config = made

    return run


def designs(level, tilted, files, runs) -> None:
    """The planner with its tilt arithmetic cut back step by step (see the docstring)."""
    names = ("exact", "bends without phi''", "and level turns, slopes", "least")
    print("| file | planner, level | " + " | ".join(names) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in names) + " |")
    for path in files:
        recs = list(gcode.read(path, warn=lambda m: None))
        fns = [_planner(level, recs, path)] + [
            _as(cls, tilted, recs, path)
            for cls in (vplotter.TwoCord, _NoPhi2, _LevelTurns, _Least)]
        n = max(3, runs // 3) if len(recs) > 5000 else runs
        best = _best(fns, n)
        print(f"| {os.path.basename(path)} | {best[0] * 1e3:.1f} ms | "
              + " | ".join(f"+{(b / best[0] - 1) * 100:.0f} %" for b in best[1:]) + " |")


def main(argv) -> None:
    runs = int(argv[argv.index("--runs") + 1]) if "--runs" in argv else 15
    base = config.load(os.path.join(ROOT, "config.toml"))
    level = dataclasses.replace(base, gondola=config.Gondola(40.0, 15.0))
    tilted = dataclasses.replace(base, gondola=config.Gondola(40.0, 15.0, 30.0))
    files = [os.path.join(ROOT, "gcode_samples", "car.ngc"),
             gcodetools_file(os.path.join(tempfile.mkdtemp(), "gcodetools.ngc"))]
    if "--designs" in argv:
        designs(level, tilted, files, runs)
        return
    print("| file | planner, level | planner, tilted | tilt costs | floor, all vertices "
          "| floor, input vertices |")
    print("| --- | --- | --- | --- | --- | --- |")
    for path in files:
        recs = list(gcode.read(path, warn=lambda m: None))
        plan_level, plan_tilted = _planner(level, recs, path), _planner(tilted, recs, path)
        n = max(3, runs // 3) if len(recs) > 5000 else runs
        t_level, t_tilted = _best([plan_level, plan_tilted], n)
        seen = _windows(plan_tilted)
        k_level, k_tilted = kinematics.from_config(level), kinematics.from_config(tilted)
        floors = []
        for name in ("refined", "input"):
            w = seen[name]
            a, b = _best([lambda: exact_level(k_level, w), lambda: exact_tilted(k_tilted, w)],
                         runs)
            verts = sum(len(v) for v in w)
            floors.append(f"+{(b - a) / t_level * 100:.1f} % ({verts:,} vertices: "
                          f"{b * 1e3:.2f} ms against {a * 1e3:.2f} ms)")
        print(f"| {os.path.basename(path)} | {t_level * 1e3:.1f} ms | {t_tilted * 1e3:.1f} ms "
              f"| +{(t_tilted / t_level - 1) * 100:.0f} % | {floors[0]} | {floors[1]} |")


if __name__ == "__main__":
    main(sys.argv[1:])
