"""Journal records and trace rows written in order on a helper thread, so that fsync and text
formatting stay off the thread that drives the outputs (used by machine/job.py's player)."""

from __future__ import annotations

import queue
import threading

from vplotter.motion.schedule import Rows


class Writer:
    """Writes journal records and trace rows in order on a helper thread (fsync and text
    formatting stay off the thread that drives the outputs)."""

    def __init__(self, tracer, threaded: bool = True):
        """threaded=False: write at once, on the calling thread."""
        self.tracer = tracer
        self.q: queue.Queue = queue.Queue(maxsize=64)   # a dry run must not outrun it unbounded
        self.landed = 0
        self.cond = threading.Condition()
        self.error: BaseException | None = None
        self.thread = None
        if threaded:
            self.thread = threading.Thread(target=self._run, daemon=True, name="vplotter-write")
            self.thread.start()

    def _run(self) -> None:
        while True:
            item = self.q.get()
            if item is None:
                return
            try:
                self._do(*item)
            except BaseException as e:  # noqa: BLE001 - reported by close()
                self.error = e
                with self.cond:
                    self.landed = 1 << 62
                    self.cond.notify_all()

    def _do(self, kind: str, args) -> None:
        if kind == "journal":
            journal, *rest = args
            journal.record(*rest)
            with self.cond:
                self.landed += 1
                self.cond.notify_all()
        elif self.tracer is not None:
            self.tracer.write(args)

    def _put(self, item) -> None:
        if self.thread is None:
            self._do(*item)
        else:
            self.q.put(item)

    def journal(self, journal, counts, dev, line: int, pen: str) -> None:
        self._put(("journal", (journal, tuple(counts), tuple(int(d) for d in dev), line, pen)))

    def trace(self, rows: Rows) -> None:
        self._put(("trace", rows))

    def wait_journal(self, records: int) -> None:
        with self.cond:
            while self.landed < records:
                self.cond.wait()

    def close(self) -> None:
        if self.thread is not None:
            self.q.put(None)
            self.thread.join()
        if self.error is not None:
            raise self.error
