"""config.toml -> one frozen dataclass per section.

Every key is declared once in SCHEMA with its type, default (None = required) and bounds; a
key nobody declared is an error (it is usually a typo), and every error names the key.
"""

from __future__ import annotations

import difflib
import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vplotter.errors import ConfigError
from vplotter.inputs.gcode import PenDialect as Gcode   # [gcode]: how files move the pen

DRIVES = ("half", "full", "wave")
KINDS = ("vplotter", "polar")
DRIVERS = ("uln2003", "stepdir")
PEN_KINDS = ("servo", "switch", "output")
UNSET = "unset"   # a default: the key may be left out (the value is then None)
MOTOR_NAMES = {"vplotter": ("left", "right"), "polar": ("rotary", "linear")}


@dataclass(frozen=True)
class Machine:
    anchor_distance_mm: float | None = None
    kind: str = "vplotter"


@dataclass(frozen=True)
class Polar:
    """The polar plotter: a rotary table under a linear arm (G-code frame, mm and degrees)."""

    centre_x_mm: float
    centre_y_mm: float
    arm_angle_deg: float
    radius_min_mm: float
    radius_max_mm: float
    home_pin: int | None
    home_radius_mm: float | None
    home_active_low: bool


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
    # which keys apply depends on [machine] kind and [motors] driver; the others stay None
    driver: str = "uln2003"
    names: tuple[str, str] = ("left", "right")
    rotary_steps_per_deg: float | None = None
    linear_steps_per_mm: float | None = None
    rotary_pins: tuple[int, int, int, int] | None = None
    linear_pins: tuple[int, int, int, int] | None = None
    rotary_reverse: bool = False
    linear_reverse: bool = False
    left_step_pin: int | None = None
    left_dir_pin: int | None = None
    right_step_pin: int | None = None
    right_dir_pin: int | None = None
    rotary_step_pin: int | None = None
    rotary_dir_pin: int | None = None
    linear_step_pin: int | None = None
    linear_dir_pin: int | None = None
    enable_pin: int | None = None
    dir_setup_us: int = 1
    step_pulse_us: int = 2

    left_spool_circumference_mm: float | None = None    # None: spool_circumference_mm
    right_spool_circumference_mm: float | None = None

    @property
    def circumferences_mm(self) -> tuple[float, float]:
        """Cord wound per spool turn, left and right (V-plotter)."""
        return (self.left_spool_circumference_mm or self.spool_circumference_mm,
                self.right_spool_circumference_mm or self.spool_circumference_mm)

    @property
    def steps_per_unit(self) -> tuple[float, float]:
        """Steps per unit of each motor's coordinate: per mm of cord (left, right), or per
        degree of the table and per mm of the arm (rotary, linear)."""
        if self.names[0] == "rotary":
            return (self.rotary_steps_per_deg, self.linear_steps_per_mm)
        left, right = self.circumferences_mm
        return (self.steps_per_rev / left, self.steps_per_rev / right)

    def _pair(self, suffix: str) -> tuple:
        return tuple(getattr(self, f"{n}_{suffix}") for n in self.names)

    @property
    def reverse(self) -> tuple[bool, bool]:
        return self._pair("reverse")

    @property
    def out_pins(self) -> list[int]:
        """The motor output pins, bit i of an output word = out_pins[i]: IN1..IN4 of both
        motors (uln2003), or STEP, DIR of both motors and ENABLE (stepdir)."""
        if self.driver == "stepdir":
            pins = [getattr(self, f"{n}_{what}_pin") for n in self.names for what in ("step", "dir")]
            return pins + [self.enable_pin]
        return [p for pins in self._pair("pins") for p in pins]

    @property
    def idle_word(self) -> int:
        """The output word of released motors: coils all low, or ENABLE high (drivers off)."""
        return 1 << 4 if self.driver == "stepdir" else 0


@dataclass(frozen=True)
class Pen:
    """kind "servo": `pin` gets pulses of up_us/down_us. "output": `pin` is held high while
    the pen is down (a solenoid). "switch": `pin` runs the cam motor: up until `switch_pin`
    closes (at most timeout_s), down for down_s. The schedule's pen rows carry up_us/down_us
    for every kind (1 and 2 for output and switch): the backend turns them into what the kind
    needs (backends/pens.py)."""

    pin: int
    up_us: int
    down_us: int
    settle_s: float
    kind: str = "servo"
    switch_pin: int | None = None
    switch_active_low: bool = True
    timeout_s: float = 2.0
    down_s: float = 0.2


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
class Gondola:
    cord_spacing_mm: float     # between the points where the two cords hold the gondola
    pen_below_mm: float        # the pen below the line through those points (midway)


