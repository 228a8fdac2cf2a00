"""The reader registry (src/vplotter/readers/): a reader registered in a test is drawn with no
other change, and `file_kind` keeps the sniffing rules it had before the registry (a copy of
the old function is the reference)."""

from __future__ import annotations

import argparse
import os
import tempfile

import numpy as np
import pytest
from hypothesis import given, strategies as st

from vplotter import config, readers
from vplotter.cli import main
from vplotter.errors import ConfigError
from vplotter.prepare import prepare
from vplotter.readers import Reader, file_kind

from conftest import REPO


# ------------------------------------------------------------------ a fake format
def _read_xy(path: str, ctx):
    """A file of "x y" lines: one stroke through the points."""
    from vplotter.inputs.strokes import Drawing, Stroke

    with open(path) as f:
        pts = [tuple(map(float, line.split())) for line in f if line.strip()]
    return Drawing(path, [Stroke(np.array(pts), 1)])


XY = Reader("xy", "point list", (".xy",), _read_xy,
            lambda path, stroke, k: f"{path}: point list {k + 1}")


@pytest.fixture
def xy_file(tmp_path, monkeypatch):
    monkeypatch.setattr(readers, "READERS", (XY,) + readers.READERS)
    f = tmp_path / "square.xy"
    f.write_text("0 0\n20 0\n20 20\n0 20\n0 0\n")
    return f


def _args(**kw) -> argparse.Namespace:
    base = dict(order=None, rotate=None, fit=False, scale=None, margin=0.0, align=None,
                valign=None, offset=None, join=None, layer=None, pause_between_layers=False,
                strict=False)
    return argparse.Namespace(**{**base, **kw})


def test_a_registered_reader_is_prepared(xy_file):
    cfg = config.load(REPO / "config.toml")
    assert file_kind(str(xy_file)) == "xy"
    prep = prepare(str(xy_file), cfg, _args(offset=(5.0, -5.0)), warn=lambda m: None)
    assert prep.kind == "xy" and not prep.passthrough
    assert len(prep.strokes) == 1
    box = prep.strokes[0].pts
    assert np.allclose(box.min(axis=0), (5.0, -5.0))          # moved by --offset
    assert prep.where(1) == f"{xy_file}: point list 1"
    with pytest.raises(ConfigError, match="--layer is for SVG and DXF files"):
        prepare(str(xy_file), cfg, _args(layer=["a"]), warn=lambda m: None)


def test_a_registered_reader_is_drawn(xy_file, capsys):
    cfg = str(REPO / "config.toml")
    assert main(["--config", cfg, "calibrate", "--at", "0", "0"]) == 0
    capsys.readouterr()
    assert main(["--config", cfg, "draw", str(xy_file), "--dry-run"]) == 0
    out, err = capsys.readouterr()
    assert "Traceback" not in err and "error" not in err
    assert f"{xy_file}: 1 strokes placed and ordered in" in out
    assert main(["--config", cfg, "info", str(xy_file)]) == 0      # named by its title
    assert capsys.readouterr().out.startswith(f"{xy_file}: point list, 20 x 20 mm")


# ------------------------------------------------------------------ file_kind
def _old_file_kind(path: str) -> str:
    """prepare.file_kind as it was before the registry."""
    svg_suffixes, text_suffixes = (".svg", ".svgz"), (".txt",)
    image_suffixes = (".png", ".jpg", ".jpeg", ".webp", ".bmp", ".tif", ".tiff", ".gif")
    image_magic = (b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff", b"GIF87a", b"GIF89a", b"II*\x00",
                   b"MM\x00*")
    low = path.lower()
    if low.endswith(svg_suffixes):
        return "svg"
    if low.endswith(".dxf"):
        return "dxf"
    if low.endswith(image_suffixes):
        return "image"
    try:
        with open(path, "rb") as f:
            head = f.read(256)
    except OSError:
        head = None
    text = head.lstrip(b"\xef\xbb\xbf \t\r\n") if head is not None else b""
    if low.endswith(text_suffixes):
        return "svg" if text.startswith((b"<?xml", b"<svg", b"<!--", b"<!DOCTYPE")) else "text"
    if head is None:
        return "gcode"
    if head.startswith(image_magic) or (head[:4] == b"RIFF" and head[8:12] == b"WEBP"):
        return "image"
    if head.startswith(b"AutoCAD Binary DXF") or head.split()[:2] == [b"0", b"SECTION"]:
        return "dxf"
    if head.startswith(b"\x1f\x8b") or text.startswith(b"<"):
        return "svg"
    return "gcode"


PIECES = [b"", b"\xef\xbb\xbf", b" ", b"\t", b"\r\n", b"\n", b"\x0c", b"<", b"<?xml", b"<svg",
          b"<!--", b"<!DOCTYPE", b"<html>", b"0", b"SECTION", b"0\nSECTION\n",
          b"AutoCAD Binary DXF", b"\x1f\x8b", b"\x89PNG\r\n\x1a\n", b"\xff\xd8\xff",
          b"GIF87a", b"GIF89a", b"II*\x00", b"MM\x00*", b"RIFF", b"WEBP", b"\x00\x00\x00\x00",
          b"G1 X0 Y0\n", b"hello", b"\xbf"]
NAMES = ["a", "a.ngc", "a.gcode", "a.svg", "A.SVG", "a.svgz", "a.txt", "a.TXT", "a.dxf",
         "a.DXF", "a.png", "a.JPG", "a.jpeg", "a.webp", "a.bmp", "a.tif", "a.tiff", "a.gif",
         "a.svg.txt", "a.txt.svg", "a.png.txt"]


@given(name=st.sampled_from(NAMES),
       head=st.lists(st.sampled_from(PIECES) | st.binary(max_size=6), max_size=5)
       .map(b"".join))
def test_file_kind_keeps_the_old_rules(name, head):
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, name)
        with open(path, "wb") as f:
            f.write(head)
        assert file_kind(path) == _old_file_kind(path)


@pytest.mark.parametrize("name", NAMES)
def test_file_kind_of_a_missing_file(name, tmp_path):
    path = str(tmp_path / name)
    assert file_kind(path) == _old_file_kind(path)


@pytest.mark.parametrize("head, name, kind", [
    (b"<svg/>", "a.txt", "svg"), (b"\xef\xbb\xbf  <?xml", "a.txt", "svg"),
    (b"<html>", "a.txt", "text"), (b"0\nSECTION", "a.txt", "text"),
    (b"0\nSECTION\n", "a", "dxf"), (b"\x1f\x8b", "a", "svg"), (b"<html>", "a", "svg"),
    (b"GIF89a", "a", "image"), (b"RIFF\x00\x00\x00\x00WEBP", "a", "image"),
    (b"G1 X1", "a.ngc", "gcode"), (b"<svg/>", "a.png", "image"), (b"", "a.dxf", "dxf"),
])
def test_file_kind_examples(head, name, kind, tmp_path):
    f = tmp_path / name
    f.write_bytes(head)
    assert file_kind(str(f)) == kind


def test_every_reader_names_its_kind_once():
    kinds = [r.kind for r in readers.READERS]
    assert len(kinds) == len(set(kinds))
    assert readers.READERS[-1].kind == "gcode"        # what no other reader takes
    assert all(readers.reader_of(k).kind == k for k in kinds)
