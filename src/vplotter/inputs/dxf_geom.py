"""DXF entities -> points: the chords of lines, arcs, circles, ellipses, splines and polylines
(bulges as arcs) within a tolerance, in the entity's own frame (its OCS), and the transforms
(ezdxf matrices, the tolerance in a block's coordinates); what makes an entity broken (Broken);
table look-ups. The walk of the document (blocks, layers, colours, strokes) is `dxf.py`'s."""

from __future__ import annotations

import math

import numpy as np

MAX_POINTS = 10_000_000     # points of all strokes together (160 MB of coordinates)
ZERO = "of zero size"
NOT_FINITE = "with values that are not finite"
UNREADABLE = "that cannot be read"


class Broken(Exception):
    """One entity cannot be drawn (the file can): `reason` is its kind (ZERO, NOT_FINITE,
    UNREADABLE), `detail` what went wrong, for the warning that counts them."""

    def __init__(self, reason: str, detail: str = ""):
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason, self.detail = reason, detail


def finite(*values: float) -> None:
    """Raise Broken unless every value is a finite number."""
    if not all(math.isfinite(v) for v in values):
        raise Broken(NOT_FINITE)


def first_line(e: BaseException) -> str:
    if isinstance(e, (StopIteration, EOFError)):
        return "it ends before its sections do (truncated?)"
    text = str(e).strip().splitlines()
    return (text[0] if text else type(e).__name__)[:200]


def entry(table, name: str):
    """The table entry (LAYER, STYLE) of that name, None when the table lacks it."""
    from ezdxf.lldxf.const import DXFTableEntryError

    try:
        return table.get(name)
    except (DXFTableEntryError, TypeError, AttributeError):
        return None


def m44(m) -> np.ndarray:
    """ezdxf Matrix44 (row vectors) -> numpy 4x4."""
    return np.array([list(m.get_row(i)) for i in range(4)], dtype=float)


def local_tol(tol: float, m: np.ndarray) -> float:
    """The chord tolerance in block coordinates (and in any OCS in them, a rotation): tol over
    the largest stretch of m from there to G-code mm (X and Y): the largest singular value of
    its 3x2 part, from the 2x2 Gram matrix."""
    with np.errstate(all="ignore"):     # a huge scale: no finite stretch, add() refuses it
        a = m[:3, :2] / max(float(np.abs(m[:3, :2]).max()), 1e-300)
        g = a.T @ a
        half = (g[0, 0] + g[1, 1]) / 2
        top = half + math.sqrt(max(((g[0, 0] - g[1, 1]) / 2) ** 2 + g[0, 1] ** 2, 0.0))
        stretch = math.sqrt(max(top, 0.0)) * float(np.abs(m[:3, :2]).max())
    return tol / stretch if 1e-300 < stretch < math.inf else tol


def ocs(entity) -> np.ndarray:
    """The entity's OCS -> WCS as a 4x4 (row vectors), from its extrusion."""
    o = entity.ocs()
    f = np.eye(4)
    f[0, :3], f[1, :3], f[2, :3] = tuple(o.ux), tuple(o.uy), tuple(o.uz)
    return f


