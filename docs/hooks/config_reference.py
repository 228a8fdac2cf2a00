"""MkDocs hook: the tables of docs/configuration.md, generated from the config schema.

`<!-- config-reference -->` in configuration.md is replaced at build time by one table per
section of `vplotter.config.SCHEMA` (key, type, default, range or choices, what it applies to)
with the one-line descriptions of `vplotter.config.keys`. A key without a description fails
the build (tests/test_config_docs.py says the same earlier).
"""

from __future__ import annotations

PLACEHOLDER = "<!-- config-reference -->"
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


def on_page_markdown(markdown, page, config, files):
    if PLACEHOLDER in markdown:
        return markdown.replace(PLACEHOLDER, reference())
    return markdown
