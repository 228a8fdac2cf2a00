"""Calibration commands that measure the machine.

- `calibrate steps`: measure a cord before and after a known number of steps and write the
  corrected spool_circumference_mm into config.toml, keeping its comments and layout.
- `calibrate pattern`: draw numbered marks over the page and write pattern.csv
  (calibration/pattern.py).
- `calibrate fit`: fit the machine to the distances measured between the marks
  (calibration/fit.py), write the new values into config.toml and keep the stored position
  where the pen really is.
"""

from __future__ import annotations

from pathlib import Path

from vplotter.machine import state
from vplotter.errors import ConfigError, InputError


def _ask(prompt: str) -> float:
    try:
        text = input(prompt)
    except EOFError:
        raise InputError("error: no answer (end of input); calibration cancelled") from None
    try:
        value = float(text.strip().replace(",", "."))
    except ValueError:
        raise InputError(f"error: {text.strip()!r} is not a length in mm; "
                         f"calibration cancelled") from None
    if not value > 0:
        raise InputError(f"error: a cord length must be above 0 (got {value:g})")
    return value


def write_circumference(path: str | Path, value: float, motor: str | None = None) -> str:
    """Set [motors] spool_circumference_mm in the TOML file, comments and layout kept; the
    motor's own left_/right_spool_circumference_mm instead where the file has it. Returns
    the key written."""
    import tomlkit

    p = Path(path)
    doc = tomlkit.parse(p.read_text(encoding="utf-8"))
    key = f"{motor}_spool_circumference_mm"
    if motor is None or key not in doc["motors"]:
        key = "spool_circumference_mm"
    doc["motors"][key] = round(value, 5)
    state.atomic_write(p, tomlkit.dumps(doc))
    return key


def calibrate_steps(args, cfg, command: str) -> int:
    from vplotter.machine import job
    from vplotter.motion.schedule import Scheduler

    if args.motor is None:
        raise ConfigError("error: calibrate steps needs --motor left|right")
    if not 0 < args.steps <= 100_000:
        raise ConfigError(f"error: --steps must be 1..100000 (got {args.steps})")
    if not args.dry_run:            # the plotter first: a busy one fails before any question
        from vplotter.machine import lock

        lock.acquire(command)
    m = 0 if args.motor == "left" else 1
    spu = cfg.motors.steps_per_unit
    expected = args.steps / spu[m]
    print(f"The {args.motor} cord will be lengthened by {args.steps} steps "
          f"(about {expected:.2f} mm with the configured spool_circumference_mm = "
          f"{cfg.motors.spool_circumference_mm:g}).")
    before = _ask(f"Measure the {args.motor} cord now, from where it leaves the spool to the "
                  f"pen (mm): ")
    # no stored position: the cord moves by steps and the position stays unknown (one
    # measured cord does not make one)
    pos = job.load_position(cfg, trust=True, dry_run=args.dry_run) if state.load() else None
    from vplotter.commands.common import session

    delta = [0, 0]
    delta[m] = args.steps
    with session(args, cfg, command, pos) as s:
        sched = Scheduler(cfg, None, s.counts, pos.ref_mm if pos is not None else (0.0, 0.0))
        s.play([sched.cord_move(delta)])
        moved = s.counts
    after = _ask(f"Measure the {args.motor} cord again (mm): ")
    measured = after - before
    if not 0.5 * expected <= measured <= 2.0 * expected:
        raise InputError(f"error: the cord changed by {measured:.2f} mm, expected about "
                         f"{expected:.2f} mm; check the measurements (and the motor wiring)")
    circ = cfg.motors.circumferences_mm[m] * measured / expected
    if args.dry_run:
        print(f"dry run: spool_circumference_mm would be {circ:.4f} (config not changed)")
        return 0
    key = write_circumference(args.config, circ, args.motor)
    if pos is not None:
        _store_measured(args, pos, moved, m, after)
    print(f"{args.config}: [motors] {key} = {circ:.4f} "
          f"(was {cfg.motors.circumferences_mm[m]:g}; {args.steps} steps moved the cord "
          f"{measured:.2f} mm)")
    return 0


