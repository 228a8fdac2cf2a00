"""Running a schedule on the machine safely: lock, backend, signals, journal, trace.

`Session` is used by every command that moves something (draw, jog, goto, home, pen,
calibrate steps). It guarantees, whatever happens (error, Ctrl+C, SIGTERM, SSH hang-up):
the pen is lifted, the coils are released, the exact position reached is stored, and a second
process cannot drive the same plotter at the same time. A dry run (the fake backend without
--realtime) takes no lock and never writes the stored position.

A draw hands its session a `DrawJob` when it makes it: what is drawn (stored with the position,
so that a stopped or crashed draw can be resumed), whether it runs in the background, how its
live status is published and what happens at a pause. What the session learns for its caller
is asked for with methods (`go_live`, `resume_from`, `finished`, `rebase`, `here`), never set
on it from outside.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from vplotter.motion import drivers
from vplotter.machine import state
from vplotter.machine.ahead import JOURNAL_EVERY_US, Ahead, stretches
from vplotter.machine.ledger import Ledger
from vplotter.machine.position import check_machine, load_position, uncertainty_mm
from vplotter.machine.signals import SIGNALS, Signals
from vplotter.machine.writer import Writer as _Writer
from vplotter.errors import BackendError, Interrupted
from vplotter.motion.schedule import Rows

# the names other modules have imported from here
__all__ = ["DrawJob", "JOURNAL_EVERY_US", "SIGNALS", "Session", "Stop", "check_machine",
           "load_position", "uncertainty_mm"]
_split = stretches
_Ahead = Ahead


@dataclass
class Stop:
    signum: int
    counts: tuple[int, int]
    line: int


@dataclass(frozen=True)
class DrawJob:
    """What a draw's session needs from the command: the file (`name` as given, for messages;
    `file` its absolute path), its hash and the options that placed and ordered it (a resume
    needs the same), `detached`: a background draw (SIGHUP does not stop it, pauses wait for
    `vplotter continue`), `publisher(time_s)`: makes the live status (machine/live.Publisher)
    once the plot time is known (None: nothing is published), `on_pause(pause, stop, progress)`:
    what happens at a Pause, everything before it played (stop() tells that a signal came)."""

    name: str
    file: str
    sha256: str
    options: str | None = None
    detached: bool = False
    publisher: Callable | None = None
    on_pause: Callable | None = None

    def record(self) -> dict:
        """What is stored with the position while it draws (and in `resume`)."""
        rec = {"file": self.file, "sha256": self.sha256}
        if self.options is not None:
            rec["options"] = self.options
        return rec


def _eprint(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


class Session:
    def __init__(self, cfg, command: str, backend_name: str, dry_run: bool, trace=None,
                 realtime: bool = False, position: state.Position | None = None,
                 job: DrawJob | None = None, pen_only: bool = False):
        """position: the stored position the motors start from, None if none is stored (the
        motors may still move by steps; nothing is stored). pen_only: only the pen moves
        (machine/ledger.py)."""
        self.cfg = cfg
        self.command = command
        self.backend_name = backend_name
        self.dry_run = dry_run
        # [gpio] realtime: the fake backend of a real (not dry) run plays in real time
        self.realtime = realtime or (backend_name == "fake" and not dry_run
                                     and bool(getattr(getattr(cfg, "gpio", None), "realtime",
                                                      False)))
        self.trace_path = trace
        self.job = job
        self.ledger = Ledger(position, job.record() if job is not None else None, pen_only)
        self.signals = Signals(ignore_hangup=job is not None and job.detached)
        self.counts = position.counts if position is not None else (0, 0)
        self.stop: Stop | None = None
        self.backend = None
        self.tracer = None
        self._trace_file = None
        self._lock = None
        self.t_us = 0          # schedule time of the last row played
        self.line = 0
        self.pen_down = False
        self.coils: int | None = None     # the motor output word last played
        self._moved = False
        self._writer: _Writer | None = None
        self.live = None        # live.Publisher while a draw runs (go_live)
        self.waiting = None     # the Pause being waited at
        self._waited = (0, 0)   # pauses waited at, and for how long (ns)

    @property
    def saves_state(self) -> bool:
        return not self.dry_run

    @property
    def position(self) -> state.Position | None:
        """The stored position the counts are taken from (the last one saved)."""
        return self.ledger.position

    @property
    def drawing(self) -> dict | None:
        """{"file", "sha256", ...} of the draw (what is stored with the position), or None."""
        return self.ledger.drawing

    @property
    def stop_pending(self) -> bool:
        """A signal asked to stop."""
        return self.signals.pending

    # ------------------------------------------------------------ context
    def __enter__(self) -> "Session":
        from vplotter import backends
        from vplotter.machine import lock
        from vplotter.machine.trace import TraceWriter

        if self.saves_state:
            self._lock = lock.acquire(self.command)
        try:
            options = {"realtime": True} if self.realtime else {}
            self.backend = backends.create(self.backend_name, self.cfg, **options)
            self.backend.open()
            if self.trace_path:
                self._trace_file = open(self.trace_path, "w", encoding="utf-8")
                self.tracer = TraceWriter(self._trace_file, self.backend.coil_pins,
                                          self.backend.pen_pin)
            self.signals.install(self._stop_soon)
        except BaseException:
            self._cleanup()
            raise
        return self

    def _stop_soon(self) -> None:
        if self.backend is not None:
            self.backend.stop_requested = True

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc is not None and self._moved and not isinstance(exc, Interrupted):
                self._abort()
            if self.backend is not None and not isinstance(exc, BackendError):
                try:
                    self.backend.drain()     # the stored position must be where the motors are
                except Exception:  # noqa: BLE001 - close() below still releases everything
                    pass
        finally:
            if self._moved and self.saves_state:
                # after a backend failure nobody knows what the motors last did
                self._save(clean=not isinstance(exc, BackendError))
            self.end_live(exc)
            self._cleanup()
        return False

    # ------------------------------------------------------------ what the caller says
    def go_live(self, time_s: float) -> None:
        """The draw is validated (time_s of plot time): its live status is published from now
        on (`vplotter status`, the page, [notify]), if the job has a publisher."""
        if self.job is not None and self.job.publisher is not None:
            self.live = self.job.publisher(time_s)
            self.live.update(0.0, 0, force=True)

    def place(self, start_xy) -> None:
        """The drawing was ordered from G-code point start_xy: stored with it, so that a
        resumed draw is ordered the same way (its record numbers match)."""
        self.ledger.drawing["start"] = list(start_xy)

    def resume_from(self, xy) -> dict | None:
        """The draw was stopped at G-code point xy: if something of it was drawn, the stored
        position says to resume it from the line reached (returned), else None."""
        if self.line > 0:
            self.ledger.resume = {**self.ledger.drawing, "line": self.line,
                                  "xy": [float(xy[0]), float(xy[1])]}
        return self.ledger.resume

    def finished(self) -> None:
        """The draw ran to its end: nothing is left to resume."""
        self.ledger.resume = {}

    def rebase(self, position: state.Position) -> None:
        """From here on the counts are taken from this position (`home` found its reference)."""
        self.ledger.position = position

    def here(self) -> state.Position:
        """The position reached, from the current reference."""
        return self.ledger.position.moved_to(self.counts)

    def end_live(self, exc) -> None:
        """The live status (and [notify]) says how the draw ended: ended, stopped, failed."""
        if self.live is not None:
            self.live.close("ended" if exc is None else
                            "stopped" if isinstance(exc, Interrupted) else "failed")
            self.live = None

    def lift_and_release(self) -> None:
        """Pen up and coils released now, between two plays (the Python API stopped by a
        signal while its script's own code ran)."""
        self._abort()

    def hand_over_pins(self):
        """`draw --detach`: before anything moved, give up the pins, the trace and the signal
        handlers, but not the lock, which is returned: the caller passes it on to the process
        that goes on from here and then closes it with Lock.hand_over() (never unlocking)."""
        assert not self._moved
        held, self._lock = self._lock, None
        self._cleanup()
        return held

    def _cleanup(self) -> None:
        if self.live is not None:
            self.live.close()
            self.live = None
        self.signals.restore()
        if self.backend is not None:
            self.backend.close()
        if self._trace_file is not None:
            self._trace_file.close()
            self._trace_file = None
        self.ledger.close()
        if self._lock is not None:
            self._lock.release()
            self._lock = None

    def _interrupted(self) -> Interrupted:
        signum = self.signals.signum
        self.stop = Stop(signum, self.counts, self.line)
        return Interrupted(f"stopped by {self.signals.name()}", signum)

    # ------------------------------------------------------------ playing
    def play(self, chunks: Iterable[Rows], progress=None) -> None:
        """Play rows; on a signal stop, lift the pen, release and raise Interrupted.
        progress(t_us, line) is called after every stretch played.

        The schedule is computed on a helper thread ahead of the motors, and the journal and
        the trace are written on another, so that the thread driving the outputs does nothing
        else while the motors run.
        """
        # a simulated machine (the fake backend, not in real time) needs no helper threads
        threaded = self.realtime or self.backend_name != "fake"
        ahead = Ahead(chunks, split=self.saves_state, threaded=threaded)
        self._writer = _Writer(self.tracer, threaded=threaded)
        switch = sys.getswitchinterval()
        sys.setswitchinterval(0.0005)     # hand the interpreter back to the player quickly
        try:
            cur, k = ahead.get(), 0
            while cur is not None and not self.signals.signum:
                if not isinstance(cur, Rows):        # a pause: wait once all is played
                    self.backend.drain()
                    k = self._pause(cur, k, progress)
                    if self.signals.signum:
                        break
                    cur = ahead.get()
                    continue
                nxt = ahead.get()
                if self.saves_state and self._begin_motion():
                    # until the next record lands the motors are in this part or the next
                    span = cur if not isinstance(nxt, Rows) else Rows.concat([cur, nxt])
                    dev = np.abs(span.steps - np.asarray(self.counts)).max(axis=0)
                    up = self.cfg.pen.up_us           # any other pulse is a pen down (per pen)
                    down = self.pen_down or bool(((cur.pen_us > 0) & (cur.pen_us != up)).any())
                    self._writer.wait_journal(k - 1)
                    self._writer.journal(self.ledger.journal, self.counts, dev, int(cur.line[0]),
                                         "down" if down else "up")
                    k += 1
                n = self.backend.play(cur)
                self._played(cur, n)
                if progress is not None:
                    progress(self.t_us, self.line)
                if self.live is not None:
                    self._publish()
                if n < len(cur):
                    break
                cur = nxt
        finally:
            sys.setswitchinterval(switch)
            ahead.close()
            writer, self._writer = self._writer, None
            writer.close()
        if self.signals.signum:
            self._abort()
            raise self._interrupted()

    def _pause(self, p, k: int, progress) -> int:
        """Wait at a Pause: it is the line being done (a stop now resumes there, and a
        resumed draw asks for the pen again), the journal has the exact position (the motors
        stand), status shows the wait. Returns the journal records written."""
        self.line = int(p.line)
        if self.ledger.journal is not None:
            self._writer.wait_journal(k - 1)
            self._writer.journal(self.ledger.journal, self.counts, (0, 0), self.line, "up")
            self._writer.wait_journal(k + 1)
            k += 1
        self.waiting = p
        if self.live is not None:
            self.live.waiting(p)
        t0 = time.monotonic_ns()
        if self.job is not None and self.job.on_pause is not None:
            self.job.on_pause(p, lambda: self.stop_pending, progress)
        # a real-time player moves its timeline by the wait: that is no lateness
        self._waited = (self._waited[0] + 1, self._waited[1] + time.monotonic_ns() - t0)
        if self.signals.signum:          # stopped while waiting: the change is still to do
            return k
        self.waiting = None
        if p.pen is not None:
            self.ledger.pen_in = {"pen": p.pen, "index": int(p.index), "count": int(p.count)}
        if self.live is not None:
            self.live.waiting(None)
        return k

    def _publish(self, force: bool = False) -> None:
        shifts, lost_ns = self.backend.shifts()
        if shifts:
            shifts, lost_ns = max(0, shifts - self._waited[0]), max(0, lost_ns - self._waited[1])
        self.live.update(self.t_us / 1e6, self.line, shifts, lost_ns / 1e9, force)

    def _played(self, part: Rows, n: int) -> None:
        if n <= 0:
            return
        done = part[:n]
        if self.tracer is not None:
            written = self.backend.written_us()
            shown = done if written is None or len(written) < n else \
                Rows(written[:n], done.coils, done.pen_us, done.line, done.steps)
            if self._writer is not None:
                self._writer.trace(shown)
            else:
                self.tracer.write(shown)
        self.counts = (int(done.steps[-1, 0]), int(done.steps[-1, 1]))
        self.t_us = int(done.t_us[-1])
        self.line = int(done.line[-1])
        self.coils = int(done.coils[-1])
        pens = done.pen_us[done.pen_us > 0]
        if len(pens):
            self.pen_down = int(pens[-1]) != self.cfg.pen.up_us
        self._moved = True

    def _begin_motion(self) -> bool:
        """Before the motors move: True if the journal is written (a position is stored)."""
        self.ledger.begin(self.counts)
        return self.ledger.journal is not None

    def _abort(self) -> None:
        """Pen up and coils released, played to the end whatever else happens."""
        if self.backend is None:
            return
        self.backend.stop_requested = False
        m = self.cfg.motors
        # a STEP pulse that was just raised stays high its full width
        t = self.t_us + (m.step_pulse_us if m.driver == "stepdir" else 1) if self._moved else 0
        up, settle = self.cfg.pen.up_us, int(round(self.cfg.pen.settle_s * 1e6))
        idle = self.backend.idle_word
        held = self.coils if self._moved and self.coils is not None else idle
        if m.driver == "stepdir" and held != idle:
            held &= ~0b101                      # both STEP lines low (drivers.StepDir)
        # the motors hold while the pen lifts, then are released from a one-coil phase
        # (motion/schedule.py): a motor in a two-coil phase first takes the half step back
        drv = drivers.create(m, self.counts)
        d = drv.to_one_coil() if held != idle else np.zeros(2, np.int64)
        drv.advance(d)
        end = np.asarray(self.counts) + d
        t_off = t + max(settle, 1)
        times, words, pens, steps = [t], [held], [up], [self.counts]
        if d.any():
            times.append(t_off)
            words.append(drv.hold_word())
            pens.append(0)
            steps.append(end)
            t_off += int(np.ceil(1e6 / m.max_step_rate)) + 1
        times.append(t_off)
        words.append(idle)
        pens.append(0)
        steps.append(end)
        rows = Rows(np.array(times, dtype=np.int64), np.array(words, dtype=np.uint8),
                    np.array(pens, dtype=np.int32), np.full(len(times), self.line, dtype=np.int64),
                    np.array(steps, dtype=np.int64))
        try:
            n = self.backend.play(rows)
            self._played(rows, n)
            self.pen_down = False
        except Exception as e:  # noqa: BLE001 - keep going: close() still releases
            _eprint(f"vplotter: warning: could not lift the pen: {e}")

    def _save(self, clean: bool) -> None:
        self.ledger.save(self.counts, self.pen_down, clean, self.waiting)
