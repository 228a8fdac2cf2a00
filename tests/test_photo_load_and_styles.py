"""Photographs: the loader (every mode, EXIF orientation, reduction, tone options, bad files in
one line), the shared hatcher (polygons with holes, masks) and the styles hatch, spiral and
squiggle (inside the picture, ink rises with darkness, spacing is the density knob, white
draws nothing, deterministic)."""

from __future__ import annotations

import struct
import time
import zlib

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from PIL import Image

from support import REPO
from vplotter.errors import InputError
from vplotter.inputs.hatch import hatch_mask, hatch_polygons
from vplotter.inputs.image import style
from vplotter.inputs.image.load import aspect, load, srgb_decode
from vplotter.inputs.image.picture import Picture

DATA = REPO / "tests" / "data" / "images"
GREY = float(1 - srgb_decode(128 / 255))           # darkness of sRGB 128: 0.784
MINE = ("hatch", "spiral", "squiggle", "flow")


def _dark(path, w=20.0, h=10.0, **kw):
    return load(path, w, h, **kw).darkness


# ---- the loader -------------------------------------------------------------------------------

@pytest.mark.parametrize("mode, value, expect", [
    ("L", 128, GREY),
    ("RGB", (128, 128, 128), GREY),
    ("RGB", (255, 0, 0), 1 - 0.2126),
    ("RGBA", (0, 0, 0, 0), 0.0),                     # transparent: white paper
    ("RGBA", (0, 0, 0, 128), 128 / 255),             # alpha is coverage
    ("LA", (0, 64), 64 / 255),
    ("CMYK", (0, 0, 0, 255), 1.0),
    ("1", 0, 1.0),
    ("F", 0.5, float(1 - srgb_decode(0.5))),
])
def test_modes(tmp_path, mode, value, expect):
    im = Image.new(mode, (40, 20), value)
    ext = {"CMYK": "tif", "F": "tif", "LA": "png"}.get(mode, "png")
    path = tmp_path / f"x.{ext}"
    im.save(path)
    d = _dark(path)
    assert d.dtype == np.float32 and d.ndim == 2
    assert np.allclose(d, expect, atol=0.01)


def test_sixteen_bit(tmp_path):
    path = tmp_path / "g16.png"
    Image.fromarray(np.full((20, 40), 32768, np.uint16)).save(path)
    assert Image.open(path).mode.startswith("I")
    assert np.allclose(_dark(path), 1 - srgb_decode(32768 / 65535), atol=1e-3)
    ramp = _dark(DATA / "gray16.png", 64, 8, pen_mm=2)
    assert ramp[0, 0] > 0.99 and ramp[0, -1] < 0.01 and np.all(np.diff(ramp[0]) < 0)


def test_palette_with_transparency():
    d = _dark(DATA / "palette_transparent.gif", 30, 12, pen_mm=2)     # 1 px per mm... pen 2: 1 mm
    assert d.shape == (12, 30)
    assert np.allclose(d[:, :9], 0) and np.allclose(d[:, 11:19], 1) and np.allclose(d[:, 21:], 0)


@pytest.mark.parametrize("fmt", ["PNG", "JPEG", "WEBP", "BMP", "TIFF", "GIF"])
def test_formats(tmp_path, fmt):
    a = np.full((30, 60), 255, np.uint8)
    a[:, :30] = 0
    path = tmp_path / f"x.{fmt.lower()}"
    Image.fromarray(a).convert("RGB").save(path, fmt)
    d = _dark(path, 60, 30, pen_mm=2)
    assert d[:, :25].mean() > 0.95 and d[:, 35:].mean() < 0.05


def test_gif_first_frame(tmp_path):
    path = tmp_path / "anim.gif"
    frames = [Image.new("L", (20, 10), 0), Image.new("L", (20, 10), 255)]
    frames[0].save(path, save_all=True, append_images=frames[1:])
    assert _dark(path).mean() > 0.95


