"""Distances between the decoded drawing and the reference path: drawn polylines, point to
polyline distances (k-d tree), accuracy both ways and the page (or the polar table's reach)."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.spatial import cKDTree

from . import polar as tp
from .config import merge_config
from .decoder import Decoded


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


_last: list = []     # [(decoded, polylines, spacing), (d1, d2)]: accuracy and verify ask twice


def _accuracy_arrays(decoded, polylines, spacing):
    """Both directions' distances; the last answer is kept (with its inputs, so that their ids
    cannot be reused) because a test usually asks accuracy() and then verify() of one trace."""
    polylines = list(polylines)
    if _last and _last[0][0] is decoded and _last[0][2] == spacing \
            and len(_last[0][1]) == len(polylines) \
            and all(a is b for a, b in zip(_last[0][1], polylines)):
        return _last[1]
    d1, d2 = _distances(decoded, polylines, spacing)
    _last[:] = [(decoded, polylines, spacing), (d1, d2)]
    return d1, d2


def _distances(decoded, polylines, spacing):
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
