"""The file readers: one module per format, each declaring a `Reader` (readers/base.py), and
the registry that picks one for a file.

The order of READERS is the order of the look inside a file whose name no reader takes
(`sniff`); the last reader takes what no other does (G-code: any text may be G-code). Adding a
format is a module with its READER and one line here (docs/design.md, "Readers").
"""

from __future__ import annotations

from vplotter.readers import dxf, gcode, photo, svg, text, vpype
from vplotter.readers.base import Context, Reader

__all__ = ["READERS", "Context", "Reader", "file_kind", "reader_for", "reader_of"]

READERS: tuple[Reader, ...] = (
    photo.READER,           # image magic
    dxf.READER,             # a DXF section or sentinel
    svg.READER,             # gzip or markup
    text.READER,
    vpype.READER,           # by name only: *.vpype.npz (the vpype plugin's)
    gcode.READER,           # last: what no other reader takes
)


def _head(path: str) -> bytes | None:
    try:
        with open(path, "rb") as f:
            return f.read(256)
    except OSError:
        return None         # the reader reports it


def reader_for(path: str) -> Reader:
    """The reader of a file: by its name's suffix, else by its first bytes (read once). A
    weak suffix (.txt) is its reader's unless the first bytes declare another format."""
    readers = READERS
    low = path.lower()
    named = next((r for r in readers if r.takes_name(low)), None)
    if named is not None and not named.weak_suffix:
        return named
    head = _head(path)
    if named is not None:
        return next((r for r in readers if r.declares is not None
                     and r.declares(head or b"")), named)
    if head is None:
        return readers[-1]
    return next((r for r in readers if r.sniff is not None and r.sniff(head)), readers[-1])


def file_kind(path: str) -> str:
    """The kind of the reader of `path` ("svg", "dxf", "image", "text", "gcode", ...)."""
    return reader_for(path).kind


def reader_of(kind: str) -> Reader:
    """The reader of a kind (KeyError: no such reader)."""
    for r in READERS:
        if r.kind == kind:
            return r
    raise KeyError(kind)
