"""queue (add, move, remove, clear, run) and history.

A job is a copy of a drawing file (machine/queue.py keeps it in the state directory) with the
file options of `draw` it is drawn with and how many copies. `queue run` draws the jobs one
after another as `draw` draws a file, in this process (or with --detach in a background one);
between two jobs, and between two copies, it waits as at a pen change for fresh paper (Enter,
or `vplotter continue`). A stopped copy (`vplotter stop`, Ctrl+C) stays first in the queue and
the next `queue run` resumes it where it stopped (`draw --resume`).
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass

from vplotter.budget import clock_text
from vplotter.commands.common import (add_machine_options, answering, eprint, load_config,
                                      say)
from vplotter.errors import ConfigError, Interrupted, MachineError, VplotterError


# ---------------------------------------------------------------- the command line
def add_queue(p: argparse.ArgumentParser) -> None:
    from vplotter.file_options import add_file_options

    p.add_argument("--json", action="store_true", help="the jobs as JSON")
    sub = p.add_subparsers(dest="action", metavar="ACTION")
    a = sub.add_parser("add", help="put a drawing last in the queue (a copy of the file is kept)",
                       description="validate FILE with these options, as `draw` would draw it, "
                                   "and put it last in the queue (a copy of the file is kept)")
    a.add_argument("file", help="the drawing: G-code, SVG, DXF, text (.txt) or a photo")
    a.add_argument("--copies", type=int, default=1, metavar="N",
                   help="draw it N times, with a stop for fresh paper between (default 1)")
    a.add_argument("--strict", action="store_true",
                   help="treat warnings about inconsistent arcs as errors")
    add_file_options(a)
    m = sub.add_parser("move", help="put job ID at position POS (1: first)")
    m.add_argument("id", type=int, help="the job's number (`vplotter queue` lists them)")
    m.add_argument("pos", type=int, help="its new place in the queue, 1 first")
    r = sub.add_parser("remove", help="take job ID out of the queue")
    r.add_argument("id", type=int, help="the job's number (`vplotter queue` lists them)")
    sub.add_parser("clear", help="empty the queue")
    run = sub.add_parser("run", help="draw the jobs one after another, waiting for fresh paper "
                                     "between them (Enter or `vplotter continue`)")
    add_machine_options(run)
    run.add_argument("--detach", action="store_true",
                     help="after checking the queue, draw it in the background (follow with "
                          "`vplotter status --watch` or `vplotter log -f`)")
    run.add_argument("--detached", action="store_true", help=argparse.SUPPRESS)


def add_history(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="the plots as JSON, one list")


@dataclass(frozen=True)
class Added:
    """`queue add`: the job, and the queue's plot time with it."""

    id: int
    name: str
    copies: int
    estimate_s: float
    total_s: float
    message: str


@dataclass(frozen=True)
class QueueStarted:
    """`queue run --detach`: the background process and its log."""

    pid: int
    log: str
    message: str


def cmd_queue(args, argv=None) -> int:
    from vplotter.machine import queue

    action = args.action
    if action is None:
        return _list(args.json)
    if action == "add":
        with answering() as answer:
            answer(add_job(args))
        return 0
    if action == "move":
        queue.move(args.id, args.pos)
        return _list(False)
    if action == "remove":
        job = queue.remove(args.id)
        say(f"removed job {job['id']}: {job['name']}")
        return 0
    if action == "clear":
        n = queue.clear()
        say(f"the queue is empty ({n} job{'s' if n != 1 else ''} removed)")
        return 0
    with answering() as answer:
        started = run_queue(args, argv)
        if started is not None:
            answer(started)
    return 0


