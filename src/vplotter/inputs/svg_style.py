"""The parts of SVG styling and coordinates that the SVG reader needs: lengths and units,
viewBox + preserveAspectRatio, transforms, and the declared values of `display`,
`visibility` and the paint properties (`fill`, `stroke`, `color`, `fill-rule`, `stop-color`:
style attribute, presentation attribute, simple <style> rules; inheritance is `svg_paint.py`'s).

Matrices are 3x3 numpy arrays acting on column vectors (x, y, 1): x' = a x + c y + e.
"""

from __future__ import annotations

import math
import re

import numpy as np

PX_PER_MM = 96.0 / 25.4
# CSS absolute units in px (user units); em/ex assume the default 16 px font
UNIT_PX = {"": 1.0, "px": 1.0, "mm": PX_PER_MM, "cm": 10 * PX_PER_MM, "in": 96.0,
           "pt": 96.0 / 72.0, "pc": 16.0, "q": PX_PER_MM / 4, "em": 16.0, "ex": 8.0}
UNIT_MM = {"": 25.4 / 96, "px": 25.4 / 96, "mm": 1.0, "cm": 10.0, "in": 25.4, "pt": 25.4 / 72,
           "pc": 25.4 / 6, "q": 0.25}
_NUM = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_LENGTH = re.compile(rf"\s*({_NUM})\s*([a-zA-Z]*|%)\s*$")
_NUMBERS = re.compile(_NUM)
_SEPARATORS = re.compile(r"[\s,]*$")


class BadValue(ValueError):
    """A value that does not parse; the reader turns it into file:line:col: error."""


def _finite(text: str) -> float:
    value = float(text)
    if not abs(value) < 1e12:
        raise BadValue(f"{text} is too large")
    return value


def length(text: str | None, ref: float | None = None) -> float | None:
    """A length in user units (px); `ref` is what 100 % is. None for a missing value."""
    if text is None:
        return None
    m = _LENGTH.match(text)
    if not m:
        raise BadValue(f"{text.strip()!r} is not a length")
    value, unit = _finite(m.group(1)), m.group(2).lower()
    if unit == "%":
        if ref is None:
            raise BadValue(f"{text.strip()!r}: a percentage is not allowed here")
        return value * ref / 100.0
    if unit not in UNIT_PX:
        raise BadValue(f"{text.strip()!r}: unknown unit {unit!r}")
    return value * UNIT_PX[unit]


def length_mm(text: str) -> float:
    """An absolute length (the root's width/height) in mm, exact for mm, cm, in, pt, pc."""
    m = _LENGTH.match(text)
    if not m:
        raise BadValue(f"{text.strip()!r} is not a length")
    unit = m.group(2).lower()
    if unit not in UNIT_MM:
        raise BadValue(f"{text.strip()!r}: unknown unit {unit!r} (mm, cm, in, pt, pc or px)")
    return _finite(m.group(1)) * UNIT_MM[unit]


def numbers(text: str | None) -> list[float]:
    """A list of numbers separated by white space and/or commas (points, viewBox)."""
    if not text:
        return []
    if not _SEPARATORS.match(_NUMBERS.sub(" ", text)):
        raise BadValue(f"{text.strip()[:40]!r} is not a list of numbers")
    return [_finite(v) for v in _NUMBERS.findall(text)]


def view_box(text: str | None) -> tuple[float, float, float, float] | None:
    if text is None or not text.strip():
        return None
    v = numbers(text)
    if len(v) != 4:
        raise BadValue(f"viewBox needs 4 numbers (got {text.strip()!r})")
    if not (v[2] > 0 and v[3] > 0):
        raise BadValue(f"viewBox width and height must be above 0 (got {text.strip()!r})")
    return v[0], v[1], v[2], v[3]


