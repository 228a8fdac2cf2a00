"""The two-cord hanging plotter (V-plotter).

Machine frame: origin at the LEFT anchor (where the cord leaves the left spool), +x right,
+y DOWN; the right anchor is at (anchor_distance_mm, 0). Motor coordinates are the two cord
lengths in mm: left = hypot(x, y), right = hypot(D - x, y).
"""

from __future__ import annotations

import numpy as np


class TwoCord:
    motors = ("left", "right")

    def __init__(self, anchor_distance_mm: float, origin_x_mm: float, origin_y_mm: float):
        self.d_mm = float(anchor_distance_mm)
        self.origin = np.array([origin_x_mm, origin_y_mm], dtype=float)
        self.anchors = np.array([[0.0, 0.0], [self.d_mm, 0.0]])

    def to_machine(self, xy_gcode: np.ndarray) -> np.ndarray:
        g = np.asarray(xy_gcode, dtype=float)
        return np.stack((self.origin[0] + g[..., 0], self.origin[1] - g[..., 1]), axis=-1)

    def to_gcode(self, xy: np.ndarray) -> np.ndarray:
        m = np.asarray(xy, dtype=float)
        return np.stack((m[..., 0] - self.origin[0], self.origin[1] - m[..., 1]), axis=-1)

    def inverse(self, xy: np.ndarray) -> np.ndarray:
        m = np.asarray(xy, dtype=float)
        return np.stack((np.hypot(m[..., 0], m[..., 1]),
                         np.hypot(self.d_mm - m[..., 0], m[..., 1])), axis=-1)

    def forward(self, cords: np.ndarray) -> np.ndarray:
        c = np.asarray(cords, dtype=float)
        left, right = c[..., 0], c[..., 1]
        x = (self.d_mm ** 2 + left ** 2 - right ** 2) / (2.0 * self.d_mm)
        y = np.sqrt(np.maximum(left ** 2 - x ** 2, 0.0))
        return np.stack((x, y), axis=-1)

    def _rel(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2 motors, 2) vectors from each anchor to the points."""
        return np.asarray(xy, dtype=float)[:, None, :] - self.anchors[None, :, :]

    def slope(self, xy: np.ndarray, e: np.ndarray) -> np.ndarray:
        rel = self._rel(xy)
        return np.einsum("nmk,nk->nm", rel, e) / np.linalg.norm(rel, axis=2)

    def bend(self, xy: np.ndarray, e: np.ndarray) -> np.ndarray:
        k = self.slope(xy, e)
        return (1.0 - k * k) / np.linalg.norm(self._rel(xy), axis=2)

    def extrema(self, p0: np.ndarray, e: np.ndarray, d: np.ndarray) -> np.ndarray:
        # the cord is shortest where the pen passes the foot of the perpendicular from the anchor
        s = -np.einsum("nmk,nk->nm", self._rel(p0), e)
        inside = (s > 1e-9) & (s < d[:, None] - 1e-9)
        return np.where(inside, s, np.nan)

    def crossing(self, p0: np.ndarray, e: np.ndarray, motor: int, piece: np.ndarray,
                 q: np.ndarray, rising: np.ndarray) -> np.ndarray:
        """Distance s along p0[piece] + s e[piece] at which cord `motor` has length q."""
        rel = p0 - self.anchors[motor]
        b = rel[:, 0] * e[:, 0] + rel[:, 1] * e[:, 1]           # per piece
        c = b * b - (rel[:, 0] ** 2 + rel[:, 1] ** 2)
        b, c = b[piece], c[piece]                                # per step
        root = np.sqrt(np.maximum(c + q * q, 0.0))
        return np.where(rising, root - b, -b - root)
