"""Text in single-stroke Hershey fonts: a string -> polylines a pen draws once (no outlines).

The glyphs come from the Hershey-Fonts package (`HersheyFonts`, MIT; the font data are
Dr. A. V. Hershey's, in the Usenet distribution's ASCII-ordered .jhf form): 32 fonts of the 96
printable ASCII characters each (docs/design.md says why this package).

Sizes: `size` is the font size as SVG's font-size means it, the em. One em is 32 Hershey units:
a Hershey font's body runs from 25 units above the baseline (the tops of brackets) to 7 below
(the descender), so the body fills the em as a usual font's does (ascent 0.78 em, descent
0.22 em), and the cap height (21 units, the line Hershey calls the cap line) is
CAP_HEIGHT = 21/32 = 0.656 of the font size. Script fonts descend 12 units (0.375 em).

Coordinates: y up, the baseline at y = 0, the anchor point at x = 0, in the unit of `size`.
Characters without a glyph: an accented letter is drawn as its base letter (é as e, through
Unicode decomposition), anything else is left blank (the width of '?') and named in `missing`;
white space (tab, no-break space) is a space.
"""

from __future__ import annotations

import unicodedata
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

EM_UNITS = 32.0          # Hershey units per em (font size)
BASELINE = 9.0           # the baseline in Hershey's y-down glyph coordinates
CAP_HEIGHT = 21.0 / EM_UNITS     # cap height / font size
DEFAULT_FONT = "futural"
ANCHORS = ("start", "middle", "end")
LINE_HEIGHT = 1.25       # default distance of baselines, in font sizes (ems)

# CSS generic families (and a few common names) -> Hershey font: (regular, bold, italic,
# bold italic). The package has no fixed-width Hershey font: monospace is drawn in futural.
_SANS = ("futural", "futuram", "futural", "futuram")
_SERIF = ("timesr", "timesrb", "timesi", "timesib")
_SCRIPT = ("scripts", "scriptc", "scripts", "scriptc")
_GOTHIC = ("gothiceng", "gothiceng", "gothiceng", "gothiceng")
FAMILIES = {
    "sans-serif": _SANS, "sans": _SANS, "arial": _SANS, "helvetica": _SANS, "verdana": _SANS,
    "dejavu sans": _SANS, "liberation sans": _SANS, "system-ui": _SANS, "futura": _SANS,
    "monospace": _SANS, "courier": _SANS, "courier new": _SANS,
    "serif": _SERIF, "times": _SERIF, "times new roman": _SERIF, "georgia": _SERIF,
    "dejavu serif": _SERIF, "liberation serif": _SERIF,
    "cursive": _SCRIPT, "script": _SCRIPT,
    "fantasy": _GOTHIC, "gothic": _GOTHIC,
    # the EMS/Inkscape "Hershey Text" family names
    "hershey sans 1-stroke": _SANS, "hershey sans med": ("futuram",) * 4,
    "hershey serif med": _SERIF, "hershey script 1-stroke": _SCRIPT,
    "hershey gothic english": _GOTHIC,
}


@dataclass
class TextShape:
    polylines: list[np.ndarray]      # (K, 2) each, y up, baseline y = 0, anchor at x = 0
    advance: float                   # total width (the pen's advance over the whole text)
    missing: set[str] = field(default_factory=set)        # characters without a glyph
    substituted: dict[str, str] = field(default_factory=dict)   # 'é' -> 'e' drawn instead


@dataclass(frozen=True)
class FontMetrics:
    """A font's extent in font sizes (ems): every glyph lies within y in [descent, ascent]
    (descent < 0), and within its own advance in x."""

    ascent: float
    descent: float


def font_names() -> list[str]:
    """The Hershey fonts the package has (futural, futuram, timesr, scripts, gothiceng, ...)."""
    return sorted(_package().default_font_names)


@lru_cache(maxsize=1)
def _package():
    try:
        from HersheyFonts import HersheyFonts
    except ImportError as e:           # a broken install: say what is missing
        raise RuntimeError("the Hershey-Fonts package is not installed "
                           "(pip install Hershey-Fonts)") from e
    return HersheyFonts()


