"""The text reader (inputs/text.py): a .txt file (UTF-8) drawn in a Hershey font, unless it
holds SVG."""

from __future__ import annotations

from vplotter.readers.base import Reader


def read(path: str, ctx):
    from vplotter.inputs import text

    return text.read(path, ctx.warn)


def place(path: str, stroke, k: int) -> str:
    return f"{path}:{stroke.line}"


READER = Reader("text", "text", (".txt",), read, place, weak_suffix=True)
