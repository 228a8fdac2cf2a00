"""Streaming throughput against real grbl firmware: vplotter's streamer versus the controller
with its planner always full.

grbl's own simulator (github.com/grbl/grbl-sim, built from grbl 1.1h; build it yourself
outside this repository) runs the real firmware on this computer. This script puts it behind a
pseudo-terminal pair (opening the port soft-resets it, like an Arduino), writes the controller
settings that config.toml implies ($100/$101 steps/mm, $110/$111 max rate, $120/$121
acceleration: asked for here, never by vplotter), and streams the file's line stream twice:

- "planner full": a writer that pushes the whole stream into the port at once. The simulator
  reads a byte only when its receive buffer has room, so the port's kernel buffer feeds it the
  moment it can take more: the controller is never waiting for the host;
- vplotter: `vplotter draw FILE --backend serial` (character counting, status polling).

Both are timed from the first line sent until the controller reports Idle after the last
answer, in wall-clock time, with the simulator running at the same speed factor; the figure
is planner-full time / vplotter time (1.0: vplotter never lets the planner starve).

Run: python bench/serial_throughput.py --sim /path/to/grbl_sim.exe [--speed 4] [FILE ...]
"""

from __future__ import annotations

import argparse
import fcntl
import os
import select
import struct
import subprocess
import sys
import tempfile
import termios
import threading
import time
import tty

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class SimPort:
    """grbl_sim on one pty pair, bridged to another whose slave is the port to open."""

    def __init__(self, exe: str, speed: float, workdir: str):
        self.am, aslave = os.openpty()
        self.bm, self.bs = os.openpty()
        for fd in (aslave, self.bs):
            tty.setraw(fd)
            attrs = termios.tcgetattr(fd)
            attrs[3] &= ~termios.ECHO
            termios.tcsetattr(fd, termios.TCSANOW, attrs)
        fcntl.ioctl(self.bm, termios.TIOCPKT, struct.pack("i", 1))
        self.proc = subprocess.Popen(["stdbuf", "-i0", "-o0", exe, "-n", "-t", str(speed), "-b", "/dev/null", "-s",
                                      "/dev/null"], stdin=aslave, stdout=aslave,
                                     stderr=subprocess.DEVNULL, cwd=workdir)
        os.close(aslave)
        self.port = os.ttyname(self.bs)
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._bridge, daemon=True)
        self.thread.start()

    def _bridge(self) -> None:
        while not self.stop.is_set():
            r, _, _ = select.select([self.am, self.bm], [], [], 0.1)
            try:
                if self.am in r:
                    os.write(self.bm, os.read(self.am, 4096))
                if self.bm in r:
                    pkt = os.read(self.bm, 4096)
                    if pkt[0] & termios.TIOCPKT_FLUSHREAD:     # port opened: reset, as on DTR
                        os.write(self.am, b"\x18")
                    if pkt[0] == 0 and len(pkt) > 1:
                        os.write(self.am, pkt[1:])
            except OSError:
                return

    def close(self) -> None:
        self.stop.set()
        self.proc.kill()
        self.proc.wait()
        self.thread.join()
        for fd in (self.am, self.bm, self.bs):
            os.close(fd)


def settings_for(cfg) -> list[str]:
    from vplotter.commands.serial import expected_settings

    return [f"${n}={v:.3f}" for n, (v, _) in expected_settings(cfg).items()]


def planner_full(port: str, lines: list[str], settings: list[str]) -> float:
    import serial

    from vplotter.backends.grbl import Link

    ser = serial.Serial(port, 115200, timeout=0.02)
    link = Link(ser, port, 20.0)
    link.wait_banner()
    time.sleep(1.0)                          # a second banner may follow (start-up, then reset)
    link.read_lines()
    for s in settings:
        link.command(s)
    data = "".join(ln + "\n" for ln in lines).encode()
    answered = 0
    t0 = time.monotonic()
    writer = threading.Thread(target=ser.write, args=(data,))
    writer.start()
    last_poll = 0.0
    while True:
        now = time.monotonic()
        if answered == len(lines) and now - last_poll > 0.05:
            ser.write(b"?")
            last_poll = now
        for ln in link.read_lines():
            if ln == "ok" or ln.startswith("error"):
                answered += 1
            elif ln.startswith("<Idle") and answered == len(lines):
                writer.join()
                ser.close()
                return time.monotonic() - t0


