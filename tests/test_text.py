"""Text in single-stroke Hershey fonts (issue 23): the layout against boxes computed here from
the font package's own glyph table (advances, the cap line and the body of 32 units), SVG
<text> against boxes computed from its attributes, and the `text` command end to end."""

from __future__ import annotations

import json
import math
import random

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vplotter.cli import main
from vplotter.inputs import svg
from vplotter.inputs import text as T

NS = 'xmlns="http://www.w3.org/2000/svg"'
# one em = 32 Hershey units; the body runs 25 units above the baseline to 7 below (12 in the
# script fonts); the cap line is 21 units above the baseline
EM, ASCENT, CAP = 32.0, 25.0 / 32, 21.0 / 32


def package_advance(text: str, font: str = "futural") -> float:
    """The advance in ems, from the Hershey-Fonts package's glyph table directly: each glyph's
    width, or its strokes' extent where they reach past its sides (italic and script j, f)."""
    from HersheyFonts import HersheyFonts

    f = HersheyFonts()
    f.load_default_font(font)
    total = 0
    for c in text:
        g = f.all_glyphs[c]
        xs = [x for s in g.strokes for x, _ in s]
        total += max([g.left_offset + g.char_width, *xs]) - min([g.left_offset, *xs])
    return total / EM


def points(shape) -> np.ndarray:
    return np.concatenate(shape.polylines) if shape.polylines else np.zeros((0, 2))


# ------------------------------------------------------------------ layout
@pytest.mark.parametrize("font", ["futural", "timesr", "scripts", "gothiceng", "timesi"])
def test_layout_box_and_advance(font):
    text = "Hg Wy|j(]"
    size = 12.5
    s = T.layout(text, size, font=font)
    assert s.advance == pytest.approx(package_advance(text, font) * size)
    m = T.metrics(font)
    descent = -12 / EM if font == "scripts" else -7 / EM
    assert (m.ascent, m.descent) == (ASCENT, descent)
    p = points(s)
    assert p[:, 0].min() >= -1e-9 and p[:, 0].max() <= s.advance + 1e-9
    assert p[:, 1].min() >= descent * size - 1e-9 and p[:, 1].max() <= ASCENT * size + 1e-9
    assert s.missing == set()


def test_cap_height_and_baseline():
    s = T.layout("H", 32.0)          # one Hershey unit per mm
    p = points(s)
    assert p[:, 1].min() == pytest.approx(0) and p[:, 1].max() == pytest.approx(21)
    assert T.CAP_HEIGHT == CAP


@pytest.mark.parametrize("anchor, k", [("middle", 0.5), ("end", 1.0)])
def test_anchor_shifts_by_the_advance(anchor, k):
    a = T.layout("Plotter", 10)
    b = T.layout("Plotter", 10, anchor=anchor)
    assert b.advance == a.advance
    for pa, pb in zip(a.polylines, b.polylines, strict=True):
        assert np.allclose(pb, pa - (k * a.advance, 0))


def test_letter_spacing_widens_by_n_minus_one_gaps():
    a = T.layout("spacing", 10)
    b = T.layout("spacing", 10, letter_spacing=1.5)
    assert b.advance == pytest.approx(a.advance + 6 * 1.5)
    # the last glyph moved by 6 gaps
    assert np.allclose(b.polylines[-1], a.polylines[-1] + (9.0, 0))


def test_missing_glyphs_are_named_and_accents_fall_back():
    s = T.layout("a€é✓€", 10)
    assert s.missing == {"€", "✓"} and s.substituted == {"é": "e"}
    assert len(s.polylines) == len(T.layout("ae", 10).polylines)
    assert s.advance == pytest.approx(T.layout("a?e??", 10).advance)
    msg = T.missing_warning("x.svg", s.missing, s.substituted, "futural")
    assert msg.startswith("x.svg: warning: ") and "'€', '✓'" in msg and "'é'" in msg


