"""A varied set of drawings for the plan / time-optimal comparison (deterministic).

Each generator writes one G-code file inside a page box (G-code mm, x0 x1 y0 y1) and returns
its path; `n` scales how much is in it (the small files in tests/data are n = 1, the large
bench files n = 10..40). What each one stresses:

- `tiny_shapes`: squares, triangles and circles of 1-10 mm, the pen lifted between their
  sides (every side its own stroke: many stops, settle times, short travel).
- `far_arcs`: nearly straight G2/G3 arcs, radius 1e3-1e5 mm, in I/J and R form, chained.
- `micro_arcs`: arcs of radius 0.1-1 mm, chained into wiggles, and whole tiny circles.
- `gcodetools_far`: what gcodetools writes for smooth drawings: thousands of short biarcs,
  many nearly straight with their centres far away, Z pen moves, F on the plunge.
- `zigzag`: dense zigzags (0.3-2 mm pitch), pen down.
- `long_travel`: long pen-up moves across the page between short strokes.
- `mixed`: a bit of everything, M3/M5 pen.
- `gcodetools_small`: gcodetools strokes of small tangent arcs (radius 0.1-1.5 mm, log-uniform;
  the sense of turning random), `G02 X.. Y.. Z.. I.. J.. F..` (only in the large set).
"""

from __future__ import annotations

import math

import numpy as np

SEED_BOX = (-180.0, 180.0, -230.0, 280.0)


def _f(v):
    return f"{v:.4f}"


def _write(path, out):
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")
    return path


def _spot(rng, box, margin=15.0):
    x0, x1, y0, y1 = box
    return rng.uniform(x0 + margin, x1 - margin), rng.uniform(y0 + margin, y1 - margin)


def _turn(x, y, heading, r, side, sweep):
    """An arc of radius r leaving (x, y) along `heading`, turning left (side 1) or right (-1)
    by `sweep` radians: its centre and end point (cx, cy, x1, y1)."""
    cxx, cyy = x - side * r * math.sin(heading), y + side * r * math.cos(heading)
    a1 = math.atan2(y - cyy, x - cxx) + side * sweep
    return cxx, cyy, cxx + r * math.cos(a1), cyy + r * math.sin(a1)


def tiny_shapes(path, n=1, box=SEED_BOX, seed=1):
    rng = np.random.default_rng(seed)
    out = ["(tiny shapes: every side its own stroke)", "G21 G90", "G00 Z5"]
    for _ in range(12 * n):
        cx, cy = _spot(rng, box)
        kind = rng.integers(3)
        size = rng.uniform(1.0, 10.0)
        if kind < 2:                                   # square / triangle, side by side
            k = 4 if kind == 0 else 3
            rot = rng.uniform(0, 2 * math.pi)
            pts = [(cx + size / 2 * math.cos(rot + 2 * math.pi * i / k),
                    cy + size / 2 * math.sin(rot + 2 * math.pi * i / k)) for i in range(k + 1)]
            for (xa, ya), (xb, yb) in zip(pts, pts[1:]):
                out += [f"G00 X{_f(xa)} Y{_f(ya)}", "G01 Z-1 F600", f"G01 X{_f(xb)} Y{_f(yb)}",
                        "G00 Z5"]
        else:                                          # circle in quarters, pen up between
            r = size / 2
            for q in range(4):
                a0, a1 = q * math.pi / 2, (q + 1) * math.pi / 2
                xa, ya = cx + r * math.cos(a0), cy + r * math.sin(a0)
                xb, yb = cx + r * math.cos(a1), cy + r * math.sin(a1)
                out += [f"G00 X{_f(xa)} Y{_f(ya)}", "G01 Z-1",
                        f"G03 X{_f(xb)} Y{_f(yb)} I{_f(cx - xa)} J{_f(cy - ya)}", "G00 Z5"]
    out += ["G00 X0 Y0", "M2"]
    return _write(path, out)


def far_arcs(path, n=1, box=SEED_BOX, seed=2):
    rng = np.random.default_rng(seed)
    out = ["(nearly straight arcs: radius 1e3-1e5 mm, I/J and R)", "G21 G90", "G00 Z5"]
    for s in range(3 * n):
        x, y = _spot(rng, box, 60.0)
        heading = rng.uniform(0, 2 * math.pi)
        out += [f"G00 X{_f(x)} Y{_f(y)}", "G01 Z-1 F400"]
        for i in range(12):
            chord = rng.uniform(2.0, 25.0)
            r = 10 ** rng.uniform(3, 5)
            ccw = rng.random() < 0.5
            side = 1 if ccw else -1
            sweep = chord / r
            cxx, cyy, x1, y1 = _turn(x, y, heading, r, side, sweep)
            x0b, x1b, y0b, y1b = box
            if not (x0b + 5 < x1 < x1b - 5 and y0b + 5 < y1 < y1b - 5):
                heading += math.pi
                continue
            code = "G03" if ccw else "G02"
            if (s + i) % 2:
                out.append(f"{code} X{x1:.6f} Y{y1:.6f} R{r:.4f}")
            else:
                out.append(f"{code} X{x1:.6f} Y{y1:.6f} I{cxx - x:.6f} J{cyy - y:.6f}")
            x, y = x1, y1
            heading += side * sweep + (rng.uniform(-0.6, 0.6) if rng.random() < 0.3 else 0.0)
        out.append("G00 Z5")
    out += ["G00 X0 Y0", "M2"]
    return _write(path, out)


