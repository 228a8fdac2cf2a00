"""grbl's serial protocol (grbl 1.1; grblHAL and FluidNC speak it too), over a byte port.

What a host must do (grbl's doc/markdown/interface.md, protocol.c, serial.c, report.c):
- the board resets when the port opens and prints `Grbl 1.1h ['$' for help]`;
- a line is answered `ok` or `error:N` once it has been parsed and planned; `ALARM:N` comes at
  any time; `<Idle|MPos:x,y,z|Bf:15,128|FS:0,0|WCO:x,y,z>` answers `?`; `[MSG:...]` and other
  push messages come at any time;
- character counting: the receive buffer holds rx_buffer - 1 characters (a ring buffer), and
  what does not fit is lost, so the host keeps the bytes of the lines not yet answered within
  that and sends more as answers come back, never waiting for each answer in turn;
- `?`, `!` (feed hold), `~` (resume), 0x18 (soft reset), 0x9E (spindle stop while held) are
  real-time commands, taken out of the stream as they arrive and never counted.

`Link` speaks it over anything with pyserial's read/write/in_waiting (pyserial is imported
only by the serial backend that opens the port).
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass

from vplotter.errors import BackendError

BANNER = re.compile(r"^Grbl(HAL)? \S+ \[.*help")
READ_TIMEOUT_S = 0.02          # the port's read timeout: how long one read() may block
NOT_YET = object()             # a chunk source with nothing ready yet (still planning)
SAME_MM = 0.02                 # reported positions this close to two moves: the earlier one
HOLD_AGAIN_S = 0.5             # a feed hold not taken after this long is sent again
STALL_S = 30.0                 # reports Run, same position, no answer for this long: stalled

ERRORS = {
    1: "G-code words need a command letter and a value", 2: "bad number",
    3: "unsupported $ command", 4: "negative value", 8: "not idle ($ command during a job)",
    9: "locked out (alarm or jog): run $X or home", 15: "jog target beyond the travel limits",
    20: "unsupported or invalid G-code command", 22: "feed rate not set",
    24: "two commands in one line need the same axes", 33: "invalid target",
    36: "unused axis words",
}
ALARMS = {
    1: "hard limit switch hit; the position is lost", 2: "soft limit: a target beyond the travel",
    3: "reset while moving; the position may be lost", 9: "homing failed",
}


class LinkError(BackendError):
    """The controller stopped answering or the port went away."""


class ControllerError(BackendError):
    """The controller answered error:N to a line."""

    def __init__(self, code: int, index: int):
        super().__init__(f"error:{code} ({ERRORS.get(code, 'see the grbl error codes')})")
        self.code = code
        self.index = index


class AlarmError(BackendError):
    def __init__(self, code: int):
        super().__init__(f"the controller raised ALARM:{code} "
                         f"({ALARMS.get(code, 'see the grbl alarm codes')})")
        self.code = code


@dataclass
class Status:
    state: str                          # Idle, Run, Hold:0, Hold:1, Alarm, ...
    mpos: tuple | None = None
    wpos: tuple | None = None
    wco: tuple | None = None
    bf: tuple | None = None             # planner blocks free, rx bytes free
    fields: dict | None = None

    @property
    def held(self) -> bool:
        """Stopped by a feed hold (or nothing was moving): safe to reset."""
        return self.state in ("Hold:0", "Idle")


def parse_status(text: str) -> Status | None:
    """`<Idle|MPos:1.000,2.000,0.000|FS:0,0>` -> Status; None if it is not a status report."""
    if not (text.startswith("<") and text.endswith(">")):
        return None
    parts = text[1:-1].split("|")
    st = Status(parts[0], fields={})
    for p in parts[1:]:
        key, _, val = p.partition(":")
        st.fields[key] = val
        try:
            nums = tuple(float(v) for v in val.split(","))
        except ValueError:
            continue
        if key == "MPos":
            st.mpos = nums
        elif key == "WPos":
            st.wpos = nums
        elif key == "WCO":
            st.wco = nums
        elif key == "Bf":
            st.bf = nums
    return st


class Link:
    """Lines and real-time bytes to a grbl controller; answers come back as text lines."""

    def __init__(self, port, name: str, timeout_s: float = 5.0, clock=time.monotonic):
        self.port = port
        self.name = name
        self.timeout_s = timeout_s
        self.clock = clock
        self._buf = bytearray()
        self.wco: tuple | None = None
        self.banner = ""
        self.messages: list[str] = []     # push messages ([MSG:...] and the like)

    def _lost(self, e: Exception) -> LinkError:
        return LinkError(f"lost the connection to the controller on {self.name} ({e})")

    def write(self, data: bytes) -> None:
        try:
            self.port.write(data)
        except Exception as e:  # noqa: BLE001 - SerialException, OSError, a closed port
            raise self._lost(e) from None

    def read_lines(self) -> list[str]:
        """Complete lines that arrived (waits up to READ_TIMEOUT_S when there are none)."""
        try:
            data = self.port.read(max(1, self.port.in_waiting))
        except Exception as e:  # noqa: BLE001
            raise self._lost(e) from None
        if not data:
            return []
        self._buf += data
        *lines, rest = self._buf.split(b"\n")
        self._buf = bytearray(rest)
        return [ln.decode("ascii", "replace").strip("\r").strip() for ln in lines if ln.strip()]

    def status_of(self, text: str) -> Status | None:
        st = parse_status(text)
        if st is not None and st.wco is not None:
            self.wco = st.wco
        return st

    def work_position(self, st: Status) -> tuple[float, float] | None:
        """X, Y in work coordinates (what G-code lines name), if the report allows."""
        if st.wpos is not None:
            return st.wpos[0], st.wpos[1]
        if st.mpos is not None and self.wco is not None:
            return st.mpos[0] - self.wco[0], st.mpos[1] - self.wco[1]
        return None

    def wait_banner(self, timeout_s: float | None = None, poke: bool = True) -> str:
        """Wait for the start-up banner. A board that does not reset when the port opens is
        soft-reset once half-way through the wait."""
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        t0 = self.clock()
        poked = not poke
        while True:
            for ln in self.read_lines():
                if BANNER.match(ln):
                    self.banner = ln
                    return ln
            now = self.clock()
            if not poked and now - t0 > timeout_s / 2:
                self.write(b"\x18")
                poked = True
            if now - t0 > timeout_s:
                raise LinkError(f"no answer from a grbl controller on {self.name} within "
                                f"{timeout_s:g} s (is it connected, is [serial] baud right?)")

    def command(self, line: str, timeout_s: float | None = None) -> list[str]:
        """Send one line and wait for its answer (for settings, queries and single moves,
        never for streaming). Returns the lines that came before `ok`."""
        self.write(line.encode("ascii") + b"\n")
        return self.until_ok(timeout_s)

    def until_ok(self, timeout_s: float | None = None) -> list[str]:
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        got: list[str] = []
        last = self.clock()
        while True:
            lines = self.read_lines()
            if lines:
                last = self.clock()
            for ln in lines:
                if ln == "ok":
                    return got
                if ln.startswith("error:"):
                    raise ControllerError(_code(ln), -1)
                if ln.startswith("ALARM:"):
                    raise AlarmError(_code(ln))
                if ln.startswith("<"):
                    self.status_of(ln)
                got.append(ln)
            if self.clock() - last > timeout_s:
                raise LinkError(f"no answer from the controller on {self.name} within "
                                f"{timeout_s:g} s")

    def status(self, timeout_s: float | None = None) -> Status:
        """Ask `?` and wait for the report (answers to lines are kept in self.messages)."""
        timeout_s = self.timeout_s if timeout_s is None else timeout_s
        self.write(b"?")
        t0 = last_ask = self.clock()
        while True:
            for ln in self.read_lines():
                st = self.status_of(ln)
                if st is not None:
                    return st
                self.messages.append(ln)
            now = self.clock()
            if now - last_ask > 0.25:          # a '?' can be lost while the board starts
                self.write(b"?")
                last_ask = now
            if now - t0 > timeout_s:
                raise LinkError(f"no status report from the controller on {self.name} within "
                                f"{timeout_s:g} s")


def _code(text: str) -> int:
    try:
        return int(text.split(":", 1)[1])
    except (ValueError, IndexError):
        return -1


class Streamer:
    """Streams `Lines` chunks with character counting and polls `?` every poll_s.

    Keeps the window of lines that may still run (the one being executed to the last one
    pulled) so that a reported position can be named by its line. Lines past `cover_end` are
    not sent until `need_cover(first, last)` (the session's journal record) has been called
    for them: a crash then never leaves the motors beyond what the journal says.
    """

    def __init__(self, link: Link, rx_buffer: int, poll_s: float = 0.2, ahead: int = 40):
        self.link = link
        self.capacity = rx_buffer - 1      # grbl's ring buffer keeps one byte free
        self.poll_s = poll_s
        self.ahead = ahead
        self.base = 0                      # global index of self.text[0]
        self.text: list[str] = []
        self.q: list[tuple[float, float]] = []
        self.meta: list[tuple[int, bool, int]] = []    # (file line, pen down, t_us)
        self.start_q: tuple[float, float] | None = None
        self.pulled = self.sent = self.acked = 0
        self.current = 0                   # line being executed (from the last status)
        self.pos: tuple[float, float] | None = None
        self.status: Status | None = None
        self.cover_end = 0
        self._inflight: list[int] = []     # byte counts of lines sent and not answered
        self._used = 0
        self._next_poll = 0.0
        self._last_rx = 0.0
        self._moved = 0.0                  # when the reported position or an answer last changed

    # -- the window of lines
    def _add(self, chunk) -> None:
        self.text.extend(chunk.text)
        self.q.extend(map(tuple, chunk.q.tolist()))
        self.meta.extend(zip(chunk.line.tolist(), chunk.down.tolist(), chunk.t_us.tolist()))
        self.pulled += len(chunk)

    def line_at(self, i: int) -> tuple[str, tuple[float, float], tuple[int, bool, int]]:
        k = i - self.base
        return self.text[k], self.q[k], self.meta[k]

    def q_before(self, i: int) -> tuple[float, float]:
        return self.q[i - 1 - self.base] if i > self.base else self.start_q

    def window(self, first: int, last: int) -> list[tuple[float, float]]:
        """Stream coordinates the machine passes from line `first` to line `last`."""
        first = max(first, self.base)
        pts = [self.q_before(first)] if first == self.base and self.start_q else []
        return pts + self.q[first - self.base:last + 1 - self.base]

    def _trim(self) -> None:
        drop = self.current - 1 - self.base
        if drop > 4096:
            self.start_q = self.q[drop - 1]
            del self.text[:drop], self.q[:drop], self.meta[:drop]
            self.base += drop

    def locate(self, pos) -> int:
        """The line whose move (in stream coordinates) passes nearest to pos, among those
        that may be running. Of the moves within SAME_MM of the nearest, the earliest: a
        reported position is rounded and quantised to steps, and a closed shape ends where it
        began, so the earlier reading is the safe one (a resume then redraws a little rather
        than skipping a loop); a pen change after a move is not begun until the move ends."""
        import numpy as np

        lo, hi = self.current, max(self.current, self.acked - 1)
        if hi < lo or lo >= self.pulled:
            return self.current
        b = np.array(self.q[lo - self.base:hi + 1 - self.base])
        a = np.array([self.q_before(lo)] + self.q[lo - self.base:hi - self.base])
        ab = b - a
        len2 = np.einsum("ij,ij->i", ab, ab)
        p = np.asarray(pos, dtype=float)
        t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.where(len2 > 0, len2, 1.0), 0, 1)
        d = np.hypot(*(a + ab * t[:, None] - p).T)
        return lo + int(np.flatnonzero(d <= d.min() + SAME_MM)[0])

    # -- streaming
    def _answer(self, ln: str) -> None:
        if ln == "ok" or ln.startswith("error:"):
            if not self._inflight:
                self.link.messages.append(ln)
                return
            self._used -= self._inflight.pop(0)
            self.acked += 1
            self._moved = self.link.clock()
            if ln != "ok":
                raise ControllerError(_code(ln), self.acked - 1)
        elif ln.startswith("ALARM:"):
            raise AlarmError(_code(ln))
        elif BANNER.match(ln):
            raise LinkError(f"the controller on {self.link.name} restarted by itself "
                            f"(power or cable?)")
        else:
            st = self.link.status_of(ln)
            if st is None:
                self.link.messages.append(ln)
                return
            self.status = st
            if st.state == "Alarm":
                raise AlarmError(0)
            pos = self.link.work_position(st)
            now = self.link.clock()
            if pos != self.pos or st.state != "Run":
                self._moved = now
            elif now - self._moved > STALL_S:
                raise LinkError(f"the controller on {self.link.name} reports Run but has not "
                                f"moved for {STALL_S:g} s (stalled?)")
            if pos is not None and self.start_q is not None:
                self.pos = pos
                self.current = self.locate(pos)
                self._trim()

    def poll(self, now: float) -> list[str]:
        """Ask for a status when due; read and handle what arrived. Raises LinkError when
        nothing at all came back within the link's timeout."""
        if now >= self._next_poll:
            self.link.write(b"?")
            self._next_poll = now + self.poll_s
        lines = self.link.read_lines()
        if lines:
            self._last_rx = now
        elif now - self._last_rx > self.link.timeout_s:
            raise LinkError(f"the controller on {self.link.name} stopped answering "
                            f"(nothing for {self.link.timeout_s:g} s)")
        for ln in lines:
            self._answer(ln)
        return lines

    def run(self, chunks, start_q, stop, on_status, need_cover) -> bool:
        """Stream every line of `chunks`; True once the controller is Idle after the last
        answer, False as soon as stop() is true (nothing more is sent then)."""
        clock = self.link.clock
        if self.start_q is None:           # a run after a pause goes on from where it was
            self.start_q = tuple(start_q)
        self._last_rx = self._moved = clock()
        it = iter(chunks)
        exhausted = False
        idle_seen = False
        while True:
            if stop():
                return False
            while not exhausted and self.pulled - self.sent < 2 * self.ahead:
                chunk = next(it, None)
                if chunk is None:
                    exhausted = True
                elif chunk is NOT_YET:
                    break
                else:
                    self._add(chunk)
            out = bytearray()
            while self.sent < self.pulled:
                if self.sent >= self.cover_end:
                    self.cover_end = min(self.pulled, self.sent + self.ahead)
                    need_cover(self.current, self.cover_end - 1)
                data = self.text[self.sent - self.base].encode("ascii") + b"\n"
                if len(data) > self.capacity:
                    raise BackendError(f"a line of {len(data)} bytes does not fit the controller's "
                                       f"receive buffer ([serial] rx_buffer = {self.capacity + 1})")
                if self._used + len(data) > self.capacity:
                    break
                out += data
                self._used += len(data)
                self._inflight.append(len(data))
                self.sent += 1
            if out:
                self.link.write(bytes(out))
            acked = self.acked
            status = self.status
            self.poll(clock())
            if self.status is not status:
                on_status(self)
                # Idle after the last answer: everything has run (answers come after planning)
                idle_seen = (exhausted and self.acked == self.pulled and acked == self.acked
                             and self.status.state == "Idle")
                if idle_seen:
                    self.current = self.pulled
                    return True

    def hold(self, timeout_s: float) -> Status:
        """Feed hold, then wait until the controller reports Hold:0 (stopped on the path)."""
        clock = self.link.clock
        self.link.write(b"!")
        self._next_poll = 0.0
        t0 = sent = clock()
        while True:
            status = self.status
            try:
                self.poll(clock())
            except ControllerError:
                pass                  # a refused line behind the hold changes nothing now
            if self.status is not status and self.status.state == "Hold:0":
                return self.status
            if self.status is not status and not self.status.state.startswith("Hold") \
                    and clock() - sent > HOLD_AGAIN_S:
                self.link.write(b"!")         # not taken (grbl-sim can lose one): again
                sent = clock()
            if clock() - t0 > timeout_s:
                raise LinkError(f"the controller on {self.link.name} did not report a "
                                f"finished feed hold within {timeout_s:g} s")
