"""The file options the page gives a drawing, as `vplotter draw`'s: the same names (the
argparse dest: `width`, `fit`, `style`, `max_time`, `fill`), the same meaning, and the same
validation (the `estimate` command's own parser, whose errors become one line instead of a
usage message and exit 2).

A page's options are a JSON object such as {"width": 300, "style": "stipple", "max_time":
"45m"}; `argv()` makes them the command-line words (`--width=300 --style=stipple
--max-time=45m`) that estimate, preview and draw are given, so the three always agree.
`takes()` says which of them a file's kind takes (photos: style and max_time; SVG: fill;
every file: width and fit), from the readers' own `Reader.options`.
"""

from __future__ import annotations

import argparse

from vplotter.errors import ConfigError

PLACE = ("width", "fit")             # every drawing
GROUP_OPTIONS = {"photo": ("style", "max_time"), "fill": ("fill",)}
NAMES = PLACE + GROUP_OPTIONS["photo"] + GROUP_OPTIONS["fill"]
FLAGS = ("fit",)                     # true or false, no value


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise ConfigError(f"error: {message}")


def takes(path: str) -> list[str]:
    """The page's option names that the file at `path` takes."""
    from vplotter import readers

    reader = readers.reader_for(path)
    out = list(PLACE)
    for group, names in GROUP_OPTIONS.items():
        if group in reader.options:
            out.extend(names)
    return out


def clean(options, allowed=NAMES) -> dict:
    """options without empty values (None, "", false), as the page sends them; ConfigError
    for an unknown name or a value that is neither a number, a string nor (fit) a boolean."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ConfigError("error: options must be a JSON object such as {\"width\": 300}")
    out = {}
    for name, value in options.items():
        if name not in NAMES:
            raise ConfigError(f"error: unknown option {str(name)[:40]!r} (the page's options "
                              f"are {', '.join(NAMES)})")
        if name not in allowed or value is None or value == "" or value is False:
            continue
        if name in FLAGS:
            if value is not True:
                raise ConfigError(f"error: {name} must be true or false (got {value!r:.40})")
        elif (isinstance(value, bool) or not isinstance(value, (int, float, str))
              or isinstance(value, str) and not (value.isprintable() and len(value) <= 40)):
            raise ConfigError(f"error: {name} must be a number or a word (got {value!r:.40})")
        out[name] = value
    return out


def argv(options: dict) -> list[str]:
    """The command-line words of clean() options, in NAMES order."""
    words: list[str] = []
    for name in NAMES:
        if name not in options:
            continue
        flag = "--" + name.replace("_", "-")
        words.append(flag if name in FLAGS else f"{flag}={options[name]}")
    return words


def check(path: str, words: list[str]) -> argparse.Namespace:
    """`vplotter estimate PATH WORDS`'s arguments, parsed by the command's own parser
    (ConfigError: its error, one line)."""
    from vplotter.commands import draw

    p = _Parser(prog="vplotter estimate", add_help=False)
    draw.add_estimate(p)
    return p.parse_args([*words, "--", path])


def choices() -> dict[str, list[str]]:
    """The values the command line allows for the page's options that have a list of them
    (style, fill), as its parser says."""
    from vplotter.commands import draw

    p = _Parser(prog="vplotter estimate", add_help=False)
    draw.add_estimate(p)
    return {a.dest: list(a.choices) for a in p._actions
            if a.dest in NAMES and a.choices is not None}
