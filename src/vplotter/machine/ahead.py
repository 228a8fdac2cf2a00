"""The schedule's parts computed on a helper thread, a bounded number ahead of the motors, and
cut into journal stretches (used by machine/job.py's player and machine/serial_job.py)."""

from __future__ import annotations

import queue
import threading
from typing import Iterable

import numpy as np

from vplotter.backends import memory
from vplotter.motion.schedule import Rows

JOURNAL_EVERY_US = 500_000     # journal at least every 0.5 s of motion


def stretches(rows: Rows) -> Iterable[Rows]:
    """Cut rows into stretches of at most JOURNAL_EVERY_US, also right after pen changes.
    The stretches are copies: a view would keep the whole computed part (up to STEPS_PER_PART
    steps, megabytes) in memory until its last stretch is played."""
    n = len(rows)
    if n == 0:
        return
    t = rows.t_us
    marks = np.arange(t[0] + JOURNAL_EVERY_US, t[-1] + 1, JOURNAL_EVERY_US)
    cuts = set(np.searchsorted(t, marks).tolist())
    pen_rows = np.flatnonzero(rows.pen_us > 0)
    cuts.update((pen_rows + 1).tolist())
    bounds = [0] + [c for c in sorted(cuts) if 0 < c < n] + [n]
    for a, b in zip(bounds[:-1], bounds[1:]):
        yield rows[a:b].copy()


END = object()


class Failure:
    def __init__(self, exc: BaseException):
        self.exc = exc


class Ahead:
    """Computes the schedule's parts on a helper thread, a bounded number ahead."""

    def __init__(self, chunks: Iterable[Rows], depth: int = 8, split: bool = True,
                 threaded: bool = True):
        """split: cut the rows into journal stretches (only a run that stores the position
        journals; a dry run plays whole chunks); threaded=False: compute each part when it
        is asked for (a simulated machine waits for nobody)."""
        self.split = split
        self.q: queue.Queue = queue.Queue(maxsize=depth)
        self.stopped = threading.Event()
        self.thread = None
        if not threaded:
            self.parts = (p for rows in chunks for p in
                          (stretches(rows) if split and isinstance(rows, Rows) else (rows,)))
            return
        self.thread = threading.Thread(target=self._run, args=(chunks,), daemon=True,
                                       name="vplotter-plan")
        self.thread.start()

    def _put(self, item) -> bool:
        while not self.stopped.is_set():
            try:
                self.q.put(item, timeout=0.05)
                return True
            except queue.Full:
                continue
        return False

    def _run(self, chunks) -> None:
        try:
            for rows in chunks:
                for part in (stretches(rows) if self.split and isinstance(rows, Rows) else (rows,)):
                    if not self._put(part):
                        return
                rows = part = None      # the stretches are copies: the computed part can go
                memory.give_back()
            self._put(END)
        except BaseException as e:  # noqa: BLE001 - handed to the main thread
            self._put(Failure(e))

    def get(self) -> Rows | None:
        if self.thread is None:
            return next(self.parts, None)
        item = self.q.get()
        if isinstance(item, Failure):
            self.q.put(item)            # later calls see it too
            raise item.exc
        if item is END:
            self.q.put(END)
            return None
        return item

    def close(self) -> None:
        self.stopped.set()
        if self.thread is not None:
            self.thread.join(timeout=5)
