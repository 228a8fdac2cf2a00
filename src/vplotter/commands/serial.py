"""draw --backend serial, `vplotter serial check` and `vplotter serial console`."""

from __future__ import annotations

import argparse
import os
import sys

from vplotter.commands.common import Progress, command_line, eprint, file_hash, load_config, say
from vplotter.errors import ConfigError, Interrupted


def draw(args, argv, cfg, pos, begin, on_pause=None) -> int:
    """cmd_draw hands the serial case here: validate, then stream the lines to the controller.
    on_pause(pause, stop, progress): what happens at M0 or a pen change (machine/job.DrawJob)."""
    import numpy as np

    from vplotter import pipeline
    from vplotter.commands.common import error_line
    from vplotter.machine import history, live, notify
    from vplotter.machine.job import DrawJob
    from vplotter.machine.serial_job import SerialSession
    from vplotter.inputs import gcode
    from vplotter.motion.linestream import LineScheduler

    if args.backend != "serial":
        raise ConfigError("error: --save-stream goes with --backend serial")
    if getattr(args, "detach", False) or getattr(args, "detached", False):
        raise ConfigError("error: --detach does not work with --backend serial yet")
    if args.trace or args.realtime:
        raise ConfigError("error: --trace and --realtime are for the GPIO backends "
                          "(--save-stream writes what is sent to the controller)")
    made: list[LineScheduler] = []

    class Counted(LineScheduler):            # the validation pass counts the lines
        def __init__(self, *a):
            super().__init__(*a)
            made.append(self)

    path = os.path.abspath(args.file)
    plot = history.plot_for(args)           # None for a dry run

    def publisher(time_s: float):
        hook = notify.hook(cfg.notify)
        return live.Publisher(command_line(argv), path, time_s,
                              on_state=plot.hook(hook) if plot is not None else hook)

    # M0, a pen change: all before it runs, then it asks
    job = DrawJob(args.file, path, file_hash(args.file), on_pause=on_pause,
                  publisher=None if args.dry_run else publisher)
    with SerialSession(cfg, command_line(argv), args.dry_run, pos, args.save_stream, job) as s, \
            history.kept(plot, s, error_line):
        records = gcode.read(args.file, strict=args.strict)
        summary = pipeline.validate(cfg, records, pos.counts, pos.ref_mm, args.file, begin,
                                    lambda: s.stop_pending, Counted)
        if summary is not None:
            s.go_live(summary.time_s)      # for `vplotter status`
            if plot is not None:
                plot.started_with(summary)
            say(f"{args.file}: {summary.text()}")
            say(f"{args.file}: {made[-1].lines_total} lines to stream "
                f"({cfg.serial.axes} axes, {cfg.serial.port})")
        quiet = gcode.read(args.file, strict=args.strict, warn=lambda m: None)
        progress = (Progress(summary) if summary and sys.stderr.isatty() and not s.dry_run
                    else None)
        try:
            s.play(pipeline.stream(cfg, quiet, pos.counts, pos.ref_mm, args.file,
                                   start_at=begin, scheduler=LineScheduler), progress)
        except Exception as e:
            if progress:
                progress.done()
            if s.stop_xy is not None:
                s.resume_from(s.stop_xy)
            xy = np.where(np.abs(s.stop_xy or (0.0, 0.0)) < 5e-4, 0.0, s.stop_xy or (0.0, 0.0))
            where = (f"{args.file}:{s.line}: stopped" if s.line
                     else f"{args.file}: stopped before drawing")
            if isinstance(e, Interrupted):
                eprint(f"{where} at X{xy[0]:.3f} Y{xy[1]:.3f}; pen lifted"
                       f"{'' if s.dry_run else ', position saved'}")
            elif s.line and not s.dry_run:
                eprint(f"{where} near X{xy[0]:.3f} Y{xy[1]:.3f} (the last position the controller "
                       f"reported); position saved")
            if not s.dry_run and s.line:
                eprint(f"resume with: vplotter draw {args.file} --resume --backend serial")
            raise
        if progress:
            progress.done()
        s.finished()
        if args.verbose and not s.dry_run:
            say(f"{s.lines_sent} lines streamed")
    return 0


def add_serial(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="serial_command", metavar="ACTION", required=True)
    sub.add_parser("check", help="print the controller's banner, build info and settings, and "
                                 "where they contradict config.toml")
    sub.add_parser("console", help="a line-by-line terminal to the controller: ? status, ! hold, "
                                   "~ resume, Ctrl+X (or the word ^X) soft reset, Ctrl+D quits")


