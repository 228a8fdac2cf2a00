"""Reading the machine config: ``DEFAULT_CONFIG`` overlaid with a TOML file, text or dict
(``tomllib``), the coil sequences of the drive tables and the steps per mm of the cords."""

from __future__ import annotations

import copy
import os
import tomllib


#: Defaults for every configuration key (same keys as the package's config.toml).
DEFAULT_CONFIG: dict = {
    "machine": {"anchor_distance_mm": 422.5},
    "origin": {"x_mm": 211.25, "y_mm": 430.0},
    "page": {"x_min_mm": -200.0, "x_max_mm": 200.0,
             "y_min_mm": -250.0, "y_max_mm": 300.0},
    "motors": {
        "drive": "half",
        "steps_per_rev": 4096,
        "spool_circumference_mm": 25.0,
        "max_step_rate": 663,
        "max_accel": 2000,
        "left_pins": [0, 5, 6, 13],
        "right_pins": [12, 16, 20, 21],
        "left_reverse": True,
        "right_reverse": False,
    },
    "pen": {"pin": 24, "up_us": 500, "down_us": 1500, "settle_s": 0.3},
    "motion": {"tolerance_mm": 0.01},
}

#: Coil sequences in FORWARD order, as IN1..IN4 bit strings.
SEQUENCES: dict[str, list[str]] = {
    "half": ["1000", "1100", "0100", "0110", "0010", "0011", "0001", "1001"],
    "full": ["1100", "0110", "0011", "1001"],
    "wave": ["1000", "0100", "0010", "0001"],
}

MOTORS = ("left", "right")


def merge_config(cfg: dict | None) -> dict:
    """Return a deep copy of ``DEFAULT_CONFIG`` overlaid with ``cfg``.

    ``cfg`` is a nested dict as produced by ``tomllib`` (sections
    ``machine``, ``origin``, ``page``, ``motors``, ``pen``, ``motion``).
    Missing sections/keys take the defaults; unknown keys are kept.
    """
    out = copy.deepcopy(DEFAULT_CONFIG)
    for section, values in (cfg or {}).items():
        if isinstance(values, dict) and isinstance(out.get(section), dict):
            out[section].update(copy.deepcopy(values))
        else:
            out[section] = copy.deepcopy(values)
    drive = out["motors"]["drive"]
    if drive not in SEQUENCES:
        raise ValueError(f"unknown motors.drive {drive!r}")
    if out["pen"].get("kind", "servo") in ("output", "switch"):
        # solenoid and cam pens: the pen pin's trace values are the commands 1 (up), 2 (down)
        out["pen"]["up_us"], out["pen"]["down_us"] = 1, 2
    if out["pen"]["up_us"] == out["pen"]["down_us"]:
        raise ValueError("pen.up_us == pen.down_us")
    return out


def load_config(source: str | os.PathLike | dict | None = None) -> dict:
    """Load a machine config and merge it with the defaults.

    ``source`` may be ``None`` (pure defaults), a dict, a path to a TOML file,
    or TOML text (a ``str`` that is not an existing file name).
    """
    if source is None or isinstance(source, dict):
        return merge_config(source)
    if isinstance(source, os.PathLike) or (
            isinstance(source, str) and "\n" not in source and os.path.isfile(source)):
        with open(source, "rb") as fh:
            return merge_config(tomllib.load(fh))
    return merge_config(tomllib.loads(str(source)))


def steps_per_mm(cfg: dict) -> float:
    """Motor steps per mm of cord: ``steps_per_rev / spool_circumference_mm``."""
    m = merge_config(cfg)["motors"]
    return float(m["steps_per_rev"]) / float(m["spool_circumference_mm"])


def steps_per_mm_pair(cfg: dict) -> tuple[float, float]:
    """Steps per mm of the left and right cords: ``[motors] left_/right_spool_circumference_mm``
    where given, else ``spool_circumference_mm``."""
    m = merge_config(cfg)["motors"]
    return tuple(float(m["steps_per_rev"]) / float(m.get(f"{side}_spool_circumference_mm")
                                                    or m["spool_circumference_mm"])
                 for side in MOTORS)
