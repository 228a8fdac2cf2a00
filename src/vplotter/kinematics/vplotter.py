"""The two-cord hanging plotter (V-plotter).

Machine frame: origin at the LEFT anchor (where the cord leaves the left spool), +x right,
+y DOWN; the right anchor is at (anchor_distance_mm, 0). Motor coordinates are the cord
lengths in mm that the motors have paid out.

Models (each one off by default, and then the formulas are exactly the plain ones):
- gondola: the cords hold the gondola `cord_spacing_mm` apart, the pen midway between them and
  `pen_below_mm` below the line through them; the gondola does not tilt. A cord's geometric
  length is then the distance from the pen to a shifted anchor E (the anchor moved by
  (+-spacing/2, pen_below)): left = |p - E_left|, right = |p - E_right|.
- sag (kinematics/sag.py): heavy cords hang as catenaries; level or tilting gondola, with or
  without stretch.
- stretch: the cords stretch in proportion to their tension. From the static balance of the
  gondola's weight W (two cords, weight straight down) a cord of geometric length g carries
  t = T / W (t_left = -x_R g_L / C, t_right = x_L g_R / C with r = p - E and C = r_L x r_R);
  the motor pays out q = g / (1 + stretch * t) of unstretched cord.
With stretch the step solver, the extrema and forward kinematics iterate (bracketed Newton);
slopes and bends are exact derivatives along the line (second-order Taylor arithmetic).
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.kinematics.taylor import add as _add
from vplotter.kinematics.taylor import div as _div
from vplotter.kinematics.taylor import mul as _mul
from vplotter.kinematics.taylor import scale as _scale
from vplotter.kinematics.taylor import sqrt as _sqrt
from vplotter.kinematics.taylor import sub as _sub
from vplotter.kinematics import tilt_kept, tilt_steps
from vplotter.kinematics.sag import Sag
from vplotter.kinematics.sag import crossing as sag_crossing
from vplotter.kinematics.tilt import FEW, Gondola
from vplotter.kinematics.tilt_along import cord_jets, cords_value, tensions

NEWTON_STEPS = 40          # at most; they stop when every row is within TOL_MM
TOL_MM = 1e-10
FAST_TILT = True           # tilt: the step solver of tilt_steps (False: the exact one)
MID_SHARE = 0.1            # tilt: pieces longer than this share of the shorter cord at their
#                            middle solve the bend there (bend_inside)
TURN_MM = 1e-5             # tilt: the turning points' Newton stops after a step below this
#                            (the point is then within about 1e-13 mm: the error squares)


class TwoCord:
    motors = ("left", "right")

    def __init__(self, anchor_distance_mm: float, origin_x_mm: float, origin_y_mm: float,
                 cord_spacing_mm: float = 0.0, pen_below_mm: float = 0.0, stretch: float = 0.0,
                 mass_below_pen_mm: float | None = None, sag_per_mm: float = 0.0):
        self.d_mm = float(anchor_distance_mm)
        self.origin = np.array([origin_x_mm, origin_y_mm], dtype=float)
        self.spacing_mm = float(cord_spacing_mm)
        self.pen_below_mm = float(pen_below_mm)
        self.stretch = float(stretch)
        half = self.spacing_mm / 2.0
        # the points the pen would hang from if the cords met at the pen (shifted anchors)
        self.anchors = np.array([[half, self.pen_below_mm],
                                 [self.d_mm - half, self.pen_below_mm]])
        self.mass_below_pen_mm = None if mass_below_pen_mm is None else float(mass_below_pen_mm)
        self.gondola = None if mass_below_pen_mm is None else Gondola(
            self.d_mm, self.spacing_mm, self.pen_below_mm, self.mass_below_pen_mm)
        # the cords' mass per mm over the gondola's (0: straight cords)
        self.sag_per_mm = float(sag_per_mm)
        self.sag = None if self.sag_per_mm == 0.0 else Sag(
            self.d_mm, self.spacing_mm, self.pen_below_mm, self.sag_per_mm, self.stretch,
            self.gondola)
        # the closed forms hold: a level gondola and cords that neither stretch nor sag
        self.plain = self.stretch == 0.0 and self.gondola is None and self.sag is None

    def to_machine(self, xy_gcode: np.ndarray) -> np.ndarray:
        g = np.asarray(xy_gcode, dtype=float)
        return np.stack((self.origin[0] + g[..., 0], self.origin[1] - g[..., 1]), axis=-1)

    def to_gcode(self, xy: np.ndarray) -> np.ndarray:
        m = np.asarray(xy, dtype=float)
        return np.stack((m[..., 0] - self.origin[0], self.origin[1] - m[..., 1]), axis=-1)

    def check_move(self, xy: np.ndarray, start: np.ndarray) -> int:
        """-1: the cords reach every point of the page (which the plan checks). Sagging cords
        hold the gondola only where neither cord's end on it is near straight below its
        anchor: there the other cord goes slack and hangs in a bow deeper than the step solver
        takes (a plan 0.4 m off was seen). Each cord's drop over its span is kept under
        sag.SLACK / (mu D), so that the slack cord's catenary parameter H / mu stays above
        D / (2 SLACK) (H >= 1 / (2 K) of straight cords): a half-plane per cord, so the lines
        between such points keep to it too. The first point where not."""
        if self.sag is None:
            return -1
        from vplotter.kinematics.sag import SLACK

        m = np.asarray(xy, dtype=float)
        half = self.spacing_mm / 2.0
        steep = SLACK / (self.sag_per_mm * self.d_mm)
        drop = m[:, 1] - self.pen_below_mm
        bad = ((drop > steep * (m[:, 0] - half)) | (drop > steep * (self.d_mm - half - m[:, 0]))
               | (m[:, 0] - half <= 0.0) | (m[:, 0] + half >= self.d_mm))
        idx = np.flatnonzero(bad)
        return int(idx[0]) if idx.size else -1

    def cannot_reach(self, x: float, y: float) -> str:
        if self.sag is not None:
            return (f"the pen cannot reach X{x:.3f} Y{y:.3f}: a cord's end on the gondola "
                    f"would hang nearly straight below its anchor, the other cord slack "
                    f"(sagging cords: keep the drawing further from the page's sides)")
        return f"the pen cannot reach X{x:.3f} Y{y:.3f}"

    # ------------------------------------------------------------------ geometry
    def _geometric(self, xy: np.ndarray) -> np.ndarray:
        m = np.asarray(xy, dtype=float)
        a = self.anchors
        return np.stack((np.hypot(m[..., 0] - a[0, 0], m[..., 1] - a[0, 1]),
                         np.hypot(a[1, 0] - m[..., 0], m[..., 1] - a[1, 1])), axis=-1)

    def _triangulate(self, g: np.ndarray) -> np.ndarray:
        """Pen position from geometric cord lengths (no stretch)."""
        left, right = g[..., 0], g[..., 1]
        d = self.d_mm - self.spacing_mm
        x = (d ** 2 + left ** 2 - right ** 2) / (2.0 * d)
        y = np.sqrt(np.maximum(left ** 2 - x ** 2, 0.0))
        return np.stack((x + self.anchors[0, 0], y + self.anchors[0, 1]), axis=-1)

    def inverse(self, xy: np.ndarray) -> np.ndarray:
        if self.plain:
            return self._geometric(xy)
        if self.sag is not None:
            return self.sag.inverse(xy)
        m = np.asarray(xy, dtype=float)
        if self.gondola is not None:
            flat = m.reshape(-1, 2)
            state = (tilt_kept.balance(self, flat) if len(flat) > 2
                     else self.gondola.solve(flat[:, 0], flat[:, 1]))
            if m.ndim == 2 and len(m) > 2:        # a window's vertices: see tilt_steps
                tilt_kept.remember(self, m, state)
            return cords_value(state[6], self.stretch).reshape(m.shape)
        flat = m.reshape(-1, 2)
        q, _, _ = self._jets(flat, np.zeros_like(flat))
        return q.reshape(m.shape)

    def forward(self, cords: np.ndarray) -> np.ndarray:
        c = np.asarray(cords, dtype=float)
        p = self._triangulate(c)
        if self.plain:
            return p
        if self.sag is not None:
            return self.sag.forward(c.reshape(-1, 2), p.reshape(-1, 2)).reshape(c.shape)
        # Newton on q(p) = c (with a tilting gondola, its angle phi the third unknown, held
        # in balance at every step); the Jacobian rows are the slopes along x and y
        flat_c = c.reshape(-1, 2)
        if self.gondola is not None and len(flat_c) <= FEW:      # a few: in Python floats
            return np.reshape([self._forward_one(*q, *xy) for q, xy in
                               zip(flat_c.tolist(), p.reshape(-1, 2).tolist())], c.shape)
        p = p.reshape(-1, 2).copy()
        ex = np.broadcast_to([1.0, 0.0], p.shape)
        ey = np.broadcast_to([0.0, 1.0], p.shape)
        phi = None
        for _ in range(NEWTON_STEPS):
            state = None
            if self.gondola is not None:
                state = self.gondola.solve(p[:, 0], p[:, 1], phi)
                phi = state[0]
            q, jx, _ = self._jets(p, ex, state)
            _, jy, _ = self._jets(p, ey, state)
            f = q - flat_c
            dx, dy = _newton_step(f[:, 0], f[:, 1], jx[:, 0], jx[:, 1], jy[:, 0], jy[:, 1])
            p[:, 0] -= dx
            p[:, 1] -= dy
            if not np.abs(np.concatenate((dx, dy))).max(initial=0.0) > TOL_MM:
                break
        return p.reshape(c.shape)

    def _forward_one(self, ql: float, qr: float, x: float, y: float) -> tuple:
        """forward() of one point with the tilting gondola in Python floats, from (x, y)."""
        g, phi = self.gondola, 0.0
        for _ in range(NEWTON_STEPS):
            st = g.state_one(x, y, phi)
            phi = st[0]
            (lx, kxl, _), (rx, kxr, _) = cord_jets(g.jets_at(x, y, 1.0, 0.0, st)[0], self.stretch)
            (_, kyl, _), (_, kyr, _) = cord_jets(g.jets_at(x, y, 0.0, 1.0, st)[0], self.stretch)
            dx, dy = _newton_step(lx - ql, rx - qr, kxl, kxr, kyl, kyr)
            x, y = x - dx, y - dy
            if not max(abs(dx), abs(dy)) > TOL_MM:
                break
        return float(x), float(y)

    def _rel(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2 motors, 2) vectors from each (shifted) anchor to the points (the anchor
        shifted as the tilted gondola holds the cords there)."""
        xy = np.asarray(xy, dtype=float)
        if self.gondola is not None:
            r, _ = self.gondola.cords(xy[:, 0], xy[:, 1])
            return -np.stack((np.stack(r[:2], axis=-1), np.stack(r[2:], axis=-1)), axis=1)
        return xy[:, None, :] - self.anchors[None, :, :]

    # ------------------------------------------------------------------ stretch
    def _jets(self, xy: np.ndarray, e: np.ndarray, state=None):
        """Motor coordinates (N, 2) at xy with their first and second derivatives along the
        unit direction e, by Taylor arithmetic: every quantity is (value, d/ds, d2/ds2).
        `state`: the tilted gondola's balance at xy (Gondola.solve), when known."""
        xy = np.asarray(xy, dtype=float)
        e = np.asarray(e, dtype=float)
        if self.sag is not None:
            return self.sag.jets(xy, e)
        if self.gondola is not None:
            ql, qr = tilt_kept.jets(self, xy, e, state)
            return tuple(np.stack((a, b)).T for a, b in zip(ql, qr))     # (rows of motors)
        zero = np.zeros(len(xy))
        xl = (xy[:, 0] - self.anchors[0, 0], e[:, 0], zero)
        yl = (xy[:, 1] - self.anchors[0, 1], e[:, 1], zero)
        xr = (xy[:, 0] - self.anchors[1, 0], e[:, 0], zero)
        yr = yl
        gl = _sqrt(_add(_mul(xl, xl), _mul(yl, yl)))
        gr = _sqrt(_add(_mul(xr, xr), _mul(yr, yr)))
        cross = _sub(_mul(xl, yr), _mul(yl, xr))
        k = self.stretch
        # q = g / (1 + k t) = g C / (C + k t C), t_left C = -x_R g_L, t_right C = x_L g_R
        ql = _div(_mul(gl, cross), _sub(cross, _scale(_mul(xr, gl), k)))
        qr = _div(_mul(gr, cross), _add(cross, _scale(_mul(xl, gr), k)))
        return tuple(np.stack((a, b), axis=-1) for a, b in zip(ql, qr))

    def tension(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) cord tensions in units of the gondola's weight."""
        if self.sag is not None:
            return self.sag.tension(xy)
        if self.gondola is not None:
            xy = np.asarray(xy, dtype=float)
            return tensions(self.gondola.cords(xy[:, 0], xy[:, 1])[0])
        rel = self._rel(xy)
        g = np.linalg.norm(rel, axis=2)
        cross = rel[:, 0, 0] * rel[:, 1, 1] - rel[:, 0, 1] * rel[:, 1, 0]
        return np.stack((-rel[:, 1, 0] * g[:, 0], rel[:, 0, 0] * g[:, 1]), axis=-1) / cross[:, None]

    # ------------------------------------------------------------------ along a line
    def _along(self, xy: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 2) slopes and cord lengths (no stretch), component by component: what
        einsum("nmk,nk->nm", rel, e) and norm(rel, axis=2) give, several times faster."""
        xy = np.asarray(xy, dtype=float)
        e = np.asarray(e, dtype=float)
        a = self.anchors
        ks, gs = [], []
        for m in (0, 1):       # motor by motor: (N, 2) against (2,) is numpy's slow loop
            x = xy[:, 0] - a[m, 0]
            y = xy[:, 1] - a[m, 1]
            g = np.sqrt(x * x + y * y)
            ks.append((x * e[:, 0] + y * e[:, 1]) / g)
            gs.append(g)
        return np.stack(ks, axis=-1), np.stack(gs, axis=-1)

    def slope(self, xy: np.ndarray, e: np.ndarray) -> np.ndarray:
        if self.gondola is not None and self.sag is None:
            xy = np.asarray(xy, dtype=float)
            e = np.asarray(e, dtype=float)
            known = tilt_kept.known_slopes(self, xy, e)
            if known is not None:
                return known
            return tilt_kept.slopes(self, xy, e, tilt_kept.balance(self, xy))
        if not self.plain:
            return self._jets(xy, e)[1]
        return self._along(xy, e)[0]

    def bend(self, xy: np.ndarray, e: np.ndarray) -> np.ndarray:
        if not self.plain:
            return self._jets(xy, e)[2]
        k, g = self._along(xy, e)
        return (1.0 - k * k) / g

    def slope_bend(self, xy: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """slope(xy, e) and bend(xy, e) at once."""
        if not self.plain:
            _, k, b = self._jets(xy, e)
            return k, b
        k, g = self._along(xy, e)
        return k, (1.0 - k * k) / g

    def ends(self, verts: np.ndarray, e: np.ndarray) -> tuple | None:
        """(slopes, bends) at the pieces' starts, then at their ends (each (M, N)) of the
        pieces through verts along e, where the tilting gondola without stretch works out each
        vertex's share once for its two pieces (tilt_kept.ends); None otherwise (the planner
        asks slope_bend at both ends)."""
        if self.gondola is not None and self.sag is None and self.stretch == 0.0:
            return tilt_kept.ends(self, verts, e)
        return None

    def bend_inside(self, mid, e, d, k0, k1, b0, b1) -> np.ndarray:
        """(M, N) the bend at the middles `mid` of pieces of length d along e, whose slopes and
        bends at their ends are k0, k1, b0, b1 (M, N). The tilting gondola's pieces up to
        MID_SHARE of the shorter cord take the middle of the slope's cubic through their ends
        (within 1e-4 of the largest bend at the ends and the middle, on walls from 300 to
        1000 mm: its balance is not solved again); longer ones solve it."""
        if self.gondola is None or self.sag is not None:
            return self.bend(mid, e).T
        out = 1.5 * (k1 - k0) / np.maximum(d, 1e-300) - 0.25 * (b0 + b1)
        a = self.anchors
        x, y = mid[:, 0], mid[:, 1]
        near = np.minimum((x - a[0, 0]) ** 2 + (y - a[0, 1]) ** 2,
                          (x - a[1, 0]) ** 2 + (y - a[1, 1]) ** 2)          # (squared)
        long = np.flatnonzero(d * d > MID_SHARE * MID_SHARE * near)
        if len(long) > FEW:
            out[:, long] = self.bend(mid[long], e[long]).T
        elif len(long):            # a few: in Python floats (numpy's overhead is most)
            out[:, long] = np.array([tilt_kept.bend_one(self, *p, *u) for p, u in
                                     zip(mid[long].tolist(), e[long].tolist())]).T
        return out

    def carry(self, old: np.ndarray, new: np.ndarray, piece: np.ndarray,
              end: np.ndarray) -> None:
        """The planner put points in on the pieces through old (refine.put_in): the tilting
        gondola keeps its balance at new, from old's (tilt_kept.carry)."""
        if self.gondola is not None and self.sag is None:
            tilt_kept.carry(self, old, new, piece, end)

    def extrema(self, p0: np.ndarray, e: np.ndarray, d: np.ndarray) -> np.ndarray:
        # the cord is shortest where the pen passes the foot of the perpendicular from the anchor
        if not self.plain:
            s = self._slope_zero(p0, e, d)
        else:
            p0 = np.asarray(p0, dtype=float)
            a = self.anchors
            s = np.stack([-((p0[:, 0] - a[m, 0]) * e[:, 0] + (p0[:, 1] - a[m, 1]) * e[:, 1])
                          for m in (0, 1)], axis=-1)           # (motor by motor: see _along)
        inside = (s > 1e-9) & (s < d[:, None] - 1e-9)
        return np.where(inside, s, np.nan)

    def _slope_zero(self, p0, e, d) -> np.ndarray:
        """Where the slope changes sign inside the piece (NaN where it does not): bracketed
        Newton on the slope, the bend being its derivative."""
        n = len(p0)
        out = np.full((n, 2), np.nan)
        tilt = self.gondola is not None and self.sag is None
        if tilt:
            k0, k1, search = tilt_kept.end_slopes(self, p0, e, d)
        else:
            k0 = self.slope(p0, e)
            ends = p0 + e * d[:, None]
            if self.gondola is not None and n > 1:
                # pieces that follow one another: the next start (the balance solved already;
                # the slope differs by the bend times a rounding error)
                same = tilt_kept.following(p0, ends)[:-1]
                ends[:-1] = np.where(same[:, None], p0[1:], ends[:-1])
            k1 = self.slope(ends, e)
        # the rows of both motors at once with the tilting gondola (each iterate solves the
        # balance for both cords); one motor at a time otherwise
        turn = k0 * k1 < 0
        groups = ([turn] if self.gondola is not None
                  else [turn & [True, False], turn & [False, True]])
        for group in groups:
            at = np.flatnonzero(group)                      # (np.nonzero: slower)
            if not len(at):
                continue
            rows, m = at >> 1, at & 1
            sign = np.where(k1[rows, m] > 0, 1.0, -1.0)      # sign * slope rises through zero
            if tilt:
                f = search(rows, m, sign)
            else:
                at = np.arange(len(rows))

                def f(s, rows=rows, m=m, sign=sign, at=at):
                    _, k, b = self._jets(p0[rows] + e[rows] * s[:, None], e[rows])
                    return sign * k[at, m], sign * b[at, m]

            s0 = None
            if self.gondola is not None:
                # first guess: where a straight cord turns that has the slopes at the piece's
                # ends (a straight cord's slope is u / sqrt(h^2 + u^2) at u from the foot of
                # the perpendicular: tan = u / h is linear in u)
                t0, t1 = (k / np.sqrt(np.maximum(1.0 - k * k, 1e-12))
                          for k in (k0[rows, m], k1[rows, m]))
                s0 = np.minimum(np.maximum(d[rows] * t0 / (t0 - t1), 0.0), d[rows])
            one = getattr(f, "one", None)
            if one is not None:                 # (the tilting gondola's few rows, one by one)
                out[rows, m] = [_bracketed_one(fi, 0.0, di, TURN_MM, si) for fi, di, si in
                                zip(one, d[rows].tolist(), s0.tolist())]
            else:
                out[rows, m] = _bracketed(f, np.zeros(len(rows)), d[rows].astype(float),
                                          TURN_MM if tilt else TOL_MM, s0)
        return out

    def crossing(self, p0: np.ndarray, e: np.ndarray, motor: int, piece: np.ndarray,
                 q: np.ndarray, rising: np.ndarray, spacing: float | None = None) -> np.ndarray:
        """Distance s along p0[piece] + s e[piece] at which motor coordinate `motor` reaches q.
        Each piece starts on the near side of its steps' q and the motor runs one way on it;
        spacing: see kinematics/__init__.py."""
        if self.sag is not None:
            return sag_crossing(self, p0, e, motor, piece, q, rising, _bracketed, TOL_MM)
        if self.gondola is not None and FAST_TILT:
            return tilt_steps.crossing(self, p0, e, motor, piece, q, rising, self._exact_crossing,
                                       spacing)
        return self._exact_crossing(p0, e, motor, piece, q, rising)

    def _exact_crossing(self, p0, e, motor, piece, q, rising) -> np.ndarray:
        """crossing() by bracketed Newton steps on the exact cords (stretch, tilt)."""
        if self.gondola is not None:          # the steps it gets are few: solve per step
            p0, e, piece = p0[piece], e[piece], np.arange(len(piece))
        rel = p0 - self.anchors[motor] if self.gondola is None else self._rel(p0)[:, motor]
        b = rel[:, 0] * e[:, 0] + rel[:, 1] * e[:, 1]           # per piece
        c = b * b - (rel[:, 0] ** 2 + rel[:, 1] ** 2)
        b, c = b[piece], c[piece]                                # per step
        if self.plain:
            root = np.sqrt(np.maximum(c + q * q, 0.0))
            return np.where(rising, root - b, -b - root)
        # stretch: first guess where the cord, stretched as at the piece start, reaches q ...
        g = q * (1.0 + self.stretch * self.tension(p0)[:, motor])[piece]
        root = np.sqrt(np.maximum(c + g * g, 0.0))
        s = np.where(rising, root - b, -b - root)
        # ... then Newton on sign * (q(s) - target), which rises through zero on the piece from
        # its start (bracketed: where it stops rising, the piece has ended before)
        start, dirn = p0[piece], e[piece]
        sign = np.where(rising, 1.0, -1.0)

        def f(s_):
            v, k, _ = self._jets(start + dirn * s_[:, None], dirn)
            return sign * (v[:, motor] - q), sign * k[:, motor]

        return _bracketed(f, np.zeros(len(q)), None, TOL_MM, np.maximum(s, 0.0))


