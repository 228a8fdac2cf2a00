"""The recording fake: plays rows on a simulated clock and never sleeps (tests and --dry-run).

With realtime=True it plays through the same timing loop as the gpiozero backend
(`realtime.Player`) into recording outputs, so scheduling lateness can be measured on any
machine (`vplotter draw FILE --dry-run --realtime --verbose`).
"""

from __future__ import annotations

from vplotter.backends import Backend
from vplotter.backends.realtime import Player
from vplotter.schedule import Rows


class FakeBackend(Backend):
    name = "fake"

    def __init__(self, cfg, record: bool = False, realtime: bool = False, clock=None,
                 sleep=None, **timing):
        """record: keep every played chunk in `recorded`; realtime: play in real time
        (clock, sleep and timing options such as spin_us go to `realtime.Player`)."""
        super().__init__(cfg)
        self.record = record
        self.realtime = realtime
        self.recorded: list[Rows] = []
        self.coils = 0
        self.pen_us = 0
        self._player = None
        if realtime:
            timing = {"min_step_us": 1e6 / cfg.motors.max_step_rate, **timing}
            self._player = Player(self._write_coils, self._write_pen, clock, sleep, **timing)

    def _write_coils(self, word: int, changed: int) -> None:
        self.coils = word

    def _write_pen(self, pulse_us: int) -> None:
        self.pen_us = pulse_us

    def open(self) -> None:
        self.coils = 0
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
        if self.record:
            self.recorded.append(rows)
        self.coils = int(rows.coils[-1])
        self.pen_us = int(rows.pen_us[-1])
        return n

    def close(self) -> None:
        self.coils = 0
        self.pen_us = 0

    def lateness(self) -> dict | None:
        return self._player.lateness.stats() if self._player is not None else None

