"""SVG paint: `fill`, `stroke`, `color` and `fill-rule` inherited down the tree, and a paint
turned into a pen (the colour as the file writes it) and a colour ('#rrggbb').

The declared values come from `svg_style.own_style` (presentation attribute < <style> rule <
style attribute, `!important` above all). Here they are inherited as SVG says: every one of
these properties inherits; `inherit` and `unset` take the parent's value, `initial` the initial
one (fill black, stroke none, color black, fill-rule nonzero). `currentColor` stays a keyword
while it is inherited and takes the `color` of the element it is used on (CSS Color 4);
`color: currentColor` is the parent's color.

Paints (`paint`): `none` (and `transparent`) is no paint; a colour is #rgb, #rrggbb, rgb()
(commas or spaces), hsl(), or a name; `url(#id) fallback` takes the fallback when there is one
(`url(#id) none`: no paint), else the first stop colour of the gradient `#id` (its `href`
followed), else a pen of its own named `url(#id)` drawn black (a pattern, a missing id);
`context-fill`/`context-stroke` (markers only) are no paint. The pen is the colour's name in
lower case (`red`) or its #rrggbb form (`#F80` and `rgb(255,136,0)` are `#ff8800`). A value
that is none of these raises ValueError.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable

from vplotter.inputs import colour as colours

_URL = re.compile(r"url\(\s*['\"]?#([^)'\"]*)['\"]?\s*\)\s*(.*)$", re.I)
_HSL = re.compile(r"hsla?\(\s*([-+.\d]+)(?:deg)?\s*[,\s]\s*([-+.\d]+)%\s*[,\s]\s*([-+.\d]+)%"
                  r"\s*(?:[,/][^)]*)?\)$", re.I)
_RGB_SPACES = re.compile(r"(rgba?)\(\s*([-+.\d]+%?)\s+([-+.\d]+%?)\s+([-+.\d]+%?)\s*(?:/[^)]*)?\)$",
                         re.I)
RULES = ("nonzero", "evenodd")
Pen = tuple[str, str]            # (pen name as the file writes it, '#rrggbb')


@dataclass(frozen=True)
class Paint:
    """The inherited (computed) paint properties where an element stands."""

    fill: str = "black"
    stroke: str = "none"
    color: str = "black"
    rule: str = "nonzero"


INITIAL = Paint()
_FIELDS = {"fill": "fill", "stroke": "stroke", "color": "color", "fill-rule": "rule"}


def cascade(parent: Paint, own: dict[str, str]) -> Paint:
    """The paint of an element from its parent's and its own declared values."""
    new = {}
    for prop, name in _FIELDS.items():
        value = own.get(prop)
        if value is None:
            continue
        low = value.strip().lower()
        if low in ("inherit", "unset", ""):
            continue
        if low == "initial":
            new[name] = getattr(INITIAL, name)
        elif name == "rule":
            if low in RULES:
                new[name] = low
        elif name == "color":
            if low != "currentcolor":
                new[name] = value.strip()
        else:
            new[name] = value.strip()
    if not new:
        return parent
    from dataclasses import replace

    return replace(parent, **new)


def _colour(text: str) -> Pen | None:
    """A colour as written -> (pen, '#rrggbb'); None for none/transparent."""
    t = text.strip()
    low = t.lower()
    m = _HSL.match(low)
    if m:
        return _named(t, _hsl(*(float(g) for g in m.groups())))
    m = _RGB_SPACES.match(low)
    if m:
        low = f"rgb({m.group(2)}, {m.group(3)}, {m.group(4)})"
    hexed = colours.parse(low)
    if hexed is None:
        return None
    return _named(low, hexed)


def _named(low: str, hexed: str) -> Pen:
    return (low if re.fullmatch(r"[a-z]+", low) else hexed), hexed


def _hsl(h: float, s: float, l: float) -> str:
    import colorsys

    r, g, b = colorsys.hls_to_rgb((h % 360) / 360, min(max(l, 0), 100) / 100,
                                  min(max(s, 0), 100) / 100)
    return "#" + "".join(f"{round(c * 255):02x}" for c in (r, g, b))


def paint(text: str, color: str, server: Callable[[str], str | None]) -> Pen | None:
    """A fill or stroke value -> (pen, '#rrggbb') or None (no paint). `color` is the element's
    color (for currentColor); `server(id)` gives a paint server's colour text (a gradient's
    first stop) or None. Raises ValueError for what is not a paint."""
    t = text.strip()
    low = t.lower()
    if low in ("none", "context-fill", "context-stroke"):
        return None
    if low == "currentcolor":
        if color.strip().lower() == "currentcolor":
            return _named("black", "#000000")
        return _colour(color)
    m = _URL.match(t)
    if m:
        ident, fallback = m.group(1).strip(), m.group(2).strip()
        if fallback:
            return paint(fallback, color, lambda i: None)
        stop = server(ident)
        if stop is not None:
            return paint(stop, color, lambda i: None)
        return f"url(#{ident})", "#000000"
    return _colour(t)


def first_stop(ids: dict, ident: str, style: Callable[[dict], dict]) -> str | None:
    """The first stop colour of the gradient `ident` (its href chain followed), or None.
    `style(attrs)` gives a stop's declared values."""
    node, seen = ids.get(ident), set()
    while node is not None and node.tag in ("linearGradient", "radialGradient"):
        stops = [c for c in node.children if c.tag == "stop" and c.svg]
        if stops:
            own = style(stops[0].attrs)
            value = own.get("stop-color", "black")
            return own.get("color", "black") if value == "currentcolor" else value
        seen.add(id(node))
        href = node.attrs.get("href", node.attrs.get("xlink:href", "")).strip()
        node = ids.get(href[1:]) if href.startswith("#") else None
        if node is not None and id(node) in seen:
            return None
    return None


def unify(pens: list[Pen | None]) -> dict[str, str]:
    """Pen renames that make each colour one pen, named as the file first writes it."""
    first: dict[str, str] = {}
    out: dict[str, str] = {}
    for p in pens:
        if p is None or p[0].startswith("url("):
            continue
        name = first.setdefault(p[1], p[0])
        if name != p[0]:
            out[p[0]] = name
    return out


def pens(reader, node, ctx):
    """(fill, stroke) of a drawn element of the SVG reader: each (pen, '#rrggbb') or None (no
    paint); a colour that does not parse is an error at the element."""
    def server(ident: str):
        return first_stop(reader.ids, ident,
                          lambda a: reader.style.own_style(reader.sheet, "stop", a))

    p, out = ctx.paint, []
    for name, value in (("fill", p.fill), ("stroke", p.stroke)):
        try:
            out.append(paint(value, p.color, server))
        except ValueError as e:
            raise reader.err(node, f"{name}: {e}") from None
    return out[0], out[1]
