"""`vplotter calibrate photo` on 12 MP phone photos: wall time, peak memory and accuracy.

The simulated wall of tests/support/wall.py draws the calibration pattern; its strokes,
decoded through the TRUE geometry, are rendered by tests/support/phone_photo.py as 12 MP
JPEGs (straight on; 25 degrees off-axis with lens distortion and a strong light gradient;
upright, stored on its side with an EXIF orientation). For each, `vplotter calibrate photo`
runs with one tape distance (0.3 mm off): its wall time and peak resident size
and CPU time (resource.getrusage of the children, from a small process that runs it: the
CPU time does not grow when other work shares the machine, the wall time does), then
the 300 mm test drawing is drawn and decoded through the true geometry (rigid match): how
far it is off its true shape. Two walls: the level one, and the same with a gondola that tilts
(its centre of mass 30 mm below the pen; config.toml without a [gondola], so the photo route
fits the cord spacing, the pen offset and the centre of mass with the rest).

`--wide`: the tilted wall again on machines of 1 m and 2 m between the anchors (pages of
640 x 600 mm and 1200 x 1000 mm, the pattern's marks twice as large on the second; every
true value off config.toml's: anchors 9 mm, the origin (6, -5) mm, spools, stretch, cords
50 mm apart, the pen 14 mm below them), the camera as much farther back as the page is
larger than config.toml's.

Run: python -m bench.calibrate_photo [--mp 12] [--wall level|tilted|both] [--wide]
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import math
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import test_support

# the command runs in a grandchild forked from this small process: a child forked from the
# bench itself would count the bench's own pages (the rendered photos) in its peak
MEASURE = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]); "
           "u = resource.getrusage(resource.RUSAGE_CHILDREN); "
           "print(u.ru_maxrss, u.ru_utime + u.ru_stime, file=sys.stderr); "
           "sys.exit(r.returncode)")

wall = test_support("wall")
pp = test_support("phone_photo")
tc = test_support("tracecheck")


def views(mp: float) -> dict:
    w = int(round(math.sqrt(mp * 1e6 * 4 / 3)))
    h = int(round(w * 3 / 4))
    return {
        "straight": pp.View(size=(w, h)),
        "25 degrees, lens, light": pp.View(size=(w, h), yaw_deg=25, pitch_deg=6, roll_deg=-4,
                                           k1=-0.08, k2=0.012, light=0.65, noise=0.015,
                                           blur_px=1.2, quality=80),
        "portrait, EXIF": pp.View(size=(h, w), roll_deg=2, k1=0.03, distance_mm=700,
                                  exif_orientation=6),
    }


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mp", type=float, default=12.0, help="megapixels (default 12)")
    ap.add_argument("--wall", choices=("level", "tilted", "both"), default="both")
    ap.add_argument("--wide", action="store_true", help="tilted walls of 1 m and 2 m")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="photo"))
    print("| wall | photo | pixels | time | CPU time | peak memory | test drawing off its shape |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    if args.wide:
        for d_mm, origin, page in ((1000.0, (500.0, 650.0), (320.0, -300.0, 300.0)),
                                   (2000.0, (1000.0, 1300.0), (600.0, -500.0, 500.0))):
            _wide(d_mm, origin, page)
            far = max(2 * page[0], page[2] - page[1]) / 550.0
            run_wall(tmp / f"wide{d_mm:.0f}", True, args.mp, f"tilted, {d_mm / 1000:g} m", far)
        return
    for tilted in {"level": [False], "tilted": [True], "both": [False, True]}[args.wall]:
        run_wall(tmp / ("tilted" if tilted else "level"), tilted, args.mp)


def _wide(d_mm: float, origin: tuple, page: tuple) -> None:
    """The simulated wall's config.toml and its true machine on a machine d_mm wide."""
    text = (wall.REPO / "config.toml").read_text()
    for key, value in (("anchor_distance_mm", d_mm), ("x_mm", origin[0]), ("y_mm", origin[1]),
                       ("x_min_mm", -page[0]), ("x_max_mm", page[0]), ("y_min_mm", page[1]),
                       ("y_max_mm", page[2])):
        text = re.sub(rf"^{key} = \S+", f"{key} = {value}", text, flags=re.M)
    wall._config = lambda gondola: text + (f"\n[gondola]\n{gondola}" if gondola else "")

    def true_config(mass_below_mm=None, sag=None):
        gondola = {"cord_spacing_mm": 50.0, "pen_below_mm": 14.0}
        if mass_below_mm is not None:
            gondola["mass_below_pen_mm"] = mass_below_mm
        return tc.load_config({
            "machine": {"anchor_distance_mm": d_mm + 9.0},
            "origin": {"x_mm": origin[0] + 6.0, "y_mm": origin[1] - 5.0},
            "motors": {"left_spool_circumference_mm": 25.0 * 1.012,
                       "right_spool_circumference_mm": 25.0 * 0.991},
            "gondola": gondola, "cords": {"stretch": 0.004}})

    wall.true_config = true_config


def run_wall(tmp: Path, tilted: bool, mp: float, label: str = "", far: float = 1.0) -> None:
    label = label or ("tilted" if tilted else "level")
    tmp.mkdir()
    os.environ["XDG_STATE_HOME"] = str(tmp / "state")
    with contextlib.redirect_stdout(io.StringIO()):
        (tmp / "pattern").mkdir()
        drawn = wall.draw_pattern(tmp / "pattern", tilted=tilted)
    strokes = tc.drawn_polylines(drawn["dec"])
    for i, (name, view) in enumerate(views(mp).items()):
        view = dataclasses.replace(view, distance_mm=view.distance_mm * max(far, 1.0))
        here = tmp / f"w{i}"
        here.mkdir()
        os.environ["XDG_STATE_HOME"] = str(here / "state")
        w = wall.new_wall(here, drawn)
        photo = here / "photo.jpg"
        pp.render(strokes, photo, view, seed=i)
        last = max(w["dots"])
        d = float(np.hypot(*(w["dots"][1] - w["dots"][last]))) + 0.3
        cmd = [sys.executable, "-m", "vplotter", "--config", str(w["cfg"]), "calibrate",
               "photo", str(photo), "--pattern", str(w["csv"]), "--distance", "1", str(last),
               f"{d:.1f}"]
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, "-c", MEASURE, *cmd], capture_output=True, text=True)
        took = time.perf_counter() - t0
        *err, last = r.stderr.strip().splitlines()
        if r.returncode:
            print(f"| {label} | {name} | failed: {' '.join(err)} | | | | |")
            continue
        rss, cpu = last.split()
        with contextlib.redirect_stdout(io.StringIO()):
            off = wall.draw_and_check(w, "after")
        print(f"| {label} | {name} | {view.size[0]} x {view.size[1]} | {took:.1f} s | "
              f"{float(cpu):.1f} s | "
              f"{int(rss) / 1024:.0f} MB | {off:.3f} mm |", flush=True)


if __name__ == "__main__":
    main()