@pytest.mark.parametrize("orientation", [6, 8])
def test_exif_orientation(tmp_path, orientation):
    """A phone photo stored on its side comes out upright: stored 40 x 20 with its left half
    black; 6 (turn clockwise) puts that half on top, 8 (anticlockwise) at the bottom."""
    a = np.full((20, 40), 255, np.uint8)
    a[:, :20] = 0
    ex = Image.Exif()
    ex[0x0112] = orientation
    path = tmp_path / "phone.jpg"
    Image.fromarray(a).convert("RGB").save(path, quality=95, exif=ex.tobytes())
    assert aspect(path) == pytest.approx(0.5)
    d = _dark(path, 10, 20, pen_mm=1)
    assert d.shape == (40, 20)
    top, bottom = d[:15].mean(), d[25:].mean()
    assert (top > 0.9 and bottom < 0.1) if orientation == 6 else (top < 0.1 and bottom > 0.9)
    d = _dark(DATA / "exif6.jpg", 10, 20, pen_mm=1)                   # the committed one
    assert d[:15].mean() > 0.9 and d[25:].mean() < 0.1


def test_reduced_to_what_the_pen_shows(tmp_path):
    path = tmp_path / "big.png"
    Image.new("L", (2000, 1000), 128).save(path)
    pic = load(path, 100, 50, pen_mm=0.5)            # 0.25 mm a pixel
    assert pic.darkness.shape == (200, 400)
    assert np.allclose(pic.darkness, GREY, atol=0.01)
    jpg = tmp_path / "big.jpg"
    Image.new("RGB", (3000, 2000), (128, 128, 128)).save(jpg)
    assert load(jpg, 150, 100).darkness.shape == (400, 600)
    small = load(path, 1000, 500).darkness                            # never enlarged
    assert small.shape == (1000, 2000)


def test_tone_options(tmp_path):
    path = tmp_path / "g.png"
    a = np.zeros((10, 20), np.uint8)
    a[:, 10:] = 255
    Image.fromarray(a).save(path)
    d = _dark(path, pen_mm=2)
    assert d[0, 0] == pytest.approx(1) and d[0, -1] == pytest.approx(0)
    inv = _dark(path, pen_mm=2, invert=True)
    assert inv[0, 0] == pytest.approx(0) and inv[0, -1] == pytest.approx(1)
    flat = _dark(path, pen_mm=2, contrast=0.0)                         # all mid grey
    assert np.allclose(flat, float(1 - srgb_decode(0.5)), atol=1e-4)
    light = _dark(path, pen_mm=2, brightness=1.0)
    assert np.allclose(light, 0)
    soft = _dark(path, pen_mm=2, contrast=0.5, brightness=0.1)
    assert 0 < soft[0, -1] < soft[0, 0] < 1


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _bomb(path):
    """A tiny PNG whose header claims 30,000 x 30,000 pixels."""
    ihdr = struct.pack(">IIBBBBB", 30000, 30000, 8, 0, 0, 0, 0)
    idat = zlib.compress(b"\0" * 30001)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr)
                     + _png_chunk(b"IDAT", idat) + _png_chunk(b"IEND", b""))


def _truncated(path, fmt):
    a = np.random.default_rng(1).integers(0, 255, (60, 80, 3), dtype=np.uint8)
    Image.fromarray(a).save(path, fmt)
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])


@pytest.mark.parametrize("case", ["missing", "empty", "text", "directory", "png_cut",
                                  "jpeg_cut", "bomb", "garbage_after_header"])
def test_bad_files_one_line(tmp_path, case):
    path = tmp_path / "bad.png"
    if case == "empty":
        path.write_bytes(b"")
    elif case == "text":
        path.write_text("this is not a picture\n")
    elif case == "directory":
        path.mkdir()
    elif case == "png_cut":
        _truncated(path, "PNG")
    elif case == "jpeg_cut":
        path = tmp_path / "bad.jpg"
        _truncated(path, "JPEG")
    elif case == "bomb":
        _bomb(path)
    elif case == "garbage_after_header":
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4)
    t = time.perf_counter()
    with pytest.raises(InputError) as err:
        load(path, 100, 100)
    assert time.perf_counter() - t < 1.0
    msg = str(err.value)
    assert msg.startswith(f"{path}: error: ") and "\n" not in msg
    if case != "jpeg_cut" and case != "png_cut":
        with pytest.raises(InputError):
            aspect(path)


