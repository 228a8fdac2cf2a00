"""The G-code parser against its contract: features, every error kind at file:line:col,
warnings, and properties checked with hypothesis."""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vplotter.inputs import gcode
from vplotter.errors import InputError
from vplotter.inputs.gcode import Dwell, Move, Pen

NAME = "t.ngc"


def parse(text: str, mode: str | None = None, strict: bool = False):
    """(records, warnings) of a program given as one string."""
    lines = text.split("\n")
    warnings: list[str] = []
    mode = mode or gcode.detect_pen_mode(lines)
    records = list(gcode.parse_lines(lines, NAME, mode, strict, warnings.append))
    return records, warnings


def records(text: str, mode: str | None = None) -> list:
    recs, warnings = parse(text, mode)
    assert warnings == []
    return recs


def error(text: str, mode: str | None = None, strict: bool = False) -> str:
    with pytest.raises(InputError) as e:
        parse(text, mode, strict)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def moves(text: str, mode: str | None = None) -> list[Move]:
    return [r for r in records(text, mode) if isinstance(r, Move)]


def ends(text: str) -> list[tuple[float, float]]:
    return [(m.x1, m.y1) for m in moves(text)]


def no_col(recs: list) -> list:
    return [dataclasses.replace(r, col=0) for r in recs]


# ------------------------------------------------------------------ tokenizer
def test_tokenize_with_and_without_spaces():
    assert gcode.tokenize("G01X5Y-5.5", "f:1") == [("G", 1.0, 1), ("X", 5.0, 4), ("Y", -5.5, 6)]
    assert gcode.tokenize("  g1  x 5 ( c ) y+.5 ; rest", "f:1") == [
        ("G", 1.0, 3), ("X", 5.0, 7), ("Y", 0.5, 17)]
    assert gcode.tokenize("", "f:1") == []
    assert gcode.tokenize("(only a comment)\r\n", "f:1") == []


# ------------------------------------------------------------------ motion
def test_motion_is_modal_and_g00_to_g03_are_the_same_codes():
    recs = moves("G00 X1 Y2\nX3\nG01 Y4\nX5 Y6\nG1 X0\nG0 Y0")
    assert [(m.x1, m.y1, m.rapid) for m in recs] == [
        (1, 2, True), (3, 2, True), (3, 4, False), (5, 6, False), (0, 6, False), (0, 0, True)]
    assert [(m.x0, m.y0) for m in recs] == [(0, 0), (1, 2), (3, 2), (3, 4), (5, 6), (0, 6)]
    assert all(m.arc == 0 for m in recs)


def test_upper_lower_case_and_spacing_give_the_same_records():
    a = records("G1 X5 Y5 F600\nG2 X15 Y5 I5 J0")
    b = records("g01x5y5f600\ng02X15y5i5j0")
    c = records("G 1 X 5 Y 5 F 600\n\tG2\tX15\tY5\tI5\tJ0")
    assert no_col(a) == no_col(b) == no_col(c)


def test_line_and_column_of_records():
    recs = records("G21\n\nG1 X5\n  N20 G0 Y1\nM3\nG4 P1")
    assert [(r.line, r.col) for r in recs] == [(3, 1), (4, 7), (5, 1), (6, 1)]


def test_move_without_any_coordinate_is_not_a_move():
    assert records("G1\nG0 F100\nG1 F200") == []


def test_comments_percent_and_blank_lines():
    text = "%\n(header)\n; semicolon comment\n\nG1 X1 (mid) Y2 ; end\n(a ; b) G1 X3\n%"
    assert ends(text) == [(1, 2), (3, 2)]


def test_n_numbers_and_checksum():
    line = "N10 G1 X5 Y6"
    cs = 0
    for ch in line:
        cs ^= ord(ch)
    assert ends(f"{line}*{cs}") == [(5, 6)]
    assert ends(f"{line}*{cs} ; comment after the checksum") == [(5, 6)]
    assert ends("N1 G1 X1\nN2 X2") == [(1, 0), (2, 0)]


def test_g17_is_accepted():
    assert ends("G17 G1 X1") == [(1, 0)]


def test_g20_inches_scale_coordinates_centres_and_feed():
    (m,) = moves("G20 G1 X1 Y2 F10")
    assert (m.x1, m.y1) == (25.4, 50.8)
    assert m.feed_mm_s == pytest.approx(10 * 25.4 / 60)
    (a,) = moves("G20 G2 X2 Y0 I1 J0")
    assert (a.x1, a.cx, a.cy) == (50.8, 25.4, 0.0)
    (b,) = moves("G20\nG21 G1 X1")
    assert b.x1 == 1.0


