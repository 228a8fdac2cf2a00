"""The SVG reader (inputs/svg.py): .svg and .svgz, gzip or markup, and a .txt file holding SVG.
Its fills are hatched by `prepare` once the drawing is placed (`Drawing.fills`)."""

from __future__ import annotations

from vplotter.readers.base import Reader, text_head


def _declares(head: bytes) -> bool:
    return text_head(head).startswith((b"<?xml", b"<svg", b"<!--", b"<!DOCTYPE"))


def _sniff(head: bytes) -> bool:
    return head.startswith(b"\x1f\x8b") or text_head(head).startswith(b"<")   # gzip, markup


def read(path: str, ctx):
    from vplotter.inputs import svg

    layers = ctx.layers
    if ctx.fill.mode == "outline":
        return svg.read(path, ctx.tol_mm, layers=layers, warn=ctx.warn)
    drawing, fills = svg.read_fills(path, ctx.tol_mm, layers, ctx.warn, ctx.fill)
    drawing.fills = fills
    return drawing


def place(path: str, stroke, k: int) -> str:
    return f"{path}: element {stroke.src}" if stroke.src else f"{path}: element {stroke.line}"


READER = Reader("svg", "SVG", (".svg", ".svgz"), read, place, sniff=_sniff,
                declares=_declares, options=("layer", "fill"))