def arc(cx: float, cy: float, r: float, a0: float, sweep: float, tol: float,
         multiple: int = 1) -> np.ndarray:
    """(K, 2) points along a circular arc from angle a0 (radians) through `sweep` (signed),
    chords within tol of the arc (their number a multiple of `multiple`); both ends exact."""
    finite(cx, cy, r, a0, sweep)
    if r <= 0:
        return np.array([[cx, cy]])
    step = 2 * math.acos(max(1 - tol / r, -1.0)) if tol < r else math.pi / 2
    n = max(int(math.ceil(abs(sweep) / max(min(step, math.pi / 2), 1e-9))), 1)
    n = -(-n // multiple) * multiple
    if n > MAX_POINTS:
        raise OverflowError
    t = a0 + sweep / n * np.arange(n + 1.0)
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def bulged(xy: np.ndarray, bulge: np.ndarray, closed: bool, tol: float) -> np.ndarray:
    """A polyline's vertices (N, 2) with bulges (the bulge of vertex i bends the segment to
    i + 1: tan(sweep / 4), positive counter-clockwise) -> points along its lines and arcs."""
    n = len(xy)
    if closed and n > 1:
        xy = np.vstack([xy, xy[:1]])
    b = np.zeros(max(len(xy) - 1, 0))
    k = min(len(b), len(bulge))
    b[:k] = bulge[:k]
    chord = np.hypot(*np.diff(xy, axis=0).T)
    out, start = [], 0
    # straight segments are the vertices as they are: only the bulged ones are walked
    for i in np.nonzero(~(np.abs(b) < 1e-12) & (chord != 0.0))[0].tolist():
        p, q, c_len = xy[i], xy[i + 1], float(chord[i])
        sweep = 4 * math.atan(float(b[i]))
        r = c_len / (2 * abs(math.sin(sweep / 2)))
        # the centre: off the chord's middle to the left of p->q by chord / (2 tan(sweep / 2))
        # (to the right for a clockwise arc or one of more than 180 degrees)
        d = (q - p) / c_len
        c = (p + q) / 2 + np.array([-d[1], d[0]]) * c_len / (2 * math.tan(sweep / 2))
        a0 = math.atan2(p[1] - c[1], p[0] - c[0])
        pts = arc(c[0], c[1], r, a0, sweep, tol)
        pts[-1] = q
        out += [xy[start:i + 1], pts[1:]]
        start = i + 2
    out.append(xy[start:])
    return np.concatenate(out)


def curve(e, t: str, tol: float):
    """(frame, polylines, z) of a curve entity, in its own frame (4x4 row vectors to the
    block's coordinates; polylines of 2 columns at height z, or 3), chords within tol; None for
    a polygon or poly-face mesh (not drawn). Raises Broken."""
    d = e.dxf
    frame = np.eye(4)
    z = 0.0
    if t == "LINE":
        polys = [np.array([list(d.start), list(d.end)])]
    elif t in ("CIRCLE", "ARC"):
        frame = ocs(e)
        c = d.center
        z = c[2]
        if t == "CIRCLE":           # a multiple of 4 chords: its extent is exact
            pts = arc(c[0], c[1], d.radius, 0.0, 2 * math.pi, tol, 4)
            pts[-1] = pts[0]
        else:
            a0, a1 = math.radians(d.start_angle), math.radians(d.end_angle)
            sweep = (a1 - a0) % (2 * math.pi) or 2 * math.pi
            pts = arc(c[0], c[1], d.radius, a0, sweep, tol)
        polys = [pts]
    elif t == "ELLIPSE":
        polys = [ellipse(e, tol)]
    elif t == "SPLINE":
        try:
            pts = [tuple(v) for v in e.construction_tool().flattening(tol, segments=4)]
        except (ValueError, ZeroDivisionError, IndexError, ArithmeticError) as ex:
            raise Broken(UNREADABLE, first_line(ex)) from None
        polys = [np.array(pts)] if pts else []
    elif t == "LWPOLYLINE":
        frame = ocs(e)
        z = d.get("elevation", 0.0)
        xyb = np.array(list(e.get_points("xyb")), dtype=float).reshape(-1, 3)
        polys = [bulged(xyb[:, :2], xyb[:, 2], e.closed, tol)]
    else:
        got = polyline(e, tol)
        if got is None:
            return None
        frame, polys = got
    return frame, polys, z


def ellipse(e, tol: float) -> np.ndarray:
    d = e.dxf
    major = np.array(list(d.major_axis), dtype=float)
    minor = np.array(list(e.minor_axis), dtype=float)
    c = np.array(list(d.center), dtype=float)
    a = float(np.linalg.norm(major))
    t0, t1 = d.get("start_param", 0.0), d.get("end_param", 2 * math.pi)
    finite(*major, *minor, *c, t0, t1)
    span = (t1 - t0) % (2 * math.pi)
    full = span < 1e-12 or abs(span - 2 * math.pi) < 1e-12
    span = 2 * math.pi if full else span
    # a chord over a parameter step dt stays within a dt^2 / 8 of the curve (|p''| <= a)
    step = math.sqrt(8 * tol / a) if a > 0 else span
    n = max(int(math.ceil(span / min(step, math.pi / 4))), 1)
    if n > MAX_POINTS:
        raise OverflowError
    t = t0 + span * np.linspace(0.0, 1.0, n + 1)
    pts = c + np.cos(t)[:, None] * major + np.sin(t)[:, None] * minor
    if full:
        pts[-1] = pts[0]
    return pts


def polyline(e, tol: float):
    """(frame, [points]) of a POLYLINE, None for a mesh (not drawn)."""
    if e.is_polygon_mesh or e.is_poly_face_mesh:
        return None
    verts = [v for v in e.vertices if not v.dxf.get("flags", 0) & 16]  # spline frame
    if not verts:
        return np.eye(4), []
    loc = np.array([list(v.dxf.location) for v in verts], dtype=float)
    if e.is_3d_polyline:
        if e.is_closed and len(loc) > 1:
            loc = np.vstack([loc, loc[:1]])
        return np.eye(4), [loc]
    frame = ocs(e)
    bulge = np.array([v.dxf.get("bulge", 0.0) for v in verts], dtype=float)
    pts = bulged(loc[:, :2], bulge, e.is_closed, tol)
    z = float(e.dxf.get("elevation", (0, 0, 0))[2])
    return frame, [np.column_stack([pts, np.full(len(pts), z)])]
