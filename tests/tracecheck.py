"""Independent verifier for vplotter GPIO traces.

This module is deliberately written WITHOUT importing or reading anything
from ``vplotter`` itself: it re-implements, from the written contract only,
everything needed to check that a recorded (simulated) drawing is right:

* reading the trace CSV (``# vplotter trace v1`` / ``t,pin,value``),
* decoding the coil patterns of the two stepper motors into steps,
* the pen servo state,
* the V-plotter kinematics (cords <-> pen position),
* a small, independent G-code interpreter that produces the reference
  pen-down path,
* checks (step rate, acceleration, pen settling, release at end, accuracy).

Conventions used throughout
---------------------------
* Machine frame: origin at the LEFT anchor, +x to the right, +y DOWN, right
  anchor at ``(anchor_distance_mm, 0)``.
* G-code frame: ``(X, Y)`` with Y up; machine ``x = origin.x_mm + X``,
  ``y = origin.y_mm - Y``.  All positions returned by this module are in
  G-code coordinates (mm) unless stated otherwise.
* Cords: ``left = hypot(x, y)``, ``right = hypot(D - x, y)`` with the default models;
  ``[gondola]`` (cord spacing, pen below) and ``[cords] stretch`` change them (see
  :func:`inverse_kinematics`), ``[motors] left_/right_spool_circumference_mm`` the steps per
  mm of each motor.
* Motors are named ``"left"`` and ``"right"`` (``"rotary"`` and ``"linear"`` on the polar
  plotter, whose motor coordinates, angle in degrees and radius in mm, take the place of the
  cords; step/dir drivers and the polar kinematics are in ``tracecheck_polar.py``).
* Step directions in :class:`Decoded` are CORD directions: ``+1`` = the step
  lengthened that motor's cord, ``-1`` = shortened it (the ``*_reverse``
  flags are already applied).  ``seq_dirs`` holds the raw direction through
  the coil sequence (+1 forward).
* Times are seconds; internally they are also kept as integer microseconds
  (the trace has 6 decimals) so that grouping of simultaneous rows and the
  window binning are exact.

Check functions return a list of human readable problem strings; an empty
list means OK.
"""

from __future__ import annotations

import copy
import math
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np
from scipy.spatial import cKDTree

import tracecheck_polar as tp

__all__ = [
    "DEFAULT_CONFIG", "SEQUENCES", "HEADER", "TraceFormatError", "GCodeError",
    "Trace", "MotorSteps", "Decoded",
    "load_config", "merge_config", "steps_per_mm", "steps_per_mm_pair",
    "inverse_kinematics", "forward_kinematics",
    "read_trace", "format_problems", "decode",
    "illegal_transitions", "min_step_interval", "check_step_rate",
    "steps_while_settling", "released_at_end", "window_velocities",
    "max_window_accel", "window_accel_tolerance", "check_window_accel",
    "reference_path", "drawn_polylines", "distances_to_polylines",
    "accuracy", "check_accuracy", "check_page", "plot_time", "verify",
]

HEADER = "# vplotter trace v1"
COLUMNS = "t,pin,value"

#: Defaults for every configuration key (same keys as the package's config.toml).
DEFAULT_CONFIG: dict = {
    "machine": {"anchor_distance_mm": 422.5},
    "origin": {"x_mm": 211.25, "y_mm": 430.0},
    "page": {"x_min_mm": -200.0, "x_max_mm": 200.0,
             "y_min_mm": -250.0, "y_max_mm": 300.0},
    "motors": {
        "drive": "half",
        "steps_per_rev": 4096,
        "spool_circumference_mm": 25.0,
        "max_step_rate": 663,
        "max_accel": 2000,
        "left_pins": [0, 5, 6, 13],
        "right_pins": [12, 16, 20, 21],
        "left_reverse": True,
        "right_reverse": False,
    },
    "pen": {"pin": 24, "up_us": 500, "down_us": 1500, "settle_s": 0.3},
    "motion": {"tolerance_mm": 0.01},
}

#: Coil sequences in FORWARD order, as IN1..IN4 bit strings.
SEQUENCES: dict[str, list[str]] = {
    "half": ["1000", "1100", "0100", "0110", "0010", "0011", "0001", "1001"],
    "full": ["1100", "0110", "0011", "1001"],
    "wave": ["1000", "0100", "0010", "0001"],
}

MOTORS = ("left", "right")

#: Slack (seconds) allowed for the 6-decimal rounding of trace times.
TIME_EPS = 1e-6


class TraceFormatError(ValueError):
    """The trace file violates the format contract (cannot be read)."""


class GCodeError(ValueError):
    """The reference G-code interpreter met something it does not support."""


# --------------------------------------------------------------------------
# configuration and kinematics
# --------------------------------------------------------------------------

def merge_config(cfg: dict | None) -> dict:
    """Return a deep copy of ``DEFAULT_CONFIG`` overlaid with ``cfg``.

    ``cfg`` is a nested dict as produced by ``tomllib`` (sections
    ``machine``, ``origin``, ``page``, ``motors``, ``pen``, ``motion``).
    Missing sections/keys take the defaults; unknown keys are kept.
    """
    out = copy.deepcopy(DEFAULT_CONFIG)
    for section, values in (cfg or {}).items():
        if isinstance(values, dict) and isinstance(out.get(section), dict):
            out[section].update(copy.deepcopy(values))
        else:
            out[section] = copy.deepcopy(values)
    drive = out["motors"]["drive"]
    if drive not in SEQUENCES:
        raise ValueError(f"unknown motors.drive {drive!r}")
    if out["pen"].get("kind", "servo") in ("output", "switch"):
        # solenoid and cam pens: the pen pin's trace values are the commands 1 (up), 2 (down)
        out["pen"]["up_us"], out["pen"]["down_us"] = 1, 2
    if out["pen"]["up_us"] == out["pen"]["down_us"]:
        raise ValueError("pen.up_us == pen.down_us")
    return out


def load_config(source: str | os.PathLike | dict | None = None) -> dict:
    """Load a machine config and merge it with the defaults.

    ``source`` may be ``None`` (pure defaults), a dict, a path to a TOML file,
    or TOML text (a ``str`` that is not an existing file name).
    """
    if source is None or isinstance(source, dict):
        return merge_config(source)
    if isinstance(source, os.PathLike) or (
            isinstance(source, str) and "\n" not in source and os.path.isfile(source)):
        with open(source, "rb") as fh:
            return merge_config(tomllib.load(fh))
    return merge_config(tomllib.loads(str(source)))


