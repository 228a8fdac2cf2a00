"""DXF TEXT, ATTRIB and MTEXT -> polylines in the entity's frame, in single-stroke Hershey fonts
(`text.py`).

Size: a DXF text height is taken as the font size (the em, as an SVG's font-size is): the
text of a 5 mm TEXT lies within the 5 mm body of the font (capitals
5 x text.CAP_HEIGHT = 3.3 mm tall, descenders below the baseline included), and is as wide as
`text.layout(content, 5).advance`. CAD programs draw the capitals the full height (1.52 times
larger): SIZE_PER_HEIGHT = 1 / text.CAP_HEIGHT would draw that. Alignment (top, middle) and
MTEXT's line pitch follow the capitals actually drawn.

- TEXT/ATTRIB: insertion point, height, rotation, width factor, oblique angle, backward and
  upside-down flags, horizontal alignment (left, center, right, aligned, middle, fit: the last
  two between the insertion and alignment points) and vertical alignment (baseline, bottom,
  middle, top) about the alignment point; in the entity's OCS.
- Content: `%%d`, `%%p`, `%%c` (degree, plus-minus, diameter; `%%u`, `%%o` dropped) and
  `\\U+XXXX` (a unicode character, as DXF before R2007 writes them) in TEXT and MTEXT.
- MTEXT: the plain text (formatting codes dropped; \\P breaks lines), char height, insertion
  point, rotation or text direction, extrusion, attachment point (top/middle/bottom x
  left/center/right), the line spacing factor (baselines 5/3 x the capitals' height apart, as
  CAD programs space them) and the reference width (lines wrapped at spaces to fit it).
- Fonts: the text style's font file names the Hershey font (txt, simplex, romans -> rowmans;
  romand, isoct -> rowmand; romant, romanc, complex -> rowmant; italic -> timesi; script ->
  scripts; gothic -> gothiceng; a TrueType family name as CSS names it, e.g. arial ->
  futural). A style the STYLE table lacks or a font none of these names is drawn in the
  default font (futural), counted and named in one warning; a text in "Standard" when the
  table lacks it, as files without tables write them, is in the Standard font txt.
"""

from __future__ import annotations

import math
import re
from typing import Callable

import numpy as np

from vplotter.inputs import text as hershey
from vplotter.inputs.dxf_geom import entry

SIZE_PER_HEIGHT = 1.0       # Hershey font size (em) per DXF text height (see above)
LINE_PITCH = 5.0 / 3.0      # MTEXT baseline distance / capital height at line spacing factor 1
DEFAULT_HEIGHT = 2.5        # a TEXT of height 0 whose style has no fixed height
SHX = {"txt": "rowmans", "simplex": "rowmans", "romans": "rowmans", "monotxt": "rowmans",
       "isocp": "rowmans", "isocpeur": "rowmans", "iso": "rowmans", "romand": "rowmand",
       "isoct": "rowmand", "isocteur": "rowmand", "romant": "rowmant", "romanc": "rowmant",
       "complex": "rowmant", "italic": "timesi", "italicc": "timesi", "italict": "timesi",
       "scripts": "scripts", "scriptc": "scriptc", "gothice": "gothiceng",
       "gothicg": "gothicger", "gothici": "gothicita", "greeks": "greeks", "greekc": "greekc",
       "cyrillic": "cyrillic", "cyriltlc": "cyrilc_1"}
_UNICODE = re.compile(r"\\U\+([0-9A-Fa-f]{4})")
_MTEXT_SPECIAL = {"\\": "\\\\", "{": "\\{", "}": "\\}"}     # kept literal in MTEXT


def unescape(text: str, mtext: bool = False) -> str:
    """DXF's \\U+XXXX escapes -> the characters (in MTEXT: a backslash or brace escaped again,
    for its parser); an escaped backslash (MTEXT's \\\\) is left as it is."""
    def char(m: re.Match) -> str:
        c = chr(int(m.group(1), 16))
        return _MTEXT_SPECIAL.get(c, c) if mtext else c

    if "\\U+" not in text:
        return text
    parts = text.split("\\\\") if mtext else [text]
    return ("\\\\" if mtext else "").join(_UNICODE.sub(char, p) for p in parts)


