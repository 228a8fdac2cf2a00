"""The DXF reader (inputs/dxf.py): .dxf, or a file that opens with a DXF section or a binary
DXF's sentinel."""

from __future__ import annotations

from vplotter.readers.base import Reader


def _sniff(head: bytes) -> bool:
    # group code 0, SECTION: a DXF file; or a binary DXF's sentinel
    return head.startswith(b"AutoCAD Binary DXF") or head.split()[:2] == [b"0", b"SECTION"]


def read(path: str, ctx):
    from vplotter.inputs import dxf

    return dxf.read(path, ctx.tol_mm, layers=ctx.layers, warn=ctx.warn)


def place(path: str, stroke, k: int) -> str:
    return f"{path}: entity {stroke.src}"


READER = Reader("dxf", "DXF", (".dxf",), read, place, sniff=_sniff, options=("layer",))
