"""Cutting straight wall pieces for controllers that interpolate in motor space.

A grbl-style controller moves its axes along straight lines. Fed the V-plotter's cord lengths as
X and Y, it moves both cords linearly, and the pen then follows a curve, not the straight
piece. This module cuts each straight piece (machine frame, mm) so that the straight line in
motor space between consecutive cut points, mapped back to the wall, stays within a tolerance
of the true piece.

The bound, per piece p(s) = p0 + s e, 0 <= s <= d, for each motor m with anchor a_m:

- the cord c_m(s) = |p(s) - a_m| has c_m'' = h_m^2 / r_m^3, where h_m is the (constant)
  distance of the anchor from the piece's line and r_m = |p(s) - a_m|; so on the piece
  |c_m''| <= h_m^2 / r_min^3 with r_min the distance from the anchor to the piece;
- a sub-piece of length L has its chord in motor space within L^2 / 8 * max|c_m''| of the true
  cord curve, in each motor (the interpolation error of a straight line);
- a cord error dc moves the pen by at most |dc| / sigma, where sigma is the smallest singular
  value of the Jacobian d(cords)/d(pen) (rows: the unit vectors from the anchors to the pen),
  sigma = sqrt(1 - |cos gamma|), gamma the angle between the two cords.

So L <= sqrt(8 tol sigma / |c''|) keeps the pen within tol. sigma is taken as the least of
its values at the ends and the middle of the piece times SIGMA_MARGIN (it changes by a few
per cent over the length of a sub-piece). Pieces are cut evenly, so a piece of length d gets
ceil(d / L) sub-pieces.
"""

from __future__ import annotations

import numpy as np

SIGMA_MARGIN = 0.9


def _sigma(kin, xy: np.ndarray) -> np.ndarray:
    """Smallest singular value of d(cords)/d(pen) at the points (N, 2)."""
    rel = kin._rel(xy)                                   # (N, 2 motors, 2)
    u = rel / np.linalg.norm(rel, axis=2, keepdims=True)
    cos = np.abs(np.einsum("nk,nk->n", u[:, 0], u[:, 1]))
    return np.sqrt(np.maximum(1.0 - cos, 0.0))


def _bend_bound(kin, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """Bound of |d2 cord / ds2| on each piece, per motor: (N, 2)."""
    seg = p1 - p0
    d = np.linalg.norm(seg, axis=1)
    e = seg / np.where(d > 0, d, 1.0)[:, None]
    rel0 = kin._rel(p0)                                  # p0 - a, (N, M, 2)
    along = -np.einsum("nmk,nk->nm", rel0, e)            # where the foot of the perpendicular is
    t = np.clip(along, 0.0, d[:, None])
    nearest = rel0 + t[..., None] * e[:, None, :]
    r_min = np.linalg.norm(nearest, axis=2)
    h = np.abs(rel0[..., 0] * e[:, None, 1] - rel0[..., 1] * e[:, None, 0])
    return h * h / np.maximum(r_min, 1e-9) ** 3


def counts(kin, verts: np.ndarray, tol_mm: float) -> np.ndarray:
    """How many sub-pieces each piece of the polyline `verts` (N+1, 2) needs."""
    p0, p1 = verts[:-1], verts[1:]
    d = np.linalg.norm(p1 - p0, axis=1)
    sigma = np.minimum.reduce([_sigma(kin, p0), _sigma(kin, 0.5 * (p0 + p1)), _sigma(kin, p1)])
    bend = np.linalg.norm(_bend_bound(kin, p0, p1), axis=1)
    max_len = np.sqrt(8.0 * tol_mm * SIGMA_MARGIN * sigma / np.maximum(bend, 1e-300))
    return np.maximum(1, np.ceil(d / max_len - 1e-9)).astype(np.int64)


def cut(kin, verts: np.ndarray, tol_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Cut the pieces of the polyline `verts` (N+1, 2, machine mm).

    Returns (points (K, 2) on the true pieces, excluding verts[0]; piece (K,) index of the
    piece each point ends a sub-piece of). The last point of every piece is its end vertex.
    """
    n = counts(kin, verts, tol_mm)
    piece = np.repeat(np.arange(len(n)), n)
    k = np.arange(len(piece)) - np.repeat(np.cumsum(n) - n, n) + 1     # 1..n within a piece
    f = (k / n[piece])[:, None]
    pts = verts[piece] + f * (verts[piece + 1] - verts[piece])
    last = np.cumsum(n) - 1
    pts[last] = verts[1:]
    return pts, piece


def cord_speed_ratio(kin, xy0: np.ndarray, xy1: np.ndarray) -> np.ndarray:
    """Least |d cords / d path| over each short straight piece (sampled at its ends): the motor-
    space feed that keeps the pen at v is v times this (for pieces cut by `cut`)."""
    seg = xy1 - xy0
    d = np.linalg.norm(seg, axis=1)
    e = seg / np.where(d > 0, d, 1.0)[:, None]
    k0 = np.linalg.norm(kin.slope(xy0, e), axis=1)
    k1 = np.linalg.norm(kin.slope(xy1, e), axis=1)
    return np.minimum(k0, k1)
