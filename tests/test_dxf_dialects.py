"""DXFs as CAD programs write them (issue 33): AutoCAD R12 to R2018, LibreCAD, QCAD, FreeCAD,
Inkscape and a script's table-less R12, with text in styles and fonts the file lacks, SHX
paths, unicode escapes, %% codes, MTEXT formatting codes, layers the LAYER table lacks, and
broken entities. Every one converts (`vplotter convert F.dxf -o out.ngc`, exit 0) with its
warnings counted, and its line geometry is where it was written: the coordinates given to
ezdxf, sampled here, lie within 0.02 mm of the pen-down path that the reference G-code reader
(tests/support/tracecheck, which imports nothing of vplotter) reads from out.ngc.

Each drawing has a frame (0, 0)-(200, 150) around everything drawn, so the drawing's centre,
which convert puts on X0 Y0, is (100, 75)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from support import tracecheck as tc

ezdxf = pytest.importorskip("ezdxf")

from vplotter.cli import main  # noqa: E402
from vplotter.inputs import dxf, dxf_text  # noqa: E402

CENTRE = np.array([100.0, 75.0])
FRAME = [(0, 0), (200, 0), (200, 150), (0, 150)]
VERSIONS = ["R12", "R2000", "R2004", "R2007", "R2010", "R2013", "R2018"]
NAN = float("nan")


class Written:
    """What a test gave ezdxf, as points sampled along it (in the file's mm)."""

    def __init__(self):
        self.parts: list[np.ndarray] = []

    def line(self, a, b) -> None:
        t = np.linspace(0, 1, 50)[:, None]
        self.parts.append(np.array(a, float) * (1 - t) + np.array(b, float) * t)

    def polygon(self, pts) -> None:
        for a, b in zip(pts, pts[1:] + pts[:1]):
            self.line(a, b)

    def arc(self, c, r, a0=0.0, a1=360.0) -> None:
        sweep = (a1 - a0) % 360 or 360
        t = np.radians(a0 + sweep * np.linspace(0, 1, 200))
        self.parts.append(np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)]))

    def points(self) -> np.ndarray:
        return np.concatenate(self.parts)


def convert(tmp_path, capsys, config_path, path) -> tuple[list[np.ndarray], list[str]]:
    """Convert the file as a person does: exit 0, no error; (pen-down polylines read back by
    the reference reader, the warning lines)."""
    out = tmp_path / "out.ngc"
    code = main(["--config", str(config_path), "convert", str(path), "-o", str(out)])
    got, err = capsys.readouterr()
    assert code == 0 and "Traceback" not in err + got, err
    assert "error:" not in err, err
    return tc.reference_path(out, spacing=0.05), [ln for ln in err.splitlines()
                                                  if "warning:" in ln]


def assert_drawn(polylines, written: Written, tol: float = 0.02) -> None:
    d = tc.distances_to_polylines(written.points() - CENTRE, polylines)
    assert d.max() <= tol, f"written geometry {d.max():.4f} mm from what was drawn"
    # nothing broken became a dot: every pen-down path goes somewhere
    assert all(np.ptp(p, axis=0).max() > 0 for p in polylines)


def geometry(msp, w: Written, version: str, **attribs) -> None:
    """The shapes every dialect draws: frame, lines, circle, arc, a polyline with a bulge."""
    if version == "R12":
        msp.add_polyline2d(FRAME, close=True, dxfattribs=attribs)
        msp.add_polyline2d([(20, 120, 0, 0, 1), (60, 120, 0, 0, 0)], format="xyseb",
                           dxfattribs=attribs)
    else:
        msp.add_lwpolyline(FRAME, close=True, dxfattribs=attribs)
        msp.add_lwpolyline([(20, 120, 1), (60, 120, 0)], format="xyb", dxfattribs=attribs)
    w.polygon(FRAME)
    w.arc((40, 120), 20, 180, 360)               # bulge 1: a half circle, counter-clockwise
    msp.add_line((10, 10), (60, 40), dxfattribs=attribs)
    w.line((10, 10), (60, 40))
    msp.add_line((150, 20), (190, 20), dxfattribs=attribs)
    w.line((150, 20), (190, 20))
    msp.add_circle((100, 75), 20, dxfattribs=attribs)
    w.arc((100, 75), 20)
    msp.add_arc((160, 100), 15, 30, 200, dxfattribs=attribs)
    w.arc((160, 100), 15, 30, 200)


def style_warning(path, n: int, names: str) -> str:
    return (f"{path}: warning: {n} text{'s' if n > 1 else ''} in styles or fonts not found "
            f"({names}): drawn in the default single-stroke font (futural)")


