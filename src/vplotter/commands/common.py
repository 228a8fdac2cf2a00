"""What the commands share: config, stored position, the session, printing that never fails,
and a command's result handed as a value to a caller that runs it in a subprocess."""

from __future__ import annotations

import argparse
import os
import sys
from contextlib import contextmanager

from vplotter.errors import BusyError, MachineError, VplotterError, unreadable
from vplotter.budget import clock_text


def eprint(msg: str) -> None:
    say(msg, sys.stderr)


def say(msg: str, stream=None, end: str = "\n") -> None:
    """Print, but never fail: after SIGHUP the SSH terminal is gone and writing to it raises,
    while the machine still has to be stopped and its position saved."""
    try:
        stream = stream or sys.stdout
        stream.write(msg + end)
        stream.flush()
    except (OSError, ValueError):
        pass


def load_config(args):
    from vplotter import config

    return config.load(args.config)


def position(cfg, args, dry_run: bool):
    """The position to start from. Anything that will move or store the machine takes the
    plotter lock first (a second mover fails here, exit 3, before reading a position that the
    running one is changing); the session shares it, and it is released when the command ends.
    A dry run takes no lock; without a stored position it assumes X0 Y0, after an unclean stop
    it goes on but says how uncertain the stored position is."""
    from vplotter import kinematics
    from vplotter.commands import warnings
    from vplotter.machine import lock, state
    from vplotter.machine.position import load_position, uncertainty_mm

    if not dry_run:
        lock.acquire(lock_command(args))
    if dry_run and state.load() is None:
        kin = kinematics.from_config(cfg)
        cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
        # said with the warnings: after the file is read, never before an error (cli.main)
        warnings.warn("note: no calibrated position stored; the dry run assumes the pen at X0 Y0")
        return state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_unit)
    pos = load_position(cfg, getattr(args, "trust_position", False), dry_run)
    if dry_run and not pos.clean:
        holder = lock.holder()
        if holder is not None:
            warnings.warn(f"note: pid {holder['pid']} ({holder.get('command', 'vplotter')}) "
                          f"is moving the plotter; the dry run starts from the position stored "
                          f"last")
        else:
            warnings.warn(f"warning: the last stop was not clean (crash or power cut): the "
                          f"stored position is uncertain by up to "
                          f"{uncertainty_mm(cfg, pos):.2f} mm; the dry run starts from it "
                          f"(`vplotter calibrate --at X Y` makes it exact)")
    return pos


def position_if_stored(cfg, args, check_only: bool = False):
    """For what can move without knowing where the pen is (`jog --left/--right`): the stored
    position as position() gives it, or None if none is stored (it stays unknown: nothing is
    assumed, and nothing is stored afterwards). Takes the lock as position() does.
    check_only (`pen`): only the lock, and a corrupt stored file is an error; returns None."""
    from vplotter.machine import lock, state

    if not args.dry_run:
        lock.acquire(lock_command(args))
    if state.load() is None or check_only:
        return None
    return position(cfg, args, args.dry_run)


def lock_command(args) -> str:
    """What the lock file says the holder does: `vplotter draw car.ngc`."""
    words = ["vplotter", getattr(args, "command", None) or ""]
    for name in ("file", "action", "what"):
        v = getattr(args, name, None)
        if isinstance(v, str):
            words.append(v)
    return " ".join(w for w in words if w)


def add_machine_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--dry-run", action="store_true",
                   help="simulate with the fake backend: nothing moves, no state is saved")
    p.add_argument("--backend", choices=("lgpio", "gpiozero", "fake", "serial"),
                   help="GPIO backend (default: [gpio] backend in config.toml); serial: stream "
                        "the drawing to a grbl controller on [serial] port (draw only)")
    p.add_argument("--trace", metavar="OUT.csv", help="write every GPIO change to a CSV trace")
    p.add_argument("--trust-position", action="store_true",
                   help="go on from the stored position after an unclean stop")
    p.add_argument("--realtime", action="store_true",
                   help="with the fake backend: play in real time to measure timing lateness")


def session(args, cfg, command: str, pos, job=None, pen_only: bool = False):
    """The Session that moves the machine for a command (job: a draw's machine/job.DrawJob;
    pos None: no position is stored; pen_only: only the pen moves, machine/ledger.py)."""
    from vplotter.machine.job import Session

    dry = getattr(args, "dry_run", False)
    if args.backend == "serial":
        raise MachineError("error: --backend serial streams drawings: use it with `vplotter draw`")
    name = "fake" if dry else (args.backend or cfg.gpio.backend)
    # --backend fake is a simulated machine (lock, stored position); --dry-run touches nothing
    return Session(cfg, command, name, dry, args.trace, args.realtime, pos, job, pen_only)


def command_line(argv) -> str:
    return "vplotter " + " ".join(argv if argv is not None else sys.argv[1:])


def file_hash(path: str) -> str:
    import hashlib

    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError as e:
        raise unreadable(path, e) from None
    return h.hexdigest()


def stream_rows(cfg, records, pos, name, start_at=None):
    from vplotter import pipeline

    return pipeline.stream(cfg, records, pos.counts, pos.ref_mm, name, start_at=start_at)


