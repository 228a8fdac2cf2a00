"""Command line: a table of commands {name: (handler, add_arguments, help)}.

Heavy modules (numpy, backends) are imported inside the handlers so that `vplotter --help`
stays fast. Every error a person can cause ends as one line on stderr and exit status 2
(3 when the plotter is busy, 128 + N after signal N); anything unexpected is exit 1 with a
hint to rerun with --debug.
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable

from vplotter.errors import BusyError, ConfigError, InputError, MachineError, VplotterError


def _eprint(msg: str) -> None:
    _say(msg, sys.stderr)


def _say(msg: str, stream=None, end: str = "\n") -> None:
    """Print, but never fail: after SIGHUP the SSH terminal is gone and writing to it raises,
    while the machine still has to be stopped and its position saved."""
    try:
        stream = stream or sys.stdout
        stream.write(msg + end)
        stream.flush()
    except (OSError, ValueError):
        pass


# ---------------------------------------------------------------- shared helpers
def _config(args):
    from vplotter import config

    return config.load(args.config)


def _position(cfg, args, dry_run: bool):
    """The position to start from. A dry run without a stored position assumes X0 Y0."""
    from vplotter import job, kinematics, state

    if dry_run and state.load() is None:
        kin = kinematics.from_config(cfg)
        cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
        _eprint("note: no calibrated position stored; the dry run assumes the pen at X0 Y0")
        return state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_mm)
    return job.load_position(cfg, getattr(args, "trust_position", False), dry_run)


def _add_machine_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--dry-run", action="store_true",
                   help="simulate with the fake backend: nothing moves, no state is saved")
    p.add_argument("--backend", choices=("lgpio", "gpiozero", "fake"),
                   help="GPIO backend (default: [gpio] backend in config.toml)")
    p.add_argument("--trace", metavar="OUT.csv", help="write every GPIO change to a CSV trace")
    p.add_argument("--trust-position", action="store_true",
                   help="go on from the stored position after an unclean stop")
    p.add_argument("--realtime", action="store_true",
                   help="with the fake backend: play in real time to measure timing lateness")


def _session(args, cfg, command: str, pos):
    from vplotter.job import Session

    dry = getattr(args, "dry_run", False)
    name = "fake" if dry else (args.backend or cfg.gpio.backend)
    # --backend fake is a simulated machine (lock, stored position); --dry-run touches nothing
    return Session(cfg, command, name, dry, args.trace, args.realtime, pos)


def _command_line(argv) -> str:
    return "vplotter " + " ".join(argv if argv is not None else sys.argv[1:])


def _file_hash(path: str) -> str:
    import hashlib

    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError as e:
        raise InputError(f"{path}: error: cannot read: {e.strerror}") from None
    return h.hexdigest()


def _stream(cfg, records, pos, name, start_at=None):
    from vplotter import pipeline

    return pipeline.stream(cfg, records, pos.counts, pos.ref_mm, name, start_at=start_at)


def _moves_to(cfg, pos, target):
    """A G-code record moving the pen from where it is to the G-code point `target`."""
    from vplotter import jog

    return jog.xy_records(cfg, pos, pos.counts, target)


def _check_on_page(cfg, x: float, y: float, what: str) -> None:
    pg = cfg.page
    if not (pg.x_min_mm <= x <= pg.x_max_mm and pg.y_min_mm <= y <= pg.y_max_mm):
        raise MachineError(f"error: {what} X{x:.3f} Y{y:.3f} is outside the page "
                           f"(X {pg.x_min_mm:g}..{pg.x_max_mm:g}, Y {pg.y_min_mm:g}..{pg.y_max_mm:g})")


def _run_records(args, cfg, command: str, pos, records) -> int:
    """Validate, then play records on the machine (used by jog, goto and home)."""
    from vplotter import pipeline

    pipeline.validate(cfg, records, pos.counts, pos.ref_mm, command)
    with _session(args, cfg, command, pos) as s:
        s.play(_stream(cfg, records, pos, command))
    return 0


# ---------------------------------------------------------------- draw / estimate
def _add_draw(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="G-code file (.ngc, .gcode, .nc)")
    _add_machine_options(p)
    p.add_argument("--strict", action="store_true",
                   help="treat warnings about inconsistent arcs as errors")
    p.add_argument("--verbose", action="store_true", help="print timing lateness statistics")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--resume", action="store_true",
                   help="go on from where the last interrupted draw of FILE stopped")
    g.add_argument("--from-line", type=int, metavar="N", help="start at line N of FILE")
    p.add_argument("--force", action="store_true", help="--resume even if FILE changed since")


def _start_at(args, pos):
    from vplotter.pipeline import StartAt

    if args.from_line is not None:
        if args.from_line < 1:
            raise ConfigError(f"error: --from-line must be 1 or more (got {args.from_line})")
        return StartAt(args.from_line)
    if not args.resume:
        return None
    info = pos.extra.get("resume")
    if not info:
        raise MachineError("error: nothing to resume: no interrupted draw is stored")
    import os

    if os.path.abspath(args.file) != info.get("file") and not args.force:
        raise MachineError(f"error: the interrupted draw was {info.get('file')}, not "
                           f"{os.path.abspath(args.file)} (--force to resume anyway)")
    if _file_hash(args.file) != info.get("sha256") and not args.force:
        raise MachineError(f"error: {args.file} changed since the draw was interrupted "
                           f"(--force to resume anyway, or --from-line N)")
    xy = info.get("xy")
    return StartAt(int(info["line"]), (float(xy[0]), float(xy[1])) if xy else None)


def cmd_draw(args, argv=None) -> int:
    import os

    import numpy as np

    from vplotter import gcode, kinematics, pipeline
    from vplotter.errors import Interrupted

    cfg = _config(args)
    pos = _position(cfg, args, args.dry_run)
    start_at = _start_at(args, pos)
    session = _session(args, cfg, _command_line(argv), pos)
    session.drawing = {"file": os.path.abspath(args.file), "sha256": _file_hash(args.file)}
    # the session (lock, pins, signal handlers) is open first, so that a signal at any moment
    # ends the same way; nothing is output before the whole file has been validated
    with session as s:
        # validation pass: the whole file, page limits and exact plot time before anything moves
        records = gcode.read(args.file, strict=args.strict)
        summary = pipeline.validate(cfg, records, pos.counts, pos.ref_mm, args.file, start_at,
                                    lambda: s.stop_pending)
        if summary is not None:
            _say(f"{args.file}: {summary.text()}")
        quiet = gcode.read(args.file, strict=args.strict, warn=lambda m: None)
        if s.tracer is not None:
            s.tracer.comment(f"file {os.path.abspath(args.file)}")
        progress = (_Progress(summary.time_s) if summary and sys.stderr.isatty() and not s.dry_run
                    else None)
        try:
            s.play(_stream(cfg, quiet, pos, args.file, start_at=start_at), progress)
        except Interrupted:
            kin = kinematics.from_config(cfg)
            cords = np.asarray(pos.ref_mm) + np.asarray(s.counts) / cfg.motors.steps_per_mm
            xy = kin.to_gcode(kin.forward(cords[None, :]))[0]
            if s.line > 0:      # something of the file was drawn
                s.resume_info = {**session.drawing, "line": s.line,
                                 "xy": [float(xy[0]), float(xy[1])]}
            if progress:
                progress.done()
            xy = np.where(np.abs(xy) < 5e-4, 0.0, xy)
            where = f"{args.file}:{s.line}: stopped" if s.line else f"{args.file}: stopped before drawing"
            _eprint(f"{where} at X{xy[0]:.3f} Y{xy[1]:.3f}; pen lifted, coils released"
                    f"{'' if s.dry_run else ', position saved'}")
            if not s.dry_run and s.resume_info:
                _eprint(f"resume with: vplotter draw {args.file} --resume")
            raise
        if progress:
            progress.done()
        s.resume_info = {}
        stats = s.backend.lateness()
        if stats:
            text = ("lateness (actual - planned change time): p50 {p50_ms:.3f} ms, "
                    "p99 {p99_ms:.3f} ms, max {max_ms:.3f} ms over {n} changes").format(**stats)
            if stats.get("underruns"):
                text += f", {stats['underruns']} queue underruns"
            if s.tracer is not None:
                s.tracer.comment(text)
            if args.verbose:
                _say(text)
    return 0


class _Progress:
    """A one-line progress bar on stderr (only on a terminal)."""

    def __init__(self, total_s: float):
        self.total_us = max(total_s * 1e6, 1.0)
        self.last = -1

    def __call__(self, t_us: int, line: int) -> None:
        pct = min(100, int(100 * t_us / self.total_us))
        if pct == self.last:
            return
        self.last = pct
        left = max(0.0, (self.total_us - t_us) / 1e6)
        bar = "#" * (pct // 4) + "-" * (25 - pct // 4)
        _say(f"\r[{bar}] {pct:3d}%  line {line}  {int(left // 60)}:{int(left % 60):02d} left ",
             sys.stderr, end="")

    def done(self) -> None:
        _say("", sys.stderr)


def cmd_estimate(args, argv=None) -> int:
    from vplotter import gcode, pipeline

    cfg = _config(args)
    pos = _position(cfg, args, True)
    summary = pipeline.validate(cfg, gcode.read(args.file, strict=args.strict), pos.counts,
                                pos.ref_mm, args.file)
    print(f"{args.file}: {summary.text()}")
    return 0


def _add_estimate(p) -> None:
    p.add_argument("file")
    p.add_argument("--strict", action="store_true")


# ---------------------------------------------------------------- calibrate / status
def _add_calibrate(p) -> None:
    p.add_argument("what", nargs="?", choices=("steps",),
                   help="`steps`: measure steps per mm by moving one motor")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--at", nargs=2, type=float, metavar=("X", "Y"),
                   help="the pen is now at this G-code point")
    g.add_argument("--cords", nargs=2, type=float, metavar=("LEFT", "RIGHT"),
                   help="measured cord lengths in mm (anchor to pen)")
    p.add_argument("--motor", choices=("left", "right"), help="with `steps`: the motor to move")
    p.add_argument("--steps", type=int, default=2000, help="with `steps`: how many (default 2000)")
    _add_machine_options(p)


def cmd_calibrate(args, argv=None) -> int:
    import math

    import numpy as np

    from vplotter import kinematics, lock, state

    cfg = _config(args)
    if args.what == "steps":
        from vplotter.calibrate import calibrate_steps

        return calibrate_steps(args, cfg, _command_line(argv))
    if args.at is None and args.cords is None:
        raise ConfigError("error: say where the pen is: --at X Y or --cords LEFT RIGHT "
                          "(or `calibrate steps --motor left`)")
    kin = kinematics.from_config(cfg)
    values = args.at if args.at is not None else args.cords
    if not all(math.isfinite(v) and abs(v) < 1e5 for v in values):
        raise ConfigError(f"error: {' '.join(f'{v:g}' for v in values)} is not a position on a wall")
    if args.at is not None:
        xy = kin.to_machine(np.array([args.at]))
        if not xy[0, 1] > 0:
            raise MachineError(f"error: G-code point X{args.at[0]:g} Y{args.at[1]:g} is not below "
                               f"the anchors")
        cords = kin.inverse(xy)[0]
    else:
        left, right = args.cords
        d = cfg.machine.anchor_distance_mm
        if not (left > 0 and right > 0) or left + right <= d or abs(left - right) >= d:
            raise ConfigError(f"error: cords {left:g} and {right:g} mm cannot meet below anchors "
                              f"{d:g} mm apart")
        cords = np.array([left, right])
    held = lock.acquire(_command_line(argv))
    try:
        pos = state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_mm)
        pos.extra["home"] = [float(v) for v in kin.to_gcode(kin.forward(cords[None, :]))[0]]
        state.save(pos)
        state.clear_journal()
    finally:
        held.release()
    print(_describe(cfg, pos))
    return 0


def _pen_xy(cfg, pos):
    from vplotter import jog

    return jog.pen_xy(cfg, pos, pos.counts)


def _describe(cfg, pos) -> str:
    xy = _pen_xy(cfg, pos) + 0.0     # no "-0.000"
    xy[abs(xy) < 5e-4] = 0.0
    return (f"pen at X{xy[0]:.3f} Y{xy[1]:.3f}  "
            f"cords left {pos.left_mm:.3f} mm ({pos.left_steps} steps) "
            f"right {pos.right_mm:.3f} mm ({pos.right_steps} steps)  pen {pos.pen}")


def _add_status(p) -> None:
    p.add_argument("--json", action="store_true", help="machine-readable output")


def cmd_status(args, argv=None) -> int:
    import json

    from vplotter import job, state

    cfg = _config(args)
    stored = state.load()
    if stored is None:
        if args.json:
            print(json.dumps({"calibrated": False}))
        else:
            print("position unknown: run `vplotter calibrate --at X Y`")
        return 0
    pos = state.recovered(stored).rebased(cfg.motors.steps_per_mm)
    off = job.uncertainty_mm(cfg, pos)
    xy = _pen_xy(cfg, pos)
    resume = pos.extra.get("resume")
    if args.json:
        print(json.dumps({
            "calibrated": True, "x_mm": round(float(xy[0]), 4), "y_mm": round(float(xy[1]), 4),
            "left_mm": pos.left_mm, "right_mm": pos.right_mm,
            "left_steps": pos.left_steps, "right_steps": pos.right_steps, "pen": pos.pen,
            "clean": pos.clean, "last_stop": "clean" if pos.clean else "unclean",
            "uncertainty_mm": round(off, 4),
            "resume": resume or None, "state_file": str(state.state_path())}))
        return 0
    print(_describe(cfg, pos))
    if pos.clean:
        print("last stop: clean")
    else:
        print(f"last stop: UNCLEAN (crash or power cut): the position may be off by up to "
              f"{off:.2f} mm; check it and run `vplotter calibrate`, or draw with --trust-position")
    if resume:
        where = (f"at X{resume['xy'][0]:.3f} Y{resume['xy'][1]:.3f}" if resume.get("xy")
                 else "from its start")
        print(f"resume: {resume['file']} line {resume['line']} {where} (vplotter draw FILE --resume)")
    print(f"state file: {state.state_path()}")
    return 0


# ---------------------------------------------------------------- pen
def _add_pen(p) -> None:
    p.add_argument("action", choices=("up", "down", "cycle"))
    p.add_argument("--up-us", type=int, help="try this pen-up pulse width (us) instead of config")
    p.add_argument("--down-us", type=int, help="try this pen-down pulse width (us)")
    p.add_argument("--hold", type=float, default=1.0, help="cycle: seconds to stay down (default 1)")
    _add_machine_options(p)


def cmd_pen(args, argv=None) -> int:
    import dataclasses

    from vplotter.schedule import Rows, Scheduler

    cfg = _config(args)
    for name in ("up_us", "down_us"):
        v = getattr(args, name)
        if v is not None:
            if not 0 < v <= 2600:
                raise ConfigError(f"error: --{name.replace('_', '-')} must be 1..2600 (got {v})")
            cfg = dataclasses.replace(cfg, pen=dataclasses.replace(cfg.pen, **{name: v}))
    pos = _position(cfg, args, args.dry_run)
    sched = Scheduler(cfg, None, pos.counts, pos.ref_mm)
    if args.action == "up":
        sched.pen_down = True       # always send it: the servo may be anywhere
        parts = [sched.pen(False)]
    elif args.action == "down":
        parts = [sched.pen(True)]
    else:
        parts = [sched.pen(True), sched.dwell(args.hold), sched.pen(False)]
    rows = Rows.concat([r for r in parts if r is not None])
    with _session(args, cfg, _command_line(argv), pos) as s:
        s.play([rows])
    print(f"pen {args.action}")
    return 0


# ---------------------------------------------------------------- jog / goto / home
def _add_jog(p) -> None:
    p.add_argument("--dx", type=float, help="move the pen right by this many mm (- for left)")
    p.add_argument("--dy", type=float, help="move the pen up by this many mm (- for down)")
    p.add_argument("--left", type=float, help="lengthen the left cord by mm (- shortens)")
    p.add_argument("--right", type=float, help="lengthen the right cord by mm (- shortens)")
    p.add_argument("--step", type=float, default=1.0, help="interactive: first step size in mm")
    _add_machine_options(p)


def cmd_jog(args, argv=None) -> int:
    from vplotter import jog

    cfg = _config(args)
    pos = _position(cfg, args, args.dry_run)
    if args.dx is not None or args.dy is not None:
        if args.left is not None or args.right is not None:
            raise ConfigError("error: jog takes --dx/--dy or --left/--right, not both")
        xy = _pen_xy(cfg, pos)
        target = (float(xy[0]) + (args.dx or 0.0), float(xy[1]) + (args.dy or 0.0))
        _check_on_page(cfg, *target, "jog target")
        return _run_records(args, cfg, _command_line(argv), pos, _moves_to(cfg, pos, target))
    if args.left is not None or args.right is not None:
        with _session(args, cfg, _command_line(argv), pos) as s:
            s.play([jog.cord_rows(cfg, pos, s.counts, args.left or 0.0, args.right or 0.0)])
        return 0
    return jog.interactive(args, cfg, pos, _session(args, cfg, _command_line(argv), pos))


def _add_goto(p) -> None:
    p.add_argument("x", type=float)
    p.add_argument("y", type=float)
    _add_machine_options(p)


def cmd_goto(args, argv=None) -> int:
    cfg = _config(args)
    _check_on_page(cfg, args.x, args.y, "goto target")
    pos = _position(cfg, args, args.dry_run)
    return _run_records(args, cfg, _command_line(argv), pos, _moves_to(cfg, pos, (args.x, args.y)))


def cmd_home(args, argv=None) -> int:
    cfg = _config(args)
    pos = _position(cfg, args, args.dry_run)
    home = pos.extra.get("home", (0.0, 0.0))
    return _run_records(args, cfg, _command_line(argv), pos, _moves_to(cfg, pos, tuple(home)))


COMMANDS: dict[str, tuple[Callable, Callable, str]] = {
    "draw": (cmd_draw, _add_draw, "draw a G-code file"),
    "estimate": (cmd_estimate, _add_estimate, "validate a file and print the plot time"),
    "calibrate": (cmd_calibrate, _add_calibrate, "tell vplotter where the pen is, or measure steps/mm"),
    "status": (cmd_status, _add_status, "print the stored position"),
    "pen": (cmd_pen, _add_pen, "lift, lower or cycle the pen"),
    "jog": (cmd_jog, _add_jog, "move the pen by hand (arrow keys) or by --dx/--dy, --left/--right"),
    "goto": (cmd_goto, _add_goto, "move the pen (up) to a G-code point"),
    "home": (cmd_home, _add_machine_options, "move the pen (up) to the last calibrated point"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="vplotter", description="Drive a hanging wall plotter (V-plotter) from a Raspberry Pi.")
    parser.add_argument("--config", default="config.toml", metavar="PATH",
                        help="machine configuration (default: ./config.toml)")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_, add_args, help_text) in COMMANDS.items():
        add_args(sub.add_parser(name, help=help_text, description=help_text))
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # argparse: usage errors are exit 2, --help is 0
        return int(e.code or 0)
    if not args.command:
        parser.print_help()
        return 2
    handler = COMMANDS[args.command][0]
    try:
        return handler(args, argv)
    except VplotterError as e:
        msg = str(e)
        if isinstance(e, BusyError) or "error:" in msg:
            _eprint(msg if not msg.startswith("error:") else f"vplotter: {msg}")
        else:
            _eprint(f"vplotter: {msg}" if e.exit_code >= 128 else f"vplotter: error: {msg}")
        return e.exit_code
    except KeyboardInterrupt:
        _eprint("vplotter: interrupted")
        return 130
    except BrokenPipeError:
        return 1
    except Exception as e:  # noqa: BLE001 - the last line of defence
        if args.debug:
            raise
        _eprint(f"vplotter: internal error: {type(e).__name__}: {e} (rerun with --debug for details)")
        return 1


def run() -> None:
    sys.exit(main())
