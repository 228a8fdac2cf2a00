"""Segmenter: lines and arcs -> straight pieces within tolerance_mm of the true curve.

Pure numpy, G-code frame (+Y up, mm). A line stays one piece: the step schedule moves the pen
along the true straight line (each cord steps when the pen crosses its next step boundary),
so lines need no cutting for accuracy. Arcs become chords whose sagitta is at most the
tolerance; an arc whose end radius differs from its start radius becomes a spiral (radius
linear in the swept angle) that ends exactly at the programmed end point.
"""

from __future__ import annotations

import math
from itertools import chain
from operator import attrgetter

import numpy as np

from vplotter.inputs.gcode import Move
from vplotter.motion.planner import ACCEL_MARGIN, CORNER_SHARE, SHARP_SHARE, TAU_S

# Share of tolerance_mm given to the chords of arcs; the rest is left for the step quantisation
# (half a step of each cord moves the pen by up to ~0.008 mm on the seed machine's page).
CHORD_SHARE = 0.75

TWO_PI = 2.0 * math.pi
_EMPTY = np.empty((0, 2))
_ENDS = attrgetter("x0", "y0", "x1", "y1", "cx", "cy", "arc")


def arc_sweep(move: Move) -> float:
    """Signed swept angle in radians (+ counter-clockwise); a closed arc is a full turn."""
    a0 = math.atan2(move.y0 - move.cy, move.x0 - move.cx)
    a1 = math.atan2(move.y1 - move.cy, move.x1 - move.cx)
    # start == end, or a spiral ending at its start angle: a full turn
    sweep = (a1 - a0) % TWO_PI if move.arc > 0 else (a0 - a1) % TWO_PI
    if sweep == 0.0 or math.hypot(move.x1 - move.x0, move.y1 - move.y0) <= 1e-9:
        sweep = TWO_PI
    return move.arc * sweep


def chord_count(radius_mm: float, sweep: float, tol_mm: float) -> int:
    """Chords needed so that a chord's sagitta on a circle of `radius_mm` stays <= tol_mm."""
    if radius_mm <= tol_mm:
        step = math.pi / 2
    else:
        step = 2.0 * math.acos(1.0 - tol_mm / radius_mm)
        if step <= 0.0:         # 1 - tol/r rounds to 1 (a spiral of next to no sweep)
            step = 4.0 * math.asin(math.sqrt(tol_mm / (2.0 * radius_mm)))
    return max(1, math.ceil(abs(sweep) / step - 1e-9))


def chord_turn(cfg):
    """How far a chord of an arc may turn (radians) on a two-cord machine, by radius: the pen
    goes round an arc of radius r at up to v = min(draw speed, sqrt(CORNER_SHARE a r)) (a: the
    smallest cord acceleration; a cord's slope is at most 1). The planner counts the speed jump
    at a chord's corner against the 0.1 s acceleration window: it takes the corners of a curve
    as the centripetal v^2 / r when a chord is passed well within TAU_S (chord <= v TAU_S / 2),
    or the jump alone as SHARP_SHARE of the budget otherwise (turn <= SHARP_SHARE a TAU_S / v).
    Where the tolerance alone would cut coarser chords than either, the arc is cut finer, so
    that tiny arcs on a slow machine are not passed at a crawl. None for other machines."""
    if cfg.machine.kind != "vplotter":
        return None
    m = cfg.motors
    acc = float(np.min(m.max_accel * ACCEL_MARGIN / np.asarray(m.steps_per_unit, dtype=float)))
    cap = cfg.motion.draw_speed_mm_s

    def turn(r):
        r = np.maximum(r, 1e-9)
        v = np.minimum(cap, np.sqrt(CORNER_SHARE * acc * r))
        return np.maximum(0.5 * v * TAU_S / r, SHARP_SHARE * acc * TAU_S / v)

    return turn


def points(move: Move, tol_mm: float, max_angle=None) -> np.ndarray:
    """The piece end points of `move` as an (N, 2) array, without its start point.

    The last row is exactly (x1, y1). A zero-length line gives an empty array. max_angle:
    a function of the arc's radius (an array) giving the most a chord may turn (radians), or
    None (only the tolerance counts).
    """
    if move.arc == 0:
        if move.x1 == move.x0 and move.y1 == move.y0:
            return _EMPTY
        return np.array(((move.x1, move.y1),))
    sweep = arc_sweep(move)
    r0 = math.hypot(move.x0 - move.cx, move.y0 - move.cy)
    r1 = math.hypot(move.x1 - move.cx, move.y1 - move.cy)
    dr = (r1 - r0) / abs(sweep)
    # A spiral bends like a circle of radius sqrt(r^2 + 4 r'^2) (r' = dr/dangle).
    r_eff = math.sqrt(max(r0, r1) ** 2 + 4.0 * dr * dr)
    n = chord_count(r_eff, sweep, tol_mm)
    if max_angle is not None:
        n = max(n, math.ceil(abs(sweep) / float(max_angle(np.array([r_eff]))[0]) - 1e-9))
    f = np.arange(1, n + 1) / n
    a0 = math.atan2(move.y0 - move.cy, move.x0 - move.cx)
    ang = a0 + sweep * f
    rad = r0 + (r1 - r0) * f
    out = np.column_stack((move.cx + rad * np.cos(ang), move.cy + rad * np.sin(ang)))
    out[-1] = (move.x1, move.y1)
    return out