def steps_per_mm(cfg: dict) -> float:
    """Motor steps per mm of cord: ``steps_per_rev / spool_circumference_mm``."""
    m = merge_config(cfg)["motors"]
    return float(m["steps_per_rev"]) / float(m["spool_circumference_mm"])


def steps_per_mm_pair(cfg: dict) -> tuple[float, float]:
    """Steps per mm of the left and right cords: ``[motors] left_/right_spool_circumference_mm``
    where given, else ``spool_circumference_mm``."""
    m = merge_config(cfg)["motors"]
    return tuple(float(m["steps_per_rev"]) / float(m.get(f"{side}_spool_circumference_mm")
                                                    or m["spool_circumference_mm"])
                 for side in MOTORS)


def _models(c: dict) -> tuple[float, float, float, float]:
    """(anchor distance, gondola cord spacing, pen below the cords' line, cord stretch)."""
    return (float(c["machine"]["anchor_distance_mm"]),
            float(c.get("gondola", {}).get("cord_spacing_mm", 0.0)),
            float(c.get("gondola", {}).get("pen_below_mm", 0.0)),
            float(c.get("cords", {}).get("stretch", 0.0)))


def _machine_cords(c: dict, x, y):
    """What the motors pay out for a pen at machine (x, y).

    The cords hold a gondola (that does not tilt) at two points ``cord_spacing_mm`` apart, the
    pen midway between them and ``pen_below_mm`` below them.  Each cord stretches by
    ``stretch * tension / weight`` (tensions from the balance of the weight: the horizontal
    pulls cancel, the vertical ones carry the weight), so the motor pays out
    ``length / (1 + stretch * tension / weight)``.
    """
    D, s, h, k = _models(c)
    ay = y - h
    lx = x - s / 2.0
    rx = D - (x + s / 2.0)
    geo_l, geo_r = np.hypot(lx, ay), np.hypot(rx, ay)
    if k == 0.0:
        return geo_l, geo_r
    alpha = np.arctan2(ay, lx)          # left cord above the horizontal
    beta = np.arctan2(ay, rx)
    both = np.sin(alpha + beta)
    return geo_l / (1.0 + k * np.cos(beta) / both), geo_r / (1.0 + k * np.cos(alpha) / both)


def inverse_kinematics(cfg: dict, X, Y):
    """Cord lengths paid out (left, right) in mm for G-code point(s) ``(X, Y)``."""
    c = merge_config(cfg)
    x = c["origin"]["x_mm"] + np.asarray(X, dtype=float)
    y = c["origin"]["y_mm"] - np.asarray(Y, dtype=float)
    return _machine_cords(c, x, y)


def forward_kinematics(cfg: dict, left, right):
    """G-code point(s) ``(X, Y)`` from the cord lengths paid out.

    Triangulation ``x = (a^2 - b^2 + D^2) / 2D``, ``y = sqrt(a^2 - x^2)`` (the pen hangs
    below the anchors, y >= 0 in the machine frame) between the anchors moved in by the
    gondola; with stretch, Newton steps on the inverse (finite-difference Jacobian) from
    there.  Cord pairs that do not form a triangle with the anchor line give NaN.
    """
    c = merge_config(cfg)
    D, s, h, k = _models(c)
    a = np.asarray(left, dtype=float)
    b = np.asarray(right, dtype=float)
    d = D - s
    x = (a * a - b * b + d * d) / (2.0 * d)
    y2 = a * a - x * x
    with np.errstate(invalid="ignore"):
        y = np.where(y2 >= 0.0, np.sqrt(np.maximum(y2, 0.0)), np.nan)
    x = x + s / 2.0
    y = y + h
    if k != 0.0:
        eps = 1e-5
        for _ in range(50):
            fl, fr = _machine_cords(c, x, y)
            ul, ur = _machine_cords(c, x + eps, y)
            vl, vr = _machine_cords(c, x, y + eps)
            j11, j12 = (ul - fl) / eps, (vl - fl) / eps
            j21, j22 = (ur - fr) / eps, (vr - fr) / eps
            el, er = fl - a, fr - b
            det = j11 * j22 - j12 * j21
            dx = (el * j22 - j12 * er) / det
            dy = (j11 * er - j21 * el) / det
            x, y = x - dx, y - dy
            with np.errstate(invalid="ignore"):
                if not np.nanmax(np.abs(np.concatenate([np.ravel(dx), np.ravel(dy), [0.0]]))) > 1e-10:
                    break
    return x - c["origin"]["x_mm"], c["origin"]["y_mm"] - y


def _pattern_table(drive: str) -> tuple[np.ndarray, int]:
    """Map 4-bit code (IN1 = MSB) -> phase index; 0000 -> -2; not in table -> -1."""
    seq = SEQUENCES[drive]
    table = np.full(16, -1, dtype=np.int64)
    table[0] = -2
    for i, p in enumerate(seq):
        table[int(p, 2)] = i
    return table, len(seq)


# --------------------------------------------------------------------------
# trace reading
# --------------------------------------------------------------------------

@dataclass
class Trace:
    """A parsed trace.  Rows are in FILE order (see :func:`format_problems`).

    Attributes: ``t`` (float seconds), ``t_us`` (int microseconds, exact),
    ``pin`` (int BCM), ``value`` (int), ``path`` (source or None).
    """
    t: np.ndarray
    t_us: np.ndarray
    pin: np.ndarray
    value: np.ndarray
    path: str | None = None

    def __len__(self) -> int:
        return len(self.t)