def test_g91_relative_and_ij_always_relative_to_the_arc_start():
    assert ends("G91 G1 X1 Y1\nX1\nY-3\nG90 X10") == [(1, 1), (2, 1), (2, -2), (10, -2)]
    for end in ("G90 G2 X20 Y10", "G91 G2 X10 Y0"):
        arc = moves(f"G0 X10 Y10\n{end} I5 J0")[-1]
        assert (arc.x1, arc.y1, arc.cx, arc.cy) == (20, 10, 15, 10)


def test_g91_relative_z_moves_the_pen():
    recs = records("G91\nG0 Z5\nG1 Z-6\nG1 X1\nG0 Z2")
    assert [type(r).__name__ for r in recs] == ["Pen", "Move", "Pen"]
    assert [r.down for r in recs if isinstance(r, Pen)] == [True, False]


def test_feed_is_units_per_minute_and_modal():
    recs = moves("G1 X1 F600\nX2\nG0 X3\nG1 X4 F120")
    assert [m.feed_mm_s for m in recs] == [10.0, 10.0, 10.0, 2.0]
    assert moves("G1 X1")[0].feed_mm_s is None


def test_dwell_in_seconds():
    recs = records("G4 P0.5\nG4P2\nG4 P0")
    assert recs == [Dwell(1, 1, 0.5), Dwell(2, 1, 2.0), Dwell(3, 1, 0.0)]


@pytest.mark.parametrize("end", ["M2", "M30", "m02", "M30 (end)"])
def test_program_end_ignores_what_follows_with_one_warning(end):
    recs, warnings = parse(f"G1 X1\n{end}\n(comment)\n\nG1 X2\nthis is not g-code at all !!\nG1 Z-1")
    assert no_col(recs) == no_col(moves("G1 X1"))
    assert warnings == [f"{NAME}:5: warning: program ended (M2/M30); the lines after it are ignored"]


def test_program_end_with_only_comments_after_it_does_not_warn():
    recs, warnings = parse("G1 X1 M2\n(end)\n%\n; bye\n")
    assert len(recs) == 1 and warnings == []


def test_move_on_the_end_line_is_drawn():
    recs, warnings = parse("G1 X1\nG1 X2 M30\nG1 X3")
    assert [(r.x1, r.y1) for r in recs] == [(1, 0), (2, 0)]
    assert len(warnings) == 1


# ------------------------------------------------------------------ pen
def test_z_pen_below_zero_is_down_zero_and_above_is_up():
    recs = records("G0 Z5\nG1 Z-1\nG1 X1\nG0 Z0\nG0 X2\nG1 Z-0.1\nG1 Z-2\nG0 Z0.5")
    pens = [(r.line, r.down) for r in recs if isinstance(r, Pen)]
    assert pens == [(2, True), (4, False), (6, True), (8, False)]


def test_z_pen_file_ignores_m3_m5():
    text = "M3 S1000\nG0 Z5\nG0 X1\nM5\nG1 Z-1\nG1 X2\nM5\nG0 Z5\nM3"
    assert gcode.detect_pen_mode(text.split("\n")) == "z"
    recs, _ = parse(text)
    pens = [(r.line, r.down) for r in recs if isinstance(r, Pen)]
    assert pens == [(5, True), (8, False)]


def test_m3_m5_pen_when_the_file_has_no_z():
    text = "G0 X1\nM3 S255\nG1 X2\nM3\nM5\nM5\nG0 X0\nM03 S0\nM05"
    assert gcode.detect_pen_mode(text.split("\n")) == "m"
    recs, _ = parse(text)
    assert [(r.line, r.down) for r in recs if isinstance(r, Pen)] == [
        (2, True), (5, False), (8, True), (9, False)]


def test_pen_starts_up():
    assert records("M5\nG0 X1", "m") == [Move(2, 1, 0, 0, 1, 0, rapid=True)]
    assert records("G0 Z5\nG0 X1") == [Move(2, 1, 0, 0, 1, 0, rapid=True)]


def test_pen_change_comes_before_the_move_on_the_same_line():
    recs = records("M3 G1 X1 F60")
    assert isinstance(recs[0], Pen) and recs[0].down and recs[0].col == 1
    recs = records("G1 X1 Z-1")
    assert isinstance(recs[0], Pen) and recs[0].col == 7 and isinstance(recs[1], Move)


