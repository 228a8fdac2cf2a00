"""The tilting gondola of the V-plotter (`[gondola] mass_below_pen_mm`).

A rigid gondola: the cords hold it at two points `cord_spacing_mm` apart, the pen midway between
them and `pen_below_mm` below the line through them, its centre of mass G `mass_below_pen_mm`
below the pen on its symmetry line (all in the gondola's frame). Wherever the two cords pull
unevenly the gondola turns by an angle phi until it balances: the two cords and the weight
(straight down through G) meet in one point, i.e. the torques about G cancel.

Machine frame (origin at the left anchor, +y down), the anchors A_L = (0, 0), A_R = (D, 0).
For a pen at p and the gondola turned by phi (R the rotation by phi):
- the cords' points P_m = p + R v_m, v_L = (-spacing/2, -pen_below), v_R = (+spacing/2, ...);
- the cords r_m = A_m - P_m (from the gondola to the anchor), geometric lengths |r_m|;
- from G to the cords' points R a_m, a_m = v_m - (0, mass_below_pen);
- balance: the tensions T_L, T_R carry the weight, T_L r_L/|r_L| + T_R r_R/|r_R| = (0, -W),
  and the torque about G vanishes: sum (R a_m) x T_m r_m/|r_m| = 0. Eliminating the tensions
  (T_L ∝ r_Rx, T_R ∝ -r_Lx, times the same positive factor), the balance is the polynomial
  F(p, phi) = (R a_L x r_L) r_Rx - (R a_R x r_R) r_Lx = 0 (no square roots).
The tensions with the gondola tilted come from the same force balance, so cord stretch (when
set) uses them: t_L = r_Rx |r_L| / C, t_R = -r_Lx |r_R| / C, C = r_L x r_R (in units of the
gondola's weight), the motor paying out q = |r| / (1 + stretch t).

phi solves F = 0 for each point by Halley steps from a table of phi (one step for most points:
cos and sin of phi follow it by their series), falling back on Newton steps kept inside a
bracket (bisection where a step would leave it); a few points are solved in Python floats
(numpy's overhead on a few rows is more than the arithmetic). The cords along a line, their
slopes and bends, and the motor coordinates with stretch: kinematics/tilt_along.py.
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.kinematics.tilt_along import Along

PHI_LIMIT = 1.2           # rad: the bracket (no gondola that balances turns this far)
PHI_NEWTON = 1e-7         # rad: Newton stops after a step below this: phi within 1e-13
PHI_STEPS = 60
PHI_FAST = 6              # Halley steps before the bracketed ones
PHI_HALLEY = 1e-4         # rad: Halley stops after a step below this: phi within about 2e-13
ROTATE_MAX = 1e-3         # rad: cos and sin of phi follow a step up to this by their series
FEW = 16                  # points solved in Python floats (the array's overhead is most)
GUESS_CELLS = 64          # the first guess of phi: a table, this many cells across the anchors
_TABLES: dict = {}        # the tables made, by gondola (the planner's and the schedule's machine)
TABLES = 32               # kept at most (each 260 kB; `calibrate fit --fit-mass` makes about 15)


class Gondola(Along):
    """The balance of a tilting gondola between anchors 0 and `d_mm` apart."""

    def __init__(self, d_mm: float, spacing_mm: float, pen_below_mm: float,
                 mass_below_pen_mm: float):
        half = spacing_mm / 2.0
        h, c = pen_below_mm, mass_below_pen_mm
        self._half, self._h, self._ha = half, h, h + c           # (see _terms)
        self.d_mm = float(d_mm)
        self.v = ((-half, -h), (half, -h))                    # pen -> the cords' points
        self.a = ((-half, -h - c), (half, -h - c))            # centre of mass -> them
        # - a_m x v_m, the constant part of k_m (see _coefficients)
        self._k0 = tuple(-(ax * vy - ay * vx) for (ax, ay), (vx, vy) in zip(self.a, self.v))
        # the orientation of the stable balance: sign * F rises through zero there (the
        # restoring torque), the same everywhere on the wall; taken below the middle
        mid = np.array([self.d_mm / 2.0]), np.array([self.d_mm])
        self.sign = 1.0 if self._terms(*mid, np.ones(1), np.zeros(1))[0][0] > 0 else -1.0

    # ------------------------------------------------------------------ the balance
    def _terms(self, x, y, c, s):
        """dF/dphi at pen (x, y) with cos/sin of phi c, s; the cords r_m and R a_m."""
        (pl_x, pl_y, pr_x, pr_y), g = self._arms(c, s, pen=True)
        gl_x, gl_y, gr_x, gr_y = g
        wlx, wrx, wy = -x, self.d_mm - x, -y                     # w_m = A_m - p
        rlx, rly = wlx - pl_x, wy - pl_y
        rrx, rry = wrx - pr_x, wy - pr_y
        kl = gl_x * rly - gl_y * rlx
        kr = gr_x * rry - gr_y * rrx
        # d/dphi: d(R w) = (-(R w)_y, (R w)_x), dr_m = -d(R v_m), so dk_m = -(R a_m) . w_m
        dkl = -(gl_x * wlx + gl_y * wy)
        dkr = -(gr_x * wrx + gr_y * wy)
        df = dkl * rrx + kl * pr_y - dkr * rlx - kr * pl_y
        return df, (rlx, rly, rrx, rry), g

    def _arms(self, c, s, pen: bool = False) -> tuple:
        """(R v_m, R a_m) (or R a_m alone: pen False) at cos/sin of phi c, s, each as (Lx, Ly,
        Rx, Ry): the gondola is symmetric, R v_m = (-+ half c + h s, -+ half s - h c), R a_m
        the same with h + mass_below_pen for h."""
        half, h, ha = self._half, self._h, self._ha
        hc, hs = half * c, half * s
        t = ha * s
        g = [t - hc, None, t + hc, None]
        t = ha * c
        g[1], g[3] = -hs - t, hs - t
        if not pen:
            return tuple(g)
        t = h * s
        v = [t - hc, None, t + hc, None]
        t = h * c
        v[1], v[3] = -hs - t, hs - t
        return tuple(v), tuple(g)

    def _coefficients(self, x, y) -> tuple:
        """F at pen (x, y) as a quadratic in cos and sin of phi: with w_m = A_m - p, k_m =
        (R a_m) x r_m = c (a_m x w_m) - s (a_m . w_m) - a_m x v_m (R a x R v = a x v) and
        r_mx = w_mx - (R v_m)_x both linear in (c, s). The per-point terms (P_L, Q_L, P_R,
        Q_R, w_Lx, w_Rx): a Newton step then costs half of _terms."""
        (alx, aly), (arx, ary) = self.a
        wlx, wrx = -x, self.d_mm - x
        wy = -y
        return (alx * wy - aly * wlx, -(alx * wlx + aly * wy),
                arx * wy - ary * wrx, -(arx * wrx + ary * wy), wlx, wrx)

    def _f(self, co, c, s, second: bool = False) -> tuple:
        """F and dF/dphi from _coefficients at cos/sin of phi c, s (and d2F/dphi2: second)."""
        pl, ql, pr, qr, wlx, wrx = co
        (vlx, vly), (vrx, vry) = self.v
        k0l, k0r = self._k0
        kl = c * pl + s * ql + k0l
        kr = c * pr + s * qr + k0r
        rlx = wlx - (c * vlx - s * vly)
        rrx = wrx - (c * vrx - s * vry)
        f = kl * rrx - kr * rlx
        # d/dphi: dc = -s, ds = c; d2/dphi2: -c, -s (so k'' = k0 - k, r_x'' = w_x - r_x)
        dkl = c * ql - s * pl
        dkr = c * qr - s * pr
        drlx = s * vlx + c * vly
        drrx = s * vrx + c * vry
        df = dkl * rrx + kl * drrx - dkr * rlx - kr * drlx
        if not second:
            return f, df
        return f, df, ((k0l - kl) * rrx + 2.0 * dkl * drrx + kl * (wrx - rrx)
                       - (k0r - kr) * rlx - 2.0 * dkr * drlx - kr * (wlx - rlx))

    def solve(self, x, y, phi=None):
        """phi at pen points (x, y): (phi, cos, sin, dF/dphi, dF/dx, dF/dy, cords r)."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        if x.size <= FEW:                 # in Python floats: no array overhead
            start = np.zeros(x.shape) if phi is None else np.broadcast_to(phi, x.shape)
            rows = [self.state_one(a, b, p) for a, b, p in
                    zip(x.ravel().tolist(), y.ravel().tolist(), np.ravel(start).tolist())]
            cols = np.array([(*st[:6], *st[6]) for st in rows]).reshape(-1, 10)
            cols = np.ascontiguousarray(cols.T).reshape((10, *x.shape))
            return (*cols[:6], tuple(cols[6:]))
        phi = self._guess(x, y) if phi is None else np.array(phi, dtype=float)
        # Halley steps (the balance is smooth and phi small: one step from the table's guess
        # for most points); cos and sin turn with phi by their series, not computed again. The
        # rows that did not settle on the stable balance go the bracketed way
        c, s = _cos_sin(phi)
        co = self._coefficients(x, y)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            h = self._halley(co, c, s)
            phi, c, s = _turned(phi, c, s, h)
            last = np.abs(h)
            at = np.flatnonzero(~(last <= PHI_HALLEY))          # the rows still stepping
            for _ in range(PHI_FAST - 1):
                if not len(at):
                    break
                h = self._halley(tuple(v[at] for v in co), c[at], s[at])
                phi[at], c[at], s[at] = _turned(phi[at], c[at], s[at], h)
                last[at] = np.abs(h)
                at = at[~(np.abs(h) <= PHI_HALLEY)]
        del co, h                               # (let go before the terms: see vertex_terms)
        df, r, g = self._terms(x, y, c, s)
        sdf = self.sign * df
        # unless every row settled (at: those whose last step was not below PHI_HALLEY) on the
        # stable balance inside the bracket, those that did not go the bracketed way
        if len(at) or not (sdf.min() > 0 and np.abs(phi).max() < PHI_LIMIT):
            ok = (last <= PHI_HALLEY) & (sdf > 0) & (np.abs(phi) < PHI_LIMIT)
            i = np.flatnonzero(~ok)
            phi[i] = self._bracketed(x[i], y[i], np.zeros(len(i)))
            c, s = np.cos(phi), np.sin(phi)
            df, r, g = self._terms(x, y, c, s)
        return self._state(phi, c, s, df, r, g)

    def _halley(self, co, c, s):
        """Halley's step for F at cos/sin of phi c, s (from _coefficients co): the error after
        it is about 0.15 step^3 (measured over the page of five gondolas)."""
        f, df, d2f = self._f(co, c, s, second=True)
        newton = f / df
        return newton / (1.0 - 0.5 * newton * d2f / df)

    def _guess(self, x, y) -> np.ndarray:
        """A first guess of phi at (x, y): the balance solved on a grid of cells D /
        GUESS_CELLS (once per gondola: 3 ms), interpolated bilinearly (within 3e-5 in the
        seed page's middle, 1.3e-4 at 99 % of its points: one Halley step settles it; with half
        as many cells, 14 % of a 97,000-line drawing's points took a second one)."""
        table = self.__dict__.get("_table")
        if table is None:
            key = (self.d_mm, self.v, self.a)
            table = _TABLES.get(key)
            if table is None:
                table = _TABLES[key] = self._grid()
                while len(_TABLES) > TABLES:      # (a fit tries many gondolas: the oldest go)
                    del _TABLES[next(iter(_TABLES))]
            self._table = table
        h, rows, cols, cells = table
        fx = x / h
        fy = y / h
        np.maximum(fx, 0.0, out=fx)             # (np.clip costs more on a few points)
        np.minimum(fx, cols + 1 - 1.000001, out=fx)       # (nodes - 1.000001)
        np.maximum(fy, 0.0, out=fy)
        np.minimum(fy, rows + 1 - 1.000001, out=fy)
        ix, iy = fx.astype(np.intp), fy.astype(np.intp)
        fx -= ix
        fy -= iy
        k = iy * cols
        k += ix
        a, b, c, d = (v.take(k) for v in cells)
        return a + fx * b + fy * (c + fx * d)

    def _grid(self) -> tuple:
        """(h, rows, columns, cells) of the grid of phi: between the anchors (columns x = j h),
        from 2 h below them down to 2 D (rows y = i h, clamped at 2 h: nearer, the points the
        gondola cannot hang at begin); per cell (flat, row by row) its bilinear terms: phi at
        its first corner a, and b - a, c - a, d - b - c + a of the others (b along x, c along
        y, d across)."""
        h = self.d_mm / GUESS_CELLS
        xs = np.arange(GUESS_CELLS + 1) * h
        ys = np.arange(2 * GUESS_CELLS + 1) * h
        gx, gy = np.meshgrid(xs, np.maximum(ys, 2.0 * h))
        phi = self.solve(gx.ravel(), gy.ravel(), np.zeros(gx.size))[0]
        t = np.where(np.isfinite(phi), phi, 0.0).reshape(gx.shape)
        a = t[:-1, :-1]
        b, c = t[:-1, 1:] - a, t[1:, :-1] - a
        d = t[1:, 1:] - a
        d -= b
        d -= c
        return h, *a.shape, tuple(np.ascontiguousarray(v).ravel() for v in (a, b, c, d))

    def _bracketed(self, x, y, phi):
        """phi by Newton steps kept inside a bracket (bisection where a step would leave it)."""
        lo = np.full(x.shape, -PHI_LIMIT)
        hi = np.full(x.shape, PHI_LIMIT)
        sg = self.sign
        co = self._coefficients(x, y)
        for _ in range(PHI_STEPS):
            f, df = self._f(co, np.cos(phi), np.sin(phi))
            above = sg * f > 0
            hi = np.where(above, phi, hi)
            lo = np.where(above, lo, phi)
            with np.errstate(divide="ignore", invalid="ignore"):
                nxt = phi - f / df
            bad = ~((nxt >= lo) & (nxt <= hi)) | ~(sg * df > 0)
            nxt = np.where(bad, (lo + hi) / 2.0, nxt)
            step = np.abs(nxt - phi)
            phi = nxt
            # Newton doubles the digits: after a step this small phi is within about 1e-13
            if not step.max(initial=0.0) > PHI_NEWTON:
                break
        return phi

    def _state(self, phi, c, s, df, r, g):
        """solve()'s answer from the balance's terms at phi."""
        gl_x, gl_y, gr_x, gr_y = g
        rlx, _, rrx, _ = r
        kl = gl_x * r[1] - gl_y * rlx
        kr = gr_x * r[3] - gr_y * rrx
        # dr/dx = (-1, 0), dr/dy = (0, -1) for both cords
        fx = gl_y * rrx - kl - gr_y * rlx + kr
        fy = -gl_x * rrx + gr_x * rlx
        return phi, c, s, df, fx, fy, r

    def state_one(self, x: float, y: float, phi: float = 0.0) -> tuple:
        """solve()'s answer for one point in Python floats (no array overhead), from phi."""
        phi = self._phi_one(x, y, phi)
        c, s = math.cos(phi), math.sin(phi)
        df, r, g = self._terms(x, y, c, s)
        return self._state(phi, c, s, df, r, g)

    def _phi_one(self, x: float, y: float, phi: float) -> float:
        """phi at one point by bracketed Newton steps from phi, in Python floats."""
        lo, hi = -PHI_LIMIT, PHI_LIMIT
        co = self._coefficients(x, y)
        for _ in range(PHI_STEPS):
            f, df = self._f(co, math.cos(phi), math.sin(phi))
            if self.sign * f > 0:
                hi = phi
            else:
                lo = phi
            nxt = phi - f / df if self.sign * df > 0 else (lo + hi) / 2.0
            nxt = nxt if lo <= nxt <= hi else (lo + hi) / 2.0
            step, phi = abs(nxt - phi), nxt
            if not step > PHI_NEWTON:
                break
        return phi

    def cords(self, x, y, phi=None) -> tuple:
        """The cord vectors (r_Lx, r_Ly, r_Rx, r_Ry) of the balanced gondola, and phi."""
        phi, _, _, _, _, _, r = self.solve(x, y, phi)
        return r, phi


