"""Scripts of moveto/pendown/lineto/penup for the Python API and the same moves as G-code
(test_api.py, bench/api_script.py)."""

from __future__ import annotations

import math
import random


def spiral(n: int) -> list[tuple[float, float]]:
    return [((2 + k / 40) * math.cos(k / 20), (2 + k / 40) * math.sin(k / 20))
            for k in range(n + 1)]


def walks(n: int, length: int, seed: int = 1, spread=(150.0, 100.0),
          step: float = 3.0) -> list[list[tuple[float, float]]]:
    """n random walks of `length` steps of up to `step` mm, each starting anywhere in
    +-spread."""
    rnd = random.Random(seed)
    out = []
    for _ in range(n):
        x, y = rnd.uniform(-spread[0], spread[0]), rnd.uniform(-spread[1], spread[1])
        pts = [(x, y)]
        for _ in range(length):
            x, y = x + rnd.uniform(-step, step), y + rnd.uniform(-step, step)
            pts.append((x, y))
        out.append(pts)
    return out


def gcode_of(strokes) -> str:
    """The G-code file a script of moveto/pendown/lineto/penup is: one call a line."""
    lines = []
    for pts in strokes:
        lines += [f"G0 X{pts[0][0]!r} Y{pts[0][1]!r}", "M3"]
        lines += [f"G1 X{x!r} Y{y!r}" for x, y in pts[1:]]
        lines.append("M5")
    return "\n".join(lines) + "\n"
