"""config.toml -> one frozen dataclass per section.

Every key is declared once in SCHEMA with its type, default (None = required) and bounds; a
key nobody declared is an error (it is usually a typo), and every error names the key.
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vplotter.errors import ConfigError

DRIVES = ("half", "full", "wave")


@dataclass(frozen=True)
class Machine:
    anchor_distance_mm: float


@dataclass(frozen=True)
class Origin:
    x_mm: float
    y_mm: float


@dataclass(frozen=True)
class Page:
    x_min_mm: float
    x_max_mm: float
    y_min_mm: float
    y_max_mm: float


@dataclass(frozen=True)
class Motors:
    drive: str
    steps_per_rev: int
    spool_circumference_mm: float
    max_step_rate: float
    max_accel: float
    left_pins: tuple[int, int, int, int]
    right_pins: tuple[int, int, int, int]
    left_reverse: bool
    right_reverse: bool

    @property
    def steps_per_unit(self) -> tuple[float, float]:
        """Steps per unit of each motor's coordinate (per mm of cord, left and right)."""
        spm = self.steps_per_rev / self.spool_circumference_mm
        return (spm, spm)


@dataclass(frozen=True)
class Pen:
    pin: int
    up_us: int
    down_us: int
    settle_s: float


@dataclass(frozen=True)
class Motion:
    tolerance_mm: float
    draw_speed_mm_s: float
    travel_speed_mm_s: float


@dataclass(frozen=True)
class Gpio:
    backend: str
    chip: int


@dataclass(frozen=True)
class Serial:
    port: str
    baud: int
    rx_buffer: int
    pen_down: str
    pen_up: str
    axes: str
    feed_scale: float
    timeout_s: float


@dataclass(frozen=True)
class Config:
    machine: Machine
    origin: Origin
    page: Page
    motors: Motors
    pen: Pen
    motion: Motion
    gpio: Gpio
    serial: Serial | None = None
    path: str = "config.toml"


# section -> key -> (kind, default or None if required, low, high); bounds are inclusive
# unless the kind ends in '+' (strictly above low).
SCHEMA: dict[str, dict[str, tuple]] = {
    "machine": {"anchor_distance_mm": ("float+", None, 0.0, 1e5)},
    "origin": {"x_mm": ("float", None, -1e5, 1e5), "y_mm": ("float+", None, 0.0, 1e5)},
    "page": {
        "x_min_mm": ("float", None, -1e5, 1e5),
        "x_max_mm": ("float", None, -1e5, 1e5),
        "y_min_mm": ("float", None, -1e5, 1e5),
        "y_max_mm": ("float", None, -1e5, 1e5),
    },
    "motors": {
        "drive": ("str", "half", DRIVES, None),
        "steps_per_rev": ("int+", None, 0, 10**7),
        "spool_circumference_mm": ("float+", None, 0.0, 1e4),
        "max_step_rate": ("float+", None, 0.0, 1e5),
        "max_accel": ("float+", 2000.0, 0.0, 1e7),
        "left_pins": ("pins", None, 0, 63),
        "right_pins": ("pins", None, 0, 63),
        "left_reverse": ("bool", False, None, None),
        "right_reverse": ("bool", False, None, None),
    },
    "pen": {
        "pin": ("int", None, 0, 63),
        "up_us": ("int+", None, 0, 2600),
        "down_us": ("int+", None, 0, 2600),
        "settle_s": ("float", 0.3, 0.0, 60.0),
    },
    "motion": {
        "tolerance_mm": ("float+", 0.01, 0.0, 10.0),
        "draw_speed_mm_s": ("float+", 4.0, 0.0, 1e4),
        "travel_speed_mm_s": ("float+", 8.0, 0.0, 1e4),
    },
    "gpio": {
        "backend": ("str", "lgpio", ("lgpio", "gpiozero", "fake"), None),
        "chip": ("int", 0, 0, 64),
    },
    "serial": {     # a grbl-style controller on a serial port (--backend serial)
        "port": ("text", "/dev/ttyUSB0", None, None),
        "baud": ("int+", 115200, 0, 10**7),
        "rx_buffer": ("int", 128, 64, 1 << 20),
        "pen_down": ("text", "M3 S1000", None, None),
        "pen_up": ("text", "M5", None, None),
        "axes": ("str", "motors", ("motors", "xy"), None),
        "feed_scale": ("float+", 1.0, 0.0, 1e3),
        "timeout_s": ("float+", 5.0, 0.0, 3600.0),
    },
}
OPTIONAL_SECTIONS = {"gpio", "motion", "serial"}
SECTION_CLASSES = {"machine": Machine, "origin": Origin, "page": Page, "motors": Motors,
                   "pen": Pen, "motion": Motion, "gpio": Gpio, "serial": Serial}


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float):
        return f"{v:g}"
    return repr(v) if isinstance(v, str) else str(v)


