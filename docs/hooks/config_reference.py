"""The tables of docs/configuration.md, generated from the config schema.

Between `<!-- config-reference:start -->` and `<!-- config-reference:end -->` configuration.md
holds one table per section of `vplotter.config.SCHEMA` (key, type, default, range or choices,
what it applies to) with the one-line descriptions of `vplotter.config.keys`, written into the
file so that it reads the same on GitHub as on the site. After a change to the schema:

    python docs/hooks/config_reference.py      # rewrites the tables in docs/configuration.md

As an MkDocs hook it fails the build when the file is not current, and so does
tests/test_config_docs.py (CI runs both). A key without a description fails both too.
"""

from __future__ import annotations

import re
from pathlib import Path

START = "<!-- config-reference:start -->"
END = "<!-- config-reference:end -->"
PAGE = Path(__file__).resolve().parent.parent / "configuration.md"
TYPES = {"float": "number", "int": "whole number", "str": "choice", "text": "text",
         "pins": "4 BCM pins", "bool": "true/false", "range": "[low, high]",
         "url": "http(s) URL"}


def _num(v) -> str:
    if isinstance(v, float) and v.is_integer() and abs(v) < 1e15:
        return str(int(v))
    return f"{v:g}" if isinstance(v, float) else str(v)


def _default(default, unset) -> str:
    if default is None:
        return "required"
    if default == unset:
        return "unset"
    if isinstance(default, bool):
        return f"`{str(default).lower()}`"
    if isinstance(default, str):
        return f'`"{default}"`'
    if isinstance(default, tuple):
        return "`[" + ", ".join(_num(v) for v in default) + "]`"
    return f"`{_num(default)}`"


def _range(kind: str, lo, hi) -> str:
    base = kind.rstrip("+")
    if base == "str":
        return ", ".join(f"`{c}`" for c in lo)
    if base in ("bool", "text", "url"):
        return ""
    if base == "pins":
        return f"each {lo}..{hi}"
    if base == "range":
        return f"within {_num(lo)} to {_num(hi)}"
    if kind.endswith("+"):
        return f"above {_num(lo)}, up to {_num(hi)}"
    return f"{_num(lo)} to {_num(hi)}"


def _applies(when: str | None, choices: dict) -> str:
    if not when:
        return "all"
    parts = []
    for w in when.split():
        name = next((n for n, values in choices.items() if w in values), "?")
        parts.append(f"{name} `{w}`")
    return ", ".join(parts)


def reference() -> str:
    from vplotter import config
    from vplotter.config.keys import DESCRIPTIONS, SECTIONS

    out = []
    for section, keys in config.SCHEMA.items():
        out.append(f"### [{section}]\n")
        out.append(SECTIONS[section])
        notes = []
        if section in config.OPTIONAL_SECTIONS:
            notes.append("Optional section.")
        if section in config.SECTION_WHEN:
            notes.append("Only for " + _applies(config.SECTION_WHEN[section], config.SCHEMA_CHOICES)
                         + ": elsewhere the section is an error.")
        out[-1] = " ".join([out[-1]] + notes)
        out.append("")
        out.append("| key | type | default | range / choices | applies to | description |")
        out.append("| --- | --- | --- | --- | --- | --- |")
        for key, spec in keys.items():
            kind, default, lo, hi = spec[:4]
            when = spec[4] if len(spec) > 4 else None
            name = f"{section}.{key}"
            if name not in DESCRIPTIONS:
                raise KeyError(f"config key {name} has no description in vplotter/config/keys.py")
            out.append(f"| `{key}` | {TYPES[kind.rstrip('+')]} | {_default(default, config.UNSET)} "
                       f"| {_range(kind, lo, hi)} | {_applies(when, config.SCHEMA_CHOICES)} "
                       f"| {DESCRIPTIONS[name]} |")
        out.append("")
    return "\n".join(out)


def render(markdown: str) -> str:
    """`markdown` with the tables between the two markers made anew."""
    block = re.compile(re.escape(START) + ".*?" + re.escape(END), re.S)
    if not block.search(markdown):
        raise ValueError(f"configuration.md has no {START} ... {END} block")
    return block.sub(lambda _: f"{START}\n\n{reference()}\n{END}", markdown, count=1)


def on_page_markdown(markdown, page, config, files):
    if START in markdown and render(markdown) != markdown:
        raise ValueError("docs/configuration.md is not current: run "
                         "`python docs/hooks/config_reference.py` and commit it")
    return markdown


if __name__ == "__main__":
    text = PAGE.read_text(encoding="utf-8")
    PAGE.write_text(render(text), encoding="utf-8")
