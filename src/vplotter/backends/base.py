"""The interface every backend implements (`Backend`)."""

from __future__ import annotations

from vplotter.config import Config
from vplotter.motion.schedule import Rows


def servo_widths(cfg: Config) -> tuple[int, ...]:
    """Every servo pulse a draw may send (us): [pen] up_us and down_us, and the down_us of
    each owned [pens.NAME] that has one of its own."""
    return (cfg.pen.up_us, cfg.pen.down_us,
            *(p.down_us for p in cfg.pens.owned if p.down_us is not None))


class Backend:
    """Base class. `open` claims the pins (motor outputs at the idle word, pen pulses off),
    `play` outputs rows at their times, `close` releases everything and must never raise.

    The motor outputs are one word over `coil_pins` (bit i = coil_pins[i]): IN1..IN4 of both
    motors for ULN2003 boards, or STEP, DIR of both motors and ENABLE for step/dir drivers
    (motion/drivers.py). `idle_word` is what they are when the motors are released: all low for
    coils, ENABLE high for step/dir drivers."""

    name = "base"

    def __init__(self, cfg: Config):
        self.cfg = cfg
        self.coil_pins = list(cfg.motors.out_pins)
        self.idle_word = cfg.motors.idle_word
        self.pen_pin = cfg.pen.pin
        self.stop_requested = False

    def open(self) -> None:
        raise NotImplementedError

    def play(self, rows: Rows) -> int:
        """Output the rows; return how many were played (fewer if a stop was requested)."""
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError

    def drain(self) -> None:
        """Wait until every row handed to play() has been output (a backend that queued rows
        ahead of the motors would override this; every backend here has written them all when
        play() returns)."""

    def read_input(self, pin: int) -> bool:
        """The level of an input pin (a switch), True = high."""
        raise NotImplementedError

    def lateness(self) -> dict | None:
        """For real-time backends: {"p50_ms", "p99_ms", "max_ms", "n"} of actual minus planned
        change times; None when timing is simulated."""
        return None

    def written_us(self):
        """Real-time backends: when each row of the last play() call was actually written
        (microseconds on the trace's clock), so that a trace shows what happened; None when
        timing is simulated (the rows' own times are what happened)."""
        player = getattr(self, "_player", None)
        return None if player is None else player.written_us

    def shifts(self) -> tuple[int, int]:
        """Real-time backends: how often lateness moved the timeline (by more than 0.1 ms) and
        the total time it moved (ns); (0, 0) when timing is simulated."""
        player = getattr(self, "_player", None)
        return (0, 0) if player is None else (player.shifts, player.lost_ns)

    def __enter__(self):
        self.open()
        return self

    def __exit__(self, *exc):
        self.close()
        return False