def test_detect_pen_mode():
    assert gcode.detect_pen_mode(["G1 X1", "(Z in a comment)", "; Z-1"]) == "m"
    assert gcode.detect_pen_mode(["G1 X1", "g0z5"]) == "z"
    assert gcode.detect_pen_mode(["M3", "M2", "G0 Z5"]) == "m"  # after the end: ignored


# ------------------------------------------------------------------ ignored codes
def test_codes_that_change_nothing_are_summarised_in_one_warning():
    text = ("G40 G49 G54\nG61\nG64 P0.01\nG80 G94\nM7\nM8\nM9\nS1000\nT1\nG54\n"
            "M3 S200\nG1 X1\nM5")
    recs, warnings = parse(text)
    assert [type(r) for r in recs] == [Pen, Move, Pen]
    assert warnings == [f"{NAME}: warning: ignored codes that change nothing for a pen plotter: "
                        "G40, G49, G54 x2, G61, G64, G80, G94, M7, M8, M9, S x2, T"]


def test_no_summary_when_nothing_was_ignored():
    assert parse("G1 X1")[1] == []


# ------------------------------------------------------------------ arcs
def test_arc_ij_centre_and_direction():
    (_, cw, ccw) = moves("G0 X10 Y0\nG2 X0 Y-10 I-10 J0\nG3 X10 Y0 I0 J10")
    assert (cw.arc, cw.cx, cw.cy, cw.x1, cw.y1) == (-1, 0, 0, 0, -10)
    assert (ccw.arc, ccw.cx, ccw.cy) == (1, 0, 0)


def test_arc_with_only_i_or_only_j():
    (a,) = moves("G2 X10 I5")
    assert (a.cx, a.cy) == (5, 0)
    (b,) = moves("G3 Y10 J5")
    assert (b.cx, b.cy) == (0, 5)


@pytest.mark.parametrize("code,r,centre", [
    ("G2", 5 * math.sqrt(2), (5, -5)),   # minor clockwise arc from (0,0) to (10,0)
    ("G2", -5 * math.sqrt(2), (5, 5)),   # major clockwise arc
    ("G3", 5 * math.sqrt(2), (5, 5)),    # minor counter-clockwise arc
    ("G3", -5 * math.sqrt(2), (5, -5)),  # major counter-clockwise arc
])
def test_arc_r_form_and_negative_r(code, r, centre):
    (a,) = moves(f"{code} X10 Y0 R{r:.12f}")
    assert (a.cx, a.cy) == pytest.approx(centre, abs=1e-9)


def test_r_arc_of_exactly_half_a_circle_and_tiny_rounding_of_r():
    (a,) = moves("G2 X10 Y0 R5")
    assert (a.cx, a.cy) == pytest.approx((5, 0))
    (b,) = moves("G2 X10 Y0 R4.99995")  # chord longer than 2R by 1e-4 mm: accepted
    assert (b.cx, b.cy) == pytest.approx((5, 0))


def test_full_circle_when_start_equals_end():
    a = moves("G0 X10 Y0\nG2 X10 Y0 I-10 J0")[-1]
    assert (a.x0, a.y0, a.x1, a.y1, a.cx, a.cy, a.arc) == (10, 0, 10, 0, 0, 0, -1)
    b = moves("G0 X10 Y0\nG3 I-10")[-1]  # no end point: the end is the start
    assert (b.x1, b.y1, b.cx, b.arc) == (10, 0, 0, 1)


def _spiral(r0: float, r1: float, strict: bool = False):
    """A G2 from (0,0) around (r0,0) ending at radius r1, a quarter turn later."""
    return parse(f"G2 X{r0:.6f} Y{r1:.6f} I{r0:.6f} J0", strict=strict)


@pytest.mark.parametrize("r0,r1,warns", [
    (1.0, 1.0049, False), (1.0, 1.0051, True),        # below 5 mm: the 0.005 mm floor
    (1.0, 0.9951, False), (1.0, 0.9949, True),
    (10.0, 10.0099, False), (10.0, 10.0101, True),    # 0.1 % of 10 mm = 0.01 mm
    (1000.0, 1000.99, False), (1000.0, 1001.01, True),  # 0.1 % of 1000 mm = 1 mm
    (1000.0, 999.01, False), (1000.0, 998.99, True),
])
def test_spiral_warning_threshold(r0, r1, warns):
    recs, warnings = _spiral(r0, r1)
    assert len(recs) == 1 and recs[0].arc == -1
    if warns:
        assert len(warnings) == 1
        assert warnings[0].startswith(f"{NAME}:1:1: warning: arc end radius")
        with pytest.raises(InputError, match=rf"^{NAME}:1:1: error: arc end radius"):
            _spiral(r0, r1, strict=True)
    else:
        assert warnings == []
        assert len(_spiral(r0, r1, strict=True)[0]) == 1


