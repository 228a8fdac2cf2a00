"""How a G-code file moves the pen: the [gcode] dialect of config.toml (Z, M3/M5 or M280
servo angles) and, in 'auto', the detection of the mode from the file's first pen words."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from vplotter.errors import InputError
from vplotter.inputs.gcode_words import tokenize

END_M = {2.0, 30.0}   # M2/M30: the program end


@dataclass(frozen=True)
class PenDialect:
    """How a file moves the pen (config.toml [gcode]; the defaults are the classic rules).

    pen: 'auto' (the first Z word or M280 P<m280_servo> decides; neither: M3/M5), 'z', 'm3' or
    'm280'. In each mode the other pen commands change nothing."""

    pen: str = "auto"
    z_down_below_mm: float = 0.0              # Z below this is down (G-code mm)
    m3_down: bool = True                      # M3 lowers and M5 lifts (false: the reverse)
    m280_servo: int = 0                       # M280 P<this> is the pen servo
    m280_up_s: tuple[float, float] = (70.0, 180.0)    # S (servo angle) in this range: up
    m280_down_s: tuple[float, float] = (0.0, 50.0)    # S in this range: down


CLASSIC = PenDialect()
PEN_MODES = {"z": "z", "m3": "m", "m280": "s"}


def detect_pen_mode(lines: Iterable[str], servo: int | None = None) -> str:
    """'z' if a Z word comes before the program end (Inkscape gcodetools, CamBam), else 'm'
    (M3/M5). With `servo`, an M280 P<servo> (Makelangelo) that comes before any Z word gives
    's'. A line that does not tokenize ends the search: parsing will report it."""
    for raw in lines:
        low = raw.lower()
        if "z" not in low and "m" not in low:  # cheap: most lines need no tokenizing
            continue
        try:
            words = tokenize(raw, "")
        except InputError:
            return "m"
        if any(letter == "Z" for letter, _, _ in words):
            return "z"
        if servo is not None and any(letter == "M" and value == 280.0
                                     for letter, value, _ in words):
            if any(letter == "P" and value == servo for letter, value, _ in words):
                return "s"
        if any(letter == "M" and value in END_M for letter, value, _ in words):
            return "m"
    return "m"
