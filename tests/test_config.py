"""config.toml: the seed config loads; every kind of mistake is one ConfigError naming the key."""

from __future__ import annotations

import copy
import re
import tomllib

import pytest

from vplotter import config
from vplotter.errors import ConfigError


@pytest.fixture
def seed(config_path) -> dict:
    return tomllib.loads(config_path.read_text(encoding="utf-8"))


def test_seed_config_loads(config_path):
    cfg = config.load(config_path)
    assert cfg.path == str(config_path)
    assert cfg.machine.anchor_distance_mm == 422.5
    assert (cfg.origin.x_mm, cfg.origin.y_mm) == (211.25, 430.0)
    assert (cfg.page.x_min_mm, cfg.page.x_max_mm, cfg.page.y_min_mm, cfg.page.y_max_mm) == (
        -200.0, 200.0, -250.0, 300.0)
    m = cfg.motors
    assert (m.drive, m.steps_per_rev, m.max_step_rate, m.max_accel) == ("half", 4096, 663.0, 2000.0)
    assert m.left_pins == (0, 5, 6, 13) and m.right_pins == (12, 16, 20, 21)
    assert m.left_reverse is True and m.right_reverse is False
    assert m.steps_per_unit == pytest.approx((4096 / 25.0, 4096 / 25.0))
    assert isinstance(m.max_step_rate, float) and isinstance(m.steps_per_rev, int)
    assert (cfg.pen.pin, cfg.pen.up_us, cfg.pen.down_us, cfg.pen.settle_s) == (24, 500, 1500, 0.3)
    assert cfg.gpio.backend == "lgpio"


def test_optional_sections_and_keys_take_their_defaults(seed):
    del seed["motion"], seed["gpio"], seed["motors"]["drive"], seed["motors"]["max_accel"]
    del seed["motors"]["left_reverse"], seed["pen"]["settle_s"]
    cfg = config.from_dict(seed)
    assert cfg.motion == config.Motion(0.01, 4.0, 8.0)
    assert cfg.gpio == config.Gpio("lgpio", 0)
    assert (cfg.motors.drive, cfg.motors.max_accel, cfg.motors.left_reverse) == ("half", 2000.0, False)
    assert cfg.pen.settle_s == 0.3


def _set(section, key, value):
    def change(d):
        d.setdefault(section, {})[key] = value
    return change


def _del(section, key=None):
    def change(d):
        if key is None:
            del d[section]
        else:
            del d[section][key]
    return change