def test_layout_lines_and_font_names():
    s = T.layout_lines("ab\ncd", 10, line_height=2)
    second = T.layout("cd", 10)
    assert np.allclose(s.polylines[-1], second.polylines[-1] - (0, 20))
    assert {"futural", "futuram", "timesr", "scripts", "gothiceng"} <= set(T.font_names())
    assert T.pick_font("'Times New Roman', serif") == "timesr"
    assert T.pick_font("Comic Sans") == "futural"
    assert T.pick_font("monospace") == "futural"
    assert T.pick_font("cursive") == "scripts"
    assert T.pick_font("serif", bold=True, italic=True) == "timesib"
    assert T.pick_font("gothiceng") == "gothiceng"


@settings(max_examples=60)
@given(text=st.text(st.characters(min_codepoint=32, max_codepoint=0x2FF), max_size=30),
       size=st.floats(0.1, 500), spacing=st.floats(0, 20),
       anchor=st.sampled_from(T.ANCHORS), font=st.sampled_from(["futural", "timesr", "scripts"]))
def test_any_printable_text_lays_out_inside_its_box(text, size, spacing, anchor, font):
    s = T.layout(text, size, font=font, anchor=anchor, letter_spacing=spacing)
    p = points(s)
    assert np.all(np.isfinite(p)) and math.isfinite(s.advance)
    if len(p):
        m = T.metrics(font)
        x0 = {"start": 0.0, "middle": -s.advance / 2, "end": -s.advance}[anchor]
        tol = 1e-9 * max(1.0, s.advance)
        assert p[:, 0].min() >= x0 - tol and p[:, 0].max() <= x0 + s.advance + tol
        assert p[:, 1].min() >= m.descent * size - 1e-9 and p[:, 1].max() <= m.ascent * size + 1e-9
    # every printable ASCII character has a glyph
    assert s.missing <= set(text) and all(ord(c) > 126 for c in s.missing)


# ------------------------------------------------------------------ SVG
def read(tmp_path, body: str, size='width="200mm" height="200mm" viewBox="0 0 200 200"'):
    p = tmp_path / "t.svg"
    p.write_text(f"<svg {NS} {size}>{body}</svg>", encoding="utf-8")
    warnings: list[str] = []
    return svg.read(str(p), 0.01, None, warnings.append), warnings


def to_user(pts: np.ndarray) -> np.ndarray:
    """G-code mm of the 200 x 200 mm page (1 user unit = 1 mm) back to SVG user units."""
    return np.column_stack([pts[:, 0] + 100, 100 - pts[:, 1]])


def by_src(d) -> dict[str, np.ndarray]:
    out: dict[str, list] = {}
    for s in d.strokes:
        out.setdefault(s.src, []).append(to_user(s.pts))
    return {k: np.concatenate(v) for k, v in out.items()}


def inside(p: np.ndarray, box, tol=1e-6) -> bool:
    x0, y0, x1, y1 = box
    return bool(np.all((p[:, 0] >= x0 - tol) & (p[:, 0] <= x1 + tol)
                       & (p[:, 1] >= y0 - tol) & (p[:, 1] <= y1 + tol)))


def box(x, y, text, fs, anchor="start", font="futural"):
    """The user-unit box (y down) of a line of text: advance x body, from the attributes."""
    w = package_advance(text, font) * fs
    left = x - {"start": 0, "middle": w / 2, "end": w}[anchor]
    below = 12 if font.startswith("script") else 7
    return left, y - ASCENT * fs, left + w, y + below / EM * fs


def test_text_lands_in_its_box_with_font_size_and_anchor(tmp_path):
    d, w = read(tmp_path, '<text id="a" x="20" y="50" font-size="10">Hello</text>'
                          '<text id="b" x="100" y="100" style="font-size:20px;text-anchor:middle">Mid</text>'
                          '<text id="c" x="190" y="150" font-size="8" text-anchor="end">End</text>')
    assert w == [] and d.skipped["text"] == 0
    got = by_src(d)
    for key, want in (("a", box(20, 50, "Hello", 10)), ("b", box(100, 100, "Mid", 20, "middle")),
                      ("c", box(190, 150, "End", 8, "end"))):
        assert inside(got[key], want)
        # and fills it: capitals reach the cap line, the first and last glyph its ends
        fs = (want[3] - want[1])
        assert got[key][:, 1].min() < want[1] + (ASCENT - CAP) * fs + 1e-6
        assert got[key][:, 0].max() - got[key][:, 0].min() > 0.8 * (want[2] - want[0])


