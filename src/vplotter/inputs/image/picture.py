"""The picture every style reads: wanted ink coverage on a grid, and its size on the wall."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Picture:
    """`darkness[r, c]` is the ink coverage wanted at pixel (row r from the TOP, column c from
    the left), 0 (paper) to 1 (solid ink): 1 - the pixel's luminance in linear light, after
    the tone options. The picture covers 0..width_mm (x, right) by 0..height_mm (y, UP) in
    G-code mm, so row 0 is the top edge at y = height_mm."""

    darkness: np.ndarray        # (H, W) float32 in [0, 1]
    width_mm: float
    height_mm: float
    name: str = "<image>"

    @property
    def mm_per_px(self) -> float:
        return self.width_mm / self.darkness.shape[1]

    def at(self, xy) -> np.ndarray:
        """Darkness at G-code points (N, 2) (bilinear between pixel centres; 0 outside)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        h, w = self.darkness.shape
        col = xy[:, 0] / self.width_mm * w - 0.5
        row = (self.height_mm - xy[:, 1]) / self.height_mm * h - 0.5
        inside = ((xy[:, 0] >= 0) & (xy[:, 0] <= self.width_mm) &
                  (xy[:, 1] >= 0) & (xy[:, 1] <= self.height_mm))
        c0 = np.clip(np.floor(col), 0, w - 1).astype(np.intp)
        r0 = np.clip(np.floor(row), 0, h - 1).astype(np.intp)
        c1, r1 = np.minimum(c0 + 1, w - 1), np.minimum(r0 + 1, h - 1)
        fc, fr = np.clip(col - c0, 0, 1), np.clip(row - r0, 0, 1)
        d = self.darkness
        top = d[r0, c0] * (1 - fc) + d[r0, c1] * fc
        bottom = d[r1, c0] * (1 - fc) + d[r1, c1] * fc
        return np.where(inside, top * (1 - fr) + bottom * fr, 0.0)
