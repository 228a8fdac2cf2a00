"""How far the pen lands when heavy cords sag and the kinematics ignore it ([cords]
mass_g_per_m unset), on the seed machine (config.toml) and on a 1 m and a 2 m wall.

The machine is calibrated with `calibrate --at 0 0` at the page's origin (there the pen is
right: the stored cords are taken as true), then plans every point with straight cords; the
motors pay out the straight cords' differences from that reference, and the pen lands where
sagging cords of those lengths hold it (kinematics/sag.py). Printed per wall, cord and gondola
mass: the worst distance over the page (a 41 x 41 grid), the worst after the best rigid move
(rotation and translation: what a drawing's shape shows), and the most a cord is longer than
its chord (the sag itself, at the page's worst point); the same on the page's middle half
(half its width and height). Level gondola, no stretch.

Run: python -m bench.sag_error
"""

from __future__ import annotations

import os

import numpy as np

from vplotter import config
from vplotter.kinematics.vplotter import TwoCord

from bench import ROOT

CORDS = {"GT2 6 mm belt (7.5 g/m)": 7.5, "ball chain (18 g/m)": 18.0}
GONDOLAS_G = (100.0, 200.0, 400.0)


def walls() -> dict:
    """name -> (anchor distance, origin x, origin y, page x min/max, y min/max) in mm."""
    cfg = config.load(os.path.join(ROOT, "config.toml"))
    pg = cfg.page
    return {
        f"seed machine ({cfg.machine.anchor_distance_mm:g} mm)": (
            cfg.machine.anchor_distance_mm, cfg.origin.x_mm, cfg.origin.y_mm,
            pg.x_min_mm, pg.x_max_mm, pg.y_min_mm, pg.y_max_mm),
        "1 m wall (page 700 x 600)": (1000.0, 500.0, 750.0, -350.0, 350.0, -300.0, 300.0),
        "2 m wall (page 1400 x 1200)": (2000.0, 1000.0, 1400.0, -700.0, 700.0, -600.0, 600.0),
    }


def _rigid(a: np.ndarray, b: np.ndarray) -> float:
    """Worst distance from a to b after the best rotation and translation of a (Kabsch)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, d]) @ u.T
    return float(np.hypot(*((a - ca) @ rot.T + cb - b).T).max())


def error(wall: tuple, per_m: float, gondola_g: float, share: float = 1.0):
    """(pen off, after a rigid move, cord longer than its chord) on the page's middle
    `share` of its width and height."""
    d, ox, oy, x0, x1, y0, y1 = wall
    x0, x1 = (x0 + x1) / 2 + (x0 - x1) / 2 * share, (x0 + x1) / 2 + (x1 - x0) / 2 * share
    y0, y1 = (y0 + y1) / 2 + (y0 - y1) / 2 * share, (y0 + y1) / 2 + (y1 - y0) / 2 * share
    straight = TwoCord(d, ox, oy)
    sag = TwoCord(d, ox, oy, sag_per_mm=per_m / 1000.0 / gondola_g)
    gx, gy = np.meshgrid(np.linspace(x0, x1, 41), np.linspace(y0, y1, 41))
    want = straight.to_machine(np.column_stack((gx.ravel(), gy.ravel())))
    origin = straight.to_machine(np.zeros((1, 2)))
    q = sag.inverse(origin) + straight.inverse(want) - straight.inverse(origin)
    got = sag.forward(q)
    longer = (sag.inverse(want) - straight.inverse(want)).max()
    return float(np.hypot(*(got - want).T).max()), _rigid(got, want), float(longer)


def main() -> None:
    print("| wall | cord | gondola | pen off (worst) | after a rigid move | cord longer than "
          "its chord | the same on the page's middle half (3 figures) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, wall in walls().items():
        for cord, per_m in CORDS.items():
            for g in GONDOLAS_G:
                off, shape, longer = error(wall, per_m, g)
                mid = " / ".join(f"{v:.2f}" for v in error(wall, per_m, g, 0.5))
                print(f"| {name} | {cord} | {g:g} g | {off:.2f} mm | {shape:.2f} mm | "
                      f"{longer:.2f} mm | {mid} mm |")


if __name__ == "__main__":
    main()
