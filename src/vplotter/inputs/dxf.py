"""DXF file -> Drawing: the model space's lines, curves and text as strokes in G-code mm.

Read with ezdxf (imported here only). The rules (docs/drawing-files.md, section "DXF"):

- drawn: LINE, LWPOLYLINE and 2D/3D POLYLINE (bulges as arcs), ARC, CIRCLE, ELLIPSE, SPLINE,
  INSERT (block references with their scale, rotation, extrusion and MINSERT grid, nested),
  TEXT, ATTRIB and MTEXT (single-stroke Hershey fonts, `dxf_text.py`); each polyline, arc or
  curve is one stroke, a 3D one as seen from above (its X and Y);
- curves are cut into chords within the pipeline's tolerance of the true curve *after* the
  block and unit transforms (the tolerance in the entity's own frame is divided by the largest
  stretch of those transforms);
- layers are pens: `Stroke.layer` and `Stroke.pen` are the layer's name, `Stroke.colour` the
  entity's colour (true colour or ACI; BYLAYER, BYBLOCK and layer "0" inside blocks resolved
  as CAD programs do; ACI 7, white on a dark screen, is black on paper);
- skipped: entities on frozen, off or not-plotted layers and on "Defpoints" (counted as
  hidden), invisible entities, ATTDEFs (block templates), paper space, and every other entity
  type (HATCH, DIMENSION, IMAGE, 3DFACE, POINT, ...), counted per type in one warning;
- $INSUNITS scales to mm (unitless: mm); the drawing's extent is centred on X0 Y0, +Y up.

Refused with one line (InputError): what ezdxf cannot read (not a DXF file, a corrupt or
truncated one, text or binary junk), a block that inserts itself (directly or through other
blocks), and a drawing whose blocks expand to more than MAX_ENTITIES entities.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from vplotter.errors import InputError
from vplotter.inputs.strokes import Drawing, Stroke

MAX_ENTITIES = 500_000      # entities drawn once blocks are expanded (MINSERT grids included)
MAX_POINTS = 10_000_000     # points of all strokes together (160 MB of coordinates)
MAX_DEPTH = 100             # blocks nested in blocks
HIDDEN_LAYERS = {"defpoints"}   # CAD programs never plot this layer
CURVES = {"LINE", "LWPOLYLINE", "POLYLINE", "ARC", "CIRCLE", "ELLIPSE", "SPLINE"}
TEXTS = {"TEXT", "ATTRIB", "MTEXT"}
QUIET = {"ATTDEF", "SEQEND", "VERTEX"}   # parts or templates: not drawn, not counted
Warn = Callable[[str], None]


def _stderr(msg: str) -> None:
    import sys

    print(msg, file=sys.stderr)


@dataclass(frozen=True)
class _Ctx:
    """Where an entity stands: its block's transform and what BYBLOCK/layer 0 resolve to."""

    m: np.ndarray                  # 4x4, row vectors: block coordinates -> mm (WCS x units)
    tol: float                     # the chord tolerance in block coordinates (see _local_tol)
    layer: str | None = None       # the INSERT's layer (layer "0" entities inside take it)
    colour: str = "#000000"        # the INSERT's colour (BYBLOCK entities inside take it)
    top: int = 0                   # number of the model-space entity this comes from
    src: str = ""                  # handles of the INSERTs this comes through


def read(path: str, tol_mm: float, layers: list[str] | None = None,
         warn: Warn = _stderr, centre: bool = True) -> Drawing:
    """Read a DXF file's model space into a Drawing in G-code mm, its extent centred on X0 Y0
    (+Y up; centre=False: where the file puts it, in mm). Curves stay within tol_mm of the true
    curve. `layers`: draw only these layers. Raises InputError."""
    if not tol_mm > 0:
        raise ValueError("tol_mm must be above 0")
    doc = _open(path)
    return _Reader(path, doc, tol_mm, layers, warn).read(centre)


