"""One plotter, one process: an exclusive flock on $XDG_STATE_HOME/vplotter/lock.

The kernel drops the lock when its process dies, so a stale lock of a crashed process is
taken over without asking. The lock file names its holder ({"pid", "command", "since"}) while it
is held and is emptied when it is released, so `holder()` tells who drives the plotter without
ever touching the lock itself (status never takes it).

Within one process the lock is taken once: every mover takes it before it reads the stored
position, and the session that then moves the machine shares it (acquire() counts). A draw
that goes on in the background (`draw --detach`) hands the open lock to its child process
(flock belongs to the open file description, which the child inherits): the child finds its
number in VPLOTTER_LOCK_FD and adopts it.
"""

from __future__ import annotations

import fcntl
import json
import os
import time

from vplotter.errors import BusyError
from vplotter.config import state_dir

ENV_FD = "VPLOTTER_LOCK_FD"


def lock_path():
    return state_dir() / "lock"


INFO_BYTES = 1024   # the lock file's size while it is held

class Lock:
    def __init__(self, fd: int, command: str):
        self.fd = fd
        self.command = command
        self.count = 1

    def write_info(self, pid: int | None = None, command: str | None = None) -> None:
        info = {"pid": pid or os.getpid(), "command": command or self.command,
                "since": time.time()}
        # padded to a fixed size and written in one pwrite: a reader never sees it empty or
        # half old, half new (JSON allows the trailing spaces)
        data = json.dumps(info).encode()
        os.pwrite(self.fd, data + b" " * max(0, INFO_BYTES - len(data)), 0)

    def release(self) -> None:
        """Give back one acquire(); the last one unlocks."""
        global _held
        self.count -= 1
        if self.count > 0 or self.fd < 0:
            return
        try:
            os.ftruncate(self.fd, 0)
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
        except OSError:
            pass
        self.fd = -1
        if _held is self:
            _held = None

    def hand_over(self) -> None:
        """Close this process's descriptor WITHOUT unlocking: a child process that inherited
        the same open file description keeps the lock."""
        global _held
        try:
            os.close(self.fd)
        except OSError:
            pass
        self.fd, self.count = -1, 0
        if _held is self:
            _held = None


_held: Lock | None = None


def acquire(command: str) -> Lock:
    """Take the plotter (or share it, when this process holds it already); BusyError (exit 3)
    names the holder and what it is doing."""
    global _held
    if _held is not None:
        _held.count += 1
        return _held
    adopted = _adopt(command)
    if adopted is not None:
        _held = adopted
        return adopted
    path = lock_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        info = _read(fd)
        os.close(fd)
        raise BusyError(holder_line(info), info) from None
    lock = Lock(fd, command)
    lock.write_info()
    _held = lock
    return lock


def release_all() -> None:
    """The command is over: whatever this process still holds is released."""
    while _held is not None:
        _held.release()


def _adopt(command: str) -> Lock | None:
    fd_text = os.environ.pop(ENV_FD, None)
    if not fd_text:
        return None
    try:
        fd = int(fd_text)
        if os.fstat(fd).st_ino != os.stat(lock_path()).st_ino:
            return None
    except (ValueError, OSError):
        return None
    os.set_inheritable(fd, False)
    lock = Lock(fd, command)
    lock.write_info()
    return lock


def _read(fd: int) -> dict:
    try:
        info = json.loads(os.pread(fd, 4096, 0).decode("utf-8", "replace") or "{}")
    except ValueError:
        return {}
    return info if isinstance(info, dict) else {}


def holder() -> dict | None:
    """{"pid", "command", "since"} of the process driving the plotter, or None. Reads the lock
    file only (never locks it): a holder that died without releasing is no holder."""
    try:
        with open(lock_path(), "rb") as f:
            info = json.loads(f.read(4096).decode("utf-8", "replace") or "{}")
    except (OSError, ValueError):
        return None
    if not isinstance(info, dict) or not isinstance(info.get("pid"), int):
        return None
    return info if alive(info["pid"]) else None


def alive(pid: int) -> bool:
    """Is process pid running (a zombie is not)?"""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
    except (OSError, IndexError):
        return True


def holder_line(info: dict) -> str:
    """plotter busy: pid 1234 (vplotter draw car.ngc) since 12:03"""
    since = time.strftime("%H:%M", time.localtime(info.get("since", time.time())))
    return (f"plotter busy: pid {info.get('pid', '?')} ({info.get('command', 'vplotter')}) "
            f"since {since}")