def _newton_step(f0, f1, x0, x1, y0, y1) -> tuple:
    """forward()'s Newton step (dx, dy) for the two motors' residuals f0, f1, the Jacobian's
    columns their slopes along x (x0, x1) and along y (y0, y1): arrays, or Python floats."""
    det = x0 * y1 - y0 * x1
    return (f0 * y1 - y0 * f1) / det, (x0 * f1 - f0 * x1) / det


def _bracketed_one(f, lo: float, hi: float, tol: float, s: float) -> float:
    """_bracketed for one row in Python floats, f(s) -> (value, derivative), hi known."""
    for _ in range(NEWTON_STEPS):
        v, k = f(s)
        if v >= 0 or k < -1e-9:
            hi = s
        else:
            lo = s
        nxt = s - v / k if k > 0 else math.nan
        if not lo < nxt < hi:
            nxt = (lo + hi) / 2.0
        if v == 0:
            nxt = s
        step, s = abs(nxt - s), nxt
        if not step > tol:
            break
    return s


def _bracketed(f, lo, hi, tol, s=None):
    """First root of f after lo, where f rises through zero (f(lo) <= 0), by Newton steps kept
    inside the bracket [lo, hi]; hi None: unknown yet. A point where f is >= 0, or where it
    falls (past the stretch where it rises), becomes hi. f returns the value and the
    derivative. Vectorised; stops when every step is below tol."""
    lo = lo.copy()
    hi = np.full(len(lo), np.inf) if hi is None else hi.copy()
    s = (lo + np.where(np.isfinite(hi), hi, lo)) / 2.0 if s is None else s.copy()
    for _ in range(NEWTON_STEPS):
        v, k = f(s)
        beyond = (v >= 0) | (k < -1e-9)
        lo = np.where(beyond, lo, s)
        hi = np.where(beyond, s, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            nxt = s - v / k
        mid = np.where(np.isfinite(hi), (lo + hi) / 2.0, lo + 2.0 * (s - lo) + 1.0)
        bad = ~((nxt > lo) & (nxt < hi)) | ~(k > 0)
        nxt = np.where(bad, mid, nxt)
        nxt = np.where(v == 0, s, nxt)
        step = np.abs(nxt - s)
        s = nxt
        if not step.max(initial=0.0) > tol:
            break
    return s
