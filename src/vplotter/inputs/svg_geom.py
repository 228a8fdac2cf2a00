"""SVG geometry -> polylines: path data and basic shapes become subpaths of segments in user
units, and a subpath becomes one (K, 2) polyline under an affine map, within a tolerance
measured AFTER the map (in mm), so that it holds under any scale or skew.

Segments (user units, each starts where the previous one ended):
  ("L", x, y)                                   straight line
  ("Q", x1, y1, x, y)                           quadratic Bézier
  ("C", x1, y1, x2, y2, x, y)                   cubic Bézier
  ("A", rx, ry, phi_deg, large, sweep, x, y)    elliptical arc, SVG path parameters

Elliptical arcs are cut in their own coordinates (centre parameterisation, SVG 1.1 F.6) and
only then mapped: the image of an ellipse under an affine map is sampled exactly, skew
included. Béziers are mapped by their control points (affine maps keep Béziers Béziers).
"""

from __future__ import annotations

import math
import re

import numpy as np

from vplotter.inputs.svg_style import sigma_max

Subpath = tuple[tuple[float, float], list[tuple], bool]   # start, segments, closed
_POINT_EXP = re.compile(r"([0-9])\.(?=[eE])")
_BARE_POINT = re.compile(r"([0-9])\.(?![0-9])")
MAX_PIECES = 1_000_000   # per curve: beyond this the input is absurd (a typo in a number)


_PATH_CLASS: list = []


def _raw_arcs_path():
    """svgelements' Path, made once: its arcs become straight placeholders with their own
    parameters kept on the side (its Arc object computes a centre approximately and carries the
    arc-times-matrix shortcut; we need neither, and skipping it is faster)."""
    if not _PATH_CLASS:
        from svgelements import Line, Path

        class RawArcs(Path):
            def __init__(self, d, raw):
                self._raw = raw
                super().__init__(d)

            def arc(self, *args, relative=False, **kwargs):
                for i in range(0, len(args), 6):
                    start, end = self.current_point, args[i + 5]
                    if end in ("z", "Z"):
                        end = self.z_point
                    self._raw[len(self._segments)] = args[i:i + 5]
                    self.append(Line(start, end))
                return self

        _PATH_CLASS.append(RawArcs)
    return _PATH_CLASS[0]


def path_data(d: str) -> list[Subpath]:
    """Path data (the `d` attribute) -> subpaths; svgelements does the syntax. An empty `d`
    gives nothing; a bad one raises ValueError."""
    if not d or not d.strip():
        return []
    from svgelements import Close, CubicBezier, Line, Move, QuadraticBezier

    raw: dict[int, tuple] = {}
    # "1." is a number in SVG path data, svgelements wants a digit after the point
    d = _BARE_POINT.sub(r"\1 ", _POINT_EXP.sub(r"\1", d))
    try:
        path = _raw_arcs_path()(d, raw)
    except (ValueError, TypeError, IndexError, AttributeError):
        raise ValueError("path data is not valid") from None
    out: list[Subpath] = []
    start: tuple[float, float] | None = None
    segs: list[tuple] = []

    def flush(closed: bool) -> None:
        if start is not None:
            out.append((start, segs, closed))

    for i, s in enumerate(path._segments):
        if isinstance(s, Move):
            flush(False)
            start, segs = (float(s.end.x), float(s.end.y)), []
            continue
        if start is None:             # path data must start with M; svgelements allows it
            raise ValueError("path data must start with M")
        if isinstance(s, Close):
            flush(True)
            start, segs = (start[0], start[1]), []   # a command after Z starts there
            continue
        end = (float(s.end.x), float(s.end.y))
        if i in raw:
            rx, ry, phi, large, sweep = raw[i]
            segs.append(("A", abs(float(rx)), abs(float(ry)), float(phi), bool(large),
                         bool(sweep), *end))
        elif isinstance(s, Line):
            segs.append(("L", *end))
        elif isinstance(s, QuadraticBezier):
            segs.append(("Q", float(s.control.x), float(s.control.y), *end))
        elif isinstance(s, CubicBezier):
            segs.append(("C", float(s.control1.x), float(s.control1.y),
                         float(s.control2.x), float(s.control2.y), *end))
        else:
            raise ValueError(f"unknown path segment {type(s).__name__}")
    flush(False)
    return out


