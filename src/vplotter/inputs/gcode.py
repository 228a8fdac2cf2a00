"""Streaming G-code parser: text lines -> Move / Pen / Dwell / Pause records in G-code mm.

Independent of the machine: it knows nothing of cords, pages or motors. One line is held in
memory at a time, so a file of any size can be read. Every record carries file:line:col so
that later stages can report errors at the place in the file that caused them.

Frame: G-code coordinates, +Y up, millimetres (G20 inches are converted here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable, Iterator

from vplotter.errors import InputError, unreadable
from vplotter.inputs.gcode_pen import (CLASSIC, END_M, PEN_MODES, PenDialect,  # noqa: F401
                                       detect_pen_mode)
from vplotter.inputs.gcode_tools import (Tools, comment_pen, comment_text, pen_message,
                                         scan, tool_name)
from vplotter.inputs.gcode_words import (ALLOWED_LETTERS, LineWords, _blank,  # noqa: F401
                                        read_line, sort_words, tokenize)

MM_PER_INCH = 25.4
MAX_VALUE = 1e6  # mm for X Y Z I J R, seconds for P: anything larger is a typo
# Codes that change nothing for a pen plotter: accepted, summarised in one warning.
IGNORED_G = {40.0, 49.0, 54.0, 61.0, 64.0, 80.0, 94.0}
IGNORED_M = {7.0, 8.0, 9.0}
MOTION_G = {0.0, 1.0, 2.0, 3.0}
UNSUPPORTED_HINTS = {18.0: " (only the XY plane, G17, is drawn)",
                     19.0: " (only the XY plane, G17, is drawn)",
                     41.0: " (cutter compensation)", 42.0: " (cutter compensation)",
                     92.0: " (coordinate offsets)", 93.0: " (inverse-time feed)"}


@dataclass(frozen=True, slots=True)
class Move:
    """A straight line (arc == 0) or an arc (-1 clockwise G2, +1 counter-clockwise G3)."""

    line: int
    col: int
    x0: float
    y0: float
    x1: float
    y1: float
    arc: int = 0
    cx: float = 0.0
    cy: float = 0.0
    rapid: bool = False
    feed_mm_s: float | None = None


@dataclass(frozen=True, slots=True)
class Pen:
    line: int
    col: int
    down: bool


@dataclass(frozen=True, slots=True)
class Dwell:
    line: int
    col: int
    seconds: float


@dataclass(frozen=True, slots=True)
class Pause:
    """Lift the pen (already up) and wait for the person: between layers (made by `prepare`
    for --pause-between-layers; the player waits there with the coils released), at M0/M1, or
    at a pen change (`pen` names the pen to put in, the `index`-th of `count`)."""

    line: int
    col: int
    message: str
    pen: str | None = None
    index: int = 0
    count: int = 0


Record = Move | Pen | Dwell | Pause
Warn = Callable[[str], None]


def _fmt_code(letter: str, value: float) -> str:
    return f"{letter}{int(value)}" if value == int(value) else f"{letter}{value:g}"


class Parser:
    """Holds the modal state between lines. Use `read()` rather than this class directly."""

    def __init__(self, name: str, pen_mode: str, strict: bool, warn: Warn,
                 dialect: PenDialect = CLASSIC, tools: tuple | None = None):
        self.name = name
        self.tools = Tools(tools)        # tool changes (gcode_tools.scan's result, or None)
        self.pen_mode = pen_mode
        self.dialect = dialect
        self.strict = strict
        self.warn = warn
        self.x = self.y = 0.0
        self.z: float | None = None
        self.pen_down = False
        self.motion: float | None = None
        self.scale = 1.0
        self.relative = False
        self.feed_mm_s: float | None = None
        self.ended = False
        self.after_end_line = 0
        self.ignored: dict[str, int] = {}

    def _err(self, line: int, col: int, msg: str) -> InputError:
        return InputError(f"{self.name}:{line}:{col}: error: {msg}")

    def block(self, raw: str, line: int) -> list[Record]:
        """The records of one line, in order (a list: most lines give one or none)."""
        if self.ended:  # whatever follows M2/M30 is not even tokenized: it is ignored
            if not self.after_end_line and not _blank(raw.replace("%", "")):
                self.after_end_line = line
            return _NONE
        b = read_line(raw, line, self.name)
        if b is None:
            return _NONE
        if b.g_codes:
            self._g_codes(b)
        if b.vals:
            self._check_range(b)
        if b.m_codes:
            self._m_codes(b)
        self._check_words(b)
        # the records, in order: tool change, pen, dwell, move, pause
        if (b.change is None and b.pen_change is None and not b.dwell_col and b.stop is None
                and not b.end_col):
            if b.has_xy or (b.has_arc_words and self.motion in (2.0, 3.0)):
                return [self._move(b.vals, line, b.motion_col)]     # (the common line)
            return _NONE
        out: list[Record] = []
        if b.change is not None:
            out.extend(self._change(line, *b.change))
        if b.pen_change is not None and b.pen_change != self.pen_down:
            self.pen_down = b.pen_change
            out.append(Pen(line, b.pen_col, b.pen_change))
        if b.dwell_col:
            out.append(Dwell(line, b.dwell_col, b.vals["P"][0]))
        if b.has_xy or (b.has_arc_words and self.motion in (2.0, 3.0)):
            out.append(self._move(b.vals, line, b.motion_col))
        if b.stop is not None:
            code, col = _fmt_code("M", b.stop[0]), b.stop[1]
            pen = comment_pen(raw, f"{self.name}:{line}")
            if pen is not None:
                out.extend(self._change(line, pen, col, code))
            else:
                out.extend(self._pause(line, col, comment_text(raw) or f"{code}: program pause"))
        if b.end_col:
            self.ended = True
        return out

    def _g_codes(self, b: LineWords) -> None:
        """The G codes: the motion and dwell of the line; units and distance modes change the
        parser's state here, before the values are read."""
        for value, col in b.g_codes:
            if value in MOTION_G:
                if b.motion is not None:
                    raise self._err(b.line, col, "two motion codes (G0-G3) on one line")
                b.motion, b.motion_col = value, col
            elif value == 4.0:
                b.dwell_col = col
            elif value == 17.0:
                pass
            elif value in (20.0, 21.0):
                self.scale = MM_PER_INCH if value == 20.0 else 1.0
            elif value in (90.0, 91.0):
                self.relative = value == 91.0
            elif value in IGNORED_G:
                self._ignore(_fmt_code("G", value))
            else:
                hint = UNSUPPORTED_HINTS.get(value, "")
                raise self._err(b.line, col, f"unsupported code {_fmt_code('G', value)}{hint}")

    def _check_range(self, b: LineWords) -> None:
        for value, _ in b.vals.values():  # a quick look first: |v| * 25.4 < MAX_VALUE
            if not -39000.0 < value < 39000.0:
                break
        else:
            return
        for letter in "XYZIJRP":
            if letter in b.vals:
                value, col = b.vals[letter]
                size = abs(value) * (1.0 if letter == "P" else self.scale)
                if size > MAX_VALUE:
                    unit = "s" if letter == "P" else "mm"
                    raise self._err(b.line, col, f"{letter}{value:g} is out of range "
                                                 f"(at most {MAX_VALUE:.0f} {unit})")

    def _m_codes(self, b: LineWords) -> None:
        """The M codes: pen (M3/M5, M280), program end, tool change, pause."""
        for value, col in b.m_codes:
            if value in (3.0, 5.0):
                if self.pen_mode == "m":  # in a Z-pen file M3/M5 drive a spindle: ignored
                    b.pen_change, b.pen_col = (value == 3.0) == self.dialect.m3_down, col
                elif self.pen_mode == "s":
                    self._ignore(_fmt_code("M", value))
            elif value == 280.0:
                b.servo_line = True
                change = self._servo(b.vals, b.line, col)
                if change is not None:
                    b.pen_change, b.pen_col = change, col
            elif value in END_M:
                b.end_col = col
            elif value == 6.0:
                b.m6_col = col
            elif value in (0.0, 1.0):
                b.stop = (value, col)
            elif value in IGNORED_M:
                self._ignore(_fmt_code("M", value))
            else:
                raise self._err(b.line, col, f"unsupported code {_fmt_code('M', value)}")

    def _check_words(self, b: LineWords) -> None:
        """S, T, P and F; then the dwell, the motion and the coordinates of the line, and Z."""
        vals = b.vals
        if "S" in vals and not b.servo_line:
            self._ignore("S")
        if b.m6_col or "T" in vals:
            b.change = self._tool(b.raw, vals if not b.servo_line else {}, b.line, b.m6_col)
        if ("P" in vals and not b.dwell_col and not b.servo_line
                and not any(v == 64.0 for v, _ in b.g_codes)):
            raise self._err(b.line, vals["P"][1], "P word without G4 (dwell)")
        if "F" in vals:
            f, col = vals["F"]
            if not f > 0:
                raise self._err(b.line, col, f"feed F must be above 0 (got {f:g})")
            self.feed_mm_s = f * self.scale / 60.0
        if b.dwell_col:
            self._check_dwell(b)
        # the modal motion code; coordinates need one, arc words need G2/G3
        if b.motion is not None:
            self.motion = b.motion
        b.has_xy = "X" in vals or "Y" in vals
        b.has_arc_words = "I" in vals or "J" in vals or "R" in vals
        if (b.has_xy or b.has_arc_words) and self.motion is None:
            letter = next(k for k in "XYIJR" if k in vals)
            raise self._err(b.line, vals[letter][1],
                            "coordinates without a motion code (G0/G1/G2/G3)")
        if b.has_arc_words and self.motion in (0.0, 1.0):
            letter = next(k for k in "IJR" if k in vals)
            raise self._err(b.line, vals[letter][1], f"{letter} is only allowed on arcs (G2/G3)")
        if "Z" in vals:
            self._z(b)

    def _check_dwell(self, b: LineWords) -> None:
        line, vals, dwell_col = b.line, b.vals, b.dwell_col
        if dwell_col and b.servo_line:
            raise self._err(line, dwell_col,
                            "G4 (dwell) and M280 cannot share a line (both use P)")
        if dwell_col:
            extra = [k for k in "XYZIJR" if k in vals]
            if extra or b.motion is not None:
                col = vals[extra[0]][1] if extra else b.motion_col
                raise self._err(line, col, "G4 (dwell) cannot share a line with a move")
            if "P" not in vals:
                raise self._err(line, dwell_col, "G4 needs P (seconds)")
            p, col = vals["P"]
            if p < 0:
                raise self._err(line, col, f"dwell P must not be negative (got {p:g})")

    def _z(self, b: LineWords) -> None:
        """Z: the new height (modal, G91-relative); it moves the pen in Z mode."""
        z, zcol = b.vals["Z"]
        z *= self.scale
        self.z = (self.z or 0.0) + z if self.relative else z
        if self.pen_mode == "z":
            b.pen_change, b.pen_col = self.z < self.dialect.z_down_below_mm, zcol
        elif self.pen_mode == "s":
            self._ignore("Z")

    def _tool(self, raw: str, vals: dict, line: int, m6_col: int) -> tuple | None:
        """The tool change of a line: (pen, col, code) or None (T on an M280 line is the
        servo's, not a tool: `vals` is then empty). T<n> selects a tool (and
        changes to it in a file without M6); M6 changes to the selected one, or to the pen a
        `(pen: NAME)` comment names."""
        change = None
        if "T" in vals:
            value, col = vals["T"]
            self.tools.selected = tool_name(value, f"{self.name}:{line}", col)
            if not self.tools.m6:
                change = (self.tools.selected, col, "T")
        if m6_col:
            pen = comment_pen(raw, f"{self.name}:{line}") or self.tools.selected
            if pen is None:
                raise self._err(line, m6_col, "M6 (tool change) without a tool: give T<n> on "
                                              "this line or before it")
            change = (pen, m6_col, "M6")
        return change

    def _change(self, line: int, pen: str, col: int, code: str) -> Iterator[Record]:
        """Put in `pen`: a pen-change pause, unless it asks for nothing (then `code` changed
        nothing and is summarised with the ignored codes)."""
        asked = self.tools.change(pen)
        if asked is None:
            self._ignore(code)
            return
        yield from self._pause(line, col, pen_message(pen, *asked), pen, *asked)

    def _pause(self, line: int, col: int, message: str, pen: str | None = None,
               index: int = 0, count: int = 0) -> Iterator[Record]:
        """A pause with the pen up; a pen that was down goes down again after it."""
        down = self.pen_down
        if down:
            yield Pen(line, col, False)
        yield Pause(line, col, message, pen, index, count)
        if down:
            yield Pen(line, col, True)

    def _ignore(self, key: str) -> None:
        self.ignored[key] = self.ignored.get(key, 0) + 1

    def _servo(self, vals: dict, line: int, col: int) -> bool | None:
        """M280 P<servo> S<angle>: True (down) / False (up) in M280 pen mode, else None."""
        if "P" not in vals or "S" not in vals:
            raise self._err(line, col, "M280 needs P (servo number) and S (angle)")
        p, s_value = vals["P"][0], vals["S"]
        if self.pen_mode != "s" or p != self.dialect.m280_servo:
            self._ignore(f"M280 P{p:g}")
            return None
        angle, scol = s_value
        up, down = self.dialect.m280_up_s, self.dialect.m280_down_s
        if down[0] <= angle <= down[1]:
            return True
        if up[0] <= angle <= up[1]:
            return False
        raise self._err(line, scol, f"M280 S{angle:g} is neither pen up (S {up[0]:g}..{up[1]:g}) "
                                    f"nor pen down (S {down[0]:g}..{down[1]:g}); see [gcode] "
                                    f"m280_up_s and m280_down_s in the config")

    def _move(self, vals: dict, line: int, col: int) -> Move:
        s = self.scale
        x0, y0 = self.x, self.y
        if self.relative:
            x1 = x0 + vals["X"][0] * s if "X" in vals else x0
            y1 = y0 + vals["Y"][0] * s if "Y" in vals else y0
        else:
            x1 = vals["X"][0] * s if "X" in vals else x0
            y1 = vals["Y"][0] * s if "Y" in vals else y0
        for v in (x1, y1):
            if abs(v) > MAX_VALUE:
                raise self._err(line, col, f"coordinate {v:g} is out of range "
                                           f"(at most {MAX_VALUE:.0f} mm)")
        self.x, self.y = x1, y1
        if self.motion in (0.0, 1.0):
            return Move(line, col, x0, y0, x1, y1, 0, 0.0, 0.0, self.motion == 0.0,
                        self.feed_mm_s)
        arc = -1 if self.motion == 2.0 else 1
        if "R" in vals:
            if "I" in vals or "J" in vals:
                raise self._err(line, vals["R"][1], "an arc takes either I/J or R, not both")
            r, rcol = vals["R"]
            r *= s
            cx, cy = self._r_centre(x0, y0, x1, y1, r, arc, line, rcol)
        else:
            if "I" not in vals and "J" not in vals:
                raise self._err(line, col, "arc without centre (I/J) or radius (R)")
            cx = x0 + vals.get("I", (0.0, 0))[0] * s
            cy = y0 + vals.get("J", (0.0, 0))[0] * s
        r0 = math.hypot(x0 - cx, y0 - cy)
        r1 = math.hypot(x1 - cx, y1 - cy)
        if r0 <= 1e-9:
            raise self._err(line, col, "arc with zero radius (centre on the start point)")
        diff = abs(r1 - r0)
        if diff > max(0.005, 0.001 * r0):
            msg = (f"arc end radius {r1:.4f} differs from start radius {r0:.4f} by {diff:.4f} mm")
            if self.strict:
                raise self._err(line, col, msg)
            self.warn(f"{self.name}:{line}:{col}: warning: {msg}; drawing a spiral")
        return Move(line, col, x0, y0, x1, y1, arc, cx, cy, False, self.feed_mm_s)

    def _r_centre(self, x0, y0, x1, y1, r, arc, line, col) -> tuple[float, float]:
        dx, dy = x1 - x0, y1 - y0
        d = math.hypot(dx, dy)
        if r == 0:
            raise self._err(line, col, "arc radius R must not be 0")
        if d < 1e-9:
            raise self._err(line, col, "an R arc needs an end point different from its start")
        half = d / 2
        h2 = r * r - half * half
        if h2 < 0:
            if half - abs(r) > max(1e-4, 1e-6 * abs(r)):
                raise self._err(line, col, f"R arc: the chord ({d:.4f} mm) is longer than 2R "
                                           f"({2 * abs(r):.4f} mm)")
            h2 = 0.0
        h = math.sqrt(h2)
        side = (1 if arc > 0 else -1) * (1 if r > 0 else -1)
        return x0 + dx / 2 - side * h * dy / d, y0 + dy / 2 + side * h * dx / d

    def finish(self) -> None:
        if self.after_end_line:
            self.warn(f"{self.name}:{self.after_end_line}: warning: program ended (M2/M30); "
                      f"the lines after it are ignored")
        if self.ignored:
            codes = ", ".join(f"{k} x{v}" if v > 1 else k for k, v in sorted(self.ignored.items()))
            self.warn(f"{self.name}: warning: ignored codes that change nothing for a pen "
                      f"plotter: {codes}")


