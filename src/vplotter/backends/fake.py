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
                 sleep=None, switch_after_s: float = 0.5, **timing):
        """record: keep every played chunk in `recorded`; realtime: play in real time
        (clock, sleep and timing options such as spin_us go to `realtime.Player`);
        switch_after_s: an input (a switch, closing to ground) reads high until this much
        simulated time after it was first read, then low."""
        super().__init__(cfg)
        self.switch_after_us = int(round(switch_after_s * 1e6))
        self.t_us = 0
        self._first_read: dict[int, int] = {}
        self.record = record
        self.realtime = realtime
        self.recorded: list[Rows] = []
        self.coils = self.idle_word
        self.pen_us = 0
        self._player = None
        if realtime:
            self._player = Player(self._write_coils, self._write_pen, clock, sleep, **timing)
            self._player.coils = self.idle_word

    def _write_coils(self, word: int, changed: int) -> None:
        self.coils = word

    def _write_pen(self, pulse_us: int) -> None:
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
        if self.record:
            self.recorded.append(rows)
        self.coils = int(rows.coils[-1])
        self.pen_us = int(rows.pen_us[-1])
        self.t_us = int(rows.t_us[-1])
        return n

    def read_input(self, pin: int) -> bool:
        first = self._first_read.setdefault(pin, self.t_us)
        return self.t_us - first < self.switch_after_us

    def close(self) -> None:
        self.coils = self.idle_word
        self.pen_us = 0

    def lateness(self) -> dict | None:
        return self._player.lateness.stats() if self._player is not None else None

