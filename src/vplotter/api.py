"""The Python API: the plotter in a script (docs/api.md).

    from vplotter import Plotter

    with Plotter("config.toml", dry_run=True) as p:
        p.moveto(0, 0)
        for k in range(1, 2000):
            p.lineto(k / 20 * math.cos(k / 50), k / 20 * math.sin(k / 50))

Coordinates are G-code millimetres (+Y up, X0 Y0 where config.toml puts it), as in a file.
The calls are buffered as records (`inputs/gcode.py`: Move, Pen) and drawn in parts through the
pipeline `draw` uses (`pipeline.Chain`: validated, then planned with the same look-ahead and
played by the same `machine/job.Session`), so that a run of `lineto`s is one planned stroke,
never a stop at each call. A part is played at `flush()`, at the end of the `with` block, at a
pen lift once FLUSH_AT_LIFT moves are buffered, and with the pen down once FLUSH_ALWAYS are
(the pen stops there). The lock is held for the whole block, the stored position and the
journal are kept as by `draw`, and a signal (Ctrl+C, SIGTERM) leaves the machine as `draw`
leaves it: pen up, coils released, position stored; it ends the block with `Stopped`.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

from vplotter.errors import BusyError, ConfigError, Interrupted, MachineError

__all__ = ["Estimate", "Plotter", "Stopped"]

FLUSH_AT_LIFT = 2_000      # moves buffered: a pen lift plays them
FLUSH_ALWAYS = 20_000      # moves buffered: played even with the pen down (a stop there)
# draw's options that belong to the Plotter (or to the command line), not to one file
MACHINE_OPTIONS = {"dry_run", "backend", "trace", "realtime", "trust_position", "detach",
                   "detached", "save_stream", "resume", "from_line", "force", "file"}


class Stopped(Interrupted, KeyboardInterrupt):
    """A signal (Ctrl+C: SIGINT, SIGTERM, SIGHUP) stopped the plotter: the pen is up, the coils
    are released and the position is stored. A KeyboardInterrupt too, so that a script that
    does not catch it ends as a Python program does at Ctrl+C; `exit_code` is 128 + N."""


@dataclass(frozen=True)
class Estimate:
    """What `Plotter.estimate` finds: the plot time and lengths, and the line `vplotter
    estimate` prints."""

    time_s: float
    drawn_mm: float
    travel_mm: float
    pen_lifts: int
    moves: int
    text: str


def _point(what: str, x: Any, y: Any) -> tuple[float, float]:
    try:
        fx, fy = float(x), float(y)
    except (TypeError, ValueError):
        raise ConfigError(f"error: {what}: x and y must be numbers (got {x!r}, {y!r})") from None
    if not (math.isfinite(fx) and math.isfinite(fy)):
        raise ConfigError(f"error: {what}: x and y must be finite (got {fx:g}, {fy:g})")
    return fx, fy


def _caller() -> tuple[str, int]:
    """The script's file and line that called into this module."""
    f = sys._getframe(2)
    while f is not None and f.f_globals.get("__name__") == __name__:
        f = f.f_back
    return (f.f_code.co_filename, f.f_lineno) if f is not None else ("<script>", 0)


