"""The wall fit on simulated walls: how far a 300 mm test drawing is off before and after
`calibrate fit`, for several true machines (tests/test_wall_calibration.py's procedure: the
simulated wall of tests/support/wall.py).

For each wall: `calibrate --at 0 0`, `calibrate pattern --backend fake`, the dots decoded
through the TRUE geometry by tests/support/tracecheck/, the pairs "measured" with 0.3 mm noise
(and once more with one of them mistyped, x10), `calibrate fit`, the test drawing drawn from
the stored position and decoded through the true geometry, matched to the ideal by a rigid
move only (ICP, Kabsch without scale): the worst distance both ways.

Then the same on walls whose gondola tilts (its centre of mass `mass` mm below the pen; the
person has measured the gondola's cord spacing and pen offset with a ruler into config.toml):
the ruler route with `calibrate fit --fit-mass`, and with the gondola taken as level.

And on walls whose cords sag (a GT2 belt of 7.5 g/m or ball chain of 18 g/m on a 200 g
gondola; config.toml says so: [cords] mass_g_per_m, [gondola] mass_g): `calibrate fit` with
the sag in config.toml, and with mass_g_per_m set to 0 (the cords taken as straight).

Run: python -m bench.wall_fit [--tilted | --sag]   (only the tilted / sagging walls)
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import sys
import tempfile
from pathlib import Path

from bench import test_support

tf = test_support("wall")

WALLS = [  # anchor distance +mm, gondola spacing, pen below, circumferences x, stretch, ref off
    dict(d=6.0, sp=40.0, pb=12.0, circ=(1.015, 0.988), k=0.003, off=(5.0, -4.0)),
    dict(d=-8.0, sp=60.0, pb=20.0, circ=(0.98, 1.02), k=0.005, off=(-6.0, 7.0)),
    dict(d=4.0, sp=30.0, pb=5.0, circ=(1.02, 1.01), k=0.002, off=(3.0, 3.0)),
    dict(d=10.0, sp=50.0, pb=15.0, circ=(0.99, 0.985), k=0.004, off=(-8.0, -5.0)),
    dict(d=-3.0, sp=25.0, pb=0.0, circ=(1.01, 0.99), k=0.006, off=(0.0, 8.0)),
]


TILTED = [  # as WALLS, and the centre of mass below the pen
    dict(d=6.0, sp=40.0, pb=12.0, circ=(1.015, 0.988), k=0.003, off=(5.0, -4.0), mass=30.0),
    dict(d=-8.0, sp=60.0, pb=20.0, circ=(0.98, 1.02), k=0.005, off=(-6.0, 7.0), mass=50.0),
    dict(d=4.0, sp=30.0, pb=5.0, circ=(1.02, 1.01), k=0.002, off=(3.0, 3.0), mass=100.0),
]


SAGGING = [  # as WALLS, and (the cords' g per m, the gondola's g)
    dict(d=6.0, sp=40.0, pb=12.0, circ=(1.015, 0.988), k=0.003, off=(5.0, -4.0), sag=(7.5, 200.0)),
    dict(d=6.0, sp=40.0, pb=12.0, circ=(1.015, 0.988), k=0.003, off=(5.0, -4.0),
         sag=(18.0, 200.0)),
    dict(d=-8.0, sp=60.0, pb=20.0, circ=(0.98, 1.02), k=0.005, off=(-6.0, 7.0), sag=(18.0, 200.0)),
]


def one(wall: dict, seed: int, typo: int | None, fits=((),)):
    tf.TRUE_ANCHOR_MM = 422.5 + wall["d"]
    tf.TRUE_SPACING_MM, tf.TRUE_PEN_BELOW_MM = wall["sp"], wall["pb"]
    tf.TRUE_CIRC_MM = (25.0 * wall["circ"][0], 25.0 * wall["circ"][1])
    tf.TRUE_STRETCH, tf.REF_OFF_MM = wall["k"], wall["off"]
    tf.TILTED_MASS_BELOW_MM = wall.get("mass")
    gondola = (f"cord_spacing_mm = {wall['sp']}\npen_below_mm = {wall['pb']}\n"
               if "mass" in wall else "")
    tmp = Path(tempfile.mkdtemp(prefix="wall"))
    os.environ["XDG_STATE_HOME"] = str(tmp / "state")
    out = io.StringIO()
    afters = []
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        (tmp / "pattern").mkdir()
        pat = tf.draw_pattern(tmp / "pattern", tilted="mass" in wall, gondola=gondola,
                              sag=wall.get("sag"))
        for i, extra in enumerate(fits):
            os.environ["XDG_STATE_HOME"] = str(tmp / f"state{i}")
            (tmp / f"w{i}").mkdir()
            w = tf.new_wall(tmp / f"w{i}", pat)
            if extra == ("straight",):          # the cords taken as straight
                extra = ()
                text = w["cfg"].read_text()
                w["cfg"].write_text(re.sub(r"mass_g_per_m = \S+", "mass_g_per_m = 0", text))
            if i == 0:
                before = tf.draw_and_check(w, "before")
            tf.measure(w["csv"], w["dots"], seed=seed, typo=typo)
            rc = tf.run(w["cfg"], "calibrate", "fit", w["csv"], *extra)
            afters.append(tf.draw_and_check(w, "after") if rc == 0 else float("nan"))
    named = sum("outlier" in line for line in out.getvalue().splitlines())
    mass = re.search(r"mass_below_pen_mm +\S+ +(\S+) +± *(\S+)", out.getvalue())
    return before, afters[0] if len(afters) == 1 else afters, rc, named, mass


def tilted() -> None:
    print("| wall | as wall | centre of mass below the pen | before | after, `--fit-mass` | "
          "fitted centre of mass | after, gondola taken as level |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for i, w in enumerate(TILTED):
        before, (after, level), _, _, mass = one(w, 100 + i, None, (("--fit-mass",), ()))
        fitted = f"{mass.group(1)} ± {mass.group(2)} mm" if mass else "not fitted"
        print(f"| T{i + 1} | {i + 1} | {w['mass']:g} mm | {before:.2f} mm | {after:.3f} mm | "
              f"{fitted} | {level:.3f} mm |", flush=True)


def sagging() -> None:
    print("| wall | as wall | cords / gondola | before | after, sag in config.toml | "
          "after, cords taken as straight |")
    print("| --- | --- | --- | --- | --- | --- |")
    for i, w in enumerate(SAGGING):
        before, (after, straight), _, _, _ = one(w, 100 + i, None, ((), ("straight",)))
        straight = ("refused (the measurements do not fit together)" if straight != straight
                    else f"{straight:.3f} mm")
        print(f"| S{i + 1} | {1 if w['d'] == 6.0 else 2} | {w['sag'][0]:g} g/m / "
              f"{w['sag'][1]:g} g | {before:.2f} mm | {after:.3f} mm | {straight} |", flush=True)


def main() -> None:
    if "--tilted" in sys.argv[1:]:
        tilted()
        return
    if "--sag" in sys.argv[1:]:
        sagging()
        return
    print("| wall | anchor | spacing / pen below | circumferences | stretch | reference off | "
          "before | after | after, one typo (named) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for i, w in enumerate(WALLS):
        before, after, _, _, _ = one(w, 100 + i, None)
        _, after_typo, _, named, _ = one(w, 100 + i, 4)
        print(f"| {i + 1} | {w['d']:+g} mm | {w['sp']:g} / {w['pb']:g} mm | "
              f"{(w['circ'][0] - 1) * 100:+.1f} % / {(w['circ'][1] - 1) * 100:+.1f} % | "
              f"{w['k']:g} | ({w['off'][0]:+g}, {w['off'][1]:+g}) mm | {before:.2f} mm | "
              f"{after:.3f} mm | {after_typo:.3f} mm ({named}) |", flush=True)
    print()
    tilted()


if __name__ == "__main__":
    main()
