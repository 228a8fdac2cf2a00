"""Streaming throughput against real grbl 1.1 firmware (grbl-sim) behind a pseudo-terminal.

    python -m bench.grbl_throughput --sim /tmp/grblbuild/grbl/grbl-sim/grbl_sim.exe \
        [--file gcode_samples/square.ngc] [--lines N] [--config config.toml] [--only a|b]

grbl-sim (github.com/grbl/grbl-sim, built against gnea/grbl 1.1 by
`bench/reference/build_grbl_sim.sh DIR`,
with three fixes to the simulator's host code: see there) compiles grbl's own planner,
stepper and serial code and runs it in real time (time factor 1; it reads one byte per baud tick
at 115200 into grbl's 128-byte receive buffer). This script starts it with its stdin/stdout on a
pty, and relays bytes between that pty and a second pty whose slave the client opens as its
serial port. The relay timestamps the traffic, so both runs are timed the same way: from the
first byte of the first G-code line (`G21G90G94`) the client sends to the last `ok`.

Before each run the simulator (fresh, empty EEPROM in a temp dir) gets the motors' settings
($100/$101 steps/mm = steps_per_rev / spool_circumference_mm, $110/$111 max rate =
max_step_rate, $120/$121 acceleration = max_accel, converted to mm).

(a) reference: the lines vplotter would send (`draw FILE --dry-run --backend serial
    --save-stream`, after `calibrate --at 0 0` in a temp XDG_STATE_HOME) streamed by a minimal
    independent character-counting streamer (grbl's stream.py logic: the bytes of unanswered
    lines stay <= 127; every ok/error frees its line).
(b) vplotter: `vplotter --config TMP draw FILE --backend serial` with [serial] port = the pty.

--lines N cuts the G-code FILE to its first N lines; (a) then streams exactly the dry-run stream
of that cut file, which is what (b) sends. Prints both times, the ratio (a)/(b) (vplotter's
throughput relative to the reference), lines acknowledged and errors, and after (b) the work
position grbl reports against the last X/Y of the stream (the planned end).
"""

from __future__ import annotations

import argparse
import os
import pty
import re
import select
import shutil
import subprocess
import sys
import tempfile
import termios
import threading
import time
import tomllib
import tty
from pathlib import Path

from bench import ROOT

ENV = dict(os.environ)
VPLOTTER = [sys.executable, "-m", "vplotter"]


def raw(fd: int) -> None:
    tty.setraw(fd)
    a = termios.tcgetattr(fd)
    a[3] &= ~(termios.ECHO | termios.ICANON)
    termios.tcsetattr(fd, termios.TCSANOW, a)


