"""Pen changes in G-code: tool changes (`T<n> M6`, `M6 T<n>`, `T<n>` then a later `M6`) and
`M0`/`M1` pauses with a `(pen: NAME)` comment (what `vplotter convert` writes).

A file without any M6 changes the tool at the `T<n>` word itself (Marlin, RepRap); with M6 a
`T<n>` only selects the tool and the M6 changes it (LinuxCNC, grbl with a tool changer). The
pen a tool change asks for is named `T<n>`; a `(pen: NAME)` comment on the line names it
instead. `scan` reads a whole file first (the pens in the order they are first asked for), so
that each change can say which of how many pens it is.
"""

from __future__ import annotations

import re
from typing import Iterable

from vplotter.errors import InputError
from vplotter.inputs.gcode_words import tokenize

PEN_COMMENT = re.compile(r"\(\s*pen\s*:\s*([^)]*?)\s*\)", re.IGNORECASE)
_COMMENT_TEXT = re.compile(r"\(\s*([^)]*?)\s*\)|;\s*(.*?)\s*$")
# a superset of the lines that may change the pen or end the program (T, M0, M1, M6, M2, M30,
# however the number is written: M06, M 6, M6.0, M.0 are what tokenize reads as those)
_HINT = re.compile(r"[tT]|[mM][ \t]*[+-]?[ \t]*0*(?:[0126]|30)?(?![0-9])")
END_M = (2.0, 30.0)


def pen_message(pen: str, index: int, count: int) -> str:
    """What a pen-change pause says: 'put in the red pen (2 of 3)'."""
    return f"put in the {pen} pen" + (f" ({index} of {count})" if count else "")


def tool_name(value: float, where: str, col: int) -> str:
    """T<n> -> 'T<n>' (a whole number 0 or more, else an InputError at where:col)."""
    if value < 0 or value != int(value) or value > 1e6:
        raise InputError(f"{where}:{col}: error: tool number T{value:g} must be a whole number "
                         f"0 or more")
    return f"T{int(value)}"


def comment_pen(raw: str, where: str) -> str | None:
    """The NAME of a `(pen: NAME)` comment on the line, None without one."""
    m = PEN_COMMENT.search(raw)
    if m is None:
        return None
    if not m.group(1):
        raise InputError(f"{where}:{m.start() + 1}: error: '(pen: )' needs a pen name")
    return m.group(1)


def comment_text(raw: str) -> str | None:
    """The first comment of the line, as its text (an M0's message), None without one."""
    m = _COMMENT_TEXT.search(raw)
    if m is None:
        return None
    return (m.group(1) if m.group(1) is not None else m.group(2)) or None


def scan(lines: Iterable[str]) -> tuple[bool, tuple[str, ...]]:
    """(the file has an M6, the pens its changes ask for in the order they are first asked
    for). Lines that do not read are skipped: the reader reports them."""
    events = []
    has_m6 = False
    for raw in lines:
        if not ("M" in raw or "T" in raw or "m" in raw or "t" in raw) or not _HINT.search(raw):
            continue  # the first test is quicker than the search, which needs one of these
        try:
            words = tokenize(raw, "")
        except InputError:
            continue
        ms = [v for letter, v, _ in words if letter == "M"]
        t = None if 280.0 in ms else next((v for letter, v, _ in words if letter == "T"), None)
        m6 = 6.0 in ms
        stop = 0.0 in ms or 1.0 in ms
        try:
            pen = comment_pen(raw, "") if m6 or stop else None
            tool = tool_name(t, "", 0) if t is not None else None
        except InputError:
            pen = tool = None
        has_m6 = has_m6 or m6
        events.append((tool, m6, stop, pen))
        if any(v in END_M for v in ms):
            break
    pens: list[str] = []
    selected = None
    for tool, m6, stop, pen in events:
        if tool is not None:
            selected = tool
            if not has_m6 and tool not in pens:
                pens.append(tool)
        if m6 and (pen or selected) and (pen or selected) not in pens:
            pens.append(pen or selected)
        if stop and pen and pen not in pens:
            pens.append(pen)
    return has_m6, tuple(pens)


class Tools:
    """The tool state of a reader: the tool selected, the pen in, the pens of the file."""

    def __init__(self, scanned: tuple[bool, tuple[str, ...]] | None):
        self.m6 = True if scanned is None else scanned[0]
        self.pens = None if scanned is None else scanned[1]
        self.selected: str | None = None
        self.pen: str | None = None

    def change(self, name: str) -> tuple[int, int] | None:
        """Put in pen `name`: (index, count) for the pause that asks for it, or None when the
        change asks for nothing (the pen is in already, or the file has one pen only)."""
        if name == self.pen:
            return None
        self.pen = name
        if self.pens is None:
            return (0, 0)
        if len(self.pens) < 2:
            return None
        return (self.pens.index(name) + 1 if name in self.pens else 0, len(self.pens))