def _known(stem: str) -> bool:
    return stem in SHX or stem in hershey.FAMILIES or stem in hershey.font_names()


class TextWriter:
    """Lays out the text entities of one file (fonts looked up once per style) and gives one
    warning for characters the fonts lack."""

    def __init__(self, path: str, doc, warn: Callable[[str], None]):
        self.path, self.doc, self.warn = path, doc, warn
        self.fonts: dict[str, tuple[str, str | None]] = {}   # style -> (font, replaced)
        self.replaced: dict[str, int] = {}      # style or font not found -> texts in it
        self.missing: set[str] = set()
        self.subs: dict[str, str] = {}
        self.used: set[str] = set()
        self.chars = 0

    def font(self, e) -> str:
        """The Hershey font of the entity's text style (the default one for a style the table
        lacks or a font not known, counted for the warning)."""
        name = e.dxf.get("style", "Standard") or "Standard"
        if name not in self.fonts:
            style = entry(self.doc.styles, name)
            if style is None and name.casefold() != "standard":
                self.fonts[name] = (hershey.DEFAULT_FONT, name)
            else:
                file = (style.dxf.get("font", "") if style is not None else "") or "txt"
                stem = file.replace("\\", "/").rsplit("/", 1)[-1].strip().lower()
                stem = stem[:-4] if stem.endswith((".shx", ".ttf", ".otf", ".lff", ".cxf",
                                                   ".pfb", ".shp")) else stem
                self.fonts[name] = ((SHX.get(stem) or hershey.pick_font(stem), None)
                                    if _known(stem) else (hershey.DEFAULT_FONT, stem or file))
        font, replaced = self.fonts[name]
        if replaced is not None:
            self.replaced[replaced] = self.replaced.get(replaced, 0) + 1
        self.used.add(font)
        return font

    def layout(self, line: str, size: float, font: str, anchor: str = "start"):
        self.chars += len(line)
        hershey.too_many(self.chars, self.path)
        shape = hershey.layout(line, size, font=font, anchor=anchor)
        self.missing |= shape.missing
        self.subs.update(shape.substituted)
        return shape

    def polylines(self, e, t: str) -> tuple[np.ndarray, list[np.ndarray]]:
        """(frame 4x4 row vectors: the text's plane -> the block's coordinates, [(K, 2)])."""
        if t == "MTEXT":
            return self.mtext(e)
        return self.text(e)

    def finish(self) -> None:
        if self.replaced:
            n = sum(self.replaced.values())
            self.warn(f"{self.path}: warning: {n} text{'s' if n > 1 else ''} in styles or fonts "
                      f"not found ({', '.join(self.replaced)}): drawn in the default "
                      f"single-stroke font ({hershey.DEFAULT_FONT})")
        msg = hershey.missing_warning(self.path, self.missing, self.subs,
                                      ", ".join(sorted(self.used)))
        if msg:
            self.warn(msg)

    # -------------------------------------------------------------- TEXT, ATTRIB
    def text(self, e) -> tuple[np.ndarray, list[np.ndarray]]:
        d = e.dxf
        content = unescape(e.plain_text())
        h = float(d.get("height", 0.0))
        if not h > 0:
            style = entry(self.doc.styles, d.get("style", "Standard"))
            h = float(style.dxf.get("height", 0.0)) if style is not None else 0.0
            h = h if h > 0 else DEFAULT_HEIGHT
        font = self.font(e)
        size = h * SIZE_PER_HEIGHT
        cap = size * hershey.CAP_HEIGHT
        shape = self.layout(content, size, font)
        wf = float(d.get("width", 1.0)) or 1.0
        shear = math.tan(math.radians(float(d.get("oblique", 0.0))))
        halign, valign = int(d.get("halign", 0)), int(d.get("valign", 0))
        p1 = np.array(list(d.get("insert", (0, 0, 0))), dtype=float)
        p2 = np.array(list(d.get("align_point", p1)), dtype=float)
        rot = math.radians(float(d.get("rotation", 0.0)))
        a = np.array([[wf, 0.0], [shear, 1.0]])          # row vectors: (x, y) @ a
        width = shape.advance * wf
        he, k = cap, 1.0
        anchor = p2
        if halign in (3, 5) and width > 0:               # aligned, fit: from p1 to p2
            span = p2[:2] - p1[:2]
            length = float(np.hypot(*span))
            if length > 0:
                rot = math.atan2(span[1], span[0])
                k = length / width
                a = a @ (np.diag([k, k]) if halign == 3 else np.diag([k, 1.0]))
                k = k if halign == 3 else 1.0
                he = cap * k
            width = length
            anchor = p1
        elif halign == 0 and valign == 0:
            anchor = p1
        dx = {0: 0.0, 1: -width / 2, 2: -width, 3: 0.0, 4: -width / 2, 5: 0.0}.get(halign, 0.0)
        descent = hershey.metrics(font).descent * size * k
        dy = {0: 0.0, 1: -descent, 2: -he / 2, 3: -he}.get(valign, 0.0)
        if halign == 4:
            dy = -he / 2
        flags = int(d.get("text_generation_flag", 0))
        flip = np.diag([-1.0 if flags & 2 else 1.0, -1.0 if flags & 4 else 1.0])
        polys = [((p @ a) + (dx, dy)) @ flip for p in shape.polylines]
        c, s = math.cos(rot), math.sin(rot)
        place = np.array([[c, s, 0, 0], [-s, c, 0, 0], [0, 0, 1, 0],
                          [anchor[0], anchor[1], anchor[2], 1]], dtype=float)
        o = e.ocs()
        ocs = np.eye(4)
        ocs[0, :3], ocs[1, :3], ocs[2, :3] = tuple(o.ux), tuple(o.uy), tuple(o.uz)
        return place @ ocs, polys

    # -------------------------------------------------------------- MTEXT
    def mtext(self, e) -> tuple[np.ndarray, list[np.ndarray]]:
        d = e.dxf
        h = float(d.get("char_height", DEFAULT_HEIGHT)) or DEFAULT_HEIGHT
        font = self.font(e)
        size = h * SIZE_PER_HEIGHT
        cap = size * hershey.CAP_HEIGHT
        ap = int(d.get("attachment_point", 1))
        ap = ap if 1 <= ap <= 9 else 1
        anchor = ("start", "middle", "end")[(ap - 1) % 3]
        from ezdxf.tools.text import plain_mtext     # the parser that knows every code

        content = plain_mtext(unescape(e.text, mtext=True), split=False)
        lines = self.wrap(content, size, font, float(d.get("width", 0.0)))
        pitch = LINE_PITCH * cap * float(d.get("line_spacing_factor", 1.0) or 1.0)
        total = cap + (len(lines) - 1) * pitch
        first = {0: -cap, 1: total / 2 - cap, 2: total - cap}[(ap - 1) // 3]
        polys: list[np.ndarray] = []
        for k, line in enumerate(lines):
            shape = self.layout(line, size, font, anchor)
            y = first - k * pitch
            polys.extend(p + (0.0, y) for p in shape.polylines)
        return _m44(e.ucs().matrix), polys

    def wrap(self, content: str, size: float, font: str, width: float) -> list[str]:
        """The lines of an MTEXT: its line breaks, and breaks at spaces to keep each line
        within `width` (0: no wrapping; a word longer than the width stands alone)."""
        out: list[str] = []
        for para in content.split("\n"):
            if not width > 0:
                out.append(para)
                continue
            words = para.split(" ")
            space = hershey.glyph(font, " ")[1] * size
            line, used = words[0], self.advance(words[0], size, font)
            for word in words[1:]:
                w = self.advance(word, size, font)
                if used + space + w > width * (1 + 1e-9) and line:
                    out.append(line)
                    line, used = word, w
                else:
                    line, used = f"{line} {word}", used + space + w
            out.append(line)
        return out

    @staticmethod
    def advance(word: str, size: float, font: str) -> float:
        return sum(hershey.glyph(font, ch)[1] for ch in word) * size


def _m44(m) -> np.ndarray:
    return np.array([list(m.get_row(i)) for i in range(4)], dtype=float)
