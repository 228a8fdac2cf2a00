"""Independent verifier, part two: step/dir drivers and the polar plotter (tracecheck.polar).

Written from the contracts only (README, issue 13), importing nothing of vplotter:

* Step/dir outputs (``[motors] driver = "stepdir"``): per motor a STEP and a DIR pin, one
  ENABLE pin (low = drivers on). A step is a RISING edge of STEP; its direction is the DIR level
  before the edge's instant: DIR high = +1 unless ``<motor>_reverse`` (V-plotter: the cord
  lengthens; polar: the table angle grows (counter-clockwise) / the pen moves away from the
  centre). DIR must not change within ``dir_setup_us`` before a rising edge (nor at its
  instant), STEP must stay high and low at least ``step_pulse_us``, ENABLE must be low at every
  edge and high at the end.
* Polar machine (``[machine] kind = "polar"``): motor coordinates are the table angle a
  (degrees) and the pen radius r (mm). With the table at a, the pen is over the paper point
  ``centre + r (cos(arm - a), sin(arm - a))`` (G-code frame, arm = ``arm_angle_deg``).
"""

from __future__ import annotations

import numpy as np

NAMES = {"vplotter": ("left", "right"), "polar": ("rotary", "linear")}


def kind(c: dict) -> str:
    return c.get("machine", {}).get("kind", "vplotter")


def driver(c: dict) -> str:
    return c["motors"].get("driver", "uln2003")


def motor_names(c: dict) -> tuple[str, str]:
    return NAMES[kind(c)]


def motor_pins(c: dict) -> dict[str, list[int]]:
    """Output pins per motor: IN1..IN4, or [STEP, DIR]; step/dir adds "enable": [pin]."""
    m = c["motors"]
    if driver(c) == "stepdir":
        out = {n: [int(m[f"{n}_step_pin"]), int(m[f"{n}_dir_pin"])] for n in motor_names(c)}
        out["enable"] = [int(m["enable_pin"])]
        return out
    return {n: [int(p) for p in m[f"{n}_pins"]] for n in motor_names(c)}


def steps_per_unit(c: dict) -> tuple[float, float]:
    m = c["motors"]
    if kind(c) == "polar":
        return float(m["rotary_steps_per_deg"]), float(m["linear_steps_per_mm"])
    spm = float(m["steps_per_rev"]) / float(m["spool_circumference_mm"])
    return spm, spm


def _polar(c: dict):
    p = c["polar"]
    return (float(p.get("centre_x_mm", 0.0)), float(p.get("centre_y_mm", 0.0)),
            float(p.get("arm_angle_deg", 0.0)))


def polar_inverse(c: dict, X, Y):
    """(table angle in (-180, 180], radius) with the pen over G-code point(s) X, Y; at the
    centre the angle is 0 (the table's angle is 0 where calibrate leaves it)."""
    cx, cy, arm = _polar(c)
    dx, dy = np.asarray(X, float) - cx, np.asarray(Y, float) - cy
    a = arm - np.degrees(np.arctan2(dy, dx))
    a = 180.0 - np.mod(180.0 - a, 360.0)
    rho = np.hypot(dx, dy)
    return np.where(rho < 1e-9, 0.0, a), rho


def polar_forward(c: dict, a, r):
    cx, cy, arm = _polar(c)
    p = np.radians(arm - np.asarray(a, float))
    r = np.asarray(r, float)
    return cx + r * np.cos(p), cy + r * np.sin(p)


def levels(gid: np.ndarray, pin: np.ndarray, value: np.ndarray, G: int, p: int,
           initial: int = 0) -> np.ndarray:
    """Level (0/1) of pin p after each instant."""
    m = pin == p
    out = np.full(G, initial, dtype=np.int64)
    if not m.any():
        return out
    g, v = gid[m], (value[m] != 0).astype(np.int64)
    last = np.ones(len(g), bool)
    last[:-1] = g[1:] != g[:-1]
    idx = np.full(G, -1, dtype=np.int64)
    idx[g[last]] = np.arange(int(last.sum()))
    idx = np.maximum.accumulate(idx)
    out[idx >= 0] = v[last][idx[idx >= 0]]
    return out


def stepdir_steps(c: dict, motor: str, gid, pin, value, G: int):
    """(instants of the steps, directions +1/-1 in motor coordinates) from STEP rising edges
    with the DIR level before the edge's instant."""
    step_pin, dir_pin = motor_pins(c)[motor]
    s = levels(gid, pin, value, G, step_pin)
    d = levels(gid, pin, value, G, dir_pin)
    rise = np.flatnonzero((s[1:] == 1) & (s[:-1] == 0)) + 1
    high = d[rise - 1] == 1
    dirs = np.where(high, 1, -1).astype(np.int64)
    if c["motors"].get(f"{motor}_reverse", False):
        dirs = -dirs
    return rise, dirs


