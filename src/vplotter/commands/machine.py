"""The machine commands: calibrate, pen, jog, goto, home (status is in commands/live.py)."""

from __future__ import annotations

from dataclasses import dataclass

from vplotter.commands.common import (add_machine_options, answering, check_on_page,
                                      command_line, eprint, load_config, moves_to, position,
                                      position_if_stored, run_records, session)
from vplotter.errors import ConfigError, MachineError


def add_calibrate(p) -> None:
    p.add_argument("what", nargs="?", choices=("steps", "pattern", "fit", "photo"),
                   help="`steps`: measure steps per mm by moving one motor; `pattern`: draw "
                        "numbered marks to measure; `fit`: fit the machine to the measurements; "
                        "`photo`: fit it to photos of the marks")
    p.add_argument("file", nargs="?", help="with `fit`: the pattern file with the distances; "
                                           "with `photo`: the photo")
    p.add_argument("photos", nargs="*", help="with `photo`: more photos of the same marks")
    p.add_argument("--pattern", metavar="FILE", help="with `photo`: the pattern's pattern.csv")
    p.add_argument("--distance", nargs=3, action="append", metavar=("I", "J", "MM"),
                   help="with `photo`: marks I and J are MM apart (tape measure); repeatable")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--at", nargs=2, type=float, metavar=("X", "Y"),
                   help="the pen is now at this G-code point")
    g.add_argument("--cords", nargs=2, type=float, metavar=("LEFT", "RIGHT"),
                   help="measured cord lengths in mm (anchor to pen)")
    p.add_argument("--motor", choices=("left", "right"), help="with `steps`: the motor to move")
    p.add_argument("--steps", type=int, default=2000, help="with `steps`: how many (default 2000)")
    p.add_argument("--rows", type=int, default=4, help="with `pattern`: rows of marks (default 4)")
    p.add_argument("--cols", type=int, default=4, help="with `pattern`: columns (default 4)")
    p.add_argument("--margin", type=float, metavar="MM",
                   help="with `pattern`: marks this far inside the page (default 25; more on "
                        "a page over 600 mm, whose marks are larger)")
    p.add_argument("-o", "--output",
                   help="with `pattern`: the file to write (default pattern.csv); with "
                        "`photo`: a picture of the marks found (found.png)")
    p.add_argument("--fit-spacing", action="store_true",
                   help="with `fit`: fit [gondola] cord_spacing_mm instead of the anchor distance")
    p.add_argument("--fit-mass", action="store_true",
                   help="with `fit`: fit the gondola's centre of mass ([gondola] "
                        "mass_below_pen_mm: the gondola tilts); `photo` fits it by default "
                        "wherever the photos can tell it")
    add_machine_options(p)


def cmd_calibrate(args, argv=None) -> int:
    import math

    import numpy as np

    from vplotter import kinematics
    from vplotter.machine import lock, state

    cfg = load_config(args)
    if args.what == "steps":
        from vplotter.commands.calibrate import calibrate_steps

        if cfg.machine.kind == "polar":
            raise ConfigError("error: `calibrate steps` measures a cord; on the polar plotter set "
                              "[motors] rotary_steps_per_deg and linear_steps_per_mm from the "
                              "gearing and the drivers' microsteps")

        return calibrate_steps(args, cfg, command_line(argv))
    if args.what in ("pattern", "fit"):
        from vplotter.commands import calibrate

        run = calibrate.calibrate_pattern if args.what == "pattern" else calibrate.calibrate_fit
        return run(args, cfg, command_line(argv))
    if args.what == "photo":
        from vplotter.commands.calibrate_photo import calibrate_photo

        return calibrate_photo(args, cfg, command_line(argv))
    if args.at is None and args.cords is None:
        raise ConfigError("error: say where the pen is: --at X Y or --cords LEFT RIGHT "
                          "(or `calibrate steps --motor left`)")
    kin = kinematics.from_config(cfg)
    values = args.at if args.at is not None else args.cords
    if not all(math.isfinite(v) and abs(v) < 1e5 for v in values):
        raise ConfigError(f"error: {' '.join(f'{v:g}' for v in values)} "
                          f"is not a position on a wall")
    if cfg.machine.kind == "polar":
        cords = _polar_cords(cfg, kin, args)
    elif args.at is not None:
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
    held = lock.acquire(command_line(argv))
    try:
        pos = state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_unit)
        if cfg.machine.kind != "vplotter":
            pos.extra["machine"] = cfg.machine.kind
        pos.extra["home"] = [float(v) for v in kin.to_gcode(kin.forward(cords[None, :]))[0]]
        state.save(pos)
        state.clear_journal()
    finally:
        held.release()
    print(_describe(cfg, pos))
    return 0