@lru_cache(maxsize=None)
def _font(name: str) -> dict[str, tuple[tuple[np.ndarray, ...], float]]:
    """char -> (polylines in ems, y up, the glyph's left side at x = 0; advance in ems). A
    glyph whose strokes reach past its left or right side (italic and script fonts: the tail
    of a j, by up to 8 units) is widened to hold them, so that a line's strokes always lie
    within [0, advance]."""
    pkg = _package()
    if name not in pkg.default_font_names:
        raise ValueError(f"unknown font {name!r} (fonts: {', '.join(font_names())})")
    from HersheyFonts import HersheyFonts

    f = HersheyFonts()
    f.load_default_font(name)
    glyphs = {}
    for ch, g in f.all_glyphs.items():
        if not (32 <= ord(ch) < 127):          # the 96th glyph sits on DEL: not a character
            continue
        xs = [x for s in g.strokes for x, _ in s]
        left = float(min([g.left_offset, *xs]))
        right = float(max([g.left_offset + g.char_width, *xs]))
        polys = tuple(
            np.column_stack([(np.asarray(s, dtype=float)[:, 0] - left) / EM_UNITS,
                             (BASELINE - np.asarray(s, dtype=float)[:, 1]) / EM_UNITS])
            for s in g.strokes if len(s))
        glyphs[ch] = (polys, (right - left) / EM_UNITS)
    return glyphs


def pick_font(family: str | None, bold: bool = False, italic: bool = False) -> str:
    """CSS font-family (a comma-separated list, quotes allowed), weight and style -> a Hershey
    font name: a generic name or known family maps by FAMILIES, a Hershey name is taken as it
    is, anything else is the default font (futural; futuram when bold), never an error."""
    names = set(font_names())
    for part in (family or "").split(","):
        key = part.strip().strip("'\"").strip().lower()
        if key in FAMILIES:          # first: CSS's "cursive" is not the Hershey font cursive
            return FAMILIES[key][int(bold) + 2 * int(italic)]
        if key in names:
            return key
    return _SANS[int(bold)] if bold else DEFAULT_FONT


def metrics(font: str = DEFAULT_FONT) -> FontMetrics:
    """The extent of every glyph of a font, in ems (see FontMetrics)."""
    return _metrics(font)


@lru_cache(maxsize=None)
def _metrics(font: str) -> FontMetrics:
    glyphs = _font(font)
    y = np.concatenate([p[:, 1] for polys, _ in glyphs.values() for p in polys])
    return FontMetrics(float(y.max()), float(y.min()))


def glyph(font: str, ch: str) -> tuple[tuple[np.ndarray, ...], float, str | None]:
    """(polylines in ems, advance in ems, what happened: None drawn, 'missing', or the base
    letter drawn instead) of one character."""
    glyphs = _font(font)
    if ch in glyphs:
        return glyphs[ch][0], glyphs[ch][1], None
    if ch.isspace():
        return (), glyphs[" "][1], None
    base = unicodedata.normalize("NFKD", ch)[:1]
    if base and base != ch and base in glyphs and not base.isspace():
        return glyphs[base][0], glyphs[base][1], base
    return (), glyphs["?"][1], "missing"


MAX_CHARS = 200_000     # characters one drawing may set (1 km of 5 mm letters): beyond, a typo


def too_many(count: int, where: str) -> None:
    """An error once a drawing sets more than MAX_CHARS characters (memory and time stay
    bounded: a 5 MB one-line file would take gigabytes)."""
    if count > MAX_CHARS:
        from vplotter.errors import InputError, unreadable

        raise InputError(f"{where}: error: more than {MAX_CHARS:,} characters of text: too "
                         f"many to draw")


def layout(text: str, size: float, *, font: str = DEFAULT_FONT, anchor: str = "start",
           letter_spacing: float = 0.0) -> TextShape:
    """One line of text at font size `size` (see the module notes for units and axes).
    letter_spacing (in the unit of size) is added between characters: the advance grows by
    (n - 1) x letter_spacing. anchor: which point of the line sits at x = 0 (start, middle,
    end of the advance). A newline is drawn as a space: `layout_lines` makes lines."""
    if anchor not in ANCHORS:
        raise ValueError(f"anchor must be one of {', '.join(ANCHORS)} (got {anchor!r})")
    if not (np.isfinite(size) and np.isfinite(letter_spacing)):
        raise ValueError("size and letter_spacing must be finite")
    polys: list[np.ndarray] = []
    missing: set[str] = set()
    subs: dict[str, str] = {}
    x = 0.0
    for i, ch in enumerate(text):
        if i:
            x += letter_spacing
        glyph_polys, adv, what = glyph(font, ch)
        if what == "missing":
            missing.add(ch)
        elif what is not None:
            subs[ch] = what
        for p in glyph_polys:
            polys.append(p * size + (x, 0.0))
        x += adv * size
    shift = {"start": 0.0, "middle": -x / 2, "end": -x}[anchor]
    if shift:
        polys = [p + (shift, 0.0) for p in polys]
    return TextShape(polys, x, missing, subs)


