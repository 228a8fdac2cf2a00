"""`vplotter calibrate steps`: measure a cord before and after a known number of steps and
write the corrected spool_circumference_mm into config.toml, keeping its comments and layout.
"""

from __future__ import annotations

from pathlib import Path

from vplotter import state
from vplotter.errors import ConfigError, InputError


def _ask(prompt: str) -> float:
    try:
        text = input(prompt)
    except EOFError:
        raise InputError("error: no answer (end of input); calibration cancelled") from None
    try:
        value = float(text.strip().replace(",", "."))
    except ValueError:
        raise InputError(f"error: {text.strip()!r} is not a length in mm; calibration cancelled") from None
    if not value > 0:
        raise InputError(f"error: a cord length must be above 0 (got {value:g})")
    return value


def write_circumference(path: str | Path, value: float) -> None:
    """Set [motors] spool_circumference_mm in the TOML file, comments and layout kept."""
    import tomlkit

    p = Path(path)
    doc = tomlkit.parse(p.read_text(encoding="utf-8"))
    doc["motors"]["spool_circumference_mm"] = round(value, 5)
    state.atomic_write(p, tomlkit.dumps(doc))


def calibrate_steps(args, cfg, command: str) -> int:
    from vplotter import job
    from vplotter.schedule import Scheduler

    if args.motor is None:
        raise ConfigError("error: calibrate steps needs --motor left|right")
    if not 0 < args.steps <= 100_000:
        raise ConfigError(f"error: --steps must be 1..100000 (got {args.steps})")
    if not args.dry_run:            # the plotter first: a busy one fails before any question
        from vplotter import lock

        lock.acquire(command)
    m = 0 if args.motor == "left" else 1
    spu = cfg.motors.steps_per_unit
    expected = args.steps / spu[m]
    print(f"The {args.motor} cord will be lengthened by {args.steps} steps "
          f"(about {expected:.2f} mm with the configured spool_circumference_mm = "
          f"{cfg.motors.spool_circumference_mm:g}).")
    before = _ask(f"Measure the {args.motor} cord now, from where it leaves the spool to the pen (mm): ")
    pos = job.load_position(cfg, trust=True, dry_run=args.dry_run) if state.load() else None
    if pos is None:
        pos = state.Position.at_cords(before, before, spu)
    from vplotter.commands.common import session

    delta = [0, 0]
    delta[m] = args.steps
    with session(args, cfg, command, pos) as s:
        sched = Scheduler(cfg, None, s.counts, pos.ref_mm)
        s.play([sched.cord_move(delta)])
        moved = s.counts
    after = _ask(f"Measure the {args.motor} cord again (mm): ")
    measured = after - before
    if not 0.5 * expected <= measured <= 2.0 * expected:
        raise InputError(f"error: the cord changed by {measured:.2f} mm, expected about "
                         f"{expected:.2f} mm; check the measurements (and the motor wiring)")
    circ = cfg.motors.spool_circumference_mm * measured / expected
    if args.dry_run:
        print(f"dry run: spool_circumference_mm would be {circ:.4f} (config not changed)")
        return 0
    write_circumference(args.config, circ)
    # the measured cord is now known exactly; count the position with the new steps/mm
    new_spm = cfg.motors.steps_per_rev / circ
    here = pos.moved_to(moved)
    cords = [here.left_mm, here.right_mm]
    cords[m] = after
    fresh = state.Position.at_cords(cords[0], cords[1], new_spm)
    fresh.extra = {k: v for k, v in here.extra.items() if k == "home"}
    state.save(fresh)
    print(f"{args.config}: [motors] spool_circumference_mm = {circ:.4f} "
          f"(was {cfg.motors.spool_circumference_mm:g}; {args.steps} steps moved the cord "
          f"{measured:.2f} mm)")
    return 0
