"""Everything at once: :func:`verify` decodes a trace, reads its G-code and runs every check,
returning all problems prefixed with the name of their check."""

from __future__ import annotations

from typing import Iterable

import numpy as np

from . import polar as tp
from .checks import (check_step_rate, check_window_accel, illegal_transitions, released_at_end,
                     steps_while_settling)
from .config import merge_config
from .decoder import decode
from .distances import check_accuracy, check_page, distances_to_polylines
from .gcode import reference_path
from .trace import _as_trace, format_problems


def verify(trace, gcode, cfg: dict | None = None, start_xy=(0.0, 0.0),
           tol_mm: float = 0.02, accel_window_s: float = 0.1,
           check_accel: bool = True, page: bool = True, start_q=None) -> list[str]:
    """Run every check on a trace against its G-code; returns all problems.

    ``trace`` is a :class:`Trace` or a path; ``gcode`` a path or program
    text; ``cfg`` a (partial) config dict.  Checks: format, decoding
    problems, illegal transitions, step rate (``max_step_rate``), pen
    settling (``settle_s``), release at end, windowed acceleration
    (``max_accel`` + quantisation slack, if ``check_accel``), page bounds (if
    ``page``) and accuracy (``tol_mm`` both ways).  Each problem is prefixed
    with the name of the check.
    """
    tr = _as_trace(trace)
    c = merge_config(cfg)
    dec = decode(tr, c, start_xy, start_q)
    probs: list[str] = []

    def add(name: str, items: Iterable[str]):
        probs.extend(f"[{name}] {p}" for p in items)

    add("format", format_problems(tr, c))
    add("decode", dec.problems)
    if tp.driver(c) == "stepdir":
        order = np.argsort(tr.t_us, kind="stable")
        add("stepdir", tp.check_stepdir_timing(tr.t_us[order], tr.pin[order], tr.value[order], c))
    if tp.kind(c) == "polar":
        tool = reference_path(gcode, start_xy, travel=True)
        # every pen point, up or down, on the tool path: travel follows straight lines too
        far = distances_to_polylines(dec.points, tool)
        if len(far) and far.max() > tol_mm:
            i = int(np.argmax(far))
            add("travel", [f"pen point ({dec.x[i]:.4f}, {dec.y[i]:.4f}) is {far[i]:.4f} mm off "
                           f"the tool path"])
        turned = float(np.abs(dec.steps["rotary"].dirs).sum()) / tp.steps_per_unit(c)[0]
        add("rotation", tp.check_shorter_rotation(turned, tool[0], c, dec.start_cords[0]))
    add("illegal", illegal_transitions(dec))
    add("step-rate", check_step_rate(dec, c["motors"]["max_step_rate"]))
    add("settle", steps_while_settling(dec, c["pen"]["settle_s"]))
    add("release", released_at_end(tr, c))
    if check_accel:
        add("accel", check_window_accel(dec, c["motors"]["max_accel"], accel_window_s))
    if page:
        add("page", check_page(dec, c))
    add("accuracy", check_accuracy(dec, reference_path(gcode, start_xy), tol_mm))
    return probs
