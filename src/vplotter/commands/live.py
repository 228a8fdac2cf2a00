"""status, stop, log and continue: what people use while a draw runs (over SSH, from a phone).

None of them takes the plotter lock: they read the stored position, the lock file's holder and
what the running draw publishes (vplotter.machine.live).
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

from vplotter.budget import clock_text
from vplotter.commands.common import load_config, say
from vplotter.errors import VplotterError

POLL_S = 0.05        # stop and log -f look this often (product code, not a test)
WATCH_S = 0.5        # status --watch redraws this often


def add_status(p) -> None:
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--watch", action="store_true",
                   help="a live progress line until the running draw ends, then the status")


def _snapshot(cfg):
    """(stored position or None, lock holder or None, running draw or None)."""
    from vplotter.machine import live, lock, state
    from vplotter.machine.position import check_machine

    holder = lock.holder()
    drawing = live.read(holder) if holder else None
    stored = state.load()
    if stored:
        check_machine(cfg, stored)      # a polar position is no pair of cords
    pos = state.recovered(stored).rebased(cfg.motors.steps_per_unit) if stored else None
    return pos, holder, drawing


def cmd_status(args, argv=None) -> int:
    cfg = load_config(args)
    if args.watch and not args.json:
        _watch()
    pos, holder, drawing = _snapshot(cfg)
    if args.json:
        _print_json(cfg, pos, holder, drawing)
    else:
        _print_text(cfg, pos, holder, drawing)
    return 0


def _busy(holder):
    if holder is None:
        return None
    return {"pid": holder["pid"], "command": holder.get("command", ""),
            "since": time.strftime("%H:%M", time.localtime(holder.get("since", time.time())))}


def _print_json(cfg, pos, holder, drawing) -> None:
    import json

    print(json.dumps(status_object(cfg, pos, holder, drawing, snapshot=False)))


def status_object(cfg, pos=None, holder=None, drawing=None, snapshot: bool = True) -> dict:
    """What `status --json` prints (and the web page's GET /api/status answers): read now
    when snapshot is true, else from the given position, lock holder and running draw."""
    from vplotter.machine import state
    from vplotter.machine.position import uncertainty_mm
    from vplotter.commands.machine import _pen_xy

    if snapshot:
        pos, holder, drawing = _snapshot(cfg)
    if pos is None:
        return {"calibrated": False, "busy": _busy(holder), "drawing": drawing}
    xy = _pen_xy(cfg, pos)
    running = holder is not None
    return {
        "calibrated": True, "x_mm": round(float(xy[0]), 4), "y_mm": round(float(xy[1]), 4),
        "left_mm": pos.left_mm, "right_mm": pos.right_mm,
        "left_steps": pos.left_steps, "right_steps": pos.right_steps, "pen": pos.pen,
        # a process that holds the lock is moving the machine: its stop is still to come
        "clean": None if running else pos.clean,
        "last_stop": "running" if running else ("clean" if pos.clean else "unclean"),
        "uncertainty_mm": round(uncertainty_mm(cfg, pos), 4),
        "resume": None if running else pos.extra.get("resume") or None,
        "state_file": str(state.state_path()),
        "pen_in": pos.extra.get("pen_in"),      # the pen put in last: {"pen", "index", "count"}
        "pen_change": None if running else pos.extra.get("pen_change"),   # stopped waiting
        "busy": _busy(holder), "drawing": drawing}


def _print_text(cfg, pos, holder, drawing) -> None:
    from vplotter.commands.machine import _describe
    from vplotter.machine import state
    from vplotter.machine.position import uncertainty_mm

    if holder is not None:
        busy = _busy(holder)
        print(f"{'drawing now' if drawing else 'busy'}: pid {busy['pid']} ({busy['command']}) "
              f"since {busy['since']}")
        if drawing and drawing.get("waiting"):
            print(f"  WAITING: {drawing['waiting']['prompt']}, then `vplotter continue` (or "
                  f"Enter on its terminal)")
        if drawing:
            print(f"  {drawing['file']} line {drawing['line']}: {drawing['percent']:.1f} % of the "
                  f"plot time done, {clock_text(drawing['elapsed_s'])} elapsed, "
                  f"{clock_text(drawing['remaining_s'])} left, finish at {drawing['finish']}")
            if drawing["shifts"]:
                print(f"  the timeline moved {drawing['shifts']} times "
                      f"({drawing['lost_s']:.2f} s lost to lateness)")
    if pos is None:
        print("position unknown: run `vplotter calibrate --at X Y`")
        return
    if holder is not None:
        off = uncertainty_mm(cfg, pos)
        print(f"{_describe(cfg, pos)}  (moving: where the journal had it, within {off:.2f} mm)")
    else:
        print(_describe(cfg, pos))
        if pos.clean:
            print("last stop: clean")
        else:
            off = uncertainty_mm(cfg, pos)
            print(f"last stop: UNCLEAN (crash or power cut): the position may be off by up to "
                  f"{off:.2f} mm; check it and run `vplotter calibrate`, or draw with "
                  f"--trust-position")
    pen_in, change = pos.extra.get("pen_in"), pos.extra.get("pen_change")
    if change and holder is None:
        print(f"stopped at a pen change: {_pen_text(change)}; --resume asks for it again")
    elif pen_in:
        print(f"pen in: {_pen_text(pen_in)}")
    resume = pos.extra.get("resume")
    if resume and holder is None:
        where = (f"at X{resume['xy'][0]:.3f} Y{resume['xy'][1]:.3f}" if resume.get("xy")
                 else "from its start")
        print(f"resume: {resume['file']} line {resume['line']} {where} "
              f"(vplotter draw FILE --resume)")
    print(f"state file: {state.state_path()}")


def _pen_text(p: dict) -> str:
    from vplotter.machine.live import pen_prompt
    from types import SimpleNamespace

    return pen_prompt(SimpleNamespace(**{"message": "", "index": 0, "count": 0, **p}))


def _watch() -> None:
    """One live line (progress bar, line, times) until no draw runs any more."""
    from vplotter.machine import live, lock

    shown = False
    while True:
        holder = lock.holder()
        d = live.read(holder) if holder else None
        if holder is None:
            break
        if d is not None and d.get("waiting"):
            text = f"\rwaiting: {d['waiting']['prompt']} (vplotter continue goes on) "
        elif d is not None:
            text = (f"\r[{live.bar(d['percent'])}] {d['percent']:5.1f} %  line {d['line']}  "
                    f"{clock_text(d['elapsed_s'])} elapsed  "
                    f"{clock_text(d['remaining_s'])} left  finish {d['finish']} ")
        else:
            text = f"\rbusy: pid {holder['pid']} ({holder.get('command', '')}) "
        say(text, sys.stderr, end="")
        shown = True
        time.sleep(WATCH_S)
    if shown:
        say("", sys.stderr)
    else:
        say("no draw is running", sys.stderr)


def add_stop(p) -> None:
    p.add_argument("--timeout", type=float, default=60.0,
                   help="seconds to wait for the pen to be up and the position stored (default 60)")


@dataclass(frozen=True)
class Stopped:
    """What `vplotter stop` did: pid is the draw it stopped (None: nothing was running, `why`
    says so); where: the stored position it left, described (None: no position is stored);
    resume: the file to go on with `draw FILE --resume`."""

    pid: int | None = None
    why: str = ""
    command: str = ""
    where: str | None = None
    clean: bool = True
    resume: str | None = None

    def lines(self) -> list[str]:
        if self.pid is None:
            return [f"nothing to stop: {self.why}"]
        if self.where is None:
            return [f"stopped pid {self.pid}"]
        return [f"stopped pid {self.pid} ({self.command}): {self.where}"
                f"{'' if self.clean else ' (not a clean stop: see vplotter status)'}"] + \
            ([f"resume with: vplotter draw {self.resume} --resume"] if self.resume else [])

    @property
    def message(self) -> str:
        return self.lines()[0]


def cmd_stop(args, argv=None) -> int:
    for line in stop_draw(load_config(args), args.timeout).lines():
        say(line)
    return 0


def stop_draw(cfg, timeout_s: float) -> Stopped:
    """Pause the running draw: SIGINT to the lock holder, wait until it has lifted the pen,
    released the coils and stored the position (it lets go of the lock then), say where.
    VplotterError when it cannot be signalled or does not stop within timeout_s."""
    import os
    import signal

    from vplotter.machine import lock, state

    holder = lock.holder()
    if holder is None:
        return Stopped(why="no vplotter is driving the plotter")
    pid = holder["pid"]
    try:
        os.kill(pid, signal.SIGINT)
    except ProcessLookupError:
        return Stopped(why="it has just ended")
    except PermissionError:
        raise VplotterError(f"cannot stop pid {pid} ({holder.get('command', '')}): it belongs to "
                            f"another user (sudo vplotter stop)") from None
    deadline = time.monotonic() + timeout_s
    while lock.alive(pid) and (lock.holder() or {}).get("pid") == pid:
        if time.monotonic() > deadline:
            raise VplotterError(f"pid {pid} has not stopped within {timeout_s:g} s")
        time.sleep(POLL_S)
    pos = state.load()
    if pos is None:
        return Stopped(pid)
    from vplotter.commands.machine import _describe

    resume = pos.extra.get("resume")
    return Stopped(pid, command=holder.get("command", ""), where=_describe(cfg, pos),
                   clean=pos.clean, resume=resume["file"] if resume else None)


def add_continue(p) -> None:
    pass


@dataclass(frozen=True)
class Continued:
    """`vplotter continue`: the draw (pid) that waited goes on; prompt: what it waited for."""

    pid: int
    prompt: str

    @property
    def message(self) -> str:
        return f"continuing pid {self.pid}: {self.prompt}"


def cmd_continue(args, argv=None) -> int:
    say(continue_draw().message)
    return 0


def continue_draw() -> Continued:
    """Let the draw that waits at a pen change (or another pause) go on: it polls for the
    request (machine/live.py), the same as Enter on its terminal. MachineError when nothing
    waits."""
    from vplotter.errors import MachineError
    from vplotter.machine import live, lock

    holder = lock.holder()
    drawing = live.read(holder) if holder else None
    waiting = (drawing or {}).get("waiting")
    if not waiting:
        what = "no vplotter is driving the plotter" if holder is None else \
            f"pid {holder['pid']} is not waiting at a pause"
        raise MachineError(f"error: nothing to continue: {what}")
    live.request_continue(drawing["pid"])
    return Continued(drawing["pid"], waiting["prompt"])


def add_log(p) -> None:
    p.add_argument("-f", "--follow", action="store_true",
                   help="keep printing what the background draw writes until it ends")


def cmd_log(args, argv=None) -> int:
    """Print the log of the last background draw (`draw --detach`)."""
    from vplotter.machine import live, lock

    path = live.log_path()
    try:
        f = open(path, encoding="utf-8", errors="replace")
    except FileNotFoundError:
        say(f"no log yet: `vplotter draw FILE --detach` writes one ({path})")
        return 0
    with f:
        while True:
            text = f.read()
            if text:
                say(text, end="")
            if not args.follow or lock.holder() is None:
                text = f.read()          # what came between the last read and the end
                if text:
                    say(text, end="")
                return 0
            time.sleep(POLL_S)
