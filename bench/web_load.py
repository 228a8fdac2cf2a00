"""What `vplotter serve` costs beside a real-time draw: the draw's timing with and without web
load, and the server's CPU and memory under that load.

    python -m bench.web_load [--seconds 60] [--pollers 20] [--streams 5] [--poll-s 0.5]
                             [--one-core]

Plays the same drawing (a zigzag of about --seconds of plot time) twice in real time on the
fake backend (`vplotter draw FILE --backend fake --realtime --trace T.csv --verbose`: the
real-time player of the gpiozero backend, into recording outputs): once with no server, once
with `vplotter serve` running and --pollers clients each asking GET /api/status every --poll-s
seconds plus --streams clients holding GET /api/events open (the page's live status). A draw
started from the CLI is what the page shows too, so the server does the same work as for a draw
it started itself. --one-core puts the draw and the server on one CPU (a Pi Zero or Pi 1; the
clients, who are phones, run elsewhere).

Prints, for both runs, the lateness the draw reports (p50 / p99 / max of actual - planned change
time, timeline shifts, time lost) and the shortest step interval per motor in the trace of what
was written (against 1/max_step_rate); for the loaded run the server's CPU (share of one core
over the draw), its resident memory (now and peak), requests served and their latency.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from bench import ROOT, test_support

tc = test_support("tracecheck")


def zigzag(seconds: float, speed_mm_s: float = 4.0) -> str:
    """Horizontal lines 40 mm long, 1 mm apart, drawn pen down: about `seconds` of plot."""
    n = max(2, int(seconds * speed_mm_s / 41.0))
    out = ["G21 G90", "G00 Z5", "G00 X0 Y0", "G01 Z-1 F600"]
    for i in range(n):
        out.append(f"G01 X{40 if i % 2 == 0 else 0} Y{-i}")
        out.append(f"G01 Y{-(i + 1)}")
    out += ["G00 Z5", "G00 X0 Y0", "M2"]
    return "\n".join(out) + "\n"


def cpu_s(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def mem_mb(pid: int) -> tuple[float, float]:
    text = Path(f"/proc/{pid}/status").read_text()
    get = lambda k: int(re.search(rf"{k}:\s+(\d+) kB", text).group(1)) / 1024  # noqa: E731
    return get("VmRSS"), get("VmHWM")


def vplotter(cfg: Path, *argv: str, cpu: set | None = None, **kw):
    pre = (lambda: os.sched_setaffinity(0, cpu)) if cpu else None
    return subprocess.Popen([sys.executable, "-m", "vplotter", "--config", str(cfg), *argv],
                            preexec_fn=pre, text=True, **kw)


def draw(cfg: Path, gcode: Path, trace: Path, cpu: set | None) -> dict:
    assert vplotter(cfg, "calibrate", "--at", "0", "0", stdout=subprocess.DEVNULL).wait() == 0
    p = vplotter(cfg, "draw", str(gcode), "--backend", "fake", "--realtime", "--trace",
                 str(trace), "--verbose", cpu=cpu, stdout=subprocess.PIPE,
                 stderr=subprocess.PIPE)
    out, err = p.communicate()
    assert p.returncode == 0, err
    m = re.search(r"p50 ([\d.]+) ms, p99 ([\d.]+) ms, max ([\d.]+) ms over (\d+) changes", out)
    shifts = re.search(r"moved (\d+) times .*?, ([\d.]+) s lost", out)
    machine = tc.load_config(cfg)
    dec = tc.decode(tc.read_trace(trace), machine)
    return {"p50_ms": float(m.group(1)), "p99_ms": float(m.group(2)), "max_ms": float(m.group(3)),
            "changes": int(m.group(4)), "shifts": int(shifts.group(1)) if shifts else 0,
            "lost_s": float(shifts.group(2)) if shifts else 0.0,
            "min_step_us": {k: round(v * 1e6, 1) for k, v in tc.min_step_interval(dec).items()},
            "step_rate_violations": len(tc.check_step_rate(dec, machine["motors"]["max_step_rate"])),
            "plot_s": out.split("plot time ")[1].split(")")[0] + ")"}


class Load:
    """--pollers threads asking /api/status, --streams threads reading /api/events."""

    def __init__(self, port: int, pollers: int, streams: int, poll_s: float, cpu: set | None):
        self.port, self.stop = port, threading.Event()
        self.latencies: list[float] = []
        self.events = 0
        self.errors = 0
        self.threads = [threading.Thread(target=self.poll, args=(poll_s, i / pollers * poll_s))
                        for i in range(pollers)]
        self.threads += [threading.Thread(target=self.stream) for _ in range(streams)]
        if cpu:
            os.sched_setaffinity(0, cpu)
        for t in self.threads:
            t.start()

    def poll(self, every: float, offset: float) -> None:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        next_t = time.monotonic() + offset
        while not self.stop.wait(max(0.0, next_t - time.monotonic())):
            next_t += every
            t0 = time.perf_counter()
            try:
                conn.request("GET", "/api/status")
                r = conn.getresponse()
                json.loads(r.read())
                self.latencies.append(time.perf_counter() - t0)
            except (OSError, http.client.HTTPException, ValueError):
                self.errors += 1
                conn.close()
                conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)

    def stream(self) -> None:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        conn.request("GET", "/api/events")
        r = conn.getresponse()
        while not self.stop.is_set():
            line = r.fp.readline()
            if not line:
                break
            if line.startswith(b"data: "):
                self.events += 1
        conn.close()

    def close(self) -> None:
        self.stop.set()
        for t in self.threads:
            t.join(timeout=5)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--pollers", type=int, default=20)
    ap.add_argument("--streams", type=int, default=5)
    ap.add_argument("--poll-s", type=float, default=0.5)
    ap.add_argument("--one-core", action="store_true",
                    help="draw and server on CPU 0, the clients on the others")
    args = ap.parse_args()
    cores = sorted(os.sched_getaffinity(0))
    machine_cpu = {cores[0]} if args.one_core else None
    client_cpu = set(cores[1:]) if args.one_core and len(cores) > 1 else None
    work = Path(tempfile.mkdtemp(prefix="web-load-"))
    os.environ["XDG_STATE_HOME"] = str(work / "state")
    cfg = work / "config.toml"
    cfg.write_text((ROOT / "config.toml").read_text().replace('backend = "lgpio"',
                                                             'backend = "fake"'))
    gcode = work / "zigzag.ngc"
    gcode.write_text(zigzag(args.seconds))
    print(f"{os.cpu_count()} CPUs; {'draw and server on one core' if args.one_core else 'all cores'}")
    idle = draw(cfg, gcode, work / "idle.csv", machine_cpu)
    print(f"no server:   {idle}")
    server = vplotter(cfg, "serve", "--port", "0", cpu=machine_cpu, stdout=subprocess.PIPE,
                      stderr=subprocess.DEVNULL)
    port = int(re.search(r":(\d+)/", server.stdout.readline()).group(1))
    threading.Thread(target=lambda: [None for _ in server.stdout], daemon=True).start()
    load = Load(port, args.pollers, args.streams, args.poll_s, client_cpu)
    time.sleep(2.0)                                  # the clients are connected
    c0, t0 = cpu_s(server.pid), time.monotonic()
    loaded = draw(cfg, gcode, work / "loaded.csv", machine_cpu)
    c1, t1 = cpu_s(server.pid), time.monotonic()
    rss, peak = mem_mb(server.pid)
    load.close()
    server.terminate()
    server.wait(timeout=10)
    lat = sorted(load.latencies) or [float("nan")]
    print(f"web load:    {loaded}")
    print(f"server: {100 * (c1 - c0) / (t1 - t0):.1f} % of one core over the {t1 - t0:.1f} s "
          f"draw; RSS {rss:.1f} MB (peak {peak:.1f} MB); {len(load.latencies)} status requests "
          f"(median {1e3 * lat[len(lat) // 2]:.1f} ms, p99 {1e3 * lat[int(len(lat) * 0.99)]:.1f} ms, "
          f"{load.errors} errors), {load.events} events on {args.streams} streams")


if __name__ == "__main__":
    main()