def test_one_spiral_warning_per_line():
    recs, warnings = parse("G2 X10 Y10.5 I10\nG0 X0 Y0\nG2 X10 Y10.5 I10\nG0 X0 Y0")
    assert len(recs) == 4
    assert [w.split(": ")[0] for w in warnings] == [f"{NAME}:1:1", f"{NAME}:3:1"]


# ------------------------------------------------------------------ errors
PRE = "G21\nG90\n"  # the bad line is line 3

ERRORS = [
    # (line 3, column, part of the message)
    ("O100 sub", 1, "O-words"),
    ("o100", 1, "O-words"),
    ("#1 = 5", 1, "#parameters"),
    ("G1 X#1", 5, "#parameters"),
    ("G1 X[1+2]", 5, "[expressions]"),
    ("G41", 1, "unsupported code G41 (cutter compensation)"),
    ("G42", 1, "unsupported code G42"),
    ("G18", 1, "unsupported code G18"),
    ("G19", 1, "unsupported code G19"),
    ("G92 X0 Y0", 1, "unsupported code G92"),
    ("G1 X5 G92", 7, "unsupported code G92"),
    ("G93", 1, "unsupported code G93"),
    ("G5", 1, "unsupported code G5"),
    ("G0.5 X1", 1, "unsupported code G0.5"),
    ("G90.1", 1, "unsupported code G90.1"),
    ("M4", 1, "unsupported code M4"),
    ("M6", 1, "M6 (tool change) without a tool: give T<n>"),
    ("T1.5 M6", 1, "tool number T1.5 must be a whole number"),
    ("T-1", 1, "tool number T-1 must be a whole number"),
    ("M0 (pen:)", 4, "'(pen: )' needs a pen name"),
    ("M99", 1, "unsupported code M99"),
    ("G1 Q5", 4, "unsupported word Q5"),
    ("G1 X5 A3", 7, "unsupported word A3"),
    ("hello", 1, "unsupported word H"),
    ("G1\tX5\tD1", 7, "unsupported word D1"),
    ("G1 X1.2.3", 8, "unexpected character '.'"),
    ("G1 X-", 4, "X must be followed by a number"),
    ("G1 Xabc", 4, "X must be followed by a number"),
    ("G1 X", 4, "X must be followed by a number (got 'end of line')"),
    ("G1 X.", 4, "X must be followed by a number"),
    ("G1 X1e3", 6, "exponent"),
    ("G1 X" + "9" * 400, 4, "too large"),
    ("G1 X\u0661", 4, "X must be followed by a number"),  # an Arabic-Indic digit one
    ("G1 X1 \u017f5", 7, "unexpected character"),        # long s, upper() would be S
    ("G1 X5 @", 7, "unexpected character '@'"),
    ("/G1 X5", 1, "unexpected character '/'"),
    ("% G1 X5", 1, "unexpected character '%'"),
    ("\ufeffG1 X5", 1, "unexpected character"),  # a BOM is only skipped at the file start
    ("G1 X5 (open", 7, "not closed"),
    ("G1 X5*ab", 6, "checksum after '*' must be a number"),
    ("G1 X5*12 G1", 6, "checksum after '*' must be a number"),
    ("N1 G1 X5*1", 9, "checksum 1 does not match the line (expected 100)"),
    ("G2 X10 Y0", 1, "arc without centre (I/J) or radius (R)"),
    ("G2 X10 Y0 R4", 11, "chord (10.0000 mm) is longer than 2R (8.0000 mm)"),
    ("G2 X10 Y0 R-4.999", 11, "longer than 2R"),
    ("G3 X10 Y0 R5 I5", 11, "either I/J or R"),
    ("G2 R5", 4, "end point different from its start"),
    ("G2 X10 R0", 8, "must not be 0"),
    ("G2 X10 I0 J0", 1, "zero radius"),
    ("G1 X5 I1", 7, "I is only allowed on arcs"),
    ("G0 R1", 4, "R is only allowed on arcs"),
    ("X5", 1, "coordinates without a motion code"),
    ("J5", 1, "coordinates without a motion code"),
    ("G1 X5 X6", 7, "X appears twice"),
    ("G1 F1 F2", 7, "F appears twice"),
    ("G1 N5 X1", 4, "N line number must come first"),
    ("G0 G1 X1", 4, "two motion codes"),
    ("G1 X5 F0", 7, "feed F must be above 0 (got 0)"),
    ("G1 X5 F-5", 7, "feed F must be above 0 (got -5)"),
    ("G4", 1, "G4 needs P (seconds)"),
    ("G4 P-1", 4, "must not be negative"),
    ("G4 P1 X5", 7, "cannot share a line with a move"),
    ("G4 G1 P1", 4, "cannot share a line with a move"),
    ("G1 X5 P1", 7, "P word without G4"),
    ("G4 P2000000", 4, "P2e+06 is out of range"),
    ("G1 X2000000", 4, "X2e+06 is out of range"),
    ("G20 G1 X40000", 8, "X40000 is out of range"),
    ("G2 X1 I-1000001", 7, "I-1e+06 is out of range"),
]


