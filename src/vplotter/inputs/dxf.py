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
- one broken entity never stops the file: an entity of zero size, with values that are not
  finite, or that ezdxf cannot evaluate is skipped, the INSERTs of blocks the file lacks too,
  each kind counted in one warning; a layer or text style the tables lack is taken as a
  default one (text: `dxf_text.py`);
- $INSUNITS scales to mm (unitless or no HEADER section: mm); the drawing's extent is
  centred on X0 Y0, +Y up.

This module walks the document (blocks, layers, colours, the strokes); `dxf_geom.py` cuts each
entity into points.

Refused with one line (InputError): what ezdxf cannot read (not a DXF file, a corrupt or
truncated one, text or binary junk), a block that inserts itself (directly or through other
blocks), a drawing whose blocks expand to more than MAX_ENTITIES entities or whose strokes
have more than MAX_POINTS points.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from vplotter.errors import InputError, unreadable
from vplotter.inputs import dxf_geom
from vplotter.inputs.dxf_geom import (MAX_POINTS, Broken, entry, first_line, local_tol,
                                      m44)
from vplotter.inputs.strokes import Drawing, Stroke

MAX_ENTITIES = 500_000      # entities drawn once blocks are expanded (MINSERT grids included)
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
    reader = _Reader(path, doc, tol_mm, layers, warn)
    reader.headless = not _has_header(path)
    return reader.read(centre)


def _has_header(path: str) -> bool:
    """Whether the file has a HEADER section (the first one, when there is one): ezdxf gives a
    file without one a header of its own, in metres, where the file has no unit at all."""
    try:
        with open(path, "rb") as f:
            return b"HEADER" in f.read(4096)
    except OSError:
        return True


def _open(path: str):
    import os

    try:
        import ezdxf
        from ezdxf.lldxf.const import DXFError
    except ImportError:     # pragma: no cover - a dependency; the message says what to do
        raise InputError(f"{path}: error: reading DXF needs the ezdxf package "
                         f"(pip install ezdxf)") from None
    try:
        if os.path.isdir(path):
            raise IsADirectoryError(path)
        size = os.path.getsize(path)
    except OSError as e:         # the same one line as every reader's (errors.unreadable)
        raise unreadable(path, e, "a DXF file") from None
    if size == 0:
        raise InputError(f"{path}: error: the file is empty, not a DXF file")
    try:
        return ezdxf.readfile(path)
    except DXFError as e:
        raise InputError(f"{path}: error: not a valid DXF file: {first_line(e)}") from None
    except (OSError, UnicodeError) as e:
        what = e.strerror if isinstance(e, OSError) and e.strerror else first_line(e)
        if "not a DXF file" in str(e):
            what = "not a DXF file (no DXF section structure at its start)"
        raise InputError(f"{path}: error: {what}") from None
    except MemoryError:
        raise InputError(f"{path}: error: too large to read into memory") from None
    except Exception as e:      # noqa: BLE001 - ezdxf on truncated or garbled input raises
        # whatever its parsing met (IndexError, struct.error, ValueError, ...): one line
        raise InputError(f"{path}: error: not a valid DXF file: {first_line(e)}") from None


def _aci(aci: int) -> str:
    """ACI colour -> '#rrggbb'; 7 (white on a dark screen, black on light) is black on paper."""
    from ezdxf import colors

    return "#000000" if aci == 7 else "#%02x%02x%02x" % tuple(colors.aci2rgb(aci))


