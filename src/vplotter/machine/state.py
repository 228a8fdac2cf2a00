"""The stored position: cord lengths (mm and steps) in $XDG_STATE_HOME/vplotter/state.json.

A V-plotter has no end stops; this file is the only thing that knows where the pen is.
Writes are atomic (temporary file, fsync, rename, fsync of the directory).
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

from vplotter.config import state_dir  # noqa: F401 - where the files below live
from vplotter.errors import StateError

VERSION = 1


def state_path() -> Path:
    return state_dir() / "state.json"


@dataclass
class Position:
    """Motor coordinates (cord lengths): left_mm = ref_left_mm + left_steps / steps_per_unit[0]
    (the same for right with steps_per_unit[1]). On the polar plotter (extra["machine"] =
    "polar") left_mm and right_mm hold the table angle in degrees and the pen radius in mm."""

    left_mm: float
    right_mm: float
    left_steps: int
    right_steps: int
    steps_per_unit: tuple[float, float]
    pen: str = "up"
    clean: bool = True
    extra: dict = field(default_factory=dict)

    @property
    def ref_mm(self) -> tuple[float, float]:
        spu = self.steps_per_unit
        return (self.left_mm - self.left_steps / spu[0], self.right_mm - self.right_steps / spu[1])

    @property
    def counts(self) -> tuple[int, int]:
        return (self.left_steps, self.right_steps)

    @classmethod
    def at_cords(cls, left_mm: float, right_mm: float, steps_per_unit) -> "Position":
        return cls(float(left_mm), float(right_mm), 0, 0, _pair(steps_per_unit))

    def moved_to(self, counts) -> "Position":
        ref = self.ref_mm
        spu = self.steps_per_unit
        return Position(ref[0] + int(counts[0]) / spu[0], ref[1] + int(counts[1]) / spu[1],
                        int(counts[0]), int(counts[1]), spu, self.pen,
                        self.clean, dict(self.extra))

    def rebased(self, steps_per_unit) -> "Position":
        """The same cords counted with other steps per unit (after `calibrate steps`)."""
        spu = _pair(steps_per_unit)
        if spu == self.steps_per_unit:
            return self
        return Position(self.left_mm, self.right_mm, 0, 0, spu, self.pen, self.clean,
                        dict(self.extra))


def _pair(value) -> tuple[float, float]:
    """Steps per unit of both motors from a pair or one number for both."""
    if isinstance(value, (int, float)):
        return (float(value), float(value))
    a, b = value
    return (float(a), float(b))


def atomic_write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    try:
        dfd = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
    except OSError:
        pass


def load(path: Path | None = None) -> Position | None:
    """The stored position, or None if there is none. Raises StateError if it is unreadable."""
    p = path or state_path()
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except OSError as e:
        raise StateError(f"{p}: error: cannot read the stored position: {e.strerror}") from None
    hint = "run `vplotter calibrate --at X Y` to set the position again"
    try:
        data = json.loads(text)
        if not isinstance(data, dict) or data.get("version") != VERSION:
            raise ValueError("unknown version")
        pos = Position(float(data["left_mm"]), float(data["right_mm"]), int(data["left_steps"]),
                       int(data["right_steps"]),
                       _pair(data["steps_per_unit"] if "steps_per_unit" in data
                             else data["steps_per_mm"]),        # version 1 before per-motor
                       str(data.get("pen", "up")), bool(data.get("clean", True)),
                       dict(data.get("extra", {})))
        if pos.extra.get("machine", "vplotter") != "vplotter":   # polar: angle, radius
            if not all(abs(v) < 1e6 for v in (pos.left_mm, pos.right_mm)):
                raise ValueError("motor coordinates out of range")
        elif not all(0 < v < 1e6 for v in (pos.left_mm, pos.right_mm)):
            raise ValueError("cord lengths out of range")
        if not all(0 < v < 1e6 for v in pos.steps_per_unit):
            raise ValueError("steps per unit out of range")
    except (ValueError, KeyError, TypeError) as e:
        raise StateError(f"{p}: error: the stored position is corrupt ({e}); {hint}") from None
    return pos


def save(pos: Position, path: Path | None = None) -> None:
    data = {"version": VERSION, **asdict(pos)}
    atomic_write(path or state_path(), json.dumps(data, indent=2) + "\n")


# ---------------------------------------------------------------- journal (crash safety)
def journal_path() -> Path:
    return state_dir() / "journal"


class Journal:
    """Append-only record of the position while the machine moves (one JSON line, fsync'd).

    Each record is written before a stretch of motion is played: the step counts where it
    starts and how far (in steps) the motors may be from them until the next record. After a
    crash the stored position is the last record and that distance bounds its error.
    """

    def __init__(self, path: Path | None = None):
        self.path = path or journal_path()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.f = open(self.path, "a", encoding="utf-8")

    def record(self, counts, dev_steps, line: int, pen: str) -> None:
        rec = {"steps": [int(counts[0]), int(counts[1])],
               "dev": [int(dev_steps[0]), int(dev_steps[1])], "line": int(line), "pen": pen}
        self.f.write(json.dumps(rec) + "\n")
        self.f.flush()
        os.fsync(self.f.fileno())

    def close(self) -> None:
        try:
            self.f.close()
        except OSError:
            pass


def last_journal_record(path: Path | None = None) -> dict | None:
    """The last complete record (a power cut can leave a torn last line)."""
    p = path or journal_path()
    try:
        lines = p.read_text(encoding="utf-8", errors="replace").splitlines()
    except FileNotFoundError:
        return None
    for line in reversed(lines):
        try:
            rec = json.loads(line)
            if (isinstance(rec, dict) and len(rec.get("steps", ())) == 2
                    and len(rec.get("dev", ())) == 2):
                return rec
        except ValueError:
            continue
    return None


def clear_journal() -> None:
    try:
        os.unlink(journal_path())
    except FileNotFoundError:
        pass


def recovered(pos: Position) -> Position:
    """After an unclean stop: the position from the journal, with its error bound in extra."""
    if pos.clean:
        return pos
    rec = last_journal_record()
    if rec is None:
        return pos
    new = pos.moved_to(rec["steps"])
    new.pen = rec.get("pen", "unknown")
    new.extra["uncertain_steps"] = [int(rec["dev"][0]), int(rec["dev"][1])]
    new.extra["line"] = int(rec.get("line", 0))
    drawing = new.extra.get("drawing")
    if drawing and new.extra["line"] > 0:
        # the line being drawn when the record was written: resume from its start
        new.extra["resume"] = {**drawing, "line": new.extra["line"], "xy": None}
    return new
