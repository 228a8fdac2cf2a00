"""Backends play a step schedule (Rows) on the machine's outputs; they compute no geometry.

One small interface (`base.Backend`); each driver lives in its own module and is the only importer
of its library, so `import vplotter.backends` never touches GPIO:

- fake: records rows on a simulated clock and never sleeps (tests, --dry-run);
- gpiozero: any gpiozero pin factory, software-timed;
- lgpio: the Raspberry Pi's gpiochip through lgpio.
"""

from __future__ import annotations

from vplotter.backends.base import Backend
from vplotter.config import Config
from vplotter.errors import BackendError

NAMES = ("fake", "gpiozero", "lgpio")
__all__ = ["Backend", "NAMES", "create"]


def create(name: str, cfg: Config, **options) -> Backend:
    if name == "fake":
        from vplotter.backends.fake import FakeBackend

        return FakeBackend(cfg, **options)
    if name == "gpiozero":
        from vplotter.backends.gpiozero import GpiozeroBackend

        return GpiozeroBackend(cfg, **options)
    if name == "lgpio":
        from vplotter.backends.lgpio import LgpioBackend

        return LgpioBackend(cfg, **options)
    raise BackendError(f"unknown backend {name!r} (choose {', '.join(NAMES)})")