def _open(path: str):
    import os

    try:
        import ezdxf
        from ezdxf.lldxf.const import DXFError
    except ImportError:     # pragma: no cover - a dependency; the message says what to do
        raise InputError(f"{path}: error: reading DXF needs the ezdxf package "
                         f"(pip install ezdxf)") from None
    if os.path.isdir(path):
        raise InputError(f"{path}: error: is a directory, not a DXF file")
    try:
        size = os.path.getsize(path)
    except OSError as e:
        raise InputError(f"{path}: error: cannot read: {e.strerror}") from None
    if size == 0:
        raise InputError(f"{path}: error: the file is empty, not a DXF file")
    try:
        return ezdxf.readfile(path)
    except DXFError as e:
        raise InputError(f"{path}: error: not a valid DXF file: {_first_line(e)}") from None
    except (OSError, UnicodeError) as e:
        what = e.strerror if isinstance(e, OSError) and e.strerror else _first_line(e)
        if "not a DXF file" in str(e):
            what = "not a DXF file (no DXF section structure at its start)"
        raise InputError(f"{path}: error: {what}") from None
    except MemoryError:
        raise InputError(f"{path}: error: too large to read into memory") from None
    except Exception as e:      # noqa: BLE001 - ezdxf on truncated or garbled input raises
        # whatever its parsing met (IndexError, struct.error, ValueError, ...): one line
        raise InputError(f"{path}: error: not a valid DXF file: {_first_line(e)}") from None


def _first_line(e: BaseException) -> str:
    if isinstance(e, (StopIteration, EOFError)):
        return "it ends before its sections do (truncated?)"
    text = str(e).strip().splitlines()
    return (text[0] if text else type(e).__name__)[:200]


def _aci(aci: int) -> str:
    """ACI colour -> '#rrggbb'; 7 (white on a dark screen, black on light) is black on paper."""
    from ezdxf import colors

    return "#000000" if aci == 7 else "#%02x%02x%02x" % tuple(colors.aci2rgb(aci))


def _m44(m) -> np.ndarray:
    """ezdxf Matrix44 (row vectors) -> numpy 4x4."""
    return np.array([list(m.get_row(i)) for i in range(4)], dtype=float)


def _local_tol(tol: float, m: np.ndarray) -> float:
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


def _ocs(entity) -> np.ndarray:
    """The entity's OCS -> WCS as a 4x4 (row vectors), from its extrusion."""
    o = entity.ocs()
    f = np.eye(4)
    f[0, :3], f[1, :3], f[2, :3] = tuple(o.ux), tuple(o.uy), tuple(o.uz)
    return f


