"""A G-code file whose arcs end on another radius than they start (gcodetools writes such
biarcs), with those arcs written as the G1 lines of the spirals vplotter draws for them, so
that the file draws the same (within 0.001 mm) without a warning, in any program.

    python -m bench.make.spiral_lines IN.ngc OUT.ngc

Made gcode_samples/car.ngc and gcode_samples/polar/car.ngc from their gcodetools originals
(tests/data/car_gcodetools.ngc and polar_car_gcodetools.ngc).
"""

from __future__ import annotations

import argparse
import math
import re

TOL_MM = 0.001          # the lines lie within this of the spiral


def spiral_lines(path: str) -> list[str]:
    """The file's lines, each inconsistent arc replaced by a comment and its spiral's lines."""
    from vplotter.inputs import gcode
    from vplotter.motion import segment

    bad = {}
    for r in gcode.read(path, warn=lambda m: None):
        if isinstance(r, gcode.Move) and r.arc:
            r0 = math.hypot(r.x0 - r.cx, r.y0 - r.cy)
            r1 = math.hypot(r.x1 - r.cx, r.y1 - r.cy)
            if abs(r1 - r0) > max(0.005, 0.001 * r0):      # the parser's own rule (grbl's)
                bad[r.line] = r
    out = []
    with open(path, encoding="utf-8") as f:
        for no, line in enumerate(f.read().splitlines(), 1):
            if no not in bad:
                out.append(line)
                continue
            z = re.search(r"Z\S+", line)
            out.append(f"(an arc whose end radius differs from the start, as a spiral: "
                       f"{line.strip()})")
            out += [f"G01 X{x:.6f} Y{y:.6f}" + (f" {z.group(0)}" if z else "")
                    for x, y in segment.points(bad[no], TOL_MM)]
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("source")
    p.add_argument("output")
    a = p.parse_args()
    with open(a.output, "w", encoding="utf-8") as f:
        f.write("\n".join(spiral_lines(a.source)) + "\n")


if __name__ == "__main__":
    main()