# ---------------------------------------------------------------- add and list
def add_job(args) -> Added:
    """Validate the file as `draw` would draw it (one error line, exit 2, when it does not),
    then copy it into the queue."""
    from vplotter import pipeline
    from vplotter.commands import warnings
    from vplotter.commands.files import prepare_file
    from vplotter.machine import queue

    if not 1 <= args.copies <= queue.MAX_COPIES:
        raise ConfigError(f"error: --copies must be 1 to {queue.MAX_COPIES} (got {args.copies})")
    cfg = load_config(args)
    pos = _start(cfg, args)
    prep = prepare_file(args, cfg, pos)
    summary = pipeline.validate(cfg, prep.records(), pos.counts, pos.ref_mm, args.file,
                                where=prep.where)
    warnings.flush()
    job = queue.add(args.file, option_words(args), args.copies, summary.time_s)
    total = sum(queue.left_s(j) for j in queue.jobs())
    copies = f", {job['copies']} copies" if job["copies"] > 1 else ""
    msg = (f"job {job['id']}: {job['name']}{copies}, plot time {clock_text(summary.time_s)}"
           f"{' each' if copies else ''}; the queue: {clock_text(total)}")
    say(msg)
    return Added(job["id"], job["name"], job["copies"], job["estimate_s"], round(total, 3), msg)


def _start(cfg, args):
    """Where the plot times are counted from: the stored position, else X0 Y0 (said nothing:
    the job is timed again when it is drawn)."""
    from vplotter import kinematics
    from vplotter.commands.common import position
    from vplotter.machine import state

    if state.load() is None:
        kin = kinematics.from_config(cfg)
        cords = kin.inverse(kin.to_machine([[0.0, 0.0]]))[0]
        return state.Position.at_cords(cords[0], cords[1], cfg.motors.steps_per_unit)
    return position(cfg, args, True)


def option_words(args) -> list[str]:
    """The command-line words of the file options args has (those not at their default), as
    `draw` takes them."""
    from vplotter.file_options import add_file_options

    p = argparse.ArgumentParser(add_help=False)
    add_file_options(p)
    p.add_argument("--strict", action="store_true")
    words: list[str] = []
    for a in p._actions:
        value = getattr(args, a.dest, None)
        if not a.option_strings or value is None or value == a.default or a.dest == "verbose":
            continue
        flag = a.option_strings[-1]
        if a.nargs == 0:
            words.append(flag)
        elif isinstance(value, list) and a.nargs is None:      # repeated (--layer)
            for v in value:
                words.append(f"{flag}={v}")
        elif isinstance(value, (list, tuple)):                   # --offset X Y
            words += [flag, *(repr(v) for v in value)]
        elif a.dest == "refill_every":
            words.append(f"{flag}={value!r}mm")
        else:
            words.append(f"{flag}={value!r}" if isinstance(value, float) else f"{flag}={value}")
    return words


def listing() -> dict:
    """The jobs as `queue --json` prints them, and the total plot time left."""
    from vplotter.machine import queue

    jobs = queue.jobs()
    out = [{**{k: j[k] for k in ("id", "name", "options", "copies", "done", "estimate_s",
                                 "stopped", "added")},
            "left_s": round(queue.left_s(j), 3)} for j in jobs]
    return {"jobs": out, "total_s": round(sum(j["left_s"] for j in out), 3)}


def _list(as_json: bool) -> int:
    import json

    data = listing()
    if as_json:
        print(json.dumps(data))
        return 0
    if not data["jobs"]:
        say("the queue is empty: `vplotter queue add FILE` puts a drawing in it")
        return 0
    for k, j in enumerate(data["jobs"], 1):
        left = j["copies"] - j["done"]
        copies = (f", copy {j['done'] + 1} of {j['copies']}" if j["copies"] > 1 else "")
        more = f" ({left} copies left)" if left > 1 else ""
        stopped = ", stopped part-way: `queue run` resumes it" if j["stopped"] else ""
        opts = f" {' '.join(j['options'])}" if j["options"] else ""
        say(f"{k}. job {j['id']}: {j['name']}{opts}{copies}{more}, plot time "
            f"{clock_text(j['left_s'])}{stopped}")
    n = len(data["jobs"])
    say(f"total: {clock_text(data['total_s'])} for {n} job{'s' if n != 1 else ''}")
    return 0