def cmd_serial(args, argv=None) -> int:
    cfg = load_config(args)
    if args.serial_command == "check":
        return check(cfg)
    return console(cfg)


# ---------------------------------------------------------------- check
def expected_settings(cfg) -> dict[int, tuple[float, str]]:
    """grbl $-settings that config.toml implies for the X and Y axes: {number: (value, what)}."""
    m = cfg.motors
    if cfg.serial.axes == "motors":
        out = {}
        for axis, spu in enumerate(m.steps_per_unit):   # controller mm = cord mm
            out[100 + axis] = (spu, "steps/mm")
            out[110 + axis] = (m.max_step_rate / spu * 60.0, "max rate mm/min")
            out[120 + axis] = (m.max_accel / spu, "acceleration mm/s^2")
        return out
    fastest = max(cfg.motion.draw_speed_mm_s, cfg.motion.travel_speed_mm_s) * 60.0
    return {110: (fastest, "max rate mm/min (at least the travel speed)"),
            111: (fastest, "max rate mm/min (at least the travel speed)")}


def compare_settings(cfg, settings: dict[int, float]) -> list[str]:
    """Warnings where the controller's settings contradict config.toml."""
    out = []
    for num, (want, what) in sorted(expected_settings(cfg).items()):
        have = settings.get(num)
        if have is None:
            continue
        if num in (100, 101):
            bad = abs(have - want) > 1e-3 * want
            hint = "positions will be off by the ratio"
        elif num in (110, 111):
            bad = have > want * 1.02 if cfg.serial.axes == "motors" else have < want * 0.98
            hint = ("the motors may be asked for more steps/s than [motors] max_step_rate"
                    if cfg.serial.axes == "motors"
                    else "the controller cannot reach the speed caps")
        else:
            bad = have > want * 1.02
            hint = "above [motors] max_accel"
        if bad:
            out.append(f"warning: ${num}={have:g} ({what}) "
                       f"but config.toml implies {want:.3f}: {hint}")
    return out


def parse_settings(lines: list[str]) -> dict[int, float]:
    out = {}
    for ln in lines:
        if ln.startswith("$") and "=" in ln:
            key, _, val = ln[1:].partition("=")
            try:
                out[int(key)] = float(val.split()[0])
            except (ValueError, IndexError):
                continue
    return out


def check(cfg) -> int:
    from vplotter.backends.serial import open_port

    link = open_port(cfg)
    try:
        say(f"{cfg.serial.port}: {link.banner}")
        st = link.status()
        say(f"state: {st.state}")
        for ln in link.command("$I"):
            say(ln)
        lines = link.command("$$")
        for ln in lines:
            say(ln)
        warnings = compare_settings(cfg, parse_settings(lines))
        for w in warnings:
            eprint(w)
        if not warnings:
            say(f"settings agree with {cfg.path} ([serial] axes = {cfg.serial.axes})")
    finally:
        link.port.close()
    return 0


# ---------------------------------------------------------------- console
REALTIME = {"?": b"?", "!": b"!", "~": b"~", "\x18": b"\x18", "^X": b"\x18", "^x": b"\x18"}


def console(cfg, stdin=None, out=None) -> int:
    """Read lines from stdin: `?`, `!`, `~`, Ctrl+X (or `^X`) go out as real-time bytes, any
    other line as a G-code or $ line; everything the controller says is printed. The
    controller's $ settings change only when you type them."""
    import select

    from vplotter.backends.serial import open_port

    stdin = stdin or sys.stdin
    out = out or sys.stdout
    link = open_port(cfg)
    say(f"{cfg.serial.port}: {link.banner}  (? status, ! hold, ~ resume, Ctrl+X reset, "
        f"Ctrl+D quits)", out)
    try:
        while True:
            for ln in link.read_lines():
                say(ln, out)
            try:
                ready, _, _ = select.select([stdin], [], [], 0.05)
            except (OSError, ValueError, TypeError):
                ready = [stdin]
            if not ready:
                continue
            text = stdin.readline()
            if text == "":
                break
            cmd = text.strip()
            if not cmd:
                continue
            if cmd in REALTIME:
                link.write(REALTIME[cmd])
            else:
                link.write(cmd.replace("\x18", "").encode("ascii", "replace") + b"\n")
                if "\x18" in cmd:
                    link.write(b"\x18")
        # what is still on its way: until the controller has been quiet for a moment
        quiet_since = link.clock()
        while link.clock() - quiet_since < 0.3:
            lines = link.read_lines()
            for ln in lines:
                say(ln, out)
            if lines:
                quiet_since = link.clock()
    except KeyboardInterrupt:
        pass
    finally:
        link.port.close()
    return 0
