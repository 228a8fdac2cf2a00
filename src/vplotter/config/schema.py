"""Every key of config.toml, declared once: section -> key -> (type, default, low or choices,
high, whose key it is). The default None means required, UNSET that the key may be left out
(the value is then None); "float+"/"int+" exclude the low bound. A key nobody declared is an
error (it is usually a typo). What each key means is in `keys.py` beside this file.
"""

from __future__ import annotations

from vplotter.config.sections import (DRIVERS, DRIVES, KINDS, PEN_KINDS, UNSET, Cords, Gcode,
                                      Gondola, Gpio, Machine, Motion, Motors, Notify, Origin, Page,
                                      Pen, Pens, Polar, Serial)

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
        "realtime": ("bool", False, None, None),
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
        "mass_below_pen_mm": ("float", UNSET, -1e3, 1e4),
        "mass_g": ("float+", UNSET, 0.0, 1e5),
    },
    "cords": {"stretch": ("float", 0.0, 0.0, 0.5),
              "mass_g_per_m": ("float", 0.0, 0.0, 1e4)},
    "gcode": {
        "pen": ("str", "auto", ("auto", "z", "m3", "m280"), None),
        "z_down_below_mm": ("float", 0.0, -1e4, 1e4),
        "m3_down": ("bool", True, None, None),
        "m280_servo": ("int", 0, 0, 255),
        "m280_up_s": ("range", (70.0, 180.0), -1e4, 1e4),
        "m280_down_s": ("range", (0.0, 50.0), -1e4, 1e4),
    },
    # [pens]: the change point, and one table [pens.NAME] per pen the person owns (PEN_KEYS)
    "pens": {"change_x_mm": ("float", UNSET, -1e5, 1e5),
             "change_y_mm": ("float", UNSET, -1e5, 1e5)},
    # [notify]: a JSON POST when a draw ends, pauses, fails or waits for a pen change
    "notify": {"url": ("url", UNSET, None, None),
               "timeout_s": ("float+", 5.0, 0.0, 60.0)},
}
PEN_KEYS: dict[str, tuple] = {
    "colour": ("text", None, None, None),
    "width_mm": ("float+", UNSET, 0.0, 100.0),
    "speed_mm_s": ("float+", UNSET, 0.0, 1e4),
    "down_us": ("int+", UNSET, 0, 2600),
}
OPTIONAL_SECTIONS = {"gpio", "motion", "serial", "gondola", "cords", "gcode", "pens", "notify"}
# sections that belong to one machine kind; [page] is optional for the polar machine (its
# default is the square around the table's reach)
SECTION_WHEN = {"origin": "vplotter", "polar": "polar", "gondola": "vplotter", "cords": "vplotter"}
SECTION_CLASSES = {"machine": Machine, "origin": Origin, "polar": Polar, "page": Page,
                   "motors": Motors, "pen": Pen, "motion": Motion, "gpio": Gpio,
                   "serial": Serial, "gondola": Gondola, "cords": Cords, "gcode": Gcode,
                   "pens": Pens, "notify": Notify}
PEN_CODES = {"output": (1, 2), "switch": (1, 2)}    # up_us, down_us of the pen rows
# values of the V-plotter's coil keys where they do not apply (the fields have no defaults)
NOT_USED = {"drive": "half", "steps_per_rev": 0, "spool_circumference_mm": 0.0, "left_pins": (),
            "right_pins": (), "left_reverse": False, "right_reverse": False}

SCHEMA_CHOICES = {"machine kind": KINDS, "driver": DRIVERS, "pen kind": PEN_KINDS}