# ---------------------------------------------------------------- history
def cmd_history(args, argv=None) -> int:
    import json

    from vplotter.machine import history

    plots = history.read()
    if args.json:
        print(json.dumps(plots))
        return 0
    if not plots:
        say("no plots yet: every `vplotter draw` (and each queue job) is kept here")
        return 0
    for p in plots:
        say(history_line(p))
    return 0


def history_line(p: dict) -> str:
    """One plot for a person: when, what, how it ended, the times, the metres, the pens."""
    import time

    start = time.strftime("%Y-%m-%d %H:%M", time.localtime(p["start"]))
    end = f"-{time.strftime('%H:%M', time.localtime(p['end']))}" if p["end"] else ""
    copy = f" ({p['copy']})" if p.get("copy") else ""
    took = f", took {clock_text(p['actual_s'])}" if p["actual_s"] is not None else ""
    pens = f", pens {', '.join(p['pens'])}" if p["pens"] else ""
    result = p["result"] + (f": {p['error']}" if p.get("error") else "")
    return (f"{start}{end}  {p['file']}{copy}: {result}; plot time "
            f"{clock_text(p['estimate_s'])} planned{took}, {p['drawn_m']:.2f} m drawn{pens}")


# ---------------------------------------------------------------- run
def run_queue(args, argv) -> QueueStarted | None:
    from vplotter.machine import lock, queue

    cfg = load_config(args)
    if not queue.jobs():
        if args.detach:
            raise MachineError("error: the queue is empty: nothing to draw")
        say("the queue is empty: `vplotter queue add FILE` puts a drawing in it")
        return None
    if args.detach and args.dry_run:
        raise ConfigError("error: --detach draws on the machine; a --dry-run has nothing to detach")
    if args.dry_run:
        _dry_run(args)
        return None
    held = lock.acquire("vplotter queue run")
    if args.detach:
        return _detach(argv, held)
    first = True
    while True:
        jobs = queue.jobs()
        if not jobs:
            break
        job = jobs[0]
        if not first and not job["stopped"]:
            _paper(cfg, job, args.detached)
        first = False
        _draw(args, job)
    say("the queue is done")
    return None


def _copy_text(job: dict, k: int) -> str | None:
    return f"{k} of {job['copies']}" if job["copies"] > 1 else None


def _draw(args, job: dict) -> None:
    """Draw the next copy of job (resumed where it stopped, if it did); the queue learns how
    it went: one copy more done, or stopped part-way (it stays first)."""
    from vplotter.commands import draw
    from vplotter.machine import history, queue, state

    k = int(job["done"]) + 1
    copy = _copy_text(job, k)
    # stopped (`vplotter stop`) or cut short by a crash or power cut: go on where it was
    stored = state.load()
    info = (state.recovered(stored).extra.get("resume") or {}) if stored else {}
    mine = info.get("file") == os.path.abspath(job["file"])
    resume = mine and (bool(job["stopped"]) or not stored.clean)
    if job["stopped"] and not mine:
        eprint(f"vplotter: warning: {job['name']} was stopped part-way, but the stored "
               f"position no longer says where: drawing it from the start")
    dargs, words = _draw_args(args, job, resume)
    dargs.job_name, dargs.job_copy = job["name"], copy
    dargs.plot = plot = history.Plot(os.path.abspath(job["file"]), job["name"], copy)
    say(f"queue: job {job['id']}: {job['name']}{f' ({copy})' if copy else ''}"
        f"{', resumed' if resume else ''}")
    try:
        draw.draw_file(dargs, words)
    except Interrupted:
        if plot.t0:
            queue.mark_stopped(job["id"], bool((state.load() or _NO).extra.get("resume")))
        say(f"queue: stopped in {job['name']}{f' ({copy})' if copy else ''}: "
            f"`vplotter queue run` goes on from there")
        raise
    except VplotterError as e:
        if not plot.t0:
            from vplotter.commands.common import error_line

            history.failed(plot.path, job["name"], error_line(e), copy)
        raise
    queue.copy_done(job["id"])