BAD = [
    # (what is wrong, change to the seed config, exact message after "config.toml: ")
    ("unknown section", _set("motor", "drive", "half"), "unknown section [motor]"),
    ("unknown key", _set("motors", "max_step_rat", 5), "unknown key [motors] max_step_rat (did you mean max_step_rate?)"),
    ("unknown key, no hint", _set("pen", "colour", "red"), "unknown key [pen] colour"),
    ("missing section", _del("machine"), "missing section [machine]"),
    ("missing key", _del("motors", "steps_per_rev"), "[motors] steps_per_rev is missing"),
    ("missing key", _del("origin", "y_mm"), "[origin] y_mm is missing"),
    ("section not a table", lambda d: d.__setitem__("pen", 5), "[pen] must be a table"),
    ("number as string", _set("motors", "max_step_rate", "663"), "[motors] max_step_rate must be a number (got '663')"),
    ("bool as number", _set("machine", "anchor_distance_mm", True), "[machine] anchor_distance_mm must be a number (got true)"),
    ("float for int", _set("motors", "steps_per_rev", 4096.0), "[motors] steps_per_rev must be a whole number (got 4096)"),
    ("string for int", _set("pen", "pin", "24"), "[pen] pin must be a whole number (got '24')"),
    ("bool as string", _set("motors", "left_reverse", "yes"), "[motors] left_reverse must be true or false (got 'yes')"),
    ("bool as int", _set("motors", "right_reverse", 1), "[motors] right_reverse must be true or false (got 1)"),
    ("bad choice", _set("motors", "drive", "micro"), "[motors] drive must be one of half | full | wave (got 'micro')"),
    ("bad backend", _set("gpio", "backend", "rpi"), "[gpio] backend must be one of lgpio | gpiozero | fake (got 'rpi')"),
    ("pins not a list", _set("motors", "left_pins", 5), "[motors] left_pins must be a list of 4 BCM pin numbers (got 5)"),
    ("three pins", _set("motors", "left_pins", [1, 2, 3]), "[motors] left_pins must be a list of 4 BCM pin numbers (got [1, 2, 3])"),
    ("pin out of range", _set("motors", "right_pins", [12, 16, 20, 99]), "[motors] right_pins pin 99 is not a BCM number 0..63"),
    ("negative rate", _set("motors", "max_step_rate", -5), "[motors] max_step_rate must be above 0 (got -5)"),
    ("zero rate", _set("motors", "max_step_rate", 0), "[motors] max_step_rate must be above 0 (got 0)"),
    ("zero accel", _set("motors", "max_accel", 0.0), "[motors] max_accel must be above 0 (got 0)"),
    ("zero anchors", _set("machine", "anchor_distance_mm", 0), "[machine] anchor_distance_mm must be above 0 (got 0)"),
    ("negative spool", _set("motors", "spool_circumference_mm", -25.0), "[motors] spool_circumference_mm must be above 0 (got -25)"),
    ("zero steps", _set("motors", "steps_per_rev", 0), "[motors] steps_per_rev must be above 0 (got 0)"),
    ("zero speed", _set("motion", "draw_speed_mm_s", 0), "[motion] draw_speed_mm_s must be above 0 (got 0)"),
    ("zero tolerance", _set("motion", "tolerance_mm", 0.0), "[motion] tolerance_mm must be above 0 (got 0)"),
    ("negative settle", _set("pen", "settle_s", -0.1), "[pen] settle_s must be between 0 and 60 (got -0.1)"),
    ("pulse too long", _set("pen", "down_us", 3000), "[pen] down_us must be between 0 and 2600 (got 3000)"),
    ("nan", _set("motion", "travel_speed_mm_s", float("nan")), "[motion] travel_speed_mm_s must be a number (got nan)"),
    ("inf", _set("motors", "max_step_rate", float("inf")), "[motors] max_step_rate must be between 0 and 100000 (got inf)"),
    ("origin above the anchors", _set("origin", "y_mm", -5), "[origin] y_mm must be above 0 (got -5)"),
    ("origin on the anchor line", _set("origin", "y_mm", 0.0), "[origin] y_mm must be above 0 (got 0)"),
    ("page top above the anchors", _set("page", "y_max_mm", 500.0),
     "[page] y_max_mm = 500 puts the page top 70 mm above the anchors ([origin] y_mm = 430); "
     "lower y_max_mm or increase [origin] y_mm"),
    ("empty page", _set("page", "x_max_mm", -200.0), "[page] x_min_mm must be below x_max_mm (got -200 and -200)"),
    ("upside-down page", _set("page", "y_min_mm", 300.0), "[page] y_min_mm must be below y_max_mm (got 300 and 300)"),
    ("duplicate pin across motors", _set("motors", "right_pins", [12, 16, 20, 5]),
     "[motors] right_pins: pin 5 is already used by [motors] left_pins"),
    ("duplicate pin in one motor", _set("motors", "left_pins", [0, 5, 5, 13]),
     "[motors] left_pins: pin 5 is already used by [motors] left_pins"),
    ("pen on a motor pin", _set("pen", "pin", 21), "[pen] pin: pin 21 is already used by [motors] right_pins"),
    ("same servo pulses", _set("pen", "down_us", 500), "[pen] up_us and down_us must differ (both 500)"),
]


@pytest.mark.parametrize("what,change,message", BAD, ids=[b[0] for b in BAD])
def test_bad_config_names_the_key(seed, what, change, message):
    data = copy.deepcopy(seed)
    change(data)
    with pytest.raises(ConfigError) as e:
        config.from_dict(data, "config.toml")
    assert str(e.value) == f"config.toml: {message}"
    assert e.value.exit_code == 2


