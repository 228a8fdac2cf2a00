"""A draw on a grbl-style controller: `SerialSession`, a `job.Session` that keeps the same
guarantees with the controller doing the motion: the plotter lock, the stored position (the
position the controller reports, as cord lengths and steps), the crash journal, and on a
signal: feed hold, wait until the controller has stopped on the path, lift the pen, soft
reset, and a place to resume from (the reported position, mapped back to the file's line).
"""

from __future__ import annotations

import itertools

import numpy as np

from vplotter import kinematics
from vplotter.backends.grbl import NOT_YET, AlarmError, ControllerError, LinkError, Streamer
from vplotter.backends.serial import SerialBackend
from vplotter.errors import BackendError, Interrupted
from vplotter.inputs.gcode import Pause
from vplotter.machine.ahead import END, Ahead, Failure
from vplotter.machine.job import DrawJob, Session


class SerialSession(Session):
    def __init__(self, cfg, command: str, dry_run: bool, position, save_stream: str | None = None,
                 job: DrawJob | None = None):
        super().__init__(cfg, command, "serial", dry_run, None, False, position, job)
        self.save_stream = save_stream
        self.kin = kinematics.from_config(cfg)
        self.motors = cfg.serial.axes == "motors"
        self.ref = np.asarray(position.ref_mm, dtype=float)
        self.spu = np.asarray(cfg.motors.steps_per_unit, dtype=float)
        self.stop_xy: tuple[float, float] | None = None    # G-code point where it stopped
        self.lines_sent = 0
        self.t_us = 0            # the plan's time the controller has reached (the history)
        self._clean = True
        self._streamer: Streamer | None = None
        self._halted = False
        self.file = job.name if job is not None else "<input>"    # for messages

    def __enter__(self) -> "SerialSession":
        from vplotter.machine import lock

        if self.saves_state:
            self._lock = lock.acquire(self.command)
        try:
            self.backend = SerialBackend(self.cfg, self.dry_run)
            self.backend.open()
            if self.save_stream:
                try:
                    self._trace_file = open(self.save_stream, "w", encoding="ascii")
                except OSError as e:
                    raise BackendError(f"cannot write {self.save_stream}: {e.strerror}") from None
            self.signals.install(self._stop_soon)
        except BaseException:
            self._cleanup()
            raise
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc is not None and self._moved and self._clean and not self._halted:
                self._abort()
        finally:
            if self._moved and self.saves_state:
                if not self._clean and self._streamer is not None:
                    s = self._streamer
                    self._cover(s.current, s.sent - 1)     # where it may be, for the journal
                self._save(clean=self._clean)
            self.end_live(exc)
            self._cleanup()
        return False

    # ------------------------------------------------------------ positions
    def _cords(self, q: np.ndarray) -> np.ndarray:
        q = np.asarray(q, dtype=float).reshape(-1, 2)
        return q if self.motors else self.kin.inverse(self.kin.to_machine(q))

    def _counts(self, q) -> np.ndarray:
        return np.rint((self._cords(q) - self.ref) * self.spu).astype(np.int64)

    def _here(self, q) -> None:
        self.counts = tuple(int(c) for c in self._counts(q)[0])
        xy = self.kin.to_gcode(self.kin.forward(self._cords(q)))[0]
        self.stop_xy = (float(xy[0]), float(xy[1]))

    # ------------------------------------------------------------ playing
    def play(self, chunks, progress=None) -> None:
        chunks = iter(chunks)
        first = next(chunks, None)
        if first is None:
            return
        if self._trace_file is not None:
            chunks = self._tee(itertools.chain([first], chunks))
        else:
            chunks = itertools.chain([first], chunks)
        if self.dry_run:
            self._play_dry(chunks, progress)
            return
        link = self.backend.link
        s = self._streamer = Streamer(link, self.cfg.serial.rx_buffer)
        self._moved = True
        ahead = _Prefetch(chunks)       # planning runs on a helper thread, ahead of the stream

        def on_status(st: Streamer) -> None:
            if st.pos is None:
                return
            self._here(st.pos)
            k = min(st.current, st.pulled - 1)
            _, _, (line, _, t_us) = st.line_at(k)
            self.line, self.t_us = line, int(t_us)
            self.pen_down = st.line_at(k - 1)[2][1] if k > st.base else self.pen_down
            self.lines_sent = st.sent
            if self.live is not None:
                self.live.update(t_us / 1e6, line)
            if progress is not None:
                progress(t_us, line)

        try:
            done = self._run_to_pauses(s, ahead, on_status, first.q[0], progress)
        except ControllerError as e:
            text, _, (line, _, _) = s.line_at(e.index)
            self._halt()
            raise BackendError(
                f"{self.file}:{line}: error: the controller refused `{text}` (line "
                f"{e.index + 1} of the stream): {e}; stopped, pen lifted") from None
        except AlarmError:
            self._clean = False
            raise
        except LinkError:
            self._clean = False
            raise
        finally:
            ahead.close()
        if not done:
            self._halt()
            raise self._interrupted()
        on_status(s)
        self.pen_down = bool(s.meta[-1][1]) if s.meta else self.pen_down

    def _run_to_pauses(self, s: Streamer, ahead, on_status, q0, progress) -> bool:
        """Stream up to each Pause (M0, a pen change), let everything before it run until
        the controller is Idle (the pen is up), then the pause: `on_pause` asks the person
        and waits. True once all has run, False at a stop."""
        stop = lambda: self.signals.pending      # noqa: E731
        while True:
            seg = _UpToPause(ahead)
            if not s.run(seg, q0, stop, on_status, self._cover):
                return False
            if seg.pause is None:
                return True
            on_status(s)
            self._ask(seg.pause, progress)
            if stop():
                return False

    def _ask(self, pause, progress) -> None:
        """A Pause: the job's on_pause asks the person and waits."""
        if self.job is not None and self.job.on_pause is not None:
            self.job.on_pause(pause, lambda: self.stop_pending, progress)

    def _tee(self, chunks):
        for ch in chunks:
            if not isinstance(ch, Pause):
                self._trace_file.write("".join(t + "\n" for t in ch.text))
            yield ch

    def _play_dry(self, chunks, progress) -> None:
        last = None
        for ch in chunks:
            if self.signals.pending:
                raise Interrupted(f"stopped by {self.signals.name()}", self.signals.signum)
            if isinstance(ch, Pause):
                self._ask(ch, progress)
                continue
            if len(ch):
                last = ch
                self.line = int(ch.line[-1])
                self.lines_sent += len(ch)
                if progress is not None:
                    progress(int(ch.t_us[-1]), self.line)
        if last is not None:
            self._here(last.q[-1])
            self.pen_down = bool(last.down[-1])

    def _cover(self, first: int, last: int) -> None:
        """Journal: where the motors are and how far they may get until the next record."""
        if not self.saves_state or self._streamer is None:
            return
        s = self._streamer
        pts = s.window(first - 1, last)
        if not pts:
            return
        self._begin_motion()
        dev = np.abs(self._counts(np.array(pts)) - np.asarray(self.counts)).max(axis=0)
        self.ledger.journal.record(self.counts, dev, self.line, "down" if self.pen_down else "up")

    def _halt(self) -> None:
        """Feed hold, wait until stopped on the path, lift the pen, soft reset."""
        s, link = self._streamer, self.backend.link
        self._halted = True
        try:
            st = s.hold(self.cfg.serial.timeout_s)
            pos = link.work_position(st)
            if pos is not None:
                self._here(pos)
                self.line = s.line_at(min(s.locate(pos), s.pulled - 1))[2][0]
            if self.cfg.serial.pen_up.upper().startswith("M5"):
                link.write(b"\x9e")            # spindle stop while held: the pen goes up now
            link.write(b"\x18")
            link.wait_banner(poke=False)
            link.command(self.cfg.serial.pen_up)
            link.command(f"G4P{self.cfg.pen.settle_s:g}")
            self.pen_down = False
        except (LinkError, AlarmError, ControllerError) as e:
            self._clean = False
            raise BackendError(f"could not stop the controller cleanly: {e}") from None

    def _abort(self) -> None:
        if self._streamer is not None and self.backend is not None and self.backend.link:
            try:
                self._halt()
            except BackendError:
                pass


class _UpToPause:
    """The chunks of `it` up to the next Pause, which is kept in `pause`."""

    def __init__(self, it):
        self.it, self.pause = it, None

    def __iter__(self):
        return self

    def __next__(self):
        ch = next(self.it)
        if isinstance(ch, Pause):
            self.pause = ch
            raise StopIteration
        return ch


class _Prefetch(Ahead):
    """Iterates `chunks` on a helper thread, a bounded number ahead, so that planning the next
    lines never holds up the stream (a Pi Zero plans a round of pieces in about a second).
    Errors raised while planning are raised to the consumer; while the next chunk is still
    being planned, the iterator gives NOT_YET instead of waiting."""

    def __init__(self, chunks, depth: int = 16):
        super().__init__(chunks, depth, split=False)

    def __iter__(self):
        return self

    def __next__(self):
        import queue

        try:
            item = self.q.get(timeout=0.005)
        except queue.Empty:
            return NOT_YET              # still planning: the stream goes on meanwhile
        if item is END:
            self.q.put(item)
            raise StopIteration
        if isinstance(item, Failure):
            self.q.put(item)
            raise item.exc
        return item
