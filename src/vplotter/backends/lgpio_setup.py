"""Starting lgpio safely: the import, the process's timers and memory, and errors people can
act on.

`import lgpio` makes a notify FIFO (`.lgd-nfy<N>`) in the process's working directory, and
fails with a bare FileNotFoundError when that directory is not writable. Setting LG_WD instead
makes lgpio's C library chdir the whole process there. `load_lgpio()` does both safely: the FIFO
is made in the state directory and its name removed once both ends are open, and the working
directory is restored (relative paths on the command line keep their meaning). lgpio says only
"can not open gpiochip"; `chip_error()` looks at the device itself to say what to do.
"""

from __future__ import annotations

import errno
import os
import sys

from vplotter.errors import BackendError

def missing(version: tuple[int, int] = tuple(sys.version_info[:2])) -> str:
    """What to install when `import lgpio` fails, for this Python: the lgpio project's wheels
    stop at 3.12, Adafruit's adafruit-lgpio (the same `import lgpio`) starts at 3.13."""
    pkg = "lgpio" if version < (3, 13) else "adafruit-lgpio"
    py = f"Python {version[0]}.{version[1]}"
    return (f"error: the lgpio backend needs the lgpio module; for {py}: `pip install {pkg}` "
            f"in this environment (or `pip install '.[pi]'` in vplotter's directory; where pip "
            f"has to build it, first `sudo apt install swig python3-dev`), or `sudo apt install "
            f"python3-lgpio` with a venv made with --system-site-packages; or use --dry-run to "
            f"simulate")


def load_lgpio(importer=None):
    """Import lgpio so that its notify FIFO is made in the state directory, never in the
    user's working directory; the working directory is unchanged afterwards. Every failure is
    one BackendError line. importer() -> module stands in for `import lgpio` in tests."""
    if importer is None:
        if "lgpio" in sys.modules and sys.modules["lgpio"] is not None:
            return sys.modules["lgpio"]

        def importer():
            import lgpio
            return lgpio
    from vplotter.config import state_dir

    where = state_dir()
    try:
        where.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise BackendError(f"error: cannot make {where} for lgpio's notify file ({e.strerror}); "
                           f"set XDG_STATE_HOME to a writable directory, or use --dry-run") \
            from None
    here = _cwd_handle()
    old = os.environ.get("LG_WD")
    os.environ["LG_WD"] = str(where)  # lgpio's C library chdirs there once, at its first use
    try:
        lg = importer()
    except ImportError:
        raise BackendError(missing()) from None
    except Exception as e:  # noqa: BLE001 - lgpio fails at import when its FIFO cannot be made
        raise BackendError(f"error: lgpio cannot start ({type(e).__name__}: {e}); is {where} "
                           f"writable? or use --dry-run") from None
    finally:
        if old is None:
            os.environ.pop("LG_WD", None)
        else:
            os.environ["LG_WD"] = old
        _restore_cwd(here)
    _remove_fifo(lg, where)
    return lg


def _cwd_handle():
    try:
        return os.open(".", getattr(os, "O_PATH", os.O_RDONLY) | os.O_DIRECTORY)
    except OSError:
        try:
            return os.getcwd()
        except OSError:
            return None


def _restore_cwd(here) -> None:
    if here is None:
        return
    try:
        if isinstance(here, int):
            os.fchdir(here)
        else:
            os.chdir(here)
    except OSError:
        pass
    finally:
        if isinstance(here, int):
            os.close(here)


def _remove_fifo(lg, where) -> None:
    """Both ends of the FIFO are open now: its name is no longer needed."""
    thread = getattr(lg, "_notify_thread", None)
    handle = getattr(thread, "_notify", None)
    if isinstance(handle, int) and handle >= 0:
        try:
            os.unlink(os.path.join(where, f".lgd-nfy{handle}"))
        except OSError:
            pass


_latency_fd: int | None = None


def tight_timers() -> None:
    """Timer slack 1 ns for this thread and the threads it starts: Linux lets a sleeping thread wake
    up to 50 us late by default, which every write the player times would show. Where allowed
    (root), also ask for no deep CPU idle states while the process runs (/dev/cpu_dma_latency 0, as
    cyclictest does): a CPU waking from one makes the next edge later; the request ends with the
    process."""
    global _latency_fd
    if not sys.platform.startswith("linux"):
        return
    if _latency_fd is None:
        try:
            fd = os.open("/dev/cpu_dma_latency", os.O_WRONLY | os.O_CLOEXEC)
            os.write(fd, (0).to_bytes(4, sys.byteorder))
            _latency_fd = fd
        except OSError:
            _latency_fd = -1
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(29, ctypes.c_ulong(1), 0, 0, 0)  # PR_SET_TIMERSLACK
    except (OSError, AttributeError):
        pass


def chip_errno(chip: int) -> int:
    """Why /dev/gpiochipN cannot be opened (lgpio says only "can not open gpiochip")."""
    try:
        os.close(os.open(f"/dev/gpiochip{chip}", os.O_RDWR | os.O_CLOEXEC))
    except OSError as e:
        return e.errno or 0
    return 0


def chip_error(chip: int, why: str) -> BackendError:
    code = chip_errno(chip)
    dev = f"/dev/gpiochip{chip}"
    if code in (errno.EACCES, errno.EPERM):
        return BackendError(f"error: permission denied on {dev}: add your user to the gpio group "
                            f"(`sudo adduser $USER gpio`, then log in again; `groups` lists "
                            f"yours), or use --dry-run")
    if code == errno.ENOENT:
        return BackendError(f"error: there is no {dev} (no GPIO here?): use --dry-run to "
                            f"simulate; on a Pi 5 with an older kernel set [gpio] chip = 4")
    detail = os.strerror(code) if code else why
    return BackendError(f"error: cannot open {dev} ({detail}): check [gpio] chip in the config, "
                        f"or use --dry-run")
