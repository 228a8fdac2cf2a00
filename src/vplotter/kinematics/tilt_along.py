"""The tilting gondola along a line (kinematics/tilt.py solves its balance at points).

Along a line p0 + s e, phi' and phi'' follow by implicit differentiation of the balance F = 0
(F_phi phi' = -F_s, F_phi phi'' = -(F_ss + 2 F_sphi phi' + F_phiphi phi'^2)), and every cord
with them by Taylor arithmetic: the planner's slopes and bends stay exact. At a window's
vertices the planner asks along two directions (the pieces before and after): `vertex_terms`
works out what they share once (phi's gradient and Hessian in x and y), and `along` gives
each direction's slopes and bends from it. The motor coordinates follow from the cords, with
cord stretch under the tilted gondola's tensions (`cord_jets`, `cords_value`, `tensions`).
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.kinematics import taylor as tl


class Along:
    """Gondola's methods along a line (it solves the balance: `solve`, `state_one`; its `v`,
    `a`, `d_mm`, `_k0` and `_arms` are the gondola's)."""

    def vertex_terms(self, x, y, state) -> tuple:
        """What the slopes and bends of the cords (no stretch) along any direction at pen
        points (x, y) share, the balance there `state`: phi's gradient and Hessian in x, y
        (implicit differentiation of F = 0 with F's second partials, F being quadratic in the
        pen point), and per cord its unit vector, 1 / |r|, the arm R v_m and the arm's parts
        along and across the cord. `along` turns them into slopes and bends: a vertex's two
        pieces share them."""
        _, c, s, df, fx, fy, (rlx, rly, rrx, rry) = state
        wrx, wy = self.d_mm - x, -y
        ulx, uly = -x - rlx, wy - rly                        # R v_m = A_m - p - r_m
        urx, ury = wrx - rrx, wy - rry
        glx, gly, grx, gry = self._arms(c, s)                # R a_m
        gwl = -(glx * x + gly * y)                           # R a_m . (A_m - p)
        gwr = grx * wrx - gry * y
        del wrx, wy
        kl = glx * rly - gly * rlx                           # R a_m x r_m
        kr = grx * rry - gry * rrx
        k0l, k0r = self._k0                                  # - a_m x v_m
        # F's second partials (F_yy = 0), p standing for phi
        fxp = glx * rrx + gly * ury + gwl - grx * rlx - gry * uly - gwr
        fyp = gly * rrx - glx * ury - gry * rlx + grx * uly
        fpp = ((k0l - kl) * rrx - 2.0 * gwl * ury + kl * urx
               - (k0r - kr) * rlx + 2.0 * gwr * uly - kr * ulx)
        # (the arrays let go as soon as they are used: with all of them held at once the heap
        # grows past what the C library keeps, and this took twice as long)
        del kl, kr, gwl, gwr
        inv = -1.0 / df
        px, py = fx * inv, fy * inv                          # phi_x, phi_y
        hxx = (2.0 * (gry - gly) + (2.0 * fxp + fpp * px) * px) * inv
        hxy = (glx - grx + fxp * py + fyp * px + fpp * px * py) * inv
        hyy = (2.0 * fyp + fpp * py) * py * inv
        del glx, gly, grx, gry, fxp, fyp, fpp, inv
        cords = []
        for rx, ry, ux, uy in ((rlx, rly, ulx, uly), (rrx, rry, urx, ury)):
            q, iq, hx, hy = _unit(rx, ry)
            cords.append((q, hx, hy, iq, ux, uy, hx * ux + hy * uy, hy * ux - hx * uy))
        return (px, py, hxx, hxy, hyy), tuple(cords)

    def slopes(self, xy, e, state=None) -> np.ndarray:
        """(N, 2) d|r_m|/ds along p(s) = xy + s e (the cords' slopes without stretch)."""
        x, y = xy[:, 0], xy[:, 1]
        st = self.solve(x, y) if state is None else state
        return slopes_along(self.slope_terms(x, y, st), slice(None), e)

    def slope_terms(self, x, y, state) -> tuple:
        """What the cords' slopes (no stretch) along any direction at pen points (x, y) share,
        the balance there `state`: phi's gradient, and per cord its unit vector and the arm R v_m
        across it (`slopes_along`: a vertex's two pieces share them)."""
        _, _, _, df, fx, fy, (rlx, rly, rrx, rry) = state
        inv = -1.0 / df
        cords = []
        for rx, ry, anchor in ((rlx, rly, 0.0), (rrx, rry, self.d_mm)):
            _, iq, hx, hy = _unit(rx, ry)
            ux, uy = anchor - x - rx, -y - ry                  # R v_m = A_m - p - r_m
            cords.append((hx, hy, hx * uy - hy * ux))
        return fx * inv, fy * inv, cords

    def jets(self, xy, e, state=None):
        """The cords r_m along p(s) = xy + s e at s = 0 as triples (value, d/ds, d2/ds2):
        ((rLx, rLy), (rRx, rRy)), with phi's own triple; `state`: solve(xy) when known."""
        x, y = xy[:, 0], xy[:, 1]
        return self.jets_at(x, y, e[:, 0], e[:, 1], self.solve(x, y) if state is None else state)

    def jets_at(self, x, y, ex, ey, state):
        """jets() at pen (x, y) along (ex, ey), the balance there `state`: arrays, or Python
        floats for one point (state_one)."""
        phi, c, s, df, fx, fy, r = state
        p1 = -(fx * ex + fy * ey) / df
        sq = p1 * p1
        # with phi'' = 0 first: a body vector turns as (R w)' = phi' J R w, (R w)'' = -phi'^2
        # R w (J (x, y) = (-y, x)), and r_m = A_m - p - R v_m; then F'' gives phi''
        cords, ks = [], []
        g = self._arms(c, s)                                     # R a_m
        for gx, gy, rx0, ry0, anchor in zip(g[::2], g[1::2], r[::2], r[1::2], (0.0, self.d_mm)):
            px, py = anchor - x - rx0, -y - ry0                  # R v_m
            rx = (rx0, p1 * py - ex, sq * px)
            ry = (ry0, -ey - p1 * px, sq * py)
            g1x, g1y = -p1 * gy, p1 * gx
            # k = gx ry - gy rx as a triple
            k0 = gx * ry0 - gy * rx0
            k1 = g1x * ry0 + gx * ry[1] - g1y * rx0 - gy * rx[1]
            k2 = 2.0 * (g1x * ry[1] - g1y * rx[1]) + gx * ry[2] - gy * rx[2] - sq * k0
            cords.append((px, py, rx, ry))
            ks.append((k0, k1, k2))
        (kl0, kl1, kl2), (kr0, kr1, kr2) = ks
        rxl, rxr = cords[0][2], cords[1][2]
        f2 = (kl2 * rxr[0] + 2.0 * kl1 * rxr[1] + kl0 * rxr[2]
              - kr2 * rxl[0] - 2.0 * kr1 * rxl[1] - kr0 * rxl[2])
        p2 = -f2 / df
        # phi'' enters the second derivatives of the cords linearly: d r_m / d phi = -J R v_m
        out = [((rx[0], rx[1], rx[2] + p2 * py), (ry[0], ry[1], ry[2] - p2 * px))
               for px, py, rx, ry in cords]
        return out, (phi, p1, p2)


