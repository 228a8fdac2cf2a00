"""The steps of a plan: what the machine does, in order (`pipeline.plan` makes them, the
schedule plays them, `Kept` keeps them for `replay`).

A plan is `Start`, then any of `Motion`, `InPlace`, `PenMove`, `Dwell` and `Wait`, then
`Finish`; readers tell them apart by type and read their fields by name.
"""

from __future__ import annotations

from dataclasses import dataclass

from vplotter.inputs.gcode import Pause
from vplotter.motion.planner import Block, Turn


class Step:
    """A step of the plan."""

    __slots__ = ()


@dataclass(frozen=True, slots=True)
class Start(Step):
    """The plan begins: the pen as the caller has it (None: lift it first)."""

    pen_down: bool | None


@dataclass(frozen=True, slots=True)
class Motion(Step):
    """The pen moves along planned pieces (a slice of a planner Block ending at a stop or
    where the planner's block ends)."""

    block: Block


@dataclass(frozen=True, slots=True)
class InPlace(Step):
    """The motors move to `turn.q` with the pen standing still (the polar table turning at its
    centre), between two Motions."""

    turn: Turn


@dataclass(frozen=True, slots=True)
class PenMove(Step):
    """The pen goes down (or up), at a standstill; `line`: the G-code line it belongs to."""

    down: bool
    line: int


@dataclass(frozen=True, slots=True)
class Dwell(Step):
    """The machine waits `seconds` at a standstill (G4)."""

    seconds: float
    line: int


@dataclass(frozen=True, slots=True)
class Wait(Step):
    """The player waits for the person (a Pause record: M0/M1, between layers, a pen change
    when `pause.pen` is set); the pen is up."""

    pause: Pause


@dataclass(frozen=True, slots=True)
class Finish(Step):
    """The plan ends: the pen is lifted if `lift`."""

    lift: bool
