"""The recording fake: plays rows on a simulated clock, never sleeps (tests and --dry-run)."""

from __future__ import annotations

from vplotter.backends import Backend
from vplotter.schedule import Rows


class FakeBackend(Backend):
    name = "fake"

    def __init__(self, cfg, record: bool = False, realtime: bool = False):
        super().__init__(cfg)
        self.record = record
        self.realtime = realtime  # real-time playing: see issue 4 (not yet built)
        self.recorded: list[Rows] = []
        self.clock_us = 0
        self.coils = 0
        self.pen_us = 0
        self.is_open = False
        self.rows_played = 0

    def open(self) -> None:
        self.is_open = True
        self.coils = 0
        self.pen_us = 0

    def play(self, rows: Rows) -> int:
        n = len(rows)
        if n == 0:
            return 0
        if self.record:
            self.recorded.append(rows)
        self.clock_us = int(rows.t_us[-1])
        self.coils = int(rows.coils[-1])
        self.pen_us = int(rows.pen_us[-1])
        self.rows_played += n
        return n

    def close(self) -> None:
        self.coils = 0
        self.pen_us = 0
        self.is_open = False
