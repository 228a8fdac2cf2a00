"""vplotter: drive a hanging wall plotter (V-plotter) from a Raspberry Pi.

`from vplotter import Plotter` is the Python API (vplotter/api.py, docs/api.md); it is imported
only when asked for, so that `vplotter --help` stays fast."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"
__all__ = ["Estimate", "Plotter", "Stopped", "__version__"]

if TYPE_CHECKING:
    from vplotter.api import Estimate, Plotter, Stopped


def __getattr__(name: str) -> Any:
    if name in ("Estimate", "Plotter", "Stopped"):
        from vplotter import api

        return getattr(api, name)
    raise AttributeError(f"module 'vplotter' has no attribute {name!r}")