def vplotter_stream(cfg_path: str, gfile: str, port: str, settings: list[str],
                    state_dir: str) -> tuple[float, int]:
    import serial

    from vplotter.backends import grbl
    from vplotter.backends.grbl import Link
    from vplotter.cli import main

    ser = serial.Serial(port, 115200, timeout=0.02)
    link = Link(ser, port, 20.0)
    link.wait_banner()
    time.sleep(1.0)                          # a second banner may follow (start-up, then reset)
    link.read_lines()
    for s in settings:                       # the bench asks for them; vplotter never does
        link.command(s)
    ser.close()
    os.environ["XDG_STATE_HOME"] = state_dir
    main(["--config", cfg_path, "calibrate", "--at", "0", "0"])
    timed: dict = {}
    run = grbl.Streamer.run

    def timed_run(self, *a, **kw):
        t0 = time.monotonic()
        try:
            return run(self, *a, **kw)
        finally:
            timed["s"] = time.monotonic() - t0
            timed["lines"] = self.pulled

    grbl.Streamer.run = timed_run
    try:
        rc = main(["--config", cfg_path, "draw", gfile, "--backend", "serial"])
    finally:
        grbl.Streamer.run = run
    if rc != 0:
        raise SystemExit(f"draw failed with exit status {rc}")
    return timed["s"], timed["lines"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sim", required=True, help="grbl_sim.exe (grbl-sim built from grbl 1.1h)")
    ap.add_argument("--speed", type=float, default=1.0, help="simulator speed factor (-t)")
    ap.add_argument("--config", default=os.path.join(ROOT, "config.toml"))
    ap.add_argument("files", nargs="*", default=[os.path.join(ROOT, "gcode_samples", "circles.ngc")])
    args = ap.parse_args()
    from vplotter import config
    from vplotter.cli import main as vmain

    print(f"{'file':<14} {'lines':>6} {'planner full':>13} {'vplotter':>10} {'throughput':>11}")
    for gfile in args.files:
        with tempfile.TemporaryDirectory() as tmp:
            sim = SimPort(os.path.abspath(args.sim), args.speed, tmp)
            try:
                text = open(args.config).read() + f'\n[serial]\nport = "{sim.port}"\ntimeout_s = 20.0\n'
                cfg_path = os.path.join(tmp, "config.toml")
                open(cfg_path, "w").write(text)
                cfg = config.load(cfg_path)
                stream = os.path.join(tmp, "stream.gcode")
                os.environ["XDG_STATE_HOME"] = os.path.join(tmp, "dry")
                with open(os.devnull, "w") as null:
                    old = sys.stdout, sys.stderr
                    sys.stdout = sys.stderr = null
                    try:
                        vmain(["--config", cfg_path, "draw", gfile, "--dry-run", "--backend",
                               "serial", "--save-stream", stream])
                    finally:
                        sys.stdout, sys.stderr = old
                lines = open(stream).read().splitlines()
                settings = settings_for(cfg)
                full = planner_full(sim.port, lines, settings)
                with open(os.devnull, "w") as null:
                    old = sys.stdout, sys.stderr
                    sys.stdout = sys.stderr = null
                    try:
                        ours, n = vplotter_stream(cfg_path, gfile, sim.port, settings,
                                                  os.path.join(tmp, "state"))
                    finally:
                        sys.stdout, sys.stderr = old
            finally:
                sim.close()
        print(f"{os.path.basename(gfile):<14} {n:>6} {full:>12.1f}s {ours:>9.1f}s "
              f"{full / ours:>10.1%}", flush=True)


if __name__ == "__main__":
    main()
