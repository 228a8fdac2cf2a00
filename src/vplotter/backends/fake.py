"""The recording fake: plays rows on a simulated clock and never sleeps (tests and --dry-run).

With realtime=True it plays through the same timing loop as the gpiozero backend
(`realtime.Player`) into recording outputs, so scheduling lateness can be measured on any
machine (`vplotter draw FILE --dry-run --realtime --verbose`).
"""

from __future__ import annotations

from vplotter.backends import pens
from vplotter.backends.base import Backend
from vplotter.backends.realtime import Player
from vplotter.motion.schedule import Rows


class FakeBackend(Backend):
    name = "fake"

    def __init__(self, cfg, record: bool = False, realtime: bool = False, clock=None,
                 sleep=None, switch_after_s: float = 0.5, **timing):
        """record: keep every played chunk in `recorded`; realtime: play in real time
        (clock, sleep and timing options such as spin_us go to `realtime.Player`);
        switch_after_s: an input (a switch, closing to ground) reads high until this much
        simulated time after it was first read, then low; the pen cam's switch closes this
        long after its motor starts (more than [pen] timeout_s: the pen lift fails)."""
        super().__init__(cfg)
        self.switch_after_us = int(round(switch_after_s * 1e6))
        self.t_us = 0
        self._first_read: dict[int, int] = {}
        self._sim_s = 0.0
        self._cam_on, self._cam_closed, self._cam_started = False, False, 0.0
        self._pen = pens.create(cfg, self._cam_motor, self._cam_read, lambda: self._sim_s,
                                self._sim_sleep)
        self.record = record
        self.realtime = realtime
        self.recorded: list[Rows] = []
        self.coils = self.idle_word
        self.pen_us = 0
        self._player = None
        if realtime:
            timing = {"min_step_us": 1e6 / cfg.motors.max_step_rate, **timing}
            self._player = Player(self._write_coils, self._write_pen, clock, sleep, **timing)
            self._player.coils = self.idle_word

    def _write_coils(self, word: int, changed: int) -> None:
        self.coils = word

    def _write_pen(self, pulse_us: int) -> None:
        if self._pen is not None and pulse_us:
            self._pen.set(pulse_us)
        self.pen_us = pulse_us

    def open(self) -> None:
        self.coils = self.idle_word
        self.pen_us = 0

    def play(self, rows: Rows) -> int:
        n = len(rows)
        if n == 0 or self.stop_requested:
            return 0
        if self._player is not None:
            n = self._player.play(rows, lambda: self.stop_requested)
            if n == 0:
                return 0
            rows = rows[:n]
        if self._player is None:
            self._pen_action(rows)
        if self.record:
            self.recorded.append(rows)
        self.coils = int(rows.coils[-1])
        self.pen_us = int(rows.pen_us[-1])
        self.t_us = int(rows.t_us[-1])
        return n

    def _pen_action(self, rows: Rows) -> None:
        if self._pen is None:
            return
        for v in rows.pen_us[rows.pen_us > 0].tolist():
            self._pen.set(v)

    # the simulated cam: its switch closes switch_after_s after the motor starts turning it
    # up; after a down run it is open
    def _cam_motor(self, level: int) -> None:
        if level and not self._cam_on:
            self._cam_started = self._sim_s
        elif not level and self._cam_on:
            self._cam_closed = self._cam_switch()
        self._cam_on = bool(level)

    def _cam_switch(self) -> bool:
        return self._cam_on and self._sim_s - self._cam_started >= self.switch_after_us / 1e6 \
            or (not self._cam_on and self._cam_closed)

    def _cam_read(self) -> bool:
        return self._cam_switch() != self.cfg.pen.switch_active_low

    def _sim_sleep(self, seconds: float) -> None:
        self._sim_s += seconds

    def read_input(self, pin: int) -> bool:
        first = self._first_read.setdefault(pin, self.t_us)
        return self.t_us - first < self.switch_after_us

    def close(self) -> None:
        self.coils = self.idle_word
        self.pen_us = 0

    def lateness(self) -> dict | None:
        return self._player.lateness.stats() if self._player is not None else None

