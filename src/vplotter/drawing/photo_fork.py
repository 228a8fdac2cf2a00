"""Work beside a photo's convert in a forked process: `--style auto` searches, scores and finishes
the stipples' tour (its dearest style) on a second core while this one does the others
(`photo_auto.auto`).

`start(job)` forks a child that runs job(send) and exits; each send(x) pickles x down a pipe,
and `Child.get` reads them in order in the parent. The child inherits the picture and the
planner as they are (nothing is passed in), and a drawing is a pure function of its options, so
what it sends is what this process would make: the convert's output is byte-identical either
way. It forks only where that is safe and gains: on Linux, where this process runs one thread
(a thread holding a lock at the fork would leave the child stuck on it: a web server's convert
runs alone), and at least WORKERS cores are ours. A vplotter error in the child (a budget too
short for the picture) is raised by `get` as the parent's own; anything else (the child died,
a result that does not pickle) raises `Lost`, and the parent does that work itself. The child
ignores Ctrl-C (the parent stops it: `close`, always called), dies with the parent (a parent
killed outright leaves nothing computing) and leaves by os._exit (no atexit handlers, no
buffers of the parent flushed twice; a draw's session files and pins are not closed, the
parent's copies stay open). Memory: the child shares the parent's pages until either writes
them (copy on write); at 12 MP, 1 h its peak RSS is 163 MB beside the parent's 196 MB.
"""

from __future__ import annotations

import os
import pickle
import signal
import sys
import threading

WORKERS = 2           # processes the work is spread over (1: never fork)


class Lost(Exception):
    """The child could not give its result: the parent does that work itself."""


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:                    # not Linux
        return os.cpu_count() or 1


def start(job) -> "Child | None":
    """A child running job(send), or None where forking is not safe or gains nothing."""
    if WORKERS < 2 or not sys.platform.startswith("linux") or threading.active_count() != 1 \
            or cores() < WORKERS:
        return None
    read, write = os.pipe()
    for f in (sys.stdout, sys.stderr):
        f.flush()
    me = os.getpid()
    pid = os.fork()
    if pid == 0:                              # the child: never returns
        os.close(read)
        _run(job, os.fdopen(write, "wb"), me)
    os.close(write)
    return Child(pid, os.fdopen(read, "rb"))


def _run(job, out, parent: int) -> None:
    from vplotter.errors import VplotterError

    def send(x) -> None:
        pickle.dump(("ok", x), out, pickle.HIGHEST_PROTOCOL)
        out.flush()

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        _die_with_parent(parent)
        job(send)
    except VplotterError as e:
        _tell(out, ("error", e))
    except BaseException as e:               # noqa: BLE001 (a bug: the parent redoes it)
        _tell(out, ("lost", repr(e)))
    finally:
        os._exit(0)


def _die_with_parent(parent: int) -> None:
    """The child is killed when the parent dies (prctl PR_SET_PDEATHSIG), not left computing
    for nobody; if the parent is already gone, it stops here."""
    import ctypes

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)    # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    if os.getppid() != parent:
        os._exit(0)


def _tell(out, message) -> None:
    try:
        pickle.dump(message, out, pickle.HIGHEST_PROTOCOL)
        out.flush()
    except BaseException:                     # noqa: BLE001 (the parent is gone or stopped it)
        pass


class Child:
    def __init__(self, pid: int, inp):
        self.pid, self.inp = pid, inp

    def get(self):
        """The next thing the child sent (raises its vplotter error, or Lost)."""
        try:
            kind, x = pickle.load(self.inp)
        except Exception as e:                # EOF: it died; or what it sent does not load
            raise Lost(repr(e)) from None
        if kind == "error":
            raise x
        if kind != "ok":
            raise Lost(x)
        return x

    def close(self) -> None:
        """Stop the child (if it still runs) and reap it."""
        if self.pid:
            try:
                os.kill(self.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            os.waitpid(self.pid, 0)
            self.pid = 0
            self.inp.close()
