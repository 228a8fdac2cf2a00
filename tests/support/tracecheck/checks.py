"""Checks on the pins and the decoded steps: illegal coil transitions, step intervals against
``max_step_rate``, steps while the pen settles, release at the end, coil patterns at energise
and release, windowed velocities and accelerations, plot time."""

from __future__ import annotations

import math

import numpy as np

from . import polar as tp
from .config import merge_config
from .decoder import Decoded, _per_group_last
from .trace import TIME_EPS, _as_trace, _coil_pins


def illegal_transitions(decoded: Decoded) -> list[str]:
    """Illegal coil transitions found by :func:`decode` (empty = OK)."""
    return list(decoded.illegal)


def min_step_interval(decoded: Decoded) -> dict[str, float]:
    """Smallest time between two consecutive steps of each motor (s).

    ``inf`` for a motor with fewer than two steps.
    """
    out = {}
    for motor in decoded.steps:
        tu = decoded.steps[motor].t_us
        out[motor] = float(np.min(np.diff(tu)) / 1e6) if len(tu) >= 2 else math.inf
    return out


def check_step_rate(decoded: Decoded, max_step_rate: float) -> list[str]:
    """Steps closer together than ``1/max_step_rate - 1e-6`` s (empty = OK)."""
    limit = 1.0 / float(max_step_rate) - TIME_EPS
    probs = []
    for motor in decoded.steps:
        st = decoded.steps[motor]
        if len(st) < 2:
            continue
        iv = np.diff(st.t_us) / 1e6
        bad = np.flatnonzero(iv < limit)
        if len(bad):
            i = int(bad[np.argmin(iv[bad])])
            probs.append(f"{motor}: {len(bad)} step intervals shorter than "
                         f"1/{max_step_rate} s; shortest {iv[i] * 1e6:.0f} us at "
                         f"t={st.times[i + 1]:.6f} (first at t={st.times[bad[0] + 1]:.6f})")
    return probs


def steps_while_settling(decoded: Decoded, settle_s: float,
                         include_initial: bool = False) -> list[str]:
    """Steps taken within ``settle_s`` after the pen pin changed to a nonzero width.

    A step at time ``ts`` violates a change at ``tc`` when
    ``tc <= ts < tc + settle_s - 1e-6`` (a step at the same instant as the
    change counts).  Every change of the pin's value to a nonzero width is a
    change (including re-enabling pulses 0 -> w).  The initial level at the
    first instant is not a change unless ``include_initial``.
    """
    changes = [(t, v) for i, (t, v) in enumerate(decoded.pen_values)
               if v != 0 and (i > 0 or include_initial)]
    probs = []
    settle_us = int(round(float(settle_s) * 1e6))
    for motor in decoded.steps:
        tu = decoded.steps[motor].t_us
        for tc, v in changes:
            tc_us = int(round(tc * 1e6))
            lo = np.searchsorted(tu, tc_us, side="left")
            hi = np.searchsorted(tu, tc_us + settle_us - 1, side="left")  # < tc+settle-1us
            if hi > lo:
                probs.append(f"{motor}: {hi - lo} steps within {settle_s} s after pen set to "
                             f"{v} us at t={tc:.6f} (first step at t={tu[lo] / 1e6:.6f})")
    return probs


def released_at_end(trace, cfg: dict | None = None) -> list[str]:
    """At the end of the trace all coil pins are 0, the pen pin is 0 (pulses
    off) and the last nonzero pen width is ``up_us`` (empty = OK)."""
    tr = _as_trace(trace)
    c = merge_config(cfg)
    probs = []
    order = np.argsort(tr.t_us, kind="stable")
    pin, value = tr.pin[order], tr.value[order]
    coils = _coil_pins(c)
    if tp.driver(c) == "stepdir":       # STEP low, ENABLE high (the timing check has both)
        for p in [coils[m][0] for m in tp.motor_names(c)] + coils["enable"]:
            vals = value[pin == p]
            want = 1 if p in coils["enable"] else 0
            if len(vals) == 0 or vals[-1] != want:
                probs.append(f"pin {p} does not end at {want} (motors not released)")
    for motor in (() if tp.driver(c) == "stepdir" else tp.motor_names(c)):
        for p in coils[motor]:
            vals = value[pin == p]
            if len(vals) == 0:
                probs.append(f"{motor} coil pin {p} never set")
            elif vals[-1] != 0:
                probs.append(f"{motor} coil pin {p} ends at {vals[-1]} (not released)")
    pen_pin = int(c["pen"]["pin"])
    pv = value[pin == pen_pin]
    if len(pv) == 0:
        probs.append(f"pen pin {pen_pin} never set")
    else:
        if pv[-1] != 0:
            probs.append(f"pen pin ends with pulses on ({pv[-1]} us)")
        nz = pv[pv != 0]
        if len(nz) == 0:
            probs.append("pen was never commanded")
        elif nz[-1] != int(c["pen"]["up_us"]):
            probs.append(f"pen last commanded to {nz[-1]} us, not up ({c['pen']['up_us']} us)")
    return probs