def read_trace(path: str | os.PathLike) -> Trace:
    """Read a trace CSV.

    The first line must be exactly ``# vplotter trace v1`` and the first
    non-comment, non-blank line must be ``t,pin,value``.  Any other line
    starting with ``#`` (and blank lines) is skipped wherever it occurs.
    Raises :class:`TraceFormatError` when the file cannot be read as a trace.
    """
    with open(path, "r", encoding="utf-8") as fh:
        lines = fh.read().splitlines()
    if not lines or lines[0].rstrip() != HEADER:
        raise TraceFormatError(
            f"{path}: first line must be {HEADER!r}, got {lines[0] if lines else ''!r}")
    data: list[str] = []
    seen_columns = False
    for ln in lines[1:]:
        s = ln.strip()
        if not s or s.startswith("#"):
            continue
        if not seen_columns:
            if s.replace(" ", "") != COLUMNS:
                raise TraceFormatError(f"{path}: expected column line {COLUMNS!r}, got {s!r}")
            seen_columns = True
            continue
        data.append(s)
    if not seen_columns:
        raise TraceFormatError(f"{path}: no {COLUMNS!r} line")
    if data:
        try:
            arr = np.loadtxt(data, delimiter=",", comments="#", dtype=np.float64, ndmin=2)
        except ValueError as exc:
            raise TraceFormatError(f"{path}: bad data row: {exc}") from exc
        if arr.shape[1] != 3:
            raise TraceFormatError(f"{path}: rows must have 3 fields")
    else:
        arr = np.zeros((0, 3))
    t = arr[:, 0]
    if not np.all(np.isfinite(arr)):
        raise TraceFormatError(f"{path}: non-finite number in data")
    pin = arr[:, 1]
    value = arr[:, 2]
    if np.any(pin != np.round(pin)) or np.any(value != np.round(value)):
        raise TraceFormatError(f"{path}: pin and value must be integers")
    return Trace(t=t.copy(), t_us=np.rint(t * 1e6).astype(np.int64),
                 pin=pin.astype(np.int64), value=value.astype(np.int64),
                 path=str(path))


def _as_trace(trace) -> Trace:
    return trace if isinstance(trace, Trace) else read_trace(trace)


def _coil_pins(cfg: dict) -> dict[str, list[int]]:
    """Output pins per motor (and "enable" for step/dir drivers)."""
    return tp.motor_pins(cfg)


def format_problems(trace, cfg: dict | None = None) -> list[str]:
    """Problems with the trace against the format contract.

    Checks: times non-decreasing and non-negative; times are whole
    microseconds (6 decimals); the first row is at t = 0 and every configured
    pin (8 coil pins + pen pin) has a row at t = 0; coil values are 0/1; pen
    values are >= 0; no rows for pins outside the configuration.
    """
    tr = _as_trace(trace)
    c = merge_config(cfg)
    probs: list[str] = []
    if len(tr) == 0:
        return ["trace has no data rows"]
    if np.any(np.diff(tr.t_us) < 0):
        i = int(np.argmax(np.diff(tr.t_us) < 0))
        probs.append(f"times decrease at data row {i + 1} (t={tr.t[i]:.6f} -> {tr.t[i + 1]:.6f})")
    if np.any(tr.t_us < 0):
        probs.append("negative times")
    if np.any(np.abs(tr.t * 1e6 - tr.t_us) > 1e-3):
        probs.append("times are not whole microseconds (6 decimals)")
    if tr.t_us[0] != 0:
        probs.append(f"first row is at t={tr.t[0]:.6f}, not 0")
    coils = _coil_pins(c)
    pen_pin = int(c["pen"]["pin"])
    motor_pins = [p for pins in coils.values() for p in pins]
    all_pins = motor_pins + [pen_pin]
    at0 = set(tr.pin[tr.t_us == 0].tolist())
    missing = [p for p in all_pins if p not in at0]
    if missing:
        probs.append(f"pins without an initial level at t=0: {missing}")
    coil_mask = np.isin(tr.pin, motor_pins)
    bad = coil_mask & ~np.isin(tr.value, [0, 1])
    if np.any(bad):
        i = int(np.argmax(bad))
        probs.append(f"{int(bad.sum())} coil rows with value not 0/1 (first t={tr.t[i]:.6f} "
                     f"pin={tr.pin[i]} value={tr.value[i]})")
    if np.any(tr.value[tr.pin == pen_pin] < 0):
        probs.append("negative pen pulse width")
    unknown = sorted(set(tr.pin.tolist()) - set(all_pins))
    if unknown:
        probs.append(f"rows for pins not in the configuration: {unknown}")
    return probs


# --------------------------------------------------------------------------
# decoding
# --------------------------------------------------------------------------

@dataclass
class MotorSteps:
    """Steps of one motor.

    ``times`` (s), ``t_us`` (int us), ``dirs`` (+1 cord lengthened / -1
    shortened), ``seq_dirs`` (+1 forward through the coil sequence / -1).
    """
    times: np.ndarray
    t_us: np.ndarray
    dirs: np.ndarray
    seq_dirs: np.ndarray

    def __len__(self) -> int:
        return len(self.times)


def _empty_steps() -> MotorSteps:
    return MotorSteps(np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64),
                      np.zeros(0, np.int64))


@dataclass
class Decoded:
    """Result of :func:`decode`.

    Pen points (one per instant at which a cord or the pen state changed,
    plus the initial state at the first time) are in ``t``, ``x``, ``y``
    (G-code mm), ``pen_down`` (bool); the matching cord lengths are in
    ``left_mm``/``right_mm``.  ``steps`` maps motor -> :class:`MotorSteps`.
    ``illegal`` lists human readable illegal coil transitions (capped at
    ``ILLEGAL_MESSAGE_CAP`` messages; ``n_illegal`` is the full count).
    ``pen_values`` are ``(t, us)`` pairs for every change of the pen pin's
    value between instants (the first entry is the initial level);
    ``pen_events`` are ``(t, down)`` pairs for every change of the pen state.
    ``problems`` collects decoding problems other than illegal transitions
    (e.g. cords that cannot be triangulated).
    """
    cfg: dict = field(default_factory=lambda: merge_config(None))
    start_xy: tuple[float, float] = (0.0, 0.0)
    start_cords: tuple[float, float] = (0.0, 0.0)
    steps: dict[str, MotorSteps] = field(default_factory=lambda: {m: _empty_steps() for m in MOTORS})
    illegal: list[str] = field(default_factory=list)
    n_illegal: int = 0
    pen_values: list[tuple[float, int]] = field(default_factory=list)
    pen_events: list[tuple[float, bool]] = field(default_factory=list)
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    x: np.ndarray = field(default_factory=lambda: np.zeros(0))
    y: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pen_down: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    left_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    right_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    end_time: float = 0.0
    problems: list[str] = field(default_factory=list)

    @property
    def points(self) -> np.ndarray:
        """All pen points as an (N, 2) array in G-code mm."""
        return np.column_stack([self.x, self.y])

    @property
    def down_points(self) -> np.ndarray:
        """Pen points with the pen down, (N, 2)."""
        return self.points[self.pen_down]

    def pen_is_down_at(self, t: float) -> bool:
        """Pen state at time ``t`` (state after all rows with time <= t)."""
        state = False
        for te, down in self.pen_events:
            if te <= t + TIME_EPS / 2:
                state = down
            else:
                break
        return state


