"""draw and estimate."""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass

from vplotter.commands.common import (Progress, add_machine_options, answering, command_line,
                                      eprint, file_hash, load_config, position, say, session)
from vplotter.errors import ConfigError, MachineError


def add_draw(p: argparse.ArgumentParser) -> None:
    from vplotter.file_options import add_file_options

    p.add_argument("file", help="the drawing: G-code, SVG, DXF, text (.txt) or a photo "
                                "(PNG, JPEG, WebP, BMP, TIFF, GIF)")
    add_machine_options(p)
    p.add_argument("--strict", action="store_true",
                   help="treat warnings about inconsistent arcs as errors")
    p.add_argument("--verbose", action="store_true",
                   help="say more: every warning, a photo's tone details, and the timing "
                        "lateness statistics")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--resume", action="store_true",
                   help="go on from where the last interrupted draw of FILE stopped")
    g.add_argument("--from-line", type=int, metavar="N", help="start at line N of FILE")
    p.add_argument("--force", action="store_true", help="--resume even if FILE changed since")
    p.add_argument("--save-stream", metavar="OUT.gcode",
                   help="with --backend serial: write the G-code lines streamed to the controller")
    p.add_argument("--detach", action="store_true",
                   help="after validation, draw in the background (survives the end of the SSH "
                        "session; follow with `vplotter status --watch` or `vplotter log -f`)")
    p.add_argument("--detached", action="store_true", help=argparse.SUPPRESS)
    add_file_options(p, verbose=False)


def start_at(args, pos):
    from vplotter.pipeline import StartAt

    if args.from_line is not None:
        if args.from_line < 1:
            raise ConfigError(f"error: --from-line must be 1 or more (got {args.from_line})")
        return StartAt(args.from_line)
    if not args.resume:
        return None
    info = pos.extra.get("resume")
    if not info:
        raise MachineError("error: nothing to resume: no interrupted draw is stored")
    import os

    if os.path.abspath(args.file) != info.get("file") and not args.force:
        raise MachineError(f"error: the interrupted draw was {info.get('file')}, not "
                           f"{os.path.abspath(args.file)} (--force to resume anyway)")
    if file_hash(args.file) != info.get("sha256") and not args.force:
        raise MachineError(f"error: {args.file} changed since the draw was interrupted "
                           f"(--force to resume anyway, or --from-line N)")
    from vplotter.file_options import options_key

    key = options_key(args.file, args)
    if info.get("options", key) != key and not args.force:
        raise MachineError(f"error: the interrupted draw of {args.file} was placed or ordered "
                           f"with other options; give the same ones to --resume")
    xy = info.get("xy")
    return StartAt(int(info["line"]), (float(xy[0]), float(xy[1])) if xy else None)


@dataclass(frozen=True)
class DrawStarted:
    """`draw --detach`: the background draw's pid, its log, and the first line the draw said
    (how the file was ordered, or its summary)."""

    pid: int
    log: str
    message: str


def cmd_draw(args, argv=None) -> int:
    with answering() as answer:
        started = draw_file(args, argv)
        if started is not None:
            answer(started)
    return 0


def draw_file(args, argv=None) -> DrawStarted | None:
    """The draw command: validate FILE, then draw it here, or (--detach) in a background
    process, whose DrawStarted is returned."""
    cfg = load_config(args)
    if args.detach and args.dry_run:
        raise ConfigError("error: --detach draws on the machine; a --dry-run has nothing to detach")
    pos = position(cfg, args, args.dry_run)
    begin = start_at(args, pos)
    if args.backend == "serial" or args.save_stream:
        from vplotter.commands import serial

        serial.draw(args, argv, cfg, pos, begin, PauseHandler(args.dry_run))
        return None
    return draw_from(args, argv, cfg, pos, begin)


def draw_from(args, argv, cfg, pos, begin=None, reached=None) -> DrawStarted | None:
    """Draw FILE from the position `pos` (the lock taken): `draw`'s, and the Python API's
    `Plotter.draw_file` (vplotter/api.py). reached(position): told where the pen is once the
    file is drawn (the API goes on from there)."""
    # the session (lock, pins, signal handlers) is open first, so that a signal at any moment
    # ends the same way; nothing is output before the whole file has been validated
    from vplotter.commands.common import error_line
    from vplotter.machine import history

    plot = history.plot_for(args)
    with session(args, cfg, command_line(argv), pos, draw_job(args, argv, cfg, plot)) as s, \
            history.kept(plot, s, error_line):
        prep, summary, said = _validate(args, cfg, pos, begin, s)
        if args.detach and summary is not None:
            return _detach(args, argv, s, said[0])
        if plot is not None and summary is not None:
            plot.started_with(summary)
        _play(args, cfg, pos, begin, s, prep, summary)
    if reached is not None:
        reached(s.here())
    return None


