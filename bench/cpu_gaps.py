"""How often this machine takes the CPU away from a spinning thread, and for how long: the floor
under any software-timed pulse (a pen pulse whose fall falls into such a gap comes out long).

    python -m bench.cpu_gaps [--seconds 2] [--fifo]

Spins on the monotonic clock for --seconds (at SCHED_FIFO priority 10 with --fifo, as vplotter's
player spins through a pen pulse where allowed) and prints the gaps between two successive
clock reads longer than 5 us and 20 us: how many per second, their sizes, and the share of time
a given instant lies more than 20 us inside one (the chance that a pulse's fall comes 20 us or
more late).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--fifo", action="store_true")
    a = ap.parse_args()
    if a.fifo:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
    clock = time.monotonic_ns
    end = clock() + int(a.seconds * 1e9)
    prev = clock()
    gaps = []
    while prev < end:
        t = clock()
        if t - prev > 5000:
            gaps.append(t - prev)
        prev = t
    g = np.array(gaps, dtype=np.float64) / 1e3
    big = g[g > 20]
    late = np.clip(big - 20, 0, None).sum() / (a.seconds * 1e6)
    print(f"{'FIFO' if a.fifo else 'normal'} priority, {a.seconds:g} s spinning")
    print(f"gaps > 5 us: {len(g) / a.seconds:.0f}/s; > 20 us: {len(big) / a.seconds:.0f}/s")
    if len(g):
        p50, p90, p100 = np.percentile(g, [50, 90, 100])
        print(f"gap sizes: median {p50:.1f} us, p90 {p90:.1f} us, max {p100:.1f} us; "
              f"time away {g.sum() / (a.seconds * 1e4):.1f} %")
    print(f"an instant lies > 20 us inside a gap: {100 * late:.2f} % of the time")


if __name__ == "__main__":
    main()
