"""--cmyk: a colour photo separated into yellow, cyan, magenta and black pen layers, each drawn
in the chosen style, all within one budget; `preview --ink` draws each pen in its colour."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from vplotter.cli import main
from vplotter.drawing import photo
from vplotter.drawing.place import Box, Placement
from vplotter.inputs.image import cmyk
from vplotter.inputs.image.load import srgb_encode

STYLES = ("hatch", "spiral", "squiggle", "stipple")
PAGE = Box(-200, -250, 200, 300)
COLOURS = {"yellow": "#ffff00", "cyan": "#00ffff", "magenta": "#ff00ff", "black": "#000000"}


def save(tmp_path, linear_rgb, name="c.png"):
    """An (H, W, 3) linear-light picture saved as an 8-bit sRGB PNG."""
    v = np.round(srgb_encode(np.asarray(linear_rgb, dtype=float)) * 255).astype(np.uint8)
    path = tmp_path / name
    Image.fromarray(v).save(path)
    return path


def layered(path, style="hatch", spacing=1.5, width=80.0):
    """{pen: drawn mm} and the strokes of --cmyk at a fixed spacing."""
    drawn, _, _ = photo.strokes(str(path), photo.PhotoOptions(style=style, spacing_mm=spacing,
                                                              cmyk=True, width_mm=width),
                                PAGE, Placement(), None)
    per = {}
    for s in drawn:
        per[s.pen] = per.get(s.pen, 0.0) + s.length_mm() + (0.5 if len(s.pts) == 1 else 0.0)
    return per, drawn


def test_separation_of_primaries_and_grey():
    rgb = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0.5], [1, 1, 1], [0, 0, 0],
                    [0.2, 0.6, 0.9]], dtype=np.float32).T[:, None, :]      # (3, 1, 7)
    y, c, m, k = cmyk.separate(rgb)[:, 0, :]
    assert np.allclose(np.stack([y, c, m, k])[:, :3],
                       [[1, 1, 0], [0, 1, 1], [1, 0, 1], [0, 0, 0]])    # red, green, blue
    assert np.allclose([y[3], c[3], m[3], k[3]], [0, 0, 0, 0.5])           # grey: black only
    assert np.allclose([y[4], c[4], m[4], k[4]], 0)                        # white: nothing
    assert np.allclose([y[5], c[5], m[5], k[5]], [0, 0, 0, 1])             # black
    assert min(y[6], c[6], m[6]) == 0                                      # never all four


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0, 1), min_size=3, max_size=3))
def test_separation_reproduces_the_colour(rgb):
    """Ideal inks multiplying on white give the pixel back: (1 - c)(1 - k) = r, and so on."""
    y, c, m, k = cmyk.separate(np.array(rgb, dtype=np.float32)[:, None, None])[:, 0, 0]
    assert all(0 <= v <= 1 for v in (y, c, m, k))
    back = np.array([(1 - c) * (1 - k), (1 - m) * (1 - k), (1 - y) * (1 - k)])
    assert np.allclose(back, rgb, atol=1e-4)


@pytest.mark.parametrize("style", STYLES)
def test_red_is_magenta_and_yellow_only(tmp_path, style):
    red = np.zeros((40, 60, 3))
    red[..., 0] = 1.0
    per, drawn = layered(save(tmp_path, red), style, spacing=2.0)
    assert set(per) == {"yellow", "magenta"}, per
    assert all(s.colour == COLOURS[s.pen] for s in drawn)
    pens = [s.pen for s in drawn]                     # light to dark, each pen's strokes together
    assert pens == sorted(pens, key=["yellow", "cyan", "magenta", "black"].index)


@pytest.mark.parametrize("style", ("hatch", "squiggle"))
def test_grey_is_mostly_black(tmp_path, style):
    grey = np.full((40, 60, 3), 0.3)
    per, _ = layered(save(tmp_path, grey), style)
    assert set(per) == {"black"}, per                 # a neutral grey: black alone
    grey[:, :, 0] += 0.01                             # a slight red tint: a little magenta
    per, _ = layered(save(tmp_path, grey, "tint.png"), style)     # and yellow
    assert per.get("black", 0) > 0.8 * sum(per.values()), per


@pytest.mark.parametrize("style", ("hatch", "squiggle", "spiral"))
def test_each_layer_follows_its_separation(tmp_path, style):
    """Four bands across: cyan rising left to right, magenta falling, no yellow, no black:
    each pen's ink per band follows its own coverage."""
    h, w = 40, 80
    cov = np.repeat([0.15, 0.4, 0.65, 0.9], w // 4)[None, :].repeat(h, 0)
    rgb = np.stack([1 - cov, cov, np.ones_like(cov)], axis=-1)     # cyan cov, magenta 1 - cov
    _, drawn = layered(save(tmp_path, rgb), style, spacing=1.5)
    x0 = PAGE.centre[0] - 40
    for pen, rising in (("cyan", True), ("magenta", False)):
        ink = np.zeros(4)
        for s in drawn:
            if s.pen == pen and len(s.pts) > 1:
                seg = np.hypot(*np.diff(s.pts, axis=0).T)
                k = np.maximum(1, np.ceil(seg / 0.25)).astype(int)      # pieces of <= 0.25 mm
                i = np.repeat(np.arange(len(seg)), k)
                f = (np.arange(k.sum()) - np.repeat(np.cumsum(k) - k, k) + 0.5) / k[i]
                mid = s.pts[i] + (s.pts[i + 1] - s.pts[i]) * f[:, None]
                band = np.clip(((mid[:, 0] - x0) // 20).astype(int), 0, 3)
                ink += np.bincount(band, seg[i] / k[i], minlength=4)
        steps = np.diff(ink if rising else ink[::-1])
        assert (steps > 0).all(), (pen, ink)
    assert {s.pen for s in drawn} <= {"cyan", "magenta"}


def test_convert_cmyk_fits_one_budget_and_ink_preview_is_coloured(tmp_path, capsys,
                                                                   config_path):
    rgb = np.ones((60, 90, 3))
    rgb[:, :30] = [1, 0, 0]                           # red, green, grey
    rgb[:, 30:60] = [0, 1, 0]
    rgb[:, 60:] = [0.2, 0.2, 0.2]
    path = save(tmp_path, rgb)
    out = tmp_path / "c.ngc"
    code = main(["--config", str(config_path), "convert", str(path), "-o", str(out), "--cmyk",
                 "--width", "90", "--max-time", "10m"])
    _, err = capsys.readouterr()
    assert code == 0, err
    assert "cmyk: four pens" in err and "within 10:00" in err
    assert main(["--config", str(config_path), "estimate", str(out)]) == 0
    t = float(re.search(r"\(([\d.]+) s\)", capsys.readouterr()[0]).group(1))
    assert t <= 600 * 1.01
    png = tmp_path / "ink.png"
    assert main(["--config", str(config_path), "preview", str(path), "--cmyk", "--ink", "-o",
                 str(png), "--width", "90", "--spacing", "1", "--size", "800"]) == 0
    a = np.asarray(Image.open(png).convert("RGB"), dtype=int)
    r, g, b = a[..., 0], a[..., 1], a[..., 2]           # lines thinner than a pixel: hues
    magenta = (r - g > 60) & (b - g > 60)
    cyan = (g - r > 60) & (b - r > 60)
    assert magenta.sum() > 50 and cyan.sum() > 50


def test_cmyk_on_a_drawing_is_an_error(capsys, config_path, tmp_path):
    svg = tmp_path / "a.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" width="10mm" height="10mm" '
                   'viewBox="0 0 10 10"><path d="M1 1 L9 9" stroke="black"/></svg>')
    code = main(["--config", str(config_path), "estimate", str(svg), "--cmyk"])
    err = capsys.readouterr()[1]
    assert code == 2 and "--cmyk is for photos" in err and "Traceback" not in err
