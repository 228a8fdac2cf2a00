"""argparse with one-line usage errors (the command line's, cli.py, and the Python API's
file options, api.py): what is wrong, the nearest option or choice when a word is mistyped,
and where the full usage is."""

from __future__ import annotations

import argparse


class Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors: what is wrong, the nearest option or choice when
    a word is mistyped, and where the full usage is (`vplotter draw --help`)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {usage_error(self, message)}\n")


def _near(word: str, words) -> str | None:
    import difflib

    found = difflib.get_close_matches(word, list(words), n=1, cutoff=0.6)
    return found[0] if found else None


def _options(parser: argparse.ArgumentParser) -> list[str]:
    return [o for a in parser._actions for o in a.option_strings if o.startswith("--")]


def usage_error(parser: argparse.ArgumentParser, message: str) -> str:
    """argparse's `message` for a person, on one line."""
    import re

    m = re.match(r"argument (\S+): invalid choice: '(.*)' \(choose from (.*)\)$", message)
    if m:
        what, word = m.group(1), m.group(2)
        choices = [c.strip(" '") for c in m.group(3).split(",")]
        near = _near(word, choices)
        if what == "COMMAND":
            return (f"'{word}' is not a command" + (f"; did you mean '{near}'?" if near else "")
                    + " (vplotter --help lists them)")
        what = what if what.startswith("-") else f"the {what}"
        return (f"{what} {word}: not a choice" + (f"; did you mean {near}?" if near else "")
                + f" (choose from {', '.join(choices)})")
    m = re.match(r"unrecognized arguments: (.*)$", message)
    if m:
        word = m.group(1).split()[0]
        if word.startswith("-"):
            near = _near(word.split("=")[0], _options(parser))
            return (f"unknown option {word}" + (f"; did you mean {near}?" if near else "")
                    + f" ({parser.prog} --help lists the options)")
        return f"unexpected argument {word!r} ({parser.prog} --help says what it takes)"
    return f"{message} ({parser.prog} --help)"
