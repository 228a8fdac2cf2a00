"""V-plotter kinematics: cord lengths paid out <-> pen position (G-code mm), with the
``[gondola]`` cord spacing and pen offset and the ``[cords]`` stretch models."""

from __future__ import annotations

import numpy as np

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
