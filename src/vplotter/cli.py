"""Command line: a table of commands {name: (handler, add_arguments, help)}.

Heavy modules (numpy, backends) are imported inside the handlers so that `vplotter --help`
stays fast. Every error a person can cause ends as one line on stderr and exit status 2
(3 when the plotter is busy, 128 + N after signal N); anything unexpected is exit 1 with a
hint to rerun with --debug.
"""

from __future__ import annotations

import argparse
import sys
from typing import Callable

from vplotter.commands import draw, files, live, machine, pictures, serial, serve, setup
from vplotter.commands import queue as queue_cmd
from vplotter.commands import text as text_cmd
from vplotter.commands import warnings
from vplotter.commands.common import eprint, error_line, exit_code
# one-line usage errors (commands/usage.py; the Python API parses draw's options with them)
from vplotter.commands.usage import Parser, usage_error  # noqa: F401
from vplotter.errors import VplotterError


COMMANDS: dict[str, tuple[Callable, Callable, str]] = {
    "draw": (draw.cmd_draw, draw.add_draw,
             "draw a file: G-code, SVG, DXF, text (.txt) or a photo"),
    "estimate": (draw.cmd_estimate, draw.add_estimate, "validate a file and print the plot time"),
    "info": (files.cmd_info, files.add_info,
             "size, extent, strokes, travel and time of a file (file order and --order best)"),
    "convert": (files.cmd_convert, files.add_convert,
                "write the placed and ordered drawing as G-code"),
    "text": (text_cmd.cmd_text, text_cmd.add_text,
             "text in a single-stroke Hershey font, as G-code (-o) or a summary"),
    "calibrate": (setup.cmd_calibrate, machine.add_calibrate,
                  "tell vplotter where the pen is, or measure steps/mm"),
    "status": (live.cmd_status, live.add_status,
               "where the pen is, whether the last stop was clean, the running draw"),
    "stop": (live.cmd_stop, live.add_stop,
             "pause the running draw: pen up, position stored, ready to --resume"),
    "continue": (live.cmd_continue, live.add_continue,
                 "let a draw waiting at a pen change go on (as Enter on its terminal)"),
    "log": (live.cmd_log, live.add_log, "print the output of the background draw (--detach)"),
    "pen": (machine.cmd_pen, machine.add_pen, "lift, lower or cycle the pen"),
    "jog": (machine.cmd_jog, machine.add_jog,
            "move the pen by hand (arrow keys) or by --dx/--dy, --left/--right"),
    "goto": (machine.cmd_goto, machine.add_goto, "move the pen (up) to a G-code point"),
    "home": (setup.cmd_home, machine.add_machine_options,
             "move the pen (up) to the last calibrated point; polar: find the arm's end switch"),
    "serial": (serial.cmd_serial, serial.add_serial,
               "a grbl controller on [serial] port: check its settings, or a console"),
    "preview": (pictures.cmd_preview, pictures.add_preview,
                "picture (PNG/SVG) of the planned drawing: order, travel, page, anchors"),
    "simulate": (pictures.cmd_simulate, pictures.add_simulate,
                 "picture (PNG/SVG) of what a GPIO trace draws"),
    "queue": (queue_cmd.cmd_queue, queue_cmd.add_queue,
              "the job queue: add, move, remove, clear, run (fresh paper between jobs)"),
    "history": (queue_cmd.cmd_history, queue_cmd.add_history,
                "the plots drawn: when, how long, how far, how they ended"),
    "serve": (serve.cmd_serve, serve.add_serve,
              "the page on the Pi: upload, preview, draw, watch and stop from a phone"),
}


def build_parser() -> argparse.ArgumentParser:
    from vplotter import __version__

    parser = Parser(
        prog="vplotter",
        description="Drive a hanging wall plotter (V-plotter) from a Raspberry Pi: draw G-code, "
                    "SVG, DXF, text (.txt) and photos (PNG, JPEG, WebP, BMP, TIFF, GIF).")
    parser.add_argument("--version", action="version", version=f"vplotter {__version__}")
    parser.add_argument("--config", default="config.toml", metavar="PATH",
                        help="machine configuration (default: ./config.toml)")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (_, add_args, help_text) in COMMANDS.items():
        add_args(sub.add_parser(name, help=help_text, description=help_text))
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:       # named by the command's own parser, which knows its options
            sub = _subparser(parser, getattr(args, "command", None)) or parser
            sub = _subparser(sub, getattr(args, "action", None)) or sub     # queue add
            sub.error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as e:  # argparse: usage errors are exit 2, --help is 0
        return int(e.code or 0)
    if not args.command:
        parser.print_help()
        return 2
    handler = COMMANDS[args.command][0]
    warnings.begin(verbose=bool(getattr(args, "verbose", False)))
    try:
        code = _run(handler, args, argv)
        warnings.flush()
        return code
    except BrokenPipeError:
        return 1
    except (VplotterError, KeyboardInterrupt, Exception) as e:   # noqa: BLE001 - the last line
        warnings.drop()             # an error is the only line of a failed command
        if args.debug and not isinstance(e, (VplotterError, KeyboardInterrupt)):
            raise
        eprint(error_line(e))       # commands/common.py: the web's answers use the same line
        return exit_code(e)


def _subparser(parser: argparse.ArgumentParser, name: str | None):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return action.choices.get(name)
    return None


def _run(handler, args, argv) -> int:
    from vplotter.machine import lock

    try:
        return handler(args, argv)
    finally:
        lock.release_all()      # movers take the lock before reading the position


def run() -> None:
    sys.exit(main())