def micro_arcs(path, n=1, box=SEED_BOX, seed=3):
    rng = np.random.default_rng(seed)
    out = ["(arcs of 0.1-1 mm)", "G21 G90", "G00 Z5"]
    for _ in range(4 * n):
        x, y = _spot(rng, box)
        out += [f"G00 X{_f(x)} Y{_f(y)}", "G01 Z-1 F300"]
        heading = rng.uniform(0, 2 * math.pi)
        for i in range(30):
            r = rng.uniform(0.1, 1.0)
            if i % 10 == 9:                             # a whole tiny circle
                out.append(f"G02 X{_f(x)} Y{_f(y)} I{_f(r)} J0")
                continue
            side = 1 if i % 2 else -1                     # wiggle: alternate the turn
            sweep = rng.uniform(0.5, 2.5)
            cxx, cyy, x1, y1 = _turn(x, y, heading, r, side, sweep)
            i_, j_ = cxx - x, cyy - y
            x, y = x1, y1
            out.append(f"{'G03' if side > 0 else 'G02'} X{x:.5f} Y{y:.5f} I{i_:.5f} J{j_:.5f}")
            heading += side * sweep
        out.append("G00 Z5")
    out += ["G00 X0 Y0", "M2"]
    return _write(path, out)


def _gcodetools(path, strokes: int, box, rng, step_max: float, arcs: int, arc) -> str:
    """`strokes` gcodetools strokes of up to `arcs` tangent arcs each, from a random walk of
    stroke starts (steps 3 mm .. step_max); arc(rng) -> (radius, sweep, side) for each arc
    (side +1: counter-clockwise); a stroke ends where its next arc would leave the box."""
    out = ["%", "(Header)", "(Generated by gcodetools from Inkscape.)", "M3", "(Header end.)",
           "G21 (All units in mm)", ""]
    x0b, x1b, y0b, y1b = box
    x, y = 0.0, 0.0
    for k in range(strokes):
        turn = rng.uniform(0, 2 * math.pi)
        step = rng.uniform(3.0, step_max)
        x = float(np.clip(x + step * math.cos(turn), x0b + 20, x1b - 20))
        y = float(np.clip(y + step * math.sin(turn), y0b + 20, y1b - 20))
        heading = rng.uniform(0, 2 * math.pi)
        out += [f"(Start cutting path id: path{k})", "G00 Z5.000000", f"G00 X{x:.6f} Y{y:.6f}",
                "G01 Z-1.000000 F100.0(Penetrate)"]
        for i in range(arcs):
            r, sweep, side = arc(rng)
            cxx, cyy, x1, y1 = _turn(x, y, heading, r, side, sweep)
            if not (x0b + 5 < x1 < x1b - 5 and y0b + 5 < y1 < y1b - 5):
                break
            feed = " F400.000000" if i == 0 else ""
            out.append(f"{'G03' if side > 0 else 'G02'} X{x1:.6f} Y{y1:.6f} Z-1.000000 "
                       f"I{cxx - x:.6f} J{cyy - y:.6f}{feed}")
            x, y = x1, y1
            heading += side * sweep
        out += ["G00 Z5.000000", f"(End cutting path id: path{k})", ""]
    out += ["(Footer)", "M5", "G00 X0.0000 Y0.0000", "M2", "%"]
    return _write(path, out)


def gcodetools_far(path, n=1, box=SEED_BOX, seed=4, arcs=20):
    """gcodetools biarcs of a smooth drawing: radius log-uniform 0.5 mm .. 1e5 mm, so most of
    them are nearly straight with their centres far off the page."""
    def arc(rng):
        r = 10 ** rng.uniform(-0.3, 5)
        sweep = min(rng.uniform(0.3, 3.0) / r, 1.2)       # 0.3-3 mm long
        return r, sweep, 1 if rng.random() < 0.5 else -1

    return _gcodetools(path, 8 * n, box, np.random.default_rng(seed), 40.0, arcs, arc)


