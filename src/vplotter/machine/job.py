"""Running a schedule on the machine safely: lock, position, backend, signals, journal, trace.

`Session` is used by every command that moves something (draw, jog, goto, home, pen,
calibrate steps). It guarantees, whatever happens (error, Ctrl+C, SIGTERM, SSH hang-up):
the pen is lifted, the coils are released, the exact position reached is stored, and a second
process cannot drive the same plotter at the same time. A dry run (the fake backend without
--realtime) takes no lock and never writes the stored position.
"""

from __future__ import annotations

import queue
import signal
import sys
import threading
import time
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from vplotter.motion import drivers
from vplotter.backends import memory
from vplotter.machine import state
from vplotter.machine.writer import Writer as _Writer
from vplotter.errors import BackendError, Interrupted, MachineError, StateError
from vplotter.motion.schedule import Rows

JOURNAL_EVERY_US = 500_000     # journal at least every 0.5 s of motion
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@dataclass
class Stop:
    signum: int
    counts: tuple[int, int]
    line: int


def _eprint(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def load_position(cfg, trust: bool = False, dry_run: bool = False) -> state.Position:
    """The stored position, checked: refuses an unclean stop unless trusted (or a dry run)."""
    pos = state.load()
    if pos is None:
        raise MachineError("error: the pen position is unknown; put the pen on a known point and "
                           "run `vplotter calibrate --at X Y` first")
    check_machine(cfg, pos)
    pos = state.recovered(pos).rebased(cfg.motors.steps_per_unit)
    if not pos.clean and not trust and not dry_run:
        mm = uncertainty_mm(cfg, pos)
        raise StateError(f"error: the last stop was not clean (crash or power cut); the position "
                         f"may be off by up to {mm:.2f} mm. Check the pen and run `vplotter "
                         f"calibrate --at X Y`, or pass --trust-position to go on from it")
    return pos


def check_machine(cfg, pos: state.Position) -> None:
    """The stored position must be of this kind of machine (cords or angle and radius)."""
    kind = pos.extra.get("machine", "vplotter")
    if kind != cfg.machine.kind:
        raise MachineError(f"error: the stored position is of a {kind} machine, not of this "
                           f"{cfg.machine.kind}; run `vplotter calibrate` (or `vplotter home`) "
                           f"first")


def uncertainty_mm(cfg, pos: state.Position) -> float:
    """How far the pen may be from the stored position after an unclean stop."""
    dev = pos.extra.get("uncertain_steps")
    if pos.clean or dev is None:
        return 0.0
    from vplotter import kinematics

    kin = kinematics.from_config(cfg)
    spu = np.asarray(pos.steps_per_unit)
    c = np.array([pos.left_mm, pos.right_mm])
    here = kin.forward(c[None, :])[0]
    corners = np.array([[sl, sr] for sl in (-1, 1) for sr in (-1, 1)]) * np.array(dev) / spu
    return float(np.hypot(*(kin.forward(c + corners) - here).T).max())


class Session:
    def __init__(self, cfg, command: str, backend_name: str, dry_run: bool, trace=None,
                 realtime: bool = False, position: state.Position | None = None):
        self.cfg = cfg
        self.command = command
        self.backend_name = backend_name
        self.dry_run = dry_run
        self.realtime = realtime
        self.trace_path = trace
        self.position = position
        self.counts = position.counts if position is not None else (0, 0)
        self.stop: Stop | None = None
        self.backend = None
        self.tracer = None
        self._trace_file = None
        self._lock = None
        self._journal = None
        self._old_handlers: dict = {}
        self._signum = 0
        self.t_us = 0          # schedule time of the last row played
        self.line = 0
        self.pen_us = 0
        self.pen_down = False
        self.coils: int | None = None     # the motor output word last played
        self._moved = False
        self.resume_info: dict | None = None
        self._writer: _Writer | None = None
        self.drawing: dict | None = None     # {"file", "sha256"} while a draw runs
        self.live = None                     # live.Publisher while a draw runs
        self.ignore_hangup = False           # a background draw goes on when SIGHUP comes
        # on_pause(pause): a Pause came up, everything before it played: the pen is up; at a
        # pen change (pause.pen) the gondola is at the change point and the motors hold it
        # (the position stays exact while a pen is pushed in), at other pauses they are released
        self.on_pause = None
        self.waiting = None     # the Pause being waited at
        self._waited = (0, 0)   # pauses waited at, and for how long (ns)
        self.pen_in: dict | None = position.extra.get("pen_in") if position is not None else None

    @property
    def saves_state(self) -> bool:
        return not self.dry_run

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
                self.tracer = TraceWriter(self._trace_file, self.backend.coil_pins, self.backend.pen_pin)
            for s in SIGNALS:
                ignore = s == signal.SIGHUP and self.ignore_hangup
                self._old_handlers[s] = signal.signal(s, signal.SIG_IGN if ignore else self._on_signal)
        except BaseException:
            self._cleanup()
            raise
        return self

    @property
    def stop_pending(self) -> bool:
        """A signal asked to stop."""
        return bool(self._signum)

    def _on_signal(self, signum, frame) -> None:
        if not self._signum:
            self._signum = signum
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

    def end_live(self, exc) -> None:
        """The live status (and [notify]) says how the draw ended: ended, stopped, failed."""
        if self.live is not None:
            self.live.close("ended" if exc is None else
                            "stopped" if isinstance(exc, Interrupted) else "failed")
            self.live = None

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
        for s, h in self._old_handlers.items():
            try:
                signal.signal(s, h)
            except (ValueError, TypeError):
                pass
        self._old_handlers.clear()
        if self.backend is not None:
            self.backend.close()
        if self._trace_file is not None:
            self._trace_file.close()
            self._trace_file = None
        if self._journal is not None:
            self._journal.close()
            self._journal = None
        if self._lock is not None:
            self._lock.release()
            self._lock = None

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
        ahead = _Ahead(chunks, split=self.saves_state, threaded=threaded)
        self._writer = _Writer(self.tracer, threaded=threaded)
        switch = sys.getswitchinterval()
        sys.setswitchinterval(0.0005)     # hand the interpreter back to the player quickly
        try:
            cur, k = ahead.get(), 0
            while cur is not None and not self._signum:
                if not isinstance(cur, Rows):        # a pause: wait once all is played
                    self.backend.drain()
                    k = self._pause(cur, k)
                    if self._signum:
                        break
                    cur = ahead.get()
                    continue
                nxt = ahead.get()
                if self.saves_state:
                    self._begin_motion()
                    # until the next record lands the motors are in this part or the next
                    span = cur if not isinstance(nxt, Rows) else Rows.concat([cur, nxt])
                    dev = np.abs(span.steps - np.asarray(self.counts)).max(axis=0)
                    up = self.cfg.pen.up_us           # any other pulse is a pen down (per pen)
                    down = self.pen_down or bool(((cur.pen_us > 0) & (cur.pen_us != up)).any())
                    self._writer.wait_journal(k - 1)
                    self._writer.journal(self._journal, self.counts, dev, int(cur.line[0]),
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
        if self._signum:
            self._abort()
            signum = self._signum
            self.stop = Stop(signum, self.counts, self.line)
            raise Interrupted(f"stopped by {signal.Signals(signum).name}", signum)

    def _pause(self, p, k: int) -> int:
        """Wait at a Pause: it is the line being done (a stop now resumes there, and a
        resumed draw asks for the pen again), the journal has the exact position (the motors
        stand), status shows the wait. Returns the journal records written."""
        self.line = int(p.line)
        if self._journal is not None:
            self._writer.wait_journal(k - 1)
            self._writer.journal(self._journal, self.counts, (0, 0), self.line, "up")
            self._writer.wait_journal(k + 1)
            k += 1
        self.waiting = p
        if self.live is not None:
            self.live.waiting(p)
        t0 = time.monotonic_ns()
        if self.on_pause is not None:
            self.on_pause(p)
        # a real-time player moves its timeline by the wait: that is no lateness
        self._waited = (self._waited[0] + 1, self._waited[1] + time.monotonic_ns() - t0)
        if self._signum:                 # stopped while waiting: the change is still to do
            return k
        self.waiting = None
        if p.pen is not None:
            self.pen_in = {"pen": p.pen, "index": int(p.index), "count": int(p.count)}
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

    def _begin_motion(self) -> None:
        if self._journal is None:
            pos = self.position.moved_to(self.counts)
            pos.clean = False
            if self.drawing:             # after a crash, --resume goes on from the journal
                pos.extra["drawing"] = self.drawing
            state.save(pos)
            state.clear_journal()
            self._journal = state.Journal()

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
        pos = self.position.moved_to(self.counts)
        pos.pen = "down" if self.pen_down else "up"
        pos.clean = clean
        pos.extra = {k: v for k, v in pos.extra.items() if k not in ("uncertain_steps", "line")}
        if clean:
            pos.extra.pop("drawing", None)
        if self.pen_in is not None:               # the pen in the gondola, as far as known
            pos.extra["pen_in"] = self.pen_in
        if self.resume_info is not None:          # only draw says where to resume (or not)
            pos.extra.pop("resume", None)
            pos.extra.pop("pen_change", None)
            w = self.waiting
            if w is not None and w.pen is not None:   # stopped while waiting for this pen
                pos.extra["pen_change"] = {"pen": w.pen, "index": int(w.index),
                                           "count": int(w.count), "message": w.message}
            if self.resume_info:
                pos.extra["resume"] = self.resume_info
        state.save(pos)
        if clean:
            state.clear_journal()
        self.position = pos


def _split(rows: Rows) -> Iterable[Rows]:
    """Cut rows into stretches of at most JOURNAL_EVERY_US, also right after pen changes.
    The stretches are copies: a view would keep the whole computed part (up to STEPS_PER_PART
    steps, megabytes) in memory until its last stretch is played."""
    n = len(rows)
    if n == 0:
        return
    t = rows.t_us
    cuts = set(np.searchsorted(t, np.arange(t[0] + JOURNAL_EVERY_US, t[-1] + 1, JOURNAL_EVERY_US)).tolist())
    pen_rows = np.flatnonzero(rows.pen_us > 0)
    cuts.update((pen_rows + 1).tolist())
    bounds = [0] + [c for c in sorted(cuts) if 0 < c < n] + [n]
    for a, b in zip(bounds[:-1], bounds[1:]):
        yield rows[a:b].copy()


_END = object()


class _Failure:
    def __init__(self, exc: BaseException):
        self.exc = exc


class _Ahead:
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
            self.parts = (p for rows in chunks
                          for p in (_split(rows) if split and isinstance(rows, Rows) else (rows,)))
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
                for part in (_split(rows) if self.split and isinstance(rows, Rows) else (rows,)):
                    if not self._put(part):
                        return
                rows = part = None      # the stretches are copies: the computed part can go
                memory.give_back()
            self._put(_END)
        except BaseException as e:  # noqa: BLE001 - handed to the main thread
            self._put(_Failure(e))

    def get(self) -> Rows | None:
        if self.thread is None:
            return next(self.parts, None)
        item = self.q.get()
        if isinstance(item, _Failure):
            self.q.put(item)            # later calls see it too
            raise item.exc
        if item is _END:
            self.q.put(_END)
            return None
        return item

    def close(self) -> None:
        self.stopped.set()
        if self.thread is not None:
            self.thread.join(timeout=5)
