"""The calibration pattern: numbered marks over the page, the pairs to measure, pattern.csv.

Pure: marks and pairs are computed from the page, the strokes are G-code millimetres (+Y up)
for the shared pipeline, and pattern.csv (a contract, one table a spreadsheet opens) is
written and read here:

    # vplotter calibration pattern v1 (comment lines start with #)
    # reference left_mm=456.948000 right_mm=456.948000 left_steps_per_mm=163.84 ...
    kind,a,b,x_mm,y_mm,left_steps,right_steps,distance_mm
    mark,1,,-150.000,150.000,-8123,20456,
    pair,1,2,,,,,

A `mark` row: its id, nominal G-code X and Y, and the step counts (relative to the stored
reference) at which its dot was made. A `pair` row: two mark ids whose centre-to-centre
distance a person measures and writes into distance_mm.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vplotter.errors import InputError
from vplotter.inputs.strokes import Stroke

HEADER = "# vplotter calibration pattern v1 (comment lines start with #)"
COLUMNS = ["kind", "a", "b", "x_mm", "y_mm", "left_steps", "right_steps", "distance_mm"]
CIRCLE_MM = 3.0          # radius of the circle around each dot
FIRST_MM = 6.0           # mark 1 only: a second circle round the first (numbers a photo's marks)
DIGIT_GAP_MM = 2.5       # from the circle to the number (a photo tells them apart)
DIGIT_MM = 4.0           # height of the numbers
MOST_PAIRS = 30
PAGE_MM = 600.0          # a page wider or taller than this gets marks as much larger (mark_size)
MARGIN_MM = 25.0         # the marks this far inside the page by default (times mark_size)

# a tiny stroke font: polylines in a box 0.6 wide, 1 high
_W = 0.6
FONT: dict[str, list[list[tuple[float, float]]]] = {
    "0": [[(0, 0), (_W, 0), (_W, 1), (0, 1), (0, 0), (_W, 1)]],
    "1": [[(0.1, 0.8), (0.3, 1), (0.3, 0)]],
    "2": [[(0, 1), (_W, 1), (_W, 0.5), (0, 0.5), (0, 0), (_W, 0)]],
    "3": [[(0, 1), (_W, 1), (_W, 0), (0, 0)], [(0.1, 0.5), (_W, 0.5)]],
    "4": [[(0, 1), (0, 0.5), (_W, 0.5)], [(_W, 1), (_W, 0)]],
    "5": [[(_W, 1), (0, 1), (0, 0.5), (_W, 0.5), (_W, 0), (0, 0)]],
    "6": [[(_W, 1), (0, 1), (0, 0), (_W, 0), (_W, 0.5), (0, 0.5)]],
    "7": [[(0, 1), (_W, 1), (0.2, 0)]],
    "8": [[(0, 0), (_W, 0), (_W, 1), (0, 1), (0, 0)], [(0, 0.5), (_W, 0.5)]],
    "9": [[(_W, 0.5), (0, 0.5), (0, 1), (_W, 1), (_W, 0), (0, 0)]],
}


@dataclass
class Mark:
    id: int
    x_mm: float
    y_mm: float
    steps: tuple[int, int] | None = None


@dataclass
class Pair:
    a: int
    b: int
    distance_mm: float | None = None
    where: str = ""            # file:line for messages


@dataclass
class Pattern:
    marks: dict[int, Mark]
    pairs: list[Pair]
    reference: dict = field(default_factory=dict)   # left_mm, right_mm, *_steps_per_mm


def grid(page, rows: int, cols: int, margin_mm: float) -> list[Mark]:
    """Marks numbered row by row from the top left, `margin_mm` inside the page."""
    xs = np.linspace(page.x_min_mm + margin_mm, page.x_max_mm - margin_mm, cols)
    ys = np.linspace(page.y_max_mm - margin_mm, page.y_min_mm + margin_mm, rows)
    return [Mark(r * cols + c + 1, float(xs[c]), float(ys[r])) for r in range(rows)
            for c in range(cols)]


def choose_pairs(rows: int, cols: int, most: int = MOST_PAIRS) -> list[Pair]:
    """Pairs that pin the machine down: the long spans first (both diagonals, every row and
    column end to end), then neighbours along the edges, cell diagonals, inner neighbours."""
    def i(r, c):
        return r * cols + c + 1

    cand = [(i(0, 0), i(rows - 1, cols - 1)), (i(0, cols - 1), i(rows - 1, 0))]
    cand += [(i(r, 0), i(r, cols - 1)) for r in range(rows)]
    cand += [(i(0, c), i(rows - 1, c)) for c in range(cols)]
    cand += [(i(r, c), i(r, c + 1)) for r in sorted({0, rows - 1}) for c in range(cols - 1)]
    cand += [(i(r, c), i(r + 1, c)) for c in sorted({0, cols - 1}) for r in range(rows - 1)]
    n = min(rows, cols) - 1
    cand += [(i(k, k), i(k + 1, k + 1)) for k in range(n)]
    cand += [(i(k, cols - 1 - k), i(k + 1, cols - 2 - k)) for k in range(n)]
    cand += [(i(r, c), i(r, c + 1)) for r in range(1, rows - 1) for c in range(cols - 1)]
    cand += [(i(r, c), i(r + 1, c)) for c in range(1, cols - 1) for r in range(rows - 1)]
    seen, out = set(), []
    for a, b in cand:
        key = (min(a, b), max(a, b))
        if a != b and key not in seen:
            seen.add(key)
            out.append(Pair(*key))
    return out[:most]


def _circle(x: float, y: float, r: float, line: int) -> Stroke:
    ang = np.linspace(0.0, 2 * np.pi, 49)
    circle = Stroke(np.column_stack((x + r * np.cos(ang), y + r * np.sin(ang))), line=line)
    circle.pts[-1] = circle.pts[0]
    return circle


def mark_size(page) -> float:
    """How much larger than CIRCLE_MM and the rest the marks are drawn on this page: 1 up to
    PAGE_MM across, then in proportion, so that a phone photo of the whole pattern shows them
    as many pixels across on a wall of 2 m as on the seed machine's (a 12 MP photo of marks
    of 3 mm over 1.2 m loses them at 25 degrees off-axis)."""
    return max(1.0, max(page.x_max_mm - page.x_min_mm, page.y_max_mm - page.y_min_mm) / PAGE_MM)


def room_mm(size: float = 1.0) -> float:
    """The margin a mark of mark_size `size` needs inside the page (mark 1 and its number)."""
    return max(FIRST_MM + DIGIT_GAP_MM + 2 * 0.9 * DIGIT_MM, 2 * FIRST_MM) * size


def mark_strokes(mark: Mark, size: float = 1.0) -> list[Stroke]:
    """The dot (one point: pen down and up without a step), the circle (mark 1: a second one
    round it, so that a photo shows which mark is the first), the number; `size`: mark_size."""
    x, y = mark.x_mm, mark.y_mm
    circle, first, digit = CIRCLE_MM * size, FIRST_MM * size, DIGIT_MM * size
    dot = Stroke(np.array([[x, y]]), line=mark.id)
    out = [dot, _circle(x, y, circle, mark.id)]
    if mark.id == 1:
        out.append(_circle(x, y, first, mark.id))
    left = x + (first if mark.id == 1 else circle) + DIGIT_GAP_MM * size
    for ch in str(mark.id):
        for poly in FONT[ch]:
            p = np.array(poly, dtype=float) * digit
            out.append(Stroke(p + [left, y - digit / 2], line=mark.id))
        left += (_W + 0.3) * digit
    return out


def write(path: str | Path, pattern: Pattern) -> None:
    ref = pattern.reference
    lines = [HEADER]
    if ref:
        lines.append("# reference " + " ".join(f"{k}={v:.6f}" for k, v in ref.items()))
    lines.append("# measure the centre-to-centre distance of each pair's dots in mm "
                 "into distance_mm")
    lines.append(",".join(COLUMNS))
    for m in pattern.marks.values():
        steps = m.steps if m.steps is not None else ("", "")
        lines.append(f"mark,{m.id},,{m.x_mm:.3f},{m.y_mm:.3f},{steps[0]},{steps[1]},")
    for p in pattern.pairs:
        dist = "" if p.distance_mm is None else f"{p.distance_mm:.2f}"
        lines.append(f"pair,{p.a},{p.b},,,,,{dist}")
    from vplotter.machine.state import atomic_write

    atomic_write(Path(path), "\n".join(lines) + "\n")


def read(path: str | Path) -> Pattern:
    """Read pattern.csv back (with the distances a person wrote in). Blank rows and comment
    lines are skipped; every error names file:line:col."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"{p}: error: file not found") from None
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{p}: error: cannot read: {e}") from None
    raw = text.splitlines()
    if not raw or not raw[0].startswith("# vplotter calibration pattern v1"):
        raise InputError(f"{p}:1:1: error: not a vplotter calibration pattern (the first line "
                         f"must be {HEADER!r})")
    marks: dict[int, Mark] = {}
    pairs: list[Pair] = []
    reference: dict = {}
    header_seen = False
    for no, row in enumerate(csv.reader(raw), start=1):
        line = raw[no - 1]
        if line.startswith("#"):
            if line.startswith("# reference "):
                for item in line[len("# reference "):].split():
                    k, _, v = item.partition("=")
                    try:
                        reference[k] = float(v)
                    except ValueError:
                        raise InputError(
                            f"{p}:{no}:1: error: bad reference value {item!r}") from None
            continue
        cells = [c.strip() for c in row]
        if not any(cells):
            continue
        if not header_seen:
            if cells[:len(COLUMNS)] != COLUMNS:
                raise InputError(f"{p}:{no}:1: error: expected the columns {','.join(COLUMNS)}")
            header_seen = True
            continue
        cells += [""] * (len(COLUMNS) - len(cells))
        kind = cells[0]

        def num(k: int, cast=float, required=True):
            col = len(",".join(row[:k])) + (1 if k else 0) + 1
            if not cells[k]:
                if required:
                    raise InputError(f"{p}:{no}:{col}: error: {COLUMNS[k]} is missing")
                return None
            try:
                v = cast(cells[k].replace(",", "."))
            except ValueError:
                raise InputError(f"{p}:{no}:{col}: error: {COLUMNS[k]} {cells[k]!r} is not a "
                                 f"number") from None
            if not np.isfinite(v):
                raise InputError(f"{p}:{no}:{col}: error: {COLUMNS[k]} must be finite")
            return v

        if kind == "mark":
            m = Mark(num(1, int), num(3), num(4), (num(5, int), num(6, int)))
            if m.id in marks:
                raise InputError(f"{p}:{no}:1: error: mark {m.id} is listed twice")
            marks[m.id] = m
        elif kind == "pair":
            a, b = num(1, int), num(2, int)
            d = num(7, required=False)
            if d is not None and not d > 0:
                raise InputError(f"{p}:{no}:{len(','.join(row[:7])) + 2}: error: distance_mm "
                                 f"must be above 0 (got {d:g})")
            pairs.append(Pair(a, b, d, f"{p}:{no}"))
        else:
            raise InputError(f"{p}:{no}:1: error: unknown row kind {kind!r} (mark or pair)")
    for pr in pairs:
        for k in (pr.a, pr.b):
            if k not in marks:
                raise InputError(f"{pr.where}:1: error: pair {pr.a}-{pr.b} names mark {k}, "
                                 f"which is not in the file")
        if pr.a == pr.b:
            raise InputError(f"{pr.where}:1: error: pair {pr.a}-{pr.b} is one mark twice")
    if not header_seen:
        raise InputError(f"{p}: error: no column line ({','.join(COLUMNS)})")
    return Pattern(marks, pairs, reference)
