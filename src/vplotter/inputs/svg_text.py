"""SVG text -> strokes in single-stroke Hershey fonts (`text.py`): <text> with nested <tspan>,
<a> and <textPath> (drawn on a straight line), and Inkscape 0.92's flowed text (<flowRoot>)
in a rect frame.

What is followed (docs/drawing-files.md, "Text"):
- font-size (px, pt, mm ..., em/ex/% of the parent's, the CSS keywords), font-family (generic
  names and common families map to Hershey fonts: text.FAMILIES; unknown: futural),
  font-weight (bold: futuram/timesrb), font-style (italic: timesi), text-anchor per text chunk,
  letter-spacing: attributes, style attributes and <style> rules, inherited from ancestors;
- x, y, dx, dy lists on <text> and <tspan> (the innermost element that gives a value for a
  character wins; an absolute x or y starts a new text chunk, which text-anchor aligns);
- white space as browsers show it: newlines and tabs are spaces, runs of spaces are one,
  leading and trailing spaces go (xml:space="preserve" keeps every space);
- the element's transform and every ancestor's, display and visibility per tspan, layers.
Not followed (drawn as if absent, one note): rotate, textLength, baseline-shift, a textPath's
path. The font size is the em of text.py: capitals are 0.656 of it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from vplotter.inputs import svg_style as st
from vplotter.inputs import text as fonts
from vplotter.inputs.strokes import Stroke

DEFAULT_SIZE = 16.0          # px: CSS "medium", the font size when nothing says one
ABSOLUTE_SIZES = {"xx-small": 9.0, "x-small": 10.0, "small": 13.0, "medium": 16.0,
                  "large": 18.0, "x-large": 24.0, "xx-large": 32.0, "xxx-large": 48.0}
INLINE = {"tspan", "a", "textPath", "flowSpan"}
_RELATIVE = re.compile(r"\s*([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)\s*"
                       r"(rem|em|ex|%)\s*$", re.I)


# ------------------------------------------------------------------ inherited properties
def _relative(text: str, em: float, ref_pct: float | None) -> float:
    """A length that may be relative to the font size (em, ex, %: of ref_pct)."""
    m = _RELATIVE.match(text)
    if m:
        v, unit = float(m.group(1)), m.group(2).lower()
        if unit == "%" and ref_pct is not None:
            return v * ref_pct / 100.0
        if unit != "%":
            return v * {"rem": DEFAULT_SIZE, "em": em, "ex": em / 2}[unit]
    return st.length(text) or 0.0


def font_size(text: str, parent: float) -> float:
    v = text.strip().lower()
    if v in ABSOLUTE_SIZES:
        return ABSOLUTE_SIZES[v]
    if v in ("larger", "smaller"):
        return parent * 1.2 if v == "larger" else parent / 1.2
    size = _relative(v, parent, parent)
    if not (size >= 0 and math.isfinite(size)):
        raise st.BadValue(f"font-size {text.strip()!r} must not be negative")
    return size


def inherit(parent: tuple, own: dict[str, str]) -> tuple:
    """The text properties an element has: its own declared ones over its parent's. font-size
    and letter-spacing are computed here (user units), the others kept as written. A value
    that does not parse (font-size: calc(...), a negative size) is dropped, as CSS drops an
    invalid declaration: the parent's value stays."""
    d = dict(parent)
    size = d.get("font-size", DEFAULT_SIZE)
    v = own.get("font-size")
    if v is not None and v != "inherit":
        try:
            d["font-size"] = size = font_size(v, size)
        except (st.BadValue, ValueError):
            pass
    for prop in ("font-family", "font-weight", "font-style", "text-anchor", "line-height"):
        if own.get(prop) not in (None, "inherit"):
            d[prop] = own[prop]
    v = own.get("letter-spacing")
    if v is not None and v != "inherit":
        try:
            d["letter-spacing"] = 0.0 if v.strip() == "normal" else _relative(v, size, size)
        except (st.BadValue, ValueError):
            pass
    return tuple(d.items())


