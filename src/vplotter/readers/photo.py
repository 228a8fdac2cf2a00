"""The photo reader (drawing/photo.py): PNG, JPEG, WebP, BMP, TIFF and GIF, by name or by their
first bytes. A photo is drawn at the density its plot-time budget allows, so its drawing comes
out placed and ordered (the budget timed that order)."""

from __future__ import annotations

from dataclasses import replace

from vplotter.readers.base import Reader

SUFFIXES = (".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff", ".gif")
MAGIC = (b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff", b"GIF87a", b"GIF89a", b"II*\x00", b"MM\x00*")


def _sniff(head: bytes) -> bool:
    return head.startswith(MAGIC) or (head[:4] == b"RIFF" and head[8:12] == b"WEBP")


def read(path: str, ctx):
    """The placed strokes at the density the budget allows; the notes say what was chosen, the
    details how (--verbose), the advice what would show the picture better."""
    from vplotter.drawing import photo
    from vplotter.inputs.strokes import Drawing

    placed, said = photo.strokes(
        path, ctx.photo, ctx.page, replace(ctx.placement, width_mm=None, height_mm=None),
        ctx.plot_time, ctx.start_xy, ctx.order, ctx.owned)
    return Drawing(path, placed, notes=said.notes, details=said.details, advice=said.advice,
                   placed=True, ordered=True)


def place(path: str, stroke, k: int) -> str:
    return f"{path}: stroke {k + 1}"


READER = Reader("image", "photo", SUFFIXES, read, place, sniff=_sniff, options=("photo",))