def _unit(rx, ry) -> tuple:
    """A cord's length, its inverse and its unit vector (q, 1 / q, hx, hy)."""
    q = np.sqrt(rx * rx + ry * ry)
    iq = 1.0 / q
    return q, iq, rx * iq, ry * iq


def along(terms, rows, e) -> tuple:
    """(slopes, bends), each (2 motors, N), of the cords (no stretch) along the directions e
    (N, 2) at the points `rows` (a slice) of Gondola.vertex_terms: with phi' and phi'' from
    phi's gradient and Hessian, r' = -e - phi' J u and r'' = phi'^2 u - phi'' J u (u the arm
    R v_m, J the quarter turn), the slope r.r' / |r| and the bend (|r'|^2 - slope^2) / |r| +
    r.r'' / |r|."""
    (px, py, hxx, hxy, hyy), cords = terms
    ex, ey = e[:, 0], e[:, 1]
    # (in place where it can: fewer arrays made and let go, the same operations in the same
    # order as p1 = px ex + py ey, p2 = (hxx ex + 2 hxy ey) ex + hyy ey ey)
    p1 = px[rows] * ex
    t = py[rows] * ey
    p1 += t
    p2 = hxx[rows] * ex
    np.multiply(2.0, hxy[rows], out=t)
    t *= ey
    p2 += t
    p2 *= ex
    np.multiply(hyy[rows], ey, out=t)
    t *= ey
    p2 += t
    sq = p1 * p1
    ney = -ey
    k = np.empty((2, len(ex)))
    b = np.empty((2, len(ex)))
    for m, (_, hx, hy, iq, ux, uy, ru, rju) in enumerate(cords):
        dx = p1 * uy[rows]
        dx -= ex                                              # p1 uy - ex
        dy = p1 * ux[rows]
        np.subtract(ney, dy, out=dy)                          # -ey - p1 ux
        km = np.multiply(hx[rows], dx, out=k[m])
        np.multiply(hy[rows], dy, out=t)
        km += t
        dx *= dx                                              # (dx^2 + dy^2 - km^2) / |r|
        dy *= dy
        dx += dy
        np.multiply(km, km, out=t)
        dx -= t
        dx *= iq[rows]
        np.multiply(sq, ru[rows], out=t)
        dx += t                                               # + phi'^2 u.r/|r|
        np.multiply(p2, rju[rows], out=t)
        np.subtract(dx, t, out=b[m])                          # - phi'' Ju.r/|r|
    return k, b


