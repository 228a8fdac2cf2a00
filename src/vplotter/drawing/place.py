"""Placement: one affine map from the drawing as read to where it lands on the page.

Pure geometry on strokes in G-code millimetres (+Y up). The map is built in this order:
  1. --scale S and --rotate DEG (counter-clockwise, as seen on the wall) about the centre of
     the drawing's extent;
  2. --width/--height: the uniform scale that makes the extent that wide or high (both: the
     largest inside that box), about its centre; or --fit: the largest uniform scale that puts
     the extent inside the page (less --margin), centred on the page, and on a polar machine
     its corners inside the disc the arm reaches (`Box.reach`);
  3. --align left|center|right, --valign top|middle|bottom: that edge (or centre) of the
     extent on the page's edge (or centre), --margin in from the edge;
  4. --offset X Y, last.
What the page check sees is the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vplotter.errors import ConfigError
from vplotter.inputs.strokes import Stroke


EDGE_MM = 1e-9      # a drawing put on the page's edge stays this far in (rounding never crosses)
REACH_IN_MM = 1e-3  # ... and this far inside a polar arm's reach (a circle: G-code's 4 decimals
                    # could put a corner on it up to 0.00007 mm out)


@dataclass(frozen=True)
class Placement:
    scale: float = 1.0
    rotate_deg: float = 0.0
    fit: bool = False
    margin_mm: float = 0.0
    align: str | None = None      # left | center | right
    valign: str | None = None     # top | middle | bottom
    offset_mm: tuple[float, float] = (0.0, 0.0)
    width_mm: float | None = None
    height_mm: float | None = None

    @property
    def identity(self) -> bool:
        return self == Placement()


@dataclass(frozen=True)
class Box:
    x_min: float
    y_min: float
    x_max: float
    y_max: float
    reach: tuple[float, float, float] | None = None   # (x, y, r): the disc the pen reaches
                                                      # (a polar machine), beside the page

    @property
    def centre(self) -> np.ndarray:
        return np.array([(self.x_min + self.x_max) / 2, (self.y_min + self.y_max) / 2])

    @property
    def size(self) -> np.ndarray:
        return np.array([self.x_max - self.x_min, self.y_max - self.y_min])


def origin(page: Box) -> np.ndarray:
    """Where a drawing without a placement option is centred: G-code X0 Y0, the point
    `calibrate --at 0 0` names and G-code files draw around, for every kind of file (SVG, DXF
    and photos alike); the page's centre if X0 Y0 is off the page."""
    at = np.zeros(2)
    return at if outside(at, page) < 0 else page.centre


def largest(size, page: Box, margin_mm: float, centre=None) -> float:
    """The largest scale of an extent `size` (w, h) centred on `centre` (default: the page's
    centre) that keeps it inside the page less margin_mm and, on a polar machine, its corners
    inside the reach less margin_mm (inf for an extent of no size; 0 or less: no room)."""
    w, h = (float(v) for v in size)
    c = page.centre if centre is None else np.asarray(centre, dtype=float)
    room = 2 * np.minimum(c - np.array([page.x_min, page.y_min]),
                          np.array([page.x_max, page.y_max]) - c) - 2 * margin_mm
    k = min([room[i] / v for i, v in enumerate((w, h)) if v > 1e-12] or [math.inf])
    if page.reach is not None and (w > 1e-12 or h > 1e-12):
        x, y, r = page.reach
        r -= margin_mm + REACH_IN_MM
        dx, dy = abs(c[0] - x), abs(c[1] - y)
        # the far corner (dx + k w / 2, dy + k h / 2) on the circle: a k^2 + b k + c = 0
        qa, qb, qc = (w * w + h * h) / 4, dx * w + dy * h, dx * dx + dy * dy - r * r
        k = min(k, (-qb + math.sqrt(qb * qb - 4 * qa * qc)) / (2 * qa) if qc < 0 else 0.0)
    return k


