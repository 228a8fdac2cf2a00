"""config.toml -> one frozen dataclass per section (`sections.py`).

Every key is declared once in SCHEMA (`schema.py`) with its type, default (None = required) and
bounds, and described once in `keys.py` (the docs' configuration reference is made from both);
a key nobody declared is an error (it is usually a typo), and every error names the key.
"""

from __future__ import annotations

import difflib
import os
import tomllib
from pathlib import Path
from typing import Any

from vplotter.config.schema import (NOT_USED, OPTIONAL_SECTIONS, PEN_CODES, PEN_KEYS,
                                    SCHEMA, SCHEMA_CHOICES, SECTION_CLASSES, SECTION_WHEN)
from vplotter.config.sections import (DRIVERS, DRIVES, KINDS, MOTOR_NAMES, PEN_KINDS, UNSET,
                                      Config, Cords, Gcode, Gondola, Gpio, Machine, Motion,
                                      Motors, Origin, Page, Pen, Polar, Serial)
from vplotter.errors import ConfigError

__all__ = ["Config", "ConfigError", "SCHEMA", "SCHEMA_CHOICES", "SECTION_WHEN",
           "OPTIONAL_SECTIONS", "UNSET", "from_dict", "load", "state_dir",
           "Machine", "Polar", "Origin", "Page", "Motors", "Pen", "Motion", "Gpio", "Gondola",
           "Cords", "Serial", "Gcode", "DRIVES", "KINDS", "DRIVERS", "PEN_KINDS", "MOTOR_NAMES",
           "NOT_USED", "PEN_CODES", "SECTION_CLASSES"]


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
    if base == "url":       # where a notification goes: http(s), one word
        if (not isinstance(raw, str) or not raw.lower().startswith(("http://", "https://"))
                or any(c.isspace() for c in raw) or len(raw) < 9):
            raise ConfigError(f"{where} must be an http:// or https:// URL (got {_fmt(raw)})")
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


def _pen_tables(table: dict, path: str) -> tuple[dict, tuple]:
    """[pens]: split the pen tables [pens.NAME] from the section's own keys; each pen's keys
    checked like any other (PEN_KEYS), its colour parsed to '#rrggbb'."""
    from vplotter.config.sections import PenSpec

    own, pens = {}, []
    for name, value in table.items():
        if not isinstance(value, dict):
            own[name] = value
            continue
        where = f"{path}: [pens.{name}]"
        for key in value:
            if key not in PEN_KEYS:
                close = difflib.get_close_matches(key, PEN_KEYS, n=1)
                hint = f" (did you mean {close[0]}?)" if close else ""
                raise ConfigError(f"{where} unknown key {key}{hint}")
        values = {}
        for key, (kind_, default, lo, hi) in PEN_KEYS.items():
            if key not in value:
                if default is None:
                    raise ConfigError(f"{where} {key} is missing")
                values[key] = None
                continue
            values[key] = _value(f"{where} {key}", kind_, value[key], lo, hi)
        from vplotter.inputs.colour import parse

        try:
            colour = parse(values.pop("colour"))
        except ValueError as e:
            raise ConfigError(f"{where} colour: {e}") from None
        if colour is None:
            raise ConfigError(f"{where} colour: a pen needs a colour, not none")
        pens.append(PenSpec(name=name, colour=colour, **values))
    return own, tuple(pens)


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
        if section == "pens":
            table, owned = _pen_tables(table, path)
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
        if section == "pens":
            values["owned"] = owned
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
    mass = cfg.gondola.mass_below_pen_mm
    if mass is not None and not mass + cfg.gondola.pen_below_mm > 0:
        raise ConfigError(f"{path}: [gondola] mass_below_pen_mm = {mass:g} puts the centre of "
                          f"mass above the line through the cords' points (pen_below_mm = "
                          f"{cfg.gondola.pen_below_mm:g}): the gondola would tip over")
    if cfg.cords.mass_g_per_m and cfg.gondola.mass_g is None:
        raise ConfigError(f"{path}: [cords] mass_g_per_m = {cfg.cords.mass_g_per_m:g} needs "
                          f"[gondola] mass_g (the gondola's mass in grams with its pen): the "
                          f"cords sag by their mass over the gondola's")
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
    base = (os.environ.get("XDG_STATE_HOME")
            or os.path.join(os.path.expanduser("~"), ".local", "state"))
    return Path(base) / "vplotter"