def points_many(moves: list[Move], tol_mm: float, max_angle=None) -> tuple[np.ndarray, np.ndarray]:
    """`points` of many moves at once (vectorised): all their piece end points (K, 2) and how
    many each move has (a zero-length line has none)."""
    n_moves = len(moves)
    if not n_moves:
        return _EMPTY, np.zeros(0, dtype=np.int64)
    m = np.fromiter(chain.from_iterable(map(_ENDS, moves)), float, 7 * n_moves).reshape(-1, 7)
    x0, y0, x1, y1, cx, cy, arc = m.T
    is_arc = arc != 0
    count = np.where((x1 != x0) | (y1 != y0), 1, 0)
    if not is_arc.any():
        keep = count > 0
        return m[keep][:, 2:4], count
    a = np.flatnonzero(is_arc)
    ax0, ay0, ax1, ay1, acx, acy, adir = (v[a] for v in (x0, y0, x1, y1, cx, cy, arc))
    a0 = np.arctan2(ay0 - acy, ax0 - acx)
    a1 = np.arctan2(ay1 - acy, ax1 - acx)
    sweep = np.where(adir > 0, (a1 - a0) % TWO_PI, (a0 - a1) % TWO_PI)
    closed = (sweep == 0.0) | (np.hypot(ax1 - ax0, ay1 - ay0) <= 1e-9)
    sweep = adir * np.where(closed, TWO_PI, sweep)
    r0 = np.hypot(ax0 - acx, ay0 - acy)
    r1 = np.hypot(ax1 - acx, ay1 - acy)
    dr = (r1 - r0) / np.abs(sweep)
    r_eff = np.sqrt(np.maximum(r0, r1) ** 2 + 4.0 * dr * dr)
    with np.errstate(invalid="ignore", divide="ignore"):
        step = np.where(r_eff <= tol_mm, math.pi / 2,
                        2.0 * np.arccos(1.0 - tol_mm / np.maximum(r_eff, tol_mm)))
        flat = step <= 0.0      # as chord_count: 1 - tol/r rounds to 1
        if flat.any():
            step[flat] = 4.0 * np.arcsin(np.sqrt(tol_mm / (2.0 * r_eff[flat])))
    if max_angle is not None:
        step = np.minimum(step, max_angle(r_eff))
    n = np.maximum(1, np.ceil(np.abs(sweep) / step - 1e-9)).astype(np.int64)
    count[a] = n
    total = int(count.sum())
    out = np.empty((total, 2))
    end = np.cumsum(count)
    # lines: one point each
    lines = np.flatnonzero(~is_arc & (count > 0))
    out[end[lines] - 1] = m[lines][:, 2:4]
    # arcs: n points each, the last exactly the end point
    which = np.repeat(np.arange(len(a)), n)
    k = np.arange(len(which)) - np.repeat(np.cumsum(n) - n, n) + 1
    f = k / n[which]
    ang = a0[which] + sweep[which] * f
    rad = r0[which] + (r1 - r0)[which] * f
    pos = np.repeat(end[a] - n, n) + k - 1
    out[pos, 0] = acx[which] + rad * np.cos(ang)
    out[pos, 1] = acy[which] + rad * np.sin(ang)
    out[end[a] - 1] = np.column_stack((ax1, ay1))
    return out, count


def first_outside(pts: np.ndarray, x_min: float, x_max: float, y_min: float, y_max: float) -> int:
    """Index of the first point outside the rectangle, or -1."""
    bad = (pts[:, 0] < x_min) | (pts[:, 0] > x_max) | (pts[:, 1] < y_min) | (pts[:, 1] > y_max)
    idx = np.flatnonzero(bad)
    return int(idx[0]) if idx.size else -1


def cut(poly: np.ndarray, xy) -> tuple[tuple[float, float], np.ndarray]:
    """Split a polyline at the point nearest to xy: (that point, the points after it)."""
    q = np.asarray(xy, dtype=float)
    a, b = poly[:-1], poly[1:]
    ab = b - a
    len2 = np.einsum("ij,ij->i", ab, ab)
    t = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.where(len2 > 0, len2, 1.0), 0.0, 1.0)
    near = a + ab * t[:, None]
    i = int(np.argmin(np.hypot(*(near - q).T)))
    return (float(near[i, 0]), float(near[i, 1])), poly[i + 1:]