@dataclass(frozen=True)
class Cords:
    stretch: float             # strain of a cord that alone carries the gondola's weight


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
    gondola: Gondola = Gondola(0.0, 0.0)
    cords: Cords = Cords(0.0)
    serial: Serial | None = None
    gcode: Gcode = Gcode()
    path: str = "config.toml"
    polar: Polar | None = None


# section -> key -> (kind, default or None if required, low, high[, when]); bounds are inclusive
# unless the kind ends in '+' (strictly above low). `when` names the machine kind, driver or pen
# kind ("polar", "stepdir", "vplotter uln2003", ...) a key belongs to: elsewhere it is an error.
SCHEMA: dict[str, dict[str, tuple]] = {
    "machine": {"kind": ("str", "vplotter", KINDS, None),
                "anchor_distance_mm": ("float+", None, 0.0, 1e5, "vplotter")},
    "origin": {"x_mm": ("float", None, -1e5, 1e5), "y_mm": ("float+", None, 0.0, 1e5)},
    "polar": {
        "centre_x_mm": ("float", 0.0, -1e5, 1e5),
        "centre_y_mm": ("float", 0.0, -1e5, 1e5),
        "arm_angle_deg": ("float", 0.0, -360.0, 360.0),
        "radius_min_mm": ("float", 0.0, -1e5, 1e5),
        "radius_max_mm": ("float+", None, 0.0, 1e5),
        "home_pin": ("int", UNSET, 0, 63),
        "home_radius_mm": ("float", UNSET, -1e5, 1e5),
        "home_active_low": ("bool", True, None, None),
    },
    "page": {
        "x_min_mm": ("float", None, -1e5, 1e5),
        "x_max_mm": ("float", None, -1e5, 1e5),
        "y_min_mm": ("float", None, -1e5, 1e5),
        "y_max_mm": ("float", None, -1e5, 1e5),
    },
    "motors": {
        "driver": ("str", "uln2003", DRIVERS, None),
        "drive": ("str", "half", DRIVES, None, "uln2003"),
        "steps_per_rev": ("int+", None, 0, 10**7, "vplotter"),
        "spool_circumference_mm": ("float+", None, 0.0, 1e4, "vplotter"),
        "rotary_steps_per_deg": ("float+", None, 0.0, 1e6, "polar"),
        "linear_steps_per_mm": ("float+", None, 0.0, 1e6, "polar"),
        "max_step_rate": ("float+", None, 0.0, 1e5),
        "max_accel": ("float+", 2000.0, 0.0, 1e7),
        "left_pins": ("pins", None, 0, 63, "vplotter uln2003"),
        "right_pins": ("pins", None, 0, 63, "vplotter uln2003"),
        "rotary_pins": ("pins", None, 0, 63, "polar uln2003"),
        "linear_pins": ("pins", None, 0, 63, "polar uln2003"),
        "left_step_pin": ("int", None, 0, 63, "vplotter stepdir"),
        "left_dir_pin": ("int", None, 0, 63, "vplotter stepdir"),
        "right_step_pin": ("int", None, 0, 63, "vplotter stepdir"),
        "right_dir_pin": ("int", None, 0, 63, "vplotter stepdir"),
        "rotary_step_pin": ("int", None, 0, 63, "polar stepdir"),
        "rotary_dir_pin": ("int", None, 0, 63, "polar stepdir"),
        "linear_step_pin": ("int", None, 0, 63, "polar stepdir"),
        "linear_dir_pin": ("int", None, 0, 63, "polar stepdir"),
        "enable_pin": ("int", None, 0, 63, "stepdir"),
        "dir_setup_us": ("int+", 1, 0, 1000, "stepdir"),
        "step_pulse_us": ("int+", 2, 0, 1000, "stepdir"),
        "left_reverse": ("bool", False, None, None, "vplotter"),
        "right_reverse": ("bool", False, None, None, "vplotter"),
        "rotary_reverse": ("bool", False, None, None, "polar"),
        "linear_reverse": ("bool", False, None, None, "polar"),
        "left_spool_circumference_mm": ("float+", UNSET, 0.0, 1e4, "vplotter"),
        "right_spool_circumference_mm": ("float+", UNSET, 0.0, 1e4, "vplotter"),
    },
    "pen": {
        "kind": ("str", "servo", PEN_KINDS, None),
        "pin": ("int", None, 0, 63),
        "up_us": ("int+", None, 0, 2600, "servo"),
        "down_us": ("int+", None, 0, 2600, "servo"),
        "settle_s": ("float", 0.3, 0.0, 60.0),
        "switch_pin": ("int", None, 0, 63, "switch"),
        "switch_active_low": ("bool", True, None, None, "switch"),
        "timeout_s": ("float+", 2.0, 0.0, 60.0, "switch"),
        "down_s": ("float", 0.2, 0.0, 10.0, "switch"),
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
    "gondola": {
        "cord_spacing_mm": ("float", 0.0, 0.0, 1e4),
        "pen_below_mm": ("float", 0.0, -1e4, 1e4),
    },
    "cords": {"stretch": ("float", 0.0, 0.0, 0.5)},
    "gcode": {
        "pen": ("str", "auto", ("auto", "z", "m3", "m280"), None),
        "z_down_below_mm": ("float", 0.0, -1e4, 1e4),
        "m3_down": ("bool", True, None, None),
        "m280_servo": ("int", 0, 0, 255),
        "m280_up_s": ("range", (70.0, 180.0), -1e4, 1e4),
        "m280_down_s": ("range", (0.0, 50.0), -1e4, 1e4),
    },
}
OPTIONAL_SECTIONS = {"gpio", "motion", "serial", "gondola", "cords", "gcode"}
# sections that belong to one machine kind; [page] is optional for the polar machine (its
# default is the square around the table's reach)
SECTION_WHEN = {"origin": "vplotter", "polar": "polar", "gondola": "vplotter", "cords": "vplotter"}
SECTION_CLASSES = {"machine": Machine, "origin": Origin, "polar": Polar, "page": Page,
                   "motors": Motors, "pen": Pen, "motion": Motion, "gpio": Gpio,
                   "serial": Serial, "gondola": Gondola, "cords": Cords, "gcode": Gcode}
PEN_CODES = {"output": (1, 2), "switch": (1, 2)}    # up_us, down_us of the pen rows
# values of the V-plotter's coil keys where they do not apply (the fields have no defaults)
NOT_USED = {"drive": "half", "steps_per_rev": 0, "spool_circumference_mm": 0.0, "left_pins": (),
            "right_pins": (), "left_reverse": False, "right_reverse": False}


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
    if base == "range":
        if (not isinstance(raw, list) or len(raw) != 2
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in raw)):
            raise ConfigError(f"{where} must be a range [low, high] (got {_fmt(raw)})")
        low, high = float(raw[0]), float(raw[1])
        if not lo <= low <= high <= hi:
            raise ConfigError(f"{where} must be [low, high] with {_fmt(lo)} <= low <= high <= "
                              f"{_fmt(hi)} (got {_fmt(raw)})")
        return (low, high)
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