def draw_job(args, argv, cfg, plot=None):
    """What the draw's session needs from the command (machine/job.DrawJob); plot: its
    machine/history.Plot, told of the pauses."""
    import os

    from vplotter.machine import live, notify
    from vplotter.machine.job import DrawJob
    from vplotter.file_options import options_key

    path = os.path.abspath(args.file)

    def publisher(time_s: float):
        hook = notify.hook(cfg.notify)
        return live.Publisher(command_line(argv), path, time_s,
                              on_state=plot.hook(hook) if plot is not None else hook)

    # a draw that goes on in the background publishes there, not here
    here = not args.dry_run and not args.detach
    return DrawJob(args.file, path, file_hash(args.file), options_key(args.file, args),
                   detached=args.detached, publisher=publisher if here else None,
                   on_pause=PauseHandler(args.dry_run, args.detached))


def _validate(args, cfg, pos, begin, s):
    """Prepare FILE (a resumed draw is ordered from where the interrupted one started, so that
    the record numbers match), then the validation pass: the whole file, page limits and
    exact plot time before anything moves. (prep, summary or None if stopped, lines said)."""
    from vplotter import pipeline
    from vplotter.commands import warnings
    from vplotter.commands.files import prepare_file

    start = (pos.extra.get("resume") or {}).get("start") if args.resume else None
    prep = prepare_file(args, cfg, pos, start_xy=start)
    s.place(prep.start_xy)
    summary = pipeline.validate(cfg, prep.records(), pos.counts, pos.ref_mm, args.file, begin,
                                lambda: s.stop_pending, where=prep.where, park=prep.start_xy)
    said: list[str] = []
    warnings.flush()                # what reading the file found, before the summary
    if summary is not None:
        # published before the summary is printed: whoever sees the summary finds it
        s.go_live(summary.time_s)
        said = _ordered(prep) + [f"{args.file}: {line}" for line in summary.pen_lines()]
        said.append(f"{args.file}: {summary.text()}")
        for line in said:
            say(line)
    return prep, summary, said


def _play(args, cfg, pos, begin, s, prep, summary) -> None:
    """Draw what was validated (planned once, drawn as planned), then say how it went."""
    import os

    from vplotter import pipeline
    from vplotter.errors import Interrupted

    if summary is not None and summary.plan is not None:
        rows = pipeline.replay(cfg, summary.plan, pos.counts, pos.ref_mm)
    else:
        rows = pipeline.stream(cfg, prep.records(), pos.counts, pos.ref_mm, args.file,
                               start_at=begin, where=prep.where, park=prep.start_xy)
    if s.tracer is not None:
        s.tracer.comment(f"file {os.path.abspath(args.file)}")
    progress = (Progress(summary) if summary and sys.stderr.isatty() and not s.dry_run
                else None)
    try:
        s.play(rows, progress)
    except Interrupted:
        _stopped(args, cfg, pos, s, prep, progress)
        raise
    if progress:
        progress.done()
    s.finished()
    _lateness(args, s)
    if args.detached:
        say(f"{args.file}: finished at {time.strftime('%H:%M:%S')}")


def _stopped(args, cfg, pos, s, prep, progress) -> None:
    """A signal stopped the draw: where it stopped, and (if something was drawn) the stored
    position says to resume from there."""
    import numpy as np

    from vplotter import kinematics

    kin = kinematics.from_config(cfg)
    spu = np.asarray(cfg.motors.steps_per_unit)
    cords = np.asarray(pos.ref_mm) + np.asarray(s.counts) / spu
    xy = kin.to_gcode(kin.forward(cords[None, :]))[0]
    resume = s.resume_from(xy)
    if progress:
        progress.done()
    xy = np.where(np.abs(xy) < 5e-4, 0.0, xy)
    where = (f"{prep.where(s.line)}: stopped" if s.line
             else f"{args.file}: stopped before drawing")
    eprint(f"{where} at X{xy[0]:.3f} Y{xy[1]:.3f}; pen lifted, coils released"
           f"{'' if s.dry_run else ', position saved'}")
    if not s.dry_run and resume and not getattr(args, "job_name", None):   # a queue job: queue run
        eprint(f"resume with: vplotter draw {args.file} --resume")


def _lateness(args, s) -> None:
    """The real-time backends' timing: in the trace, and said with --verbose."""
    stats = s.backend.lateness()
    if not stats:
        return
    text = ("lateness (actual - planned change time): p50 {p50_ms:.3f} ms, "
            "p99 {p99_ms:.3f} ms, max {max_ms:.3f} ms over {n} changes").format(**stats)
    if stats.get("underruns"):
        text += f", {stats['underruns']} queue underruns"
    if "shifts" in stats:
        text += (f"; the timeline moved {stats['shifts']} times by more than 0.1 ms, "
                 f"{stats['lost_ms'] / 1e3:.3f} s lost in total")
    if s.tracer is not None:
        s.tracer.comment(text)
    if args.verbose:
        say(text)


