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
from vplotter.inputs import colour as colours
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


def thirds(tmp_path, middle):
    """A 90 x 60 px picture in three bands, left to right: red, `middle`, dark grey."""
    rgb = np.ones((60, 90, 3))
    rgb[:, :30] = [1, 0, 0]
    rgb[:, 30:60] = middle
    rgb[:, 60:] = [0.2, 0.2, 0.2]
    return save(tmp_path, rgb)


def layered(path, style="hatch", spacing=1.5, width=80.0):
    """{pen: drawn mm} and the strokes of --cmyk at a fixed spacing."""
    drawn, _ = photo.strokes(str(path), photo.PhotoOptions(style=style, spacing_mm=spacing,
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
    path = thirds(tmp_path, [0, 1, 0])                 # red, green, grey
    out = tmp_path / "c.ngc"
    code = main(["--config", str(config_path), "convert", str(path), "-o", str(out), "--cmyk",
                 "--width", "90", "--max-time", "10m"])
    _, err = capsys.readouterr()
    assert code == 0, err
    assert "cmyk: 4 pens" in err and "within 10:00" in err
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


# ------------------------------------------------------------------ --colours: the pens owned
PENS3 = [("black", "#000000"), ("red", "#ff0000"), ("blue", "#0000ff")]


def test_inks_for_come_light_to_dark_each_at_its_own_angle():
    inks = cmyk.inks_for(PENS3)
    assert [i[0] for i in inks] == ["red", "blue", "black"]      # L* 53, 32, 0
    assert inks[-1][2] == 45.0 and len({i[2] for i in inks}) == 3


def test_pen_colours_and_grey_separate_into_their_own_pens():
    inks = cmyk.inks_for(PENS3)
    px = np.array([[1, 0, 0], [0, 0, 1], [0.5, 0.5, 0.5], [1, 1, 1]], dtype=np.float32)
    red, blue, black = cmyk.separate_pens(px.T[:, :, None], inks)[:, :, 0]
    assert red[0] > 0.95 and blue[0] < 0.02 and black[0] < 0.02        # red: the red pen
    assert blue[1] > 0.95 and red[1] < 0.02 and black[1] < 0.02
    assert black[2] == pytest.approx(0.5, abs=0.03) and max(red[2], blue[2]) < 0.02
    assert red[3] == blue[3] == black[3] == 0                           # white: nothing


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 255), st.integers(0, 255), st.integers(0, 255)),
                min_size=2, max_size=5, unique=True),
       st.lists(st.floats(0, 1), min_size=5, max_size=5))
def test_a_mix_the_pens_can_make_comes_back(pen_rgb, share):
    """Coverages that give a colour the pens can make (absorptions add) give it back: the
    absorption of the coverages found is within a few per cent of the one asked for, and every
    coverage is within 0..1."""
    pens = [(f"p{i}", "#%02x%02x%02x" % c) for i, c in enumerate(pen_rgb)]
    inks = cmyk.inks_for(pens)
    u = np.array([[1 - c for c in colours.linear_rgb(colour)] for _, colour, _ in inks])
    a = np.array(share[:len(inks)]) / len(inks)
    want = np.clip(a @ u, 0, 1)
    got = cmyk.separate_pens((1 - want).astype(np.float32)[:, None, None], inks)[:, 0, 0]
    assert np.all((got >= 0) & (got <= 1))
    assert np.abs(got @ u - want).max() < 0.05


def test_convert_in_the_pens_owned_asks_for_each_light_to_dark(tmp_path, capsys, config_path):
    path = thirds(tmp_path, [0, 0, 1])                 # red, blue, grey
    out = tmp_path / "c.ngc"
    code = main(["--config", str(config_path), "convert", str(path), "-o", str(out),
                 "--colours", "black,red,blue", "--width", "90", "--max-time", "10m"])
    err = capsys.readouterr()[1]
    assert code == 0, err
    assert "colours: 3 pens" in err and "within 10:00" in err
    text = out.read_text()
    asks = re.findall(r"M0 \(pen: (\w+)\)", text)
    assert asks == ["red", "blue", "black"]
    # each pen draws its own third of the picture (x in mm about the page's centre)
    where = {}
    pen = None
    for line in text.splitlines():
        m = re.match(r"M0 \(pen: (\w+)\)", line)
        if m:
            pen = m.group(1)
        m = re.match(r"G1 X(-?[\d.]+)", line)
        if m and pen:
            where.setdefault(pen, []).append(float(m.group(1)))
    assert np.median(where["red"]) < -10 and abs(np.median(where["blue"])) < 10
    assert np.median(where["black"]) > 10


def test_colours_name_pens_in_the_config(tmp_path, capsys, config_path):
    cfg = tmp_path / "pens.toml"
    cfg.write_text(config_path.read_text() + '\n[pens.sepia]\ncolour = "#704214"\n'
                   '[pens.ink]\ncolour = "#101010"\n')
    rgb = np.ones((40, 40, 3)) * 0.3
    path = save(tmp_path, rgb)
    out = tmp_path / "c.ngc"
    assert main(["--config", str(cfg), "convert", str(path), "-o", str(out), "--colours",
                 "sepia,ink", "--width", "40", "--spacing", "2"]) == 0
    assert set(re.findall(r"M0 \(pen: (\w+)\)", out.read_text())) <= {"sepia", "ink"}
    capsys.readouterr()
    code = main(["--config", str(cfg), "estimate", str(path), "--colours", "sepia,inkk"])
    err = capsys.readouterr()[1]
    assert code == 2 and len([x for x in err.splitlines() if "error" in x]) == 1
    assert "'inkk' is neither a pen in [pens] nor a colour ([pens]: sepia, ink)" in err


@pytest.mark.parametrize("given, said", [
    ("black,white", "white: it draws nothing"),
    ("black,red,#000", "#000 is given twice"),
    ("black,reddish", "'reddish' is neither a pen in [pens] nor a colour"),
    (" , ", "give the pens"),
])
def test_colours_that_cannot_be_drawn_are_one_line(tmp_path, capsys, config_path, given, said):
    path = save(tmp_path, np.ones((20, 20, 3)) * 0.5)
    code = main(["--config", str(config_path), "estimate", str(path), "--colours", given])
    err = capsys.readouterr()[1]
    assert code == 2 and said in err and "Traceback" not in err
    assert len([x for x in err.splitlines() if "error" in x]) == 1


def test_cmyk_and_colours_together_is_an_error(tmp_path, capsys, config_path):
    path = save(tmp_path, np.ones((20, 20, 3)) * 0.5)
    code = main(["--config", str(config_path), "estimate", str(path), "--cmyk", "--colours",
                 "black"])
    assert code == 2 and "--cmyk or --colours, not both" in capsys.readouterr()[1]