def test_tspans_dy_and_new_chunks(tmp_path):
    d, _ = read(tmp_path, '<text id="t" x="10" y="50" font-size="10">AB<tspan font-size="20" '
                          'dy="5">CD</tspan><tspan x="190" text-anchor="end">EF</tspan></text>')
    p = by_src(d)["t"]
    ab = box(10, 50, "AB", 10)
    cd = box(ab[2], 55, "CD", 20)
    ef = box(190, 55, "EF", 10, "end")
    boxes = [ab, cd, ef]
    hits = [inside_each(p, b) for b in boxes]
    assert np.all(np.any(hits, axis=0))               # every point in one of the three
    assert all(h.any() for h in hits)                 # and each box drawn


def test_css_font_shorthand_sets_the_size(tmp_path):
    """matplotlib writes `style="font: 10px 'DejaVu Sans'; text-anchor: middle"`: the size is
    10 px, not the default 16 (in a style attribute and in a <style> rule; bold from it)."""
    d, w = read(tmp_path, '<style>.t { font: bold 12px/1.2 sans-serif }</style>'
                          '<text id="m" x="100" y="50" style="font: 10px \'DejaVu Sans\'; '
                          'text-anchor: middle">Time (s)</text>'
                          '<text id="b" class="t" x="10" y="150">Ab</text>')
    got = by_src(d)
    want = box(100, 50, "Time (s)", 10, "middle")
    assert inside(got["m"], want)
    assert got["m"][:, 1].max() - got["m"][:, 1].min() > 0.6 * (want[3] - want[1])
    assert inside(got["b"], box(10, 150, "Ab", 12, font="futuram"))


def inside_each(p, b, tol=1e-6):
    x0, y0, x1, y1 = b
    return (p[:, 0] >= x0 - tol) & (p[:, 0] <= x1 + tol) & (p[:, 1] >= y0 - tol) & (p[:, 1] <= y1 + tol)


def test_transform_css_and_inherited_font_size(tmp_path):
    body = ('<style>.big { font-size: 5mm }</style>'
            '<g transform="translate(30 40)" style="font-size:20px">'
            '<text id="t" transform="rotate(30) scale(2)" x="5" y="6"><tspan font-size="50%">Ab</tspan></text>'
            '<text id="u" class="big" x="0" y="100">Cd</text></g>')
    d, _ = read(tmp_path, body)
    got = by_src(d)
    # undo translate(30 40) rotate(30) scale(2): the points in the text's own units
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    q = got["t"] - (30, 40)
    q = np.column_stack([c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1]]) / 2
    assert inside(q, box(5, 6, "Ab", 10))
    assert inside(got["u"] - (30, 40), box(0, 100, "Cd", 5 * 96 / 25.4))


def test_white_space_collapses_as_browsers_show_it(tmp_path):
    d1, _ = read(tmp_path, '<text x="10" y="50">  a \n\t  b  </text>')
    d2, _ = read(tmp_path, '<text x="10" y="50">a b</text>')
    assert all(np.allclose(a.pts, b.pts) for a, b in zip(d1.strokes, d2.strokes, strict=True))
    d3, _ = read(tmp_path, '<text x="10" y="50" xml:space="preserve">a  b</text>')
    assert d3.strokes[-1].pts[:, 0].min() > d2.strokes[-1].pts[:, 0].min()


def test_hidden_tspan_keeps_its_place_and_hidden_text_is_counted(tmp_path):
    d1, _ = read(tmp_path, '<text x="10" y="50">a<tspan visibility="hidden">b</tspan>c</text>'
                           '<text x="10" y="80" display="none">gone</text>')
    d2, _ = read(tmp_path, '<text x="10" y="50">abc</text>')
    assert len(d1.strokes) == len(d2.strokes) - len(T.layout("b", 1).polylines)
    assert np.allclose(d1.strokes[-1].pts, d2.strokes[-1].pts)
    assert d1.skipped == {"text": 0, "image": 0, "hidden": 1}