class Sim:
    """grbl_sim.exe on pty B, relayed to pty A (the client's port)."""

    def __init__(self, exe: str, settings: dict[str, float]):
        self.dir = tempfile.mkdtemp(prefix="grblsim_")
        self.mb, sb = pty.openpty()
        raw(sb)
        raw(self.mb)
        self.proc = subprocess.Popen(
            ["stdbuf", "-i0", "-o0", os.path.abspath(exe), "-n", "-t", "1", "-b", os.devnull],
            stdin=sb, stdout=sb, stderr=subprocess.DEVNULL, cwd=self.dir, start_new_session=True)
        os.close(sb)
        import atexit
        atexit.register(lambda: self.proc.poll() is None and self.proc.kill())
        self.ma, self.sa = pty.openpty()      # keep sa open: the master never sees EIO
        raw(self.sa)
        raw(self.ma)
        self.port = os.ttyname(self.sa)
        self._buf = b""
        self.wait_for(rb"Grbl 1\.1\w* \[", 10.0)
        for k, v in settings.items():
            os.write(self.mb, f"{k}={v}\n".encode())
            self.wait_for(rb"(ok|error:\d+)\r?\n", 5.0)
        self.log: list[tuple[float, str, bytes]] = []   # (t, 'tx'|'rx', data)
        self._stop = False
        # drain what the client side holds before it opens the port
        termios.tcflush(self.sa, termios.TCIOFLUSH)
        self.thread = threading.Thread(target=self._relay, daemon=True)
        self.thread.start()

    def wait_for(self, pat: bytes, timeout: float) -> bytes:
        end = time.monotonic() + timeout
        while True:
            m = re.search(pat, self._buf)
            if m:
                self._buf = self._buf[m.end():]
                return m.group(0)
            left = end - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"grbl_sim: no {pat!r}; got {self._buf[-200:]!r}")
            r, _, _ = select.select([self.mb], [], [], left)
            if r:
                self._buf += os.read(self.mb, 4096)

    def _relay(self) -> None:
        while not self._stop:
            r, _, _ = select.select([self.ma, self.mb], [], [], 0.05)
            for fd in r:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    continue
                t = time.perf_counter()
                if fd == self.ma:
                    os.write(self.mb, data)
                    self.log.append((t, "tx", data))
                else:
                    os.write(self.ma, data)
                    self.log.append((t, "rx", data))

    def work_position(self) -> tuple[float, float] | None:
        """Ask grbl itself (`?`, several times until a report carries WCO): MPos - WCO."""
        wco = None
        mpos = None
        for _ in range(40):
            n = len(self.log)
            os.write(self.mb, b"?")
            time.sleep(0.1)
            rx = b"".join(d for _, k, d in self.log[n:] if k == "rx").decode(errors="replace")
            m = re.search(r"MPos:([-\d.]+),([-\d.]+)", rx)
            w = re.search(r"WCO:([-\d.]+),([-\d.]+)", rx)
            if m:
                mpos = (float(m.group(1)), float(m.group(2)))
            if w:
                wco = (float(w.group(1)), float(w.group(2)))
            if mpos and wco:
                return (mpos[0] - wco[0], mpos[1] - wco[1])
        return None

    def close(self) -> None:
        self._stop = True
        self.thread.join(1.0)
        self.proc.kill()
        self.proc.wait()
        for fd in (self.ma, self.sa, self.mb):
            os.close(fd)
        shutil.rmtree(self.dir, ignore_errors=True)

    def timing(self, first_line: bytes) -> dict:
        """From the first byte of first_line sent to the last ok/error received."""
        tx = b"".join(d for _, k, d in self.log if k == "tx")
        i = tx.find(first_line)
        if i < 0:
            return {"t": None, "ok": 0, "errors": []}
        n = 0
        t0 = None
        for t, k, d in self.log:
            if k == "tx":
                if n + len(d) > i:
                    t0 = t
                    break
                n += len(d)
        oks, errors, t1 = 0, [], t0
        rx = b""
        for t, k, d in self.log:
            if k != "rx" or t < t0:
                continue
            rx += d
            while b"\n" in rx:
                ln, rx = rx.split(b"\n", 1)
                ln = ln.strip()
                if ln == b"ok":
                    oks += 1
                    t1 = t
                elif ln.startswith(b"error") or ln.startswith(b"ALARM"):
                    errors.append(ln.decode())
                    t1 = t
        # lines in flight over time (sent, not answered): time-weighted mean and time at zero
        sent = acked = 0
        pos = 0
        idle = area = 0.0
        last = t0
        rxb = b""
        for t, k, d in self.log:
            if t0 <= t <= t1:
                dt = t - last
                area += dt * (sent - acked)
                if sent == acked:
                    idle += dt
                last = t
            if k == "tx":
                for c in d:
                    if pos >= i and c == 10:
                        sent += 1
                    pos += 1
            elif t >= t0:
                rxb += d
                while b"\n" in rxb:
                    ln, rxb = rxb.split(b"\n", 1)
                    if ln.strip() == b"ok" or ln.strip().startswith(b"error"):
                        acked += 1
        span = max(t1 - t0, 1e-9)
        return {"t": t1 - t0, "ok": oks, "errors": errors, "mean_inflight": area / span,
                "t_empty": idle}