@dataclass(frozen=True)
class Props:
    size: float
    font: str                 # the Hershey font
    anchor: str
    spacing: float
    line_height: float        # baselines apart in font sizes (flowed text)


def props(font: tuple, cache: dict) -> Props:
    if font in cache:
        return cache[font]
    d = dict(font)
    size = float(d.get("font-size", DEFAULT_SIZE))
    weight = str(d.get("font-weight", "normal"))
    bold = weight in ("bold", "bolder") or (weight.isdigit() and int(weight) >= 600)
    italic = str(d.get("font-style", "normal")) in ("italic", "oblique")
    anchor = str(d.get("text-anchor", "start"))
    lh = str(d.get("line-height", "normal")).strip()
    try:
        height = (fonts.LINE_HEIGHT if lh == "normal" else float(lh[:-1]) / 100
                  if lh.endswith("%") else float(lh))
    except ValueError:
        try:
            height = (st.length(lh) or 0.0) / size if size > 0 else fonts.LINE_HEIGHT
        except st.BadValue:
            height = fonts.LINE_HEIGHT
    p = Props(size, fonts.pick_font(d.get("font-family"), bold, italic),
              anchor if anchor in fonts.ANCHORS else "start",
              float(d.get("letter-spacing", 0.0)), height)
    cache[font] = p
    return p


@dataclass
class Char:
    ch: str
    chain: tuple              # the elements it sits in, outermost (<text>) first
    p: Props
    shown: bool               # visibility
    preserve: bool            # xml:space="preserve"