@pytest.mark.parametrize("line,col,what", ERRORS, ids=[e[0][:20] for e in ERRORS])
def test_error_at_file_line_col(line, col, what):
    msg = error(PRE + line + "\nG1 X1")
    assert msg.startswith(f"{NAME}:3:{col}: error: ")
    assert what in msg


def test_error_after_earlier_records_were_yielded():
    it = gcode.parse_lines(["G1 X1", "G1 Q1"], NAME, "m", False, print)
    assert isinstance(next(it), Move)
    with pytest.raises(InputError, match=f"^{NAME}:2:4: error: "):
        next(it)


def test_relative_moves_out_of_range():
    msg = error("G91 G1 X900000\nX900000")
    assert msg.startswith(f"{NAME}:2:1: error: coordinate 1.8e+06 is out of range")


def test_no_error_on_lines_after_the_end():
    recs, warnings = parse("G1 X1\nM2\nO100 #1=[2]")
    assert [(r.x1, r.y1) for r in recs] == [(1, 0)]
    assert warnings == [f"{NAME}:3: warning: program ended (M2/M30); the lines after it are ignored"]


# ------------------------------------------------------------------ read()
def test_read_picks_the_pen_mode_and_streams_records(tmp_path):
    z = tmp_path / "z.ngc"
    z.write_text("M3\nG0 Z5\nG0 X1\nG1 Z-1\nG1 X2\nG0 Z5\nM5\nM2\n")
    assert [type(r) for r in gcode.read(str(z))] == [Move, Pen, Move, Pen]
    m = tmp_path / "m.ngc"
    m.write_text("G0 X1\nM3\nG1 X2\nM5\nM2\nG0 Z5\n")
    assert [type(r) for r in gcode.read(str(m), warn=lambda s: None)] == [Move, Pen, Move, Pen]


def test_read_skips_a_byte_order_mark_and_accepts_crlf(tmp_path):
    p = tmp_path / "bom.ngc"
    p.write_bytes(b"\xef\xbb\xbfG1 X1\r\nG1 X2\r\n")
    assert [(r.line, r.x1) for r in gcode.read(str(p))] == [(1, 1.0), (2, 2.0)]


def test_read_reports_invalid_utf8_at_its_place(tmp_path):
    p = tmp_path / "bad.ngc"
    p.write_bytes(b"G1 X1\nG1 X2 \xff\xfe\n")
    with pytest.raises(InputError, match=rf"^{p}:2:7: error: unexpected character"):
        list(gcode.read(str(p)))


def test_read_missing_file_and_directory(tmp_path):
    with pytest.raises(InputError, match=r": error: no such file$"):
        list(gcode.read(str(tmp_path / "missing.ngc")))
    with pytest.raises(InputError, match=r": error: is a directory"):
        list(gcode.read(str(tmp_path)))


def test_read_strict_turns_spiral_warnings_into_errors(tmp_path):
    p = tmp_path / "s.ngc"
    p.write_text("G0 X0 Y0\nG2 X10 Y10.5 I10\n")
    warnings: list[str] = []
    assert len(list(gcode.read(str(p), warn=warnings.append))) == 2
    assert len(warnings) == 1 and warnings[0].startswith(f"{p}:2:1: warning: ")
    with pytest.raises(InputError, match=rf"^{p}:2:1: error: arc end radius"):
        list(gcode.read(str(p), strict=True))


