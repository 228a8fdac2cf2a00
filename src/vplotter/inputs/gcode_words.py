"""G-code words: one line split into (letter, value, column) words, comments and checksums
handled (`tokenize`), then sorted (`sort_words`: G and M codes, the other letters once each).
Shared by the reader (`gcode.py`) and its tool-change scan (`gcode_tools.py`)."""

from __future__ import annotations

import math
import re

from vplotter.errors import InputError

ALLOWED_LETTERS = set("GMXYZIJRFPNST")

# ASCII digits only: \d would accept other scripts' digits, which float() also takes.
_NUMBER = re.compile(r"[ \t]*([+-]?[ \t]*(?:[0-9]+\.?[0-9]*|\.[0-9]+))")
_CHECKSUM = re.compile(r"\*[ \t]*([0-9]+)")
_COMMENT = re.compile(r"\([^)]*\)|;.*")
# The common line, read by two regular expressions instead of a loop over its characters
# (`read_line`): words of the allowed letters with plain numbers, (comments), a ; comment at
# the end. Anything else (checksums, %, a sign apart from its digits, errors) takes the loop.
_WORD = r"[ \t]*+([GMXYZIJRFPNSTgmxyzijrfpnst])[ \t]*+([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))"
_PLAIN_LINE = re.compile(rf"(?:{_WORD}|[ \t]*+\([^)]*\))*[ \t]*+(?:;.*)?", re.S)
_PLAIN_WORD = re.compile(rf"{_WORD}|\([^)]*\)|;.*", re.S)
# The commonest line of all, a move as CAM programs write it (`G01 X1.5 Y-2 Z-1`): a G code
# and then some of X Y Z I J F in this order, one space apart, nothing else; read by one match.
_NUM = r"([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))"
_MOVE_LINE = re.compile(rf"G{_NUM}(?: X{_NUM})?(?: Y{_NUM})?(?: Z{_NUM})?(?: I{_NUM})?"
                        rf"(?: J{_NUM})?(?: F{_NUM})?")
_MOVE_LETTERS = ((2, "X"), (3, "Y"), (4, "Z"), (5, "I"), (6, "J"), (7, "F"))


def _blank(text: str) -> bool:
    """Nothing but white space and comments."""
    return not _COMMENT.sub("", text).strip()


def _checksum(text: str, star: int, where: str) -> None:
    """Check `*N` at text[star]: N is the XOR of the characters before the '*'."""
    m = _CHECKSUM.match(text, star)
    if not m or not _blank(text[m.end():]):
        raise InputError(f"{where}:{star + 1}: error: checksum after '*' must be a number "
                         f"at the end of the line")
    expected = 0
    for ch in text[:star]:
        expected ^= ord(ch)
    if int(m.group(1)) != expected:
        raise InputError(f"{where}:{star + 1}: error: checksum {m.group(1)} does not match "
                         f"the line (expected {expected})")


def tokenize(raw: str, where: str) -> list[tuple[str, float, int]]:
    """Split one line into (letter, value, col) words; col is 1-based. Raises InputError."""
    words: list[tuple[str, float, int]] = []
    text = raw.rstrip("\r\n")
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        if ch in " \t":
            i += 1
        elif ch == "(":
            end = text.find(")", i)
            if end < 0:
                raise InputError(f"{where}:{i + 1}: error: comment '(' is not closed on this line")
            i = end + 1
        elif ch == ";":
            break
        elif ch == "*":
            _checksum(text, i, where)
            break
        elif ch == "%" and not words and _blank(text[i + 1:]):
            break
        elif ch.isascii() and ch.isalpha():
            letter = ch.upper()
            col = i + 1
            m = _NUMBER.match(text, i + 1)
            if letter == "O":
                raise InputError(f"{where}:{col}: error: O-words (subroutines) are not supported")
            if letter == "E" and words and text[i - 1] in "0123456789.":
                raise InputError(f"{where}:{col}: error: a G-code number cannot have an "
                                 f"exponent ('e'): write it out in full")
            if letter not in ALLOWED_LETTERS:
                number = m.group(1).strip() if m else ""
                raise InputError(f"{where}:{col}: error: unsupported word {letter}{number}")
            if not m:
                rest = text[i + 1:].lstrip(" \t")
                if rest[:1] in ("#", "["):
                    i = n - len(rest)
                    continue  # reported as #parameters or [expressions] below
                got = rest[:7] or "end of line"
                raise InputError(f"{where}:{col}: error: {letter} must be followed by a number "
                                 f"(got {got!r})")
            value = float(m.group(1).replace(" ", "").replace("\t", ""))
            if not math.isfinite(value):
                raise InputError(f"{where}:{col}: error: the number after {letter} is too large")
            words.append((letter, value, col))
            i = m.end()
        elif ch == "#":
            raise InputError(f"{where}:{i + 1}: error: #parameters are not supported")
        elif ch == "[":
            raise InputError(f"{where}:{i + 1}: error: [expressions] are not supported")
        else:
            raise InputError(f"{where}:{i + 1}: error: unexpected character {ch!r}")
    return words


