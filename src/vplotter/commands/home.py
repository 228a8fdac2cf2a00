"""`vplotter home` on the polar plotter: find the arm's end switch, then back off.

The linear axis moves slowly towards its end switch ([polar] home_pin; the switch sits at the
end of the arm nearer to home_radius_mm) in short stretches, reading the switch after each;
where it closes the pen is at home_radius_mm. Then it backs off BACK_OFF_MM. The table has
no reference: its angle is taken as 0 where it stands. The stored position is set from that,
like `calibrate`.
"""

from __future__ import annotations

import numpy as np

from vplotter.machine import state
from vplotter.commands.common import eprint, session
from vplotter.errors import MachineError

STRETCH_MM = 0.25        # moved between two reads of the switch
HOME_SHARE = 0.1         # of max_step_rate while searching
BACK_OFF_MM = 2.0


def home_polar(args, cfg, command: str) -> int:
    from vplotter.motion.schedule import Scheduler

    p = cfg.polar
    spu = np.asarray(cfg.motors.steps_per_unit)
    towards = 1 if p.home_radius_mm >= (p.radius_min_mm + p.radius_max_mm) / 2 else -1
    stretch = int(np.ceil(STRETCH_MM * spu[1]))
    reach = p.radius_max_mm - p.radius_min_mm + 2 * BACK_OFF_MM
    closed_level = not p.home_active_low
    pos = state.Position.at_cords(0.0, 0.0, cfg.motors.steps_per_unit)   # radius not known yet
    pos.extra["machine"] = cfg.machine.kind
    with session(args, cfg, command, pos) as s:
        sched = Scheduler(cfg, None, s.counts, pos.ref_mm)     # one clock for the whole search
        s.play([sched.start()])                                # lift the pen
        moved = 0
        while s.backend.read_input(p.home_pin) != closed_level:
            if moved * stretch / spu[1] > reach:
                raise MachineError(f"error: the end switch (GPIO{p.home_pin}) did not close within "
                                   f"{reach:g} mm of travel; check its wiring and "
                                   f"[polar] home_active_low")
            s.play([sched.cord_move((0, towards * stretch), HOME_SHARE)])
            moved += 1
        # the pen is at home_radius_mm here; the table's angle is 0 where it stands
        s.rebase(state.Position(0.0, p.home_radius_mm, s.counts[0], s.counts[1],
                                pos.steps_per_unit, extra={"machine": cfg.machine.kind}))
        s.play([sched.cord_move((0, int(round(-towards * BACK_OFF_MM * spu[1]))), HOME_SHARE)])
        home = s.here()
    if args.dry_run:
        eprint("dry run: the fake end switch closed; nothing is stored")
    print(f"home: table angle 0, pen at radius {home.right_mm:.3f} mm "
          f"(the switch closed at {p.home_radius_mm:g} mm)")
    return 0