def _store_measured(args, pos, moved, m: int, after: float) -> None:
    """The measured cord is now known exactly; count the position with the new steps/mm."""
    from vplotter import config

    new_spm = config.load(args.config).motors.steps_per_unit
    here = pos.moved_to(moved)
    cords = [here.left_mm, here.right_mm]
    cords[m] = after
    fresh = state.Position.at_cords(cords[0], cords[1], new_spm)
    fresh.extra = {k: v for k, v in here.extra.items() if k == "home"}
    state.save(fresh)


# ---------------------------------------------------------------- calibrate pattern / fit
PATTERN_NAME = "calibration pattern"


def calibrate_pattern(args, cfg, command: str) -> int:
    """Draw numbered marks over the page and write pattern.csv with the pairs to measure."""
    import numpy as np

    from vplotter import pipeline
    from vplotter.calibration import pattern
    from vplotter.commands.common import position, session, stream_rows
    from vplotter.inputs.strokes import to_records

    _vplotter_only(cfg, "pattern")
    for name, v in (("--rows", args.rows), ("--cols", args.cols)):
        if not 2 <= v <= 10:
            raise ConfigError(f"error: {name} must be 2..10 (got {v})")
    pg = cfg.page
    size = pattern.mark_size(pg)
    margin = pattern.MARGIN_MM * size if args.margin is None else args.margin
    room = pattern.room_mm(size)
    if not room <= margin < min(pg.x_max_mm - pg.x_min_mm, pg.y_max_mm - pg.y_min_mm) / 2:
        raise ConfigError(f"error: --margin must leave room for the marks: {room:g} mm or more, "
                          f"and less than half the page (got {margin:g})")
    pos = position(cfg, args, args.dry_run)
    marks = pattern.grid(pg, args.rows, args.cols, margin)
    records = list(to_records(s for m in marks for s in pattern.mark_strokes(m, size)))
    summary = pipeline.validate(cfg, records, pos.counts, pos.ref_mm, PATTERN_NAME)
    print(f"{PATTERN_NAME}: {summary.text()}")
    dots: dict[int, tuple[int, int]] = {}

    def watch(chunks):
        # the first pen-down of each mark (rows carry the mark id as their line) is its dot
        for rows in chunks:
            for i in np.flatnonzero(rows.pen_us == cfg.pen.down_us):
                dots.setdefault(int(rows.line[i]), (int(rows.steps[i, 0]), int(rows.steps[i, 1])))
            yield rows

    with session(args, cfg, command, pos) as s:
        s.play(watch(stream_rows(cfg, records, pos, PATTERN_NAME)))
    for m in marks:
        m.steps = dots[m.id]
    spu = pos.steps_per_unit
    ref = pos.ref_mm
    pat = pattern.Pattern({m.id: m for m in marks}, pattern.choose_pairs(args.rows, args.cols),
                          {"left_mm": ref[0], "right_mm": ref[1],
                           "left_steps_per_mm": spu[0], "right_steps_per_mm": spu[1]})
    output = args.output or "pattern.csv"
    pattern.write(output, pat)
    pairs = ", ".join(f"{p.a}-{p.b}" for p in pat.pairs)
    print(f"{output}: {len(marks)} marks, {len(pat.pairs)} pairs to measure\n"
          f"Now, with a tape measure or a long ruler, measure the distance between the centres "
          f"of the dots (inside the small circles, next to their numbers) of each of these pairs "
          f"of marks, in mm, to a few tenths of a mm if you can:\n  {pairs}\n"
          f"Write each distance into the distance_mm column of that pair's row in "
          f"{output} (any spreadsheet or text editor; rows left empty are skipped), "
          f"do not move the pen or the cords meanwhile, then run:\n"
          f"  vplotter calibrate fit {output}")
    return 0


def _vplotter_only(cfg, what: str) -> None:
    if cfg.machine.kind != "vplotter":
        raise ConfigError(f"error: calibrate {what} measures a V-plotter's cords and anchors; "
                          f"this is a {cfg.machine.kind} machine")


