"""Independent verifier for vplotter GPIO traces.

This package is deliberately written WITHOUT importing or reading anything
from ``vplotter`` itself: it re-implements, from the written contract only,
everything needed to check that a recorded (simulated) drawing is right:

* reading the trace CSV (``# vplotter trace v1`` / ``t,pin,value``),
* decoding the coil patterns of the two stepper motors into steps,
* the pen servo state,
* the V-plotter kinematics (cords <-> pen position),
* a small, independent G-code interpreter that produces the reference
  pen-down path,
* checks (step rate, acceleration, pen settling, release at end, accuracy).

Modules (each imports only the ones above it, none imports vplotter):

* :mod:`.polar` - step/dir drivers and the polar plotter (motor names and pins,
  STEP/DIR decoding and timing, polar kinematics, the table's rotation and reach),
* :mod:`.config` - the machine config (defaults, TOML, drive tables, steps per mm),
* :mod:`.sag` - cords that sag (catenaries shot from the gondola; ``[cords] mass_g_per_m``),
* :mod:`.kinematics` - V-plotter kinematics (cords <-> pen position),
* :mod:`.trace` - the trace CSV and its format contract,
* :mod:`.decoder` - coil patterns, step/dir edges and the pen pin into steps and pen points,
* :mod:`.checks` - step rate, settling, release, coil edges, windowed acceleration,
* :mod:`.gcode` - the reference G-code interpreter (lines, arcs, spirals),
* :mod:`.distances` - drawn polylines, distances to the reference path, accuracy, page,
* :mod:`.report` - :func:`verify`, every check at once.

Every name is re-exported here: ``import tracecheck as tc; tc.decode(...)``.

Conventions used throughout
---------------------------
* Machine frame: origin at the LEFT anchor, +x to the right, +y DOWN, right
  anchor at ``(anchor_distance_mm, 0)``.
* G-code frame: ``(X, Y)`` with Y up; machine ``x = origin.x_mm + X``,
  ``y = origin.y_mm - Y``.  All positions returned by this package are in
  G-code coordinates (mm) unless stated otherwise.
* Cords: ``left = hypot(x, y)``, ``right = hypot(D - x, y)`` with the default models;
  ``[gondola]`` (cord spacing, pen below, the tilt), ``[cords] stretch`` and the cords' sag
  (``[cords] mass_g_per_m`` with ``[gondola] mass_g``) change them (see
  :func:`inverse_kinematics`), ``[motors] left_/right_spool_circumference_mm`` the steps per
  mm of each motor.
* Motors are named ``"left"`` and ``"right"`` (``"rotary"`` and ``"linear"`` on the polar
  plotter, whose motor coordinates, angle in degrees and radius in mm, take the place of the
  cords; step/dir drivers and the polar kinematics are in :mod:`tracecheck.polar`).
* Step directions in :class:`Decoded` are CORD directions: ``+1`` = the step
  lengthened that motor's cord, ``-1`` = shortened it (the ``*_reverse``
  flags are already applied).  ``seq_dirs`` holds the raw direction through
  the coil sequence (+1 forward).
* Times are seconds; internally they are also kept as integer microseconds
  (the trace has 6 decimals) so that grouping of simultaneous rows and the
  window binning are exact.

Check functions return a list of human readable problem strings; an empty
list means OK.
"""

from __future__ import annotations

from . import polar
from .checks import (check_step_rate, check_window_accel, coil_patterns, illegal_transitions,
                     max_window_accel, min_step_interval, plot_time, released_at_end,
                     steps_while_settling, two_coil_edges, window_accel_tolerance,
                     window_velocities)
from .config import (DEFAULT_CONFIG, MOTORS, SEQUENCES, load_config, merge_config,
                     steps_per_mm, steps_per_mm_pair)
from .decoder import ILLEGAL_MESSAGE_CAP, Decoded, MotorSteps, decode
from .distances import (_densify, accuracy, check_accuracy, check_page,
                        distances_to_polylines, drawn_polylines)
from .gcode import IGNORED_G, IGNORED_M, GCodeError, _sample_line, reference_path
from .kinematics import forward_kinematics, inverse_kinematics
from .report import verify
from .trace import COLUMNS, HEADER, TIME_EPS, Trace, TraceFormatError, format_problems, read_trace

__all__ = [
    "DEFAULT_CONFIG", "SEQUENCES", "HEADER", "TraceFormatError", "GCodeError",
    "Trace", "MotorSteps", "Decoded",
    "load_config", "merge_config", "steps_per_mm", "steps_per_mm_pair",
    "inverse_kinematics", "forward_kinematics",
    "read_trace", "format_problems", "decode",
    "illegal_transitions", "min_step_interval", "check_step_rate",
    "steps_while_settling", "released_at_end", "window_velocities",
    "max_window_accel", "window_accel_tolerance", "check_window_accel",
    "reference_path", "drawn_polylines", "distances_to_polylines",
    "accuracy", "check_accuracy", "check_page", "plot_time", "verify",
]