@pytest.mark.parametrize("content,message", [
    (None, "config file not found"),
    (b"", "missing section [machine]"),
    (b"[machine\n", "not valid TOML"),
    (b"[machine]\nanchor_distance_mm = 1\nanchor_distance_mm = 2\n", "not valid TOML"),
    (b"\xff\xfe\x00garbage", "cannot read config"),
])
def test_load_errors(tmp_path, content, message):
    p = tmp_path / "config.toml"
    if content is not None:
        p.write_bytes(content)
    with pytest.raises(ConfigError) as e:
        config.load(p)
    assert str(e.value).startswith(f"{p}: ") and message in str(e.value)
    assert "\n" not in str(e.value)


def test_load_directory(tmp_path):
    with pytest.raises(ConfigError, match="cannot read config"):
        config.load(tmp_path)


def test_load_names_the_file_in_errors(tmp_path, config_path):
    p = tmp_path / "mine.toml"
    p.write_text(config_path.read_text().replace("max_step_rate = 663", "max_step_rate = -5"))
    with pytest.raises(ConfigError) as e:
        config.load(p)
    assert str(e.value) == f"{p}: [motors] max_step_rate must be above 0 (got -5)"


def test_gcode_section_defaults_are_the_classic_pen_rules(seed):
    from vplotter.inputs.gcode import CLASSIC

    seed.pop("gcode", None)
    assert config.from_dict(seed).gcode == CLASSIC


def test_gcode_section_values_and_errors(seed):
    seed["gcode"] = {"pen": "m280", "z_down_below_mm": 1.5, "m3_down": False, "m280_servo": 2,
                     "m280_up_s": [100, 120], "m280_down_s": [10, 40.5]}
    g = config.from_dict(seed).gcode
    assert (g.pen, g.z_down_below_mm, g.m3_down, g.m280_servo) == ("m280", 1.5, False, 2)
    assert (g.m280_up_s, g.m280_down_s) == ((100.0, 120.0), (10.0, 40.5))
    for key, value, words in [("pen", "servo", "[gcode] pen must be one of"),
                              ("m3_down", 1, "[gcode] m3_down must be true or false"),
                              ("m280_up_s", [120, 100], "[gcode] m280_up_s must be [low, high]"),
                              ("m280_up_s", 90, "[gcode] m280_up_s must be a range"),
                              ("m280_down_s", [30, 110], "must not overlap"),
                              ("z_down_below", 1, "unknown key [gcode] z_down_below (did you mean z_down_below_mm?)")]:
        bad = copy.deepcopy(seed)
        bad["gcode"][key] = value
        with pytest.raises(ConfigError, match=re.escape(words)):
            config.from_dict(bad)


def test_pens_section_names_the_pens_owned(seed):
    data = copy.deepcopy(seed)
    assert config.from_dict(data).pens.owned == ()
    data["pens"] = {"change_x_mm": 0, "change_y_mm": 120,
                    "red": {"colour": "Red", "speed_mm_s": 20},
                    "ink": {"colour": "rgb(0, 0, 50%)", "down_us": 1400, "width_mm": 0.3}}
    pens = config.from_dict(data).pens
    assert pens.change_at == (0.0, 120.0)
    assert [(p.name, p.colour) for p in pens.owned] == [("red", "#ff0000"), ("ink", "#000080")]
    assert pens.get("red").speed_mm_s == 20.0 and pens.get("ink").down_us == 1400
    assert pens.get("blue") is None


@pytest.mark.parametrize("pens, message", [
    ({"red": {"color": "red"}}, r"\[pens.red\] unknown key color \(did you mean colour\?\)"),
    ({"red": {}}, r"\[pens.red\] colour is missing"),
    ({"red": {"colour": "reddish"}}, r"\[pens.red\] colour: not a colour: 'reddish'"),
    ({"red": {"colour": "none"}}, r"a pen needs a colour"),
    ({"red": {"colour": "red", "down_us": 9000}}, r"\[pens.red\] down_us"),
    ({"chnage_x_mm": 3}, r"unknown key \[pens\] chnage_x_mm \(did you mean change_x_mm\?\)"),
])
def test_pens_section_errors_name_the_pen_and_key(seed, pens, message):
    data = copy.deepcopy(seed)
    data["pens"] = pens
    with pytest.raises(ConfigError, match=message):
        config.from_dict(data)
