"""Cords that sag (`[cords] mass_g_per_m` with `[gondola] mass_g`): each cord hangs as a
catenary between its anchor and the point where it holds the gondola.

Machine frame (+x right, +y DOWN), anchors A_L = (0, 0), A_R = (D, 0); forces in units of the
gondola's weight. Only mu, the cord's mass per mm over the gondola's mass (1/mm), enters. The
cords hold the gondola at P_L, P_R (the level gondola's points beside and above the pen, or the
tilted gondola's, kinematics/tilt.py). The gondola's horizontal balance gives both cords one
horizontal tension H. A cord spanning h > 0 across and v down from its anchor, a = H / mu:
  m = asinh(v / c), c = 2 a sinh(h / 2a) (the catenary's apex parameter);
  the cord pulls the gondola up by V = H sinh(m - h / 2a), its length L = sqrt(v^2 + c^2).
As mu -> 0, c -> h, V -> H v / h, L -> the chord: computed as c = (2 H / mu) sinh(mu h / 2H)
these are the limits without cancellation (sinh keeps its relative accuracy near 0).
Balance: V_L + V_R = 1 (the weight); a tilting gondola adds its turn phi as an unknown and the
torque of the two pulls (-H, -V_L) at P_L and (H, -V_R) at P_R about its centre of mass.
Solved per point by Newton steps (H alone, or (phi, H)) from the massless cords' balance.
Stretch on top as for straight cords: q = L / (1 + stretch t), t = sqrt(H^2 + V^2) the tension
at the gondola's end (stretch 0 and mu 0 give the plain formulas exactly; mu 0 never comes
here: kinematics/vplotter.py keeps its own models then).
Along a line p0 + s e the unknowns' derivatives follow by implicit differentiation of the
balance (J u' = -F_s, J u'' = -F_ss(u') with J the balance's Jacobian in the unknowns), and
every cord with them by Taylor arithmetic (taylor.py): the planner's slopes and bends are exact.
The step solver (crossing) is the exact one: bracketed Newton steps on the cord, the balance
solved at each (from the one before). Near straight below an anchor the other cord goes slack
and hangs in a loop (H -> 0): the model holds there but is wild; no page should reach it.
"""

from __future__ import annotations

import numpy as np

from vplotter.kinematics import taylor as _taylor
from vplotter.kinematics.tilt_along import tensions

STEPS = 40           # Newton steps at most (the balance, and the pen from the cords)
TOL = 1e-10          # forward stops after a step below this (mm)
TOL_BALANCE = 1e-7   # the balance after a step below this (relative in H, rad): then ~1e-14
INSIDE_MM = 1.0      # forward: a pen this far at least inside the anchors and below them
WARM_MM = 5.0        # balance(): the last balance is the first guess for points this near
SLACK = 1.5         # TwoCord.check_move: the slack cord's mu h / 2H at most this (a plan
                    # failed at 3.3, held at 2.05)
PHI_STEP = 0.2       # rad: a Newton step of the turn goes no further


_first = _taylor.First


def _const(v):
    return (v, 0.0)


def _shift(a, k):
    return (a[0] + k, *a[1:])


