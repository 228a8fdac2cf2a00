"""Setting the machine up, with results as values (what the page asks; docs/web.md): where the
pen is (`calibrate --at X Y`), `home`, and the pen's pulse widths saved into config.toml.

`cmd_calibrate` and `cmd_home` are the commands of commands/machine.py, unchanged for the
command line, that also hand their result to a program running them (commands/common.answering:
the page's Machine runs them as subprocesses). `save_pen` writes [pen] up_us/down_us with
tomlkit, comments and layout kept, and refuses what would not load.
"""

from __future__ import annotations

from dataclasses import dataclass

from vplotter.commands.common import answering, load_config
from vplotter.errors import ConfigError

MAX_US = 2600               # the widest servo pulse `pen --up-us` takes (and [pen] allows)


@dataclass(frozen=True)
class Placed:
    """Where the pen is now (G-code mm), after `calibrate --at X Y` or `home`; message: the
    line the command prints (calibrate: the cords and steps too)."""

    x: float
    y: float
    message: str


def _placed(args, message: str | None = None) -> Placed:
    from vplotter.commands.machine import _describe, _pen_xy
    from vplotter.machine import state

    cfg = load_config(args)
    pos = state.load()
    xy = [0.0 if abs(v) < 5e-4 else round(float(v), 4) for v in _pen_xy(cfg, pos)]
    return Placed(xy[0], xy[1], message if message is not None else _describe(cfg, pos))


def cmd_calibrate(args, argv=None) -> int:
    """`vplotter calibrate`; with --at/--cords it answers a Placed."""
    from vplotter.commands import machine

    with answering() as answer:
        code = machine.cmd_calibrate(args, argv)
        if args.what is None and code == 0:
            answer(_placed(args))
    return code


def cmd_home(args, argv=None) -> int:
    """`vplotter home`; a real (not dry) run answers a Placed."""
    from vplotter.commands import machine

    with answering() as answer:
        code = machine.cmd_home(args, argv)
        if code == 0 and not args.dry_run:
            placed = _placed(args, "")
            answer(Placed(placed.x, placed.y, f"pen at X{placed.x:.3f} Y{placed.y:.3f}"))
    return code


@dataclass(frozen=True)
class PenSaved:
    """[pen] up_us and down_us written into the config file `path`."""

    up_us: int
    down_us: int
    path: str

    @property
    def message(self) -> str:
        return f"saved [pen] up_us = {self.up_us}, down_us = {self.down_us} in {self.path}"


def save_pen(path: str, up_us: int, down_us: int) -> PenSaved:
    """Write [pen] up_us and down_us into the config file at `path` (comments and layout
    kept; ConfigError for widths out of 1..MAX_US, a pen that is not a servo, or a file that
    would not load)."""
    import tomllib
    from pathlib import Path

    import tomlkit

    from vplotter import config
    from vplotter.machine import state

    for name, v in (("up_us", up_us), ("down_us", down_us)):
        if isinstance(v, bool) or not isinstance(v, int) or not 0 < v <= MAX_US:
            raise ConfigError(f"error: {name} must be a whole number of microseconds, "
                              f"1..{MAX_US} (got {v!r})")
    cfg = config.load(path)
    if cfg.pen.kind != "servo":
        raise ConfigError(f"{cfg.path}: error: [pen] kind is {cfg.pen.kind!r}: pulse widths "
                          f"are for a servo pen")
    p = Path(path)
    doc = tomlkit.parse(p.read_text(encoding="utf-8"))
    doc["pen"]["up_us"] = int(up_us)
    doc["pen"]["down_us"] = int(down_us)
    text = tomlkit.dumps(doc)
    config.from_dict(tomllib.loads(text), str(p))     # refuse a config that would not load
    state.atomic_write(p, text)
    return PenSaved(int(up_us), int(down_us), str(p))


def pen_colour(cfg, name: str | None) -> str | None:
    """The '#rrggbb' of a pen named `name`: its [pens.NAME] colour, else the name read as a
    colour (`red`, `#2050c0`), else None."""
    if not name:
        return None
    from vplotter.drawing import pens

    spec = pens.by_name(getattr(getattr(cfg, "pens", None), "owned", ()), name)
    if spec is not None:
        return spec.colour
    try:
        from vplotter.inputs import colour

        return colour.parse(name)
    except ValueError:
        return None