def stream_reference(port: str, lines: list[str], rx_buffer: int = 128) -> None:
    """grbl's stream.py character counting, on the raw pty (no pyserial)."""
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    raw(fd)
    buf = b""

    def readline(timeout=30.0) -> str:
        nonlocal buf
        end = time.monotonic() + timeout
        while b"\n" not in buf:
            r, _, _ = select.select([fd], [], [], max(0.0, end - time.monotonic()))
            if not r:
                raise TimeoutError("reference streamer: no answer")
            buf += os.read(fd, 4096)
        ln, buf = buf.split(b"\n", 1)
        return ln.strip().decode(errors="replace")

    os.write(fd, b"\x18")                       # soft reset, wait for the banner (as vplotter)
    while not readline(10).startswith("Grbl"):
        pass
    sizes: list[int] = []
    for ln in lines:
        b = (ln + "\n").encode()
        sizes.append(len(b))
        while sum(sizes) > rx_buffer - 1:
            ans = readline()
            if ans == "ok" or ans.startswith("error"):
                sizes.pop(0)
        os.write(fd, b)
    while sizes:
        ans = readline(120)
        if ans == "ok" or ans.startswith("error"):
            sizes.pop(0)
    os.close(fd)


def planned_end(lines: list[str]) -> tuple[float, float] | None:
    """The last X and Y the stream commands (work coordinates: after its G92)."""
    x = y = None
    for ln in lines:
        for letter, val in re.findall(r"([XY])(-?[\d.]+)", ln.split(";")[0]):
            if letter == "X":
                x = float(val)
            else:
                y = float(val)
    return (x, y) if x is not None and y is not None else None


def grbl_settings(cfg: dict) -> dict[str, float]:
    m = cfg["motors"]
    spm = m["steps_per_rev"] / m["spool_circumference_mm"]
    rate = m["max_step_rate"] / spm * 60.0
    acc = m["max_accel"] / spm
    return {"$100": round(spm, 3), "$101": round(spm, 3), "$110": round(rate, 3),
            "$111": round(rate, 3), "$120": round(acc, 3), "$121": round(acc, 3)}


def with_port(cfg_text: str, port: str) -> str:
    keep, skip = [], False
    for ln in cfg_text.splitlines():
        if ln.strip().startswith("["):
            skip = ln.strip().startswith("[serial]")
        if not skip:
            keep.append(ln)
    return "\n".join(keep) + f'\n\n[serial]\nport = "{port}"\n'


def report(res: dict, k: str, n: int) -> None:
    name = {"a": "reference streamer", "b": "vplotter draw"}[k]
    r = res[k]
    t = f"{r['t']:.3f} s" if r["t"] is not None else "n/a"
    extra = f", exit {r['rc']}" if "rc" in r else ""
    print(f"({k}) {name}: first line to last ok {t}, process wall {r['wall']:.3f} s, "
          f"ok {r['ok']}/{n}, errors {len(r['errors'])}{extra}; lines in flight: mean "
          f"{r.get('mean_inflight', 0):.1f}, none for {r.get('t_empty', 0):.2f} s"
          + (f" {r['errors'][:3]}" if r["errors"] else ""), flush=True)