def test_parse_lines_is_lazy():
    """Streaming: records come out while the input is still being read (here: never ends)."""
    endless = itertools.cycle(["G1 X1", "G1 X2"])
    first = list(itertools.islice(gcode.parse_lines(endless, NAME), 1000))
    assert len(first) == 1000 and first[-1].line == 1000


# ------------------------------------------------------------------ properties
COORD = st.integers(-150_000, 150_000).map(lambda k: k / 1000)  # mm, 3 decimals


def _fmt(letter: str, value: float) -> str:
    return str(int(value)) if letter in "GM" else f"{value:.3f}"


@st.composite
def programs(draw):
    """Valid M3/M5 programs as lists of lines, each a list of (letter, value) words."""
    x = y = 0.0
    lines = []
    for _ in range(draw(st.integers(1, 10))):
        kind = draw(st.sampled_from(["G0", "G1", "G2", "G3", "G3", "M3", "M5", "G4"]))
        words: list[tuple[str, float]] = []
        if kind in ("M3", "M5"):
            words = [("M", float(kind[1]))]
        elif kind == "G4":
            words = [("G", 4.0), ("P", draw(st.integers(0, 2000)) / 1000)]
        else:
            words = [("G", float(kind[1]))]
            nx, ny = draw(COORD), draw(COORD)
            if kind in ("G0", "G1"):
                which = draw(st.sampled_from(["XY", "X", "Y"]))
                words += [(k, v) for k, v in (("X", nx), ("Y", ny)) if k in which]
                nx, ny = (nx if "X" in which else x), (ny if "Y" in which else y)
            else:
                words += [("X", nx), ("Y", ny)]
                half_chord = math.hypot(nx - x, ny - y) / 2
                if half_chord > 0.01 and draw(st.booleans()):
                    r = math.ceil(half_chord * 1000 + 1) / 1000 + draw(st.integers(0, 50_000)) / 1000
                    words.append(("R", draw(st.sampled_from([r, -r]))))
                else:
                    i, j = draw(COORD), draw(COORD)
                    if i == j == 0:
                        i = 1.0
                    words += [("I", i), ("J", j)]
            if draw(st.booleans()):
                words.append(("F", draw(st.integers(1, 6000)) / 10))
            x, y = nx, ny
        lines.append(words)
    return lines


def _canonical(words) -> str:
    return " ".join(f"{letter}{_fmt(letter, v)}" for letter, v in words)


@st.composite
def number_text(draw, letter: str, value: float) -> str:
    """Another spelling of the same number."""
    if letter in "GM":
        return draw(st.sampled_from([f"{int(value)}", f"0{int(value)}", f"{int(value)}.0"]))
    s = f"{value:.3f}"
    sign, body = ("-", s[1:]) if s.startswith("-") else ("", s)
    whole, frac = body.split(".")
    short = frac.rstrip("0")
    variants = [s, f"{sign}{body}00", f"{sign}0{body}"]
    variants += [f"{sign}{whole}.{short}"] if short else [f"{sign}{whole}", f"{sign}{whole}."]
    if whole == "0" and short:
        variants.append(f"{sign}.{short}")
    if not sign:
        variants.append(f"+{body}")
    return draw(st.sampled_from(variants))


@st.composite
def formatted(draw, words) -> str:
    """One line of the same words in a random spelling: case, spaces, order, N, comments."""
    order = draw(st.permutations(words))
    parts = []
    for letter, value in order:
        letter_text = draw(st.sampled_from([letter, letter.lower()]))
        gap = draw(st.sampled_from(["", "", " ", "\t"]))
        parts.append(letter_text + gap + draw(number_text(letter, value)))
    seps = draw(st.lists(st.sampled_from(["", " ", "  ", "\t", " (note) ", "(x)"]),
                         min_size=len(parts), max_size=len(parts)))
    text = draw(st.sampled_from(["", " ", "\t"]))
    if draw(st.booleans()):
        text += f"N{draw(st.integers(0, 99999))}" + draw(st.sampled_from(["", " "]))
    text += "".join(sep + part for sep, part in zip(seps, parts))
    if draw(st.booleans()):
        cs = 0
        for ch in text:
            cs ^= ord(ch)
        text += f"*{cs}"
    text += draw(st.sampled_from(["", " ", " ; the end", "(the end)", "\r"]))
    return text


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_formatting_does_not_change_the_records(data):
    program = data.draw(programs())
    canonical = [_canonical(w) for w in program]
    other = [data.draw(formatted(w)) for w in program]
    w1: list[str] = []
    w2: list[str] = []
    a = list(gcode.parse_lines(canonical, NAME, "m", False, w1.append))
    b = list(gcode.parse_lines(other, NAME, "m", False, w2.append))
    assert no_col(a) == no_col(b), other
    assert len(w1) == len(w2)
    assert len([r for r in a if isinstance(r, Move)]) == sum(w[0][0] == "G" and w[0][1] < 4
                                                             for w in program)