_NONE: list = []      # no records (never appended to)


def _stderr(msg: str) -> None:
    import sys

    print(msg, file=sys.stderr)


def parse_lines(lines: Iterable[str], name: str = "<input>", pen_mode: str = "m",
                strict: bool = False, warn: Warn = _stderr,
                dialect: PenDialect = CLASSIC, tools: tuple | None = None) -> Iterator[Record]:
    """Parse an iterable of lines. pen_mode: 'z' (Z below the threshold is down), 'm' (M3/M5)
    or 's' (M280 servo angles); `dialect` gives the values. `tools`: the file's tool changes
    (`gcode_tools.scan`), scanned here when `lines` is a list; else a pen change says no
    "k of n" and a T<n> waits for an M6."""
    if tools is None and isinstance(lines, (list, tuple)):
        tools = scan(lines)
    p = Parser(name, pen_mode, strict, warn, dialect, tools)
    block = p.block
    for number, raw in enumerate(lines, 1):
        recs = block(raw, number)
        if recs:
            yield from recs
    p.finish()


def read(path: str, strict: bool = False, warn: Warn = _stderr,
         dialect: PenDialect = CLASSIC) -> Iterator[Record]:
    """Stream the records of a G-code file (three passes: pen mode, tool changes, then the
    records).
    `dialect` is config.toml's [gcode] (cfg.gcode)."""
    try:
        if dialect.pen == "auto":
            with open(path, encoding="utf-8-sig", errors="replace") as f:
                mode = detect_pen_mode(f, dialect.m280_servo)
        else:
            mode = PEN_MODES[dialect.pen]
        with open(path, encoding="utf-8-sig", errors="replace") as f:
            tools = scan(f)
        with open(path, encoding="utf-8-sig", errors="replace") as f:
            yield from parse_lines(f, path, mode, strict, warn, dialect, tools)
    except OSError as e:
        raise unreadable(path, e, "a G-code file") from None
