"""GPIO trace v1: every output change as `t,pin,value` rows (a contract other tools read).
Written while playing (`TraceWriter`), read back into steps and pen states (`read_steps`).

    # vplotter trace v1
    t,pin,value
    0.000000,0,0

t = seconds since the start, pin = BCM number, value = 0/1 for the motor pins (coils, or STEP,
DIR and ENABLE) and the pulse width in microseconds for the pen pin (0 = pulses off; the
codes 1 = up, 2 = down for solenoid and cam pens). The first rows give every pin at t = 0;
rows with equal t take effect together.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TextIO

import numpy as np

from vplotter.errors import InputError
from vplotter.motion.schedule import Rows

HEADER = "# vplotter trace v1\nt,pin,value\n"


class TraceWriter:
    def __init__(self, out: TextIO, coil_pins: list[int], pen_pin: int):
        self.out = out
        self.coil_pins = np.asarray(coil_pins, dtype=np.int64)
        self.pen_pin = pen_pin
        self.coils: int | None = None
        self.pen = 0
        out.write(HEADER)

    def comment(self, text: str) -> None:
        for line in text.splitlines():
            self.out.write(f"# {line}\n")

    def write(self, rows: Rows) -> None:
        if len(rows) == 0:
            return
        words = rows.coils.astype(np.int64)
        pens = rows.pen_us.astype(np.int64)
        if self.coils is None:
            # the first rows give the initial level of every pin
            init = [f"{_t(int(rows.t_us[0]))},{int(p)},{(int(words[0]) >> b) & 1}"
                    for b, p in enumerate(self.coil_pins)]
            init.append(f"{_t(int(rows.t_us[0]))},{self.pen_pin},{int(pens[0])}")
            self.out.write("\n".join(init) + "\n")
            self.coils, self.pen = int(words[0]), int(pens[0])
            rows = rows[1:]
            words, pens = words[1:], pens[1:]
            if len(words) == 0:
                return
        prev_w = np.concatenate(([self.coils], words[:-1]))
        prev_p = np.concatenate(([self.pen], pens[:-1]))
        changed = (prev_w ^ words)
        bits = ((changed[:, None] >> np.arange(len(self.coil_pins))) & 1).astype(bool)
        r_idx, b_idx = np.nonzero(bits)
        vals = (words[r_idx] >> b_idx) & 1
        pen_idx = np.flatnonzero(prev_p != pens)
        # merge coil and pen changes in row order (pen after coils within a row)
        ridx = np.concatenate((r_idx, pen_idx))
        pins = np.concatenate((self.coil_pins[b_idx], np.full(len(pen_idx), self.pen_pin)))
        values = np.concatenate((vals, pens[pen_idx]))
        key = np.concatenate((r_idx * 2, pen_idx * 2 + 1))
        order = np.argsort(key, kind="stable")
        t = rows.t_us[ridx[order]]
        sec, usec = np.divmod(t, 1_000_000)
        lines = [f"{s}.{u:06d},{p},{v}\n" for s, u, p, v in
                 zip(sec.tolist(), usec.tolist(), pins[order].tolist(), values[order].tolist())]
        self.out.write("".join(lines))
        self.out.flush()       # what was played is on disk, even if the process is killed
        self.coils, self.pen = int(words[-1]), int(pens[-1])


def _t(t_us: int) -> str:
    return f"{t_us // 1_000_000}.{t_us % 1_000_000:06d}"


@dataclass(frozen=True)
class Steps:
    """What a trace did, on one timeline: after each change (t_s), the steps each motor has made
    since the start (cord direction: + lengthens, reverse flags applied) and whether the pen is
    down (the last pulse width other than 0 is not up_us, settled or not: a pen of [pens.NAME]
    may have a down_us of its own)."""

    t_s: np.ndarray          # (N,)
    steps: np.ndarray        # (N, 2) int64, left and right
    down: np.ndarray         # (N,) bool


def read_steps(path: str, motors, pen) -> Steps:
    """Decode a trace v1 with the pins and coil table of config's [motors] and [pen].

    Raises InputError (one line naming the file) for anything that is not such a trace."""
    from vplotter.motion.sequencer import TABLES

    t_us, pin, value = _load(path)
    coil = {"left": np.asarray(motors.left_pins), "right": np.asarray(motors.right_pins)}
    known = np.concatenate((coil["left"], coil["right"], [pen.pin]))
    stray = ~np.isin(pin, known)
    if stray.any():
        raise InputError(f"{path}: error: pin {int(pin[stray.argmax()])} is not one of the "
                         f"config's pins ([motors] left_pins {list(coil['left'])}, right_pins "
                         f"{list(coil['right'])}, [pen] pin {pen.pin})")
    for k in known.tolist():
        if not (pin == k).any():
            raise InputError(f"{path}: error: the trace has no rows for pin {k} of the config "
                             f"(wrong config for this trace?)")
    table = TABLES[motors.drive]
    sign = {"left": -1 if motors.left_reverse else 1, "right": -1 if motors.right_reverse else 1}
    runs = [_motor(path, t_us, pin, value, coil[m], table, m) for m in ("left", "right")]
    # the pen: only pulse widths other than 0 say where it is
    is_pen = (pin == pen.pin) & (value != 0)
    t_pen, pen_down = _last_per_time(t_us[is_pen], value[is_pen] != pen.up_us)
    times = np.sort(np.concatenate([runs[0][0], runs[1][0], t_pen]))
    times = times[np.r_[True, times[1:] != times[:-1]]]
    steps = np.stack([sign[m] * _at(times, t, s, 0) for m, (t, s) in zip(("left", "right"), runs)],
                     axis=1)
    return Steps(times / 1e6, steps, _at(times, t_pen, pen_down, False).astype(bool))


def _load(path: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    where = f"{path}: error:"
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            if f.readline().strip() != HEADER.splitlines()[0]:
                raise InputError(f"{where} not a vplotter trace (the first line must be "
                                 f"'{HEADER.splitlines()[0]}')")
            if f.readline().strip() != HEADER.splitlines()[1]:
                raise InputError(f"{where} not a vplotter trace v1 (the second line must be "
                                 f"'{HEADER.splitlines()[1]}')")
            try:
                with warnings.catch_warnings():       # "no data": reported below
                    warnings.simplefilter("ignore", UserWarning)
                    rows = np.loadtxt(f, delimiter=",", comments="#", dtype=np.float64, ndmin=2)
            except ValueError as e:
                raise InputError(f"{where} not a trace v1 row: {e}") from None
    except OSError as e:
        raise InputError(f"{where} cannot read: {e.strerror}") from None
    if rows.shape[0] == 0:
        raise InputError(f"{where} the trace has no rows")
    if rows.shape[1] != 3 or not np.isfinite(rows).all():
        raise InputError(f"{where} a trace row is t,pin,value (3 numbers)")
    t_us = np.rint(rows[:, 0] * 1e6).astype(np.int64)
    pin, value = rows[:, 1].astype(np.int64), rows[:, 2].astype(np.int64)
    if np.any(np.diff(t_us) < 0):
        bad = int(np.flatnonzero(np.diff(t_us) < 0)[0]) + 1
        raise InputError(f"{where} time goes backwards at t = {rows[bad, 0]:.6f}")
    return t_us, pin, value


def _last_per_time(t_us: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows with equal t take effect together: keep the last of each time."""
    last = np.r_[t_us[1:] != t_us[:-1], True] if len(t_us) else np.zeros(0, dtype=bool)
    return t_us[last], v[last]