GCODE_CHARS = "GMXYZIJRFPNSTOQgmxyz0123456789.-+ \t()%;*#[]/\ufeff\u0661\u017f"


@settings(max_examples=200)
@given(st.lists(st.one_of(st.text(max_size=30), st.text(alphabet=GCODE_CHARS, max_size=30)),
                max_size=8),
       st.booleans())
def test_arbitrary_text_raises_only_input_error(lines, strict):
    try:
        mode = gcode.detect_pen_mode(lines)
        for rec in gcode.parse_lines(lines, NAME, mode, strict, lambda s: None):
            if isinstance(rec, Move):
                assert all(math.isfinite(v) for v in (rec.x1, rec.y1, rec.cx, rec.cy))
    except InputError as e:
        assert str(e).startswith(f"{NAME}:")
        assert "\n" not in str(e)


@settings(max_examples=100, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=200))
def test_arbitrary_bytes_through_read_raise_only_input_error(tmp_path, blob):
    p = tmp_path / "blob.ngc"
    p.write_bytes(blob)
    try:
        list(gcode.read(str(p), warn=lambda s: None))
    except InputError as e:
        assert str(e).startswith(f"{p}:")


@settings(max_examples=200)
@given(st.integers(-100_000, 100_000), st.integers(-100_000, 100_000),  # start, 1/1000 mm
       st.floats(1.0, 300.0),                                           # radius
       st.floats(0, 2 * math.pi),                                       # where the centre lies
       st.one_of(st.floats(5, 175), st.floats(185, 355)),              # swept degrees
       st.sampled_from([2, 3]))
def test_ij_and_r_forms_of_the_same_arc_have_the_same_centre(x0, y0, r, t, sweep, code):
    x0, y0 = x0 / 1000, y0 / 1000
    i, j = r * math.cos(t), r * math.sin(t)
    cx, cy = x0 + i, y0 + j
    a1 = t + math.pi + math.radians(sweep) * (1 if code == 3 else -1)
    x1, y1 = cx + r * math.cos(a1), cy + r * math.sin(a1)
    rr = r if sweep < 180 else -r
    start = f"G0 X{x0:.3f} Y{y0:.3f}"
    ij = records(f"{start}\nG{code} X{x1:.12f} Y{y1:.12f} I{i:.12f} J{j:.12f}")[-1]
    rf = records(f"{start}\nG{code} X{x1:.12f} Y{y1:.12f} R{rr:.12f}")[-1]
    assert ij.arc == rf.arc == (1 if code == 3 else -1)
    assert (rf.cx, rf.cy) == pytest.approx((ij.cx, ij.cy), abs=1e-7 * r + 1e-9)
    assert (ij.cx, ij.cy) == pytest.approx((cx, cy), abs=1e-9)


# ------------------------------------------------------------------ pen dialects ([gcode])
def dialect_parse(text: str, strict: bool = False, **kw):
    """(pen changes as (line, down), warnings) under a dialect, mode chosen as read() does."""
    d = gcode.PenDialect(**kw)
    lines = text.split("\n")
    mode = gcode.detect_pen_mode(lines, d.m280_servo) if d.pen == "auto" else gcode.PEN_MODES[d.pen]
    warnings: list[str] = []
    recs = list(gcode.parse_lines(lines, NAME, mode, strict, warnings.append, d))
    return [(r.line, r.down) for r in recs if isinstance(r, Pen)], warnings


def dialect_error(text: str, **kw) -> str:
    with pytest.raises(InputError) as e:
        dialect_parse(text, **kw)
    assert "\n" not in str(e.value)
    return str(e.value)


def test_classic_dialect_is_todays_behaviour():
    text = "G0 Z5\nG1 Z-1\nG1 X1\nG0 Z0\nM3\nM5"
    assert dialect_parse(text)[0] == [(r.line, r.down) for r in records(text) if isinstance(r, Pen)]
    assert gcode.PenDialect() == gcode.CLASSIC