def viewport_matrix(vb: tuple[float, float, float, float], w: float, h: float,
                    par: str | None) -> np.ndarray:
    """viewBox -> viewport (0..w, 0..h) as SVG defines preserveAspectRatio
    (default xMidYMid meet; 'none' stretches; 'slice' covers)."""
    vx, vy, vw, vh = vb
    words = (par or "").split()
    if words[:1] == ["defer"]:
        words = words[1:]
    align = words[0] if words else "xMidYMid"
    slice_ = len(words) > 1 and words[1] == "slice"
    if align == "none":
        sx, sy = w / vw, h / vh
        tx, ty = -vx * sx, -vy * sy
    else:
        if not re.fullmatch(r"x(Min|Mid|Max)Y(Min|Mid|Max)", align):
            raise BadValue(f"preserveAspectRatio {par!r} is not valid")
        s = max(w / vw, h / vh) if slice_ else min(w / vw, h / vh)
        sx = sy = s
        fx = {"Min": 0.0, "Mid": 0.5, "Max": 1.0}[align[1:4]]
        fy = {"Min": 0.0, "Mid": 0.5, "Max": 1.0}[align[5:8]]
        tx = -vx * s + fx * (w - vw * s)
        ty = -vy * s + fy * (h - vh * s)
    return np.array([[sx, 0.0, tx], [0.0, sy, ty], [0.0, 0.0, 1.0]])


def translate(x: float, y: float) -> np.ndarray:
    return np.array([[1.0, 0.0, x], [0.0, 1.0, y], [0.0, 0.0, 1.0]])


def transform(text: str | None) -> np.ndarray:
    """The `transform` attribute (svgelements parses it; an unparsable one is the identity,
    as browsers treat it)."""
    if not text or not text.strip():
        return np.eye(3)
    from svgelements import Matrix

    try:
        m = Matrix(text)
    except (ValueError, IndexError, TypeError):
        raise BadValue(f"transform {text.strip()[:60]!r} is not valid") from None
    out = np.array([[m.a, m.c, m.e], [m.b, m.d, m.f], [0.0, 0.0, 1.0]], dtype=float)
    if not np.all(np.isfinite(out)):
        raise BadValue(f"transform {text.strip()[:60]!r} is not finite")
    return out


# ------------------------------------------------------------------ style cascade
STYLE_PROPS = ("display", "visibility", "fill", "stroke", "color", "fill-rule", "stop-color")
CASED = ("fill", "stroke")           # url(#Id) keeps its case; every other value is lower-cased
_COMMENT = re.compile(r"/\*.*?\*/", re.S)
_SIMPLE_SELECTOR = re.compile(r"(\*|[A-Za-z_][\w-]*)?((?:[.#][\w-]+)*)$")
_PART = re.compile(r"([.#])([\w-]+)")


def declarations(text: str | None) -> dict[str, tuple[str, bool]]:
    """'a: b; c: d !important' -> {prop: (value, important)} for the properties we use."""
    out: dict[str, tuple[str, bool]] = {}
    for decl in (text or "").split(";"):
        if ":" not in decl:
            continue
        prop, value = decl.split(":", 1)
        prop = prop.strip().lower()
        if prop not in STYLE_PROPS and prop != "font":
            continue
        value = value.strip()
        important = re.search(r"!\s*important$", value, re.I) is not None
        if important:
            value = value[: value.rindex("!")].strip()
        if prop not in CASED:
            value = value.lower()
        if prop == "font":          # the shorthand (matplotlib writes `font: 10px 'DejaVu Sans'`)
            out.update((k, (v, important)) for k, v in font_shorthand(value).items())
        else:
            out[prop] = (value, important)
    return out


_FONT = re.compile(r"^((?:[a-z-]+|\d+)\s+)*?((?:\d*\.)?\d+(?:px|pt|pc|mm|cm|in|q|em|ex|rem|%)|"
                   r"(?:xx?-)?(?:small|large)|medium|larger|smaller)(?:\s*/\s*(\S+))?\s+(\S.*)$")


def font_shorthand(value: str) -> dict[str, str]:
    """CSS `font: [style] [variant] [weight] [stretch] size[/line-height] family` as its
    longhands (those not given are reset to normal, as CSS does); {} when it does not parse."""
    m = _FONT.match(value.strip())
    if not m:
        return {}
    lead = value.strip()[: m.start(2)].split()
    out = {"font-style": next((w for w in lead if w in ("italic", "oblique")), "normal"),
           "font-weight": next((w for w in lead if w in ("bold", "bolder", "lighter")
                                or w.isdigit()), "normal"),
           "font-size": m.group(2), "font-family": m.group(4)}
    if m.group(3):
        out["line-height"] = m.group(3)
    return out


