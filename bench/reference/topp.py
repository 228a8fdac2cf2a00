"""A time-optimal reference for the planner: how fast could the same path be drawn?

The path is the planner's own pieces (arcs already cut within tolerance), sampled every
DS_MM. At every sample the squared pen speed u = v^2 is bounded by the feed cap and each
motor's step rate (|q'| v <= rate), and the path acceleration a = u'/2 by each motor's
acceleration limit, exactly: -A <= q'' u + q' a <= A (q' = slope, q'' = bend), and u at most
where a = 0 keeps every motor within it (|q''| u <= A: above that the pen could not stay on
the curve, only pass it speeding up or braking). A forward pass and a backward pass on u give
the classic time-optimal parameterisation (as toppra computes it). Corners between pieces are passed on a blend that keeps the pen within
tolerance_mm: a circle of radius tol / (1 / cos(turn / 2) - 1), whose centripetal
acceleration is bounded in cord space like any other. Pen changes, dwells and the end are
full stops; pen settle times and the coil hold before moving are added as the schedule has
them (one hold at the first move: the coils stay energised through pen changes and dwells; a
settle for the lift at the end if the file ends pen down).

The limits are by default the planner's derated ones (0.998 x max_step_rate, 0.96 x
max_accel, see `limits`): the plan has to stay inside them, so that is the fair yardstick;
`reference(..., derated=False)` gives the bound at the raw limits.

Run: python -m bench.reference.topp FILE [...]   (prints reference time, planned time, ratio)
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

from vplotter import config, kinematics, pipeline
from vplotter.inputs import gcode
from vplotter.motion.planner import ACCEL_MARGIN, RATE_MARGIN

DS_MM = 0.1


def strokes_of(cfg, path):
    """Runs of the true path between full stops, sampled every DS_MM: tuples of arrays
    (points (S, 2) machine mm, unit tangents (S, 2), signed curvature (S,), cap (S,),
    corner (S,) True where a move starts), and the pen, dwell and hold time to add."""
    from vplotter.motion import segment

    kin = kinematics.from_config(cfg)
    mo = cfg.motion
    hold_s = math.ceil(1e6 / cfg.motors.max_step_rate) / 1e6
    runs, cur = [], []
    extra_s = cfg.pen.settle_s + hold_s   # the pen is lifted at the start; the coils hold once
    down = False

    def close():
        nonlocal cur
        if cur:
            runs.append(tuple(np.concatenate(x) for x in zip(*cur)))
            cur = []

    for rec in gcode.read(path, warn=lambda m: None):
        if isinstance(rec, gcode.Pen):
            if rec.down != down:
                close()
                extra_s += cfg.pen.settle_s       # the coils stay energised: no new hold
                down = rec.down
            continue
        if isinstance(rec, gcode.Dwell):
            close()
            extra_s += rec.seconds
            continue
        cap = mo.draw_speed_mm_s if down else mo.travel_speed_mm_s
        if down and rec.feed_mm_s is not None and not rec.rapid:
            cap = min(cap, rec.feed_mm_s)
        if rec.arc == 0:
            dx, dy = rec.x1 - rec.x0, rec.y1 - rec.y0
            length = math.hypot(dx, dy)
            if length < 1e-9:
                continue
            n = max(1, math.ceil(length / DS_MM))
            f = np.arange(n) / n
            p = np.column_stack((rec.x0 + f * dx, rec.y0 + f * dy))
            t = np.tile([dx / length, dy / length], (n, 1))
            kappa = np.zeros(n)
        else:
            sweep = segment.arc_sweep(rec)
            r0 = math.hypot(rec.x0 - rec.cx, rec.y0 - rec.cy)
            r1 = math.hypot(rec.x1 - rec.cx, rec.y1 - rec.cy)
            length = abs(sweep) * (r0 + r1) / 2
            n = max(2, math.ceil(length / DS_MM))
            f = np.arange(n) / n
            a0 = math.atan2(rec.y0 - rec.cy, rec.x0 - rec.cx)
            ang = a0 + sweep * f
            rad = r0 + (r1 - r0) * f
            p = np.column_stack((rec.cx + rad * np.cos(ang), rec.cy + rad * np.sin(ang)))
            sgn = 1.0 if sweep > 0 else -1.0
            t = np.column_stack((-np.sin(ang), np.cos(ang))) * sgn
            kappa = sgn / np.maximum(rad, 1e-9)
        # G-code frame (+Y up) -> machine frame (+y down): y flips, and so does the curvature
        cur.append((kin.to_machine(p), t * np.array([1.0, -1.0]), -kappa, np.full(n, cap),
                    np.arange(n) == 0))
    close()
    if down:
        extra_s += cfg.pen.settle_s           # the pen is lifted at the end
    return runs, extra_s, kin


def run_time(kin, run, rate_u, acc_u, tol, profile=False):
    """Time-optimal time along one run (rest to rest); with profile, also the path distance
    and the speed at every sample."""
    pts, t, kappa, capv, starts = run
    seg = np.diff(pts, axis=0)
    ds = np.append(np.hypot(seg[:, 0], seg[:, 1]), 0.0)
    nrm = np.column_stack((-t[:, 1], t[:, 0]))                 # left normal
    k = kin.slope(pts, t)                                      # (S, M) d cord / d path
    b = kin.bend(pts, t) + kappa[:, None] * kin.slope(pts, nrm)   # d2 cord / d path2
    u_max = np.minimum(capv ** 2, ((rate_u / np.maximum(np.abs(k), 1e-12)) ** 2).min(axis=1))
    # corners where a move starts with a turn: a blend within tol
    idx = np.flatnonzero(starts[1:]) + 1
    if len(idx):
        e0, e1 = t[idx - 1], t[idx]
        turn = np.arccos(np.clip((e0 * e1).sum(axis=1), -1.0, 1.0))
        c = np.cos(turn / 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(turn > 1e-6, tol / np.maximum(1.0 / c - 1.0, 1e-300), np.inf)
            nv = e1 - e0
            nn = np.linalg.norm(nv, axis=1)
            nv = np.where(nn[:, None] > 0, nv / np.maximum(nn, 1e-300)[:, None], 0.0)
            grad = kin.slope(pts[idx], nv)
            ucorner = (acc_u * r[:, None] / np.maximum(np.abs(grad), 1e-12)).min(axis=1)
        ucorner = np.where(turn > math.pi * 0.999, 0.0, ucorner)
        u_max[idx] = np.minimum(u_max[idx], ucorner)
    # at most where the pen can go round with a = 0: above that a motor's bend x v^2 alone is
    # over its limit, and the pen could not stay there (the passes below take a = 0 where the
    # limits allow only a > 0 or only a < 0)
    u_max = np.minimum(u_max, (acc_u / np.maximum(np.abs(b), 1e-12)).min(axis=1))
    u_max[0] = u_max[-1] = 0.0
    S = len(u_max)
    kk, bb, u_lim = k.tolist(), b.tolist(), u_max.tolist()
    A = acc_u.tolist()
    M = len(A)

    def a_bounds(u, i):
        hi, lo = math.inf, -math.inf
        for m in range(M):
            km, bm = kk[i][m], bb[i][m]
            if abs(km) < 1e-12:
                continue
            x1, x2 = (-A[m] - bm * u) / km, (A[m] - bm * u) / km
            if x1 > x2:
                x1, x2 = x2, x1
            hi, lo = min(hi, x2), max(lo, x1)
        return lo, hi

    u = [0.0] * S
    for i in range(S - 1):            # forward
        lo, hi = a_bounds(u[i], i)
        u[i + 1] = min(u_lim[i + 1], u[i] + 2 * max(hi, 0.0) * ds[i])
    for i in range(S - 1, 0, -1):     # backward
        lo, hi = a_bounds(u[i], i)
        u[i - 1] = min(u[i - 1], u[i] - 2 * min(lo, 0.0) * ds[i - 1])
    v = np.sqrt(np.maximum(np.array(u), 0.0))
    vm = (v[:-1] + v[1:]) / 2
    t = float((ds[:-1] / np.maximum(vm, 1e-9)).sum())
    if profile:
        return t, np.concatenate(([0.0], np.cumsum(ds[:-1]))), v
    return t


def limits(cfg, derated=True):
    """Each motor's rate and acceleration limits in cord mm: by default the planner's own
    derating (RATE_MARGIN x max_step_rate, ACCEL_MARGIN x max_accel: the envelope any plan
    must keep to so that microsecond rounding and the 0.1 s acceleration window never break a
    limit), with derated=False the raw config values (a bound no schedule reaches)."""
    spu = np.asarray(cfg.motors.steps_per_unit, dtype=float)
    rm, am = (RATE_MARGIN, ACCEL_MARGIN) if derated else (1.0, 1.0)
    return cfg.motors.max_step_rate * rm / spu, cfg.motors.max_accel * am / spu


def run_times(cfg, path, derated=True):
    """The time-optimal time of each run between full stops, and the stop time to add."""
    runs, extra, kin = strokes_of(cfg, path)
    rate_u, acc_u = limits(cfg, derated)
    tol = cfg.motion.tolerance_mm
    return [run_time(kin, run, rate_u, acc_u, tol) for run in runs], extra


def reference(cfg, path, derated=True):
    times, extra = run_times(cfg, path, derated)
    return extra + sum(times)


def main(argv):
    from bench import ROOT

    cfg = config.load(ROOT / "config.toml")
    kin = kinematics.from_config(cfg)
    cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
    for path in argv:
        ref = reference(cfg, path)
        plan = pipeline.validate(cfg, gcode.read(path, warn=lambda m: None), (0, 0), cords, path)
        print(f"{os.path.basename(path):<20} reference {ref:9.1f} s  planned {plan.time_s:9.1f} s"
              f"  ratio {plan.time_s / ref:.3f}")


if __name__ == "__main__":
    main(sys.argv[1:])