def _at(times: np.ndarray, t: np.ndarray, v: np.ndarray, before) -> np.ndarray:
    """v as it stands at each of `times` (the last change at or before), `before` earlier."""
    i = np.searchsorted(t, times, side="right") - 1
    return np.where(i >= 0, v[np.maximum(i, 0)] if len(v) else before, before)


def _motor(path, t_us, pin, value, pins, table, name) -> tuple[np.ndarray, np.ndarray]:
    """Times at which one motor's coil pattern changed, and its sequence steps (+ forward)
    counted from its first energised pattern."""
    sel = np.isin(pin, pins)
    t, p, v = t_us[sel], pin[sel], value[sel]
    if np.any((v != 0) & (v != 1)):
        raise InputError(f"{path}: error: coil pin {int(p[(v != 0) & (v != 1)][0])} of the "
                         f"{name} motor has a value other than 0/1")
    bit = np.argmax(p[:, None] == pins[None, :], axis=1)
    rows = np.arange(len(t))
    word = np.zeros(len(t), dtype=np.int64)
    for b in range(len(pins)):           # the level of each pin after every row (forward fill)
        last = np.maximum.accumulate(np.where(bit == b, rows, -1))
        word |= np.where(last >= 0, v[np.maximum(last, 0)], 0) << b
    t, word = _last_per_time(t, word)
    n = len(table)
    phase_of = np.full(16, -1, dtype=np.int64)
    phase_of[table] = np.arange(n)
    phase_of[0] = -2                     # released
    phase = phase_of[word]
    if np.any(phase == -1):
        i = int(np.flatnonzero(phase == -1)[0])
        raise InputError(f"{path}: error: the {name} motor's coils show a pattern that is not "
                         f"in the {n}-step table at t = {t[i] / 1e6:.6f} (wrong drive or pins?)")
    on = phase >= 0
    t, phase = t[on], phase[on]
    d = np.diff(phase) % n
    d = np.where(d == n - 1, -1, d)
    if np.any(np.abs(d) > 1):
        i = int(np.flatnonzero(np.abs(d) > 1)[0]) + 1
        raise InputError(f"{path}: error: the {name} motor's coils jump by more than one step "
                         f"at t = {t[i] / 1e6:.6f} (wrong drive or pins?)")
    return t, np.concatenate(([0], np.cumsum(d)))[:len(t)].astype(np.int64)