class LineWords:
    """One line's words and what they ask, between the parser's checks and its records (a
    plain class: one is made per line, and the class holds the defaults of what most lines
    do not ask)."""

    motion: float | None = None                  # G0-G3 on this line
    dwell_col: int = 0                           # G4
    pen_change: bool | None = None               # True: down, False: up
    pen_col: int = 0
    end_col: int = 0                             # M2/M30
    m6_col: int = 0
    stop: tuple[float, int] | None = None        # M0/M1: (code, col)
    servo_line: bool = False                     # M280
    change: tuple | None = None                  # the tool change: (pen, col, code)
    has_xy: bool = False
    has_arc_words: bool = False

    def __init__(self, raw: str, line: int, motion_col: int,
                 vals: dict[str, tuple[float, int]], g_codes: list[tuple[float, int]],
                 m_codes: list[tuple[float, int]]):
        self.raw = raw
        self.line = line
        self.motion_col = motion_col
        self.vals = vals                         # letter -> (value, col), once each
        self.g_codes = g_codes                   # (value, col), in line order
        self.m_codes = m_codes


def sort_words(raw: str, words: list, line: int, where: str) -> LineWords:
    """Sort a line's words: G and M codes (any number), the other letters (once each)."""
    g_codes: list[tuple[float, int]] = []
    m_codes: list[tuple[float, int]] = []
    vals: dict[str, tuple[float, int]] = {}
    for idx, (letter, value, col) in enumerate(words):
        if letter == "N":
            if idx != 0:
                raise InputError(f"{where}:{col}: error: N line number must come first on "
                                 f"the line")
            continue
        if letter == "G":
            g_codes.append((value, col))
        elif letter == "M":
            m_codes.append((value, col))
        else:
            if letter in vals:
                raise InputError(f"{where}:{col}: error: {letter} appears twice on the line")
            vals[letter] = (value, col)
    return LineWords(raw, line, words[0][2], vals, g_codes, m_codes)


def read_line(raw: str, line: int, name: str) -> LineWords | None:
    """`sort_words(tokenize(raw))`, or None for a line without words; a plain line (the
    common case) is read without the loop over its characters, to the same result."""
    text = raw.rstrip("\r\n")
    m = _MOVE_LINE.fullmatch(text) if len(text) < 200 else None    # (long: numbers too large)
    if m is not None:
        g, at = m.groups(), m.regs       # col: 1-based, of the letter (where its number starts)
        vals = {}
        for i, letter in _MOVE_LETTERS:
            if g[i - 1] is not None:
                vals[letter] = (float(g[i - 1]), at[i][0])
        return LineWords(raw, line, 1, vals, [(float(g[0]), 1)], [])
    if _PLAIN_LINE.fullmatch(text):
        g_codes: list[tuple[float, int]] = []
        m_codes: list[tuple[float, int]] = []
        vals: dict[str, tuple[float, int]] = {}
        first = 0
        for m in _PLAIN_WORD.finditer(text):
            letter = m[1]
            if not letter:
                continue
            letter, value, col = letter.upper(), float(m[2]), m.start(1) + 1
            if letter == "G":
                g_codes.append((value, col))
            elif letter == "M":
                m_codes.append((value, col))
            elif letter in vals or (letter == "N" and first) or not math.isfinite(value):
                break  # an error: the loop below reports it
            elif letter != "N":
                vals[letter] = (value, col)
            first = first or col
        else:
            if not first:
                return None
            return LineWords(raw, line, first, vals, g_codes, m_codes)
    where = f"{name}:{line}"
    words = tokenize(raw, where)
    return sort_words(raw, words, line, where) if words else None
