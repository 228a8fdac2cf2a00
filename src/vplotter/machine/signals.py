"""The signals that end a session (Ctrl+C, SIGTERM, an SSH hang-up): while a session is open
they are only noted (and the backend told to stop soon); the player then stops where it is,
lifts the pen and releases the coils itself."""

from __future__ import annotations

import signal
from typing import Callable

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


class Signals:
    """The handlers of a session: install() sets them, restore() puts the old ones back.
    ignore_hangup: a background draw (`draw --detach`) goes on when SIGHUP comes."""

    def __init__(self, ignore_hangup: bool = False):
        self.ignore_hangup = ignore_hangup
        self.signum = 0                 # the first signal that came, 0 while none
        self._on_stop: Callable[[], None] | None = None
        self._old: dict = {}
        # called last at a signal, while set: the Python API raises there between two plays
        # (its script's own code runs, nothing moves), as Ctrl+C stops any Python program
        self.idle: Callable[[int], None] | None = None

    @property
    def pending(self) -> bool:
        """A signal asked to stop."""
        return bool(self.signum)

    def name(self) -> str:
        return signal.Signals(self.signum).name

    def install(self, on_stop: Callable[[], None]) -> None:
        """on_stop() is called from the handler at every signal (it must only set flags)."""
        self._on_stop = on_stop
        for s in SIGNALS:
            ignore = s == signal.SIGHUP and self.ignore_hangup
            self._old[s] = signal.signal(s, signal.SIG_IGN if ignore else self._handle)

    def _handle(self, signum, frame) -> None:
        if not self.signum:
            self.signum = signum
        if self._on_stop is not None:
            self._on_stop()
        if self.idle is not None:
            self.idle(signum)

    def restore(self) -> None:
        for s, h in self._old.items():
            try:
                signal.signal(s, h)
            except (ValueError, TypeError):
                pass
        self._old.clear()