def _choice(data: dict, path: str, section: str, key: str) -> str:
    """The value of one of the keys that decide which other keys apply."""
    table = data.get(section, {})
    kind, default, lo, hi = SCHEMA[section][key][:4]
    if not isinstance(table, dict) or key not in table:
        return default
    return _value(f"{path}: [{section}] {key}", kind, table[key], lo, hi)


def from_dict(data: dict, path: str = "config.toml") -> Config:
    """Validate a parsed TOML document; raise ConfigError naming the first bad key."""
    for section in data:
        if section not in SCHEMA:
            raise ConfigError(f"{path}: unknown section [{section}]")
    chosen = {"machine kind": _choice(data, path, "machine", "kind"),
              "driver": _choice(data, path, "motors", "driver"),
              "pen kind": _choice(data, path, "pen", "kind")}
    kind = chosen["machine kind"]

    def applies(when: str | None) -> bool:
        return when is None or all(w in chosen.values() for w in when.split())

    def whose(when: str) -> str:
        return " and ".join(f'{name} = "{w}"' for w in when.split()
                            for name, v in chosen.items() if w in SCHEMA_CHOICES[name])

    sections = {}
    for section, keys in SCHEMA.items():
        table = data.get(section)
        when = SECTION_WHEN.get(section)
        if not applies(when):
            if table is not None:
                raise ConfigError(f"{path}: [{section}] is only for {whose(when)}")
            continue
        if table is None:
            if section == "page" and kind == "polar":
                continue                          # the square around the reach, below
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
            if not applies(keys[key][4] if len(keys[key]) > 4 else None):
                raise ConfigError(f"{path}: [{section}] {key} is only for {whose(keys[key][4])}")
        values = {}
        for key, (kind_, default, lo, hi, *when_) in keys.items():
            where = f"{path}: [{section}] {key}"
            if when_ and not applies(when_[0]):
                continue
            if key not in table:
                if default is None:
                    raise ConfigError(f"{where} is missing")
                values[key] = None if default is UNSET else default
                continue
            values[key] = _value(where, kind_, table[key], lo, hi)
        if section == "motors":
            values["names"] = MOTOR_NAMES[kind]
            values = {**NOT_USED, **values}
        if section == "pen" and values["kind"] in PEN_CODES:
            values["up_us"], values["down_us"] = PEN_CODES[values["kind"]]
        sections[section] = SECTION_CLASSES[section](**values)
    if kind == "polar":
        sections.setdefault("origin", None)
        pol = sections["polar"]
        if pol.home_radius_mm is None and pol.home_pin is not None:
            raise ConfigError(f"{path}: [polar] home_radius_mm is missing (home_pin is set)")
        if "page" not in sections:
            r = pol.radius_max_mm
            sections["page"] = Page(pol.centre_x_mm - r, pol.centre_x_mm + r,
                                    pol.centre_y_mm - r, pol.centre_y_mm + r)
    cfg = Config(**sections, path=path)
    _check_geometry(cfg)
    return cfg