def rect(x: float, y: float, w: float, h: float,
         rx: float | None, ry: float | None) -> list[Subpath]:
    if w <= 0 or h <= 0:
        return []
    if rx is None and ry is None:
        rx = ry = 0.0
    elif rx is None:
        rx = ry
    elif ry is None:
        ry = rx
    rx, ry = min(abs(rx), w / 2), min(abs(ry), h / 2)
    if rx <= 0 or ry <= 0:
        return [((x, y), [("L", x + w, y), ("L", x + w, y + h), ("L", x, y + h)], True)]
    a = ("A", rx, ry, 0.0, False, True)
    return [((x + rx, y), [("L", x + w - rx, y), (*a, x + w, y + ry), ("L", x + w, y + h - ry),
                           (*a, x + w - rx, y + h), ("L", x + rx, y + h), (*a, x, y + h - ry),
                           ("L", x, y + ry), (*a, x + rx, y)], True)]


def ellipse(cx: float, cy: float, rx: float, ry: float) -> list[Subpath]:
    """Starts at (cx + rx, cy) and runs in the positive angle direction, as SVG says."""
    if rx <= 0 or ry <= 0:
        return []
    a = ("A", rx, ry, 0.0, False, True)
    return [((cx + rx, cy), [(*a, cx - rx, cy), (*a, cx + rx, cy)], True)]


def poly(values: list[float], closed: bool) -> list[Subpath]:
    pts = list(zip(values[0::2], values[1::2]))
    if not pts:
        return []
    return [(pts[0], [("L", x, y) for x, y in pts[1:]], closed)]


# ------------------------------------------------------------------ flattening
def arc_centre(x0, y0, rx, ry, phi_deg, large, sweep, x1, y1):
    """SVG 1.1 F.6.5: (cx, cy, rx, ry, theta1, dtheta) with radii scaled up if too small.
    None when the arc is a straight line (zero radius) or nothing (end == start)."""
    if x0 == x1 and y0 == y1:
        return None
    rx, ry = abs(rx), abs(ry)
    if rx == 0 or ry == 0:
        return "line"
    phi = math.radians(phi_deg % 360.0)
    cos_p, sin_p = math.cos(phi), math.sin(phi)
    dx2, dy2 = (x0 - x1) / 2, (y0 - y1) / 2
    x1p = cos_p * dx2 + sin_p * dy2
    y1p = -sin_p * dx2 + cos_p * dy2
    lam = (x1p / rx) ** 2 + (y1p / ry) ** 2
    if lam > 1:
        s = math.sqrt(lam)
        rx, ry = rx * s, ry * s
    num = rx * rx * ry * ry - rx * rx * y1p * y1p - ry * ry * x1p * x1p
    den = rx * rx * y1p * y1p + ry * ry * x1p * x1p
    coef = math.sqrt(max(0.0, num / den)) if den > 0 else 0.0
    if large == sweep:
        coef = -coef
    cxp, cyp = coef * rx * y1p / ry, -coef * ry * x1p / rx
    cx = cos_p * cxp - sin_p * cyp + (x0 + x1) / 2
    cy = sin_p * cxp + cos_p * cyp + (y0 + y1) / 2
    ux, uy = (x1p - cxp) / rx, (y1p - cyp) / ry
    vx, vy = (-x1p - cxp) / rx, (-y1p - cyp) / ry
    theta1 = math.atan2(uy, ux)
    dtheta = math.atan2(ux * vy - uy * vx, ux * vx + uy * vy)
    if sweep and dtheta < 0:
        dtheta += 2 * math.pi
    elif not sweep and dtheta > 0:
        dtheta -= 2 * math.pi
    return cx, cy, rx, ry, phi, theta1, dtheta


def _pieces(value: float) -> int:
    if not value < MAX_PIECES:
        raise ValueError("a curve is too large for the tolerance (more than "
                         f"{MAX_PIECES} pieces)")
    return max(1, math.ceil(value))