class _Reader:
    def __init__(self, path: str, doc, tol_mm: float, wanted: list[str] | None, warn: Warn):
        self.path, self.doc, self.tol, self.warn = path, doc, tol_mm, warn
        self.asked = list(wanted or [])             # layer names are not case-sensitive
        self.wanted = {w.casefold() for w in self.asked}
        self.strokes: list[Stroke] = []
        self.layers: dict[str, dict] = {}
        self.skipped = {"text": 0, "image": 0, "hidden": 0, "other": 0}
        self.other: dict[str, int] = {}
        self.missing_blocks: dict[str, int] = {}    # block name -> INSERTs of it
        self.first_missing = ""
        self.broken: dict[str, list] = {}           # reason -> [count, first place]
        self.layer_colours: dict[str, str] = {}
        self.points = 0
        self.text = None             # dxf_text.TextWriter, made at the first text
        self.headless = False        # no HEADER section: no $INSUNITS (unitless: mm)

    # -------------------------------------------------------------- document
    def read(self, centre: bool = True) -> Drawing:
        msp = self.doc.modelspace()
        self.check_blocks(msp)
        m = np.diag([self.unit_mm(), self.unit_mm(), self.unit_mm(), 1.0])
        ctx = _Ctx(m, local_tol(self.tol, m))
        try:
            for k, e in enumerate(msp, 1):
                self.entity(e, replace(ctx, top=k))
        except OverflowError:
            raise InputError(f"{self.path}: error: more than {MAX_POINTS} points: the drawing "
                             f"is too large for the chord tolerance") from None
        self.check_layers()
        if self.text is not None:
            self.text.finish()
        self.tell()
        return self.drawing(centre)

    def tell(self) -> None:
        """The warnings that count what was not drawn: one per kind."""
        if self.other:
            parts = ", ".join(f"{n} {t}" for t, n in sorted(self.other.items(),
                                                              key=lambda kv: (-kv[1], kv[0])))
            self.warn(f"{self.path}: warning: not drawn: {parts} (drawn: lines, polylines, "
                      f"arcs, circles, ellipses, splines, blocks, text)")
        if self.broken:
            n = sum(c for c, _ in self.broken.values())
            parts = ", ".join(f"{c} {reason} ({'first ' if c > 1 else ''}{where})"
                              for reason, (c, where) in self.broken.items())
            self.warn(f"{self.path}: warning: {n} broken entit{'ies' if n > 1 else 'y'} not "
                      f"drawn: {parts}")
        if self.missing_blocks:
            n = sum(self.missing_blocks.values())
            names = ", ".join(repr(b) for b in self.missing_blocks)
            what = (f"{self.first_missing}: " if n == 1 else f"{n} INSERTs skipped (first "
                    f"{self.first_missing}): ")
            self.warn(f"{self.path}: warning: {what}no block {names}"
                      + (": skipped" if n == 1 else ""))

    def unit_mm(self) -> float:
        from ezdxf import units

        code = 0 if self.headless else self.doc.header.get("$INSUNITS", 0)
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
            lay = entry(self.doc.layers, name)      # a layer the table lacks: a default one
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
        lay = entry(self.doc.layers, layer)
        if lay is None:
            return "#000000"
        if lay.dxf.hasattr("true_color"):
            return "#%02x%02x%02x" % tuple(lay.rgb)
        return _aci(abs(lay.dxf.get("color", 7)) or 7)

    # -------------------------------------------------------------- entities
    def entity(self, e, ctx: _Ctx) -> None:
        """Draw one entity (an INSERT: its block); a broken one is counted, not drawn."""
        t = e.dxftype()
        if t in QUIET:
            return
        try:
            self.draw(e, t, ctx)
        except Broken as ex:
            self.count_broken(ex.reason, ex.detail, ctx, e, t)
        except (InputError, OverflowError, MemoryError, RecursionError):
            raise
        except Exception as ex:     # noqa: BLE001 - ezdxf on an entity with broken values
            if t in CURVES or t in TEXTS or t == "INSERT":
                self.count_broken(dxf_geom.UNREADABLE, first_line(ex), ctx, e, t)
            else:                   # a type ezdxf does not know (no layer even): not drawn
                self.skipped["other"] += 1
                self.other[t] = self.other.get(t, 0) + 1

    def count_broken(self, reason: str, detail: str, ctx: _Ctx, e, t: str) -> None:
        if reason not in self.broken:
            where = f"{ctx.src}{t} {e.dxf.get('handle', '?')}"
            self.broken[reason] = [0, where + (f": {detail}" if detail else "")]
        self.broken[reason][0] += 1

    def draw(self, e, t: str, ctx: _Ctx) -> None:
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
            if not self.missing_blocks:
                self.first_missing = f"{ctx.src}INSERT {e.dxf.handle}"
            self.missing_blocks[name] = self.missing_blocks.get(name, 0) + 1
            return
        colour = self.colour_of(e, layer, ctx)
        refs = list(e.multi_insert()) if e.mcount > 1 else [e]
        ms = [m44(ref.matrix44()) @ ctx.m for ref in refs]
        if not np.isfinite(ms).all():
            raise Broken(dxf_geom.NOT_FINITE)
        for ref, m in zip(refs, ms):
            inner = replace(ctx, m=m, tol=local_tol(self.tol, m), layer=layer, colour=colour,
                            src=f"{ctx.src}INSERT {e.dxf.handle} > ")
            for child in block:
                self.entity(child, inner)
            for attrib in ref.attribs:              # in the INSERT's own coordinates
                self.entity(attrib, replace(ctx, colour=colour))

    def curve(self, e, t: str, layer: str, ctx: _Ctx) -> None:
        got = dxf_geom.curve(e, t, ctx.tol)
        if got is None:                 # a polygon or poly-face mesh: not drawn
            self.skipped["other"] += 1
            self.other["POLYLINE (mesh)"] = self.other.get("POLYLINE (mesh)", 0) + 1
            return
        frame, polys, z = got
        self.add(e, t, polys, frame, layer, ctx, z)

    def add(self, e, t: str, polys, frame: np.ndarray, layer: str, ctx: _Ctx,
            z: float = 0.0) -> None:
        """Strokes of polylines given in the entity's frame (2 or 3 columns). Raises Broken
        for coordinates that are not finite and a curve of zero size (nothing is added)."""
        m = frame @ ctx.m
        out = []
        for p in polys:
            p = np.asarray(p, dtype=float)
            if len(p) == 0:
                continue
            with np.errstate(all="ignore"):     # overflow: broken just below
                xy = (p @ m[:2, :2] + (z * m[2, :2] + m[3, :2]) if p.shape[1] == 2
                      else p @ m[:3, :2] + m[3, :2])
            if not np.isfinite(xy).all():
                raise Broken(dxf_geom.NOT_FINITE)
            keep = np.ones(len(xy), dtype=bool)
            keep[1:] = np.any(xy[1:] != xy[:-1], axis=1)
            out.append(xy[keep])
        if t in CURVES and all(len(xy) < 2 for xy in out):
            raise Broken(dxf_geom.ZERO)     # a point (CAD programs' leftovers): not drawn
        colour = self.colour_of(e, layer, ctx)
        src = f"{ctx.src}{t} {e.dxf.handle}"
        for xy in out:
            self.points += len(xy)
            if self.points > MAX_POINTS:
                raise OverflowError
            self.strokes.append(Stroke(xy, ctx.top, 0, None, layer, src, layer, colour))
