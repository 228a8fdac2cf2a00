"""V-plotter kinematics: cord lengths paid out <-> pen position (G-code mm), with the
``[gondola]`` cord spacing and pen offset, the ``[cords]`` stretch models, and the gondola
that tilts (``[gondola] mass_below_pen_mm``: its centre of mass that far below the pen).

The tilting gondola, written from the physics (not from vplotter's method): a rigid body
held by the two cords at its two points, its weight through its centre of mass. For a turn
``phi`` the cord forces come from the force balance (Cramer's rule on the cords' angles) and
their torque about the centre of mass is summed; ``phi`` is where that torque vanishes, found
by bisection (the stable balance: the torque changes sign there).  Forward: for each trial
``phi`` the pen is where the two circles about the turned gondola's anchors meet, and the
bisection runs on the torque there; with stretch, the tensions are iterated outside.
Cords that sag (``[cords] mass_g_per_m``): :mod:`.sag`, started from the straight cords.
"""

from __future__ import annotations

import numpy as np

from . import sag
from .config import merge_config


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


TILT_LIMIT = 1.0        # rad: the bisection's bracket
TILT_FALSI = 3           # regula falsi steps after the halvings: phi within 1e-12 rad


def _mass(c: dict):
    m = c.get("gondola", {}).get("mass_below_pen_mm")
    return None if m is None else float(m)


def _turned(u, v, cos, sin):
    return u * cos - v * sin, u * sin + v * cos


def _forces(c: dict, x, y, phi):
    """(torque about the centre of mass, left tension, right tension, left cord, right cord)
    for a pen at machine (x, y) and the gondola turned by phi; weight 1, +y down."""
    D, s, h, _ = _models(c)
    cos, sin = np.cos(phi), np.sin(phi)
    lx, ly = _turned(-s / 2.0, -h, cos, sin)
    rx, ry = _turned(s / 2.0, -h, cos, sin)
    gx, gy = _turned(0.0, _mass(c) or 0.0, cos, sin)
    # the cords' points on the wall, the cords' angles towards their anchors
    Lx, Ly, Rx, Ry = x + lx, y + ly, x + rx, y + ry
    aL = np.arctan2(-Ly, -Lx)
    aR = np.arctan2(-Ry, D - Rx)
    # TL (cos aL, sin aL) + TR (cos aR, sin aR) = (0, -1): the cords carry the weight
    det = np.sin(aR - aL)
    TL = np.cos(aR) / det
    TR = -np.cos(aL) / det
    torque = ((lx - gx) * TL * np.sin(aL) - (ly - gy) * TL * np.cos(aL)
              + (rx - gx) * TR * np.sin(aR) - (ry - gy) * TR * np.cos(aR))
    return torque, TL, TR, np.hypot(Lx, Ly), np.hypot(D - Rx, Ry)


def _bisect(fn, shape, around=None, width=0.05):
    """The phi in [-TILT_LIMIT, TILT_LIMIT] (or within `width` of `around`) where fn(phi)
    changes sign: halvings down to 1e-4 rad, then regula falsi inside the bracket (each step
    gains some four digits there). A bracket about `around` that misses the change of sign
    anywhere is widened to 0.05."""
    lo = np.full(shape, -TILT_LIMIT) if around is None else around - width
    hi = np.full(shape, TILT_LIMIT) if around is None else around + width
    f_lo = fn(lo)
    if around is not None and width < 0.05:
        if (np.sign(fn(hi)) == np.sign(f_lo)).any():
            return _bisect(fn, shape, around)
    while (hi - lo).max(initial=0.0) > 1e-4:
        mid = 0.5 * (lo + hi)
        f_mid = fn(mid)
        same = np.sign(f_mid) == np.sign(f_lo)
        lo, f_lo = np.where(same, mid, lo), np.where(same, f_mid, f_lo)
        hi = np.where(same, hi, mid)
    f_hi = fn(hi)
    x = 0.5 * (lo + hi)
    for _ in range(TILT_FALSI):
        with np.errstate(divide="ignore", invalid="ignore"):
            x = lo - f_lo * (hi - lo) / (f_hi - f_lo)
        x = np.where((x >= lo) & (x <= hi), x, 0.5 * (lo + hi))
        f_x = fn(x)
        same = np.sign(f_x) == np.sign(f_lo)
        lo, f_lo = np.where(same, x, lo), np.where(same, f_x, f_lo)
        hi, f_hi = np.where(same, hi, x), np.where(same, f_hi, f_x)
    return x


def _tilted_cords(c: dict, x, y):
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    phi = _bisect(lambda p: _forces(c, x, y, p)[0], x.shape)
    _, TL, TR, gl, gr = _forces(c, x, y, phi)
    k = _models(c)[3]
    return gl / (1.0 + k * TL), gr / (1.0 + k * TR)


