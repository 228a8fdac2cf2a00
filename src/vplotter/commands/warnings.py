"""Warnings for a person: those of one kind in one file become one line with a count and the
first place, so that a long file's hundred arc warnings do not bury the one error that matters.

A `Collector` is the `warn` callback the readers and the pipeline are given. It holds what
it is told until `flush()`, which prints one line per kind in the order the kinds first came;
`--verbose` (verbose=True) prints every warning as it comes instead. A command that fails drops
what it holds (`drop()`): its error is its only line.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from typing import Callable

_PLACED = re.compile(r"^(?P<file>.*?):(?P<line>\d+)(?::(?P<col>\d+))?: warning: (?P<text>.*)$",
                     re.S)
_NUMBER = re.compile(r"-?\d+(?:\.\d+)?")
_QUOTED = re.compile(r"'[^']*'|\"[^\"]*\"")

# kinds that repeat, in a person's words: (pattern of the text, what n of them are, what is done)
KINDS = (
    (re.compile(r"^arc end radius .* differs from start radius .*; drawing a spiral$"),
     "arcs whose end radius differs from the start", "drawn as spirals"),
)


@dataclass
class _Kind:
    file: str
    place: str
    first: str              # the first warning of the kind, as it was given
    text: str
    count: int = 0


@dataclass
class Collector:
    """warn(message) for readers; flush() prints one line per kind (see the module's text)."""

    verbose: bool = False
    out: Callable[[str], None] = field(default=lambda m: print(m, file=sys.stderr, flush=True))
    _kinds: dict = field(default_factory=dict)

    def __call__(self, message: str) -> None:
        if self.verbose:
            self.out(message)
            return
        m = _PLACED.match(message)
        if m is None:                 # not placed in the file: one of a kind already
            key = ("", message)
            file, place, text = "", "", message
        else:
            file, text = m.group("file"), m.group("text")
            place = m.group("line") + (f":{m.group('col')}" if m.group("col") else "")
            key = (file, _QUOTED.sub("'…'", _NUMBER.sub("#", text)))
        kind = self._kinds.setdefault(key, _Kind(file, place, message, text))
        kind.count += 1

    def flush(self) -> None:
        """Print what was collected, one line per kind, and forget it."""
        for kind in self._kinds.values():
            self.out(line(kind))
        self._kinds.clear()

    def drop(self) -> None:
        self._kinds.clear()


def line(kind: _Kind) -> str:
    """One kind's line: the warning itself when it came once, else the count and first place."""
    if kind.count == 1:
        return kind.first
    for pattern, what, done in KINDS:
        if pattern.match(kind.text):
            return (f"{kind.file}: warning: {kind.count} {what} (first at {kind.place}): {done}; "
                    f"--verbose lists them")
    return (f"{kind.file}: warning: {kind.count} warnings like this one at {kind.place}: "
            f"{kind.text}; --verbose lists them")


# ------------------------------------------------------------------ the command's collector
_active: Collector | None = None


def begin(verbose: bool = False) -> Collector:
    """A command starts (cli.main): its warnings are collected until flush()."""
    global _active
    _active = Collector(verbose=verbose)
    return _active


def end() -> None:
    """No collecting (a server that runs until stopped): warnings go out as they come."""
    global _active
    _active = None


def warn(message: str) -> None:
    """The `warn` the commands give the readers: collected while a command runs."""
    if _active is not None:
        _active(message)
    else:
        print(message, file=sys.stderr, flush=True)


def flush() -> None:
    """Say the warnings collected so far (before a summary, before anything moves)."""
    if _active is not None:
        _active.flush()


def drop() -> None:
    """A failed command: its error is its only line."""
    if _active is not None:
        _active.drop()
