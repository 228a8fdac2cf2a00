"""`vplotter calibrate photo PHOTO... --pattern pattern.csv --distance I J MM`: the wall fit
from phone photos of the drawn pattern and a tape-measured distance (calibration/photo*.py).

Every photo is checked (every mark found and numbered) before anything is fitted; the fit is
checked (its marks agree within RMS_MAX_MM) before anything is written; then config.toml and
the stored position are written exactly as `calibrate fit` writes them (commands/calibrate).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vplotter.errors import ConfigError, InputError

RMS_MAX_MM = 0.3            # a photo's marks agree far better: a different pattern, moved pen
TAPE_MAX_MM = 3.0           # a tape distance this far off the photos: a wrong mark number
# where the fit of a gondola config.toml does not describe starts: cords 30 mm apart, the
# pen 10 mm below them (and the centre of mass fit.MASS_START_MM below the pen)
GONDOLA_START_MM = (30.0, 10.0)
# evaluations per parameter and solve for a fit with the tilt: a tilting gondola converges in
# fewer; a level one runs its centre of mass off towards infinity (and the time with it)
TILT_EVALUATIONS = 4        # (the fit without the tilt, to compare with, too)
MASS_MAX_MM = 1000.0        # a centre of mass further below: the gondola barely turns
TILT_GAIN = 0.8             # the marks' rms with the tilt below this share of it without


def _distances(args, pat) -> list[tuple[int, int, float]]:
    if not args.distance:
        raise ConfigError("error: calibrate photo needs at least one tape-measured distance "
                          "between two marks, the scale no photo gives: --distance 1 16 MM "
                          "(two far-apart marks, dot centre to dot centre)")
    out = []
    for i, j, mm in args.distance:
        try:
            a, b, d = int(i), int(j), float(mm.replace(",", "."))
        except ValueError:
            raise ConfigError(f"error: --distance {i} {j} {mm}: two mark numbers and a length "
                              f"in mm") from None
        for k in (a, b):
            if k not in pat.marks:
                raise ConfigError(f"error: --distance {i} {j} {mm}: there is no mark {k} in "
                                  f"{args.pattern}")
        if a == b or not 0 < d < 1e5:
            raise ConfigError(f"error: --distance {i} {j} {mm}: two different marks and a "
                              f"length above 0 mm")
        out.append((a, b, d))
    return out


def _photos(args) -> list[str]:
    photos = [p for p in [args.file, *(args.photos or [])] if p]
    if not photos:
        raise ConfigError("error: calibrate photo needs the photo of the drawn pattern: "
                          "vplotter calibrate photo PHOTO.jpg --pattern pattern.csv "
                          "--distance 1 16 MM")
    if not args.pattern:
        raise ConfigError("error: calibrate photo needs --pattern pattern.csv (the file "
                          "`calibrate pattern` wrote when it drew the marks)")
    return photos


def _found_path(output: str, i: int) -> Path:
    p = Path(output)
    return p if i == 0 else p.with_name(f"{p.stem}-{i + 1}{p.suffix}")


def _seen(args, photos, ids, page_xy):
    """Every photo loaded and its marks located, or the one-line error (found.png written
    first, showing what was found); the photos and where their marks are."""
    import numpy as np

    from vplotter.calibration import photo, photo_fit, photo_load

    seen, pictures = [], []
    for i, name in enumerate(photos):
        ph = photo_load.load(name)
        loc = photo.locate(ph, ids, page_xy)
        if loc.error:
            if args.output:
                photo.draw_found(ph, loc, _found_path(args.output, i))
            raise InputError(loc.error)
        px = np.array([loc.px[k] for k in ids])
        seen.append(photo_fit.Seen(name, np.arange(len(ids)), px, ph.centre, ph.focal_px))
        if args.output:                   # the photo is kept only to draw found.png
            pictures.append((ph, loc))
    return seen, pictures


def calibrate_photo(args, cfg, command: str) -> int:
    import numpy as np

    from vplotter.calibration import pattern, photo
    from vplotter.commands import calibrate as cal
    from vplotter.machine import state

    cal._vplotter_only(cfg, "photo")
    photos = _photos(args)
    pat = pattern.read(args.pattern)
    tapes = _distances(args, pat)
    ids = sorted(pat.marks)
    index = {k: i for i, k in enumerate(ids)}
    page_xy = np.array([[pat.marks[k].x_mm, pat.marks[k].y_mm] for k in ids])
    steps = np.array([pat.marks[k].steps for k in ids], dtype=float)
    stored = state.load()
    reference = cal._reference(args.pattern, pat.reference, stored)
    old = cal._machine_from(cfg, reference)
    seen, pictures = _seen(args, photos, ids, page_xy)
    tape_rows = np.array([[index[a], index[b], d] for a, b, d in tapes], dtype=float)
    with np.errstate(all="ignore"):         # a fit trying a gondola that tips over
        res, gondola = _fit(args, old, steps, seen, tape_rows)
    keys = res.names
    if args.output:
        for i, ((ph, loc), r) in enumerate(zip(pictures, res.residual_mm)):
            out = _found_path(args.output, i)
            photo.draw_found(ph, loc, out, dict(zip(ids, np.hypot(*r.T))))
            print(f"{out}: the marks found in {ph.name}, numbered, with their residuals (mm)")
    del pictures
    _check(args, res, tapes)
    new = cal._rounded(res.machine, keys)
    home, origin = cal._origin(cfg, reference, new)
    _report(cfg, photos, cal._machine_from(cfg, reference), new, res, ids, tapes, home, origin)
    path = Path(args.config)
    text = cal._config_text(path, args.fit_spacing, new, origin,
                            "mass_below_pen_mm" in keys, gondola)
    if args.dry_run:
        print(f"dry run: {path} and the stored position not changed")
        return 0
    return cal.store(command, path, text, stored, pat.reference, new, home, origin)


def _fit(args, old, steps, seen, tape_rows):
    """(the joint fit, whether it fitted the gondola's shape): where the gondola's tilt can
    matter, the machine with its centre of mass; where config.toml does not say where the
    cords hold the gondola (no [gondola]), with its cord spacing and pen offset too (the
    marks of a photo tell them, thirty distances do not): first with the centre of mass only,
    the gondola held at GONDOLA_START_MM, then all of it. Kept where the photos tell it;
    else one line says so and the machine is fitted as `calibrate fit` fits it."""
    import dataclasses

    from vplotter.calibration import fit, photo_fit

    level = fit.names(args.fit_spacing)
    # to compare with: a level fit of a tilting gondola would take long to give up
    base = photo_fit.fit(old, level, steps, seen, tape_rows, TILT_EVALUATIONS)
    gondola = old.cord_spacing_mm == 0 and old.pen_below_mm == 0
    keys = fit.names(args.fit_spacing, True)
    start = dataclasses.replace(old, mass_below_pen_mm=(
        fit.MASS_START_MM if old.mass_below_pen_mm is None else old.mass_below_pen_mm))
    if gondola:
        start = dataclasses.replace(start, cord_spacing_mm=GONDOLA_START_MM[0],
                                    pen_below_mm=GONDOLA_START_MM[1])
    tilt = None
    try:
        with np.errstate(all="ignore"):
            tilt = photo_fit.fit(start, keys, steps, seen, tape_rows, TILT_EVALUATIONS)
            if gondola and _told(tilt, base, False):    # a level gondola runs off before
                keys = (("cord_spacing_mm",) * (not args.fit_spacing) + keys[:-1]
                        + ("pen_below_mm",) + keys[-1:])
                tilt = photo_fit.fit(tilt.machine, keys, steps, seen, tape_rows,
                                     TILT_EVALUATIONS)
    except (np.linalg.LinAlgError, ValueError):
        tilt = None
    if tilt is not None and _told(tilt, base, gondola):
        return tilt, gondola
    if tilt is None:
        print("note: the photos cannot tell where the gondola's centre of mass is (the fit "
              "with it did not converge): kept as config.toml has it")
    elif gondola and "pen_below_mm" in tilt.names:
        m, sig = tilt.machine, dict(zip(tilt.names, tilt.sigma))
        print(f"note: the photos cannot tell how the gondola tilts (cord_spacing_mm "
              f"{m.cord_spacing_mm:.1f} ± {sig['cord_spacing_mm']:.1f}, pen_below_mm "
              f"{m.pen_below_mm:.1f} ± {sig['pen_below_mm']:.1f}, mass_below_pen_mm "
              f"{m.mass_below_pen_mm:.1f} ± {sig['mass_below_pen_mm']:.1f} mm): kept as "
              f"config.toml has it (level); measure where the cords hold it instead")
    else:
        print(fit.mass_untold(tilt, old.mass_below_pen_mm).replace("measurements", "photos"))
    return photo_fit.fit(base.machine, level, steps, seen, tape_rows), False


def _told(tilt, base, gondola: bool) -> bool:
    """The fit with the tilt is kept: its marks fit clearly better than the fit without
    (TILT_GAIN), its centre of mass is told (fit.mass_told) and, where the gondola was
    fitted, its cord spacing is positive and told, its pen offset too."""
    from vplotter.calibration import fit

    if not (np.all(np.isfinite(tilt.sigma)) and tilt.rms_mm < TILT_GAIN * base.rms_mm
            and fit.mass_told(tilt) and tilt.machine.mass_below_pen_mm < MASS_MAX_MM):
        return False
    if not gondola:
        return True
    sig = dict(zip(tilt.names, tilt.sigma))
    m = tilt.machine
    return bool(m.cord_spacing_mm > 4 * sig["cord_spacing_mm"] and sig["pen_below_mm"] < 5.0)


def _check(args, res, tapes) -> None:
    import numpy as np

    if not res.rms_mm <= RMS_MAX_MM:
        raise InputError(f"error: the marks in the photos do not fit the machine (they are "
                         f"{res.rms_mm:.2f} mm off on average, a photo does better than "
                         f"{RMS_MAX_MM:g} mm): is it a photo of the pattern in "
                         f"{args.pattern}, drawn without moving the pen or the cords since?")
    worst = int(np.argmax(np.abs(res.tape_mm)))
    if abs(res.tape_mm[worst]) > TAPE_MAX_MM:
        a, b, d = tapes[worst]
        raise InputError(f"error: --distance {a} {b} {d:g}: the photos and the other distances "
                         f"say {d + res.tape_mm[worst]:.1f} mm: check the mark numbers")


def _report(cfg, photos, old, new, res, ids, tapes, home, origin) -> None:
    """The old and new values, every mark's residual on the wall, the tape distances, and how
    much straight lines bent before and bend now."""
    import numpy as np

    from vplotter.commands import calibrate as cal

    print(f"{'parameter':<24}{'old':>12}{'new':>12}{'uncertainty':>14}")
    for k, sig in zip(res.names, res.sigma):
        unit, dec = cal.UNITS.get(k, ("mm", 3))
        was = getattr(old, k)
        was = f"{'level':>12}" if was is None else f"{was:>12.{dec}f}"
        print(f"{k:<24}{was}{getattr(new, k):>12.{dec}f}"
              f"{'±':>6}{sig:.{dec}f} {unit}")
    print(f"{'origin (x_mm, y_mm)':<24}{cfg.origin.x_mm:>6.2f},{cfg.origin.y_mm:.2f}"
          f"{origin[0]:>6.2f},{origin[1]:.2f}  (keeps the calibrated point at "
          f"X{home[0]:.3f} Y{home[1]:.3f})")
    for name, cam, r, used in zip(photos, res.cameras, res.residual_mm, res.used):
        tilt = np.degrees(np.arccos(min(1.0, abs(_axis_z(cam)))))
        print(f"{name}: {int(used.sum())} marks, seen {tilt:.0f} degrees off-axis, lens "
              f"k1 {cam[7]:+.3f} k2 {cam[8]:+.3f}; each mark's residual on the wall (mm):")
        cells = [f"{k:>3}: {np.hypot(*v):.2f}{'' if u else ' (left out)'}"
                 for k, v, u in zip(ids, r, used)]
        for i in range(0, len(cells), 8):
            print("  " + "  ".join(cells[i:i + 8]))
    print(f"rms {res.rms_mm:.3f} mm over the marks")
    for (a, b, d), t in zip(tapes, res.tape_mm):
        print(f"distance {a}-{b}: measured {d:.2f} mm, the fit says {d + t:.2f} mm ({t:+.2f})")
    cal.print_bends(cfg, old, new, res, origin)


def _axis_z(cam) -> float:
    from vplotter.calibration.photo_camera import rotation

    return float(rotation(cam[:3])[2, 2])
