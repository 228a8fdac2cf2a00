"""Decoding a trace into motion: coil patterns (drive tables) and step/dir edges into steps of
each motor, the pen pin into pen up/down, and the net steps through the forward kinematics
(V-plotter or polar) into pen points."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import polar as tp
from .config import MOTORS, SEQUENCES, merge_config, steps_per_mm_pair
from .kinematics import forward_kinematics, inverse_kinematics
from .trace import TIME_EPS, _as_trace, _coil_pins


def _pattern_table(drive: str) -> tuple[np.ndarray, int]:
    """Map 4-bit code (IN1 = MSB) -> phase index; 0000 -> -2; not in table -> -1."""
    seq = SEQUENCES[drive]
    table = np.full(16, -1, dtype=np.int64)
    table[0] = -2
    for i, p in enumerate(seq):
        table[int(p, 2)] = i
    return table, len(seq)


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
    net_steps = _decode_motors(dec, c, names, gid, pin, value, G, g_us, g_t)
    pen_state = _decode_pen(dec, c, gid, pin, value, G, g_t)
    _pen_points(dec, c, (L0, R0), spu, net_steps, pen_state, g_t)
    return dec


def _decode_motors(dec: Decoded, c: dict, names, gid, pin, value, G: int, g_us, g_t) -> dict:
    """Each motor's steps (dec.steps) and illegal transitions (dec.illegal, dec.n_illegal), as
    decode() describes them; returns the net steps of each motor after every instant."""
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
    return net_steps


def _decode_pen(dec: Decoded, c: dict, gid, pin, value, G: int, g_t) -> np.ndarray:
    """The pen's values and events (dec.pen_values, dec.pen_events); returns its state (1 =
    down) after every instant."""
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
    return pen_state


def _pen_points(dec: Decoded, c: dict, start_cords, spu, net_steps: dict, pen_state, g_t) -> None:
    """The pen points (dec.t, cords, x, y, pen_down) at the first instant and wherever a cord
    or the pen state changed; cords that cannot be triangulated are a problem."""
    polar = tp.kind(c) == "polar"
    names = tp.motor_names(c)
    L0, R0 = start_cords
    nl, nr = net_steps[names[0]], net_steps[names[1]]
    changed = np.zeros(len(g_t), dtype=bool)
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