class Sag:
    """The balance of a gondola on two catenaries (level, or tilting: `gondola` a tilt.Gondola)."""

    def __init__(self, d_mm: float, spacing_mm: float, pen_below_mm: float, mu_per_mm: float,
                 stretch: float = 0.0, gondola=None):
        half = float(spacing_mm) / 2.0
        self.d_mm = float(d_mm)
        self.mu = float(mu_per_mm)
        self.stretch = float(stretch)
        self.gondola = gondola
        self.v = ((-half, -float(pen_below_mm)), (half, -float(pen_below_mm)))
        self._last = None          # (points, balance) of the last balance() call

    # ------------------------------------------------------------------ one evaluation
    def _eval(self, X, Y, U):
        """The balance (vertical; torque when tilting), the motor coordinates and the pulls
        V as triples, for triples of the pen's x, y and the unknowns U ([H] or [phi, H])."""
        H = U[-1]
        tl = _taylor if len(H) == 3 else _first
        C, S = tl.cos_sin(U[0]) if len(U) == 2 else (None, None)
        mu = self.mu
        q, pull = [], []
        for (vx, vy), side in zip(self.v, (1.0, -1.0)):
            if C is None:
                px, py = _shift(X, vx), _shift(Y, vy)
            else:
                px = tl.add(X, tl.sub(tl.scale(C, vx), tl.scale(S, vy)))
                py = tl.add(Y, tl.add(tl.scale(S, vx), tl.scale(C, vy)))
            h = px if side > 0 else _shift(tl.scale(px, -1.0), self.d_mm)
            half = tl.scale(tl.div(h, H), mu / 2.0)                      # h / 2a
            c = tl.scale(tl.mul(tl.sinh(half), H), 2.0 / mu)            # 2 a sinh(h / 2a)
            v_low = tl.mul(H, tl.sinh(tl.sub(tl.asinh(tl.div(py, c)), half)))
            length = tl.sqrt(tl.add(tl.mul(py, py), tl.mul(c, c)))
            if self.stretch:
                t = tl.sqrt(tl.add(tl.mul(H, H), tl.mul(v_low, v_low)))
                length = tl.div(length, _shift(tl.scale(t, self.stretch), 1.0))
            q.append(length)
            pull.append(v_low)
        balance = [_shift(tl.add(pull[0], pull[1]), -1.0)]
        if C is not None:
            # the pulls' torque about the centre of mass G: (P - G) x F, P - G = R a_m
            torque = None
            for (ax, ay), v_low, side in zip(self.gondola.a, pull, (-1.0, 1.0)):
                gx = tl.sub(tl.scale(C, ax), tl.scale(S, ay))
                gy = tl.add(tl.scale(S, ax), tl.scale(C, ay))
                # F = (side H, -V): gx Fy - gy Fx
                term = tl.sub(tl.scale(tl.mul(gx, v_low), -1.0), tl.scale(tl.mul(gy, H), side))
                torque = term if torque is None else tl.add(torque, term)
            balance.append(torque)
        return balance, q, pull

    def _unknowns(self, state, k=None, d1=None, d2=None):
        """The unknowns as pairs: constant, or moving along unknown k (d/dk = 1); or as
        triples with the derivatives d1, d2 (lists)."""
        phi, H = state
        vals = [H] if phi is None else [phi, H]
        if d1 is not None:
            return [(v, a, b) for v, a, b in zip(vals, d1, d2)]
        return [(v, 1.0 if i == k else 0.0) for i, v in enumerate(vals)]

    # ------------------------------------------------------------------ the balance
    def _floor(self, x, y, phi):
        """H of straight cords that carry the weight (their torque aside) with the cords'
        points where the gondola turned by phi holds them: sagging cords need more (their
        pull at the gondola is less steep than the chord), so H stays above it."""
        c, s = (1.0, 0.0) if phi is None else (np.cos(phi), np.sin(phi))
        (lx, ly), (rx, ry) = self.v
        hl, hr = x + c * lx - s * ly, self.d_mm - x - c * rx + s * ry
        return 1.0 / ((y + s * lx + c * ly) / hl + (y + s * rx + c * ry) / hr)

    def massless(self, x, y) -> tuple:
        """The balance of straight cords (mu = 0): the first guess of solve()."""
        if self.gondola is None:
            return None, self._floor(x, y, None)
        r, phi = self.gondola.cords(x, y)
        t = tensions(r)[:, 0]
        return phi, t * -r[0] / np.hypot(r[0], r[1])

    def solve(self, x, y, guess=None) -> tuple:
        """(phi or None, H) at pen points (x, y): Newton steps from `guess` (the balance at
        points near by) or from the massless balance, H kept above _floor (where a cord would
        hang slack and the balance turns wild)."""
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        phi, H = self.massless(x, y) if guess is None else guess
        H = np.array(H, dtype=float)
        phi = None if phi is None else np.array(phi, dtype=float)
        rows = np.arange(len(H))           # the rows still moving
        for _ in range(STEPS):
            xr, yr, hr = x[rows], y[rows], H[rows]
            pr = None if phi is None else phi[rows]
            J, f, _, _ = _partials_of(self, xr, yr, (pr, hr))
            step = _solve(J, f)
            if pr is not None:
                pr = pr - np.clip(step[0], -PHI_STEP, PHI_STEP)
                phi[rows] = pr
            H[rows] = hr = np.maximum(hr - step[-1], self._floor(xr, yr, pr))
            size = np.abs(step[-1]) / hr
            if pr is not None:
                size = np.maximum(size, np.abs(step[0]))
            rows = rows[size > TOL_BALANCE]  # NaN: a point without a balance, left as it is
            if not len(rows):
                break
        return phi, H

    def balance(self, xy) -> tuple:
        """solve() at the points xy (N, 2), from the balance solved last where these points
        are that one's moved by less than WARM_MM (the step solver's Newton iterates)."""
        last = self._last
        if (last is not None and last[0].shape == xy.shape
                and np.abs(last[0] - xy).max(initial=0.0) < WARM_MM):
            state = self.solve(xy[:, 0], xy[:, 1], last[1])
        else:
            state = self.solve(xy[:, 0], xy[:, 1])
        self._last = (xy.copy(), state)
        return state

    def tension(self, xy) -> np.ndarray:
        """(N, 2) tensions at the gondola's ends of the cords, in units of its weight."""
        xy = np.asarray(xy, dtype=float)
        state = self.solve(xy[:, 0], xy[:, 1])
        _, _, pull = self._eval(_const(xy[:, 0]), _const(xy[:, 1]), self._unknowns(state))
        return np.stack([np.hypot(state[1], v[0]) for v in pull], axis=-1)

    # ------------------------------------------------------------------ kinematics
    def inverse(self, xy) -> np.ndarray:
        m = np.asarray(xy, dtype=float)
        flat = m.reshape(-1, 2)
        state = self.balance(flat)
        _, q, _ = self._eval(_const(flat[:, 0]), _const(flat[:, 1]), self._unknowns(state))
        return np.stack([np.broadcast_to(a[0], flat[:, 0].shape) for a in q],
                        axis=-1).reshape(m.shape)

    def jets(self, xy, e, state=None, order=2):
        """Motor coordinates (N, 2) at xy with their first and second derivatives along the
        unit directions e (order 1: the first only); `state`: solve(xy) when known."""
        xy = np.asarray(xy, dtype=float)
        e = np.asarray(e, dtype=float)
        x, y = xy[:, 0], xy[:, 1]
        state = self.balance(xy) if state is None else state
        J, _, dq, _ = _partials_of(self, x, y, state)
        fs, qs, _ = self._eval((x, e[:, 0]), (y, e[:, 1]), self._unknowns(state))
        u1 = [-v for v in _solve(J, [f[1] for f in fs])]
        if order == 1:
            k = [qs[m][1] + sum(dq[j][m] * u1[j] for j in range(len(u1))) for m in (0, 1)]
            return (np.stack([np.broadcast_to(qs[m][0], x.shape) for m in (0, 1)], axis=-1),
                    np.stack(k, axis=-1))
        zero = [0.0] * len(u1)
        fd, q, _ = self._eval((x, e[:, 0], 0.0), (y, e[:, 1], 0.0),
                              self._unknowns(state, d1=u1, d2=zero))
        u2 = [-v for v in _solve(J, [f[2] for f in fd])]
        # the unknowns' second derivatives enter the cords' linearly
        out = []
        for m, qm in enumerate(q):
            bend = qm[2] + sum(dq[k][m] * u2[k] for k in range(len(u2)))
            out.append((qm[0], qm[1], bend))
        return tuple(np.stack((a, b), axis=-1) for a, b in zip(*out))

    def first(self, xy, state):
        """Motor coordinates (N, 2) and their derivatives in x and y (N, 2 each)."""
        x, y = xy[:, 0], xy[:, 1]
        J, _, dq, cols = _partials_of(self, x, y, state)
        q = [np.broadcast_to(a[0], x.shape) for a in cols[0][1]]
        out = []
        for ex, ey in ((1.0, 0.0), (0.0, 1.0)):
            fs, qs, _ = self._eval((x, ex), (y, ey), self._unknowns(state))
            u1 = [-v for v in _solve(J, [f[1] for f in fs])]
            out.append(np.stack([qs[m][1] + sum(dq[k][m] * u1[k] for k in range(len(u1)))
                                 for m in (0, 1)], axis=-1))
        return np.stack(q, axis=-1), out[0], out[1]

    def _inside(self, p):
        """p moved (in place) to where both cords hang down from their anchors (a first guess
        from straight cords, or a Newton step, can land beyond an anchor)."""
        lo, hi = -self.v[0][0] + INSIDE_MM, self.d_mm - self.v[1][0] - INSIDE_MM
        np.clip(p[:, 0], lo, hi, out=p[:, 0])
        np.maximum(p[:, 1], INSIDE_MM - self.v[0][1], out=p[:, 1])
        return p

    def forward(self, cords, p) -> np.ndarray:
        """Pen points (N, 2) where the motors have paid out `cords` (N, 2), by Newton steps
        from the first guess p (N, 2), the balance solved at every step."""
        c = np.asarray(cords, dtype=float)
        p = self._inside(np.array(p, dtype=float))
        state = self.solve(p[:, 0], p[:, 1])
        rows = np.arange(len(p))
        for _ in range(STEPS):
            pr = p[rows]
            q, jx, jy = self.first(pr, _rows(state, rows))
            f = q - c[rows]
            det = jx[:, 0] * jy[:, 1] - jy[:, 0] * jx[:, 1]
            dx = (f[:, 0] * jy[:, 1] - jy[:, 0] * f[:, 1]) / det
            dy = (jx[:, 0] * f[:, 1] - f[:, 0] * jx[:, 1]) / det
            pr[:, 0] -= dx
            pr[:, 1] -= dy
            p[rows] = self._inside(pr)
            rows = rows[np.maximum(np.abs(dx), np.abs(dy)) > TOL]
            if not len(rows):
                break
            # the balance at the points moved on, from the one before
            new = self.solve(p[rows, 0], p[rows, 1], _rows(state, rows))
            state = tuple(None if v is None else _put(v, rows, w) for v, w in zip(state, new))
        return p