def coil_patterns(trace, pins, grouped: bool = True) -> list[int]:
    """The distinct successive patterns of the pins ``pins`` (bit i = pins[i]), starting from
    0: after every instant (rows of one time together, as the contract says), or with
    grouped=False after every single row (what a log of pin timestamps shows when pins are
    written one at a time)."""
    tr = _as_trace(trace)
    bits = {int(p): i for i, p in enumerate(pins)}
    order = np.argsort(tr.t_us, kind="stable")
    rows = list(zip(tr.t_us[order].tolist(), tr.pin[order].tolist(), tr.value[order].tolist()))
    word, out = 0, [0]
    for i, (t, p, v) in enumerate(rows):
        if p in bits:
            word = word | 1 << bits[p] if v else word & ~(1 << bits[p])
        if (not grouped or i + 1 == len(rows) or rows[i + 1][0] != t) and word != out[-1]:
            out.append(word)
    return out


def two_coil_edges(trace, cfg: dict | None = None) -> list[str]:
    """With the half-step table: every energise (0000 -> pattern) and release (pattern ->
    0000) of a coil motor is at a one-coil pattern, so that pins written one at a time pass
    through no other pattern (empty = OK). Instants (rows of one time) count as one change."""
    tr = _as_trace(trace)
    c = merge_config(cfg)
    if tp.driver(c) == "stepdir" or c["motors"].get("drive", "half") != "half":
        return []
    order = np.argsort(tr.t_us, kind="stable")
    t_us, pin, value = tr.t_us[order], tr.pin[order], tr.value[order]
    new_group = np.ones(len(t_us), dtype=bool)
    new_group[1:] = t_us[1:] != t_us[:-1]
    gid = np.cumsum(new_group) - 1
    G = int(gid[-1]) + 1 if len(gid) else 0
    g_us = t_us[new_group]
    coils = _coil_pins(c)
    probs = []
    for motor in tp.motor_names(c):
        code = np.zeros(G, dtype=np.int64)
        for bit, p in enumerate(coils[motor]):
            m = pin == p
            code |= _per_group_last(gid[m], (value[m] != 0).astype(np.int64), G, 0) << bit
        prev = np.concatenate(([0], code[:-1]))
        edge = (code != prev) & ((code == 0) | (prev == 0))
        pattern = np.where(code == 0, prev, code)
        ones = sum((pattern >> b) & 1 for b in range(4))
        for k in np.flatnonzero(edge & (ones != 1)):
            what = "released" if code[k] == 0 else "energised"
            probs.append(f"{motor}: {what} at {int(pattern[k]):04b} (two coils) at "
                         f"t={g_us[k] / 1e6:.6f}")
    return probs


def window_velocities(decoded: Decoded, motor: str, window_s: float = 0.1,
                      offset_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Signed step velocity (steps/s) per window ``[offset + k*w, offset + (k+1)*w)``.

    Windows cover one empty window before t = 0 and one after the end of the
    plot (the motors are at rest before and after), so starting from rest and
    stopping count as accelerations.  Binning is done in exact integer
    microseconds.  Returns ``(window_start_times, velocities)``.
    """
    w_us = int(round(window_s * 1e6))
    off_us = int(round(offset_s * 1e6)) % w_us
    end_us = int(round(decoded.end_time * 1e6))
    # window k = [off + k*w, off + (k+1)*w); from the window before the one
    # holding t = 0 to the window after the one holding the end time
    first = (0 - off_us) // w_us - 1
    last = (end_us - off_us) // w_us + 1
    nwin = last - first + 1
    st = decoded.steps[motor]
    counts = np.zeros(nwin, dtype=np.int64)
    if len(st):
        k = (st.t_us - off_us) // w_us - first
        np.add.at(counts, k, st.dirs)
    starts = (off_us + (np.arange(nwin) + first) * w_us) / 1e6
    return starts, counts / window_s


def max_window_accel(decoded: Decoded, window_s: float = 0.1) -> dict[str, float]:
    """Max |acceleration| (steps/s^2) per motor from windowed step counts.

    velocity of a window = signed steps in it / window_s; acceleration =
    difference of consecutive window velocities / window_s.  Evaluated for
    windows aligned at t = 0 and shifted by half a window; the max over both
    is reported.  Note the quantisation: even a perfect profile may show up
    to ``window_accel_tolerance(window_s)`` (= 2/window_s^2) more than its
    true peak acceleration.
    """
    out = {}
    for motor in decoded.steps:
        best = 0.0
        for off in (0.0, window_s / 2.0):
            _, v = window_velocities(decoded, motor, window_s, off)
            if len(v) >= 2:
                best = max(best, float(np.max(np.abs(np.diff(v)))) / window_s)
        out[motor] = best
    return out


def window_accel_tolerance(window_s: float = 0.1) -> float:
    """Quantisation bound of :func:`max_window_accel`: 2 / window_s^2 steps/s^2.

    (Each window count differs from the continuous displacement by less than
    one step and the second difference combines three cumulative counts.)
    """
    return 2.0 / (window_s * window_s)


def check_window_accel(decoded: Decoded, max_accel: float, window_s: float = 0.1,
                       slack: float | None = None) -> list[str]:
    """Motors whose :func:`max_window_accel` exceeds ``max_accel + slack``.

    ``slack`` defaults to :func:`window_accel_tolerance`.
    """
    slack = window_accel_tolerance(window_s) if slack is None else slack
    return [f"{m}: windowed acceleration {a:.0f} steps/s^2 > {max_accel} (+{slack:.0f} "
            f"quantisation slack)"
            for m, a in max_window_accel(decoded, window_s).items() if a > max_accel + slack]


def plot_time(trace) -> float:
    """Time (s) of the last row of the trace."""
    tr = _as_trace(trace)
    return float(np.max(tr.t)) if len(tr) else 0.0