def _value(where: str, kind: str, raw: Any, lo: Any, hi: Any) -> Any:
    strict = kind.endswith("+")
    base = kind.rstrip("+")
    if base == "bool":
        if not isinstance(raw, bool):
            raise ConfigError(f"{where} must be true or false (got {_fmt(raw)})")
        return raw
    if base == "str":
        if not isinstance(raw, str) or raw not in lo:
            choices = " | ".join(lo)
            raise ConfigError(f"{where} must be one of {choices} (got {_fmt(raw)})")
        return raw
    if base == "text":      # one line of text sent to a controller as it is
        if not isinstance(raw, str) or not raw.strip() or any(c in raw for c in "\r\n?!~\x18"):
            raise ConfigError(f"{where} must be one line of text without ? ! ~ (got {_fmt(raw)})")
        return raw.strip()
    if base == "pins":
        if (not isinstance(raw, list) or len(raw) != 4
                or not all(isinstance(p, int) and not isinstance(p, bool) for p in raw)):
            raise ConfigError(f"{where} must be a list of 4 BCM pin numbers (got {_fmt(raw)})")
        for p in raw:
            if not lo <= p <= hi:
                raise ConfigError(f"{where} pin {p} is not a BCM number {lo}..{hi}")
        return tuple(raw)
    if base == "int":
        if isinstance(raw, bool) or not isinstance(raw, int):
            raise ConfigError(f"{where} must be a whole number (got {_fmt(raw)})")
    elif isinstance(raw, bool) or not isinstance(raw, (int, float)):
        raise ConfigError(f"{where} must be a number (got {_fmt(raw)})")
    value = int(raw) if base == "int" else float(raw)
    if value != value:
        raise ConfigError(f"{where} must be a number (got nan)")
    if strict and not value > lo:
        raise ConfigError(f"{where} must be above {_fmt(lo)} (got {_fmt(raw)})")
    if not lo <= value <= hi:
        raise ConfigError(f"{where} must be between {_fmt(lo)} and {_fmt(hi)} (got {_fmt(raw)})")
    return value


def from_dict(data: dict, path: str = "config.toml") -> Config:
    """Validate a parsed TOML document; raise ConfigError naming the first bad key."""
    for section in data:
        if section not in SCHEMA:
            raise ConfigError(f"{path}: unknown section [{section}]")
    sections = {}
    for section, keys in SCHEMA.items():
        table = data.get(section)
        if table is None:
            if section not in OPTIONAL_SECTIONS:
                raise ConfigError(f"{path}: missing section [{section}]")
            table = {}
        if not isinstance(table, dict):
            raise ConfigError(f"{path}: [{section}] must be a table")
        for key in table:
            if key not in keys:
                close = difflib.get_close_matches(key, keys, n=1)
                hint = f" (did you mean {close[0]}?)" if close else ""
                raise ConfigError(f"{path}: unknown key [{section}] {key}{hint}")
        values = {}
        for key, (kind, default, lo, hi) in keys.items():
            where = f"{path}: [{section}] {key}"
            if key not in table:
                if default is None:
                    raise ConfigError(f"{where} is missing")
                values[key] = default
                continue
            values[key] = _value(where, kind, table[key], lo, hi)
        sections[section] = SECTION_CLASSES[section](**values)
    cfg = Config(**sections, path=path)
    _check_geometry(cfg)
    return cfg


def _check_geometry(cfg: Config) -> None:
    path = cfg.path
    pins = [*(("[motors] left_pins", p) for p in cfg.motors.left_pins),
            *(("[motors] right_pins", p) for p in cfg.motors.right_pins),
            ("[pen] pin", cfg.pen.pin)]
    seen: dict[int, str] = {}
    for key, p in pins:
        if p in seen:
            raise ConfigError(f"{path}: {key}: pin {p} is already used by {seen[p]}")
        seen[p] = key
    pg = cfg.page
    if pg.x_min_mm >= pg.x_max_mm:
        raise ConfigError(f"{path}: [page] x_min_mm must be below x_max_mm "
                          f"(got {pg.x_min_mm:g} and {pg.x_max_mm:g})")
    if pg.y_min_mm >= pg.y_max_mm:
        raise ConfigError(f"{path}: [page] y_min_mm must be below y_max_mm "
                          f"(got {pg.y_min_mm:g} and {pg.y_max_mm:g})")
    if cfg.pen.up_us == cfg.pen.down_us:
        raise ConfigError(f"{path}: [pen] up_us and down_us must differ (both {cfg.pen.up_us})")
    # The whole page must hang below the anchor line.
    top = cfg.origin.y_mm - pg.y_max_mm
    if top <= 0:
        raise ConfigError(
            f"{path}: [page] y_max_mm = {pg.y_max_mm:g} puts the page top {-top:g} mm above "
            f"the anchors ([origin] y_mm = {cfg.origin.y_mm:g}); lower y_max_mm or increase "
            f"[origin] y_mm")


def load(path: str | Path) -> Config:
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: error: config file not found (pass --config PATH)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ConfigError(f"{p}: error: cannot read config: {e}") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{p}: error: not valid TOML: {e}") from None
    return from_dict(data, str(p))
