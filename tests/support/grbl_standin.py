"""A grbl 1.1 stand-in on a pseudo-terminal pair, as unkind as the real controller.

The host opens `standin.port` (the pty's slave) like a serial port. The stand-in runs on a
thread on the master side:

- opening the port resets it: pyserial flushes the input on open, which the master sees as a
  TIOCPKT_FLUSHREAD packet, like an Arduino's reset on DTR; it then prints the banner;
- a receive buffer of rx_buffer - 1 bytes (grbl's ring buffer): every byte that arrives when
  it is full is lost and counted in `overflow` (tests assert it stays 0);
- real-time bytes (`?`, `!`, `~`, 0x18, 0x9E) are taken out as they arrive, never buffered;
- lines are parsed only while the planner (15 blocks) has room; `ok` comes after planning;
  M3/M5, G4 and G92 wait until the planner is empty (as grbl synchronizes them);
- moves run in simulated time: each turn of its loop advances the clock by `tick_s` and the
  planner executes at the programmed feed; a feed hold stops on the path (Hold:1, then Hold:0);
  a soft reset in motion raises ALARM:3;
- status reports `<Run|MPos:...|Bf:..,..|FS:..,0>`, with WCO only now and then (as grbl);
- faults on request: `error_on` (a substring: that line is answered error:20), `reply_delay`
  (answers held back by that many turns), `disconnect_after` (the port vanishes after that many
  lines), `silent` (never answers), `alarm_after` (ALARM:2 on that line, as a soft limit).

It records what it executed: `segments` (work-coordinate start, end, pen down) and `received`
(every line, in order).
"""

from __future__ import annotations

import fcntl
import os
import select
import struct
import termios
import threading

BANNER = b"\r\nGrbl 1.1h ['$' for help]\r\n"
SETTINGS = {0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 1, 11: 0.010, 12: 0.002, 13: 0,
            20: 0, 21: 0, 22: 0, 23: 0, 24: 25.0, 25: 500.0, 26: 250, 27: 1.0, 30: 1000, 31: 0,
            32: 0, 100: 163.840, 101: 163.840, 102: 250.0, 110: 242.0, 111: 242.0, 112: 500.0,
            120: 12.0, 121: 12.0, 122: 10.0, 130: 200.0, 131: 200.0, 132: 200.0}
TIOCPKT_FLUSHREAD = getattr(termios, "TIOCPKT_FLUSHREAD", 1)


