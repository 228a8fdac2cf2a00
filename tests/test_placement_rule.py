"""One placement rule for every kind of drawing (docs/drawing-files.md, Placement): without a
placement option a drawing is centred on G-code X0 Y0 (a G-code file keeps its own
coordinates, whose X0 Y0 that is); --fit, --align/--valign and --offset do the same to all."""

from __future__ import annotations

import json

import pytest

from support import REPO
from vplotter.cli import main


def _files(tmp_path) -> dict:
    from PIL import Image

    photo = tmp_path / "dark.png"
    Image.new("L", (60, 40), 0).save(photo)                # all ink: the drawing is the frame
    svg = tmp_path / "box.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="60mm" height="40mm" '
                   'viewBox="0 0 60 40"><rect x="0" y="0" width="60" height="40" '
                   'fill="none" stroke="black"/></svg>')
    ngc = tmp_path / "box.ngc"
    ngc.write_text("G0 X-30 Y-20\nM3\nG1 X30 Y-20\nG1 X30 Y20\nG1 X-30 Y20\nG1 X-30 Y-20\nM5\n")
    return {"photo": photo, "svg": svg, "gcode": ngc}


def _extent(capsys, path, *options) -> list[float]:
    code = main(["--config", str(REPO / "config.toml"), "info", str(path), "--json",
                 "--spacing", "2", *options] if path.suffix == ".png" else
                ["--config", str(REPO / "config.toml"), "info", str(path), "--json", *options])
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)["extent"]


def _centre(e):
    return ((e[0] + e[2]) / 2, (e[1] + e[3]) / 2)


@pytest.mark.parametrize("options, centre", [
    ((), (0.0, 0.0)),
    (("--offset", "20", "-10"), (20.0, -10.0)),
])
def test_the_defaults_land_every_kind_on_the_same_centre(capsys, tmp_path, options, centre):
    files = _files(tmp_path)
    sized = ("--width", "60")                  # the photo's size; the others are 60 mm wide
    for kind, path in files.items():
        e = _extent(capsys, path, *(sized if kind == "photo" else ()), *options)
        assert _centre(e) == pytest.approx(centre, abs=0.6), (kind, e)


def test_align_and_fit_treat_every_kind_alike(capsys, tmp_path):
    files = _files(tmp_path)
    for kind, path in files.items():
        size = ("--width", "60") if kind == "photo" else ()
        e = _extent(capsys, path, *size, "--align", "left", "--valign", "top", "--margin", "5")
        assert (e[0], e[3]) == pytest.approx((-195.0, 295.0), abs=0.6), (kind, e)
    # --fit: the largest inside the page, centred on the page (X -200..200, Y -250..300)
    svg, ngc = (_extent(capsys, files[k], "--fit") for k in ("svg", "gcode"))
    assert _centre(svg) == pytest.approx((0.0, 25.0), abs=0.01)
    assert svg == pytest.approx(ngc, abs=0.01)


def test_a_photo_without_a_size_is_the_largest_about_x0_y0(capsys, tmp_path):
    e = _extent(capsys, _files(tmp_path)["photo"])
    assert _centre(e) == pytest.approx((0.0, 0.0), abs=0.6)
    assert e[2] - e[0] == pytest.approx(400.0, abs=1.0)      # 3:2 inside 400 x 500 about X0 Y0
