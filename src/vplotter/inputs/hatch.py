"""Hatching: parallel lines clipped to a region, joined into back-and-forth strokes.

Two front ends share one joiner:

- `hatch_polygons(rings, spacing_mm, angle_deg, rule)`: a region bounded by polygons (holes
  are rings inside rings; "evenodd" or "nonzero" like SVG's fill-rule). For SVG fills, DXF
  hatches.
- `hatch_mask(mask, width_mm, height_mm, spacing_mm, angle_deg)`: a region given as pixels
  (a picture's tone band), lines sampled at the pixel pitch and cut into runs.

Lines run at `angle_deg` (counter-clockwise from +x) on a grid fixed to the origin: line k
is at distance (k + 1/2) x spacing from the origin along the normal, so two regions hatched at
the same angle and spacing share their lines (hatch bands meet seamlessly). In the frame of
the lines (u along, v across) the segments of line k are joined to those of line k + 1 into
one stroke, boustrophedon: when a segment overlaps exactly one segment of the next line and
that one overlaps only it back (the cells of a trapezoidal decomposition), and the short
connecting move at their common end stays inside the region (polygons: it crosses no edge and
its midpoint is inside; masks: every pixel under it is in the mask). Everything is numpy over
all segments at once; no Python loop runs per line, pixel or segment.
"""

from __future__ import annotations

import math

import numpy as np


def _frame(angle_deg: float):
    a = math.radians(angle_deg)
    d = np.array([math.cos(a), math.sin(a)])
    n = np.array([-math.sin(a), math.cos(a)])
    return d, n


