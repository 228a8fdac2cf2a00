"""serve: the page on the Pi (vplotter.web), on the CLI's own machinery.

The web app asks a Machine (below) for everything it does to the plotter, and gets values
back: the status object of `status --json`, the estimate of `estimate`, and the results of the
functions behind `stop` and `continue` (run here: they only signal the running draw), and of
`draw FILE --detach`, `pen` and `jog`, which run as the very commands in subprocesses with this
config (an argument list, never a shell) and hand their result, or their error line, back as
JSON on a pipe of their own (commands/common.answering). A failure is raised as a VplotterError
(exit_code as the command's; error_line(e) is the line the command line prints). A draw so
started lives in its own process and session: the server can stop or crash without touching
it; a pen or jog move in its own process is stopped by `vplotter stop` like any other, and a
second plotter process finds it holding the lock. `preview` runs niced (the PNG is its result).
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass

from vplotter.commands.common import eprint, load_config, say
from vplotter.errors import ConfigError, VplotterError

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
        """`status --json`'s object; a draw waiting at a pen change also says the pen's colour
        (drawing.waiting.colour: '#rrggbb' or null)."""
        from vplotter.commands.live import status_object
        from vplotter.commands.setup import pen_colour

        st = status_object(self.cfg)
        waiting = (st.get("drawing") or {}).get("waiting")
        if waiting:
            waiting["colour"] = pen_colour(self.cfg, waiting.get("pen"))
        return st

    def holder(self) -> dict | None:
        from vplotter.machine import lock

        return lock.holder()

    def busy_line(self, holder: dict) -> str:
        from vplotter.machine import live

        return live.busy_line(holder)

    def setup(self) -> dict:
        """What the page shows of the config: the backend, the page and the pen's widths, and
        the values the file options with a list of them take."""
        from vplotter.commands import page_options

        cfg = self.cfg
        pg, pen = cfg.page, cfg.pen
        return {"config": self.config_path, "machine": cfg.machine.kind,
                "backend": cfg.gpio.backend, "realtime": bool(cfg.gpio.realtime),
                "page": {"x_min_mm": pg.x_min_mm, "x_max_mm": pg.x_max_mm,
                         "y_min_mm": pg.y_min_mm, "y_max_mm": pg.y_max_mm},
                "pen": {"kind": pen.kind, "up_us": pen.up_us, "down_us": pen.down_us},
                "choices": page_options.choices()}

    def kind(self, path: str) -> tuple[str, list[str]]:
        """(the reader's kind of the file, the page's options it takes)."""
        from vplotter import readers
        from vplotter.commands import page_options

        return readers.reader_for(path).kind, page_options.takes(path)

    def options(self, path: str, wanted, taken_only: bool = False) -> dict:
        """The page's options `wanted` for the file at `path`, checked (ConfigError for a name
        or value that cannot be one); taken_only: without those its kind does not take."""
        from vplotter.commands import page_options

        return page_options.clean(wanted, page_options.takes(path) if taken_only
                                  else page_options.NAMES)

    def estimate(self, path: str, options: dict | None = None) -> "Estimated":
        """What `vplotter estimate FILE` with these (page_options) options says: the plot
        time, and a photo's notes and advice (InputError, ConfigError for a bad file or
        options, with the command line's error)."""
        from vplotter import pipeline
        from vplotter.commands import page_options
        from vplotter.commands.common import position
        from vplotter.commands.files import prepare_file

        args = page_options.check(path, _words(options))
        args.config = self.config_path
        pos = position(self.cfg, args, True)
        prep = prepare_file(args, self.cfg, pos, say_notes=False)
        time_s = pipeline.validate(self.cfg, prep.records(), pos.counts, pos.ref_mm, args.file,
                                   where=prep.where).time_s
        return Estimated(time_s, [str(n) for n in prep.notes],
                         [str(a) for a in getattr(prep, "advice", None) or []])

    def preview(self, path: str, out: str, size: int = 900,
                options: dict | None = None) -> tuple[int, str]:
        """`vplotter preview FILE -o OUT.png` with these options (a niced subprocess): (exit
        code, stderr)."""
        code, _, err = self._run(["preview", "-o", out, "--size", str(size), *_words(options),
                                  path], nice=10)
        return code, err

    # ------------------------------------------------------------ act
    def draw(self, path: str, resume: bool, options: dict | None = None):
        """`draw --detach [--resume] OPTIONS PATH` (PATH absolute: never taken for an option;
        the background draw is given the same words): a commands.draw.DrawStarted once
        validated."""
        from vplotter.commands.draw import DrawStarted

        return DrawStarted(**self._result(["draw", "--detach", *(["--resume"] if resume else []),
                                           *_words(options), path]))

    def stop(self):
        """`vplotter stop`: a commands.live.Stopped once the draw has paused."""
        from vplotter.commands.live import stop_draw

        return self._here(lambda: stop_draw(self._config(), 60.0))

    def continue_(self):
        """`vplotter continue`: a commands.live.Continued (MachineError when nothing waits)."""
        from vplotter.commands.live import continue_draw

        return self._here(continue_draw)

    def pen(self, state: str, up_us: int | None = None, down_us: int | None = None):
        """`pen up|down|cycle [--up-us N] [--down-us M]`: a PenMoved."""
        from vplotter.commands.machine import PenMoved

        widths = [*(["--up-us", str(up_us)] if up_us is not None else []),
                  *(["--down-us", str(down_us)] if down_us is not None else [])]
        return PenMoved(**self._result(["pen", state, *widths]))

    def place(self, x: float, y: float):
        """`calibrate --at X Y`: a commands.setup.Placed."""
        from vplotter.commands.setup import Placed

        return Placed(**self._result(["calibrate", "--at", repr(float(x)), repr(float(y))]))

    def home(self):
        """`home`: a commands.setup.Placed."""
        from vplotter.commands.setup import Placed

        return Placed(**self._result(["home"]))

    def save_pen(self, up_us: int, down_us: int):
        """[pen] up_us/down_us written into the config file: a commands.setup.PenSaved."""
        from vplotter.commands.setup import save_pen

        saved = self._here(lambda: save_pen(self.config_path, up_us, down_us))
        self.cfg = self._config()
        return saved

    def jog(self, dx: float, dy: float):
        from vplotter.commands.machine import Jogged

        return Jogged(**self._result(["jog", "--dx", f"{dx:.4f}", "--dy", f"{dy:.4f}"]))

    # ------------------------------------------------------------ the queue
    def queue(self) -> dict:
        """`queue --json`: {"jobs": [...], "total_s"}."""
        from vplotter.commands.queue import listing

        return self._here(listing)

    def queue_add(self, path: str, copies: int, options: dict | None = None):
        """`queue add --copies N OPTIONS PATH` (validates the file: a subprocess): Added."""
        from vplotter.commands import page_options
        from vplotter.commands.queue import Added

        page_options.check(path, _words(options))      # a bad value: its one line, here
        return Added(**self._result(["queue", "add", "--copies", str(int(copies)),
                                     *_words(options), path]))

    def queue_move(self, job_id: int, position: int) -> dict:
        from vplotter.machine import queue

        self._here(lambda: queue.move(job_id, position))
        return self.queue()

    def queue_remove(self, job_id: int) -> dict:
        from vplotter.machine import queue

        self._here(lambda: queue.remove(job_id))
        return self.queue()

    def queue_run(self):
        """`queue run --detach`: a commands.queue.QueueStarted."""
        from vplotter.commands.queue import QueueStarted

        return QueueStarted(**self._result(["queue", "run", "--detach"]))

    def now_paths(self) -> dict | None:
        """The running draw's planned path (commands/drawn.py), made once per drawing; None
        when nothing is drawn."""
        from vplotter.commands import drawn
        from vplotter.machine import live

        running = live.read()
        if not running:
            return None
        key = (running["pid"], running["command"], running["file"])
        cached = getattr(self, "_paths", None)
        if cached is not None and cached[0] == key:
            return cached[1]
        got = drawn.paths(self.cfg, running)
        if got is not None:
            self._paths = (key, got)
        return got

    def history(self) -> list[dict]:
        """`history --json`: the plots, oldest first."""
        from vplotter.machine import history

        return self._here(history.read)

    def error_line(self, e: VplotterError) -> str:
        """The line the command line prints for e."""
        from vplotter.commands.common import error_line

        return str(e) if isinstance(e, CommandFailed) else error_line(e)

    def _config(self):
        return load_config(argparse.Namespace(config=self.config_path))

    def _here(self, run):
        """run() in this process; an unexpected error ends as the command line's line for it."""
        from vplotter.commands.common import error_line, exit_code

        try:
            return run()
        except VplotterError:
            raise
        except Exception as e:  # noqa: BLE001 - answered as the command would have
            raise CommandFailed(error_line(e), exit_code(e)) from e

    def _result(self, argv: list[str], timeout_s: float = 900.0) -> dict:
        """Run the command in a subprocess; the fields of the result it hands back on its pipe
        (CommandFailed with its error line and exit status when it fails)."""
        import json
        import subprocess

        from vplotter.commands.common import RESULT_FD

        cmd = [sys.executable, "-m", "vplotter", "--config", self.config_path, *argv]
        r, w = os.pipe()
        with os.fdopen(r, "rb") as pipe:
            try:
                proc = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                      stderr=subprocess.DEVNULL, timeout=timeout_s,
                                      env=dict(os.environ, **{RESULT_FD: str(w)}), pass_fds=(w,))
            except subprocess.TimeoutExpired:
                raise CommandFailed(f"vplotter {argv[0]}: no answer within {timeout_s:g} s",
                                    1) from None
            finally:
                os.close(w)
            data = pipe.read()
        got = json.loads(data) if data else {}
        if "error" in got:
            raise CommandFailed(got["error"], int(got["exit_code"]), str(got.get("kind", "")))
        if not got.get("result"):
            raise CommandFailed(f"vplotter {argv[0]}: ended (exit status {proc.returncode}) "
                                f"without an answer", proc.returncode or 1)
        return got["result"]

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


def _words(options: dict | None) -> list[str]:
    """The command-line words of the page's options (commands/page_options)."""
    from vplotter.commands import page_options

    return page_options.argv(page_options.clean(options or {}))


class CommandFailed(VplotterError):
    """A command run in a subprocess failed: the message is the line it printed for it; kind:
    the class name of its error (BackendError: the GPIO backend could not start)."""

    def __init__(self, line: str, exit_code: int, kind: str = ""):
        super().__init__(line)
        self.exit_code = exit_code
        self.kind = kind


@dataclass(frozen=True)
class Estimated:
    """`vplotter estimate`: the plot time, and what a photo's budget chose (notes) and what
    it advises (advice), each a line for a person."""

    time_s: float
    notes: list
    advice: list


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

    from vplotter.commands import warnings

    warnings.end()          # a server runs until stopped: its warnings go to its log as they come

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
        raise ConfigError(
            f"error: cannot listen on {args.host}:{args.port}: {e.strerror}") from None
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