# ------------------------------------------------------------------ the reader's helper
class TextReader:
    """Draws the text elements of one file into the SVG reader's strokes; `finish` gives the
    one warning about missing glyphs and the one about text it could not draw."""

    def __init__(self, reader) -> None:
        self.r = reader
        self.missing: set[str] = set()
        self.subs: dict[str, str] = {}
        self.fonts: set[str] = set()
        self.unsupported: set[str] = set()
        self.cache: dict = {}
        self.chars = 0

    def finish(self) -> None:
        r = self.r
        msg = fonts.missing_warning(r.path, self.missing, self.subs,
                                    ", ".join(sorted(self.fonts)))
        if msg:
            r.warn(msg)
        if self.unsupported:
            r.warn(f"{r.path}: warning: text drawn without {', '.join(sorted(self.unsupported))}")
        n = r.skipped["text"]
        if n:
            r.warn(f"{r.path}: warning: {n} flowed text element{'s' if n > 1 else ''} "
                   f"(flowRoot) skipped: the frame is not a plain rect; convert it to text "
                   f"or paths")

    # -------------------------------------------------------------- characters
    def collect(self, node, font: tuple, shown: bool, preserve: bool, chain: tuple,
                out: list[Char], elements: list) -> None:
        r = self.r
        elements.append(node)
        p = props(font, self.cache)
        for part in node.text:
            if isinstance(part, str):
                out.extend(Char(ch, chain, p, shown, preserve) for ch in part)
                continue
            child = part
            if not child.svg or child.tag not in INLINE:
                continue
            own = r.style.own_style(r.sheet, child.tag, child.attrs)
            if own.get("display") == "none":
                continue
            vis = own.get("visibility", "inherit")
            f = inherit(font, own) if any(prop in own for prop in st.TEXT_PROPS) else font
            if child.tag == "textPath":
                self.unsupported.add("its path (textPath: on a straight line)")
            self.collect(child, f, shown if vis not in ("visible", "hidden", "collapse")
                         else vis == "visible",
                         child.attrs.get("xml:space", "preserve" if preserve else "") == "preserve",
                         chain + (child,), out, elements)

    @staticmethod
    def collapse(chars: list[Char]) -> list[Char]:
        """White space as a browser shows it (see the module notes)."""
        kept: list[Char] = []
        space = True                            # leading spaces go
        for c in chars:
            blank = c.ch in " \t\n\r"
            if c.preserve:
                if blank:
                    c.ch = " "
                kept.append(c)
                space = c.ch == " "
                continue
            if blank:
                if space:
                    continue
                c.ch = " "
            space = blank
            kept.append(c)
        while kept and kept[-1].ch == " " and not kept[-1].preserve:
            kept.pop()
        return kept

    def lengths(self, node, name: str, ref: float) -> list[float]:
        text = node.attrs.get(name)
        if text is None or not text.strip():
            return []
        try:
            return [st.length(v, ref) for v in re.split(r"[\s,]+", text.strip())]
        except st.BadValue as e:
            raise self.r.err(node, f"{name}: {e}") from None

    # -------------------------------------------------------------- <text>
    def draw(self, node, ctx) -> None:
        if node.tag == "flowRoot":
            self.flow(node, ctx)
            return
        chars: list[Char] = []
        elements: list = []
        preserve = node.attrs.get("xml:space") == "preserve"
        self.collect(node, ctx.font, ctx.vis == "visible", preserve, (node,), chars, elements)
        kept = self.collapse(chars)
        if not kept:
            return
        n = len(kept)
        at: dict[int, list[int]] = {}
        for k, c in enumerate(kept):
            for el in c.chain:
                at.setdefault(id(el), []).append(k)
        xs: list[float | None] = [None] * n
        ys: list[float | None] = [None] * n
        dxs, dys = [0.0] * n, [0.0] * n
        vw, vh = ctx.vp
        for el in elements:                      # outer first: the innermost value wins
            idx = at.get(id(el), [])
            for name, arr, ref in (("x", xs, vw), ("y", ys, vh), ("dx", dxs, vw),
                                   ("dy", dys, vh)):
                for k, v in zip(idx, self.lengths(el, name, ref)):
                    arr[k] = v
            for name in ("rotate", "textLength"):
                if el.attrs.get(name):
                    self.unsupported.add(name)
        polys = self.place(kept, xs, ys, dxs, dys)
        if not polys and not any(c.shown for c in kept):
            self.r.skipped["hidden"] += 1
            return
        self.emit(node, ctx, polys)

    def place(self, kept: list[Char], xs, ys, dxs, dys) -> list[np.ndarray]:
        """Glyphs in user units (y down) at their text positions, each chunk anchored."""
        out: list[np.ndarray] = []
        chunk: list[np.ndarray] = []
        x = y = x0 = x_end = 0.0
        anchor = "start"

        def close() -> None:
            shift = {"start": 0.0, "middle": -(x_end - x0) / 2, "end": -(x_end - x0)}[anchor]
            out.extend(q + (shift, 0.0) for q in chunk)
            chunk.clear()

        for k, c in enumerate(kept):
            if k == 0 or xs[k] is not None or ys[k] is not None:
                close()
                anchor = c.p.anchor
                x = xs[k] if xs[k] is not None else x
                y = ys[k] if ys[k] is not None else y
                x0 = x + dxs[k]
            x += dxs[k]
            y += dys[k]
            glyph, adv, what = fonts.glyph(c.p.font, c.ch)
            self.note(c, what)
            if c.shown:
                s = c.p.size
                chunk.extend(np.column_stack([x + g[:, 0] * s, y - g[:, 1] * s]) for g in glyph)
            x += adv * c.p.size
            x_end = x
            x += c.p.spacing
        close()
        return out

    def note(self, c: Char, what: str | None) -> None:
        self.chars += 1
        if self.chars > fonts.MAX_CHARS:
            fonts.too_many(self.chars, self.r.path)
        self.fonts.add(c.p.font)
        if what == "missing":
            self.missing.add(c.ch)
        elif what is not None:
            self.subs[c.ch] = what

    def emit(self, node, ctx, polys: list[np.ndarray]) -> None:
        """The polylines (user units of the element) as strokes in G-code mm."""
        r = self.r
        m = ctx.m @ r.transform(node)
        source = ctx.use or node
        pen, colour = text_paint(r, node, ctx)
        for q in polys:
            pts = q @ m[:2, :2].T + m[:2, 2]
            if np.all(np.isfinite(pts)):
                r.strokes.append(Stroke(pts, source.num, 0, None, ctx.layer, source.src(),
                                        pen, colour))

    # -------------------------------------------------------------- <flowRoot>
    def flow(self, node, ctx) -> None:
        """Inkscape 0.92 flowed text: each flowPara from the top-left of the flowRegion's rect,
        words wrapped at its width, baselines line-height apart (the first one the font's
        ascent below the top); text-anchor middle/end centre or right-align the lines."""
        r = self.r
        frame = self.frame(node, ctx)
        if frame is None:
            r.skipped["text"] += 1
            return
        fx, fy, fw, _ = frame
        paras = []
        for child in node.children:
            if child.svg and child.tag == "flowDiv":
                paras.extend(c for c in child.children if c.svg and c.tag == "flowPara")
            elif child.svg and child.tag == "flowPara":
                paras.append(child)
        polys: list[np.ndarray] = []
        y = fy
        first = True
        any_chars = False
        for para in paras:
            own = r.style.own_style(r.sheet, para.tag, para.attrs)
            if own.get("display") == "none":
                continue
            font = inherit(ctx.font, own) if any(q in own for q in st.TEXT_PROPS) else ctx.font
            vis = own.get("visibility", "inherit")
            shown = vis == "visible" if vis in ("visible", "hidden", "collapse") else \
                ctx.vis == "visible"
            chars: list[Char] = []
            self.collect(para, font, shown, False, (para,), chars, [])
            kept = self.collapse(chars)
            any_chars = any_chars or bool(kept)
            p = props(font, self.cache)
            for k, line in enumerate(self.wrap(kept, fw) or [[]]):
                y += (fonts.metrics(p.font).ascent if first else p.line_height) * p.size
                first = False
                if not line:
                    continue
                x = {"start": fx, "middle": fx + fw / 2, "end": fx + fw}[p.anchor]
                xs: list[float | None] = [x] + [None] * (len(line) - 1)
                ys: list[float | None] = [y] + [None] * (len(line) - 1)
                zero = [0.0] * len(line)
                polys.extend(self.place(line, xs, ys, zero, zero))
        if any_chars and not polys and not ctx.vis == "visible":
            r.skipped["hidden"] += 1
        self.emit(node, ctx, polys)

    def frame(self, node, ctx):
        """(x, y, width, height) of the flowRegion's rect, or None when it is not that."""
        region = next((c for c in node.children if c.svg and c.tag == "flowRegion"), None)
        if region is None or region.attrs.get("transform"):
            return None
        shapes = [c for c in region.children if c.svg]
        if len(shapes) != 1 or shapes[0].tag != "rect" or shapes[0].attrs.get("transform"):
            return None
        rect = shapes[0]
        vw, vh = ctx.vp
        L = self.r.length
        return L(rect, "x", vw), L(rect, "y", vh), L(rect, "width", vw), L(rect, "height", vh)

    @staticmethod
    def wrap(kept: list[Char], width: float) -> list[list[Char]]:
        """Greedy word wrap at spaces: lines no wider than width where a word allows."""
        lines: list[list[Char]] = []
        line: list[Char] = []
        w = 0.0
        last_space = -1
        for c in kept:
            adv = fonts.glyph(c.p.font, c.ch)[1] * c.p.size + c.p.spacing
            if c.ch == " ":
                last_space = len(line)
            line.append(c)
            w += adv
            if w > width and last_space > 0:
                lines.append(line[:last_space])
                line = line[last_space + 1:]
                w = sum(fonts.glyph(q.p.font, q.ch)[1] * q.p.size + q.p.spacing for q in line)
                last_space = -1
        if line:
            lines.append(line)
        return lines


def text_paint(reader, node, ctx) -> tuple[str | None, str | None]:
    """(pen, colour) of a text element's strokes: the colour it is filled with (what text shows),
    else its stroke colour, else the one pen."""
    from vplotter.inputs import svg_paint

    fill, stroke = svg_paint.pens(reader, node, ctx)
    return fill or stroke or (None, None)