# ------------------------------------------------------------------ AutoCAD R12 to R2018
@pytest.mark.parametrize("version", VERSIONS)
def test_autocad_versions(tmp_path, capsys, config_path, version):
    """Each version ezdxf writes: styles with an SHX path, a font no one knows and one the
    table lacks, a text without a style, unicode escapes and %% codes, MTEXT formatting codes
    (R2000 on), a zero-length line (a CAD leftover): drawn, the rest counted."""
    doc = ezdxf.new(version) if version == "R12" else ezdxf.new(version, units=4)
    msp = doc.modelspace()
    w = Written()
    geometry(msp, w, version)
    doc.styles.add("ROMANS", font="C:\\Fonts\\romans.shx")
    doc.styles.add("LATIN", font="normallatin1")
    msp.add_text("ROMANS %%p1", height=5, dxfattribs={"style": "ROMANS", "insert": (80, 20)})
    msp.add_text("LATIN \\U+00B0", height=5, dxfattribs={"style": "LATIN", "insert": (80, 30)})
    msp.add_text("GONE %%c5 %%d %%uU%%u", height=5,
                 dxfattribs={"style": "GONE", "insert": (80, 40)})
    msp.add_text("PLAIN", height=5, dxfattribs={"insert": (80, 130)})
    replaced, names = 2, "normallatin1, GONE"
    if version != "R12":
        msp.add_mtext("\\fArial|b1;BOLD\\P{\\H2x;BIG} \\U+00B1 \\S1/2;",
                      dxfattribs={"style": "romans2", "char_height": 4, "insert": (120, 140)})
        replaced, names = 3, "normallatin1, GONE, romans2"
    msp.add_line((5, 5), (5, 5))
    p = tmp_path / f"acad_{version}.dxf"
    doc.saveas(p)
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    assert_drawn(drawn, w)
    assert style_warning(p, replaced, names) in warnings
    assert f"{p}: warning: 1 broken entity not drawn: 1 of zero size (LINE " in warnings[-1]
    glyphs = [ln for ln in warnings if "no glyph" in ln]
    assert len(glyphs) == 1 and "'°', '±', 'Ø'" in glyphs[0]    # decoded, then missing
    assert len(warnings) == 3