ILLEGAL_MESSAGE_CAP = 200


def _per_group_last(gid: np.ndarray, values: np.ndarray, G: int,
                    initial: int) -> np.ndarray:
    """State per group = value of the last row at or before that group.

    ``gid`` must be non-decreasing.  Groups before the first row get ``initial``.
    """
    out = np.full(G, initial, dtype=np.int64)
    if len(gid) == 0:
        return out
    last = np.ones(len(gid), dtype=bool)
    last[:-1] = gid[1:] != gid[:-1]
    g = gid[last]
    v = values[last]
    idx = np.full(G, -1, dtype=np.int64)
    idx[g] = np.arange(len(g))
    idx = np.maximum.accumulate(idx)
    has = idx >= 0
    out[has] = v[idx[has]]
    return out


def decode(trace, cfg: dict | None = None, start_xy=(0.0, 0.0), start_q=None) -> Decoded:
    """Decode a trace into steps, pen state and pen positions.

    Semantics (from the contract):

    * Rows are stably sorted by time; rows with the same time form one
      *instant* and take effect together: the pin levels after the last row
      of an instant are compared with those after the previous instant.
    * Coil pattern of a motor = its four pins IN1..IN4 (a nonzero value counts
      as 1).  Between consecutive instants, a change of pattern is:
      a **step** if both patterns are in the drive's table and are neighbours
      in the cycle (+1 forward / -1 backward); a **release** if the new
      pattern is 0000; an **energise** if the old pattern is 0000 - legal only
      if the new pattern is the one the motor was released at (any pattern
      for the very first energise, i.e. when the motor was released from the
      initial level); anything else (two-phase jump, a pattern not in the
      table, leaving such a pattern) is **illegal** and is not counted as a
      step.  The levels at the first instant are the initial state (not a
      transition); an initial pattern not in the table is illegal.
    * Forward steps lengthen the cord unless ``<side>_reverse`` is true.
    * Start cords are the exact inverse kinematics of ``start_xy`` (G-code
      coordinates); cord = start + net_steps / steps per mm of that motor.
    * Pen: DOWN from an instant whose pen rows include ``down_us`` until an
      instant whose rows include ``up_us`` (the last such row of an instant
      wins); other values (0 = pulses off, or any other width) leave the pen
      state unchanged.  Before any command the pen counts as up.
    * A pen point is emitted for the first instant and for every instant at
      which a cord or the pen state changed; its flag is the pen state after
      that instant.
    """
    tr = _as_trace(trace)
    c = merge_config(cfg)
    names = tp.motor_names(c)
    polar = tp.kind(c) == "polar"
    spu = tp.steps_per_unit(c) if polar else steps_per_mm_pair(c)
    inv = (lambda X, Y: tp.polar_inverse(c, X, Y)) if polar else (
        lambda X, Y: inverse_kinematics(c, X, Y))
    # the polar table's angle is not fixed by the pen's point: start_q gives the motor
    # coordinates at the start (default: the angle in -180..180, as `calibrate --at` sets it)
    L0, R0 = (float(v) for v in (inv(start_xy[0], start_xy[1]) if start_q is None else start_q))
    dec = Decoded(cfg=c, start_xy=(float(start_xy[0]), float(start_xy[1])),
                  start_cords=(L0, R0), steps={m: _empty_steps() for m in names})
    if len(tr) == 0:
        dec.problems.append("empty trace")
        return dec

    order = np.argsort(tr.t_us, kind="stable")
    t_us = tr.t_us[order]
    pin = tr.pin[order]
    value = tr.value[order]
    new_group = np.ones(len(t_us), dtype=bool)
    new_group[1:] = t_us[1:] != t_us[:-1]
    gid = np.cumsum(new_group) - 1
    G = int(gid[-1]) + 1
    g_us = t_us[new_group]
    g_t = g_us / 1e6
    dec.end_time = float(g_t[-1])

    table, n = _pattern_table(c["motors"].get("drive", "half"))
    coils = _coil_pins(c)
    net_steps: dict[str, np.ndarray] = {}
    illegal_total = 0
    illegal_msgs: list[tuple[float, str]] = []
    for motor in names:
        if tp.driver(c) == "stepdir":
            s_groups, dirs = tp.stepdir_steps(c, motor, gid, pin, value, G)
            dec.steps[motor] = MotorSteps(times=g_us[s_groups] / 1e6, t_us=g_us[s_groups].copy(),
                                          dirs=dirs, seq_dirs=dirs.copy())
            per_group = np.zeros(G, dtype=np.int64)
            np.add.at(per_group, s_groups, dirs)
            net_steps[motor] = np.cumsum(per_group)
            continue
        code = np.zeros(G, dtype=np.int64)
        for bit, p in enumerate(coils[motor]):
            m = pin == p
            lvl = _per_group_last(gid[m], (value[m] != 0).astype(np.int64), G, 0)
            code |= lvl << (3 - bit)
        reverse = bool(c["motors"][f"{motor}_reverse"])
        chg = np.flatnonzero(code[1:] != code[:-1]) + 1      # instants with a change
        seq = np.concatenate([[code[0]], code[chg]])           # distinct successive codes
        ph = table[seq]
        if ph[0] == -1:
            illegal_total += 1
            illegal_msgs.append((float(g_t[0]), f"{motor}: initial pattern {seq[0]:04b} "
                                 f"is not in the {c['motors']['drive']} table"))
        prev, new = ph[:-1], ph[1:]
        both = (prev >= 0) & (new >= 0)
        d = np.mod(new - prev, n)
        fwd = both & (d == 1)
        bwd = both & (d == n - 1)
        energise = (prev == -2) & (new >= 0)
        k = np.arange(1, len(seq))                              # transition k: seq[k-1] -> seq[k]
        before_release = np.where(k >= 2, ph[np.maximum(k - 2, 0)], -3)  # -3: never released before
        bad_energise = energise & (before_release != -3) & (before_release != new)
        release = (new == -2)
        ok = fwd | bwd | release | (energise & ~bad_energise)
        bad = ~ok
        for j in np.flatnonzero(bad):
            tj = float(g_t[chg[j]])
            a, b = int(seq[j]), int(seq[j + 1])
            if bad_energise[j]:
                r = int(seq[j - 1])
                why = (f"energised at {b:04b} but released at {r:04b}" if table[r] >= 0
                       else f"energised after release from invalid pattern {r:04b}")
            elif new[j] == -1:
                why = "pattern not in the drive table"
            elif prev[j] == -1:
                why = "leaving a pattern not in the drive table (position lost)"
            else:
                why = f"jump of {int(d[j])} phases"
            illegal_total += 1
            if len(illegal_msgs) < 4 * ILLEGAL_MESSAGE_CAP:
                illegal_msgs.append((tj, f"{motor}: illegal transition {a:04b} -> {b:04b} "
                                     f"at t={tj:.6f} ({why})"))
        step_mask = fwd | bwd
        s_groups = chg[step_mask]
        seq_dirs = np.where(fwd[step_mask], 1, -1).astype(np.int64)
        dirs = -seq_dirs if reverse else seq_dirs.copy()
        dec.steps[motor] = MotorSteps(times=g_us[s_groups] / 1e6, t_us=g_us[s_groups].copy(),
                                      dirs=dirs, seq_dirs=seq_dirs)
        per_group = np.zeros(G, dtype=np.int64)
        np.add.at(per_group, s_groups, dirs)
        net_steps[motor] = np.cumsum(per_group)
    illegal_msgs.sort(key=lambda m: m[0])
    dec.n_illegal = illegal_total
    dec.illegal = [m for _, m in illegal_msgs[:ILLEGAL_MESSAGE_CAP]]
    if illegal_total > len(dec.illegal):
        dec.illegal.append(f"... {illegal_total - len(dec.illegal)} more illegal transitions")

    # pen
    pen_pin = int(c["pen"]["pin"])
    up_us, down_us = int(c["pen"]["up_us"]), int(c["pen"]["down_us"])
    pm = pin == pen_pin
    pen_val = _per_group_last(gid[pm], value[pm], G, 0)
    cmd = pm & ((value == up_us) | (value == down_us))
    pen_state = _per_group_last(gid[cmd], (value[cmd] == down_us).astype(np.int64), G, 0)
    vchg = np.concatenate([[0], np.flatnonzero(pen_val[1:] != pen_val[:-1]) + 1])
    dec.pen_values = [(float(g_t[i]), int(pen_val[i])) for i in vchg]
    schg = np.flatnonzero(pen_state[1:] != pen_state[:-1]) + 1
    dec.pen_events = ([(float(g_t[0]), True)] if pen_state[0] else []) + \
        [(float(g_t[i]), bool(pen_state[i])) for i in schg]

    # pen points
    nl, nr = net_steps[names[0]], net_steps[names[1]]
    changed = np.zeros(G, dtype=bool)
    changed[0] = True
    changed[1:] = (nl[1:] != nl[:-1]) | (nr[1:] != nr[:-1]) | (pen_state[1:] != pen_state[:-1])
    sel = np.flatnonzero(changed)
    dec.t = g_t[sel]
    dec.left_mm = L0 + nl[sel] / spu[0]
    dec.right_mm = R0 + nr[sel] / spu[1]
    fwd = (lambda a, r: tp.polar_forward(c, a, r)) if polar else (
        lambda a, b: forward_kinematics(c, a, b))
    dec.x, dec.y = fwd(dec.left_mm, dec.right_mm)
    dec.pen_down = pen_state[sel].astype(bool)
    nan = np.isnan(dec.y)
    if np.any(nan):
        i = int(np.argmax(nan))
        dec.problems.append(f"{int(nan.sum())} cord states cannot be triangulated "
                            f"(first at t={dec.t[i]:.6f}: left={dec.left_mm[i]:.4f} "
                            f"right={dec.right_mm[i]:.4f})")
    return dec


