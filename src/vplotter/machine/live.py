"""What a running draw publishes for status, stop and log: $XDG_STATE_HOME/vplotter/live.json,
replaced atomically (temporary file + rename) a few times a second while the motors run, and
removed when the draw ends. Nobody reads the running process's internals: only this file, and
the lock file for whether its writer is still alive.

    {"pid", "command", "file", "started", "updated", "line", "done_s", "total_s",
     "shifts", "lost_s", "state", "waiting"}

done_s is the plot time played so far, total_s the plot time of the whole draw (what the
summary printed), both on the schedule's clock; lost_s the time the real-time player has lost
to lateness (the plot takes that much longer). state is "drawing", or "waiting" while the
draw waits at a pause (a pen change); waiting is null while it draws, else {"message", "pen",
"index", "count", "since", "prompt"}:
the pen to put in (null at a plain pause), the index-th of count, since when (epoch seconds),
and the one line a person reads ("put in the red pen (2 of 3)"). Whoever wants to tell
someone that the plotter waits (a notification) watches this key; `vplotter continue` (or
request_continue) lets the draw go on.

Every change of state goes to the Publisher's on_state hook (machine/notify.py): "waiting" and
"drawing" as they are written, and at the end "ended", "stopped" (paused by a signal:
resumable) or "failed", which only the hook sees (the file is removed then).
"""

from __future__ import annotations

import json
import os
import tempfile
import time

from vplotter.budget import clock_text
from vplotter.config import state_dir
from vplotter.machine import lock

EVERY_S = 0.25


def live_path():
    return state_dir() / "live.json"


def continue_path():
    """The request a waiting draw polls for: the pid it is for (`vplotter continue`)."""
    return state_dir() / "continue"


def pen_prompt(p) -> str:
    """What a person is asked at a Pause: its message ("put in the red pen (2 of 3)", "80 m
    drawn with the red pen: put in a fresh one or refill it"); a pen change without one is
    asked for by the pen's name."""
    if p.message or getattr(p, "pen", None) is None:
        return p.message
    of = f" ({p.index} of {p.count})" if p.count else ""
    return f"put in the {p.pen} pen{of}"


def request_continue(pid: int) -> None:
    """Ask the draw `pid` that waits at a pause to go on."""
    path = continue_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".continue.", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(f"{int(pid)}\n")
    os.replace(tmp, path)


def take_continue(pid: int | None = None) -> bool:
    """True (and the request gone) if someone asked this process (pid) to go on."""
    path = continue_path()
    try:
        mine = int(path.read_text(encoding="utf-8").strip() or 0) == (pid or os.getpid())
    except (OSError, ValueError):
        return False
    if mine:
        try:
            os.unlink(path)
        except OSError:
            pass
    return mine


def log_path():
    """Where a background draw (`draw --detach`) writes what it prints."""
    return state_dir() / "draw.log"


class Publisher:
    """Writes live.json for one draw, at most every EVERY_S seconds (and always on force)."""

    def __init__(self, command: str, file: str, total_s: float, clock=time.time,
                 on_state=None):
        self.clock = clock
        self.on_state = on_state     # on_state(state, info): every change of state
        self.info = {"pid": os.getpid(), "command": command, "file": file,
                     "started": clock(), "updated": 0.0, "line": 0, "done_s": 0.0,
                     "total_s": float(total_s), "shifts": 0, "lost_s": 0.0, "state": "drawing",
                     "waiting": None}
        self.last = -1e9

    def waiting(self, pause) -> None:
        """The draw waits at `pause` (None: it goes on again); written at once. A request
        to go on left from before is dropped: only one made while this wait shows counts."""
        if pause is not None:
            try:
                os.unlink(continue_path())
            except OSError:
                pass
            pause = {"message": pause.message, "pen": pause.pen, "index": int(pause.index),
                     "count": int(pause.count), "since": self.clock(),
                     "prompt": pen_prompt(pause)}
        self.info["waiting"] = pause
        before, self.info["state"] = self.info["state"], "drawing" if pause is None else "waiting"
        self.update(self.info["done_s"], self.info["line"], self.info["shifts"],
                    self.info["lost_s"], force=True)
        if self.info["state"] != before:
            self._changed()

    def _changed(self) -> None:
        if self.on_state is not None:
            try:
                self.on_state(self.info["state"], dict(self.info))
            except Exception:  # noqa: BLE001 - a hook never stops a plot
                pass

    def update(self, done_s: float, line: int, shifts: int = 0, lost_s: float = 0.0,
               force: bool = False) -> None:
        now = self.clock()
        self.info.update(done_s=float(done_s), line=int(line), shifts=int(shifts),
                         lost_s=float(lost_s))
        if force or now - self.last >= EVERY_S:
            self.last = now
            self.info["updated"] = now
            _write(self.info)

    def close(self, state: str | None = None) -> None:
        """The draw is over; state (ended, stopped or failed) goes to the on_state hook, and
        live.json goes."""
        if state is not None and state != self.info["state"]:
            self.info["state"] = state
            self._changed()
        try:
            with open(live_path(), encoding="utf-8") as f:
                mine = json.load(f).get("pid") == self.info["pid"]
        except (OSError, ValueError, AttributeError):
            return
        if mine:
            try:
                os.unlink(live_path())
            except OSError:
                pass