def outside(pts: np.ndarray, page: Box) -> int:
    """Index of the first point off the page or beyond the reach (a polar machine), or -1."""
    p = np.asarray(pts, dtype=float).reshape(-1, 2)
    bad = ((p[:, 0] < page.x_min - 1e-9) | (p[:, 0] > page.x_max + 1e-9) |
           (p[:, 1] < page.y_min - 1e-9) | (p[:, 1] > page.y_max + 1e-9))
    if page.reach is not None:
        x, y, r = page.reach
        bad |= np.hypot(p[:, 0] - x, p[:, 1] - y) > r + 1e-9
    idx = np.flatnonzero(bad)
    return int(idx[0]) if idx.size else -1


def extent(strokes: list[Stroke]) -> Box | None:
    """The bounding box of every point of the strokes (None when there are none)."""
    if not strokes:
        return None
    lo = np.min([s.pts.min(axis=0) for s in strokes], axis=0)
    hi = np.max([s.pts.max(axis=0) for s in strokes], axis=0)
    return Box(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def _box_of(pts: np.ndarray) -> Box:
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return Box(float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def matrix(p: Placement, pts: np.ndarray, page: Box) -> tuple[np.ndarray, np.ndarray]:
    """(A, b): a point x lands at A @ x + b. `pts` (N, 2): every point of the drawing as
    read (fit and align look at the extent of the transformed points)."""
    if len(pts) == 0:
        return np.eye(2), np.asarray(p.offset_mm, dtype=float)
    box = _box_of(pts)
    a = math.radians(p.rotate_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    A = p.scale * rot
    c = box.centre
    b = c - A @ c
    now = _box_of(pts @ A.T + b)
    if p.width_mm or p.height_mm:
        want = [(p.width_mm, now.size[0]), (p.height_mm, now.size[1])]
        k = [w / s for w, s in want if w and s > 1e-12]
        if not k:
            raise ConfigError("error: --width/--height: the drawing has no extent to scale")
        s = min(k)
        A, b = s * A, s * (b - now.centre) + now.centre
        now = _box_of(pts @ A.T + b)
    room = page.size - 2 * p.margin_mm
    k = largest(now.size, page, p.margin_mm) if p.fit else math.inf
    if (p.fit or p.align or p.valign) and ((room <= 0).any() or not k > 0):
        raise ConfigError(f"error: --margin {p.margin_mm:g} leaves no room on the page "
                          f"({page.size[0]:g} x {page.size[1]:g} mm)")
    if p.fit:
        s = (k if math.isfinite(k) else 1.0) * (1 - 1e-12)   # rounding must not cross the edge
        # scale about the extent's centre, then move that centre to the page's centre
        A, b = s * A, s * (b - now.centre) + page.centre
        now = _box_of(pts @ A.T + b)
    shift = np.zeros(2)
    if p.align:
        shift[0] = {"left": page.x_min + p.margin_mm - now.x_min + EDGE_MM,
                    "center": page.centre[0] - now.centre[0],
                    "right": page.x_max - p.margin_mm - now.x_max - EDGE_MM}[p.align]
    if p.valign:
        shift[1] = {"bottom": page.y_min + p.margin_mm - now.y_min + EDGE_MM,
                    "middle": page.centre[1] - now.centre[1],
                    "top": page.y_max - p.margin_mm - now.y_max - EDGE_MM}[p.valign]
    return A, b + shift + np.asarray(p.offset_mm, dtype=float)


def apply(strokes: list[Stroke], A: np.ndarray, b: np.ndarray) -> list[Stroke]:
    """New strokes with every point mapped (the input is left as it is)."""
    from dataclasses import replace

    return [replace(s, pts=s.pts @ A.T + b) for s in strokes]


def place(strokes: list[Stroke], p: Placement, page: Box) -> list[Stroke]:
    if p.identity:
        return strokes
    pts = np.concatenate([s.pts for s in strokes]) if strokes else np.zeros((0, 2))
    A, b = matrix(p, pts, page)
    return apply(strokes, A, b)
