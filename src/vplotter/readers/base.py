"""The reader interface: what a file reader declares (its kind, the files it takes, the file
options it takes, how it names a stroke's place) and the context it reads in.

A reader turns a file into one `inputs.strokes.Drawing`. It does not see argparse or the
config: `prepare` (prepare.py) checks the options, builds a `Context` and asks the registry
(`readers/__init__.py`) for the reader of a file.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

BOM_AND_SPACE = b"\xef\xbb\xbf \t\r\n"


def text_head(head: bytes) -> bytes:
    """The first bytes without a UTF-8 byte order mark and leading white space."""
    return head.lstrip(BOM_AND_SPACE)


@dataclass(frozen=True)
class Context:
    """What a reader may need, made once by `prepare` from the options and the config."""

    tol_mm: float                       # chords of curves within this (the flattening tolerance)
    warn: Callable[[str], None]
    layers: tuple | list | None = None  # --layer: only these layers (SVG, DXF)
    fill: object = None                 # inputs.fill.FillOptions (readers taking "fill")
    photo: object = None                # drawing.photo.PhotoOptions (readers taking "photo")
    placement: object = None            # drawing.place.Placement (--scale, --fit, ...)
    page: object = None                 # drawing.place.Box: the page drawings are placed on
    plot_time: Callable[[list], float] | None = None   # strokes -> s, as they would be drawn
    start_xy: tuple[float, float] = (0.0, 0.0)         # where the pen's travel starts
    order: str = "best"                 # --order (or the reader's default)
    owned: tuple = ()                   # config.toml [pens]: the pens owned
    strict: bool = False                # --strict (G-code arcs)
    dialect: object = None              # config.toml [gcode] pen dialect, or None


@dataclass(frozen=True)
class Reader:
    """One file format.

    kind: its name ("svg", "gcode", ...: Prepared.kind, `file_kind`).
    title: the format as people say it ("SVG", "G-code", "photo"; `vplotter info` names it).
    suffixes: the file names it takes, lower case (".svg", ...); a name with one of them is
        this reader's without a look inside, unless `weak_suffix`.
    sniff: head -> bool, on the first 256 bytes of a file whose name no reader takes.
    declares: head -> bool: the first bytes declare this format outright, so that a file with
        a `weak_suffix` reader's name is this reader's (a .txt file holding SVG).
    weak_suffix: the suffix names any plain text (.txt): a reader's `declares` wins over it.
    read(path, ctx) -> Drawing (inputs/strokes.py).
    place(path, stroke, k) -> str: the file place of stroke k (0-based, in drawing order) for
        messages and resume ('file:line:col', 'file: element ID').
    options: the groups of file options it takes ("layer", "fill", "photo", see
        file_options.GROUPS); the others are errors for its files.
    order: the stroke order without --order ("best", or "keep": the file's).
    streams: drawn as it is (--order keep, no placement or pen option), the file streams its
        own records (G-code: `Prepared.records`).
    """

    kind: str
    title: str
    suffixes: tuple[str, ...]
    read: Callable
    place: Callable
    sniff: Callable[[bytes], bool] | None = None
    declares: Callable[[bytes], bool] | None = None
    weak_suffix: bool = False
    options: tuple[str, ...] = ()
    order: str = "best"
    streams: bool = False

    def takes_name(self, low: str) -> bool:
        return bool(self.suffixes) and low.endswith(self.suffixes)
