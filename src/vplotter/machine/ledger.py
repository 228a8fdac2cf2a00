"""What a session stores about the machine: the position it started from (and a new reference
after `home`), the crash journal while the motors run, the pen in the gondola, and for a draw
what it is and where it can be resumed.

Without a position (none is stored: `jog --left/--right` before any `calibrate`) nothing is
stored and no journal is written: the position stays unknown, also after a crash. A session
that only moves the pen (`pen_only`: `vplotter pen`) writes no journal either (the motors stand)
and changes nothing of a stored position but its pen state."""

from __future__ import annotations

from vplotter.machine import state


class Ledger:
    def __init__(self, position: state.Position | None, drawing: dict | None = None,
                 pen_only: bool = False):
        self.position = position
        self.pen_only = pen_only
        # {"file", "sha256", ["options"], ["start"]} of a draw: after a crash, --resume goes on
        # from the journal; after a stop, from `resume`
        self.drawing = drawing
        self.journal: state.Journal | None = None
        self.pen_in: dict | None = position.extra.get("pen_in") if position is not None else None
        # None: not a draw (the stored resume stays as it is); {}: the draw finished;
        # {..., "line", "xy"}: where the stopped draw goes on
        self.resume: dict | None = None

    def begin(self, counts) -> None:
        """The motors are about to move: the stored position says the stop was not clean (until
        it is saved again) and the journal is started."""
        if self.position is None or self.pen_only:
            return
        if self.journal is None:
            pos = self.position.moved_to(counts)
            pos.clean = False
            if self.drawing:
                pos.extra["drawing"] = self.drawing
            state.save(pos)
            state.clear_journal()
            self.journal = state.Journal()

    def save(self, counts, pen_down: bool, clean: bool, waiting=None) -> None:
        """Store where the motors are. waiting: the Pause the draw was stopped at, if any."""
        if self.pen_only:
            self._save_pen(pen_down)
            return
        if self.position is None:       # unknown it was, unknown it stays
            return
        pos = self.position.moved_to(counts)
        pos.pen = "down" if pen_down else "up"
        pos.clean = clean
        pos.extra = {k: v for k, v in pos.extra.items() if k not in ("uncertain_steps", "line")}
        if clean:
            pos.extra.pop("drawing", None)
        if self.pen_in is not None:               # the pen in the gondola, as far as known
            pos.extra["pen_in"] = self.pen_in
        if self.resume is not None:               # only draw says where to resume (or not)
            pos.extra.pop("resume", None)
            pos.extra.pop("pen_change", None)
            w = waiting
            if w is not None and w.pen is not None:   # stopped while waiting for this pen
                pos.extra["pen_change"] = {"pen": w.pen, "index": int(w.index),
                                           "count": int(w.count), "message": w.message}
            if self.resume:
                pos.extra["resume"] = self.resume
        state.save(pos)
        if clean:
            state.clear_journal()
        self.position = pos

    def _save_pen(self, pen_down: bool) -> None:
        """Only the pen moved: a stored position (read now, under the lock) keeps everything
        but its pen state; none stored, none is made."""
        stored = state.load()
        if stored is None:
            return
        stored.pen = "down" if pen_down else "up"
        state.save(stored)

    def close(self) -> None:
        if self.journal is not None:
            self.journal.close()
            self.journal = None