# --------------------------------------------------------------------------
# checks on the decoded drawing
# --------------------------------------------------------------------------

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


# --------------------------------------------------------------------------
# reference G-code interpreter
# --------------------------------------------------------------------------

_WORD_RE = re.compile(r"([A-Z])\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+))")
_COMMENT_RE = re.compile(r"\([^)]*\)")

#: G codes accepted and ignored (besides the ones interpreted).
IGNORED_G = {"17", "40", "49", "54", "61", "64", "80", "94", "91.1"}
#: M codes accepted and ignored (besides M2, M30, M3, M5).
IGNORED_M = {"7", "8", "9"}
_ALLOWED_LETTERS = set("GMXYZIJRFPSTN")


def _clean_line(raw: str) -> str:
    s = _COMMENT_RE.sub(" ", raw)
    for ch in "(;":          # unclosed parenthesis or ';' comment: drop the rest
        if ch in s:
            s = s[: s.index(ch)]
    if "*" in s:             # checksum
        s = s[: s.index("*")]
    s = s.replace("%", " ").strip()
    if s.startswith("/"):    # block delete switch assumed off: block executes
        s = s[1:]
    return s.upper()


def _code_key(v: float) -> str:
    return f"{round(v, 4):g}"


def _parse_block(s: str, lineno: int):
    words = list(_WORD_RE.finditer(s))
    rest = _WORD_RE.sub("", s).strip()
    if rest:
        raise GCodeError(f"line {lineno}: cannot parse {rest!r}")
    gs, ms, vals = [], [], {}
    for m in words:
        letter, num = m.group(1), float(m.group(2))
        if letter not in _ALLOWED_LETTERS:
            raise GCodeError(f"line {lineno}: unsupported word {m.group(0)!r}")
        if letter == "G":
            gs.append(_code_key(num))
        elif letter == "M":
            ms.append(_code_key(num))
        else:
            if letter in vals:
                raise GCodeError(f"line {lineno}: duplicate {letter} word")
            vals[letter] = num
    return gs, ms, vals


def _sample_line(p0: np.ndarray, p1: np.ndarray, spacing: float) -> np.ndarray:
    """Points after ``p0`` up to and including ``p1`` with spacing <= ``spacing``."""
    length = float(np.hypot(*(p1 - p0)))
    if length == 0.0:
        return np.zeros((0, 2))
    nseg = max(1, math.ceil(length / spacing))
    f = np.arange(1, nseg + 1) / nseg
    pts = p0 + np.outer(f, p1 - p0)
    pts[-1] = p1
    return pts