def runs(flags: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Start and end (exclusive) indices of the runs of True in each row of a 2-D bool array:
    (rows, starts, ends) flattened."""
    f = np.zeros((flags.shape[0], flags.shape[1] + 2), dtype=np.int8)
    f[:, 1:-1] = flags
    d = np.diff(f, axis=1)
    r0, s = np.nonzero(d == 1)
    r1, e = np.nonzero(d == -1)
    return r0, s, e           # np.nonzero is row-major: starts and ends pair up in order


def _join(k, u0, u1, spacing, inside, max_link_mm=None, offset=0.0):
    """Segments (line k, from u0 to u1) -> strokes in (u, v), joined back and forth where
    `inside(ua, va, ub, vb, side)` (arrays; side +1: the moves join the segments' right
    ends, -1: their left ends) allows the connecting move."""
    if len(k) == 0:
        return []
    o = np.lexsort((u0, k))
    k, u0, u1 = k[o], u0[o], u1[o]
    n = len(k)
    kk = k - k.min()
    lo_u = min(u0.min(), u1.min())
    big = float(max(u0.max(), u1.max()) - lo_u) + 1.0
    key0 = kk * big + (u0 - lo_u)
    key1 = kk * big + (u1 - lo_u)
    # overlaps with the next line (up) and the previous one (down)
    up_lo = np.searchsorted(key1, (kk + 1) * big + (u0 - lo_u), side="right")
    up_hi = np.searchsorted(key0, (kk + 1) * big + (u1 - lo_u), side="left")
    dn_lo = np.searchsorted(key1, (kk - 1) * big + (u0 - lo_u), side="right")
    dn_hi = np.searchsorted(key0, (kk - 1) * big + (u1 - lo_u), side="left")
    up_n, dn_n = up_hi - up_lo, dn_hi - dn_lo
    j = np.minimum(up_lo, n - 1)
    link = (up_n == 1) & (dn_n[j] == 1)
    pred = np.arange(n)
    pred[j[link]] = np.nonzero(link)[0]
    head = _heads(pred)
    forward = (k - k[head]) % 2 == 0
    # the connecting move at the common end (right end after a forward segment)
    src = np.nonzero(link)[0]
    dst = j[src]
    ua = np.where(forward[src], u1[src], u0[src])
    ub = np.where(forward[src], u1[dst], u0[dst])
    va = (k[src] + 0.5) * spacing + offset
    vb = (k[dst] + 0.5) * spacing + offset
    side = np.where(forward[src], 1.0, -1.0)
    ok = inside(ua, va, ub, vb, side) if len(src) else np.zeros(0, bool)
    if max_link_mm is not None:
        ok &= np.hypot(ub - ua, vb - va) <= max_link_mm
    pred = np.arange(n)
    pred[dst[ok]] = src[ok]
    head = _heads(pred)
    o = np.lexsort((k, head))
    k, u0, u1, forward, head = k[o], u0[o], u1[o], forward[o], head[o]
    us = np.where(forward, u0, u1)
    ue = np.where(forward, u1, u0)
    v = (k + 0.5) * spacing + offset
    pts = np.empty((2 * n, 2))
    pts[0::2, 0], pts[1::2, 0] = us, ue
    pts[0::2, 1] = pts[1::2, 1] = v
    cuts = 2 * (np.nonzero(np.diff(head))[0] + 1)
    return np.split(pts, cuts)


def _heads(pred: np.ndarray) -> np.ndarray:
    """The first segment of each one's chain (pointer jumping: log of the chain length)."""
    head = pred.copy()
    while True:
        nxt = head[head]
        if np.array_equal(nxt, head):
            return head
        head = nxt


def _to_xy(strokes, d, n):
    return [np.outer(s[:, 0], d) + np.outer(s[:, 1], n) for s in strokes]


# ---- polygons -------------------------------------------------------------------------------

def _edges(rings, d, n):
    """All edges (ua, va, ub, vb) of the rings, closed, in the frame of the lines."""
    parts = []
    for r in rings:
        p = np.asarray(r, dtype=float).reshape(-1, 2)
        if len(p) < 2:
            continue
        q = np.roll(p, -1, axis=0)
        parts.append(np.column_stack([p @ d, p @ n, q @ d, q @ n]))
    if not parts:
        return np.zeros((0, 4))
    e = np.concatenate(parts)
    return e[(e[:, 0] != e[:, 2]) | (e[:, 1] != e[:, 3])]


def _crossings(e, spacing):
    """Where the lines v = (k + 1/2) spacing cross the edges: (k, u, winding direction),
    half-open in v so that a vertex on a line counts once."""
    ua, va, ub, vb = e.T
    e = e[va != vb]
    ua, va, ub, vb = e.T
    vmin, vmax = np.minimum(va, vb), np.maximum(va, vb)
    k0 = np.ceil(vmin / spacing - 0.5).astype(np.int64)
    k1 = np.ceil(vmax / spacing - 0.5).astype(np.int64)          # exclusive
    cnt = np.maximum(k1 - k0, 0)
    idx = np.repeat(np.arange(len(e)), cnt)
    k = np.repeat(k0, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    v = (k + 0.5) * spacing
    t = (v - va[idx]) / (vb[idx] - va[idx])
    u = ua[idx] + t * (ub[idx] - ua[idx])
    w = np.where(vb[idx] > va[idx], 1, -1)
    return k, u, w


def _inside_flags(k, w, rule):
    """Per crossing (sorted by line, u): is the interval after it inside?"""
    o_line = np.r_[True, k[1:] != k[:-1]]
    if rule == "nonzero":
        c = np.cumsum(w)
    else:
        c = np.cumsum(np.ones_like(w))
    start = np.maximum.accumulate(np.where(o_line, np.arange(len(k)), 0))
    base = np.where(start > 0, c[start - 1], 0)
    acc = c - base
    inside = acc != 0 if rule == "nonzero" else acc % 2 == 1
    same = np.r_[k[1:] == k[:-1], False]
    return inside & same


def hatch_polygons(rings, spacing_mm: float, angle_deg: float, rule: str = "evenodd",
                   max_link_mm: float | None = None) -> list[np.ndarray]:
    """Hatch lines `spacing_mm` apart at `angle_deg` clipped to the region the rings bound
    (`rule` "evenodd" or "nonzero"), joined into back-and-forth strokes: a list of (K, 2)
    arrays in the rings' coordinates."""
    if rule not in ("evenodd", "nonzero"):
        raise ValueError(f"rule must be 'evenodd' or 'nonzero', not {rule!r}")
    if not spacing_mm > 0:
        raise ValueError("spacing_mm must be > 0")
    d, n = _frame(angle_deg)
    e = _edges(rings, d, n)
    if len(e) == 0:
        return []
    k, u, w = _crossings(e, spacing_mm)
    if len(k) == 0:
        return []
    o = np.lexsort((u, k))
    k, u, w = k[o], u[o], w[o]
    f = _inside_flags(k, w, rule)
    prev = np.r_[False, f[:-1]]
    nxt = np.r_[f[1:], False]
    s = np.nonzero(f & ~prev)[0]
    t = np.nonzero(f & ~nxt)[0] + 1
    sk, su0, su1 = k[s], u[s], u[t]
    keep = su1 - su0 > 1e-9
    sk, su0, su1 = sk[keep], su0[keep], su1[keep]

    def inside(ua, va, ub, vb, side):
        return _links_inside(e, spacing_mm, rule, ua, va, ub, vb)

    return _to_xy(_join(sk, su0, su1, spacing_mm, inside, max_link_mm), d, n)


def _links_inside(e, spacing, rule, ua, va, ub, vb):
    """Connecting moves between lines b and b + 1 that cross no edge and whose midpoint is
    inside: edges and moves paired by the band between two lines."""
    m = len(ua)
    band = np.round(np.minimum(va, vb) / spacing - 0.5).astype(np.int64)
    eua, eva, eub, evb = e.T
    b0 = np.floor(np.minimum(eva, evb) / spacing - 0.5).astype(np.int64)
    b1 = np.floor(np.maximum(eva, evb) / spacing - 0.5).astype(np.int64)
    cnt = b1 - b0 + 1
    eidx = np.repeat(np.arange(len(e)), cnt)
    eband = np.repeat(b0, cnt) + (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    o = np.argsort(eband, kind="stable")
    eidx, eband = eidx[o], eband[o]
    lo = np.searchsorted(eband, band, side="left")
    hi = np.searchsorted(eband, band, side="right")
    c = hi - lo
    ci = np.repeat(np.arange(m), c)
    ei = eidx[np.repeat(lo, c) + (np.arange(c.sum()) - np.repeat(np.cumsum(c) - c, c))]
    # proper crossings (touching at an end, as the moves' ends do, does not count)
    ax, ay, bx, by = ua[ci], va[ci], ub[ci], vb[ci]
    px, py, qx, qy = eua[ei], eva[ei], eub[ei], evb[ei]
    scale = spacing * spacing * 1e-9

    def cross(ox, oy, x1, y1, x2, y2):
        return (x1 - ox) * (y2 - oy) - (y1 - oy) * (x2 - ox)

    o1 = cross(ax, ay, bx, by, px, py)
    o2 = cross(ax, ay, bx, by, qx, qy)
    o3 = cross(px, py, qx, qy, ax, ay)
    o4 = cross(px, py, qx, qy, bx, by)
    hit = (o1 * o2 < -scale * scale) & (o3 * o4 < -scale * scale)
    crossed = np.bincount(ci[hit], minlength=m) > 0
    # the midpoint, by a ray towards +u
    mu, mv = (ua + ub) / 2, (va + vb) / 2
    mvi = mv[ci]
    on = (np.minimum(py, qy) <= mvi) & (mvi < np.maximum(py, qy))
    with np.errstate(divide="ignore", invalid="ignore"):
        xu = px + (mvi - py) / (qy - py) * (qx - px)
    # a midpoint on the boundary (a move along an edge) is inside
    ex, ey = qx - px, qy - py
    ll = ex * ex + ey * ey
    tt = np.clip(((mu[ci] - px) * ex + (mvi - py) * ey) / np.where(ll > 0, ll, 1), 0, 1)
    near = np.hypot(px + tt * ex - mu[ci], py + tt * ey - mvi) <= spacing * 1e-7
    on_edge = np.bincount(ci[near], minlength=m) > 0
    right = on & (xu > mu[ci])
    wdir = np.where(qy > py, 1.0, -1.0)
    if rule == "nonzero":
        wind = np.bincount(ci[right], weights=wdir[right], minlength=m)
        inside = np.abs(wind) > 0.5
    else:
        inside = np.bincount(ci[right], minlength=m) % 2 == 1
    return (inside | on_edge) & ~crossed


# ---- pixel masks ----------------------------------------------------------------------------

def _rect_span(v, d, n, w, h):
    """For lines at v, the u interval inside the rectangle [0, w] x [0, h]."""
    lo = np.full(len(v), -np.inf)
    hi = np.full(len(v), np.inf)
    for axis, size in ((0, w), (1, h)):
        base = v * n[axis]                    # coordinate at u = 0
        if abs(d[axis]) < 1e-12:
            bad = (base < -1e-9) | (base > size + 1e-9)
            lo[bad], hi[bad] = np.inf, -np.inf
            continue
        a = (0 - base) / d[axis]
        b = (size - base) / d[axis]
        lo = np.maximum(lo, np.minimum(a, b))
        hi = np.minimum(hi, np.maximum(a, b))
    return lo, hi


def _sample(mask, x, y, width_mm, height_mm):
    hh, ww = mask.shape
    col = np.floor(x / width_mm * ww).astype(np.int64)
    row = np.floor((height_mm - y) / height_mm * hh).astype(np.int64)
    ok = (col >= 0) & (col < ww) & (row >= 0) & (row < hh)
    out = np.zeros(x.shape, dtype=bool)
    out[ok] = mask[row[ok], col[ok]]
    return out


def hatch_mask(mask, width_mm: float, height_mm: float, spacing_mm: float, angle_deg: float,
               min_run_mm: float = 0.0, max_link_mm: float | None = None,
               offset_mm: float = 0.0) -> list[np.ndarray]:
    """Hatch lines `spacing_mm` apart at `angle_deg` where `mask` (H, W) is True; the mask
    covers [0, width_mm] x [0, height_mm] in G-code mm (row 0 at the top, y = height_mm).
    `offset_mm` shifts the grid along the normal (line k at (k + 1/2) spacing + offset: a
    sparse subset of a finer grid).
    Each line is sampled at the pixel pitch and cut into runs; runs shorter than `min_run_mm`
    are dropped; runs are joined back and forth (`_join`). Strokes (K, 2) in G-code mm, inside
    the rectangle."""
    mask = np.asarray(mask, dtype=bool)
    if not spacing_mm > 0:
        raise ValueError("spacing_mm must be > 0")
    hh, ww = mask.shape
    if hh == 0 or ww == 0 or not mask.any():
        return []
    pitch = min(width_mm / ww, height_mm / hh)
    d, n = _frame(angle_deg)
    corners = np.array([[0, 0], [width_mm, 0], [0, height_mm], [width_mm, height_mm]], float)
    cu, cv = corners @ d, corners @ n
    ks = np.arange(math.ceil((cv.min() - offset_mm) / spacing_mm - 0.5),
                   math.floor((cv.max() - offset_mm) / spacing_mm - 0.5) + 1, dtype=np.int64)
    umin = cu.min()
    ns = max(1, math.ceil((cu.max() - umin) / pitch))
    us = umin + (np.arange(ns) + 0.5) * pitch
    seg_k, seg_u0, seg_u1 = [], [], []
    chunk = max(1, 2_000_000 // ns)
    for c0 in range(0, len(ks), chunk):               # a few chunks of lines, to bound memory
        kc = ks[c0:c0 + chunk]
        v = (kc + 0.5) * spacing_mm + offset_mm
        x = us[None, :] * d[0] + v[:, None] * n[0]
        y = us[None, :] * d[1] + v[:, None] * n[1]
        flags = _sample(mask, x, y, width_mm, height_mm)
        r, s, e = runs(flags)
        lo, hi = _rect_span(v, d, n, width_mm, height_mm)
        u0 = np.maximum(umin + s * pitch, lo[r])
        u1 = np.minimum(umin + e * pitch, hi[r])
        keep = u1 - u0 >= max(min_run_mm, 1e-6)
        seg_k.append(kc[r][keep]); seg_u0.append(u0[keep]); seg_u1.append(u1[keep])
    if not seg_k or not sum(len(a) for a in seg_k):
        return []
    k = np.concatenate(seg_k)
    u0, u1 = np.concatenate(seg_u0), np.concatenate(seg_u1)

    grown = mask.copy()                               # a move may pass one pixel outside
    grown[1:] |= mask[:-1]; grown[:-1] |= mask[1:]
    g2 = grown.copy()
    g2[:, 1:] |= grown[:, :-1]; g2[:, :-1] |= grown[:, 1:]

    def inside(ua, va, ub, vb, side):
        # the move's ends are on the runs' edges: test from the last sample centres
        ua = ua - side * 0.5 * pitch
        ub = ub - side * 0.5 * pitch
        cnt = np.maximum(2, np.ceil(np.hypot(ub - ua, vb - va) / pitch).astype(np.int64) + 1)
        ci = np.repeat(np.arange(len(ua)), cnt)
        t = (np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)) / (cnt[ci] - 1)
        pu = ua[ci] + t * (ub[ci] - ua[ci])
        pv = va[ci] + t * (vb[ci] - va[ci])
        good = _sample(g2, pu * d[0] + pv * n[0], pu * d[1] + pv * n[1], width_mm, height_mm)
        return np.bincount(ci[~good], minlength=len(ua)) == 0

    strokes = _join(k, u0, u1, spacing_mm, inside, max_link_mm, offset_mm)
    out = []
    for s in _to_xy(strokes, d, n):
        s[:, 0] = np.clip(s[:, 0], 0.0, width_mm)
        s[:, 1] = np.clip(s[:, 1], 0.0, height_mm)
        out.append(s)
    return out
