"""serve: the page on the Pi (vplotter.web), on the CLI's own machinery.

The web app asks a Machine (below) for everything it does to the plotter: the status object
of `status --json`, the estimate of `estimate`, the picture of `preview`, and draws, stops, pen
and jog moves as the very commands (`draw FILE --detach`, `stop`, `pen`, `jog`) run in
subprocesses with this config (an argument list, never a shell). A draw so started lives in its
own process and session: the server can stop or crash without touching it.
"""

from __future__ import annotations

import argparse
import os
import sys

from vplotter.commands.common import eprint, load_config, say
from vplotter.errors import ConfigError

LOOPBACK = ("127.0.0.1", "::1", "localhost")
DEFAULT_PORT = 8000


def add_serve(p: argparse.ArgumentParser) -> None:
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only; "
                        "0.0.0.0 for the network, always with a token)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help=f"TCP port (default {DEFAULT_PORT}; 0: any free port)")
    p.add_argument("--token", help="secret the page and the API ask for (on a non-loopback "
                                   "--host one is made when none is given)")
    p.add_argument("--uploads", metavar="DIR",
                   help="folder for uploaded drawings (default $XDG_STATE_HOME/vplotter/uploads)")


class Machine:
    """What the web app does to the plotter, on the CLI's code."""

    def __init__(self, config_path: str):
        self.config_path = os.path.abspath(config_path)
        self.cfg = load_config(argparse.Namespace(config=self.config_path))

    # ------------------------------------------------------------ read
    def status(self) -> dict:
        from vplotter.commands.live import status_object

        return status_object(self.cfg)

    def holder(self) -> dict | None:
        from vplotter.machine import lock

        return lock.holder()

    def busy_line(self, holder: dict) -> str:
        from vplotter.machine import live

        return live.busy_line(holder)

    def estimate(self, path: str) -> float:
        """The plot time `vplotter estimate FILE` prints (InputError for a bad file)."""
        from vplotter import pipeline
        from vplotter.commands import draw
        from vplotter.commands.common import position
        from vplotter.commands.files import prepare_file

        p = argparse.ArgumentParser()
        draw.add_estimate(p)
        args = p.parse_args([path])
        args.config = self.config_path
        pos = position(self.cfg, args, True)
        prep = prepare_file(args, self.cfg, pos, say_notes=False)
        return pipeline.validate(self.cfg, prep.records(), pos.counts, pos.ref_mm, args.file,
                                 where=prep.where).time_s

    def preview(self, path: str, out: str, size: int = 900) -> tuple[int, str]:
        """`vplotter preview FILE -o OUT.png` (a niced subprocess): (exit code, stderr)."""
        code, _, err = self._run(["preview", path, "-o", out, "--size", str(size)], nice=10)
        return code, err

    # ------------------------------------------------------------ act (subprocesses)
    def draw(self, path: str, resume: bool) -> tuple[int, str, str]:
        return self._run(["draw", path, "--detach", *(["--resume"] if resume else [])])

    def stop(self) -> tuple[int, str, str]:
        return self._run(["stop"])

    def continue_(self) -> tuple[int, str, str]:
        return self._run(["continue"])

    def pen(self, state: str) -> tuple[int, str, str]:
        return self._run(["pen", state])

    def jog(self, dx: float, dy: float) -> tuple[int, str, str]:
        return self._run(["jog", "--dx", f"{dx:.4f}", "--dy", f"{dy:.4f}"])

    def _run(self, argv: list[str], nice: int = 0, timeout_s: float = 900.0):
        import subprocess

        cmd = [sys.executable, "-m", "vplotter", "--config", self.config_path, *argv]
        try:
            r = subprocess.run(cmd, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                               timeout=timeout_s, preexec_fn=(lambda: os.nice(nice)) if nice
                               else None)
        except subprocess.TimeoutExpired:
            return 1, "", f"vplotter {argv[0]}: no answer within {timeout_s:g} s"
        return r.returncode, r.stdout, r.stderr


def is_loopback(host: str) -> bool:
    import ipaddress

    if host in LOOPBACK:
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def cmd_serve(args, argv=None) -> int:
    import secrets
    import socket

    from vplotter.config import state_dir

    if not 0 <= args.port <= 65535:
        raise ConfigError(f"error: --port must be 0..65535 (got {args.port})")
    if args.token is not None and (len(args.token) < 8 or not args.token.isascii()
                                   or not args.token.isprintable() or " " in args.token):
        raise ConfigError("error: --token must be 8 or more printable ASCII characters, no spaces")
    machine = Machine(args.config)
    token = args.token
    if token is None and not is_loopback(args.host):
        token = secrets.token_urlsafe(18)
    uploads = os.path.abspath(args.uploads) if args.uploads else str(state_dir() / "uploads")
    try:
        import uvicorn

        from vplotter.web import app as web_app
    except ImportError as e:
        raise ConfigError(f"error: serve needs starlette, uvicorn and python-multipart "
                          f"(pip install starlette uvicorn python-multipart): {e}") from None
    family = socket.AF_INET6 if ":" in args.host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((args.host, args.port))
    except OSError as e:
        sock.close()
        raise ConfigError(f"error: cannot listen on {args.host}:{args.port}: {e.strerror}") from None
    sock.listen(64)
    port = sock.getsockname()[1]
    server = None
    app = web_app.create(machine, uploads, token, log=say,
                         should_exit=lambda: server is not None and server.should_exit)
    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="off",
                            timeout_graceful_shutdown=3, server_header=False)
    server = uvicorn.Server(config)
    shown = f"[{args.host}]" if ":" in args.host else args.host
    url = f"http://{shown}:{port}/" + (f"?token={token}" if token else "")
    say(f"vplotter serve: {url}")
    say(f"  uploads in {uploads}; Ctrl+C stops the server (never a running draw)")
    if not is_loopback(args.host):
        say("  anyone on the network who has this URL can drive the plotter: keep the token secret")
    import signal

    # uvicorn catches SIGINT and SIGTERM while it runs, shuts down (open event streams end
    # within 3 s; a draw in its own process goes on), then raises the signal again for the
    # handlers it found: these, which let the command end normally
    old = {s: signal.signal(s, lambda *_: None) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        server.run(sockets=[sock])
    finally:
        sock.close()
        for s, h in old.items():
            signal.signal(s, h)
    eprint("vplotter serve: stopped")
    return 0