def _lines(text: str, size: float, font: str, anchor: str, letter_spacing: float,
           line_height: float):
    """(line number from 0, the line's TextShape moved down to its baseline) per text line."""
    for k, line in enumerate(text.splitlines() or [""]):
        shape = layout(line.expandtabs(4), size, font=font, anchor=anchor,
                       letter_spacing=letter_spacing)
        dy = -k * line_height * size
        yield k, TextShape([p + (0.0, dy) for p in shape.polylines], shape.advance,
                           shape.missing, shape.substituted)


def _merged(shapes: list[TextShape]) -> TextShape:
    missing: set[str] = set()
    subs: dict[str, str] = {}
    for sh in shapes:
        missing |= sh.missing
        subs.update(sh.substituted)
    return TextShape([p for sh in shapes for p in sh.polylines],
                     max((sh.advance for sh in shapes), default=0.0), missing, subs)


def layout_lines(text: str, size: float, *, font: str = DEFAULT_FONT, anchor: str = "start",
                 letter_spacing: float = 0.0, line_height: float = LINE_HEIGHT) -> TextShape:
    """Lines (split at newlines) under each other, baselines line_height x size apart, the
    first baseline at y = 0; each line is anchored at x = 0 on its own (start: left-aligned,
    middle: centred, end: right-aligned). advance: the widest line."""
    return _merged([sh for _, sh in _lines(text, size, font, anchor, letter_spacing,
                                           line_height)])


def missing_warning(where: str, missing: set[str], substituted: dict[str, str] | None = None,
                    fonts: str = "") -> str | None:
    """The one warning for characters the font(s) lack: 'where: warning: ...' or None."""
    subs = substituted or {}
    if not missing and not subs:
        return None
    parts = []
    if missing:
        parts.append("no glyph in " + (fonts or "the font") + " for "
                     + ", ".join(repr(c) for c in sorted(missing)) + " (left blank)")
    if subs:
        parts.append(", ".join(f"{c!r}" for c in sorted(subs)) + " drawn without accents ("
                     + ", ".join(f"as {b!r}" for c, b in sorted(subs.items())) + ")")
    return f"{where}: warning: " + "; ".join(parts)


# ------------------------------------------------------------------ text as a drawing
TEXT_FILE_CAP_MM = 10.0      # a .txt file's capitals, before any placement option


def drawing(name: str, text: str, cap_mm: float = TEXT_FILE_CAP_MM, *,
            font: str = DEFAULT_FONT, anchor: str = "start", letter_spacing: float = 0.0,
            line_height: float = LINE_HEIGHT):
    """Lines of text as a Drawing in G-code mm: capitals cap_mm high, the first baseline on
    Y0 with its anchor point at X0, the next lines below. Each stroke's `line` is its text
    line (1, 2, ...). Returns (Drawing, TextShape)."""
    from vplotter.inputs.strokes import Drawing, Stroke

    too_many(len(text), name)
    lines = list(_lines(text, cap_mm / CAP_HEIGHT, font, anchor, letter_spacing, line_height))
    strokes = [Stroke(p, k + 1) for k, sh in lines for p in sh.polylines]
    return Drawing(name, strokes), _merged([sh for _, sh in lines])


def read(path: str, warn) -> object:
    """A plain text file (UTF-8) as a Drawing: `drawing` with the defaults (futural, capitals
    TEXT_FILE_CAP_MM high); characters without a glyph are named in one warning."""
    from vplotter.errors import InputError

    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: error: not UTF-8 text (byte {e.start + 1})") from None
    except OSError as e:
        raise unreadable(path, e, "a text file") from None
    d, shape = drawing(path, text)
    msg = missing_warning(path, shape.missing, shape.substituted, DEFAULT_FONT)
    if msg:
        warn(msg)
    return d