def crossing(kin, p0, e, motor, piece, q, rising, bracketed, tol) -> np.ndarray:
    """TwoCord.crossing with sagging cords: bracketed Newton steps on the exact cord
    (`bracketed`: vplotter._bracketed) from a first guess that does not run far past the
    step: beyond a piece's end the pen may come near straight below an anchor, where the other
    cord goes slack and the balance is wild (or none: NaN, taken as past the step). The guess:
    where the cord's tangent at the piece's start reaches q, or its parabola (value, slope,
    bend) where that comes sooner (a cord rising), and no further than the piece's end where
    that is known (the next piece starts there)."""
    sag = kin.sag
    n = len(p0)
    d = np.full(n, np.inf)
    if n > 1:
        gap = p0[1:] - p0[:-1]
        along = gap[:, 0] * e[:-1, 0] + gap[:, 1] * e[:-1, 1]
        off = np.hypot(gap[:, 0] - along * e[:-1, 0], gap[:, 1] - along * e[:-1, 1])
        d[:-1] = np.where((off <= 1e-9 * (1.0 + np.abs(along))) & (along >= 0), along, np.inf)
    v0, k0, b0 = (a[:, motor] for a in sag.jets(p0, e))
    sign = np.where(rising, 1.0, -1.0)
    c = sign * (v0[piece] - q)               # <= 0: the steps lie ahead
    b = sign * k0[piece]
    a = np.maximum(sign * b0[piece] / 2.0, 0.0)     # the parabola only where it is sooner
    with np.errstate(divide="ignore", invalid="ignore"):
        s = -2.0 * c / (b + np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0)))
    hi = d[piece] + 1e-9
    s = np.clip(np.nan_to_num(s, nan=0.0, posinf=np.inf), 0.0, hi)
    s = np.where(np.isfinite(s), s, 0.0)
    start, dirn = p0[piece], e[piece]

    def f(s_):
        v, k = sag.jets(start + dirn * s_[:, None], dirn, order=1)
        v = sign * (v[:, motor] - q)
        return np.where(np.isnan(v), np.inf, v), sign * k[:, motor]

    return bracketed(f, np.zeros(len(q)), hi, tol, s)


def _partials_of(sag: Sag, x, y, state):
    """The balance's Jacobian in the unknowns (J[row][col]) at pens (x, y), the balance's
    values, the motor coordinates' derivatives in the unknowns (dq[col][motor]) and the
    evaluations themselves (one per unknown)."""
    X, Y = _const(x), _const(y)
    n = 1 if state[0] is None else 2
    cols = [sag._eval(X, Y, sag._unknowns(state, k)) for k in range(n)]
    J = [[col[0][r][1] for col in cols] for r in range(n)]
    return J, [f[0] for f in cols[0][0]], [[qm[1] for qm in col[1]] for col in cols], cols


def _rows(state, rows):
    return tuple(None if v is None else v[rows] for v in state)


def _put(v, rows, w):
    v = v.copy()
    v[rows] = w
    return v


def _solve(J, rhs):
    """J u = rhs for 1x1 or 2x2 J (lists of arrays), by Cramer's rule."""
    if len(J) == 1:
        return [rhs[0] / J[0][0]]
    (a, b), (c, d) = J
    det = a * d - b * c
    return [(rhs[0] * d - b * rhs[1]) / det, (a * rhs[1] - c * rhs[0]) / det]