def _turned(phi, c, s, h) -> tuple:
    """phi - h with its cos and sin: by the series of the turn by h (to within 1e-17 for steps
    up to ROTATE_MAX), else computed."""
    phi = phi - h
    if not np.abs(h).max(initial=0.0) <= ROTATE_MAX:
        return phi, np.cos(phi), np.sin(phi)
    return (phi, *_back(c, s, h))


def _back(c, s, h) -> tuple:
    """cos and sin of phi - h from those of phi (c, s), by the series of the turn by h."""
    q = h * h
    ch = 1.0 - q * (0.5 - q / 24.0)
    sh = h * (1.0 - q / 6.0)
    return c * ch + s * sh, s * ch - c * sh


ANGLES = 1024             # per rad: cos and sin of a guess turned from the nearest of these
ANGLE_ROWS = 2000         # on at least this many points (fewer: np.cos and np.sin cost less)
_AT = int(PHI_LIMIT * ANGLES) + 1
_COS = np.cos(np.arange(-_AT, _AT + 1) / ANGLES)
_SIN = np.sin(np.arange(-_AT, _AT + 1) / ANGLES)


def _cos_sin(phi) -> tuple:
    """cos and sin of phi: on many points, those of the nearest multiple of 1 / ANGLES turned
    by the rest (below ROTATE_MAX: _back) (np.cos and np.sin cost some 25 operations each)."""
    if phi.size < ANGLE_ROWS or not np.abs(phi).max(initial=0.0) < PHI_LIMIT:
        return np.cos(phi), np.sin(phi)
    k = np.rint(phi * ANGLES)
    at = k.astype(np.intp)
    at += _AT
    k *= 1.0 / ANGLES
    k -= phi                                     # the nearest multiple less phi
    return _back(_COS.take(at), _SIN.take(at), k)