def _arc_sweep(a0: float, a1: float, clockwise: bool, full: bool) -> float:
    if full:
        return -2 * math.pi if clockwise else 2 * math.pi
    if clockwise:
        sw = -math.fmod((a0 - a1) % (2 * math.pi), 2 * math.pi)
    else:
        sw = math.fmod((a1 - a0) % (2 * math.pi), 2 * math.pi)
    if sw == 0.0:            # same angle but a different point: one full turn
        sw = -2 * math.pi if clockwise else 2 * math.pi
    return sw


def _sample_arc(p0: np.ndarray, p1: np.ndarray, centre: np.ndarray, clockwise: bool,
                spacing: float) -> np.ndarray:
    """Arc/spiral from ``p0`` to ``p1`` around ``centre`` (points after p0, incl. p1).

    Full circle when ``p0 == p1`` (within 1e-9 mm).  Radius is linear in the
    swept angle (exact circle when both radii are equal); the last point is
    exactly ``p1``.  Spacing <= ``spacing`` (uses an upper bound of the
    spiral length).
    """
    v0, v1 = p0 - centre, p1 - centre
    r0, r1 = float(np.hypot(*v0)), float(np.hypot(*v1))
    a0, a1 = math.atan2(v0[1], v0[0]), math.atan2(v1[1], v1[0])
    full = float(np.hypot(*(p1 - p0))) <= 1e-9
    sw = _arc_sweep(a0, a1, clockwise, full)
    bound = abs(sw) * max(r0, r1) + abs(r1 - r0)
    if bound == 0.0:
        return np.zeros((0, 2))
    nseg = max(1, math.ceil(bound / spacing))
    f = np.arange(1, nseg + 1) / nseg
    ang = a0 + sw * f
    rad = r0 + (r1 - r0) * f
    pts = centre + np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    pts[-1] = p1
    return pts


def _read_gcode_text(src) -> str:
    if isinstance(src, os.PathLike):
        return Path(src).read_text(encoding="utf-8", errors="replace")
    if isinstance(src, str) and "\n" not in src and len(src) < 4096 and os.path.isfile(src):
        return Path(src).read_text(encoding="utf-8", errors="replace")
    return str(src)


def reference_path(gcode, start_xy=(0.0, 0.0), spacing: float = 0.005,
                   travel: bool = False) -> list[np.ndarray]:
    """Pen-down polylines of a G-code program, densely sampled (with ``travel``: one
    polyline of the whole tool path from ``start_xy``, pen up or down).

    ``gcode`` is a path (``str``/``PathLike`` to an existing file) or program
    text.  Returns a list of ``(N, 2)`` arrays in G-code mm; consecutive
    points are at most ``spacing`` apart (arcs are sampled ON the curve, so
    the chord error is at most ``spacing^2 / 8r``).  A pen-down with no
    motion before the pen-up gives a single-point polyline.

    Supported: G0/G1/G2/G3 (also G00.., modal; axis words without any prior
    motion code use G0), X Y Z I J R F, G20/G21, G90/G91 (I and J are always
    relative to the arc start), comments ``( )`` and ``;``, N words,
    ``*checksum``, ``%``, leading ``/``, M2/M30 (end after the block's
    motion), G4 (dwell, ignored) and the ignored codes in ``IGNORED_G`` /
    ``IGNORED_M`` plus S/T/P/F words.  Anything else raises
    :class:`GCodeError`.

    Pen: if the program contains any Z word it is a Z-pen program: Z < 0 is
    down, Z >= 0 up (Z tracked absolutely, relative under G91, starting at
    0); M3/M5 are ignored.  Otherwise M3 = down, M5 = up.  The pen starts up
    and a pen change takes effect before the XY motion of the same block.
    The pen state, not G0/G1, decides whether a motion draws.

    Arcs: G2 clockwise, G3 counter-clockwise (Y up).  Start == end (within
    1e-9 mm) is a full circle; start != end at the same angle is one full
    turn of a spiral.  R form: centre on the left (G3) / right (G2) of the
    chord for R > 0, the other side for R < 0 (arc > 180 degrees); R with
    start == end is an error.  When the end radius differs from the start
    radius (I/J form) the arc is a spiral whose radius is linear in the swept
    angle around the I/J centre, ending exactly at the end point.
    """
    text = _read_gcode_text(gcode)
    lines = [(i + 1, _clean_line(raw)) for i, raw in enumerate(text.splitlines())]
    blocks = []
    for lineno, s in lines:
        if s:
            blocks.append((lineno, *_parse_block(s, lineno)))
    z_file = any("Z" in vals for _, _, _, vals in blocks)

    pos = np.array([float(start_xy[0]), float(start_xy[1])])
    scale = 1.0           # mm per program unit
    absolute = True
    motion: str | None = None
    z = 0.0
    pen = False
    polylines: list[np.ndarray] = []
    current: list[np.ndarray] = []
    tool: list[np.ndarray] = [pos.reshape(1, 2).copy()]

    def pen_set(down: bool):
        nonlocal pen, current
        if down and not pen:
            current = [pos.reshape(1, 2).copy()]
        elif pen and not down:
            polylines.append(np.concatenate(current))
            current = []
        pen = down

    for lineno, gs, ms, vals in blocks:
        block_motion = None
        for g in gs:
            if g in ("0", "1", "2", "3"):
                if block_motion is not None:
                    raise GCodeError(f"line {lineno}: two motion codes in one block")
                block_motion = g
            elif g == "20":
                scale = 25.4
            elif g == "21":
                scale = 1.0
            elif g == "90":
                absolute = True
            elif g == "91":
                absolute = False
            elif g == "4" or g in IGNORED_G:
                pass
            else:
                raise GCodeError(f"line {lineno}: unsupported G{g}")
        end_program = False
        pen_cmd = None
        for m in ms:
            if m in ("2", "30"):
                end_program = True
            elif m == "3":
                pen_cmd = True
            elif m == "5":
                pen_cmd = False
            elif m in IGNORED_M:
                pass
            else:
                raise GCodeError(f"line {lineno}: unsupported M{m}")
        if block_motion is not None:
            motion = block_motion
        # pen change first
        if z_file:
            if "Z" in vals:
                z = vals["Z"] * scale if absolute else z + vals["Z"] * scale
                pen_set(z < 0)
        elif pen_cmd is not None:
            pen_set(pen_cmd)
        # motion
        has_xy = "X" in vals or "Y" in vals
        has_arc = "I" in vals or "J" in vals or "R" in vals
        mode = motion if motion is not None else "0"
        if mode in ("0", "1"):
            if has_arc:
                raise GCodeError(f"line {lineno}: I/J/R without G2/G3")
        if has_xy or (mode in ("2", "3") and has_arc):
            target = pos.copy()
            for k, axis in ((0, "X"), (1, "Y")):
                if axis in vals:
                    target[k] = vals[axis] * scale if absolute else pos[k] + vals[axis] * scale
            if mode in ("0", "1"):
                pts = _sample_line(pos, target, spacing)
            else:
                cw = mode == "2"
                if "R" in vals:
                    if "I" in vals or "J" in vals:
                        raise GCodeError(f"line {lineno}: both R and I/J")
                    centre = _centre_from_r(pos, target, vals["R"] * scale, cw, lineno)
                else:
                    if not ("I" in vals or "J" in vals):
                        raise GCodeError(f"line {lineno}: arc without I/J/R")
                    centre = pos + np.array([vals.get("I", 0.0), vals.get("J", 0.0)]) * scale
                pts = _sample_arc(pos, target, centre, cw, spacing)
            if len(pts):
                tool.append(pts)
            if pen and len(pts):
                current.append(pts)
            pos = target
        if end_program:
            break
    if travel:
        return [np.concatenate(tool)]
    if pen:
        polylines.append(np.concatenate(current))
    return polylines