def _detach(args, argv, s, message: str) -> DrawStarted:
    """Go on in a new process (commands/common.background); the pins and the lock pass to it."""
    from vplotter.commands.common import background

    pid, log = background(argv, s.hand_over_pins())
    say(f"drawing in the background: pid {pid}; its output goes to {log}")
    say("follow it: vplotter status --watch (or vplotter log -f); pause it: vplotter stop")
    return DrawStarted(pid, log, message)


def _ordered(prep) -> list[str]:
    """The line that says how the file was placed and ordered (none for G-code kept as is)."""
    if prep.passthrough:
        return []
    return [f"{prep.path}: {len(prep.strokes)} strokes placed and ordered in {prep.order_s:.2f} s"]


class PauseHandler:
    """What happens at a Pause: the pen is up (at a pen change the gondola is parked at the
    change point and held there; at a plain pause the coils are released). A dry run only
    notes it; a draw waits for Enter or `vplotter continue`, a background draw (--detach) for
    `vplotter continue`; a signal (`vplotter stop`) ends any wait."""

    def __init__(self, dry_run: bool, detached: bool = False):
        self.dry_run, self.detached = dry_run, detached

    def __call__(self, p, stop, progress) -> None:
        from vplotter.machine import live

        if progress:
            progress.done()
        text = live.pen_prompt(p)
        if self.dry_run:
            say(f"pause: {text} (dry run: not waiting)")
            return
        if self.detached:
            say(f"pause: {text}; waiting: `vplotter continue` goes on")
            wait_continue(stop, live.take_continue)
        elif p.pen is not None:
            say(f"pause: {text}, then press Enter")     # what to do is the pause's message
            if not wait_enter(sys.stdin, stop, go=live.take_continue,
                              closed="waiting for `vplotter continue`"):
                wait_continue(stop, live.take_continue)     # no terminal (a service)
        else:
            say(f"pause: {text}, then press Enter")
            wait_enter(sys.stdin, stop, go=live.take_continue)
        if not stop() and p.pen is not None:
            say(f"going on with the {p.pen} pen")


POLL_S = 0.2          # a waiting draw looks for `vplotter continue` (or a stop) this often


_sleep = time.sleep    # (tests make the wait run on a simulated clock)


def wait_continue(stop, go) -> None:
    """Wait until go() (someone ran `vplotter continue`) or stop() (a signal) turns true."""
    while not stop() and not go():
        _sleep(POLL_S)


def wait_enter(stdin, stop, poll_s: float = POLL_S, go=lambda: False,
               closed: str = "not waiting at the pause") -> bool:
    """Read one line from stdin; polls so that a signal (stop() true) or `vplotter continue`
    (go() true) ends the wait. With stdin closed (end of file) it says so (`closed`: what
    happens then) and returns False."""
    try:
        fd = stdin.fileno()
    except (AttributeError, OSError, ValueError):
        fd = None
    if fd is not None:
        import select

        while not stop():
            ready, _, _ = select.select([fd], [], [], poll_s)
            if ready:
                break
            if go():
                return True
        else:
            return True
    if stdin.readline() == "":
        eprint(f"vplotter: warning: standard input is closed: {closed}")
        return False
    return True


def estimate_file(args, cfg, pos, **prepare):
    """The file prepared and validated from `pos`: (prep, summary), estimate's and the Python
    API's `Plotter.estimate` (prepare: prepare_file's warn, say_notes)."""
    from vplotter import pipeline
    from vplotter.commands.files import prepare_file

    prep = prepare_file(args, cfg, pos, **prepare)
    return prep, pipeline.validate(cfg, prep.records(), pos.counts, pos.ref_mm, args.file,
                                   where=prep.where)


def cmd_estimate(args, argv=None) -> int:
    from vplotter.commands import warnings

    cfg = load_config(args)
    pos = position(cfg, args, True)
    prep, summary = estimate_file(args, cfg, pos)
    warnings.flush()
    for line in _ordered(prep):
        say(line)
    for line in summary.pen_lines():
        print(f"{args.file}: {line}")
    print(f"{args.file}: {summary.text()}")
    return 0


def add_estimate(p) -> None:
    from vplotter.file_options import add_file_options

    p.add_argument("file", help="the drawing: G-code, SVG, DXF, text (.txt) or a photo "
                                "(PNG, JPEG, WebP, BMP, TIFF, GIF)")
    p.add_argument("--strict", action="store_true", help="treat arc warnings as errors")
    add_file_options(p)

