"""The software player under load: a real-time draw on gpiozero's MockFactory while CPU burners
(`python -c "while True: pass"`) run beside it, the pins timed OUTSIDE vplotter.

    python -m bench.stress [--burners 2] [--side 12] [--config config.toml]

Draws a square (side --side mm, pen down, then back to X0 Y0) with `vplotter draw --backend
gpiozero --verbose`, on MockFactory pins whose class records time.perf_counter_ns() at every
state change. The pin log is decoded by tests/support/tracecheck/ (which imports nothing of
vplotter)
and compared with the dry run's trace. Prints, per motor, the shortest interval between two
steps (the limit is 1 / max_step_rate), the illegal coil transitions, whether the decoded steps
are the dry run's (the patterns after every single pin change equal the dry run's, and so do the
decoded step directions), and the timeline shifts and time lost.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import ROOT, test_support

tc = test_support("tracecheck")


def square(side: float) -> str:
    h = side / 2
    return (f"G21 G90\nG00 Z5\nG00 X{-h} Y{-h}\nG01 Z-1 F600\nG01 X{h} Y{-h}\nG01 X{h} Y{h}\n"
            f"G01 X{-h} Y{h}\nG01 X{-h} Y{-h}\nG00 Z5\nG00 X0 Y0\nM2\n")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--burners", type=int, default=2)
    ap.add_argument("--side", type=float, default=12.0)
    ap.add_argument("--config", default=str(ROOT / "config.toml"))
    a = ap.parse_args()

    from gpiozero import Device
    from gpiozero.pins.mock import MockFactory, MockPWMPin

    from vplotter import config
    from vplotter.cli import main as vplotter

    log: list = []

    class TimedPin(MockPWMPin):
        def _change_state(self, value):
            changed = super()._change_state(value)
            if changed:
                log.append((time.perf_counter_ns(), self.info.name, value))
            return changed

    cfg = config.load(a.config)
    tmp = Path(tempfile.mkdtemp())
    os.environ["XDG_STATE_HOME"] = str(tmp / "state")
    gfile = tmp / "square.ngc"
    gfile.write_text(square(a.side))
    assert vplotter(["--config", a.config, "calibrate", "--at", "0", "0"]) == 0
    assert vplotter(["--config", a.config, "draw", str(gfile), "--dry-run", "--trace",
                     str(tmp / "dry.csv")]) == 0
    Device.pin_factory = MockFactory(pin_class=TimedPin)
    burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
               for _ in range(a.burners)]
    try:
        start = time.perf_counter_ns()
        code = vplotter(["--config", a.config, "draw", str(gfile), "--backend", "gpiozero",
                         "--verbose", "--trace", str(tmp / "real.csv")])
    finally:
        for b in burners:
            b.kill()
            b.wait()
    assert code == 0, code
    pins = [*cfg.motors.left_pins, *cfg.motors.right_pins]
    coil = [(t, int(n[4:]), int(v)) for t, n, v in log if int(n[4:]) in pins]
    t_us = np.array([(t - start) // 1000 for t, _, _ in coil], np.int64)
    pin = np.array([p for _, p, _ in coil], np.int64)
    value = np.array([v for _, _, v in coil], np.int64)
    t_us = np.concatenate((np.zeros(8, np.int64), t_us))
    pin = np.concatenate((np.array(pins, np.int64), pin))
    value = np.concatenate((np.zeros(8, np.int64), value))
    got = tc.Trace(t_us / 1e6, t_us, pin, value)
    tcfg = tc.load_config(a.config)
    dec = tc.decode(got, tcfg)
    dry = tc.read_trace(tmp / "dry.csv")
    ref = tc.decode(dry, tcfg)
    limit_us = 1e6 / cfg.motors.max_step_rate
    print(f"{a.burners} burners, square of {a.side:g} mm, plot time {ref.end_time:.2f} s, "
          f"played in {(t_us[-1]) / 1e6:.2f} s")
    for m, motor in enumerate(("left", "right")):
        iv = np.diff(dec.steps[motor].t_us)
        # every pin change on its own against the dry run's instants: no pattern in between
        same = (tc.coil_patterns(got, pins[4 * m:4 * m + 4], grouped=False)
                == tc.coil_patterns(dry, pins[4 * m:4 * m + 4])
                and np.array_equal(dec.steps[motor].dirs, ref.steps[motor].dirs))
        print(f"  {motor}: {len(dec.steps[motor])} steps (dry run {len(ref.steps[motor])}), "
              f"shortest interval {iv.min():.0f} us (limit {limit_us:.1f} us, "
              f"{iv.min() / limit_us:.3f} of it), same steps as the dry run: {same}")
    print(f"  illegal transitions: {dec.n_illegal}")
    real = Path(tmp / "real.csv").read_text().splitlines()
    print("  " + next((ln[2:] for ln in real if ln.startswith("# lateness")), "no lateness line"))


if __name__ == "__main__":
    main()