class GrblStandin:
    def __init__(self, rx_buffer: int = 128, blocks: int = 15, tick_s: float = 0.05,
                 error_on: str | None = None, reply_delay: int = 0,
                 disconnect_after: int | None = None, silent: bool = False, settings=None,
                 alarm_after: int | None = None, freeze_after: int | None = None,
                 lose_holds: int = 0):
        self.master, self.slave = os.openpty()
        fcntl.ioctl(self.master, termios.TIOCPKT, struct.pack("i", 1))
        self.port = os.ttyname(self.slave)
        self.cap = rx_buffer - 1
        self.blocks = blocks
        self.tick_s = tick_s
        self.error_on = error_on
        self.reply_delay = reply_delay
        self.disconnect_after = disconnect_after
        self.silent = silent
        self.alarm_after = alarm_after
        self.freeze_after = freeze_after      # stops moving (reports Run for ever) after N answers
        self.lose_holds = lose_holds          # the first N `!` are lost (grbl-sim's flag race)
        self.settings = {**SETTINGS, **(settings or {})}
        self.overflow = 0
        self.max_rx = 0
        self.max_planned = 0
        self.received: list[str] = []
        self.segments: list[tuple[tuple, tuple, bool]] = []
        self.resets = 0
        self.answered = 0                 # ok and error:N answers to lines
        self.realtime: list[bytes] = []
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._reset_state(first=True)
        self.thread = threading.Thread(target=self._run, daemon=True, name="grbl-standin")
        self.thread.start()

    # ------------------------------------------------------------ state
    def _reset_state(self, first: bool = False) -> None:
        if not first:
            moving = self.planner and self.state in ("Run", "Hold:1")
            self.state = "Alarm" if moving else ("Alarm" if self.state == "Alarm" else "Idle")
            if moving:
                self._reply(b"ALARM:3\r\n")
        else:
            self.mpos = [0.0, 0.0]
            self.state = "Idle"
            self._out: list[tuple[int, bytes]] = []
            self.clock = 0.0
            self.turn = 0
        self.rx = bytearray()
        self.planner: list[dict] = []
        self.wco_lost = list(getattr(self, "wco", [0.0, 0.0]))   # G92 does not survive a reset
        self.wco = [0.0, 0.0]
        self.wco_counter = 0
        self.feed = 0.0
        self.pen_down = False
        self.spindle_stop = False
        self.waiting: dict | None = None   # a synchronizing line (M3/M5/G4/G92) being done
        self.status_due = False

    def wpos(self) -> tuple[float, float]:
        return (self.mpos[0] - self.wco[0], self.mpos[1] - self.wco[1])

    def _reply(self, data: bytes) -> None:
        self.answered += data.count(b"ok\r\n") + data.count(b"error:")
        if not self.silent:
            self._out.append((self.turn + self.reply_delay, data))

    # ------------------------------------------------------------ the loop
    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                ready, _, _ = select.select([self.master], [], [], 0.002)
            except (OSError, ValueError):
                return
            with self._lock:
                if ready:
                    try:
                        pkt = os.read(self.master, 4096)
                    except OSError:
                        pkt = b""
                    if pkt:
                        self._packet(pkt)
                self._turn()

    def _packet(self, pkt: bytes) -> None:
        flags, data = pkt[0], pkt[1:]
        if flags & TIOCPKT_FLUSHREAD:       # the host opened the port (pyserial flushes): reset
            self._soft_reset()
        if flags != 0:
            return
        for b in data:
            c = bytes([b])
            if c in (b"?", b"!", b"~", b"\x18", b"\x9e"):
                self.realtime.append(c)
                if c == b"?":
                    self.status_due = True
                elif c == b"!" and self.lose_holds > 0:
                    self.lose_holds -= 1
                elif c == b"!":
                    if self.state == "Run":
                        self.state = "Hold:1"
                    elif self.state == "Idle":
                        self.state = "Hold:0"
                elif c == b"~":
                    if self.state.startswith("Hold"):
                        self.state = "Run" if self.planner else "Idle"
                elif c == b"\x18":
                    self._soft_reset()
                elif c == b"\x9e" and self.state == "Hold:0":
                    self.spindle_stop = not self.spindle_stop
                    self.pen_down = self.pen_down and not self.spindle_stop
                continue
            if len(self.rx) < self.cap:
                self.rx.append(b)
                self.max_rx = max(self.max_rx, len(self.rx))
            else:
                self.overflow += 1

    def _soft_reset(self) -> None:
        self.resets += 1
        self._reset_state()
        self._reply(BANNER)

    def _turn(self) -> None:
        self.turn += 1
        self.clock += self.tick_s
        if self.state == "Hold:1":
            self.state = "Hold:0"            # stopped on the path at once
        elif not self.state.startswith("Hold") and self.state != "Alarm":
            self._execute(self.tick_s)
        self._parse()
        if self.status_due:
            self.status_due = False
            self._reply(self._status().encode() + b"\r\n")
        if self._out:
            due = [d for t, d in self._out if t <= self.turn]
            self._out = [(t, d) for t, d in self._out if t > self.turn]
            if due:
                try:
                    os.write(self.master, b"".join(due))
                except OSError:
                    pass

    def _status(self) -> str:
        free = self.blocks - len(self.planner)
        s = (f"<{self.state}|MPos:{self.mpos[0]:.3f},{self.mpos[1]:.3f},0.000"
             f"|Bf:{free},{self.cap - len(self.rx)}|FS:{self.feed:.0f},0")
        if self.wco_counter == 0:
            s += f"|WCO:{self.wco[0]:.3f},{self.wco[1]:.3f},0.000"
            self.wco_counter = 30 if self.state != "Idle" else 10
        self.wco_counter -= 1
        return s + ">"

    def _execute(self, dt: float) -> None:
        if self.freeze_after is not None and self.answered >= self.freeze_after and self.planner:
            self.state = "Run"                # grbl-sim with its interrupts lost: no more steps
            return
        while dt > 0 and self.planner:
            b = self.planner[0]
            dx, dy = b["end"][0] - self.mpos[0], b["end"][1] - self.mpos[1]
            left = (dx * dx + dy * dy) ** 0.5
            step = b["feed"] / 60.0 * dt
            start = self.wpos()
            if step >= left:
                self.mpos = list(b["end"])
                dt -= left / (b["feed"] / 60.0) if b["feed"] > 0 else dt
                self.planner.pop(0)
            else:
                self.mpos = [self.mpos[0] + dx * step / left, self.mpos[1] + dy * step / left]
                dt = 0
            self.segments.append((start, self.wpos(), self.pen_down))
            self.state = "Run"
        self._finish_wait(max(dt, 0.0))
        if not self.planner and self.state == "Run":
            self.state = "Idle"

    # ------------------------------------------------------------ lines
    def _parse(self) -> None:
        while self.waiting is None:
            end = self.rx.find(b"\n")
            if end < 0:
                return
            text = self.rx[:end].decode("ascii", "replace").strip().upper().replace(" ", "")
            if text.startswith("G1") and len(self.planner) >= self.blocks:
                return                      # planner full: the line stays in the buffer
            del self.rx[:end + 1]
            if not text:
                self._reply(b"ok\r\n")
                continue
            self.received.append(text)
            if self.disconnect_after is not None and len(self.received) >= self.disconnect_after:
                self.close_port()
                return
            if self.alarm_after is not None and len(self.received) == self.alarm_after:
                # a soft limit: grbl stops at once, kills the spindle and locks out
                self.planner.clear()
                self.rx.clear()
                self.pen_down = False
                self.state = "Alarm"
                self._reply(b"ALARM:2\r\n[MSG:Reset to continue]\r\n")
                return
            if self.state == "Alarm" and not text.startswith("$"):
                self._reply(b"error:9\r\n")
                continue
            if self.error_on and self.error_on in text:
                self._reply(b"error:20\r\n")
                continue
            self._line(text)

    def _words(self, text: str) -> dict:
        words, i = {}, 0
        while i < len(text):
            letter = text[i]
            j = i + 1
            while j < len(text) and (text[j].isdigit() or text[j] in ".-"):
                j += 1
            words.setdefault(letter, []).append(float(text[i + 1:j]) if j > i + 1 else 0.0)
            i = j
        return words

    def _line(self, text: str) -> None:
        if text == "$I":
            self._reply(b"[VER:1.1h.20190830:]\r\n[OPT:V,15,128]\r\nok\r\n")
            return
        if text == "$$":
            out = "".join(f"${k}={v:g}\r\n" if isinstance(v, int) else f"${k}={v:.3f}\r\n"
                          for k, v in self.settings.items())
            self._reply(out.encode() + b"ok\r\n")
            return
        if text == "$X":
            self.state = "Idle"
            self._reply(b"[MSG:Caution: Unlocked]\r\nok\r\n")
            return
        if text.startswith("$"):
            self._reply(b"error:3\r\n")
            return
        try:
            w = self._words(text)
        except ValueError:
            self._reply(b"error:2\r\n")
            return
        g = w.get("G", [])
        m = w.get("M", [])
        if 92.0 in g:
            self._sync(0.0, lambda: self._g92(w))
        elif 4.0 in g:
            self._sync(w.get("P", [0.0])[0], None)
        elif m:
            down = m[0] == 3.0
            self._sync(0.0, lambda: setattr(self, "pen_down", down and not self.spindle_stop))
        elif 1.0 in g or 0.0 in g:
            if "F" in w:
                self.feed = w["F"][0]
            if self.feed <= 0:
                self._reply(b"error:22\r\n")
                return
            last = self.planner[-1]["end"] if self.planner else tuple(self.mpos)
            end = (w["X"][0] + self.wco[0] if "X" in w else last[0],
                   w["Y"][0] + self.wco[1] if "Y" in w else last[1])
            if end != tuple(last):
                self.planner.append({"end": end, "feed": self.feed, "text": text})
                self.max_planned = max(self.max_planned, len(self.planner))
                if self.state == "Idle":
                    self.state = "Run"
            self._reply(b"ok\r\n")
        elif all(v in (21.0, 90.0, 94.0) for v in g) and g:
            self._reply(b"ok\r\n")
        else:
            self._reply(b"error:20\r\n")

    def _sync(self, dwell_s: float, then) -> None:
        """grbl waits for the planner to empty before M3/M5, G4 and G92 (and answers after)."""
        self.waiting = {"dwell": dwell_s, "then": then}
        self._finish_wait(0.0)

    def _finish_wait(self, dt: float) -> None:
        w = self.waiting
        if w is None or self.planner:
            return
        if w["then"] is not None:
            w["then"]()
            w["then"] = None
        w["dwell"] -= dt
        if w["dwell"] <= 1e-12:
            self.waiting = None
            self._reply(b"ok\r\n")

    def _g92(self, w) -> None:
        if "X" in w:
            self.wco[0] = self.mpos[0] - w["X"][0]
        if "Y" in w:
            self.wco[1] = self.mpos[1] - w["Y"][0]
        self.wco_counter = 0

    # ------------------------------------------------------------ control from tests
    def close_port(self) -> None:
        """The cable is pulled: the master side goes away."""
        try:
            os.close(self.master)
        except OSError:
            pass
        self.master = -1
        self._stop.set()

    def stop(self) -> None:
        self._stop.set()
        self.thread.join(timeout=5)
        for fd in (self.master, self.slave):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self.master = self.slave = -1
