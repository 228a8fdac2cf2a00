"""The reference G-code reader: an independent interpreter of G0-G3 (arcs and spirals by
I/J or R), units, absolute/relative and the pen (Z or M3/M5) into densely sampled pen-down
polylines or the whole tool path."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np


class GCodeError(ValueError):
    """The reference G-code interpreter met something it does not support."""


_WORD_RE = re.compile(r"([A-Z])\s*([+-]?(?:\d+(?:\.\d*)?|\.\d+))")
_COMMENT_RE = re.compile(r"\([^)]*\)")

#: G codes accepted and ignored (besides the ones interpreted).
IGNORED_G = {"17", "40", "49", "54", "61", "64", "80", "94", "91.1"}
#: M codes accepted and ignored (besides M2, M30, M3, M5).
IGNORED_M = {"0", "1", "7", "8", "9"}     # M0/M1 pause: they move nothing
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
    blocks = _blocks(_read_gcode_text(gcode))
    z_file = any("Z" in vals for _, _, _, vals in blocks)

    pos = np.array([float(start_xy[0]), float(start_xy[1])])
    scale, absolute = 1.0, True          # mm per program unit, G90
    motion: str | None = None
    z, pen = 0.0, False
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
        block_motion, scale, absolute = _g_codes(gs, lineno, scale, absolute)
        end_program, pen_cmd = _m_codes(ms, lineno)
        if block_motion is not None:
            motion = block_motion
        # pen change first
        if z_file:
            if "Z" in vals:
                z = vals["Z"] * scale if absolute else z + vals["Z"] * scale
                pen_set(z < 0)
        elif pen_cmd is not None:
            pen_set(pen_cmd)
        moved = _motion(pos, vals, motion if motion is not None else "0", scale, absolute,
                        spacing, lineno)
        if moved is not None:
            pos, pts = moved
            if len(pts):
                tool.append(pts)
                if pen:
                    current.append(pts)
        if end_program:
            break
    if travel:
        return [np.concatenate(tool)]
    if pen:
        polylines.append(np.concatenate(current))
    return polylines


def _blocks(text: str) -> list:
    """(line number, G codes, M codes, values) of every block that is not empty."""
    lines = [(i + 1, _clean_line(raw)) for i, raw in enumerate(text.splitlines())]
    blocks = []
    for lineno, s in lines:
        if s:
            blocks.append((lineno, *_parse_block(s, lineno)))
    return blocks


def _g_codes(gs, lineno: int, scale: float, absolute: bool):
    """The block's motion code (or None), and the units (mm per program unit) and distance
    mode after its G words."""
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
    return block_motion, scale, absolute


def _m_codes(ms, lineno: int):
    """(the program ends after this block, the pen command: True down, False up, None)."""
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
    return end_program, pen_cmd


def _motion(pos, vals: dict, mode: str, scale: float, absolute: bool, spacing: float,
            lineno: int):
    """(target, sampled points) of the block's motion in `mode`, or None if it does not move."""
    has_xy = "X" in vals or "Y" in vals
    has_arc = "I" in vals or "J" in vals or "R" in vals
    if mode in ("0", "1"):
        if has_arc:
            raise GCodeError(f"line {lineno}: I/J/R without G2/G3")
    if not (has_xy or (mode in ("2", "3") and has_arc)):
        return None
    target = pos.copy()
    for k, axis in ((0, "X"), (1, "Y")):
        if axis in vals:
            target[k] = vals[axis] * scale if absolute else pos[k] + vals[axis] * scale
    if mode in ("0", "1"):
        return target, _sample_line(pos, target, spacing)
    cw = mode == "2"
    if "R" in vals:
        if "I" in vals or "J" in vals:
            raise GCodeError(f"line {lineno}: both R and I/J")
        centre = _centre_from_r(pos, target, vals["R"] * scale, cw, lineno)
    else:
        if not ("I" in vals or "J" in vals):
            raise GCodeError(f"line {lineno}: arc without I/J/R")
        centre = pos + np.array([vals.get("I", 0.0), vals.get("J", 0.0)]) * scale
    return target, _sample_arc(pos, target, centre, cw, spacing)


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
