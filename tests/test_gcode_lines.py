"""The quick reading of a plain G-code line (`gcode_words.read_line`) against the loop over
its characters (`sort_words(tokenize(...))`): the same words, values and columns, and the same
error for any line, plain or not (hypothesis, on lines made of G-code's pieces)."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st

from vplotter.errors import InputError
from vplotter.inputs.gcode_words import read_line, sort_words, tokenize

PIECES = ["G", "g", "M", "X", "Y", "Z", "I", "J", "R", "F", "P", "N", "S", "T", "E", "O", "t",
          "0", "1", "2", "01", "1.5", ".5", "1.", "30", "-", "+", "- ", " ", "  ", "\t", ".",
          "(c)", "(pen: red)", "(", ")", ";", "; x", "*", "*12", "%", "#1", "[", "e3",
          "1" * 400, "\r\n", "\n", "é", "٣"]


def outcome(fn):
    try:
        b = fn()
    except InputError as e:
        return "error", str(e)
    if b is None:
        return None
    return b.motion_col, b.vals, b.g_codes, b.m_codes, b.raw, b.line


def loop(raw: str):
    words = tokenize(raw, "f:7")
    return sort_words(raw, words, 7, "f:7") if words else None


def check(raw: str) -> None:
    assert outcome(lambda: read_line(raw, 7, "f")) == outcome(lambda: loop(raw))


def test_plain_and_odd_lines():
    for raw in ["G01 X51.006030 Y3.217270 Z-1.000000", "g1x1y2", "N10 G1 X1 (a;b) Y2 ; end",
                "G1 X1 X2", "G1 N2", "N1 N2", "(only a comment)", "", "  \t", "G1 X1.5.3",
                "M3 S1000", "G1 X+.5 Y-1.", "G1 X- 5", "G1 X1 *99", "%", "T1 M6 (pen: red)",
                "G2 X1 Y1 I0.5 J0.5\r\n", "G1 X" + "9" * 400, "M6 (pen: )",
                "G02 X1.5 Y-2 Z-1 I.5 J-0.25 F400.0", "G01 Y1 X2", "G01 X1 Y2 Z3 F-1",
                "G03 X1 Y2 R3", "G00 Z5.000000", "G1 X1 Y2 "]:
        check(raw)


@settings(max_examples=600, deadline=None)
@given(st.lists(st.sampled_from(PIECES), max_size=12))
def test_same_as_the_loop(pieces):
    check("".join(pieces))


NUMBER = st.sampled_from(["0", "1", "01", "1.5", ".5", "1.", "-1.000000", "+2", "-.25",
                          "51.006030", "- 1", "1e3", "1.2.3", ""])


@settings(max_examples=400, deadline=None)
@given(st.sampled_from(["G", "G0", "G00", "G01", "G02", "G03", "G1", "G17", "G-1", "G 1", "g1"]),
       st.lists(st.tuples(st.sampled_from("XYZIJFRPxX"), NUMBER, st.sampled_from([" ", "", "  "])),
                max_size=7),
       st.sampled_from(["", " ", "\r\n", "\n", "(c)", " ; x"]))
def test_moves_as_cam_programs_write_them(g, words, end):
    """A G code and X Y Z I J F words one space apart, read by one match: the same as the loop
    (and lines nearly like them, which it leaves to the loop)."""
    check(g + "".join(f"{sep}{letter}{value}" for letter, value, sep in words) + end)
