"""Pens: which pen draws each stroke, in which order the pens come, and the pauses that ask
for them.

`resolve` gives every stroke its pen (`Stroke.pen` becomes the pen's name, `Stroke.colour`
its '#rrggbb', and a pen's `speed_mm_s` caps `Stroke.feed_mm_s`):

- With pens in config.toml (`[pens.NAME]`): a stroke in a layer named like a pen gets that
  pen (the layer is how a person says "this part in that pen"); else a stroke whose own pen
  (an SVG colour as written, a DXF layer, a G-code tool) is named like a pen gets it; else
  its colour goes to the nearest pen by CIEDE2000 colour difference (a warning when that is
  more than FAR_DE: the file asks for a colour nobody owns); a stroke without a colour or a
  pen (a photo, an SVG without colours) is drawn with the darkest pen; a named pen that
  matches nothing and has no colour (a tool `T3` not in [pens]) stays a pen of that name,
  with a warning.
- Without pens in config.toml each distinct colour is a pen, named by the colour as the file
  first writes it (`red`, `#ff8800`); a pen without a colour (`T2`) is a pen of its own; the
  strokes without any pen are the one pen `default`, drawn as black (they join a black pen).

`arrange` groups the strokes by pen, pens light to dark (CIE L*, ties in the order the pens
first appear) or in file order, and orders the strokes within each group only: ordering
never mixes pens. `Breaks` says where the records pause: before each pen's strokes when the
drawing has two pens or more (the first included), for a fresh pen every `refill` mm drawn,
and between layers with --pause-between-layers.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable, Iterable, Iterator

import numpy as np

from vplotter.drawing.pen_options import ORDERS, parse_distance  # noqa: F401
from vplotter.inputs import colour as colours
from vplotter.inputs.gcode import Move, Pause
from vplotter.inputs.gcode_tools import pen_message
from vplotter.inputs.strokes import Stroke

DEFAULT = "default"          # the pen of strokes that name none (without [pens])
BLACK = "#000000"
FAR_DE = 20.0                # CIEDE2000 above this: the nearest pen is not the colour asked for
INSIDE_MM = 1.0              # a refill inside a stroke only with more than this of it left
Warn = Callable[[str], None]


# ------------------------------------------------------------------ colour difference
def lab(colour: str) -> tuple[float, float, float]:
    """CIE L*a*b* (D65) of '#rrggbb'."""
    r, g, b = colours.linear_rgb(colour)
    xyz = (0.4124564 * r + 0.3575761 * g + 0.1804375 * b) / 0.95047, \
          (0.2126729 * r + 0.7151522 * g + 0.0721750 * b), \
          (0.0193339 * r + 0.1191920 * g + 0.9503041 * b) / 1.08883
    fx, fy, fz = (t ** (1 / 3) if t > (6 / 29) ** 3 else t / (3 * (6 / 29) ** 2) + 4 / 29
                  for t in xyz)
    return 116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)


def ciede2000(lab1: tuple[float, float, float], lab2: tuple[float, float, float]) -> float:
    """The CIEDE2000 colour difference (kL = kC = kH = 1), as Sharma, Wu and Dalal (2005)."""
    (l1, a1, b1), (l2, a2, b2) = lab1, lab2
    cb = (math.hypot(a1, b1) + math.hypot(a2, b2)) / 2
    g = 0.5 * (1 - math.sqrt(cb ** 7 / (cb ** 7 + 25.0 ** 7)))
    a1p, a2p = (1 + g) * a1, (1 + g) * a2
    c1p, c2p = math.hypot(a1p, b1), math.hypot(a2p, b2)
    h1p = math.degrees(math.atan2(b1, a1p)) % 360 if c1p else 0.0
    h2p = math.degrees(math.atan2(b2, a2p)) % 360 if c2p else 0.0
    dlp, dcp = l2 - l1, c2p - c1p
    dh = h2p - h1p
    if c1p * c2p == 0:
        dh = 0.0
    elif dh > 180:
        dh -= 360
    elif dh < -180:
        dh += 360
    dhp = 2 * math.sqrt(c1p * c2p) * math.sin(math.radians(dh / 2))
    lbp, cbp = (l1 + l2) / 2, (c1p + c2p) / 2
    if c1p * c2p == 0:
        hbp = h1p + h2p
    elif abs(h1p - h2p) <= 180:
        hbp = (h1p + h2p) / 2
    else:
        hbp = (h1p + h2p + (360 if h1p + h2p < 360 else -360)) / 2
    t = (1 - 0.17 * math.cos(math.radians(hbp - 30)) + 0.24 * math.cos(math.radians(2 * hbp))
         + 0.32 * math.cos(math.radians(3 * hbp + 6)) - 0.20 * math.cos(math.radians(4 * hbp - 63)))
    dtheta = 30 * math.exp(-((hbp - 275) / 25) ** 2)
    rc = 2 * math.sqrt(cbp ** 7 / (cbp ** 7 + 25.0 ** 7))
    sl = 1 + 0.015 * (lbp - 50) ** 2 / math.sqrt(20 + (lbp - 50) ** 2)
    sc, sh = 1 + 0.045 * cbp, 1 + 0.015 * cbp * t
    rt = -math.sin(math.radians(2 * dtheta)) * rc
    return math.sqrt((dlp / sl) ** 2 + (dcp / sc) ** 2 + (dhp / sh) ** 2
                     + rt * (dcp / sc) * (dhp / sh))


def distance(c1: str, c2: str) -> float:
    """How different two '#rrggbb' colours look (CIEDE2000; about 2 is just noticeable)."""
    return ciede2000(lab(c1), lab(c2))


# ------------------------------------------------------------------ resolving
def _colour_of(text: str | None) -> str | None:
    """'#rrggbb' if the text is a colour (a pen named 'red' or '#f80'), else None."""
    if text is None:
        return None
    try:
        return colours.parse(text)
    except ValueError:
        return None


def by_name(owned: Iterable, name: str | None):
    """The owned pen called `name` (exactly, else ignoring case), or None."""
    if name is None:
        return None
    owned = tuple(owned)
    return (next((p for p in owned if p.name == name), None)
            or next((p for p in owned if p.name.lower() == name.lower()), None))


def nearest(owned: Iterable, colour: str):
    """(the owned pen whose colour looks closest to `colour`, the difference)."""
    return min(((p, distance(colour, p.colour)) for p in owned), key=lambda pd: pd[1])


def match(owned: tuple, pen: str | None, colour: str | None, layer: str | None = None):
    """(owned pen, colour difference or None) for a stroke's layer, pen and colour; (None,
    None) for a named pen that matches nothing and has no colour."""
    spec = by_name(owned, layer) or by_name(owned, pen)
    if spec is not None:
        return spec, None
    colour = colour or _colour_of(pen)
    if colour is not None:
        return nearest(owned, colour)
    if pen is None:
        return min(owned, key=lambda p: colours.lightness(p.colour)), None
    return None, None


def width_of(owned: tuple):
    """region -> the `width_mm` of the owned pen its fill colour resolves to (None: no such
    width): the spacing a hatch fill takes when --fill-spacing is not given."""
    def width(region) -> float | None:
        if not owned:
            return None
        spec, _ = match(owned, region.pen, region.colour, region.layer)
        return None if spec is None else spec.width_mm
    return width


def _cap(feed: float | None, speed: float | None) -> float | None:
    if speed is None:
        return feed
    return speed if feed is None else min(feed, speed)


WHITE_MIN = 0xFD          # white: every channel at least this (#fdfdfd and lighter)


def is_white(colour: str | None) -> bool:
    """Whether a colour is the paper's white, which a pen does not show: every channel of its
    '#rrggbb' at least WHITE_MIN (#fdfdfd, #fefefe, #ffffff, `white`). A faint colour with one
    channel lower (#fcfdf8, `lightyellow` #ffffe0) is not white: it is drawn."""
    if colour is None:
        return False
    c = colour if len(colour) == 7 and colour.startswith("#") else _colour_of(colour)
    try:
        return c is not None and all(int(c[k:k + 2], 16) >= WHITE_MIN for k in (1, 3, 5))
    except ValueError:
        return False


def _no_white(strokes: list[Stroke], owned: tuple, warn: Warn, name: str) -> list[Stroke]:
    """The strokes without those in white (is_white: a page's background, a white fill)
    unless a pen in [pens] is white: white does not show on paper. One warning says so."""
    if any(is_white(p.colour) for p in owned):
        return strokes
    keep = [not is_white(st.colour or _colour_of(st.pen)) for st in strokes]
    if all(keep):
        return strokes
    n = keep.count(False)
    warn(f"{name}: warning: {n} stroke{'s' if n > 1 else ''} in white left out (white does not "
         f"show on paper; a white pen in [pens] draws them)")
    return [st for st, k in zip(strokes, keep) if k]


def resolve(strokes: list[Stroke], owned: tuple = (), warn: Warn = lambda m: None,
            name: str = "<input>") -> list[Stroke]:
    """New strokes whose `pen` is the pen that draws them and `colour` its colour (see the
    module's doc); one warning per colour drawn with a far pen and per unknown pen name.
    Strokes in white are left out unless a white pen is owned."""
    strokes = _no_white(strokes, owned, warn, name)
    if not owned:
        return _own_pens(strokes)
    out, done, said = [], {}, set()
    for st in strokes:
        key = (st.layer, st.pen, st.colour)
        if key not in done:
            spec, de = match(owned, st.pen, st.colour, st.layer)
            if spec is None:
                if st.pen not in said:
                    said.add(st.pen)
                    warn(f"{name}: warning: pen {st.pen} is not one of the pens in [pens] "
                         f"({', '.join(p.name for p in owned)}): it is asked for by that name")
                done[key] = (st.pen, BLACK, None)
            else:
                written = st.colour or _colour_of(st.pen)
                if de is not None and de > FAR_DE and written not in said:
                    said.add(written)
                    what = st.pen if st.pen and st.pen != written else written
                    warn(f"{name}: warning: no pen in [pens] is close to colour {what}: drawn "
                         f"with {spec.name} ({spec.colour}, colour difference {de:.0f})")
                done[key] = (spec.name, spec.colour, spec.speed_mm_s)
        pen, colour, speed = done[key]
        out.append(replace(st, pen=pen, colour=colour, feed_mm_s=_cap(st.feed_mm_s, speed)))
    return out


def _own_pens(strokes: list[Stroke]) -> list[Stroke]:
    """Without [pens]: one pen per colour (named as the file first writes it), per colourless
    pen name, and the default pen (black) for strokes without either."""
    keys = []
    names: dict = {}
    for st in strokes:
        colour = st.colour or _colour_of(st.pen)
        key = colour if colour is not None else ("name", st.pen) if st.pen is not None else BLACK
        keys.append(key)
        if st.pen is not None:
            names.setdefault(key, st.pen)
    out = []
    for st, key in zip(strokes, keys):
        colour = key if isinstance(key, str) else BLACK
        out.append(replace(st, pen=names.get(key, DEFAULT), colour=colour))
    return out


# ------------------------------------------------------------------ order
def pens_of(strokes: Iterable[Stroke]) -> list[tuple[str, str]]:
    """(name, colour) of each pen, in the order the strokes first use them."""
    seen: dict = {}
    for st in strokes:
        name = st.pen if st.pen is not None else DEFAULT
        if name not in seen:
            seen[name] = st.colour or _colour_of(st.pen) or BLACK
    return list(seen.items())


def arrange(strokes: list[Stroke], pen_order: str = "light-to-dark",
            order: Callable[[list[Stroke], np.ndarray], list[Stroke]] | None = None,
            start_xy=(0.0, 0.0)) -> list[Stroke]:
    """The strokes grouped by pen in pen order, each group ordered by `order(group, at)` from
    where the previous group ended (None: as they come)."""
    if pen_order not in ORDERS:
        raise ValueError(pen_order)
    groups: dict = {}
    for st in strokes:
        groups.setdefault(st.pen, []).append(st)
    names = list(groups)
    if pen_order == "light-to-dark":
        colour = dict(pens_of(strokes))
        names.sort(key=lambda n: -colours.lightness(colour[n if n is not None else DEFAULT]))
    out: list[Stroke] = []
    at = np.asarray(start_xy, dtype=float)
    for n in names:
        done = order(groups[n], at) if order is not None else groups[n]
        out += done
        if done:
            at = done[-1].pts[-1]
    return out


def table(strokes: list[Stroke]) -> list[dict]:
    """{"name", "colour", "strokes", "drawn_mm"} per pen, in the order the strokes use them."""
    rows = {n: {"name": n, "colour": c, "strokes": 0, "drawn_mm": 0.0}
            for n, c in pens_of(strokes)}
    for st in strokes:
        row = rows[st.pen if st.pen is not None else DEFAULT]
        row["strokes"] += 1
        row["drawn_mm"] += st.length_mm()
    return list(rows.values())


# ------------------------------------------------------------------ pauses
class Breaks:
    """Where the records of `strokes` pause, and what each pause says: `before(k)` is asked
    once for each stroke in order, `cuts(pts)` for its points then."""

    def __init__(self, strokes: list[Stroke], refill_mm: float | None = None,
                 layers: bool = False):
        self.strokes = strokes
        self.pens = [n for n, _ in pens_of(strokes)]
        self.count = len(self.pens)
        self.every = refill_mm
        self.layers = layers
        self.used = 0.0                  # mm drawn with the pen since it was put in
        self.lengths = _lengths(strokes).tolist() if refill_mm else None

    def _pen(self, k: int) -> str:
        p = self.strokes[k].pen
        return p if p is not None else DEFAULT

    def _refill(self, pen: str) -> tuple:
        i = self.pens.index(pen) + 1
        return (f"{self.every / 1000:g} m drawn with the {pen} pen: put in a fresh one or "
                f"refill it", pen, i, self.count)

    def before(self, k: int) -> tuple | None:
        """Pause(...) arguments after the line number (message, pen, index, count) for a pause
        before stroke k, or None."""
        pen = self._pen(k)
        if self.count >= 2 and (k == 0 or self._pen(k - 1) != pen):
            self.used = 0.0
            i = self.pens.index(pen) + 1
            return (pen_message(pen, i, self.count), pen, i, self.count)
        if k and self.every and self.used >= self.every - 1e-9:
            self.used = 0.0
            return self._refill(pen)
        prev = self.strokes[k - 1] if k else None
        if prev is not None and self.layers and self.strokes[k].layer != prev.layer:
            nxt = self.strokes[k].layer
            return (f"layer {prev.layer} done; next: layer {nxt}: change the pen",)
        return None

    def split(self, k: int) -> tuple[np.ndarray, dict[int, tuple]]:
        """The points of stroke k with the refills inside it: (points, {point index: Pause
        arguments}), a refill point added where the pen has drawn `refill_mm` (one that would
        leave INSIDE_MM or less of the stroke waits for its end)."""
        pts = self.strokes[k].pts
        if self.lengths is None or self.used + self.lengths[k] < self.every:
            self.used += self.lengths[k] if self.lengths is not None else 0.0
            return pts, {}
        pts = np.asarray(pts, dtype=float)
        seg = np.hypot(*np.diff(pts, axis=0).T)
        total = float(seg.sum())
        marks = np.arange(self.every - self.used, total - INSIDE_MM, self.every)
        if not len(marks):
            self.used += total
            return pts, {}
        cum = np.cumsum(seg)
        idx = np.searchsorted(cum, marks)
        t = (marks - (cum[idx] - seg[idx])) / np.where(seg[idx] > 0, seg[idx], 1.0)
        at = pts[idx] + t[:, None] * (pts[idx + 1] - pts[idx])
        pause = self._refill(self._pen(k))
        self.used = total - float(marks[-1])
        where = idx + 1 + np.arange(len(idx))
        return np.insert(pts, idx + 1, at, axis=0), {int(i): pause for i in where}


def _lengths(strokes: list[Stroke]) -> np.ndarray:
    """The drawn length of each stroke, in one pass over all points."""
    if not strokes:
        return np.zeros(0)
    n = np.array([len(s.pts) for s in strokes])
    pts = np.concatenate([s.pts for s in strokes]).astype(float)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    seg[np.cumsum(n)[:-1] - 1] = 0.0           # the gaps between strokes are not drawn
    out = np.add.reduceat(np.append(seg, 0.0), np.cumsum(n) - n)
    out[n == 1] = 0.0
    return out


def passthrough(records: Iterable, owned: tuple, warn: Warn | None, name: str) -> Iterable:
    """A G-code file's own records with [pens] (without: the records as they are): a
    pen-change pause names the owned pen its pen matches (by name, else the nearest colour),
    whose speed caps the drawing moves after it; a pen that matches nothing is warned about
    once (when warn is given)."""
    return _owned_records(records, owned, warn, name) if owned else records


def _owned_records(records: Iterable, owned: tuple, warn: Warn | None, name: str) -> Iterator:
    cap = None
    said: set = set()
    for rec in records:
        if isinstance(rec, Pause) and rec.pen is not None:
            spec, de = match(owned, rec.pen, None)
            cap = spec.speed_mm_s if spec is not None else None
            if spec is None and warn is not None and rec.pen not in said:
                said.add(rec.pen)
                warn(f"{name}:{rec.line}: warning: pen {rec.pen} is not one of the pens in "
                     f"[pens] ({', '.join(p.name for p in owned)}): it is asked for by that name")
            if de is not None and de > FAR_DE and warn is not None and rec.pen not in said:
                said.add(rec.pen)       # as resolve() says it for a drawing's far colours
                warn(f"{name}:{rec.line}: warning: no pen in [pens] is close to colour "
                     f"{rec.pen}: drawn with {spec.name} ({spec.colour}, colour difference "
                     f"{de:.0f})")
            if spec is not None and spec.name != rec.pen:
                rec = replace(rec, pen=spec.name,
                              message=pen_message(spec.name, rec.index, rec.count))
        elif cap is not None and isinstance(rec, Move) and not rec.rapid:
            rec = replace(rec, feed_mm_s=_cap(rec.feed_mm_s, cap))
        yield rec


# ------------------------------------------------------------------ plot time per pen
def times(marks: list, total_s: float) -> list[tuple]:
    """(pen, seconds, fresh pens, index, count) per pen in drawing order, from the pipeline's
    marks [pen, start s, fresh pens, index, count] (pipeline.Summary.pen_mark): the time from
    a pen's change to the next (pen None: what is drawn before the first pen change)."""
    marks = list(marks)
    if marks and marks[0][1] >= 0.5:
        marks.insert(0, [None, 0.0, 0, 0, 0])
    ends = [m[1] for m in marks[1:]] + [total_s]
    return [(pen, t1 - t0, fresh, i, k) for (pen, t0, fresh, i, k), t1 in zip(marks, ends)]


def time_lines(marks: list, total_s: float) -> list[str]:
    """One line per pen: which pen, its plot time, the fresh pens it takes ('pen 2 of 3: red
    for 0:56 (56.2 s)'; no 'plot time' in it: that names the drawing's summary line)."""
    from vplotter.budget import clock_text

    out = []
    for pen, s, fresh, i, k in times(marks, total_s):
        what = (f"pen {i} of {k}: {pen}" if pen is not None and k > 1 and i else
                f"pen {pen}" if pen is not None else "before the first pen change")
        more = f", {fresh} fresh pen{'s' if fresh > 1 else ''}" if fresh else ""
        out.append(f"{what} for {clock_text(s)} ({s:.1f} s){more}")
    return out
