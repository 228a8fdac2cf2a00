"""The polar plotter: a rotary table turns the paper, a linear arm moves the pen along a line.

Machine frame: the G-code frame moved so that the table's axis is the origin (+x, +y as in
G-code, mm). Motor coordinates are the table angle a in degrees (counter-clockwise seen from
above) and the pen's radius r in mm along the arm. With the table turned by a, the paper point
at polar angle p (degrees, about the centre) and distance rho lies under the pen when
a = arm_angle_deg - p and r = rho; if the arm can pass over the centre (radius_min_mm < 0) the
same point is also under the pen at a + 180 with r = -rho.

The angle is not periodic here: the motor counts turns. `path` unwraps it along a polyline,
starting from the motor angle where the pen is, always the shorter rotation between
neighbouring vertices (a straight piece not through the centre subtends less than 180 degrees,
so this is the table's true continuous angle). At the centre (the pole) the angle is undefined:
a vertex there may need the table to turn in place before the pen leaves (a line through the
centre: half a turn), which `path` reports as a different angle before and after the vertex.
"""

from __future__ import annotations

import math

import numpy as np

from vplotter.errors import MachineError

POLE_MM = 1e-4            # closer to the centre than this, a vertex is at the pole
START_POLE_MM = 0.01      # the pen starting this close to the centre turns there first
DEG = 180.0 / math.pi
# Pieces are cut at the foot of the perpendicular from the centre (the radius turns round
# there, the angle moves fastest), at foot +- h / sqrt(3) (where the angle's second derivative
# peaks) and at foot +- h * 2^k: so on every piece each motor's speed and acceleration per mm
# of path are largest at one of its ends, and a piece far from the pole is not slowed down by
# how fast the angle turns near it.
_CUTS = np.concatenate(([1.0 / math.sqrt(3.0)], 2.0 ** np.arange(0, 24)))


def _wrap(d: np.ndarray) -> np.ndarray:
    """Angles in degrees wrapped to (-180, 180]."""
    return 180.0 - np.mod(180.0 - d, 360.0)