def check_stepdir_timing(t_us: np.ndarray, pin: np.ndarray, value: np.ndarray, c: dict) -> list[str]:
    """DIR set-up before every rising STEP edge, STEP high and low widths, ENABLE low at every
    edge and high at the end (rows sorted by time; rows at one time act together)."""
    m = c["motors"]
    setup = int(m.get("dir_setup_us", 1))
    width = int(m.get("step_pulse_us", 2))
    pins = motor_pins(c)
    probs = []

    def changes(p):
        """(times, new levels) where pin p's level changes (the last row of an instant wins)."""
        sel = pin == p
        t, v = t_us[sel], (value[sel] != 0).astype(np.int64)
        last = np.ones(len(t), bool)
        last[:-1] = t[1:] != t[:-1]
        t, v = t[last], v[last]
        keep = np.ones(len(t), bool)
        keep[1:] = v[1:] != v[:-1]
        return t[keep], v[keep]

    et, ev = changes(pins["enable"][0])
    for motor in motor_names(c):
        st, sv = changes(pins[motor][0])
        dt, _ = changes(pins[motor][1])
        dt = dt[1:] if len(dt) and dt[0] == 0 else dt         # the initial level at t = 0
        rise = st[sv == 1]
        # DIR changes in (edge - setup, edge]
        lo = np.searchsorted(dt, rise - setup, side="right")
        hi = np.searchsorted(dt, rise, side="right")
        bad = np.flatnonzero(hi > lo)
        if len(bad):
            probs.append(f"{motor}: {len(bad)} DIR changes within {setup} us before a STEP edge "
                         f"(first edge at t={rise[bad[0]] / 1e6:.6f})")
        w = np.diff(st[1:] if len(st) and st[0] == 0 and sv[0] == 0 else st)
        if len(w) and w.min() < width:
            i = int(np.argmin(w))
            probs.append(f"{motor}: STEP level held {w[i]} us < {width} us (at change {i})")
        # ENABLE level at each edge (the last change at or before it)
        k = np.searchsorted(et, rise, side="right") - 1
        en = np.where(k >= 0, ev[np.maximum(k, 0)], 1)
        if np.any(en != 0):
            i = int(np.argmax(en != 0))
            probs.append(f"{motor}: {int((en != 0).sum())} steps while ENABLE is high "
                         f"(first at t={rise[i] / 1e6:.6f})")
        if len(sv) and sv[-1] != 0:
            probs.append(f"{motor}: STEP ends high")
    if not len(ev) or ev[-1] != 1:
        probs.append("ENABLE does not end high (motors not released)")
    return probs


def swept_deg(points: np.ndarray, c: dict, start_angle_deg: float,
              min_radius_mm: float = 1e-6) -> float:
    """Total table rotation that following a densely sampled path needs, starting with the
    table at start_angle_deg: the sum of the shorter-way angle changes between consecutive
    points (across the centre: half a turn)."""
    cx, cy, arm = _polar(c)
    p = np.asarray(points, float)
    rho = np.hypot(p[:, 0] - cx, p[:, 1] - cy)
    p = p[rho > min_radius_mm]
    ang = np.concatenate(([arm - start_angle_deg], np.degrees(np.arctan2(p[:, 1] - cy, p[:, 0] - cx))))
    d = np.diff(ang)
    d = 180.0 - np.mod(180.0 - d, 360.0)
    return float(np.abs(d).sum())


def check_shorter_rotation(rotary_deg_total: float, path_points: np.ndarray, c: dict,
                           start_angle_deg: float, slack_deg: float = 1.0) -> list[str]:
    """The table turned no more than the tool path needs going the shorter way round."""
    need = swept_deg(path_points, c, start_angle_deg)
    if rotary_deg_total > need * 1.001 + slack_deg:
        return [f"the table turned {rotary_deg_total:.2f} degrees; the path needs "
                f"{need:.2f} going the shorter way"]
    return []


def radius_problems(x, y, c: dict, tol_mm: float) -> list[str]:
    cx, cy, _ = _polar(c)
    rho = np.hypot(np.asarray(x) - cx, np.asarray(y) - cy)
    rmax = float(c["polar"]["radius_max_mm"])
    bad = (rho > rmax + tol_mm) | ~np.isfinite(rho)
    if np.any(bad):
        i = int(np.argmax(bad))
        return [f"{int(bad.sum())} pen points beyond the table's reach ({rmax:g} mm), first "
                f"({x[i]:.3f}, {y[i]:.3f})"]
    return []

