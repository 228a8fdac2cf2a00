"""Command line: a table of commands {name: (handler, add_arguments, help)}.

Heavy modules (numpy, backends) are imported inside the handlers so that `vplotter --help`
stays fast. Every error a person can cause ends as one line on stderr and exit status 2
(3 when the plotter is busy); anything unexpected is exit 1 with a hint to rerun with --debug.
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable

from vplotter.errors import ConfigError, MachineError, VplotterError


def _eprint(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# ---------------------------------------------------------------- shared helpers
def _config(args):
    from vplotter import config

    return config.load(args.config)


def _position(cfg, dry_run: bool):
    """The stored position (re-counted if steps/mm changed), or for a dry run without one,
    the pen at G-code X0 Y0."""
    from vplotter import kinematics, state

    pos = state.load()
    spm = cfg.motors.steps_per_mm
    if pos is None:
        if not dry_run:
            raise MachineError("error: the pen position is unknown; put the pen on a known point "
                               "and run `vplotter calibrate --at X Y` first")
        kin = kinematics.from_config(cfg)
        cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
        _eprint("note: no calibrated position stored; the dry run assumes the pen at X0 Y0")
        return state.Position.at_cords(cords[0], cords[1], spm), False
    return pos.rebased(spm), True


def _backend_name(args, cfg) -> str:
    if getattr(args, "dry_run", False):
        return "fake"
    return args.backend or cfg.gpio.backend


def _open_backend(name: str, cfg, **options):
    from vplotter import backends

    backend = backends.create(name, cfg, **options)
    backend.open()
    return backend


# ---------------------------------------------------------------- draw / estimate
def _add_draw(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", help="G-code file (.ngc, .gcode, .nc)")
    p.add_argument("--dry-run", action="store_true",
                   help="plan and simulate with the fake backend; nothing moves, no state is saved")
    p.add_argument("--trace", metavar="OUT.csv", help="write every GPIO change to a CSV trace")
    p.add_argument("--strict", action="store_true",
                   help="treat warnings about inconsistent arcs as errors")
    p.add_argument("--backend", choices=("lgpio", "gpiozero", "fake"),
                   help="GPIO backend (default: [gpio] backend in config.toml)")
    p.add_argument("--realtime", action="store_true",
                   help="with the fake backend: play in real time to measure timing lateness")
    p.add_argument("--verbose", action="store_true", help="print timing lateness statistics")


def cmd_draw(args) -> int:
    from vplotter import pipeline, state
    from vplotter.trace import TraceWriter

    cfg = _config(args)
    pos, stored = _position(cfg, args.dry_run)
    summary = pipeline.Summary()
    # validation pass: the whole file, page limits and exact plot time before anything moves
    for _ in pipeline.stream(cfg, args.file, pos.counts, pos.ref_mm, args.strict,
                             emit=False, summary=summary):
        pass
    print(f"{args.file}: {summary.text()}")
    name = _backend_name(args, cfg)
    trace_file = open(args.trace, "w", encoding="utf-8") if args.trace else None
    backend = None
    try:
        options = {"realtime": True} if args.realtime else {}
        backend = _open_backend(name, cfg, **options)
        tracer = None
        if trace_file:
            tracer = TraceWriter(trace_file, backend.coil_pins, backend.pen_pin)
        last = None
        quiet = lambda msg: None  # noqa: E731  (warnings were printed by the validation pass)
        for rows in pipeline.stream(cfg, args.file, pos.counts, pos.ref_mm, args.strict, quiet):
            backend.play(rows)
            if tracer:
                tracer.write(rows)
            last = rows
        end = (int(last.steps[-1, 0]), int(last.steps[-1, 1])) if last is not None else pos.counts
        stats = backend.lateness()
        if stats:
            text = ("lateness (actual - planned change time): p50 {p50_ms:.3f} ms, "
                    "p99 {p99_ms:.3f} ms, max {max_ms:.3f} ms over {n} changes").format(**stats)
            if tracer:
                tracer.comment(text)
            if args.verbose:
                print(text)
    finally:
        if backend is not None:
            backend.close()
        if trace_file:
            trace_file.close()
    if not args.dry_run:
        new = pos.moved_to(end)
        new.pen = "up"
        state.save(new)
    return 0


def cmd_estimate(args) -> int:
    from vplotter import pipeline

    cfg = _config(args)
    pos, _ = _position(cfg, True)
    summary = pipeline.Summary()
    for _ in pipeline.stream(cfg, args.file, pos.counts, pos.ref_mm, args.strict, emit=False,
                             summary=summary):
        pass
    print(f"{args.file}: {summary.text()}")
    return 0


def _add_estimate(p) -> None:
    p.add_argument("file")
    p.add_argument("--strict", action="store_true")


# ---------------------------------------------------------------- calibrate / status
def _add_calibrate(p) -> None:
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--at", nargs=2, type=float, metavar=("X", "Y"),
                   help="the pen is now at this G-code point")
    g.add_argument("--cords", nargs=2, type=float, metavar=("LEFT", "RIGHT"),
                   help="measured cord lengths in mm (anchor to pen)")


def cmd_calibrate(args) -> int:
    import numpy as np

    from vplotter import kinematics, state

    cfg = _config(args)
    kin = kinematics.from_config(cfg)
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
    pos = state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_mm)
    state.save(pos)
    print(_describe(cfg, pos))
    return 0


def _describe(cfg, pos) -> str:
    import numpy as np

    from vplotter import kinematics

    kin = kinematics.from_config(cfg)
    xy = kin.to_gcode(kin.forward(np.array([[pos.left_mm, pos.right_mm]])))[0]
    return (f"pen at X{xy[0]:.3f} Y{xy[1]:.3f}  "
            f"cords left {pos.left_mm:.3f} mm ({pos.left_steps} steps) "
            f"right {pos.right_mm:.3f} mm ({pos.right_steps} steps)  pen {pos.pen}"
            f"{'' if pos.clean else '  (last stop was NOT clean)'}")


def cmd_status(args) -> int:
    from vplotter import state

    cfg = _config(args)
    pos = state.load()
    if pos is None:
        print("position unknown: run `vplotter calibrate --at X Y`")
        return 0
    print(_describe(cfg, pos.rebased(cfg.motors.steps_per_mm)))
    print(f"state file: {state.state_path()}")
    return 0


# ---------------------------------------------------------------- pen
def _add_pen(p) -> None:
    p.add_argument("action", choices=("up", "down"))
    p.add_argument("--dry-run", action="store_true")
    p.add_argument("--backend", choices=("lgpio", "gpiozero", "fake"))


def cmd_pen(args) -> int:
    from vplotter import state
    from vplotter.schedule import Scheduler

    cfg = _config(args)
    pos, stored = _position(cfg, True)
    sched = Scheduler(cfg, None, pos.counts, pos.ref_mm)
    sched.pen_down = args.action == "up"   # force the command to be sent
    rows = sched.pen(args.action == "down")
    backend = _open_backend(_backend_name(args, cfg), cfg)
    try:
        backend.play(rows)
    finally:
        backend.close()
    if stored and not args.dry_run:
        pos.pen = args.action
        state.save(pos)
    print(f"pen {args.action}")
    return 0


COMMANDS: dict[str, tuple[Callable, Callable, str]] = {
    "draw": (cmd_draw, _add_draw, "draw a G-code file"),
    "estimate": (cmd_estimate, _add_estimate, "validate a file and print the plot time"),
    "calibrate": (cmd_calibrate, _add_calibrate, "tell vplotter where the pen is"),
    "status": (cmd_status, lambda p: None, "print the stored position"),
    "pen": (cmd_pen, _add_pen, "lift or lower the pen"),
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
        return handler(args)
    except VplotterError as e:
        _eprint(str(e) if ": error: " in str(e) or str(e).startswith("error:")
                else f"vplotter: error: {e}")
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
