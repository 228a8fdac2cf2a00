"""Reading the trace CSV (``# vplotter trace v1`` / ``t,pin,value``) and checking it against
the format contract (times, initial levels, pin values, pins of the configuration)."""

from __future__ import annotations

import io
import os
from dataclasses import dataclass

import numpy as np

from . import polar as tp
from .config import merge_config

HEADER = "# vplotter trace v1"
COLUMNS = "t,pin,value"

#: Slack (seconds) allowed for the 6-decimal rounding of trace times.
TIME_EPS = 1e-6


class TraceFormatError(ValueError):
    """The trace file violates the format contract (cannot be read)."""


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
        text = fh.read()
    arr = _read_fast(text)
    if arr is not None:
        return _trace(arr, path)
    lines = text.splitlines()
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
    return _trace(arr, path)


def _read_fast(text: str) -> np.ndarray | None:
    """The data rows of a well-formed trace written by vplotter (header, column line, rows
    and comment lines) in one loadtxt call, 10-20 % faster than line by line; None for
    anything else, which :func:`read_trace` then reads line by line (same arrays, or the same
    error)."""
    head = HEADER + "\n" + COLUMNS + "\n"
    if not text.startswith(head):
        return None
    rest = text[len(head):]
    if not rest or "\r" in rest:
        return None
    try:    # comment lines and blank lines are skipped by loadtxt as by the loop below
        arr = np.loadtxt(io.StringIO(rest), delimiter=",", comments="#", dtype=np.float64,
                         ndmin=2)
    except ValueError:
        return None
    if arr.shape[1] != 3 or not np.all(np.isfinite(arr)):
        return None
    if np.any(arr[:, 1:] != np.round(arr[:, 1:])):
        return None
    return arr


def _trace(arr: np.ndarray, path) -> Trace:
    t = arr[:, 0]
    return Trace(t=t.copy(), t_us=np.rint(t * 1e6).astype(np.int64),
                 pin=arr[:, 1].astype(np.int64), value=arr[:, 2].astype(np.int64),
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