def _arc_points(p0, seg, lin: np.ndarray, tol: float) -> np.ndarray | None:
    """Points after p0 (user units) of an arc whose image under `lin` stays within tol."""
    _, rx, ry, phi_deg, large, sweep, x1, y1 = seg
    c = arc_centre(p0[0], p0[1], rx, ry, phi_deg, large, sweep, x1, y1)
    if c is None:
        return None
    if c == "line":
        return np.array([[x1, y1]])
    cx, cy, rx, ry, phi, th1, dth = c
    cos_p, sin_p = math.cos(phi), math.sin(phi)
    # ellipse point = centre + A (cos t, sin t), A = R(phi) diag(rx, ry); under lin: lin @ A
    A = np.array([[cos_p * rx, -sin_p * ry], [sin_p * rx, cos_p * ry]])
    sigma = sigma_max(lin @ A)
    # chord of a parameter step h deviates at most sigma (1 - cos(h / 2)) from the image
    if sigma <= tol:
        h = math.pi / 2
    else:
        h = min(math.pi / 2, 2 * math.acos(1 - tol / sigma))
    n = _pieces(abs(dth) / h)
    t = th1 + dth * np.arange(1, n + 1) / n
    pts = np.column_stack((np.cos(t), np.sin(t))) @ A.T + (cx, cy)
    pts[-1] = (x1, y1)
    return pts


def _bezier_points(ctrl: np.ndarray, lin: np.ndarray, tol: float) -> np.ndarray:
    """Points after the start of a quadratic (3 control points) or cubic (4) Bézier, cut at
    equal parameter steps: the chord error is at most h^2/8 max|B''| (after the map)."""
    d2 = ctrl[2:] - 2 * ctrl[1:-1] + ctrl[:-2]                      # second differences
    deg = len(ctrl) - 1
    b2 = deg * (deg - 1) * float(np.max(np.hypot(*(d2 @ lin.T).T)))  # max |B''| (mm)
    n = _pieces(math.sqrt(b2 / (8 * tol))) if b2 > 0 else 1
    t = np.arange(1, n + 1)[:, None] / n
    s = 1 - t
    if deg == 2:
        pts = s * s * ctrl[0] + 2 * s * t * ctrl[1] + t * t * ctrl[2]
    else:
        pts = (s ** 3 * ctrl[0] + 3 * s * s * t * ctrl[1] + 3 * s * t * t * ctrl[2]
               + t ** 3 * ctrl[3])
    pts[-1] = ctrl[-1]
    return pts


def flatten(sub: Subpath, m: np.ndarray, tol: float) -> np.ndarray | None:
    """One subpath -> (K, 2) polyline under the affine map m (3x3), within tol of the true
    mapped curve. Consecutive equal points are merged; a closed subpath ends exactly on its
    first point; a subpath that goes nowhere but has a segment or a Z is one point (a dot);
    a lone moveto is None."""
    start, segs, closed = sub
    if not segs and not closed:
        return None
    lin = m[:2, :2]
    pieces: list = [[start]]
    line_run: list = []
    cur = start
    for seg in segs:
        kind = seg[0]
        end = (seg[-2], seg[-1])
        if kind == "L":
            line_run.append(end)
        else:
            if line_run:
                pieces.append(line_run)
                line_run = []
            if kind == "A":
                pts = _arc_points(cur, seg, lin, tol)
            else:
                pts = _bezier_points(np.array([cur, *zip(seg[1:-1:2], seg[2::2])], dtype=float),
                                     lin, tol)
            if pts is not None:
                pieces.append(pts)
        cur = end
    if line_run:
        pieces.append(line_run)
    if closed:
        pieces.append([start])
    user = np.concatenate([np.asarray(p, dtype=float).reshape(-1, 2) for p in pieces])
    pts = user @ lin.T + m[:2, 2]
    if closed:
        pts[-1] = pts[0]
    if not np.all(np.isfinite(pts)):
        raise ValueError("coordinates are too large")
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.any(pts[1:] != pts[:-1], axis=1)
    return pts[keep]
