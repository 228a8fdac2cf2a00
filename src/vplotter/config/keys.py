"""One line about every key of config.toml, "section.key" -> description.

`schema.py` says what a key is (type, default, bounds, whose it is); this says what it means.
The docs' configuration reference is generated from both (docs/hooks/config_reference.py), and
tests/test_config_docs.py checks that every SCHEMA key has a description and no description
names a key SCHEMA lacks. Markdown is allowed (the text goes into a table cell).
"""

from __future__ import annotations

SECTIONS: dict[str, str] = {
    "machine": "The machine kind and, for a V-plotter, its anchors.",
    "origin": "Where G-code X0 Y0 lies in the V-plotter's machine frame (origin at the LEFT "
              "cord anchor, +x right, +y DOWN).",
    "polar": "The polar plotter: a rotary table under a linear arm (replaces [origin] and "
             "anchor_distance_mm).",
    "page": "The drawable area in G-code coordinates; points outside are refused before "
            "anything moves. Optional for the polar plotter (default: the square around "
            "radius_max_mm).",
    "motors": "The two motors, their drivers and pins, their limits.",
    "pen": "How the pen is lifted and lowered.",
    "motion": "Path tolerance and speed caps.",
    "gpio": "Which GPIO library plays the schedule, on which chip.",
    "serial": "A grbl 1.1 / grblHAL / FluidNC controller on a serial port (`--backend serial`).",
    "gondola": "Where the cords hold the gondola, relative to the pen (V-plotter).",
    "cords": "How much the cords stretch under the gondola's weight (V-plotter).",
    "gcode": "How G-code files move the pen (the pen dialect).",
    "pens": "Where the gondola waits for a pen change, and the pens you own: one table "
            "`[pens.NAME]` per pen with `colour` (a name such as `red`, `#rgb`, `#rrggbb`, "
            "required), and optionally `width_mm` (its line: the spacing of the hatch fills it "
            "draws unless `--fill-spacing` is given), `speed_mm_s` (draw speed cap with this pen) "
            "and `down_us` (servo pulse for pen down with this pen). Colours in a file are "
            "matched to the nearest pen you own; without pen tables each colour is a pen of its "
            "own.",
    "notify": "Where to send a JSON POST when a draw ends, pauses, fails or waits for a pen "
              "change (ntfy and other webhook services take it; a failing one is logged and "
              "the plot goes on).",
}

