"""Scheduling lateness of the software-timed (real-time) paths, idle and with one core busy.

    python -m bench.lateness [--seconds 10] [--spin-us 2000] [--config config.toml]

Plays a synthetic schedule in real time: both motors stepping at the configured max step rate
(half a step apart, so ~1,300 coil changes a second), handed over in 0.5 s parts like
`vplotter draw` does, with a pen change at the start. Backends: the fake (recording outputs)
and gpiozero on its MockFactory. Each runs with the machine idle, then with a busy-loop process
hogging one core. Prints p50 / p99 / max of when each change was written minus when it was due,
the timeline shifts (moves of more than 0.1 ms) and the time lost to them, and for scale how
often a bare busy loop loses the CPU meanwhile (on a virtual machine the host steals time).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numpy as np

from bench import ROOT

from vplotter import config
from vplotter.backends import create
from vplotter.motion.schedule import Rows
from vplotter.motion.sequencer import TABLES, coil_words


def synthetic(cfg, seconds: float) -> list[Rows]:
    """Pen down and settle, then both motors at the max step rate; in 0.5 s parts."""
    m = cfg.motors
    rate = m.max_step_rate
    settle = int(cfg.pen.settle_s * 1e6)
    n = int(seconds * rate)
    k = np.arange(n)
    t = np.concatenate((settle + np.rint(k * 1e6 / rate),
                        settle + np.rint((k + 0.5) * 1e6 / rate))).astype(np.int64)
    motor = np.concatenate((np.zeros(n, int), np.ones(n, int)))
    order = np.argsort(t, kind="stable")
    t, motor = t[order], motor[order]
    left, right = np.cumsum(motor == 0), np.cumsum(motor == 1)
    words = coil_words(TABLES[m.drive], left, right).astype(np.uint8)
    t = np.concatenate(([0, settle], t))
    coils = np.concatenate(([0, 0], words)).astype(np.uint8)
    pen = np.zeros(len(t), np.int32)
    pen[0] = cfg.pen.down_us
    steps = np.zeros((len(t), 2), np.int64)
    steps[2:, 0], steps[2:, 1] = left, right
    rows = Rows(t, coils, pen, np.zeros(len(t), np.int64), steps)
    cuts = np.searchsorted(t, np.arange(500_000, t[-1], 500_000))
    edges = [0, 1, *cuts.tolist(), len(t)]
    return [Rows(*(getattr(rows, f)[a:b] for f in ("t_us", "coils", "pen_us", "line", "steps")))
            for a, b in zip(edges[:-1], edges[1:]) if b > a]


def backend(name: str, cfg, spin_us: int):
    if name == "fake (realtime)":
        return create("fake", cfg, realtime=True, spin_us=spin_us)
    from gpiozero.pins.mock import MockFactory, MockPWMPin

    return create("gpiozero", cfg, pin_factory=MockFactory(pin_class=MockPWMPin),
                  spin_us=spin_us)


def run(name: str, cfg, parts: list[Rows], spin_us: int) -> dict:
    b = backend(name, cfg, spin_us)
    b.open()
    try:
        for p in parts:
            b.play(p)
        return b.lateness()
    finally:
        b.close()


def stalls(seconds: float) -> str:
    """How often a bare busy loop loses the CPU (the machine's own noise floor)."""
    t0 = prev = time.perf_counter_ns()
    gaps = []
    while prev - t0 < seconds * 1e9:
        now = time.perf_counter_ns()
        if now - prev > 100_000:
            gaps.append(now - prev)
        prev = now
    g = np.array(gaps or [0]) / 1e6
    return (f"{len(gaps)} stalls >0.1 ms in {seconds:g} s, {g.sum():.1f} ms lost, "
            f"longest {g.max():.3f} ms")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="motion per run (default 10)")
    ap.add_argument("--spin-us", type=int, default=2000, help="spin before each deadline")
    ap.add_argument("--config", default=str(ROOT / "config.toml"))
    args = ap.parse_args()
    cfg = config.load(args.config)
    parts = synthetic(cfg, args.seconds)
    changes = sum(len(p) for p in parts)
    print(f"synthetic schedule: {changes} changes in {parts[-1].t_us[-1] / 1e6:.1f} s "
          f"({cfg.motors.max_step_rate:g} steps/s per motor), spin {args.spin_us} us")
    print(f"{'backend':<20}{'load':<12}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}{'changes':>9}"
          f"{'shifts':>8}{'lost s':>8}")
    for load in ("idle", "1 core busy"):
        hog = None
        if load != "idle":
            hog = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            time.sleep(0.2)
        try:
            print(f"{'(bare busy loop)':<20}{load:<12}{stalls(2.0)}", flush=True)
            for name in ("fake (realtime)", "gpiozero (mock)"):
                s = run(name, cfg, parts, args.spin_us)
                print(f"{name:<20}{load:<12}{s['p50_ms']:>9.3f}{s['p99_ms']:>9.3f}"
                      f"{s['max_ms']:>9.3f}{s['n']:>9}{s['shifts']:>8}{s['lost_ms'] / 1e3:>8.3f}",
                      flush=True)
        finally:
            if hog is not None:
                hog.kill()
                hog.wait()


if __name__ == "__main__":
    main()