def run_vplotter(args, settings: dict, cfg_text: str, src: Path, tmp: Path, lines: list,
                 first: bytes, calibrated_env, res: dict) -> None:
    """(b): `vplotter draw FILE --backend serial` on a fresh simulator; its timing into res."""
    sim = Sim(args.sim, settings)
    try:
        conf = tmp / "config.toml"
        conf.write_text(with_port(cfg_text, sim.port))
        env = calibrated_env()
        w0 = time.perf_counter()
        try:
            p = subprocess.run(VPLOTTER + ["--config", str(conf), "draw", str(src),
                                           "--backend", "serial"], env=env,
                               capture_output=True, text=True, timeout=args.timeout)
        except subprocess.TimeoutExpired as e:
            p = subprocess.CompletedProcess(e.cmd, "timeout", e.stdout or "", e.stderr or "")
            print(f"(b) vplotter draw did not finish within {args.timeout} s", flush=True)
        wall = time.perf_counter() - w0
        time.sleep(0.2)
        res["b"] = dict(sim.timing(first), wall=wall, rc=p.returncode)
        if p.returncode:
            print(str(p.stdout)[-2000:], str(p.stderr)[-2000:])
        report(res, "b", len(lines))
        end = planned_end(lines)
        got = sim.work_position()
        if end and got:
            off = max(abs(got[0] - end[0]), abs(got[1] - end[1]))
            print(f"(b) final work position {got[0]:.3f}, {got[1]:.3f}; planned end "
                  f"{end[0]:.3f}, {end[1]:.3f}; off by {off:.3f} mm", flush=True)
    finally:
        sim.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim", required=True, help="path to grbl_sim.exe")
    ap.add_argument("--file", default=str(ROOT / "gcode_samples" / "square.ngc"))
    ap.add_argument("--config", default=str(ROOT / "config.toml"))
    ap.add_argument("--lines", type=int, default=0, help="only the first N lines of FILE")
    ap.add_argument("--only", choices=["a", "b"], default=None)
    ap.add_argument("--timeout", type=float, default=3600.0, help="for (b), s")
    args = ap.parse_args()

    tmp = Path(tempfile.mkdtemp(prefix="grbltp_"))
    cfg_text = Path(args.config).read_text()
    cfg = tomllib.loads(cfg_text)
    settings = grbl_settings(cfg)
    src = Path(args.file)
    if args.lines:
        cut = tmp / src.name
        cut.write_text("".join(src.read_text().splitlines(keepends=True)[:args.lines]))
        src = cut

    def calibrated_env() -> dict:
        st = tempfile.mkdtemp(dir=tmp, prefix="state_")
        env = dict(ENV, XDG_STATE_HOME=st)
        subprocess.run(VPLOTTER + ["--config", args.config, "calibrate", "--at", "0", "0"],
                       env=env, check=True, stdout=subprocess.DEVNULL)
        return env

    stream = tmp / "stream.gcode"
    subprocess.run(VPLOTTER + ["--config", args.config, "draw", str(src), "--dry-run", "--backend",
                               "serial", "--save-stream", str(stream)],
                   env=calibrated_env(), check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    lines = [ln.strip() for ln in stream.read_text().splitlines() if ln.strip()]
    first = (lines[0] + "\n").encode()
    print(f"file {args.file}{f' (first {args.lines} lines)' if args.lines else ''}: "
          f"{len(lines)} lines, {sum(len(x) + 1 for x in lines)} bytes to stream")
    print("grbl settings: " + " ".join(f"{k}={v}" for k, v in settings.items()), flush=True)

    res = {}
    if args.only in (None, "a"):
        sim = Sim(args.sim, settings)
        try:
            w0 = time.perf_counter()
            stream_reference(sim.port, lines)
            wall = time.perf_counter() - w0
            time.sleep(0.2)
            res["a"] = dict(sim.timing(first), wall=wall)
            report(res, "a", len(lines))
        finally:
            sim.close()
    if args.only in (None, "b"):
        run_vplotter(args, settings, cfg_text, src, tmp, lines, first, calibrated_env, res)

    done = [k for k in res if res[k]["t"] and res[k]["ok"] == len(lines)
            and res[k].get("rc", 0) == 0]
    if "a" in res and "b" in res and len(done) < 2:
        print("no ratio: " + ", ".join(f"({k}) did not complete" for k in res if k not in done))
    if "a" in done and "b" in done:
        print(f"throughput vplotter / reference = (a)/(b) = {res['a']['t'] / res['b']['t']:.4f}")
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