def _polar_cords(cfg, kin, args):
    """Polar: --at X Y (the table angle that puts that paper point under the pen, in
    -180..180) or --cords ANGLE RADIUS (the motor coordinates: --cords 0 R makes the table's
    angle 0 where it stands)."""
    import numpy as np

    if args.at is not None:
        cords = kin.inverse(kin.to_machine(np.array([args.at])))[0]
    else:
        cords = np.array(args.cords, dtype=float)
    p = cfg.polar
    if not p.radius_min_mm <= cords[1] <= p.radius_max_mm:
        raise MachineError(f"error: the pen cannot be {cords[1]:g} mm from the table's centre "
                           f"(the arm reaches {p.radius_min_mm:g}..{p.radius_max_mm:g} mm)")
    return cords


def _pen_xy(cfg, pos):
    from vplotter.commands import jog

    return jog.pen_xy(cfg, pos, pos.counts)


def _describe(cfg, pos) -> str:
    xy = _pen_xy(cfg, pos) + 0.0     # no "-0.000"
    xy[abs(xy) < 5e-4] = 0.0
    if cfg.machine.kind == "polar":
        return (f"pen at X{xy[0]:.3f} Y{xy[1]:.3f}  "
                f"table {pos.left_mm:.3f} deg ({pos.left_steps} steps) "
                f"arm {pos.right_mm:.3f} mm ({pos.right_steps} steps)  pen {pos.pen}")
    return (f"pen at X{xy[0]:.3f} Y{xy[1]:.3f}  "
            f"cords left {pos.left_mm:.3f} mm ({pos.left_steps} steps) "
            f"right {pos.right_mm:.3f} mm ({pos.right_steps} steps)  pen {pos.pen}")


def add_pen(p) -> None:
    p.add_argument("action", choices=("up", "down", "cycle"))
    p.add_argument("--up-us", type=int, help="try this pen-up pulse width (us) instead of config")
    p.add_argument("--down-us", type=int, help="try this pen-down pulse width (us)")
    p.add_argument("--hold", type=float, default=1.0,
                   help="cycle: seconds to stay down (default 1)")
    add_machine_options(p)


@dataclass(frozen=True)
class PenMoved:
    """`vplotter pen ACTION`: the pen was lifted (up), lowered (down) or both (cycle)."""

    action: str

    @property
    def message(self) -> str:
        return f"pen {self.action}"


def cmd_pen(args, argv=None) -> int:
    with answering() as answer:
        moved = move_pen(args, argv)
        print(moved.message)
        answer(moved)
    return 0


def move_pen(args, argv=None) -> PenMoved:
    import dataclasses

    from vplotter.motion.schedule import Rows, Scheduler

    cfg = load_config(args)
    for name in ("up_us", "down_us"):
        v = getattr(args, name)
        if v is not None:
            if not 0 < v <= 2600:
                raise ConfigError(f"error: --{name.replace('_', '-')} must be 1..2600 (got {v})")
            cfg = dataclasses.replace(cfg, pen=dataclasses.replace(cfg.pen, **{name: v}))
    # the pen needs no position: the motors stand, and a stored position keeps all but the
    # pen's state (machine/ledger.py); none stored, none is made. A corrupt one is said
    # before anything moves (the lock first, as for every mover).
    position_if_stored(cfg, args, check_only=True)
    sched = Scheduler(cfg, None, (0, 0), (0.0, 0.0))
    if args.action == "up":
        sched.pen_down = True       # always send it: the servo may be anywhere
        parts = [sched.pen(False)]
    elif args.action == "down":
        parts = [sched.pen(True)]
    else:
        parts = [sched.pen(True), sched.dwell(args.hold), sched.pen(False)]
    rows = Rows.concat([r for r in parts if r is not None])
    with session(args, cfg, command_line(argv), None, pen_only=True) as s:
        s.play([rows])
    return PenMoved(args.action)