class Plotter:
    """The plotter for a script, as a context manager: `with Plotter(...) as p:`.

    config: the machine's config.toml. backend: "lgpio", "gpiozero" or "fake" (default:
    [gpio] backend). dry_run: simulate with the fake backend; nothing moves, nothing is stored,
    no lock is taken. trace: write every GPIO change to this CSV (`draw --trace`).
    trust_position: go on after an unclean stop (`--trust-position`). realtime: the fake
    backend plays in real time (`--realtime`)."""

    def __init__(self, config: str | os.PathLike = "config.toml", *, backend: str | None = None,
                 dry_run: bool = False, trace: str | os.PathLike | None = None,
                 trust_position: bool = False, realtime: bool = False) -> None:
        import argparse

        if backend not in (None, "lgpio", "gpiozero", "fake"):
            raise ConfigError(f"error: backend must be lgpio, gpiozero or fake (got {backend!r})")
        self._args = argparse.Namespace(
            config=str(config), command="api", dry_run=bool(dry_run), backend=backend,
            trace=None if trace is None else str(trace), trust_position=bool(trust_position),
            realtime=bool(realtime))
        self._command = f"{os.path.basename(sys.argv[0]) or 'python'} (vplotter API)"
        self._session: Any = None
        self._chain: Any = None
        self._records: list = []
        self._places: list[tuple[str, int]] = []     # the calls of the part being buffered
        self._first = 1                              # the line (call number) of _places[0]
        self._xy = (0.0, 0.0)
        self._down = False
        self._stopped_idle = False
        self._open = False

    # ---------------------------------------------------------------- the with block
    def __enter__(self) -> "Plotter":
        from vplotter import config
        from vplotter.commands import common, warnings
        from vplotter.machine import lock

        self.cfg = config.load(self._args.config)
        warnings.begin()
        try:
            if not self._args.dry_run:        # the same refusal as `draw` (common.position)
                lock.acquire(self._command)
            pos = common.position(self.cfg, self._args, self._args.dry_run)
            warnings.flush()
            self._start(pos)
        except BusyError as e:
            lock.release_all()
            raise BusyError(common.error_line(e), e.holder) from None
        except BaseException:
            lock.release_all()
            raise
        finally:
            warnings.end()
        self._open = True
        return self

    def _start(self, pos, trace: bool = True) -> None:
        """A session from `pos` (the lock is held), and a chain of parts from there."""
        from vplotter import pipeline
        from vplotter.commands import common, jog

        args = self._args if trace else _without_trace(self._args)
        self._session = common.session(args, self.cfg, self._command, pos)
        self._session.__enter__()
        self._session.signals.idle = self._signal
        xy = jog.pen_xy(self.cfg, pos, pos.counts)
        self._xy = (float(xy[0]), float(xy[1]))
        self._chain = pipeline.Chain(self.cfg, pos.counts, pos.ref_mm, self._command,
                                     where=self._where, park=self._xy)

    def __exit__(self, exc_type, exc, tb) -> bool:
        if not self._open:
            return False
        try:
            if exc is None:
                self.flush()
                self._play(self._chain.finish())
        except BaseException as e:
            self._close(e)
            raise
        self._close(exc)
        return False

    def _close(self, exc: BaseException | None) -> None:
        from vplotter.machine import lock

        self._open = False
        s = self._session
        s.signals.idle = None
        try:
            if self._stopped_idle:          # stopped between two plays: nothing aborted yet
                s.lift_and_release()
            s.__exit__(type(exc) if exc is not None else None, exc, None)
        finally:
            lock.release_all()

    def _signal(self, signum: int) -> None:
        """A signal while the script's own code runs: stop there (Session.signals.idle)."""
        self._session.signals.idle = None
        self._stopped_idle = True
        raise self._stopped(signum)

    def _stopped(self, signum: int) -> Stopped:
        import signal

        from vplotter.commands import jog

        s = self._session
        pos = s.position
        where = ""
        if pos is not None:
            xy = jog.pen_xy(self.cfg, pos, s.counts)
            xy = [0.0 if abs(v) < 5e-4 else float(v) for v in xy]
            where = f" at X{xy[0]:.3f} Y{xy[1]:.3f}"
        saved = "" if self._args.dry_run else ", position saved"
        return Stopped(f"stopped by {signal.Signals(signum).name}{where}; pen lifted, coils "
                       f"released{saved}", signum)

    def _check(self) -> None:
        if not self._open:
            raise MachineError("error: the plotter is not open: use it inside "
                               "`with Plotter(...) as p:`")

    # ---------------------------------------------------------------- drawing
    @property
    def position(self) -> tuple[float, float]:
        """Where the pen is once the calls so far are drawn (G-code mm)."""
        return self._xy

    @property
    def pen_is_down(self) -> bool:
        """Whether the pen is down once the calls so far are drawn."""
        return self._down

    def _line(self) -> int:
        self._places.append(_caller())
        return self._first + len(self._places) - 1

    def _where(self, line: int, col: int | None = None) -> str:
        k = line - self._first
        if 0 <= k < len(self._places):
            return f"{self._places[k][0]}:{self._places[k][1]}"
        return self._command

    def penup(self) -> None:
        """Lift the pen (a stop: once FLUSH_AT_LIFT moves are buffered they are drawn)."""
        self._check()
        if self._down:
            from vplotter.inputs.gcode import Pen

            self._records.append(Pen(self._line(), 0, False))
            self._down = False
        if len(self._records) >= FLUSH_AT_LIFT:
            self.flush()

    def pendown(self) -> None:
        """Lower the pen where it is."""
        self._check()
        if not self._down:
            from vplotter.inputs.gcode import Pen

            self._records.append(Pen(self._line(), 0, True))
            self._down = True

    def moveto(self, x: float, y: float) -> None:
        """Lift the pen (if down) and travel to X Y."""
        from vplotter.inputs.gcode import Move

        self._check()
        fx, fy = _point("moveto", x, y)
        if self._down:
            self.penup()
        line = self._line()
        self._records.append(Move(line, 0, self._xy[0], self._xy[1], fx, fy, rapid=True))
        self._xy = (fx, fy)

    def lineto(self, x: float, y: float, speed: float | None = None) -> None:
        """Lower the pen (if up) and draw a straight line to X Y (speed: mm/s at most;
        default: [motion] draw speed, as a G-code line without F)."""
        from vplotter.inputs.gcode import Move

        self._check()
        fx, fy = _point("lineto", x, y)
        if not self._down:
            self.pendown()
        line = self._line()
        self._records.append(Move(line, 0, self._xy[0], self._xy[1], fx, fy,
                                  feed_mm_s=None if speed is None else float(speed)))
        self._xy = (fx, fy)
        if len(self._records) >= FLUSH_ALWAYS:
            self.flush()

    def draw_path(self, points: Iterable[Sequence[float]], speed: float | None = None) -> None:
        """Travel to the first point, then draw through the others: a polyline, (N, 2)."""
        import numpy as np

        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if len(pts) == 0:
            return
        self.moveto(*pts[0])
        for x, y in pts[1:].tolist():
            self.lineto(x, y, speed)
        if len(pts) == 1:
            self.pendown()          # one point: a dot
        self.penup()

    def flush(self) -> None:
        """Draw what the calls so far asked for: validated, then planned and played as one
        part (it ends at rest); nothing is left buffered."""
        self._check()
        if not self._records:
            return
        records = self._records
        part = self._chain.validate(records, lambda: self._session.stop_pending)
        if part is None:
            raise self._stopped(self._session.signals.signum or 2)
        self._play(self._chain.rows(part, records))
        self._records = []
        self._first += len(self._places)
        self._places = []

    def _play(self, rows) -> None:
        s = self._session
        s.signals.idle = None
        try:
            s.play(rows)
        except Interrupted as e:
            raise self._stopped(e.signum) from None
        s.signals.idle = self._signal

    def home(self) -> None:
        """Lift the pen and travel to the point last calibrated (`vplotter home`)."""
        self._check()
        if self.cfg.machine.kind == "polar":
            raise MachineError("error: the polar plotter homes with its end switch: run "
                               "`vplotter home` before the script")
        pos = self._session.position
        home = pos.extra.get("home", (0.0, 0.0)) if pos is not None else (0.0, 0.0)
        self.moveto(float(home[0]), float(home[1]))
        self.flush()

    # ---------------------------------------------------------------- files and estimates
    def draw_file(self, path: str | os.PathLike, **options: Any) -> None:
        """Draw a file as `vplotter draw FILE` does, with draw's file options as keywords
        (fit=True, offset=(10, 0), rotate=90, order="best", layer=["ink"], ...), from where the
        pen is; the script goes on from where the file ends. An error in the file (or a stop)
        ends the Plotter as it ends `draw` (`estimate(path)` checks a file without moving)."""
        from vplotter.commands import draw

        self._check()
        args = _file_args("draw", str(path), options)
        for k in ("dry_run", "backend", "realtime", "trust_position"):
            setattr(args, k, getattr(self._args, k))
        self.flush()
        s = self._session
        pos = s.here()
        s.signals.idle = None
        s.__exit__(None, None, None)        # the pins for the draw's own session; lock kept
        self._session = None
        reached: list = []
        try:
            draw.draw_from(args, None, self.cfg, pos, reached=reached.append)
        except BaseException as e:
            # the draw's session left the machine safe and stored where it stopped: the
            # Plotter ends here (its `with` block sees the error)
            from vplotter.machine import lock

            self._open = False
            lock.release_all()
            if isinstance(e, Interrupted):
                raise Stopped(f"{e}: {args.file} stopped; pen lifted, coils released"
                              f"{'' if self._args.dry_run else ', position saved'}",
                              e.signum) from None
            raise
        self._start(reached[0], trace=False)

    def estimate(self, path: str | os.PathLike | None = None, **options: Any) -> Estimate:
        """The plot time: of a file drawn from where the pen is (`vplotter estimate FILE`,
        with its file options as keywords), or without a file, of the whole script so far
        (what was drawn and what is buffered). Nothing moves."""
        from vplotter import pipeline

        self._check()
        if path is None:
            part = self._chain.validate(self._records) if self._records else pipeline.Summary()
            done = self._chain.summary
            total = pipeline.Summary(
                moves=done.moves + part.moves, pieces=done.pieces + part.pieces,
                drawn_mm=done.drawn_mm + part.drawn_mm, travel_mm=done.travel_mm + part.travel_mm,
                time_s=done.time_s + part.time_s, pen_downs=done.pen_downs + part.pen_downs,
                motors=part.motors, steps=done.steps + part.steps)
            return _estimate(total)
        return _estimate(self._estimate_file(str(path), options))

    def _estimate_file(self, path: str, options: dict):
        import numpy as np

        from vplotter import kinematics, pipeline
        from vplotter.commands import files

        args = _file_args("estimate", path, options)
        pos = self._session.position
        if pos is None:
            from vplotter.machine import state

            pos = state.Position(0.0, 0.0, 0, 0, self.cfg.motors.steps_per_unit)
        kin = kinematics.from_config(self.cfg)
        q = kin.inverse(kin.to_machine(np.asarray([self._xy], dtype=float)))[0]
        counts = np.rint((q - np.asarray(pos.ref_mm)) * np.asarray(self.cfg.motors.steps_per_unit))
        here = pos.moved_to((int(counts[0]), int(counts[1])))
        prep = files.prepare_file(args, self.cfg, here, warn=lambda m: None, say_notes=False)
        return pipeline.validate(self.cfg, prep.records(), here.counts, here.ref_mm, path,
                                 where=prep.where)


