"""One plotter, one process: an exclusive flock on $XDG_STATE_HOME/vplotter/lock.

The kernel drops the lock when its process dies, so a stale lock of a crashed process is
taken over without asking.
"""

from __future__ import annotations

import fcntl
import json
import os
import time

from vplotter.errors import BusyError
from vplotter.state import state_dir


class Lock:
    def __init__(self, fd: int):
        self.fd = fd

    def release(self) -> None:
        if self.fd >= 0:
            try:
                fcntl.flock(self.fd, fcntl.LOCK_UN)
                os.close(self.fd)
            except OSError:
                pass
            self.fd = -1


def acquire(command: str) -> Lock:
    path = state_dir() / "lock"
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        try:
            info = json.loads(os.pread(fd, 4096, 0).decode("utf-8", "replace") or "{}")
        except ValueError:
            info = {}
        os.close(fd)
        since = time.strftime("%H:%M", time.localtime(info.get("since", time.time())))
        raise BusyError(f"plotter busy: pid {info.get('pid', '?')} "
                        f"({info.get('command', 'vplotter')}) since {since}") from None
    os.ftruncate(fd, 0)
    os.pwrite(fd, json.dumps({"pid": os.getpid(), "command": command, "since": time.time()}).encode(), 0)
    return Lock(fd)