def add_jog(p) -> None:
    p.add_argument("--dx", type=float, help="move the pen right by this many mm (- for left)")
    p.add_argument("--dy", type=float, help="move the pen up by this many mm (- for down)")
    p.add_argument("--left", type=float, help="lengthen the left cord by mm (- shortens)")
    p.add_argument("--right", type=float, help="lengthen the right cord by mm (- shortens)")
    p.add_argument("--step", type=float, default=1.0, help="interactive: first step size in mm")
    add_machine_options(p)


@dataclass(frozen=True)
class Jogged:
    """`vplotter jog --dx/--dy`: the G-code point the pen was moved to (the command says
    nothing)."""

    x: float
    y: float

    @property
    def message(self) -> str:
        return ""


def cmd_jog(args, argv=None) -> int:
    with answering() as answer:
        if args.dx is not None or args.dy is not None:
            answer(jog_by(args, argv))
            return 0
        return _jog_other(args, argv)


def jog_by(args, argv=None) -> Jogged:
    """jog --dx/--dy: move the pen (as it is, up or down) by dx, dy mm on the page."""
    cfg = load_config(args)
    pos = position(cfg, args, args.dry_run)
    if args.left is not None or args.right is not None:
        raise ConfigError("error: jog takes --dx/--dy or --left/--right, not both")
    xy = _pen_xy(cfg, pos)
    target = (float(xy[0]) + (args.dx or 0.0), float(xy[1]) + (args.dy or 0.0))
    check_on_page(cfg, *target, "jog target")
    run_records(args, cfg, command_line(argv), pos, moves_to(cfg, pos, target))
    return Jogged(*target)


def _jog_other(args, argv) -> int:
    """jog --left/--right (the cords: no position needed; a stored one follows the cords,
    none stays unknown), or the arrow keys (they need the position)."""
    from vplotter.commands import jog

    cfg = load_config(args)
    if args.left is not None or args.right is not None:
        pos = position_if_stored(cfg, args)
        with session(args, cfg, command_line(argv), pos) as s:
            s.play([jog.cord_rows(cfg, pos, s.counts, args.left or 0.0, args.right or 0.0)])
        if pos is None:
            eprint("note: the pen position stays unknown; once the pen is on a known point, "
                   "run `vplotter calibrate --at X Y`")
        return 0
    pos = position(cfg, args, args.dry_run)
    return jog.interactive(args, cfg, pos, session(args, cfg, command_line(argv), pos))


def add_goto(p) -> None:
    p.add_argument("x", type=float)
    p.add_argument("y", type=float)
    add_machine_options(p)


def cmd_goto(args, argv=None) -> int:
    cfg = load_config(args)
    check_on_page(cfg, args.x, args.y, "goto target")
    pos = position(cfg, args, args.dry_run)
    return run_records(args, cfg, command_line(argv), pos, moves_to(cfg, pos, (args.x, args.y)))


def cmd_home(args, argv=None) -> int:
    cfg = load_config(args)
    if cfg.machine.kind == "polar":
        from vplotter.commands.home import home_polar

        if cfg.polar.home_pin is None:
            raise ConfigError(f"{cfg.path}: [polar] home_pin is missing: `home` needs the arm's "
                              f"end switch")
        return home_polar(args, cfg, command_line(argv))
    pos = position(cfg, args, args.dry_run)
    home = pos.extra.get("home", (0.0, 0.0))
    return run_records(args, cfg, command_line(argv), pos, moves_to(cfg, pos, tuple(home)))