def test_missing_glyphs_one_warning_for_the_file(tmp_path):
    d, w = read(tmp_path, '<text x="10" y="50">a€</text><text x="10" y="90">✓b€</text>')
    assert len(w) == 1 and "'€', '✓'" in w[0] and "warning:" in w[0]
    assert len(d.strokes) == len(T.layout("ab", 1).polylines)


def test_flowroot_wraps_in_its_rect_and_other_frames_are_counted(tmp_path):
    d, w = read(tmp_path, '<flowRoot id="f" style="font-size:10px"><flowRegion>'
                          '<rect x="20" y="30" width="60" height="80"/></flowRegion>'
                          '<flowPara>one two three four five six</flowPara></flowRoot>'
                          '<flowRoot id="g"><flowRegion><path d="M0 0 L9 9 L0 9z"/></flowRegion>'
                          '<flowPara>x</flowPara></flowRoot>')
    p = by_src(d)["f"]
    assert inside(p, (20, 30, 80, 110))
    assert np.ptp(p[:, 1]) > 2 * 1.25 * 10 * 0.9           # at least three lines
    assert d.skipped["text"] == 1 and len(w) == 1 and "1 flowed text element" in w[0]


def test_held_out_text_every_element_in_its_box(tmp_path):
    """Seeded random text elements: font size, anchor, translate/rotate/scale; every element
    draws, inside the box computed here from its attributes."""
    rng = random.Random(23)
    body, want = [], {}
    words = ["Plot", "wall", "Hershey", "pen 42", "V-plotter!", "gyp", "jiffy"]
    families = {"sans-serif": "futural", "Times New Roman, serif": "timesr",
                "cursive": "scripts"}
    for k in range(30):
        text, fs = rng.choice(words), rng.uniform(2, 12)
        family = rng.choice(list(families))
        anchor = rng.choice(T.ANCHORS)
        tx, ty, ang, sc = rng.uniform(30, 170), rng.uniform(30, 170), rng.uniform(-90, 90), \
            rng.uniform(0.5, 2)
        x, y = rng.uniform(-10, 10), rng.uniform(-10, 10)
        body.append(f'<text id="e{k}" x="{x}" y="{y}" font-size="{fs}" text-anchor="{anchor}" '
                    f'font-family="{family}" '
                    f'transform="translate({tx} {ty}) rotate({ang}) scale({sc})">{text}</text>')
        want[f"e{k}"] = (box(x, y, text, fs, anchor, families[family]), tx, ty, ang, sc)
    d, w = read(tmp_path, "".join(body))
    got = by_src(d)
    assert set(got) == set(want) and d.skipped["text"] == 0
    for key, (b, tx, ty, ang, sc) in want.items():
        c, s = math.cos(math.radians(ang)), math.sin(math.radians(ang))
        q = got[key] - (tx, ty)
        q = np.column_stack([c * q[:, 0] + s * q[:, 1], -s * q[:, 0] + c * q[:, 1]]) / sc
        assert inside(q, b, 1e-6), key