def _arc(cx: float, cy: float, r: float, a0: float, sweep: float, tol: float,
         multiple: int = 1) -> np.ndarray:
    """(K, 2) points along a circular arc from angle a0 (radians) through `sweep` (signed),
    chords within tol of the arc (their number a multiple of `multiple`); both ends exact."""
    if r <= 0:
        return np.array([[cx, cy]])
    step = 2 * math.acos(max(1 - tol / r, -1.0)) if tol < r else math.pi / 2
    n = max(int(math.ceil(abs(sweep) / max(min(step, math.pi / 2), 1e-9))), 1)
    n = -(-n // multiple) * multiple
    if n > MAX_POINTS:
        raise OverflowError
    t = a0 + sweep / n * np.arange(n + 1.0)
    return np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def _bulged(xy: np.ndarray, bulge: np.ndarray, closed: bool, tol: float) -> np.ndarray:
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
        pts = _arc(c[0], c[1], r, a0, sweep, tol)
        pts[-1] = q
        out += [xy[start:i + 1], pts[1:]]
        start = i + 2
    out.append(xy[start:])
    return np.concatenate(out)


class _Reader:
    def __init__(self, path: str, doc, tol_mm: float, wanted: list[str] | None, warn: Warn):
        self.path, self.doc, self.tol, self.warn = path, doc, tol_mm, warn
        self.asked = list(wanted or [])             # layer names are not case-sensitive
        self.wanted = {w.casefold() for w in self.asked}
        self.current = ""                           # the entity being read, for messages
        self.strokes: list[Stroke] = []
        self.layers: dict[str, dict] = {}
        self.skipped = {"text": 0, "image": 0, "hidden": 0, "other": 0}
        self.other: dict[str, int] = {}
        self.missing_blocks: set[str] = set()
        self.layer_colours: dict[str, str] = {}
        self.points = 0
        self.text = None             # dxf_text.TextWriter, made at the first text

    # -------------------------------------------------------------- document
    def read(self, centre: bool = True) -> Drawing:
        msp = self.doc.modelspace()
        self.check_blocks(msp)
        m = np.diag([self.unit_mm(), self.unit_mm(), self.unit_mm(), 1.0])
        ctx = _Ctx(m, _local_tol(self.tol, m))
        try:
            for k, e in enumerate(msp, 1):
                self.entity(e, replace(ctx, top=k))
        except OverflowError:
            raise InputError(f"{self.path}: error: more than {MAX_POINTS} points: the drawing "
                             f"is too large for the chord tolerance") from None
        except InputError:
            raise
        except Exception as ex:     # noqa: BLE001 - ezdxf on an entity with broken values
            raise InputError(f"{self.path}: error: {self.current}: cannot be drawn: "
                             f"{_first_line(ex)}") from None
        self.check_layers()
        if self.text is not None:
            self.text.finish()
        if self.other:
            parts = ", ".join(f"{n} {t}" for t, n in sorted(self.other.items(),
                                                              key=lambda kv: (-kv[1], kv[0])))
            self.warn(f"{self.path}: warning: not drawn: {parts} (drawn: lines, polylines, "
                      f"arcs, circles, ellipses, splines, blocks, text)")
        return self.drawing(centre)

    def unit_mm(self) -> float:
        from ezdxf import units

        code = self.doc.header.get("$INSUNITS", 0)
        try:
            code = int(code)
            return 1.0 if code == 0 else units.conversion_factor(code, units.MM)
        except (TypeError, ValueError, IndexError):
            self.warn(f"{self.path}: warning: $INSUNITS {code!r} is not a length unit: "
                      f"read as mm")
            return 1.0

    def drawing(self, centre: bool) -> Drawing:
        w = h = None
        if self.strokes:
            lo = np.min([s.pts.min(axis=0) for s in self.strokes], axis=0)
            hi = np.max([s.pts.max(axis=0) for s in self.strokes], axis=0)
            c = (lo + hi) / 2
            for s in self.strokes if centre else ():
                s.pts = s.pts - c
            w, h = float(hi[0] - lo[0]), float(hi[1] - lo[1])
        layers = [{"id": name, "label": name, "visible": d["visible"]}
                  for name, d in self.layers.items()]
        return Drawing(self.path, self.strokes, w, h, layers, self.skipped)

    def check_blocks(self, msp) -> None:
        """Refuse a block that inserts itself, and count what the blocks expand to, before
        anything is drawn."""
        sizes: dict[str, int] = {}
        busy: list[str] = []

        def size(entities) -> int:
            total = 0
            for e in entities:
                t = e.dxftype()
                total += 1
                if t == "INSERT":
                    total += len(e.attribs)
                    name = e.dxf.get("name", "")
                    if name in busy:
                        loop = " -> ".join(busy[busy.index(name):] + [name])
                        raise InputError(f"{self.path}: error: block {name!r} inserts itself "
                                         f"({loop}; INSERT {e.dxf.handle})")
                    if name not in sizes:
                        block = self.doc.blocks.get(name)
                        if block is None:
                            sizes[name] = 0
                        else:
                            if len(busy) >= MAX_DEPTH:
                                raise InputError(f"{self.path}: error: blocks nested more than "
                                                 f"{MAX_DEPTH} deep (block {name!r})")
                            busy.append(name)
                            sizes[name] = size(block)
                            busy.pop()
                    total += max(e.mcount, 1) * sizes[name]
                if total > MAX_ENTITIES:
                    raise InputError(f"{self.path}: error: more than {MAX_ENTITIES} entities "
                                     f"once the blocks are expanded")
            return total

        size(msp)

    def check_layers(self) -> None:
        if not self.wanted:
            return
        have = {name.casefold(): d for name, d in self.layers.items()}
        unknown = [w for w in self.asked if w.casefold() not in have]
        if unknown:
            names = ", ".join(repr(n) for n in self.layers) or "none"
            raise InputError(f"{self.path}: error: no layer {unknown[0]!r} (layers: {names})")
        for name in self.asked:
            if not have[name.casefold()]["visible"]:
                self.warn(f"{self.path}: warning: layer {name!r} is frozen or off: nothing of "
                          f"it is drawn")

    # -------------------------------------------------------------- properties
    def layer_of(self, e, ctx: _Ctx) -> tuple[str, bool]:
        """(the layer the entity draws on, whether that layer is shown)."""
        name = e.dxf.get("layer", "0")
        if name == "0" and ctx.layer is not None:
            name = ctx.layer
        if name not in self.layers:
            lay = self.doc.layers.get(name)
            shown = name.lower() not in HIDDEN_LAYERS and (lay is None or (
                lay.is_on() and not lay.is_frozen() and lay.dxf.get("plot", 1) != 0))
            self.layers[name] = {"visible": shown}
        return name, self.layers[name]["visible"]

    def colour_of(self, e, layer: str, ctx: _Ctx) -> str:
        from ezdxf import colors

        if e.dxf.hasattr("true_color"):
            return "#%02x%02x%02x" % tuple(e.rgb)
        aci = e.dxf.get("color", colors.BYLAYER)
        if aci == colors.BYBLOCK:
            return ctx.colour
        if aci == colors.BYLAYER or not 0 < aci < 256:
            if layer not in self.layer_colours:
                self.layer_colours[layer] = self.layer_colour(layer)
            return self.layer_colours[layer]
        return _aci(aci)

    def layer_colour(self, layer: str) -> str:
        lay = self.doc.layers.get(layer)
        if lay is None:
            return "#000000"
        if lay.dxf.hasattr("true_color"):
            return "#%02x%02x%02x" % tuple(lay.rgb)
        return _aci(abs(lay.dxf.get("color", 7)) or 7)

    # -------------------------------------------------------------- entities
    def entity(self, e, ctx: _Ctx) -> None:
        t = e.dxftype()
        if t in QUIET:
            return
        self.current = f"{ctx.src}{t} {e.dxf.get('handle', '?')}"
        layer, shown = self.layer_of(e, ctx)
        if not shown or e.dxf.get("invisible", 0) or (t == "ATTRIB" and
                                                       e.dxf.get("flags", 0) & 1):
            self.skipped["hidden"] += 1
            return
        if t == "INSERT":
            self.insert(e, layer, ctx)
            return
        if self.wanted and layer.casefold() not in self.wanted:
            return
        if t in CURVES:
            self.curve(e, t, layer, ctx)
        elif t in TEXTS:
            from vplotter.inputs import dxf_text

            if self.text is None:
                self.text = dxf_text.TextWriter(self.path, self.doc, self.warn)
            frame, polys = self.text.polylines(e, t)
            self.add(e, t, polys, frame, layer, ctx)
        else:
            key = "image" if t in ("IMAGE", "WIPEOUT") else "other"
            self.skipped[key] += 1
            self.other[t] = self.other.get(t, 0) + 1

    def insert(self, e, layer: str, ctx: _Ctx) -> None:
        name = e.dxf.get("name", "")
        block = self.doc.blocks.get(name)
        if block is None:
            if name not in self.missing_blocks:
                self.missing_blocks.add(name)
                self.warn(f"{self.path}: warning: INSERT {e.dxf.handle}: no block {name!r}: "
                          f"skipped")
            return
        colour = self.colour_of(e, layer, ctx)
        refs = e.multi_insert() if e.mcount > 1 else [e]
        for ref in refs:
            m = _m44(ref.matrix44()) @ ctx.m
            inner = replace(ctx, m=m, tol=_local_tol(self.tol, m), layer=layer, colour=colour,
                            src=f"{ctx.src}INSERT {e.dxf.handle} > ")
            for child in block:
                self.entity(child, inner)
            for attrib in ref.attribs:              # in the INSERT's own coordinates
                self.entity(attrib, replace(ctx, colour=colour))

    def curve(self, e, t: str, layer: str, ctx: _Ctx) -> None:
        d = e.dxf
        frame = np.eye(4)
        z = 0.0
        if t == "LINE":
            polys = [np.array([list(d.start), list(d.end)])]
        elif t in ("CIRCLE", "ARC"):
            frame = _ocs(e)
            tol = ctx.tol
            c = d.center
            z = c[2]
            if t == "CIRCLE":           # a multiple of 4 chords: its extent is exact
                pts = _arc(c[0], c[1], d.radius, 0.0, 2 * math.pi, tol, 4)
                pts[-1] = pts[0]
            else:
                a0, a1 = math.radians(d.start_angle), math.radians(d.end_angle)
                sweep = (a1 - a0) % (2 * math.pi) or 2 * math.pi
                pts = _arc(c[0], c[1], d.radius, a0, sweep, tol)
            polys = [pts]
        elif t == "ELLIPSE":
            polys = [self.ellipse(e, ctx.tol)]
        elif t == "SPLINE":
            tol = ctx.tol
            try:
                pts = [tuple(v) for v in e.construction_tool().flattening(tol, segments=4)]
            except (ValueError, ZeroDivisionError, IndexError, ArithmeticError) as ex:
                raise InputError(f"{self.path}: error: SPLINE {d.handle}: {_first_line(ex)}"
                                 ) from None
            polys = [np.array(pts)] if pts else []
        elif t == "LWPOLYLINE":
            frame = _ocs(e)
            z = d.get("elevation", 0.0)
            xyb = np.array(list(e.get_points("xyb")), dtype=float).reshape(-1, 3)
            polys = [_bulged(xyb[:, :2], xyb[:, 2], e.closed, ctx.tol)]
        else:
            polys = self.polyline(e, ctx)
            if polys is None:
                return
            frame, polys = polys
        self.add(e, t, polys, frame, layer, ctx, z)

    def ellipse(self, e, tol: float) -> np.ndarray:
        d = e.dxf
        major = np.array(list(d.major_axis), dtype=float)
        minor = np.array(list(e.minor_axis), dtype=float)
        c = np.array(list(d.center), dtype=float)
        a = float(np.linalg.norm(major))
        t0, t1 = d.get("start_param", 0.0), d.get("end_param", 2 * math.pi)
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

    def polyline(self, e, ctx: _Ctx):
        """(frame, [points]) of a POLYLINE, None for a mesh (counted as not drawn)."""
        if e.is_polygon_mesh or e.is_poly_face_mesh:
            self.skipped["other"] += 1
            self.other["POLYLINE (mesh)"] = self.other.get("POLYLINE (mesh)", 0) + 1
            return None
        verts = [v for v in e.vertices if not v.dxf.get("flags", 0) & 16]  # spline frame
        if not verts:
            return np.eye(4), []
        loc = np.array([list(v.dxf.location) for v in verts], dtype=float)
        if e.is_3d_polyline:
            if e.is_closed and len(loc) > 1:
                loc = np.vstack([loc, loc[:1]])
            return np.eye(4), [loc]
        frame = _ocs(e)
        bulge = np.array([v.dxf.get("bulge", 0.0) for v in verts], dtype=float)
        pts = _bulged(loc[:, :2], bulge, e.is_closed, ctx.tol)
        z = float(e.dxf.get("elevation", (0, 0, 0))[2])
        return frame, [np.column_stack([pts, np.full(len(pts), z)])]

    def add(self, e, t: str, polys, frame: np.ndarray, layer: str, ctx: _Ctx,
            z: float = 0.0) -> None:
        """Strokes of polylines given in the entity's frame (2 or 3 columns)."""
        if not polys:
            return
        m = frame @ ctx.m
        colour = self.colour_of(e, layer, ctx)
        src = f"{ctx.src}{t} {e.dxf.handle}"
        for p in polys:
            p = np.asarray(p, dtype=float)
            if len(p) == 0:
                continue
            with np.errstate(all="ignore"):     # overflow: refused just below
                xy = (p @ m[:2, :2] + (z * m[2, :2] + m[3, :2]) if p.shape[1] == 2
                      else p @ m[:3, :2] + m[3, :2])
            if not np.isfinite(xy).all():
                raise InputError(f"{self.path}: error: {src}: coordinates are not finite")
            keep = np.ones(len(xy), dtype=bool)
            keep[1:] = np.any(xy[1:] != xy[:-1], axis=1)
            xy = xy[keep]
            self.points += len(xy)
            if self.points > MAX_POINTS:
                raise OverflowError
            self.strokes.append(Stroke(xy, ctx.top, 0, None, layer, src, layer, colour))
