"""Cords that sag (``[cords] mass_g_per_m`` with ``[gondola] mass_g``), written from the
physics and not from vplotter's method.

A cord is shot from the gondola towards its anchor: at the gondola it pulls with a horizontal
tension ``H`` and a vertical one ``V`` (upwards; weights in units of the gondola's weight,
``mu`` the cord's weight per mm).  Along its length ``s`` the vertical tension grows by
``mu s`` while ``H`` stays, so the cord reaches
``across = H/mu (asinh((V + mu s)/H) - asinh(V/H))`` and
``up = (hypot(H, V + mu s) - hypot(H, V)) / mu`` from the gondola's point.
The gondola is in balance when both cords pull with one ``H``, their ``V`` carry the weight
(``V_R = 1 - V_L``) and, when it tilts, the torque of both pulls about the centre of mass
vanishes.  Both directions are Newton's method on those conditions with a central-difference
Jacobian, vectorised over the points.  Stretch: the cord paid out is ``L / (1 + k T)`` with
``T = hypot(H, V)`` the tension at the gondola.
"""

from __future__ import annotations

import numpy as np

STEPS = 60
DIFF = 1e-7


def ratio(c: dict) -> float:
    """The cords' weight per mm over the gondola's (0: the cords do not sag)."""
    per_m = float(c.get("cords", {}).get("mass_g_per_m", 0.0) or 0.0)
    if not per_m:
        return 0.0
    return per_m / 1000.0 / float(c["gondola"]["mass_g"])


def _body(c: dict, phi):
    """From the pen to the cords' points and to the centre of mass, turned by phi."""
    g = c.get("gondola", {})
    s, h = float(g.get("cord_spacing_mm", 0.0)), float(g.get("pen_below_mm", 0.0))
    mass = float(g.get("mass_below_pen_mm", 0.0) or 0.0)
    cos, sin = np.cos(phi), np.sin(phi)

    def turn(u, v):
        return u * cos - v * sin, u * sin + v * cos

    return turn(-s / 2.0, -h), turn(s / 2.0, -h), turn(0.0, mass)


def _tilts(c: dict) -> bool:
    return c.get("gondola", {}).get("mass_below_pen_mm") is not None


def _newton(fun, u):
    """u (N, k) where fun(u, rows) (len(rows), k) vanishes, the rows of u being `rows` of the
    points: Newton steps (central-difference Jacobian) on the rows still moving, each step
    halved until the residual shrinks (a first guess far off: the sagged cords' pen is well
    above the straight cords')."""
    u = u.copy()
    k = u.shape[1]
    rows = np.arange(len(u))
    f = fun(u, rows)
    for _ in range(STEPS):
        v = u[rows]
        jac = np.empty(v.shape + (k,))
        for j in range(k):
            d = DIFF * np.maximum(np.abs(v[:, j]), 1e-3)
            up, dn = v.copy(), v.copy()
            up[:, j] += d
            dn[:, j] -= d
            jac[:, :, j] = (fun(up, rows) - fun(dn, rows)) / (2.0 * d)[:, None]
        with np.errstate(all="ignore"):
            det = np.linalg.det(np.nan_to_num(jac))
            bad = ~(np.abs(det) > 0) | ~np.isfinite(jac).all(axis=(1, 2))
            jac[bad] = np.eye(k)                     # a point without a balance: left NaN
            step = np.linalg.solve(jac, np.nan_to_num(f)[:, :, None])[:, :, 0]
            step[bad] = np.nan
            norm = np.abs(f).max(axis=1)
            t = np.ones(len(v))
            for _ in range(30):
                new = v - t[:, None] * step
                new[:, 0] = np.maximum(new[:, 0], 1e-9)          # H > 0
                fn = fun(new, rows)
                worse = ~(np.abs(fn).max(axis=1) < norm) & (norm > 1e-12) & ~bad
                if not worse.any():
                    break
                t = np.where(worse, t / 2.0, t)
        u[rows] = new
        moving = np.abs(new - v).max(axis=1) > 1e-13
        rows, f = rows[moving], fn[moving]
        if not len(rows):
            break
    return u


def _reach(mu, H, V, length):
    """(across, up) from the gondola's point to the far end of a cord of this length."""
    top = V + mu * length
    return (H / mu * (np.arcsinh(top / H) - np.arcsinh(V / H)),
            (np.hypot(H, top) - np.hypot(H, V)) / mu)


def _length(mu, H, V, across):
    """The length of cord from the gondola's point that spans `across`."""
    return (H * np.sinh(np.arcsinh(V / H) + mu * across / H) - V) / mu


def _torque(c, phi, H, vl, vr):
    """The pulls' torque about the centre of mass: (-H, -V_L) and (H, -V_R), +y down."""
    (lx, ly), (rx, ry), (gx, gy) = _body(c, phi)
    return ((lx - gx) * -vl - (ly - gy) * -H) + ((rx - gx) * -vr - (ry - gy) * H)


def inverse(c: dict, x, y, first):
    """Cords paid out (left, right) for pens at machine (x, y); `first`: (H, V_L, phi) of
    straight cords, the first guess."""
    mu, D = ratio(c), float(c["machine"]["anchor_distance_mm"])
    k = float(c.get("cords", {}).get("stretch", 0.0))
    tilt = _tilts(c)

    def cords(u, rows):
        H, vl = u[:, 0], u[:, 1]
        phi = u[:, 2] if tilt else 0.0
        (lx, ly), (rx, ry), _ = _body(c, phi)
        xr, yr = x[rows], y[rows]
        ll = _length(mu, H, vl, xr + lx)
        lr = _length(mu, H, 1.0 - vl, D - xr - rx)
        res = [_reach(mu, H, vl, ll)[1] - (yr + ly), _reach(mu, H, 1.0 - vl, lr)[1] - (yr + ry)]
        if tilt:
            res.append(_torque(c, phi, H, vl, 1.0 - vl) / 100.0)
        return np.column_stack(res), ll, lr, H, vl

    u = _newton(lambda u_, rows: cords(u_, rows)[0], np.column_stack(first[:2 + tilt]))
    _, ll, lr, H, vl = cords(u, np.arange(len(u)))
    return ll / (1.0 + k * np.hypot(H, vl)), lr / (1.0 + k * np.hypot(H, 1.0 - vl))


def forward(c: dict, a, b, first):
    """Machine (x, y) of the pen where the motors paid out cords a, b; `first`: (H, V_L,
    phi) of straight cords near by."""
    mu, D = ratio(c), float(c["machine"]["anchor_distance_mm"])
    k = float(c.get("cords", {}).get("stretch", 0.0))
    tilt = _tilts(c)

    def points(u, rows):
        H, vl = u[:, 0], u[:, 1]
        vr = 1.0 - vl
        phi = u[:, 2] if tilt else 0.0
        # the gondola's points below the anchors, where the cords end
        al, ul = _reach(mu, H, vl, a[rows] * (1.0 + k * np.hypot(H, vl)))
        ar, ur = _reach(mu, H, vr, b[rows] * (1.0 + k * np.hypot(H, vr)))
        (lx, ly), (rx, ry), _ = _body(c, phi)
        # the gondola holds them rx - lx across and ry - ly down from one another
        res = [(D - ar) - al - (rx - lx), ur - ul - (ry - ly)]
        if tilt:
            res.append(_torque(c, phi, H, vl, vr) / 100.0)
        return np.column_stack(res), al - lx, ul - ly

    u = _newton(lambda u_, rows: points(u_, rows)[0], np.column_stack(first[:2 + tilt]))
    _, x, y = points(u, np.arange(len(u)))
    return x, y
