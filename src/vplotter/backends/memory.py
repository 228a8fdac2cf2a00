"""Keeping the resident size flat over a long plot (glibc's allocator, Linux only).

The schedule is computed on a helper thread in parts of up to 10,000 steps (a few hundred kB of
numpy arrays each), played, and dropped. Left to its defaults glibc keeps what such parts
leave behind: it raises its mmap threshold after the first large free (so later parts come
from the heap and stay resident), gives each thread an arena of its own, and returns freed
pages in the middle of an arena only on `malloc_trim`. Measured over the real lgpio library
before these settings: +0.1-0.25 MB in steps during the first 90 s of car.ngc, which read as
40-60 MB per six hours when extrapolated.
"""

from __future__ import annotations

import sys
import time

M_ARENA_MAX = -8
M_MMAP_THRESHOLD = -3
GIVE_BACK_S = 5.0               # malloc_trim at most this often
MMAP_FROM = 16 * 1024           # blocks this large get their own mapping (numpy arrays of rows)

_libc = None
_last = 0.0


def _c():
    global _libc
    if _libc is None:
        _libc = False
        if sys.platform.startswith("linux"):
            try:
                import ctypes

                _libc = ctypes.CDLL(None)
                _libc.malloc_trim  # noqa: B018 - glibc only (not musl)
            except (OSError, AttributeError):
                _libc = False
    return _libc


def lean_malloc() -> None:
    """Before a real-time run starts its threads: blocks of MMAP_FROM and more (a part's
    numpy arrays) from their own mappings, given back when freed (a fixed threshold: no
    raising), and one arena for all threads."""
    c = _c()
    if c:
        c.mallopt(M_MMAP_THRESHOLD, MMAP_FROM)
        c.mallopt(M_ARENA_MAX, 1)


def give_back(now: float | None = None) -> None:
    """Return the free pages in the middle of the heap to the system (at most every
    GIVE_BACK_S; called between parts on the planning thread: ctypes lets the player run)."""
    global _last
    c = _c()
    now = time.monotonic() if now is None else now
    if c and now - _last >= GIVE_BACK_S:
        _last = now
        c.malloc_trim(0)