SCHEMA_CHOICES = {"machine kind": KINDS, "driver": DRIVERS, "pen kind": PEN_KINDS}


def _check_geometry(cfg: Config) -> None:
    path = cfg.path
    m = cfg.motors
    if m.driver == "stepdir":
        pins = [(f"[motors] {n}_{what}_pin", getattr(m, f"{n}_{what}_pin"))
                for n in m.names for what in ("step", "dir")]
        pins.append(("[motors] enable_pin", m.enable_pin))
    else:
        pins = [(f"[motors] {n}_pins", p) for n in m.names for p in getattr(m, f"{n}_pins")]
    pins.append(("[pen] pin", cfg.pen.pin))
    if cfg.pen.kind == "switch":
        pins.append(("[pen] switch_pin", cfg.pen.switch_pin))
    if cfg.polar is not None and cfg.polar.home_pin is not None:
        pins.append(("[polar] home_pin", cfg.polar.home_pin))
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
    up, down = cfg.gcode.m280_up_s, cfg.gcode.m280_down_s
    if up[0] <= down[1] and down[0] <= up[1]:
        raise ConfigError(f"{path}: [gcode] m280_up_s {_fmt(list(up))} and m280_down_s "
                          f"{_fmt(list(down))} must not overlap")
    if cfg.pen.up_us == cfg.pen.down_us:
        raise ConfigError(f"{path}: [pen] up_us and down_us must differ (both {cfg.pen.up_us})")
    if cfg.polar is not None:
        pol = cfg.polar
        if pol.radius_min_mm >= pol.radius_max_mm:
            raise ConfigError(f"{path}: [polar] radius_min_mm must be below radius_max_mm "
                              f"(got {pol.radius_min_mm:g} and {pol.radius_max_mm:g})")
        return
    spacing = cfg.gondola.cord_spacing_mm
    if spacing >= cfg.machine.anchor_distance_mm:
        raise ConfigError(f"{path}: [gondola] cord_spacing_mm must be below [machine] "
                          f"anchor_distance_mm (got {spacing:g} and "
                          f"{cfg.machine.anchor_distance_mm:g})")
    # The whole page must hang below the anchor line (the cords' ends: pen_below_mm above it).
    top = cfg.origin.y_mm - pg.y_max_mm - cfg.gondola.pen_below_mm
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


def state_dir() -> Path:
    """Where vplotter keeps the machine's truth: $XDG_STATE_HOME/vplotter (default
    ~/.local/state/vplotter): the stored position, the journal, the lock, live progress, and
    lgpio's notify FIFO."""
    base = os.environ.get("XDG_STATE_HOME") or os.path.join(os.path.expanduser("~"), ".local", "state")
    return Path(base) / "vplotter"