def slopes_along(terms, rows, e) -> np.ndarray:
    """(N, 2) the cords' slopes (no stretch) along the directions e (N, 2) at the points `rows`
    (a slice or indices) of Gondola.slope_terms: r.r' / |r| with r' = -e - phi' J u (u the arm
    R v_m, J the quarter turn), phi' = grad phi . e."""
    px, py, cords = terms
    ex, ey = e[:, 0], e[:, 1]
    p1 = px[rows] * ex + py[rows] * ey
    out = np.empty((len(ex), 2))
    for m, (hx, hy, w) in enumerate(cords):
        out[:, m] = p1 * w[rows] - (hx[rows] * ex + hy[rows] * ey)
    return out


def cord_jets(r, stretch: float):
    """Motor coordinates (value, d/ds, d2/ds2) of the left and right cord from the cords'
    triples; with stretch, the tilted force balance gives the tensions."""
    (lx, ly), (rx, ry) = r
    gl, gr = _length(lx, ly), _length(rx, ry)
    if stretch == 0.0:
        return gl, gr
    cross = tl.sub(tl.mul(lx, ry), tl.mul(ly, rx))
    # q = g / (1 + k t) = g C / (C + k t C), t_L C = r_Rx g_L, t_R C = -r_Lx g_R
    ql = tl.div(tl.mul(gl, cross), tl.add(cross, tl.scale(tl.mul(rx, gl), stretch)))
    qr = tl.div(tl.mul(gr, cross), tl.sub(cross, tl.scale(tl.mul(lx, gr), stretch)))
    return ql, qr


def _length(x, y):
    """|(x, y)| as a triple from the triples x and y (arrays, or Python floats)."""
    g = x[0] * x[0] + y[0] * y[0]
    g = math.sqrt(g) if isinstance(g, float) else np.sqrt(g)
    g1 = (x[0] * x[1] + y[0] * y[1]) / g
    return g, g1, (x[1] * x[1] + y[1] * y[1] + x[0] * x[2] + y[0] * y[2] - g1 * g1) / g


def cords_value(r, stretch: float) -> np.ndarray:
    """(N, 2) motor coordinates from the cord vectors (r_Lx, r_Ly, r_Rx, r_Ry)."""
    lx, ly, rx, ry = r
    gl, gr = np.sqrt(lx * lx + ly * ly), np.sqrt(rx * rx + ry * ry)    # (np.hypot: 3x slower)
    if stretch != 0.0:
        cross = lx * ry - ly * rx
        gl, gr = gl * cross / (cross + stretch * rx * gl), gr * cross / (cross - stretch * lx * gr)
    return np.stack((gl, gr), axis=-1)


def tensions(r) -> np.ndarray:
    """(N, 2) tensions in units of the gondola's weight."""
    lx, ly, rx, ry = r
    cross = lx * ry - ly * rx
    return np.stack((rx * np.hypot(lx, ly), -lx * np.hypot(rx, ry)), axis=-1) / cross[:, None]