def _machine_from(cfg, reference):
    from vplotter.calibration import fit

    m = cfg.motors
    left, right = m.circumferences_mm
    return fit.Machine(cfg.machine.anchor_distance_mm, reference[0], reference[1], left, right,
                       cfg.cords.stretch, cfg.gondola.cord_spacing_mm, cfg.gondola.pen_below_mm,
                       m.steps_per_rev, cfg.gondola.mass_below_pen_mm,
                       cfg.cords.sag_per_mm(cfg.gondola))


UNITS = {"anchor_distance_mm": ("mm", 3), "cord_spacing_mm": ("mm", 3), "ref_left_mm": ("mm", 3),
         "ref_right_mm": ("mm", 3), "left_circumference_mm": ("mm", 4),
         "right_circumference_mm": ("mm", 4), "stretch": ("", 5),
         "mass_below_pen_mm": ("mm", 2), "pen_below_mm": ("mm", 3)}


def calibrate_fit(args, cfg, command: str) -> int:
    """Fit the machine to the measured distances; write config.toml and the stored position."""
    from vplotter.calibration import fit, pattern

    _vplotter_only(cfg, "fit")
    if not args.file:
        raise ConfigError("error: calibrate fit needs the pattern file: "
                          "vplotter calibrate fit pattern.csv")
    pat = pattern.read(args.file)
    measured = [p for p in pat.pairs if p.distance_mm is not None]
    fit_mass = bool(getattr(args, "fit_mass", False))
    keys = fit.names(args.fit_spacing, fit_mass)
    need = fit.min_pairs(len(keys))
    if len(measured) < need:
        raise InputError(f"{args.file}: error: {len(measured)} pairs measured; fitting "
                         f"{len(keys)} parameters needs at least {need}: measure "
                         f"{need - len(measured)} more (the pair rows of the file have room "
                         f"for them)")
    stored = state.load()
    reference = _reference(args.file, pat.reference, stored)
    old = _machine_from(cfg, reference)
    res, good = _fitted(args, old, pat, measured, need, fit_mass)
    if fit_mass and not fit.mass_told(res):
        print(fit.mass_untold(res, old.mass_below_pen_mm))
        keys = fit.names(args.fit_spacing)
        res, good = _fitted(args, old, pat, measured, need, False, say=False)
    new = _rounded(res.machine, keys)
    home, origin = _origin(cfg, reference, new)
    _report(args, cfg, old, new, res, keys, measured, good, home, origin)
    path = Path(args.config)
    text = _config_text(path, args.fit_spacing, new, origin, "mass_below_pen_mm" in keys)
    if args.dry_run:
        print(f"dry run: {path} and the stored position not changed")
        return 0
    return store(command, path, text, stored, pat.reference, new, home, origin)


def store(command: str, path: Path, text: str, stored, reference: dict, new, home,
          origin) -> int:
    """Write config.toml's new text and keep the stored position where the pen really is
    (`calibrate fit` and `calibrate photo`)."""
    import numpy as np

    from vplotter.machine import lock

    held = lock.acquire(command)
    try:
        state.atomic_write(path, text)
        print(f"{path}: written (comments and layout kept)")
        if stored is None or not stored.clean or not _same_reference(stored, reference):
            print("the stored position was not kept (no position, an unclean stop, or calibrated "
                  "again since the pattern was drawn): put the pen on a known point and run "
                  "`vplotter calibrate --at X Y`")
            return 0
        cords = new.cords(np.array(stored.counts, dtype=float))
        pos = state.Position.at_cords(cords[0], cords[1], new.steps_per_unit())
        pos.pen = stored.pen
        pos.extra["home"] = [float(home[0]), float(home[1])]
        state.save(pos)
        state.clear_journal()
    finally:
        held.release()
    xy = new.kin(origin).to_gcode(new.kin(origin).forward(cords[None, :]))[0]
    print(f"stored position updated: the pen is at X{xy[0]:.3f} Y{xy[1]:.3f} "
          f"(cords {cords[0]:.3f} and {cords[1]:.3f} mm); the next draw starts from there")
    return 0