def _tilted_forward(c: dict, a, b):
    """Machine (x, y) of the tilted gondola from the cords paid out (NaN: no triangle)."""
    D, s, h, k = _models(c)
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    gl, gr = a.copy(), b.copy()

    def pen(phi):
        cos, sin = np.cos(phi), np.sin(phi)
        lx, ly = _turned(-s / 2.0, -h, cos, sin)
        rx, ry = _turned(s / 2.0, -h, cos, sin)
        # the circles about the anchors moved back by the turned gondola's points
        ex, ey, fx, fy = -lx, -ly, D - rx, -ry
        dx, dy = fx - ex, fy - ey
        d = np.hypot(dx, dy)
        along = (gl * gl - gr * gr + d * d) / (2.0 * d)
        with np.errstate(invalid="ignore"):
            up = np.sqrt(gl * gl - along * along)
        # the lower of the two points (+y down): the pen hangs below the anchors
        return ex + along * dx / d - up * dy / d, ey + along * dy / d + up * dx / d

    phi, width = None, 0.05
    for _ in range(6 if k else 1):
        # the tensions change the cords by k T (a few mm at most): phi moves far less than
        # 0.05 rad after the first round, and some 40 times less each round after
        last = phi
        phi = _bisect(lambda p: _forces(c, *pen(p), p)[0], a.shape, phi, width)
        if last is not None:
            width = float(np.clip(8.0 * np.nanmax(np.abs(phi - last), initial=0.0), 1e-9, 0.05))
        x, y = pen(phi)
        if k:
            _, TL, TR, _, _ = _forces(c, x, y, phi)
            gl, gr = a * (1.0 + k * TL), b * (1.0 + k * TR)
    return x, y


def _straight(c: dict, x, y):
    """(H, V_L, phi) of straight cords holding the gondola with its pen at machine (x, y):
    the first guess of the sagging cords' balance (tracecheck/sag.py)."""
    D, s, h, _ = _models(c)
    x = np.clip(np.ravel(np.asarray(x, dtype=float)), s / 2.0 + 1.0, D - s / 2.0 - 1.0)
    y = np.maximum(np.ravel(np.asarray(y, dtype=float)), h + 1.0)
    phi = np.zeros(x.shape)                     # a tilting gondola: Newton turns it
    _, TL, _, _, _ = _forces(c, x, y, phi)
    angle = np.arctan2(y - h, x - s / 2.0)      # the left cord below the horizontal
    return TL * np.cos(angle), TL * np.sin(angle), phi


def _sagging(c: dict, x, y, inverse: bool, a=None, b=None):
    shape = np.shape(x)
    first = _straight(c, x, y)
    if inverse:
        out = sag.inverse(c, np.ravel(x), np.ravel(y), first)
    else:
        out = sag.forward(c, np.ravel(a), np.ravel(b), first)
    return tuple(np.reshape(v, shape) for v in out)


def inverse_kinematics(cfg: dict, X, Y):
    """Cord lengths paid out (left, right) in mm for G-code point(s) ``(X, Y)``."""
    c = merge_config(cfg)
    x = c["origin"]["x_mm"] + np.asarray(X, dtype=float)
    y = c["origin"]["y_mm"] - np.asarray(Y, dtype=float)
    if sag.ratio(c):
        x, y = np.broadcast_arrays(x, y)
        return _sagging(c, x, y, True)
    if _mass(c) is not None:
        return _tilted_cords(c, x, y)
    return _machine_cords(c, x, y)


def forward_kinematics(cfg: dict, left, right):
    """G-code point(s) ``(X, Y)`` from the cord lengths paid out.

    Triangulation ``x = (a^2 - b^2 + D^2) / 2D``, ``y = sqrt(a^2 - x^2)`` (the pen hangs
    below the anchors, y >= 0 in the machine frame) between the anchors moved in by the
    gondola; with stretch, Newton steps on the inverse (finite-difference Jacobian) from
    there.  Cord pairs that do not form a triangle with the anchor line give NaN.
    """
    c = merge_config(cfg)
    if sag.ratio(c):
        # first the pen on straight cords of these lengths, then the cords sag
        left, right = np.broadcast_arrays(np.asarray(left, dtype=float),
                                          np.asarray(right, dtype=float))
        straight = {**c, "cords": {"stretch": 0.0},
                    "gondola": {k: v for k, v in c["gondola"].items() if k != "mass_below_pen_mm"}}
        X, Y = forward_kinematics(straight, left, right)
        x, y = _sagging(c, c["origin"]["x_mm"] + X, c["origin"]["y_mm"] - Y, False,
                        left, right)
        return x - c["origin"]["x_mm"], c["origin"]["y_mm"] - y
    if _mass(c) is not None:
        x, y = _tilted_forward(c, left, right)
        return x - c["origin"]["x_mm"], c["origin"]["y_mm"] - y
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
