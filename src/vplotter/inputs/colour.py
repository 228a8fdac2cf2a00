"""Colours as files and config.toml write them -> '#rrggbb': `#rgb`, `#rrggbb`, `rgb(r, g, b)`
(numbers or percentages) and the CSS/SVG colour names (svgelements' table, imported only when
a name is met). `none` and `transparent` are no colour (None); anything else is a ValueError
naming the text."""

from __future__ import annotations

import re

_HEX = re.compile(r"#([0-9a-fA-F]{3}|[0-9a-fA-F]{6})(?:[0-9a-fA-F]{2})?$")
_RGB = re.compile(r"rgba?\(\s*([^,\s]+)\s*,\s*([^,\s]+)\s*,\s*([^,\s)]+)\s*(?:,\s*[^)]*)?\)$",
                  re.IGNORECASE)


def _channel(text: str) -> int:
    if text.endswith("%"):
        return round(max(0.0, min(100.0, float(text[:-1]))) * 255 / 100)
    return max(0, min(255, round(float(text))))


def parse(text: str) -> str | None:
    t = text.strip()
    low = t.lower()
    if low in ("none", "transparent"):
        return None
    m = _HEX.match(t)
    if m:
        h = m.group(1).lower()
        return "#" + ("".join(c * 2 for c in h) if len(h) == 3 else h)
    m = _RGB.match(t)
    if m:
        try:
            return "#" + "".join(f"{_channel(g):02x}" for g in m.groups())
        except ValueError:
            raise ValueError(f"not a colour: {text!r}") from None
    if re.fullmatch(r"[a-z]+", low):
        import svgelements

        v = svgelements.Color.parse_color_lookup(low)
        if low == "black" or v != 0xFF:          # the table answers black for what it lacks
            return f"#{(v >> 24) & 0xFF:02x}{(v >> 16) & 0xFF:02x}{(v >> 8) & 0xFF:02x}"
    raise ValueError(f"not a colour: {text!r} (use a name such as red, #rgb, #rrggbb or "
                     f"rgb(r, g, b))")


def linear_rgb(colour: str) -> list[float]:
    """The linear (not gamma-encoded) sRGB channels of '#rrggbb', 0 to 1."""
    lin = []
    for k in (1, 3, 5):
        c = int(colour[k:k + 2], 16) / 255.0
        lin.append(c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4)
    return lin


def lightness(colour: str) -> float:
    """CIE L* of '#rrggbb', 0 (black) to 100 (white): how light a pen draws."""
    lin = linear_rgb(colour)
    y = 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]
    return 116.0 * (y ** (1 / 3) if y > 216 / 24389 else (24389 / 27 * y + 16) / 116) - 16.0
