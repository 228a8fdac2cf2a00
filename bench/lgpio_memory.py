"""Memory of a real-time draw on the real lgpio library: RSS of `vplotter draw` over time.

Needs lgpio installed and a gpiochip: a Raspberry Pi, or a simulated one preloaded with
LD_PRELOAD (a shim that answers the gpiochip ioctls). Runs `vplotter draw FILE --backend B
--trust-position` in real time for --seconds (in a temporary state directory, calibrated at
0 0), samples the process's RSS every --every seconds, stops it with SIGINT, and prints the
samples, the growth over the first minute and the least-squares slope after --warmup seconds,
extrapolated to six hours.

    LD_PRELOAD=/tmp/gpiochip_shim.so python -m bench.lgpio_memory --seconds 90
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench import ROOT as REPO


def rss_kb(pid: int) -> int | None:
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1])
    except OSError:
        return None
    return None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", default=str(REPO / "gcode_samples" / "car.ngc"),
                    help="G-code file, or `zigzag`: 400 pen-up moves across 150 mm (an hour)")
    ap.add_argument("--backend", default="lgpio")
    ap.add_argument("--seconds", type=float, default=90.0)
    ap.add_argument("--every", type=float, default=2.0)
    ap.add_argument("--warmup", type=float, default=20.0)
    args = ap.parse_args()

    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as state:
        env["XDG_STATE_HOME"] = state
        if args.file == "zigzag":
            args.file = os.path.join(state, "zigzag.ngc")
            with open(args.file, "w") as f:
                f.write("G21 G90\n" + "".join(f"G0 X{75 if k % 2 else -75} Y{k % 40 - 20}\n"
                                              for k in range(400)) + "M2\n")
        cmd = [sys.executable, "-m", "vplotter", "--config", str(REPO / "config.toml")]
        subprocess.run(cmd + ["calibrate", "--at", "0", "0"], env=env, check=True,
                       stdout=subprocess.DEVNULL)
        proc = subprocess.Popen(cmd + ["draw", args.file, "--backend", args.backend,
                                       "--trust-position"], env=env, cwd=state,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        t0, samples = time.monotonic(), []
        while time.monotonic() - t0 < args.seconds and proc.poll() is None:
            kb = rss_kb(proc.pid)
            if kb:
                samples.append((time.monotonic() - t0, kb))
            time.sleep(args.every)
        proc.send_signal(signal.SIGINT)
        err = proc.communicate(timeout=30)[1]
    if len(samples) < 3:
        print("too few samples; the draw said:", err.strip()[-500:])
        return 1
    full = np.median([s[1] for s in samples]) / 2          # the interpreter has started
    samples = [s for s in samples if s[1] >= full]
    t = np.array([s[0] for s in samples])
    kb = np.array([s[1] for s in samples], dtype=float)
    print(f"{args.backend} {Path(args.file).name}: {len(samples)} RSS samples over {t[-1]:.0f} s")
    for ts, k in samples[:: max(1, len(samples) // 12)]:
        print(f"  t={ts:6.1f} s  RSS {k / 1024:7.1f} MB")
    minute = kb[t <= 60]
    print(f"first minute: {minute[0] / 1024:.1f} -> {minute[-1] / 1024:.1f} MB")
    print("RSS kB:", " ".join(f"{ts:.0f}:{k:.0f}" for ts, k in zip(t, kb)))
    jumps = np.diff(kb)
    k = int(np.argmax(jumps))
    print(f"largest step between two samples: {jumps[k] / 1024:+.1f} MB at t={t[k + 1]:.0f} s")
    for name, sel in ((f"after {args.warmup:.0f} s", t >= args.warmup),
                      ("second half", t >= t[-1] / 2)):
        slope = np.polyfit(t[sel], kb[sel], 1)[0] if sel.sum() >= 3 else float("nan")
        print(f"{name}: {slope:+.3f} kB/s -> {slope * 6 * 3600 / 1024:+.1f} MB per 6 h "
              f"(least squares, extrapolated)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