def gcodetools_small(path, n=1, box=SEED_BOX, seed=8, arcs=40):
    """30 n gcodetools strokes of `arcs` tangent arcs each: radius 0.1-1.5 mm (log-uniform),
    sweep 0.1-1.2 rad, turning left or right at random (an S-bend where the sense changes)."""
    def arc(rng):
        r = 10 ** rng.uniform(-1.0, math.log10(1.5))
        return r, rng.uniform(0.1, 1.2), 1 if rng.random() < 0.5 else -1

    return _gcodetools(path, 30 * n, box, np.random.default_rng(seed), 30.0, arcs, arc)


def zigzag(path, n=1, box=SEED_BOX, seed=5):
    rng = np.random.default_rng(seed)
    out = ["(dense zigzags)", "G21 G90", "G00 Z5"]
    for _ in range(2 * n):
        x, y = _spot(rng, box, 40.0)
        amp = rng.uniform(3.0, 20.0)
        pitch = rng.uniform(0.3, 2.0)
        ang = rng.uniform(0, math.pi)
        c, s = math.cos(ang), math.sin(ang)
        out += [f"G00 X{_f(x)} Y{_f(y)}", "G01 Z-1 F600"]
        for i in range(1, 40):
            u, w = i * pitch, amp * (i % 2)
            out.append(f"G01 X{_f(x + u * c - w * s)} Y{_f(y + u * s + w * c)}")
        out.append("G00 Z5")
    out += ["G00 X0 Y0", "M2"]
    return _write(path, out)


def long_travel(path, n=1, box=SEED_BOX, seed=6):
    rng = np.random.default_rng(seed)
    x0b, x1b, y0b, y1b = box
    out = ["(long pen-up moves between short strokes)", "G21 G90", "G00 Z5"]
    for i in range(4 * n):
        x = x0b + 10 if i % 2 else x1b - 10
        y = rng.uniform(y0b + 10, y1b - 10)
        out += [f"G00 X{_f(x)} Y{_f(y)}", "G01 Z-1 F600",
                f"G01 X{_f(x + (5 if i % 2 else -5))} Y{_f(y + 3)}", "G00 Z5"]
    out += ["G00 X0 Y0", "M2"]
    return _write(path, out)


def mixed(path, n=1, box=SEED_BOX, seed=7):
    rng = np.random.default_rng(seed)
    out = ["(mixed, M3/M5 pen)", "G21 G90", "M5"]
    for _ in range(3 * n):
        x, y = _spot(rng, box, 30.0)
        out += [f"G00 X{_f(x)} Y{_f(y)}", "M3"]
        for i in range(15):
            kind = rng.integers(4)
            d = rng.uniform(0.5, 12.0)
            a = rng.uniform(0, 2 * math.pi)
            x1 = float(np.clip(x + d * math.cos(a), box[0] + 5, box[1] - 5))
            y1 = float(np.clip(y + d * math.sin(a), box[2] + 5, box[3] - 5))
            if kind == 0 or math.hypot(x1 - x, y1 - y) < 0.05:
                out.append(f"G01 X{_f(x1)} Y{_f(y1)} F{rng.uniform(60, 600):.0f}")
            elif kind == 1:
                r = math.hypot(x1 - x, y1 - y) * rng.uniform(0.6, 50)
                out.append(f"G0{2 + i % 2} X{_f(x1)} Y{_f(y1)} R{r:.4f}")
            elif kind == 2:
                out.append("G04 P0.2")
                out.append(f"G01 X{_f(x1)} Y{_f(y1)}")
            else:
                out += ["M5", f"G00 X{_f(x1)} Y{_f(y1)}", "M3"]
            x, y = x1, y1
        out.append("M5")
    out += ["G00 X0 Y0", "M2"]
    return _write(path, out)


GENERATORS = {"tiny_shapes": tiny_shapes, "far_arcs": far_arcs, "micro_arcs": micro_arcs,
              "gcodetools_far": gcodetools_far, "zigzag": zigzag, "long_travel": long_travel,
              "mixed": mixed, "gcodetools_small": gcodetools_small}
SMALL = ("tiny_shapes", "far_arcs", "micro_arcs", "gcodetools_far", "zigzag", "long_travel",
         "mixed")   # the small files of tests/data


def small_set(where):
    """The small files of tests/data (n = 1, seed page)."""
    import os

    return [GENERATORS[name](os.path.join(where, f"{name}.ngc"), 1) for name in SMALL]


if __name__ == "__main__":
    import os
    import sys

    from bench import ROOT

    small_set(sys.argv[1] if len(sys.argv) > 1 else
              os.path.join(ROOT, "tests", "data"))