# ------------------------------------------------------------------ other programs
def test_librecad(tmp_path, capsys, config_path):
    """LibreCAD (R2007): MTEXT and TEXT in styles named after its LFF fonts that the STYLE
    table does not hold (the files that were refused with `MTEXT 50: cannot be drawn:
    normallatin1`), layers the LAYER table lacks."""
    doc = ezdxf.new("R2007", units=4)
    msp = doc.modelspace()
    w = Written()
    geometry(msp, w, "R2007", layer="Konstruktion")       # not in the LAYER table
    for k in range(12):
        style = "normallatin1" if k % 3 else "romans2"
        msp.add_mtext(f"Bohrung {k}\\P%%c8", dxfattribs={"style": style, "char_height": 3,
                                                          "insert": (70 + 10 * (k % 4),
                                                                     60 + 8 * (k // 4))})
    p = tmp_path / "librecad.dxf"
    doc.saveas(p)
    assert "Konstruktion" not in [lay.dxf.name for lay in ezdxf.readfile(p).layers]
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    assert_drawn(drawn, w)
    assert warnings[0] == style_warning(p, 12, "romans2, normallatin1")
    assert len(warnings) == 2 and "'Ø'" in warnings[1]


def test_qcad(tmp_path, capsys, config_path):
    """QCAD (R2000): its CXF font "standard" as the style's font, TEXT alignments."""
    from ezdxf.enums import TextEntityAlignment

    doc = ezdxf.new("R2000", units=4)
    msp = doc.modelspace()
    w = Written()
    geometry(msp, w, "R2000")
    doc.styles.add("standard_qcad", font="standard")
    t = msp.add_text("Ø 20", height=4, dxfattribs={"style": "standard_qcad"})
    t.set_placement((100, 130), align=TextEntityAlignment.MIDDLE_CENTER)
    p = tmp_path / "qcad.dxf"
    doc.saveas(p)
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    assert_drawn(drawn, w)
    assert warnings == [style_warning(p, 1, "standard"),
                        f"{p}: warning: no glyph in futural for 'Ø' (left blank)"]


def test_freecad_r12(tmp_path, capsys, config_path):
    """FreeCAD's R12: POLYLINE with bulges, layers named after objects and missing from the
    table, TEXT in the "STANDARD" style of its own spelling: no warning."""
    doc = ezdxf.new("R12")
    msp = doc.modelspace()
    w = Written()
    geometry(msp, w, "R12", layer="Sketch001")
    msp.add_text("Part 7", height=5, dxfattribs={"style": "STANDARD", "insert": (80, 130),
                                                  "layer": "Annotation"})
    p = tmp_path / "freecad.dxf"
    doc.saveas(p)
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    assert_drawn(drawn, w)
    assert warnings == []


def test_inkscape(tmp_path, capsys, config_path):
    """Inkscape's DXF (R14 as R2000 here): paths as LWPOLYLINEs and cubic Béziers as SPLINEs
    of control points, a layer per Inkscape layer, mm units."""
    doc = ezdxf.new("R2000", units=4)
    doc.layers.add("Layer 1")
    msp = doc.modelspace()
    w = Written()
    geometry(msp, w, "R2000", layer="Layer 1")
    bez = [(20, 60), (40, 90), (60, 30), (80, 60)]
    msp.add_open_spline(bez, degree=3, dxfattribs={"layer": "Layer 1"})
    t = np.linspace(0, 1, 200)[:, None]
    b = np.array(bez, float)
    w.parts.append((1 - t) ** 3 * b[0] + 3 * (1 - t) ** 2 * t * b[1] + 3 * (1 - t) * t ** 2
                   * b[2] + t ** 3 * b[3])
    p = tmp_path / "inkscape.dxf"
    doc.saveas(p)
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    assert_drawn(drawn, w)
    assert warnings == []


def test_tableless_r12(tmp_path, capsys, config_path):
    """A script's R12: an ENTITIES section only (no LAYER or STYLE table), TEXT without a
    style: drawn in the Standard font, no warning."""
    ents = []
    for a, b in zip(FRAME, FRAME[1:] + FRAME[:1]):
        ents.append(f"0\nLINE\n8\nCUT\n10\n{a[0]}\n20\n{a[1]}\n11\n{b[0]}\n21\n{b[1]}\n")
    ents.append("0\nCIRCLE\n8\nHOLES\n10\n100\n20\n75\n40\n20\n")
    ents.append("0\nTEXT\n8\nTXT\n10\n20\n20\n20\n40\n5\n1\nM6 \\U+00D8\n")
    p = tmp_path / "script.dxf"
    p.write_text("0\nSECTION\n2\nENTITIES\n" + "".join(ents) + "0\nENDSEC\n0\nEOF\n")
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    w = Written()
    w.polygon(FRAME)
    w.arc((100, 75), 20)
    assert_drawn(drawn, w)
    assert warnings == [f"{p}: warning: no glyph in rowmans for 'Ø' (left blank)"]


# ------------------------------------------------------------------ broken entities
def test_broken_entities_are_skipped_and_counted(tmp_path, capsys, config_path):
    """Entities of zero size, with values that are not finite, a SPLINE ezdxf cannot evaluate,
    an INSERT of a missing block, one with a rotation that is not a number, entity types not
    drawn: the rest of the file is drawn, each kind in one warning."""
    doc = ezdxf.new("R2010", units=4)
    msp = doc.modelspace()
    w = Written()
    geometry(msp, w, "R2010")
    blk = doc.blocks.new("PART")
    blk.add_line((0, 0), (10, 0))
    zero = blk.add_line((3, 3), (3, 3))                  # zero size, inside a block
    good = msp.add_blockref("PART", (120, 50))
    w.line((120, 50), (130, 50))
    nan = msp.add_blockref("PART", (0, 0), dxfattribs={"rotation": NAN})
    gone = msp.add_blockref("GONE", (0, 0))
    msp.add_blockref("GONE", (1, 0))
    for _ in range(3):
        msp.add_line((7, 7), (7, 7))
    msp.add_circle((50, 50), 0)
    msp.add_circle((NAN, 50), 3)
    msp.add_arc((50, 50), 3, NAN, 40)
    msp.add_lwpolyline([(0, 0, NAN), (10, 0, 0)], format="xyb")
    spline = msp.add_spline([(30, 30)])
    msp.add_text("NaN", height=5, rotation=NAN)
    msp.add_point((3, 3))
    p = tmp_path / "broken.dxf"
    doc.saveas(p)
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    assert_drawn(drawn, w)
    assert warnings == [
        f"{p}: warning: not drawn: 1 POINT (drawn: lines, polylines, arcs, circles, ellipses, "
        f"splines, blocks, text)",
        f"{p}: warning: 11 broken entities not drawn: 5 of zero size (first INSERT "
        f"{good.dxf.handle} > LINE {zero.dxf.handle}), 5 with values that are not finite (first "
        f"INSERT {nan.dxf.handle}), 1 that cannot be read (SPLINE {spline.dxf.handle}: two or "
        f"more points required)",
        f"{p}: warning: 2 INSERTs skipped (first INSERT {gone.dxf.handle}): no block 'GONE'"]


def test_unknown_entity_types_are_counted(tmp_path, capsys, config_path):
    """An entity type ezdxf does not know (no attributes, no layer) and a proxy entity: one
    'not drawn' warning, the rest drawn."""
    p = tmp_path / "unknown.dxf"
    p.write_text("0\nSECTION\n2\nENTITIES\n0\nLINE\n8\nL1\n10\n0\n20\n0\n11\n200\n21\n"
                 "150\n0\nFOOBAR\n8\nL1\n10\n0\n20\n0\n0\nACAD_PROXY_ENTITY\n8\n0\n0\n"
                 "ENDSEC\n0\nEOF\n")
    drawn, warnings = convert(tmp_path, capsys, config_path, p)
    w = Written()
    w.line((0, 0), (200, 150))
    assert_drawn(drawn, w)
    assert warnings == [f"{p}: warning: not drawn: 1 ACAD_PROXY_ENTITY, 1 FOOBAR (drawn: lines, "
                        f"polylines, arcs, circles, ellipses, splines, blocks, text)"]


def test_bad_files_are_still_refused(tmp_path, capsys, config_path):
    """The file itself broken: truncated, not a DXF: one error line, exit 2."""
    doc = ezdxf.new("R2010")
    doc.modelspace().add_line((0, 0), (1, 0))
    doc.saveas(tmp_path / "ok.dxf")
    data = (tmp_path / "ok.dxf").read_bytes()
    for name, content in (("trunc.dxf", data[:len(data) // 3]), ("junk.dxf", b"G1 X1\n")):
        p = tmp_path / name
        p.write_bytes(content)
        code = main(["--config", str(config_path), "convert", str(p), "-o",
                     str(tmp_path / "o.ngc")])
        err = capsys.readouterr().err
        errors = [ln for ln in err.splitlines() if "error:" in ln]
        assert code == 2 and len(errors) == 1 and errors[0].startswith(f"{p}: error:")


# ------------------------------------------------------------------ text content, fonts
def strokes_of(tmp_path, build, name="t.dxf"):
    doc = ezdxf.new("R2010", units=4)
    build(doc.modelspace())
    p = tmp_path / name
    doc.saveas(p)
    warnings: list[str] = []
    d = dxf.read(str(p), 0.01, None, warnings.append, centre=False)
    return [s.pts for s in d.strokes], warnings


def same(a, b) -> bool:
    return len(a) == len(b) and all(np.allclose(p, q) for p, q in zip(a, b))


def test_escapes_draw_the_characters_they_name(tmp_path):
    """\\U+XXXX in TEXT and MTEXT is the character; MTEXT's formatting codes are dropped."""
    plain, _ = strokes_of(tmp_path, lambda m: m.add_text("ABC", height=5))
    escaped, _ = strokes_of(tmp_path, lambda m: m.add_text("\\U+0041B\\U+0043", height=5))
    assert same(plain, escaped) and len(plain) > 3
    kw = {"dxfattribs": {"char_height": 4}}
    plain, _ = strokes_of(tmp_path, lambda m: m.add_mtext("AB CD\\PEF", **kw))
    coded, _ = strokes_of(tmp_path, lambda m: m.add_mtext(
        "\\fArial|b1|i0|c0|p34;A{\\H2x;B}\\~\\U+0043{\\C1;D}\\PE\\LF\\l", **kw))
    assert same(plain, coded) and len(plain) > 5
    assert dxf_text.unescape("a\\U+00B0b") == "a°b"
    assert dxf_text.unescape("\\\\U+0041 \\U+005C", mtext=True) == "\\\\U+0041 \\\\"


@pytest.mark.parametrize("font, hershey", [("C:\\Fonts\\romans.shx", "rowmans"),
                                           ("/usr/share/fonts/ISOCP.SHX", "rowmans"),
                                           ("romand", "rowmand"), ("times.ttf", "timesr"),
                                           ("Arial.ttf", "futural"), ("", "rowmans")])
def test_known_fonts_warn_nothing(tmp_path, font, hershey):
    def build(m):
        m.doc.styles.add("S", font=font)
        m.add_text("Fonts", height=5, dxfattribs={"style": "S"})

    from vplotter.inputs import text as h

    got, warnings = strokes_of(tmp_path, build)
    assert warnings == []
    assert same(got, h.layout("Fonts", 5, font=hershey).polylines)    # at X0 Y0, size 5