# ------------------------------------------------------------------ the command
def run(capsys, argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def test_text_command_writes_gcode_that_estimate_accepts(capsys, tmp_path, config_path):
    out = tmp_path / "hello.ngc"
    code, _, err = run(capsys, ["--config", config_path, "text", "Hello", "--height", "20",
                                "-o", out])
    assert code == 0, err
    ys = [float(w[1:]) for line in out.read_text().splitlines() if line.startswith("G1")
          for w in line.split() if w.startswith("Y")]
    assert min(ys) == pytest.approx(0, abs=1e-3) and max(ys) == pytest.approx(20, abs=1e-3)
    code, text, err = run(capsys, ["--config", config_path, "estimate", out])
    assert code == 0 and "plot time" in text, err


def test_text_command_summary_and_errors(capsys, tmp_path, config_path):
    code, out, _ = run(capsys, ["--config", config_path, "text", "Hi\\nthere", "--anchor",
                                "middle", "--font", "timesr"])
    assert code == 0 and "2 line(s) in timesr" in out and "plot time" in out
    for argv, what in ((["text", "x", "--font", "nope"], "no Hershey font 'nope'"),
                       (["text", "€"], "nothing to draw"),
                       (["text", "x", "--height", "5", "--width", "50"], "not both")):
        code, _, err = run(capsys, ["--config", config_path, *argv])
        errors = [line for line in err.splitlines() if "error:" in line]
        assert code == 2 and len(errors) == 1 and what in errors[0], err


def test_a_txt_file_is_drawn_as_text_lines(capsys, tmp_path, config_path):
    f = tmp_path / "note.txt"
    f.write_text("Hello\nWorld\n", encoding="utf-8")
    code, out, err = run(capsys, ["--config", config_path, "info", f, "--json"])
    assert code == 0, err
    info = json.loads(out)
    assert info["strokes"] == len(T.layout_lines("Hello\nWorld", 1).polylines)
    assert info["extent"][3] == pytest.approx(10, abs=1e-3)      # the capitals: 10 mm


def test_bad_text_files_and_stdout(capsys, tmp_path, config_path):
    f = tmp_path / "latin1.txt"
    f.write_bytes(b"caf\xe9\n")
    code, _, err = run(capsys, ["--config", config_path, "estimate", f])
    assert code == 2 and err.splitlines()[-1] == f"{f}: error: not UTF-8 text (byte 4)"
    code, out, _ = run(capsys, ["--config", config_path, "text", "A", "-o", "-"])
    assert code == 0 and out.startswith("(vplotter convert text: ") and out.rstrip().endswith("M2")


def test_use_of_a_text_and_unsupported_features_warn_once(tmp_path):
    d, w = read(tmp_path, '<defs><text id="t" x="0" y="0" rotate="10">ab</text></defs>'
                          '<use id="u1" href="#t" x="50" y="50"/><use id="u2" href="#t" x="50" y="90"/>'
                          '<text x="10" y="20"><textPath href="#p">on a path</textPath></text>')
    got = by_src(d)
    assert set(got) >= {"u1", "u2"}
    assert np.allclose(got["u2"], got["u1"] + (0, 40))
    assert len(w) == 1 and "rotate" in w[0] and "textPath" in w[0]


def test_a_font_size_that_does_not_parse_is_ignored_as_css_does(tmp_path):
    d1, w = read(tmp_path, '<g font-size="20"><text x="10" y="50" style="font-size:calc(1px)">'
                           'Ab<tspan font-size="-3">c</tspan></text></g>')
    d2, _ = read(tmp_path, '<text x="10" y="50" font-size="20">Abc</text>')
    assert w == [] and all(np.allclose(a.pts, b.pts)
                           for a, b in zip(d1.strokes, d2.strokes, strict=True))


def test_too_much_text_is_one_line_and_exit_2_with_memory_bounded(capsys, tmp_path,
                                                                  config_path):
    """A one-line 5 MB .txt (or SVG text) once took 2.5 GB and minutes: now refused at once."""
    f = tmp_path / "huge.txt"
    f.write_text("A" * (T.MAX_CHARS + 1), encoding="utf-8")
    code, _, err = run(capsys, ["--config", config_path, "estimate", f])
    assert code == 2 and err.splitlines()[-1] == (
        f"{f}: error: more than {T.MAX_CHARS:,} characters of text: too many to draw")
    svg = tmp_path / "huge.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="10mm">'
                   + "<text x='0' y='5'>ABCDEFGHIJ</text>" * (T.MAX_CHARS // 10 + 1) + "</svg>")
    code, _, err = run(capsys, ["--config", config_path, "estimate", svg])
    assert code == 2 and err.splitlines()[-1].startswith(f"{svg}: error: more than")