class _NoPosition:
    extra: dict = {}


_NO = _NoPosition()


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise ConfigError(f"error: {message}")


def _draw_args(args, job: dict, resume: bool):
    """`draw FILE OPTIONS` for a job, with the run's machine options: (args, argv)."""
    from vplotter.commands import draw

    words = [job["file"], *job["options"]]
    if args.backend:
        words += ["--backend", args.backend]
    for flag in ("dry_run", "trust_position", "realtime", "detached"):
        if getattr(args, flag, False):
            words.append("--" + flag.replace("_", "-"))
    if resume:
        words.append("--resume")
    p = _Parser(prog="vplotter draw", add_help=False)
    draw.add_draw(p)
    dargs = p.parse_args(words)
    dargs.config, dargs.command, dargs.debug = args.config, "draw", False
    return dargs, ["--config", args.config, "draw", *words]


def _dry_run(args) -> None:
    """Every copy of every job as a dry run: nothing waits, the queue stays as it is."""
    from vplotter.commands import draw
    from vplotter.machine import queue

    first = True
    for job in queue.jobs():
        for k in range(int(job["done"]) + 1, int(job["copies"]) + 1):
            copy = _copy_text(job, k)
            if not first:
                say(f"pause: put in fresh paper for {job['name']}"
                    f"{f' ({copy})' if copy else ''} (dry run: not waiting)")
            first = False
            dargs, words = _draw_args(args, job, False)
            draw.draw_file(dargs, words)


def _paper(cfg, job: dict, detached: bool) -> None:
    """Wait for fresh paper, as at a pen change: Enter on the terminal or `vplotter
    continue`; status shows the wait. A signal ends the wait: Interrupted."""
    from vplotter.commands import draw
    from vplotter.inputs.gcode import Pause
    from vplotter.machine import live, notify
    from vplotter.machine.signals import Signals

    copy = _copy_text(job, int(job["done"]) + 1)
    text = f"put in fresh paper for {job['name']}" + (f" ({copy})" if copy else "")
    signals = Signals(ignore_hangup=detached)
    signals.install(lambda: None)
    pub = live.Publisher("vplotter queue run", os.path.abspath(job["file"]), job["estimate_s"],
                         on_state=notify.hook(cfg.notify))
    try:
        pub.waiting(Pause(0, 0, text))
        stop = lambda: signals.pending  # noqa: E731
        if detached:
            say(f"pause: {text}; waiting: `vplotter continue` goes on")
            draw.wait_continue(stop, live.take_continue)
        else:
            say(f"pause: {text}, then press Enter")
            if not draw.wait_enter(sys.stdin, stop, go=live.take_continue,
                                   closed="waiting for `vplotter continue`"):
                draw.wait_continue(stop, live.take_continue)
    finally:
        signals.restore()
        pub.close()
    if signals.signum:
        say(f"queue: stopped before {job['name']}{f' ({copy})' if copy else ''}: "
            f"`vplotter queue run` goes on from there")
        raise Interrupted(f"stopped by {signals.name()}", signals.signum)


def _detach(argv, held) -> QueueStarted:
    """`queue run` in a new process (commands/common.background, as `draw --detach`)."""
    from vplotter.commands.common import background

    pid, log = background(argv, held, "vplotter queue run")
    msg = f"drawing the queue in the background: pid {pid}; its output goes to {log}"
    say(msg)
    say("follow it: vplotter status --watch (or vplotter log -f); pause it: vplotter stop")
    return QueueStarted(pid, log, msg)