def moves_to(cfg, pos, target):
    """A G-code record moving the pen from where it is to the G-code point `target`."""
    from vplotter.commands import jog

    return jog.xy_records(cfg, pos, pos.counts, target)


def check_on_page(cfg, x: float, y: float, what: str) -> None:
    pg = cfg.page
    if not (pg.x_min_mm <= x <= pg.x_max_mm and pg.y_min_mm <= y <= pg.y_max_mm):
        raise MachineError(f"error: {what} X{x:.3f} Y{y:.3f} is outside the page "
                           f"(X {pg.x_min_mm:g}..{pg.x_max_mm:g}, "
                           f"Y {pg.y_min_mm:g}..{pg.y_max_mm:g})")


def run_records(args, cfg, command: str, pos, records) -> int:
    """Validate, then play records on the machine (used by jog, goto and home)."""
    from vplotter import pipeline

    summary = pipeline.validate(cfg, records, pos.counts, pos.ref_mm, command)
    with session(args, cfg, command, pos) as s:
        s.play(pipeline.replay(cfg, summary.plan, pos.counts, pos.ref_mm)
               if summary.plan is not None else stream_rows(cfg, records, pos, command))
    return 0


class Progress:
    """A one-line progress bar on stderr (only on a terminal): done, line, time left, and the
    drawing's travel, pen lifts and plot time."""

    def __init__(self, summary):
        self.total_us = max(summary.time_s * 1e6, 1.0)
        self.tail = (f"travel {summary.travel_mm / 1000:.2f} m, {summary.pen_downs} pen lifts, "
                     f"plot time {clock_text(summary.time_s)}")
        self.last = -1

    def __call__(self, t_us: int, line: int) -> None:
        pct = min(100, int(100 * t_us / self.total_us))
        if pct == self.last:
            return
        self.last = pct
        left = max(0.0, (self.total_us - t_us) / 1e6)
        bar = "#" * (pct // 4) + "-" * (25 - pct // 4)
        say(f"\r[{bar}] {pct:3d}%  line {line}  {clock_text(left)} left; {self.tail} ",
             sys.stderr, end="")

    def done(self) -> None:
        say("", sys.stderr)


# ---------------------------------------------------------------- results as values
RESULT_FD = "VPLOTTER_RESULT_FD"


def error_line(e: BaseException) -> str:
    """The one line the command line prints for an error that ends a command (cli.main)."""
    if isinstance(e, VplotterError):
        msg = str(e)
        if isinstance(e, BusyError) and e.holder:
            from vplotter.machine import live

            msg = live.busy_line(e.holder)
        if isinstance(e, BusyError) or "error:" in msg:
            return msg if not msg.startswith("error:") else f"vplotter: {msg}"
        return f"vplotter: {msg}" if e.exit_code >= 128 else f"vplotter: error: {msg}"
    if isinstance(e, KeyboardInterrupt):
        return "vplotter: interrupted"
    return f"vplotter: internal error: {type(e).__name__}: {e} (rerun with --debug for details)"


def exit_code(e: BaseException) -> int:
    """The exit status that goes with error_line(e)."""
    if isinstance(e, VplotterError):
        return e.exit_code
    return 130 if isinstance(e, KeyboardInterrupt) else 1


@contextmanager
def answering():
    """A command that a program runs as a subprocess (the page's commands/serve.Machine) hands
    it its result as a value: with VPLOTTER_RESULT_FD set, one JSON object goes to that pipe,
    {"result": {the result dataclass's fields}} from answer(result), or {"error": the line the
    command line prints, "exit_code": N, "kind": the error's class name} when the command
    fails. Nothing else changes: the command prints what it always prints. The variable is
    taken out of the environment, so that no process the command starts writes to the pipe."""
    import dataclasses
    import json

    fd_text = os.environ.pop(RESULT_FD, None)
    fd = int(fd_text) if fd_text and fd_text.isdigit() else None
    sent = [fd is None]

    def send(obj: dict) -> None:
        if sent[0]:
            return
        sent[0] = True
        try:
            os.write(fd, json.dumps(obj).encode())
            os.close(fd)
        except OSError:
            pass

    try:
        yield lambda result: send({"result": dataclasses.asdict(result)})
    except BaseException as e:
        send({"error": error_line(e), "exit_code": exit_code(e), "kind": type(e).__name__})
        raise
    send({"result": None})


def background(argv, held, command: str | None = None) -> tuple[int, str]:
    """The command line again (less --detach, plus --detached) in a new process in its own
    session (setsid: no terminal, no SIGHUP from it), its output to the log file; the lock
    `held` passes to it (it inherits the open lock file). (its pid, the log's path)"""
    import subprocess

    from vplotter.machine import live

    rest = [a for a in (argv if argv is not None else sys.argv[1:]) if a != "--detach"]
    log = live.log_path()
    log.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, VPLOTTER_LOCK_FD=str(held.fd))
    try:
        with open(log, "w", encoding="utf-8") as out:
            child = subprocess.Popen([sys.executable, "-m", "vplotter", *rest, "--detached"],
                                     stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                                     env=env, pass_fds=(held.fd,), start_new_session=True)
        held.write_info(pid=child.pid, command=command)
    finally:
        held.hand_over()
    return child.pid, str(log)