DESCRIPTIONS: dict[str, str] = {
    # [machine]
    "machine.kind": "`vplotter` (two cords) or `polar` (rotary table and linear arm; then "
                    "[polar] replaces [origin] and `anchor_distance_mm`).",
    "machine.anchor_distance_mm": "Distance between the two cord anchors (the points where "
                                  "the cords leave the spools).",
    # [origin]
    "origin.x_mm": "Machine x of G-code X0 (mm right of the left anchor).",
    "origin.y_mm": "Machine y of G-code X0 Y0 (mm below the anchors; G-code +Y is up, so "
                   "G-code X, Y lands at machine (x_mm + X, y_mm - Y)).",
    # [polar]
    "polar.centre_x_mm": "X of the table's axis, in G-code coordinates.",
    "polar.centre_y_mm": "Y of the table's axis, in G-code coordinates.",
    "polar.arm_angle_deg": "Direction of the pen's linear axis from the centre (0 = +X).",
    "polar.radius_min_mm": "The arm's inner reach; negative: the arm can pass over the centre.",
    "polar.radius_max_mm": "The arm's outer reach.",
    "polar.home_pin": "BCM pin of the arm's end switch (`vplotter home`); unset: no switch.",
    "polar.home_radius_mm": "The pen's radius when the end switch closes.",
    "polar.home_active_low": "true: the end switch closes to ground (the pin is pulled up).",
    # [page]
    "page.x_min_mm": "Left edge of the drawable area (G-code X).",
    "page.x_max_mm": "Right edge of the drawable area (G-code X).",
    "page.y_min_mm": "Bottom edge of the drawable area (G-code Y).",
    "page.y_max_mm": "Top edge of the drawable area (G-code Y).",
    # [motors]
    "motors.driver": "`uln2003` (coil sequences on ULN2003 boards) or `stepdir` (A4988, "
                     "DRV8825: a STEP and a DIR pin per motor, one ENABLE).",
    "motors.drive": "Coil sequence: `half` (8 phases), `full` (two coils on), `wave` (one "
                    "coil on).",
    "motors.steps_per_rev": "Sequence steps per spool turn for that drive (4096 half-steps "
                            "for a 28BYJ-48).",
    "motors.spool_circumference_mm": "Cord wound per spool turn (`calibrate steps` measures "
                                     "it).",
    "motors.rotary_steps_per_deg": "Steps per degree of the table (the microstep factor "
                                   "included).",
    "motors.linear_steps_per_mm": "Steps per mm of the arm (the microstep factor included).",
    "motors.max_step_rate": "Steps/s per motor; the planner keeps each motor at or below "
                            "99.8 % of it, and a stall never makes it step faster.",
    "motors.max_accel": "Steps/s² per motor (the planner uses 96 % of it).",
    "motors.left_pins": "BCM numbers of the left ULN2003 board's IN1..IN4.",
    "motors.right_pins": "BCM numbers of the right ULN2003 board's IN1..IN4.",
    "motors.rotary_pins": "BCM numbers of the table motor's ULN2003 IN1..IN4.",
    "motors.linear_pins": "BCM numbers of the arm motor's ULN2003 IN1..IN4.",
    "motors.left_step_pin": "STEP pin of the left motor's driver.",
    "motors.left_dir_pin": "DIR pin of the left motor's driver (high lengthens the cord "
                           "unless `left_reverse`).",
    "motors.right_step_pin": "STEP pin of the right motor's driver.",
    "motors.right_dir_pin": "DIR pin of the right motor's driver (high lengthens the cord "
                            "unless `right_reverse`).",
    "motors.rotary_step_pin": "STEP pin of the table motor's driver.",
    "motors.rotary_dir_pin": "DIR pin of the table motor's driver.",
    "motors.linear_step_pin": "STEP pin of the arm motor's driver.",
    "motors.linear_dir_pin": "DIR pin of the arm motor's driver.",
    "motors.enable_pin": "ENABLE pin of both drivers, active low (pull it up to 3.3 V so the "
                         "motors are free while the Pi boots).",
    "motors.dir_setup_us": "DIR is set this long before the STEP edge when it changes.",
    "motors.step_pulse_us": "STEP stays high (and low) at least this long.",
    "motors.left_reverse": "true: stepping forward (through the sequence, or DIR high) "
                           "shortens the left cord.",
    "motors.right_reverse": "true: stepping forward (through the sequence, or DIR high) "
                            "shortens the right cord.",
    "motors.rotary_reverse": "true: DIR high (or stepping forward) turns the table clockwise "
                             "seen from above; false: counter-clockwise (the angle grows).",
    "motors.linear_reverse": "true: DIR high (or stepping forward) moves the pen towards the "
                             "centre; false: away from it.",
    "motors.left_spool_circumference_mm": "The left motor's own cord per turn (`calibrate "
                                          "fit` writes it); unset: `spool_circumference_mm`.",
    "motors.right_spool_circumference_mm": "The right motor's own cord per turn (`calibrate "
                                           "fit` writes it); unset: "
                                           "`spool_circumference_mm`.",
    # [pen]
    "pen.kind": "`servo` (pulses of `up_us`/`down_us`), `output` (`pin` held high while the "
                "pen is down: a solenoid) or `switch` (`pin` runs a cam motor, `switch_pin` "
                "reads the cam's switch).",
    "pen.pin": "BCM pin of the servo signal, the solenoid or the cam motor.",
    "pen.up_us": "Servo pulse width for pen up (µs); try values with `vplotter pen up --up-us`.",
    "pen.down_us": "Servo pulse width for pen down (µs); try values with `vplotter pen down "
                   "--down-us`.",
    "pen.settle_s": "Wait after a pen change before moving; the servo pulses stop then (no "
                    "buzzing).",
    "pen.switch_pin": "The cam's switch, closed in the pen-up position.",
    "pen.switch_active_low": "true: the cam's switch closes to ground (the pin is pulled up).",
    "pen.timeout_s": "Pen up runs the cam motor until the switch closes, at most this long "
                     "(then a clear error, nothing more moves).",
    "pen.down_s": "Pen down runs the cam motor this long (a quarter turn of the cam).",
    # [motion]
    "motion.tolerance_mm": "Largest distance of the planned path from the true line or arc.",
    "motion.draw_speed_mm_s": "Pen-down speed cap; a lower modal F in the file lowers it.",
    "motion.travel_speed_mm_s": "Pen-up speed cap.",
    # [gpio]
    "gpio.backend": "`lgpio`, `gpiozero` or `fake` (`--backend` overrides; `--dry-run` is "
                    "always `fake`).",
    "gpio.chip": "gpiochip number (a Pi 5 with a kernel older than 6.6.45 uses 4).",
    "gpio.realtime": "With `backend = \"fake\"`: play in real time, as `--realtime` does (a "
                     "simulated plotter that takes the plot time: try `vplotter serve` on a "
                     "computer).",
    # [serial]
    "serial.port": "The controller's serial port.",
    "serial.baud": "Baud rate of the port.",
    "serial.rx_buffer": "The controller's receive buffer in bytes (grbl: 128; grblHAL and "
                        "FluidNC have more).",
    "serial.pen_down": "The line that lowers the pen (followed by `G4 P<settle_s>`).",
    "serial.pen_up": "The line that lifts the pen (followed by `G4 P<settle_s>`).",
    "serial.axes": "`motors`: X and Y are the left and right cord in mm (a plain Cartesian "
                   "grbl); `xy`: G-code X and Y, for firmware that does the plotter's "
                   "kinematics itself.",
    "serial.feed_scale": "Multiplies every feed sent (pen speed to controller feed).",
    "serial.timeout_s": "No answer for this long (banner, status, `ok`) is a lost controller.",
    # [gondola]
    "gondola.cord_spacing_mm": "Horizontal distance between the two points where the cords "
                               "hold the gondola (`calibrate fit --fit-spacing` fits it).",
    "gondola.pen_below_mm": "How far the pen (midway between those points) is below the line "
                            "through them.",
    "gondola.mass_below_pen_mm": "Where the gondola's centre of mass lies below the pen, on "
                                 "its symmetry line (negative: above it). Set, the gondola "
                                 "tilts as the cords pull unevenly and the kinematics follow "
                                 "it (`calibrate fit --fit-mass` fits it); unset: the gondola "
                                 "is taken to stay level.",
    "gondola.mass_g": "The gondola's mass in grams with its pen (and any weight added): with "
                      "`[cords] mass_g_per_m` it says how far the cords sag.",
    # [cords]
    "cords.stretch": "The cords' elastic strain when one cord alone carries the gondola's "
                     "whole weight (`calibrate fit` fits it).",
    "cords.mass_g_per_m": "The cords' mass in grams per metre: heavy cords (bead chain, a GT2 "
                          "belt) sag in a catenary and the kinematics follow it (needs "
                          "`[gondola] mass_g`); 0: straight cords.",
    # [gcode]
    "gcode.pen": "How files move the pen: `auto` (the first Z word or `M280 P<m280_servo>` "
                 "decides, else M3/M5), `z`, `m3` or `m280`.",
    "gcode.z_down_below_mm": "Z files: Z below this is pen down.",
    "gcode.m3_down": "M3/M5 files: true: M3 lowers the pen and M5 lifts it; false: the "
                     "reverse.",
    "gcode.m280_servo": "Servo files: the P number of the pen servo in `M280 P0 S90`.",
    "gcode.m280_up_s": "Servo files: the range of S (angle) that means pen up.",
    "gcode.m280_down_s": "Servo files: the range of S that means pen down (must not overlap "
                         "`m280_up_s`; any other S is an error).",
    # [pens]
    "pens.change_x_mm": "G-code X where the gondola waits while you change the pen (with "
                        "`change_y_mm`; default: where the plot started).",
    "pens.change_y_mm": "G-code Y where the gondola waits while you change the pen.",
    # [notify]
    "notify.url": "http:// or https:// address that gets the POST (e.g. an ntfy topic); "
                  "unset: no notifications.",
    "notify.timeout_s": "Give up on a notification after this many seconds (logged; the plot "
                        "never waits for it).",
}