# ---- the hatcher ------------------------------------------------------------------------------

def _inside_region(rings, pts):
    """Even-odd point in polygon, vectorised over points."""
    inside = np.zeros(len(pts), bool)
    for r in rings:
        a, b = r, np.roll(r, -1, axis=0)
        x, y = pts[:, 0:1], pts[:, 1:2]
        cond = (a[:, 1] > y) != (b[:, 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = a[:, 0] + (y - a[:, 1]) / (b[:, 1] - a[:, 1]) * (b[:, 0] - a[:, 0])
        inside ^= (np.sum(cond & (x < xc), axis=1) % 2).astype(bool)
    return inside


def _dist_to_rings(rings, pts):
    best = np.full(len(pts), np.inf)
    for r in rings:
        a, b = r, np.roll(r, -1, axis=0)
        ab = b - a
        t = np.clip(((pts[:, None] - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18), 0, 1)
        q = a + t[..., None] * ab
        best = np.minimum(best, np.hypot(*(pts[:, None] - q).transpose(2, 0, 1)).min(1))
    return best


def _densify(strokes, step=0.1):
    out = []
    for s in strokes:
        for a, b in zip(s[:-1], s[1:]):
            n = max(2, int(np.hypot(*(b - a)) / step) + 2)
            out.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
    return np.concatenate(out) if out else np.zeros((0, 2))


@st.composite
def _star_with_hole(draw):
    n = draw(st.integers(5, 14))
    radii = np.array(draw(st.lists(st.floats(5, 12), min_size=n, max_size=n)))
    t = np.linspace(0, 2 * np.pi, n, endpoint=False) + draw(st.floats(0, 1))
    outer = np.column_stack([radii * np.cos(t), radii * np.sin(t)])
    h = draw(st.floats(0.5, 3.5))
    hole = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    return [outer, hole], draw(st.floats(0.4, 1.5)), draw(st.floats(-180, 180))


@settings(max_examples=30)
@given(_star_with_hole())
def test_hatch_polygons_inside_and_covering(case):
    rings, spacing, angle = case
    strokes = hatch_polygons(rings, spacing, angle)
    pts = _densify(strokes)
    near = _dist_to_rings(rings, pts) < 1e-6
    assert np.all(_inside_region(rings, pts) | near)             # lines and their joins inside
    # every point of the region more than a spacing from its edges is within half a spacing
    # (measured across the lines) of a hatch line
    rng = np.random.default_rng(0)
    probe = rng.uniform(-12, 12, (400, 2))
    probe = probe[_inside_region(rings, probe) & (_dist_to_rings(rings, probe) > spacing)]
    segs = np.concatenate([np.stack([s[:-1], s[1:]], 1) for s in strokes])
    a, b = segs[:, 0], segs[:, 1]
    ab = b - a
    t = np.clip(((probe[:, None] - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18), 0, 1)
    dist = np.hypot(*(probe[:, None] - (a + t[..., None] * ab)).transpose(2, 0, 1)).min(1)
    assert np.all(dist <= spacing / 2 + 1e-9)
    # as much line as the area holds (the joins add at most a spacing's worth per line)
    area = 0.0
    for r in rings:
        x, y = r[:, 0], r[:, 1]
        area += abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2 * (1 if r is rings[0] else -1)
    drawn = sum(np.hypot(*np.diff(s, axis=0).T)[0::2].sum() for s in strokes)   # lines, not joins
    assert drawn == pytest.approx(area / spacing, rel=0.12, abs=3 * spacing)


def test_hatch_polygons_rules_and_joining():
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[3, 3], [7, 3], [7, 7], [3, 7]], float)
    one = lambda st: sum(np.hypot(*np.diff(s, axis=0).T)[0::2].sum() for s in st)  # noqa: E731
    assert one(hatch_polygons([sq, hole], 1, 0)) == pytest.approx(84)
    assert one(hatch_polygons([sq, hole], 1, 0, rule="nonzero")) == pytest.approx(100)
    assert one(hatch_polygons([sq, hole[::-1]], 1, 0, rule="nonzero")) == pytest.approx(84)
    assert len(hatch_polygons([sq, hole], 1, 0)) == 4        # below, left, right, above the hole
    assert len(hatch_polygons([sq], 1, 37)) == 1             # a convex region: one stroke
    u = np.array([[0, 0], [10, 0], [10, 10], [7, 10], [7, 3], [3, 3], [3, 10], [0, 10]], float)
    assert len(hatch_polygons([u], 1, 0)) == 3               # never joined across the notch
    with pytest.raises(ValueError):
        hatch_polygons([sq], 1, 0, rule="winding")


def test_hatch_mask_inside_and_covering():
    yy, xx = np.mgrid[0:200, 0:300]
    mask = ((xx - 150) ** 2 + (yy - 100) ** 2 < 80 ** 2) & ~((xx - 150) ** 2 + (yy - 100) ** 2 < 25 ** 2)
    strokes = hatch_mask(mask, 75, 50, 1.0, 30)
    pts = _densify(strokes, 0.05)
    col = np.clip((pts[:, 0] / 0.25).astype(int), 0, 299)
    row = np.clip(((50 - pts[:, 1]) / 0.25).astype(int), 0, 199)
    grown = mask.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            grown |= np.roll(np.roll(mask, dy, 0), dx, 1)
    assert grown[row, col].all()                              # within a pixel of the mask
    area = mask.sum() * 0.25 ** 2
    lines = sum(np.hypot(*np.diff(s, axis=0).T)[0::2].sum() for s in strokes)
    assert lines == pytest.approx(area / 1.0, rel=0.05)
    assert len(strokes) < 30                                  # joined, not one per run
    assert hatch_mask(np.zeros((10, 10), bool), 10, 10, 1, 0) == []


# ---- the styles -------------------------------------------------------------------------------

STEPS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)


def _ramp(w_mm=120.0, h_mm=60.0, px=0.25):
    cols = round(w_mm / px)
    d = np.repeat(np.array(STEPS, np.float32), -(-cols // len(STEPS)))[:cols]
    return Picture(np.tile(d, (round(h_mm / px), 1)), w_mm, h_mm, "ramp")


def _ink_per_band(strokes, pic, pen):
    pts = [_densify([s.pts], 0.05) for s in strokes if len(s.pts) > 1]
    pts = np.concatenate(pts) if pts else np.zeros((0, 2))
    # each densified point stands for 0.05 mm of line (a slight overcount at the vertices)
    band = np.minimum((pts[:, 0] / pic.width_mm * len(STEPS)).astype(int), len(STEPS) - 1)
    length = np.bincount(band, minlength=len(STEPS)) * 0.05
    return length * pen / (pic.width_mm / len(STEPS) * pic.height_mm)


# a generous spacing (tone curve d^1) per style: the hatch crosses its layers only this fine
GENEROUS = {"hatch": 0.75, "flow": 0.75}


@pytest.mark.parametrize("name", MINE)
def test_style_inside_and_tone(name):
    pic = _ramp()
    sp = GENEROUS.get(name, 1.5)
    strokes = style(name)(pic, sp, 0.5)
    pts = np.concatenate([s.pts for s in strokes])
    assert np.all(pts >= 0) and np.all(pts[:, 0] <= pic.width_mm) and np.all(pts[:, 1] <= pic.height_mm)
    ink = _ink_per_band(strokes, pic, 0.5)
    assert ink[0] < 0.02                                       # white: (almost) nothing
    assert np.all(np.diff(ink) > -0.01) and ink[-1] - ink[1] > 0.5, ink   # more where darker
    if name != "hatch":                                        # hatch has five tones, these
        assert np.all(np.diff(ink) > 0.03), ink                # follow every step
    chords = np.concatenate([np.hypot(*np.diff(s.pts, axis=0).T) for s in strokes])
    assert chords.min() >= 0.1
    again = style(name)(pic, sp, 0.5)                          # deterministic
    assert len(again) == len(strokes) and all(np.array_equal(a.pts, b.pts)
                                              for a, b in zip(again, strokes))


@pytest.mark.parametrize("name", MINE)
def test_spacing_is_the_density_knob(name):
    pic = Picture(np.full((240, 320), 0.5, np.float32), 80, 60)
    # a generous spacing (tone curve d^1): halving it about doubles the line (the hatch's
    # layers overlap less at a coarser pitch, so it needs more of them for the same grey)
    sp = GENEROUS.get(name, 1.5)
    n = sum(s.length_mm() for s in style(name)(pic, sp, 0.5))
    m = sum(s.length_mm() for s in style(name)(pic, sp / 2, 0.5))
    # (flow: its lines never come closer than the pen's width, 0.5 mm: 1.5 x at most here)
    assert (1.25 if name in ("hatch", "flow") else 1.6) < m / n < 2.5
    # coarser (a steeper curve, fewer layers): less line still, never more
    lengths = [sum(s.length_mm() for s in style(name)(pic, sp, 0.5)) for sp in (1.5, 2.5, 4, 6)]
    assert all(b <= a for a, b in zip(lengths, lengths[1:])) and lengths[-1] < lengths[1], lengths


RAMP5 = (0.2, 0.4, 0.6, 0.8, 1.0)


def _ink_bands(strokes, width_mm, height_mm, pen, bands=len(RAMP5)):
    """Ink per area in vertical bands: lines as length x pen, dots as discs."""
    out = np.zeros(bands)
    for s in strokes:
        if len(s.pts) == 1:
            b = min(int(s.pts[0, 0] / width_mm * bands), bands - 1)
            out[b] += np.pi * pen * pen / 4
            continue
        pts = _densify([s.pts], 0.05)
        b = np.minimum((pts[:, 0] / width_mm * bands).astype(int), bands - 1)
        out += np.bincount(b, minlength=bands) * 0.05 * pen
    return out / (width_mm / bands * height_mm)


@pytest.mark.parametrize("name", MINE + ("stipple",))
@pytest.mark.parametrize("scarce", [False, True])
def test_ramp_ink_rises_in_every_band(name, scarce):
    """Five grey bands, 0.2 to 1.0: every one gets ink and each darker one strictly more, at a
    generous spacing (tone curve d^1) and at a scarce one (d^6 or more, one hatch layer, sparse
    dashed lines in the light)."""
    from vplotter.inputs.image import flow, hatch, squiggle, tone

    spacing = (6.0 if name in ("spiral", "squiggle") else 3.0) if scarce else GENEROUS.get(name, 1.5)
    own = {"spiral": squiggle.tone_gamma, "squiggle": squiggle.tone_gamma,
           "hatch": hatch.tone_gamma, "flow": flow.tone_gamma}.get(name, tone.gamma)
    w_mm, h_mm, px = 500.0, 50.0, 0.5
    cols = round(w_mm / px)
    d = np.repeat(np.array(RAMP5, np.float32), cols // len(RAMP5))
    pic = Picture(np.tile(d, (round(h_mm / px), 1)), w_mm, h_mm, "ramp")
    ink = _ink_bands(style(name)(pic, spacing, 0.5), w_mm, h_mm, 0.5)
    assert ink[0] > 0 and np.all(np.diff(ink) > 0), ink
    if not scarce:
        assert own(spacing, 0.5) == 1.0
        if name in ("spiral", "squiggle"):                     # ink about linear in darkness
            assert np.all(np.abs(ink / ink[-1] - np.array(RAMP5)) < 0.12), ink / ink[-1]
    else:
        assert own(spacing, 0.5) > 4
        assert ink[0] < 0.05 * ink[-1]                        # the line goes to the darks


def test_tone_curve_and_nesting():
    from vplotter.inputs.image import tone

    d = np.linspace(0, 1, 101)
    for sp in (1.0, 2.0, 3.0, 5.0, 20.0):
        f = tone.curve(d, tone.gamma(sp, 0.5))
        assert f[0] == 0 and f[-1] == pytest.approx(1) and np.all(np.diff(f) > 0)
    assert tone.gamma(1.5, 0.5) == 1 and tone.gamma(4.0, 0.5) == tone.GAMMA_MAX
    gs = [tone.gamma(sp, 0.5) for sp in np.linspace(1.5, 4.0, 9)]
    assert all(b > a for a, b in zip(gs, gs[1:]))
    # every 16th line, then the ones half-way between, ... the odd ones last
    assert tone.level(np.arange(17)).tolist() == [0, 4, 3, 4, 2, 4, 3, 4, 1, 4, 3, 4, 2, 4, 3, 4, 0]
    # the lines drawn (each level's share of the lines x its duty) cover the share asked for
    lines = np.arange(1600)
    along = np.linspace(0, 1600, 4001)
    for share in (0.0, 0.004, 0.03, 0.0625, 0.1, 0.3, 0.7, 1.0):
        on = tone.dashed(share, tone.level(lines)[:, None], along[None, :], lines[:, None], 16.0)
        assert on.mean() == pytest.approx(share, abs=0.01)


@pytest.mark.parametrize("name", MINE)
def test_white_draws_nothing(name):
    pic = Picture(np.zeros((100, 100), np.float32), 50, 50)
    assert sum(s.length_mm() for s in style(name)(pic, 1.5, 0.5)) == 0


def test_hatch_few_lifts_and_layers():
    from vplotter.inputs.image.hatch import coverage, full_layers, layer_units
    assert full_layers(0.75, 0.5) == 3 and full_layers(1.25, 0.5) == 1
    c = 2 / 3
    x = np.linspace(0, 3, 31)
    assert np.allclose(layer_units(coverage(x, c), c, 3), x, atol=1e-5)
    # a generous spacing: d^1 onto 0..C(3), the lines' ink about linear in darkness
    tones = np.array([0, 0.25, 0.5, 0.75, 1.0], np.float32)
    pic = Picture(np.tile(np.repeat(tones, 100), (120, 1)), 125, 30)
    strokes = style("hatch")(pic, 0.75, 0.5)
    pts = _densify([s.pts for s in strokes], 0.05)
    band = np.minimum((pts[:, 0] / 25).astype(int), 4)
    ink = np.bincount(band, minlength=5) * 0.05 * 0.5 / (25 * 30)
    # line length x pen counts crossings twice: the coverage of n layers is n c here
    want = layer_units(tones * coverage(3, c), c, 3) * c
    assert np.allclose(ink, want, rtol=0.1, atol=0.02), (ink, want)
    pic = Picture(np.full((200, 200), 0.99, np.float32), 50, 50)
    strokes = style("hatch")(pic, 0.75, 0.5)
    assert {s.layer for s in strokes} == {"hatch 1", "hatch 2", "hatch 3"}
    # the full layers: a back-and-forth or two each (the third, 95 % of its lines, is dashed)
    assert sum(s.layer != "hatch 3" for s in strokes) <= 6
    # a scarce spacing: one layer in black, the pitch drawn is the spacing
    strokes = style("hatch")(pic, 4.0, 0.5)
    assert {s.layer for s in strokes} == {"hatch 1"}
    v = np.concatenate([s.pts @ np.array([-1, 1]) / np.sqrt(2) for s in strokes])
    k = (v / 4.0 - 0.5)
    assert np.allclose(k[np.abs(k - np.round(k)) < 0.4], np.round(k[np.abs(k - np.round(k)) < 0.4]), atol=0.02)


def test_spiral_one_track_few_lifts():
    pic = Picture(np.full((160, 160), 0.6, np.float32), 40, 40)
    strokes = style("spiral")(pic, 1.5, 0.5)
    # inside the inscribed circle one stroke; outside it about four lifts a turn
    turns_outside = (np.hypot(20, 20) - 20) / 1.5 + 1
    assert len(strokes) <= 4 * turns_outside + 2
    r = np.hypot(*(strokes[0].pts - 20).T)
    assert r[0] < 1.5 and r.max() > 19                        # from the centre outwards


def test_load_then_style(tmp_path):
    path = tmp_path / "disc.png"
    yy, xx = np.mgrid[0:120, 0:160]
    Image.fromarray(np.where((xx - 80) ** 2 + (yy - 60) ** 2 < 40 ** 2, 0, 255).astype(np.uint8)).save(path)
    w = 80.0
    pic = load(path, w, w / aspect(path))
    for name in MINE:
        strokes = style(name)(pic, 1.5, 0.5)
        pts = np.concatenate([s.pts for s in strokes])
        assert np.hypot(pts[:, 0] - 40, pts[:, 1] - 30).max() < 22   # only on the disc


def test_squiggle_rows_joined_at_inked_edges():
    grey = Picture(np.full((240, 480), 0.7, np.float32), 120, 60)
    strokes = style("squiggle")(grey, 1.5, 0.5)
    assert len(strokes) == 1                                   # boustrophedon: one stroke
    ramp = style("squiggle")(_ramp(), 1.5, 0.5)                # white left edge: row pairs,
    assert len(ramp) <= 40                                     # dashes in the lightest grey


@settings(max_examples=25)
@given(st.integers(1, 40), st.integers(1, 40), st.floats(1, 60), st.floats(1, 60),
       st.floats(0.3, 6), st.integers(0, 2**31 - 1))
def test_styles_any_picture(h, w, wmm, hmm, spacing, seed):
    """Any small picture, size and spacing: every point inside, no chord under 0.1 mm."""
    d = np.random.default_rng(seed).random((h, w)).astype(np.float32)
    pic = Picture(d, wmm, hmm)
    for name in MINE:
        for s in style(name)(pic, spacing, 0.5):
            p = s.pts
            assert np.all(p >= 0) and np.all(p[:, 0] <= wmm) and np.all(p[:, 1] <= hmm)
            assert len(p) < 2 or np.hypot(*np.diff(p, axis=0).T).min() >= 0.1 - 1e-9


# ---- the converter's own tone score (choosing the curve per picture) ---------------------------

def test_score_ink_counts_line_length_times_pen_width():
    from vplotter.inputs.image import score
    from vplotter.inputs.strokes import Stroke

    pic = Picture(np.zeros((40, 60), np.float32), 60.0, 40.0)
    line = Stroke(np.array([[5.0, 20.0], [45.0, 20.0]]))
    ink = score.ink([line], pic, 0.5)
    assert ink.shape == (40, 60)
    assert ink.sum() == pytest.approx(40 * 0.5, rel=0.02)       # mm² of ink on 1 mm² cells
    dot = score.ink([Stroke(np.array([[30.0, 20.0]]))], pic, 0.5)
    assert dot.sum() == pytest.approx(np.pi * 0.25 / 4, rel=0.02)


def test_score_prefers_ink_where_the_picture_is_dark():
    from vplotter.inputs.image import score
    from vplotter.inputs.strokes import Stroke

    d = np.zeros((40, 60), np.float32)
    d[:, :30] = 0.9                                                # dark left half
    pic = Picture(d, 60.0, 40.0)
    rows = [Stroke(np.array([[x0, y], [x0 + 28.0, y]])) for y in np.arange(1.0, 40.0, 1.5)
            for x0 in (1.0,)]
    wrong = [Stroke(p.pts + [30.0, 0.0]) for p in rows]
    assert score.correlation(rows, pic, 0.5) > 0.8
    assert score.correlation(wrong, pic, 0.5) < -0.8
    assert score.correlation([], pic, 0.5) == 0.0                  # no ink: nothing to say