class StyleSheet:
    """The simple rules of every <style> element: selectors `*`, `tag`, `.class`, `#id` and
    their compounds (`path.a#b`); rules with any other selector are ignored."""

    def __init__(self) -> None:
        # (specificity, order, tag or None, classes, id or None, declarations)
        self.rules: list[tuple] = []

    def add(self, css: str) -> None:
        css = _COMMENT.sub("", css)
        css = re.sub(r"@[^{;]*;", "", css)           # @import, @charset ...
        depth, start, chunks = 0, 0, []
        for i, ch in enumerate(css):                 # top-level "selectors { body }" only
            if ch == "{":
                if depth == 0:
                    sel_end = i
                depth += 1
            elif ch == "}" and depth:
                depth -= 1
                if depth == 0:
                    chunks.append((css[start:sel_end], css[sel_end + 1:i]))
                    start = i + 1
        for selectors, body in chunks:
            if selectors.strip().startswith("@") or "{" in body:
                continue                             # @media and friends
            decls = declarations(body)
            if not decls:
                continue
            for sel in selectors.split(","):
                m = _SIMPLE_SELECTOR.match(sel.strip())
                if not m or not sel.strip():
                    continue
                tag = m.group(1) if m.group(1) not in (None, "*") else None
                parts = _PART.findall(m.group(2))
                classes = frozenset(name for kind, name in parts if kind == ".")
                ids = [name for kind, name in parts if kind == "#"]
                if len(set(ids)) > 1:
                    continue
                spec = (len(ids), len(classes), 1 if tag else 0)
                self.rules.append((spec, len(self.rules), tag, classes, ids[0] if ids else None,
                                   decls))

    def matching(self, tag: str, classes: set[str], id_: str | None):
        for spec, order, rtag, rclasses, rid, decls in self.rules:
            if ((rtag is None or rtag == tag) and rclasses <= classes
                    and (rid is None or rid == id_)):
                yield spec, order, decls


def own_style(sheet: StyleSheet, tag: str, attrs: dict[str, str]) -> dict[str, str]:
    """The declared (not inherited) values of STYLE_PROPS on one element: style attribute over
    <style> rules (by specificity, then order; !important wins) over presentation attributes."""
    out: dict[str, tuple[tuple, str]] = {}
    for prop in STYLE_PROPS:
        if prop in attrs:
            value = attrs[prop].strip()
            out[prop] = ((0,), value if prop in CASED else value.lower())
    if sheet.rules:
        classes = set(attrs.get("class", "").split())
        for spec, order, decls in sheet.matching(tag, classes, attrs.get("id")):
            for prop, (value, important) in decls.items():
                rank = (2 if important else 1, spec, order)
                if prop not in out or rank >= out[prop][0]:
                    out[prop] = (rank, value)
    for prop, (value, important) in declarations(attrs.get("style")).items():
        rank = (3 if important else 1.5,)
        if prop not in out or rank >= out[prop][0]:
            out[prop] = (rank, value)
    return {prop: value for prop, (rank, value) in out.items()}


def sigma_max(m: np.ndarray) -> float:
    """Largest singular value of a 2x2 matrix: how much it stretches a length at most."""
    a, b, c, d = float(m[0, 0]), float(m[0, 1]), float(m[1, 0]), float(m[1, 1])
    s1 = a * a + b * b + c * c + d * d
    det = a * d - b * c
    return math.sqrt(max(0.0, (s1 + math.sqrt(max(0.0, s1 * s1 - 4 * det * det))) / 2))


# ------------------------------------------------------------------ text (svg_text.py)
# the inherited properties text is drawn with; the cascade above reads them as it reads
# display and visibility
TEXT_PROPS = ("font-size", "font-family", "font-weight", "font-style", "text-anchor",
              "letter-spacing", "line-height")
STYLE_PROPS = STYLE_PROPS + TEXT_PROPS