def _reference(file: str, ref: dict, stored) -> tuple:
    """The cord lengths at the reference point when the pattern was drawn: the pattern file's
    reference line, else the stored position's."""
    if {"left_mm", "right_mm"} <= ref.keys():
        return (ref["left_mm"], ref["right_mm"])
    if stored is not None:
        return stored.ref_mm
    raise InputError(f"{file}: error: no reference line and no stored position: "
                     f"draw the pattern again")


def _fitted(args, old, pat, measured: list, need: int, fit_mass: bool = False,
            say: bool = True):
    """(the fit, how many pairs it used): the outliers it left out are said, and a fit on too
    few pairs, or whose pairs do not fit together, is refused."""
    import numpy as np

    from vplotter.calibration import fit

    ids = sorted(pat.marks)
    index = {k: i for i, k in enumerate(ids)}
    steps = np.array([pat.marks[k].steps for k in ids], dtype=float)
    a = np.array([index[p.a] for p in measured])
    b = np.array([index[p.b] for p in measured])
    dist = np.array([p.distance_mm for p in measured])
    res, outliers = fit.fit(old, steps, a, b, dist, args.fit_spacing, fit_mass)
    for k in outliers if say else ():
        p = measured[k]
        r = res.residual_mm[k]
        print(f"{p.where}: pair {p.a}-{p.b}: measured {p.distance_mm:.2f} mm, the fit says "
              f"{p.distance_mm + r:.2f} mm ({r:+.2f} mm): an outlier, left out (a typo, or two "
              f"rows swapped?)")
    good = int(res.used.sum())
    if good < need:
        raise InputError(f"{args.file}: error: only {good} of {len(measured)} measured pairs fit "
                         f"together; the fit needs at least {need}: check the outliers above "
                         f"and measure them again")
    if not res.rms_mm <= fit.RMS_MAX_MM:
        raise InputError(f"{args.file}: error: the {good} measured pairs left do not fit "
                         f"together (they are {res.rms_mm:.1f} mm off on average, a tape "
                         f"measure does better than {fit.RMS_MAX_MM:g} mm): check the "
                         f"measurements and the mark numbers")
    return res, good


def _rounded(machine, keys):
    """The fitted values as they will be written (everything else is computed from them)."""
    import dataclasses

    new = dataclasses.replace(machine, **{
        k: round(getattr(machine, k), 5 if k == "stretch" else 4) for k in keys})
    if new.stretch < 0:
        new = dataclasses.replace(new, stretch=0.0)
    return new


def _origin(cfg, reference, new):
    """(the calibrated point in G-code mm with the old values, the new [origin] that keeps
    the pen there)."""
    import numpy as np

    from vplotter import kinematics

    kin_old = kinematics.from_config(cfg)
    home = kin_old.to_gcode(kin_old.forward(np.array([reference])))[0]
    here = new.kin().forward(np.array([[new.ref_left_mm, new.ref_right_mm]]))[0]
    return home, (round(float(here[0] - home[0]), 4), round(float(here[1] + home[1]), 4))


def _report(args, cfg, old, new, res, keys, measured, good, home, origin) -> None:
    """The old and new values, the residuals and how much straight lines bent before and
    bend now."""
    print(f"{'parameter':<24}{'old':>12}{'new':>12}{'uncertainty':>14}")
    for k, sig in zip(keys, res.sigma):
        unit, dec = UNITS[k]
        was = getattr(old, k)
        was = f"{was:>12.{dec}f}" if was is not None else f"{'unset':>12}"
        print(f"{k:<24}{was}{getattr(new, k):>12.{dec}f}{'±':>6}{sig:.{dec}f} {unit}")
    print(f"{'origin (x_mm, y_mm)':<24}{cfg.origin.x_mm:>6.2f},{cfg.origin.y_mm:.2f}"
          f"{origin[0]:>6.2f},{origin[1]:.2f}  (keeps the calibrated point at "
          f"X{home[0]:.3f} Y{home[1]:.3f})")
    print(f"residuals (fit - measured), rms {res.rms_mm:.2f} mm over {good} pairs:")
    for p, r, used in zip(measured, res.residual_mm, res.used):
        print(f"  {p.a:>3}-{p.b:<3} {p.distance_mm:9.2f} mm  {r:+7.2f}"
              f"{'' if used else '  (left out)'}")
    print_bends(cfg, old, new, res, origin)
    if args.fit_spacing:
        print("note: the drawing depends only on anchor_distance_mm - cord_spacing_mm; "
              "anchor_distance_mm was kept")