class Polar:
    motors = ("rotary", "linear")

    def __init__(self, centre_x_mm: float, centre_y_mm: float, arm_angle_deg: float,
                 radius_min_mm: float, radius_max_mm: float):
        self.centre = np.array([centre_x_mm, centre_y_mm], dtype=float)
        self.arm_deg = float(arm_angle_deg)
        self.r_min = float(radius_min_mm)
        self.r_max = float(radius_max_mm)

    def to_machine(self, xy_gcode: np.ndarray) -> np.ndarray:
        return np.asarray(xy_gcode, dtype=float) - self.centre

    def to_gcode(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(xy, dtype=float) + self.centre

    def _raw(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = np.asarray(xy, dtype=float)
        angle = self.arm_deg - np.degrees(np.arctan2(m[..., 1], m[..., 0]))
        return angle, np.hypot(m[..., 0], m[..., 1])

    def inverse(self, xy: np.ndarray, ref=None) -> np.ndarray:
        """Motor coordinates of the points, the angle unwrapped from one point to the next,
        starting nearest to ref's angle (ref: motor coordinates before the first point; None:
        the first angle in (-180, 180], and 0 at the centre, where any angle puts the pen over
        it). Positive radius (see `path` for turns at the centre)."""
        raw, rho = self._raw(xy)
        raw = np.where(rho < POLE_MM, 0.0 if ref is None else float(ref[0]), raw)
        flat = raw.reshape(-1)
        a0 = 0.0 if ref is None else float(ref[0])
        ang = a0 + np.cumsum(_wrap(np.diff(np.concatenate(([a0], flat)))))
        return np.stack((ang.reshape(raw.shape), rho), axis=-1)

    def path(self, verts: np.ndarray, q0) -> tuple[np.ndarray, np.ndarray]:
        """Motor coordinates along a polyline that starts with the motors at q0: (before, after)
        each vertex; they differ only at the pole, where the table turns in place (the shorter
        way; half a turn on a line through the centre) unless the arm can pass over the centre
        (radius_min_mm < 0), which flips the radius's sign instead when that turns less."""
        v = np.asarray(verts, dtype=float)
        raw, rho = self._raw(v)
        n = len(v)
        q_in = np.empty((n, 2))
        q_out = np.empty((n, 2))
        a_prev = float(q0[0])
        sign = -1.0 if q0[1] < 0 and self.r_min < 0 else 1.0
        pole = rho < POLE_MM
        # the motors start where they are: within a few steps of the centre that is the pole
        pole[0] |= min(rho[0], abs(float(q0[1]))) < START_POLE_MM
        start = 0
        for j in [*np.flatnonzero(pole).tolist(), n]:
            if j > start:
                seg = raw[start:j] + (180.0 if sign < 0 else 0.0)
                ang = a_prev + np.cumsum(_wrap(np.diff(np.concatenate(([a_prev], seg)))))
                q_in[start:j, 0] = q_out[start:j, 0] = ang
                q_in[start:j, 1] = q_out[start:j, 1] = sign * rho[start:j]
                a_prev = float(ang[-1])
            if j == n:
                break
            turn = 0.0
            if j + 1 < n and not pole[j + 1]:           # leaving the pole towards vertex j+1
                turn = float(_wrap(raw[j + 1] - a_prev))
                sign = 1.0
                over = float(_wrap(raw[j + 1] + 180.0 - a_prev))
                if self.r_min < 0 and rho[j + 1] <= -self.r_min + 1e-9 and abs(over) < abs(turn):
                    turn, sign = over, -1.0
            r0 = float(q0[1]) if j == 0 else 0.0        # where the motors stand, at the start
            q_in[j] = (a_prev, r0)
            q_out[j] = (a_prev + turn, r0)
            a_prev += turn
            start = j + 1
        short = q_out[:, 1] < self.r_min - 1e-6
        short[0] = False                      # where the motors are (a step off the centre)
        if short.any():
            i = int(np.flatnonzero(short)[0])
            raise MachineError(f"error: the arm passed over the centre and cannot reach radius "
                               f"{rho[i]:.3f} mm on the far side (radius_min_mm = {self.r_min:g}); "
                               f"lift the pen between such strokes")
        return q_in, q_out

    def forward(self, q: np.ndarray) -> np.ndarray:
        c = np.asarray(q, dtype=float)
        p = np.radians(self.arm_deg - c[..., 0])
        return np.stack((c[..., 1] * np.cos(p), c[..., 1] * np.sin(p)), axis=-1)

    @staticmethod
    def _hs(xy: np.ndarray, e: np.ndarray):
        """Signed distance of the line from the centre (h), position along it from the foot
        of the perpendicular (s), and the radius (kept off zero)."""
        m = np.asarray(xy, dtype=float)
        h = m[:, 0] * e[:, 1] - m[:, 1] * e[:, 0]
        s = np.einsum("nk,nk->n", m, e)
        rho = np.maximum(np.hypot(m[:, 0], m[:, 1]), POLE_MM)
        return h, s, rho

    def slope(self, xy: np.ndarray, e: np.ndarray) -> np.ndarray:
        h, s, rho = self._hs(xy, e)
        # paper angle theta grows by h / rho^2 per mm; the table angle is arm - theta
        return np.stack((-DEG * h / (rho * rho), s / rho), axis=-1)

    def bend(self, xy: np.ndarray, e: np.ndarray) -> np.ndarray:
        h, s, rho = self._hs(xy, e)
        r2 = rho * rho
        return np.stack((DEG * 2.0 * h * s / (r2 * r2), h * h / (r2 * rho)), axis=-1)

    def extrema(self, p0: np.ndarray, e: np.ndarray, d: np.ndarray) -> np.ndarray:
        h, s0, _ = self._hs(p0, e)
        foot = -s0                                      # path distance of the foot
        off = np.abs(h)[:, None] * _CUTS[None, :]
        s = np.concatenate((foot[:, None], foot[:, None] - off, foot[:, None] + off), axis=1)
        inside = (s > 1e-9) & (s < d[:, None] - 1e-9)
        return np.where(inside, s, np.nan)

    def crossing(self, p0: np.ndarray, e: np.ndarray, motor: int, piece: np.ndarray,
                 q: np.ndarray, rising: np.ndarray, spacing: float | None = None) -> np.ndarray:
        """Distance s along p0[piece] + s e[piece] at which motor `motor` reaches q: the angle
        where the line meets the line through the centre at paper angle arm - q, the radius
        where the pen is |q| from the centre (the radius's sign is q's)."""
        p0 = np.asarray(p0, dtype=float)
        if motor == 0:
            p = np.radians(self.arm_deg - q)
            ux, uy = np.cos(p), np.sin(p)
            x, y, ex, ey = p0[piece, 0], p0[piece, 1], e[piece, 0], e[piece, 1]
            cross_eu = ex * uy - ey * ux
            safe = np.where(np.abs(cross_eu) > 1e-15, cross_eu, 1e-15)
            return -(x * uy - y * ux) / safe
        b = p0[:, 0] * e[:, 0] + p0[:, 1] * e[:, 1]                 # per piece
        c = b * b - (p0[:, 0] ** 2 + p0[:, 1] ** 2)
        b, c = b[piece], c[piece]                                    # per step
        root = np.sqrt(np.maximum(c + q * q, 0.0))
        away = rising == (q >= 0)                       # the distance from the centre grows
        return np.where(away, root - b, -b - root)

    def check_move(self, xy: np.ndarray, start: np.ndarray) -> int:
        """Index of the first point the pen cannot reach going from `start` through the points
        in straight lines (beyond radius_max_mm, or, with radius_min_mm > 0, a line that
        passes too close to the centre), or -1 (`cannot_reach` says why)."""
        m = np.asarray(xy, dtype=float)
        rho = np.hypot(m[:, 0], m[:, 1])
        bad = rho > self.r_max + 1e-9
        if self.r_min > 0:
            a = np.vstack((np.asarray(start, dtype=float)[None, :], m[:-1]))
            ab = m - a
            l2 = np.einsum("ij,ij->i", ab, ab)
            t = np.clip(-np.einsum("ij,ij->i", a, ab) / np.where(l2 > 0, l2, 1.0), 0.0, 1.0)
            near = a + ab * t[:, None]
            bad |= np.hypot(near[:, 0], near[:, 1]) < self.r_min - 1e-9
        idx = np.flatnonzero(bad)
        return int(idx[0]) if idx.size else -1

    def cannot_reach(self, x: float, y: float) -> str:
        """The error for G-code point (x, y) that `check_move` found out of reach."""
        return (f"the pen cannot reach X{x:.3f} Y{y:.3f} or the line to it (the arm reaches "
                f"{self.r_min:g}..{self.r_max:g} mm from the table's centre)")
