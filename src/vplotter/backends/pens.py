"""Pen lifts other than the servo, shared by the backends (the servo is each backend's own).

The schedule's pen rows carry `[pen] up_us` / `down_us` at a pen change and 0 when the settle
time is over; for these kinds the config sets them to the codes 1 (up) and 2 (down), which is
also what the trace shows on the pen pin. A backend hands every pen value to `set`:

- "output" (a solenoid): the pin is high while the pen is down;
- "switch" (the seed machine's cam): up = run the cam motor (pin high) until the cam's switch
  closes, at most `timeout_s` (then a clear error); down = run it `down_s` (the cam's quarter
  turn). 0 changes nothing.
"""

from __future__ import annotations

import time
from typing import Callable

from vplotter.errors import MachineError


def create(cfg, write: Callable[[int], None], read: Callable[[], bool] | None = None,
           clock: Callable[[], float] = time.monotonic,
           sleep: Callable[[float], None] = time.sleep):
    """write(level) drives the pen pin; read() is the switch pin's level (kind "switch")."""
    if cfg.pen.kind == "output":
        return OutputPen(cfg.pen, write)
    if cfg.pen.kind == "switch":
        return SwitchPen(cfg.pen, write, read, clock, sleep)
    return None


class OutputPen:
    def __init__(self, pen, write):
        self.pen, self.write = pen, write

    def set(self, value: int) -> None:
        if value in (self.pen.up_us, self.pen.down_us):
            self.write(int(value == self.pen.down_us))


class SwitchPen:
    def __init__(self, pen, write, read, clock, sleep):
        self.pen, self.write, self.read, self.clock, self.sleep = pen, write, read, clock, sleep

    def closed(self) -> bool:
        return self.read() != self.pen.switch_active_low

    def set(self, value: int) -> None:
        if value == self.pen.down_us:
            self.write(1)
            self.sleep(self.pen.down_s)
            self.write(0)
        elif value == self.pen.up_us and not self.closed():
            self.write(1)
            start = self.clock()
            try:
                while not self.closed():
                    if self.clock() - start > self.pen.timeout_s:
                        pen = self.pen
                        raise MachineError(
                            f"error: the pen cam's switch (GPIO{pen.switch_pin}) did not close "
                            f"within {pen.timeout_s:g} s; check the cam motor (GPIO{pen.pin}) "
                            f"and [pen] switch_pin, switch_active_low")
                    self.sleep(0.001)
            finally:
                self.write(0)