def _estimate(s) -> Estimate:
    return Estimate(float(s.time_s), float(s.drawn_mm), float(s.travel_mm), int(s.pen_downs),
                    int(s.moves), s.text())


def _without_trace(args):
    import argparse

    return argparse.Namespace(**{**vars(args), "trace": None})


def _file_args(command: str, path: str, options: dict):
    """The arguments of `vplotter COMMAND PATH` with `options` (draw's file options as
    keywords: fit=True, offset=(10, 0), layer=["a"]), parsed by the command's own parser, so
    that a bad value is refused as the command line refuses it (ConfigError, one line)."""
    from vplotter.commands import draw
    from vplotter.commands.usage import Parser

    bad = sorted(set(options) & MACHINE_OPTIONS)
    if bad:
        raise TypeError(f"{bad[0]} is the Plotter's (Plotter({bad[0]}=...)), not a file option")
    argv = [path]
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        if value is None or value is False:
            continue
        if value is True:
            argv.append(flag)
        elif isinstance(value, (list, tuple)):
            if name == "layer":
                for v in value:
                    argv += [flag, str(v)]
            else:
                argv += [flag, *map(str, value)]
        else:
            argv += [flag, str(value)]

    class _Parser(Parser):
        def exit(self, status: int = 0, message: str | None = None):
            raise ConfigError((message or "error: bad option").strip().replace(
                f"{self.prog}: ", "", 1))

    parser = _Parser(prog=f"Plotter.{'draw_file' if command == 'draw' else command}")
    (draw.add_draw if command == "draw" else draw.add_estimate)(parser)
    args = parser.parse_args(argv)
    args.command = command
    args.config = None
    return args