def _write(info: dict) -> None:
    path = live_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".live.", suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(info, f)
        os.replace(tmp, path)
    except OSError:
        pass          # status is a convenience: never stop a drawing for it


def read(holder: dict | None = None, now: float | None = None) -> dict | None:
    """The running draw as status shows it: {"pid", "command", "file", "line", "percent",
    "elapsed_s", "remaining_s", "finish", "shifts", "lost_s", "state", "waiting"}, or None
    when no draw is running (state, waiting: see the module doc; finish counts from now while
    it waits). `holder` is the lock holder (lock.holder()); a live.json whose writer does not
    hold the lock is left over from a crash and means nothing."""
    if holder is None:
        holder = lock.holder()
    if holder is None:
        return None
    try:
        with open(live_path(), encoding="utf-8") as f:
            info = json.load(f)
        if info.get("pid") != holder.get("pid"):
            return None
        now = time.time() if now is None else now
        total, done = float(info["total_s"]), min(float(info["done_s"]), float(info["total_s"]))
        remaining = max(0.0, total - done)
        return {"pid": int(info["pid"]), "command": str(info.get("command", "")),
                "file": str(info.get("file", "")), "line": int(info["line"]),
                "percent": round(100.0 * done / total, 1) if total > 0 else 0.0,
                "elapsed_s": round(now - float(info["started"]), 1),
                "remaining_s": round(remaining, 1),
                "finish": time.strftime("%H:%M", time.localtime(now + remaining)),
                "shifts": int(info.get("shifts", 0)), "lost_s": float(info.get("lost_s", 0.0)),
                "state": str(info.get("state", "drawing")),
                "waiting": info.get("waiting") or None}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def describe(d: dict) -> str:
    """One line: drawing car.ngc line 120, 35.2 % done, 12:04 elapsed, 20:30 left (finish 14:35);
    waiting: put in the red pen (2 of 3) when it waits."""
    w = d.get("waiting")
    if w:
        return (f"waiting in {os.path.basename(d['file'])} line {d['line']}: {w['prompt']} "
                f"(`vplotter continue` goes on), {d['percent']:.1f} % done, "
                f"{clock_text(d['remaining_s'])} left")
    return (f"drawing {os.path.basename(d['file'])} line {d['line']}, {d['percent']:.1f} % done, "
            f"{clock_text(d['elapsed_s'])} elapsed, {clock_text(d['remaining_s'])} left "
            f"(finish {d['finish']})")


def bar(percent: float, width: int = 25) -> str:
    full = int(width * min(max(percent, 0.0), 100.0) / 100)
    return "#" * full + "-" * (width - full)


def busy_line(holder: dict) -> str:
    """The line a second vplotter (or the web page) shows when the plotter is taken: the lock
    holder and, while it draws, its progress."""
    msg = lock.holder_line(holder)
    drawing = read(holder)
    if drawing:
        msg += f"; {describe(drawing)}"
    return msg
