"""The steps of a plan: what the machine does, in order (`pipeline.plan` makes them, the
schedule plays them, `Kept` keeps them for `replay`).

A plan is `Start`, then any of `Motion`, `InPlace`, `PenMove`, `Dwell` and `Wait`, then
`Finish`. Each step also reads as the tuple it once was (`step[0]` its `kind`, `step[1:]` its
fields), which bench/plan_optimal.py and tests/test_planner.py still index.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import ClassVar

from vplotter.inputs.gcode import Pause
from vplotter.motion.planner import Block, Turn


class Step:
    """A step of the plan; `kind` names it in the tuple view."""

    __slots__ = ()
    kind: ClassVar[str] = ""

    def __getitem__(self, i):
        return (self.kind, *(getattr(self, f.name) for f in fields(self)))[i]


@dataclass(frozen=True, slots=True)
class Start(Step):
    """The plan begins: the pen as the caller has it (None: lift it first)."""

    kind: ClassVar[str] = "start"
    pen_down: bool | None


@dataclass(frozen=True, slots=True)
class Motion(Step):
    """The pen moves along planned pieces (a slice of a planner Block ending at a stop or
    where the planner's block ends)."""

    kind: ClassVar[str] = "motion"
    block: Block


@dataclass(frozen=True, slots=True)
class InPlace(Step):
    """The motors move to `turn.q` with the pen standing still (the polar table turning at its
    centre), between two Motions."""

    kind: ClassVar[str] = "turn"
    turn: Turn


@dataclass(frozen=True, slots=True)
class PenMove(Step):
    """The pen goes down (or up), at a standstill; `line`: the G-code line it belongs to."""

    kind: ClassVar[str] = "pen"
    down: bool
    line: int


@dataclass(frozen=True, slots=True)
class Dwell(Step):
    """The machine waits `seconds` at a standstill (G4)."""

    kind: ClassVar[str] = "dwell"
    seconds: float
    line: int


@dataclass(frozen=True, slots=True)
class Wait(Step):
    """The player waits for the person (a Pause record: M0/M1, between layers, a pen change
    when `pause.pen` is set); the pen is up."""

    kind: ClassVar[str] = "pause"
    pause: Pause


@dataclass(frozen=True, slots=True)
class Finish(Step):
    """The plan ends: the pen is lifted if `lift`."""

    kind: ClassVar[str] = "finish"
    lift: bool