def test_z_threshold():
    text = "G0 Z5\nG1 Z2\nG1 X1\nG0 Z3\nG1 Z-1\nG0 Z2.5"
    assert dialect_parse(text, z_down_below_mm=2.5)[0] == [(2, True), (4, False), (5, True), (6, False)]
    assert dialect_parse(text)[0] == [(5, True), (6, False)]


def test_m3_m5_reversed():
    text = "M5\nG1 X1\nM3\nG0 X0"
    assert dialect_parse(text, m3_down=False)[0] == [(1, True), (3, False)]
    assert dialect_parse(text)[0] == [(3, True)]


MAKELANGELO = """; Makelangelo-style file
G21
G90
M280 P0 S90 T50
G0 X10 Y10
M280 P0 S25 T50
G1 X20 Y10 F3000
M280 P0 S90
G0 X0 Y0
M280 P1 S10"""


def test_m280_servo_angles_move_the_pen():
    pens, warnings = dialect_parse(MAKELANGELO)
    assert pens == [(6, True), (8, False)]            # the first S90 is "up": already up
    assert warnings == [f"{NAME}: warning: ignored codes that change nothing for a pen plotter: M280 P1"]
    # configurable up/down ranges: S90 now lowers, S25 lifts
    pens, _ = dialect_parse(MAKELANGELO, m280_up_s=(0, 30), m280_down_s=(80, 100))
    assert pens == [(4, True), (6, False), (8, True)]
    # another servo number is the pen
    pens, _ = dialect_parse(MAKELANGELO.replace("P1 S10", "P1 S10\nM280 P1 S100\nM280 P1 S0"),
                            m280_servo=1, pen="m280")
    assert pens == [(10, True), (11, False), (12, True)]


def test_m280_value_neither_up_nor_down_is_an_error_at_its_place():
    msg = dialect_error(MAKELANGELO.replace("S25 T50", "S60 T50"))
    assert msg.startswith(f"{NAME}:6:9: error: M280 S60 is neither pen up (S 70..180) nor pen down (S 0..50)")
    assert "m280_down_s" in msg
    assert dialect_error("M280 P0").startswith(f"{NAME}:1:1: error: M280 needs P")
    assert dialect_error("M280 S20").startswith(f"{NAME}:1:1: error: M280 needs P")
    assert "cannot share" in dialect_error("G4 M280 P0 S20")


def test_a_file_that_mixes_pen_modes():
    mixed = "M3\nM280 P0 S20\nG1 X1 Z-1\nG1 X2 Z1\nM5\nM280 P0 S120\nG0 X0"
    # auto: the first M280 or Z decides (here M280); Z and M3/M5 then change nothing, with a note
    pens, warnings = dialect_parse(mixed)
    assert pens == [(2, True), (6, False)]
    assert "M3, M5, Z x2" in warnings[0]
    # the config can choose another mode: the M280 lines are then ignored, S ranges unchecked
    assert dialect_parse(mixed, pen="z")[0] == [(3, True), (4, False)]
    assert dialect_parse(mixed.replace("S20", "S60"), pen="z")[0] == [(3, True), (4, False)]
    assert dialect_parse(mixed, pen="m3")[0] == [(1, True), (5, False)]
    # Z first: a Z file (today's rule), its M280 ignored
    pens, warnings = dialect_parse("G0 Z5\n" + mixed)
    assert pens == [(4, True), (5, False)] and "M280 P0 x2" in warnings[0]


def test_m280_words_p_s_t_are_not_reported_as_ignored_or_dwell():
    pens, warnings = dialect_parse("M280 P0 S30 T100\nG1 X1\nM280 P0 S100 T100")
    assert pens == [(1, True), (3, False)] and warnings == []


def test_read_uses_the_dialect(tmp_path):
    p = tmp_path / "m.gcode"
    p.write_text(MAKELANGELO)
    pens = [(r.line, r.down) for r in gcode.read(str(p), warn=lambda m: None) if isinstance(r, Pen)]
    assert pens == [(6, True), (8, False)]
    rev = gcode.PenDialect(pen="m3", m3_down=False)
    p.write_text("M5\nG1 X1\nM3")
    assert [(r.line, r.down) for r in gcode.read(str(p), dialect=rev) if isinstance(r, Pen)] == [
        (1, True), (3, False)]