def _config_text(path: Path, fit_spacing: bool, new, origin, fit_mass: bool = False,
                 fit_gondola: bool = False) -> str:
    """config.toml with the new values (comments and layout kept; `fit_gondola`: the cord
    spacing and pen offset too, as `calibrate photo` fits them); refused if it would not
    load."""
    import tomllib

    import tomlkit

    from vplotter import config

    doc = tomlkit.parse(path.read_text(encoding="utf-8"))
    if fit_spacing:
        doc.setdefault("gondola", tomlkit.table())["cord_spacing_mm"] = new.cord_spacing_mm
    else:
        doc["machine"]["anchor_distance_mm"] = new.anchor_distance_mm
    doc["origin"]["x_mm"], doc["origin"]["y_mm"] = origin
    doc["motors"]["left_spool_circumference_mm"] = new.left_circumference_mm
    doc["motors"]["right_spool_circumference_mm"] = new.right_circumference_mm
    doc.setdefault("cords", tomlkit.table())["stretch"] = new.stretch
    if fit_mass or fit_gondola:
        gondola = doc.setdefault("gondola", tomlkit.table())
        for key in ("cord_spacing_mm", "pen_below_mm")[:2 * fit_gondola]:
            gondola[key] = getattr(new, key)
        if fit_mass:
            gondola["mass_below_pen_mm"] = new.mass_below_pen_mm
    text = tomlkit.dumps(doc)
    config.from_dict(tomllib.loads(text), str(path))     # refuse a config that would not load
    return text


def _same_reference(pos, reference: dict) -> bool:
    if not reference:
        return True
    want = (reference.get("left_mm"), reference.get("right_mm"),
            reference.get("left_steps_per_mm"), reference.get("right_steps_per_mm"))
    have = (*pos.ref_mm, *pos.steps_per_unit)
    return all(w is None or abs(w - h) <= 1e-5 * max(1.0, abs(h)) for w, h in zip(want, have))


def _spread(m, res):
    """The fitted machine moved one standard deviation along each principal axis of the
    fit's covariance (both ways): what the fit cannot tell apart from it."""
    import dataclasses

    import numpy as np

    out = [m]
    if not np.all(np.isfinite(res.cov)):
        return out
    w, v = np.linalg.eigh(res.cov)
    for val, vec in zip(w, v.T):
        for sgn in (1, -1):
            step = sgn * np.sqrt(max(val, 0.0)) * vec
            out.append(dataclasses.replace(m, **{k: getattr(m, k) + d
                                                 for k, d in zip(res.names, step)}))
    return out


def print_bends(cfg, old, new, res, origin) -> None:
    """How much a 300 mm line through the page centre bends with the old values and with the
    new (both routes, ruler and photo, report it)."""
    from vplotter.calibration import fit

    pg = cfg.page
    cx, cy = (pg.x_min_mm + pg.x_max_mm) / 2, (pg.y_min_mm + pg.y_max_mm) / 2
    spread = _spread(new, res)
    for label, a_g, b_g in (("horizontal", (cx - 150, cy), (cx + 150, cy)),
                            ("vertical", (cx, cy - 150), (cx, cy + 150))):
        before = fit.line_bend_mm(old, new, (cfg.origin.x_mm, cfg.origin.y_mm), a_g, b_g)
        after = max(fit.line_bend_mm(new, t, origin, a_g, b_g) for t in spread)
        print(f"a 300 mm {label} line through the page centre bends {before:.2f} mm with the old "
              f"values, {after:.2f} mm with the new (within the fit's uncertainty)")

