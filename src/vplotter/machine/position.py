"""The stored position as a session starts from it: loaded and checked (the kind of machine,
a clean last stop), and how far off it may be after an unclean one."""

from __future__ import annotations

import numpy as np

from vplotter.machine import state
from vplotter.errors import MachineError, StateError


def load_position(cfg, trust: bool = False, dry_run: bool = False) -> state.Position:
    """The stored position, checked: refuses an unclean stop unless trusted (or a dry run)."""
    pos = state.load()
    if pos is None:
        raise MachineError("error: the pen position is unknown: bring the pen to a known point "
                           "(`vplotter jog --left MM` / `--right MM` move the cords) and run "
                           "`vplotter calibrate --at X Y` first")
    check_machine(cfg, pos)
    pos = state.recovered(pos).rebased(cfg.motors.steps_per_unit)
    if not pos.clean and not trust and not dry_run:
        mm = uncertainty_mm(cfg, pos)
        raise StateError(f"error: the last stop was not clean (crash or power cut); the position "
                         f"may be off by up to {mm:.2f} mm. Check the pen and run `vplotter "
                         f"calibrate --at X Y`, or pass --trust-position to go on from it")
    return pos


def check_machine(cfg, pos: state.Position) -> None:
    """The stored position must be of this kind of machine (cords or angle and radius)."""
    kind = pos.extra.get("machine", "vplotter")
    if kind != cfg.machine.kind:
        raise MachineError(f"error: the stored position is of a {kind} machine, not of this "
                           f"{cfg.machine.kind}; run `vplotter calibrate` (or `vplotter home`) "
                           f"first")


def uncertainty_mm(cfg, pos: state.Position) -> float:
    """How far the pen may be from the stored position after an unclean stop."""
    dev = pos.extra.get("uncertain_steps")
    if pos.clean or dev is None:
        return 0.0
    from vplotter import kinematics

    kin = kinematics.from_config(cfg)
    spu = np.asarray(pos.steps_per_unit)
    c = np.array([pos.left_mm, pos.right_mm])
    here = kin.forward(c[None, :])[0]
    corners = np.array([[sl, sr] for sl in (-1, 1) for sr in (-1, 1)]) * np.array(dev) / spu
    return float(np.hypot(*(kin.forward(c + corners) - here).T).max())
