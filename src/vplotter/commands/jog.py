"""Moving the pen by hand: arrow keys over SSH, or one move given on the command line.

Keys (a plain terminal is enough: no curses, only the escape sequences every terminal sends):
  arrows  move the pen by the step size (up arrow = +Y, the pen goes up the wall)
  + / -   double / halve the step size (0.1 .. 50 mm)
  u / d   pen up / down
  l / L   lengthen / shorten the left cord by the step size; r / R the right cord
  q       save the position and quit (Ctrl+C does the same)
Moves that would leave the page are refused.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from vplotter import kinematics, pipeline
from vplotter.inputs import gcode
from vplotter.errors import ConfigError, Interrupted, MachineError, VplotterError
from vplotter.motion.schedule import Scheduler

KEYS = {"\x1b[A": (0, 1), "\x1b[B": (0, -1), "\x1b[C": (1, 0), "\x1b[D": (-1, 0)}
STEP_MIN, STEP_MAX = 0.1, 50.0


def cord_rows(cfg, pos, counts, left_mm: float, right_mm: float, pen_down: bool = False):
    """Rows that lengthen (or shorten, if negative) the cords by the given mm. pos None: the
    position is unknown; the motors move by steps, and nothing can be checked against the
    page or the anchors."""
    spu = np.asarray(cfg.motors.steps_per_unit)
    delta = np.rint(np.array([left_mm, right_mm]) * spu).astype(np.int64)
    if pos is None:
        sched = Scheduler(cfg, None, counts, (0.0, 0.0))
        sched.pen_down = pen_down
        return sched.cord_move(delta)
    cords = np.asarray(pos.ref_mm) + (np.asarray(counts) + delta) / spu
    kin = kinematics.from_config(cfg)
    if cfg.machine.kind == "polar":       # left/right: the table (degrees) and the arm (mm)
        if not cfg.polar.radius_min_mm <= cords[1] <= cfg.polar.radius_max_mm:
            raise MachineError("error: the arm does not reach that far")
    else:
        d = cfg.machine.anchor_distance_mm
        if cords.min() <= 0 or cords.sum() <= d or abs(cords[0] - cords[1]) >= d:
            raise MachineError("error: the cords cannot be that long or short")
    xy = kin.to_gcode(kin.forward(cords[None, :]))[0]
    pg = cfg.page
    if not (pg.x_min_mm <= xy[0] <= pg.x_max_mm and pg.y_min_mm <= xy[1] <= pg.y_max_mm):
        raise MachineError(f"error: that would put the pen at X{xy[0]:.2f} Y{xy[1]:.2f}, "
                           f"outside the page")
    sched = Scheduler(cfg, kin, counts, pos.ref_mm)
    sched.pen_down = pen_down
    return sched.cord_move(delta)


def pen_xy(cfg, pos, counts) -> np.ndarray:
    """G-code point of the pen after `counts` steps from the stored position's reference."""
    kin = kinematics.from_config(cfg)
    cords = np.asarray(pos.ref_mm) + np.asarray(counts) / np.asarray(cfg.motors.steps_per_unit)
    return kin.to_gcode(kin.forward(cords[None, :]))[0]


def xy_records(cfg, pos, counts, target) -> list:
    """A G-code record moving the pen from where it is to the G-code point `target`."""
    here = pen_xy(cfg, pos, counts)
    return [gcode.Move(0, 0, float(here[0]), float(here[1]), float(target[0]), float(target[1]))]


def _read_key(fd: int) -> str:
    ch = os.read(fd, 1).decode("latin-1")
    if ch == "\x1b":
        seq = ch + os.read(fd, 2).decode("latin-1")
        return seq
    return ch


def interactive(args, cfg, pos, session) -> int:
    if not sys.stdin.isatty():
        raise ConfigError("error: interactive jog needs a terminal; "
                          "use --dx/--dy or --left/--right")
    import termios
    import tty

    fd = sys.stdin.fileno()
    step = min(max(args.step, STEP_MIN), STEP_MAX)
    print(__doc__.split("\n\n", 1)[1].split("Moves that")[0])
    old = termios.tcgetattr(fd)
    with session as s:
        pen_down = pos.pen == "down"
        # where the pen was sent: the next arrow moves from there (the motors stop within a
        # step of it, and a release may take a half step: motion/schedule.py), so nothing drifts
        xy = pen_xy(cfg, pos, s.counts)
        try:
            tty.setcbreak(fd)
            while True:
                kin = kinematics.from_config(cfg)
                sys.stdout.write(f"\rX{xy[0]:8.2f} Y{xy[1]:8.2f}  step {step:5.1f} mm  "
                                 f"pen {'down' if pen_down else 'up  '}  ")
                sys.stdout.flush()
                key = _read_key(fd)
                try:
                    if key in ("q", "\x03", "\x04"):
                        break
                    if key == "+":
                        step = min(step * 2, STEP_MAX)
                    elif key == "-":
                        step = max(step / 2, STEP_MIN)
                    elif key in ("u", "d"):
                        sched = Scheduler(cfg, kin, s.counts, pos.ref_mm)
                        sched.pen_down = pen_down
                        rows = sched.pen(key == "d")
                        if rows is not None:
                            s.play([rows])
                        pen_down = key == "d"
                    elif key in KEYS:
                        dx, dy = KEYS[key]
                        target = (xy[0] + dx * step, xy[1] + dy * step)
                        pg = cfg.page
                        if not (pg.x_min_mm <= target[0] <= pg.x_max_mm
                                and pg.y_min_mm <= target[1] <= pg.y_max_mm):
                            raise MachineError("refused: that move leaves the page")
                        recs = xy_records(cfg, pos, s.counts, target)
                        s.play(pipeline.stream(cfg, recs, s.counts, pos.ref_mm, "jog",
                                               pen_down=pen_down))
                        xy = target
                    elif key in ("l", "L", "r", "R"):
                        mm = step if key.islower() else -step
                        left, right = (mm, 0.0) if key in "lL" else (0.0, mm)
                        s.play([cord_rows(cfg, pos, s.counts, left, right, pen_down)])
                        xy = pen_xy(cfg, pos, s.counts)
                except Interrupted:
                    break
                except VplotterError as e:
                    sys.stdout.write(f"\r{str(e).replace('error: ', '')}\n")
        finally:
            termios.tcsetattr(fd, termios.TCSADRAIN, old)
            print()
    return 0