def _centre_from_r(p0, p1, r, clockwise, lineno):
    chord = p1 - p0
    d = float(np.hypot(*chord))
    if d == 0.0:
        raise GCodeError(f"line {lineno}: R-form arc with start == end")
    h2 = r * r - (d / 2.0) ** 2
    if h2 < 0.0:
        if d / 2.0 - abs(r) > 1e-6 * max(1.0, abs(r)):
            raise GCodeError(f"line {lineno}: arc radius {abs(r)} < half chord {d / 2}")
        h2 = 0.0
    u = chord / d
    left = np.array([-u[1], u[0]])
    side = 1.0 if not clockwise else -1.0     # small CCW arc: centre on the left
    if r < 0:
        side = -side
    return (p0 + p1) / 2.0 + side * math.sqrt(h2) * left


# --------------------------------------------------------------------------
# accuracy
# --------------------------------------------------------------------------

def drawn_polylines(decoded: Decoded) -> list[np.ndarray]:
    """Runs of consecutive pen-down points of a decoded drawing, as (N, 2) arrays."""
    down = np.asarray(decoded.pen_down, dtype=bool)
    pts = np.column_stack([decoded.x, decoded.y])
    out = []
    if len(down) == 0:
        return out
    edges = np.flatnonzero(np.diff(np.concatenate([[0], down.astype(np.int8), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):
        out.append(pts[a:b])
    return out


def _densify(poly: np.ndarray, spacing: float) -> np.ndarray:
    """Insert points on the segments of ``poly`` so that none is longer than ``spacing``."""
    poly = np.asarray(poly, dtype=float).reshape(-1, 2)
    if len(poly) < 2:
        return poly
    d = np.diff(poly, axis=0)
    seg = np.hypot(d[:, 0], d[:, 1])
    if np.all(seg <= spacing):
        return poly
    nseg = np.maximum(1, np.ceil(seg / spacing).astype(np.int64))
    idx = np.repeat(np.arange(len(seg)), nseg)               # segment of each new point
    first = np.cumsum(nseg) - nseg
    k = np.arange(len(idx)) - np.repeat(first, nseg) + 1     # 1..nseg within the segment
    f = k / nseg[idx]
    pts = poly[idx] + f[:, None] * d[idx]
    ends = np.cumsum(nseg) - 1
    pts[ends] = poly[1:]                                     # exact original vertices
    return np.concatenate([poly[:1], pts])


def distances_to_polylines(points, polylines: Sequence[np.ndarray], spacing: float = 0.005,
                           k: int = 4, chunk: int = 100_000) -> np.ndarray:
    """Distance from each point to the nearest of ``polylines`` (segments, not vertices).

    The polylines are densified to segments of at most ``spacing``; a
    ``cKDTree`` of the vertices gives the ``k`` nearest vertices and the
    exact point-to-segment distance is taken over the segments adjacent to
    them.  Error bound: with ``d`` the true distance the result ``r``
    satisfies ``d <= r <= sqrt(d^2 + (spacing/2)^2)`` (exact whenever the
    nearer end of the nearest segment is among the k vertices, which is the
    normal case); at d = 0.02 mm and spacing 0.005 mm the bound is 0.00016 mm.
    Returns ``inf`` for every point when there are no polylines.
    """
    P = np.asarray(points, dtype=float).reshape(-1, 2)
    polys = [_densify(p, spacing) for p in polylines if len(p)]
    if len(P) == 0:
        return np.zeros(0)
    if not polys:
        return np.full(len(P), np.inf)
    V = np.concatenate(polys)
    has_next = np.concatenate([np.r_[np.ones(len(p) - 1, bool), False] for p in polys])
    tree = cKDTree(V)
    nV = len(V)
    kk = min(k, nV)
    out = np.empty(len(P))
    Vx, Vy = V[:, 0], V[:, 1]
    for s in range(0, len(P), chunk):
        Q = P[s:s + chunk]
        dv, iv = tree.query(Q, k=kk)
        if kk == 1:
            dv, iv = dv[:, None], iv[:, None]
        best = dv.min(axis=1)
        qx, qy = Q[:, 0:1], Q[:, 1:2]
        for off in ((0, -1) if nV >= 2 else ()):
            a = iv + off                    # segment a -> a+1
            valid = (a >= 0) & (a < nV - 1)
            a = np.clip(a, 0, nV - 2)
            valid &= has_next[a]
            ax, ay = Vx[a], Vy[a]
            abx, aby = Vx[a + 1] - ax, Vy[a + 1] - ay
            L2 = abx * abx + aby * aby
            dot = (qx - ax) * abx + (qy - ay) * aby
            tpar = np.clip(dot / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
            dseg = np.hypot(qx - ax - tpar * abx, qy - ay - tpar * aby)
            dseg[~valid] = np.inf
            best = np.minimum(best, dseg.min(axis=1))
        out[s:s + chunk] = best
    return out


def accuracy(decoded: Decoded, polylines: Sequence[np.ndarray],
             spacing: float = 0.005) -> tuple[float, float]:
    """``(max_drawn_to_path_mm, max_path_to_drawn_mm)``.

    * drawn -> path: for every decoded pen point with the pen down, the
      distance to the nearest reference polyline (segment distance).
    * path -> drawn: for every reference vertex (polylines densified to
      ``spacing``), the distance to the nearest drawn polyline (runs of
      consecutive pen-down points, joined by straight segments; a lone
      pen-down point counts as a dot).  Because the reference vertices are
      at most ``spacing`` apart, the max over the continuous path is at most
      this value + spacing/2.

    See :func:`distances_to_polylines` for the (tiny) error bound.  With no
    reference path a pen-down drawing gives ``inf`` for the first value; with
    no pen-down drawing a non-empty reference gives ``inf`` for the second.
    """
    d1, d2 = _accuracy_arrays(decoded, polylines, spacing)
    return (float(d1.max()) if len(d1) else 0.0, float(d2.max()) if len(d2) else 0.0)


def _accuracy_arrays(decoded, polylines, spacing):
    drawn_pts = decoded.down_points
    ref = [_densify(p, spacing) for p in polylines if len(p)]
    ref_pts = np.concatenate(ref) if ref else np.zeros((0, 2))
    d1 = distances_to_polylines(drawn_pts, ref, spacing)
    d2 = distances_to_polylines(ref_pts, drawn_polylines(decoded), spacing)
    return d1, d2


def check_accuracy(decoded: Decoded, polylines: Sequence[np.ndarray],
                   tol_mm: float = 0.02, spacing: float = 0.005) -> list[str]:
    """Problems when either direction of :func:`accuracy` exceeds ``tol_mm``,
    naming the worst location (G-code mm)."""
    d1, d2 = _accuracy_arrays(decoded, polylines, spacing)
    probs = []
    if len(d1) and d1.max() > tol_mm:
        i = int(np.argmax(d1))
        p = decoded.down_points[i]
        probs.append(f"drawn point ({p[0]:.4f}, {p[1]:.4f}) is {d1[i]:.4f} mm from the "
                     f"reference path ({int((d1 > tol_mm).sum())} drawn points > {tol_mm} mm)")
    if len(d2) and d2.max() > tol_mm:
        ref = np.concatenate([_densify(p, spacing) for p in polylines if len(p)])
        i = int(np.argmax(d2))
        probs.append(f"reference point ({ref[i][0]:.4f}, {ref[i][1]:.4f}) is {d2[i]:.4f} mm "
                     f"from the drawing ({int((d2 > tol_mm).sum())} reference points > {tol_mm} mm)")
    return probs


def check_page(decoded: Decoded, cfg: dict | None = None, tol_mm: float = 0.02,
               pen_down_only: bool = False) -> list[str]:
    """Pen points outside the page rectangle (G-code mm) by more than ``tol_mm``."""
    c = merge_config(cfg if cfg is not None else decoded.cfg)
    pg = c["page"]
    x, y = np.asarray(decoded.x), np.asarray(decoded.y)
    if pen_down_only:
        x, y = x[decoded.pen_down], y[decoded.pen_down]
    if tp.kind(c) == "polar":
        return tp.radius_problems(x, y, c, tol_mm)
    bad = ((x < pg["x_min_mm"] - tol_mm) | (x > pg["x_max_mm"] + tol_mm) |
           (y < pg["y_min_mm"] - tol_mm) | (y > pg["y_max_mm"] + tol_mm) | np.isnan(y))
    if np.any(bad):
        i = int(np.argmax(bad))
        return [f"{int(bad.sum())} pen points outside the page, first ({x[i]:.3f}, {y[i]:.3f})"]
    return []


# --------------------------------------------------------------------------
# everything at once
# --------------------------------------------------------------------------

def verify(trace, gcode, cfg: dict | None = None, start_xy=(0.0, 0.0),
           tol_mm: float = 0.02, accel_window_s: float = 0.1,
           check_accel: bool = True, page: bool = True, start_q=None) -> list[str]:
    """Run every check on a trace against its G-code; returns all problems.

    ``trace`` is a :class:`Trace` or a path; ``gcode`` a path or program
    text; ``cfg`` a (partial) config dict.  Checks: format, decoding
    problems, illegal transitions, step rate (``max_step_rate``), pen
    settling (``settle_s``), release at end, windowed acceleration
    (``max_accel`` + quantisation slack, if ``check_accel``), page bounds (if
    ``page``) and accuracy (``tol_mm`` both ways).  Each problem is prefixed
    with the name of the check.
    """
    tr = _as_trace(trace)
    c = merge_config(cfg)
    dec = decode(tr, c, start_xy, start_q)
    probs: list[str] = []

    def add(name: str, items: Iterable[str]):
        probs.extend(f"[{name}] {p}" for p in items)

    add("format", format_problems(tr, c))
    add("decode", dec.problems)
    if tp.driver(c) == "stepdir":
        order = np.argsort(tr.t_us, kind="stable")
        add("stepdir", tp.check_stepdir_timing(tr.t_us[order], tr.pin[order], tr.value[order], c))
    if tp.kind(c) == "polar":
        tool = reference_path(gcode, start_xy, travel=True)
        # every pen point, up or down, on the tool path: travel follows straight lines too
        far = distances_to_polylines(dec.points, tool)
        if len(far) and far.max() > tol_mm:
            i = int(np.argmax(far))
            add("travel", [f"pen point ({dec.x[i]:.4f}, {dec.y[i]:.4f}) is {far[i]:.4f} mm off "
                           f"the tool path"])
        turned = float(np.abs(dec.steps["rotary"].dirs).sum()) / tp.steps_per_unit(c)[0]
        add("rotation", tp.check_shorter_rotation(turned, tool[0], c, dec.start_cords[0]))
    add("illegal", illegal_transitions(dec))
    add("step-rate", check_step_rate(dec, c["motors"]["max_step_rate"]))
    add("settle", steps_while_settling(dec, c["pen"]["settle_s"]))
    add("release", released_at_end(tr, c))
    if check_accel:
        add("accel", check_window_accel(dec, c["motors"]["max_accel"], accel_window_s))
    if page:
        add("page", check_page(dec, c))
    add("accuracy", check_accuracy(dec, reference_path(gcode, start_xy), tol_mm))
    return probs
