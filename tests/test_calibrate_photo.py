"""`calibrate photo` on the simulated wall: phone photos of the drawn pattern and one tape
distance instead of thirty ruler measurements.

The pattern is drawn on the fake machine and decoded through the TRUE geometry
(tests/support/wall.py); tests/support/phone_photo.py renders what a phone sees of those
ink strokes (straight on; 25 degrees off-axis with lens distortion and a strong light
gradient; upright, stored on its side with an EXIF orientation). With one tape distance
(0.3 mm off) the fit must bring a 300 mm test drawing within 0.5 mm of its true shape on that
wall. Bad photos (blurred, cut off, no pattern, a different pattern) are one line, exit 2,
config.toml byte-identical.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from PIL import Image

from support import phone_photo as pp
from support import tracecheck as tc
from support.cli import run
from support.wall import draw_and_check, draw_pattern, new_wall
from vplotter.calibration import pattern
from vplotter.calibration import photo_camera as camera

VIEWS = {
    "straight": pp.View(),
    "oblique": pp.View(yaw_deg=25, pitch_deg=6, roll_deg=-4, k1=-0.08, k2=0.012, light=0.65,
                       noise=0.015, blur_px=0.9, quality=80),
    "portrait": pp.View(size=(1500, 2000), roll_deg=2, k1=0.03, distance_mm=700,
                        exif_orientation=6),
}
TAPE_ERROR_MM = 0.3


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pattern")
    d = draw_pattern(tmp)
    d["strokes"] = tc.drawn_polylines(d["dec"])
    d["photos"] = {}
    for name, view in VIEWS.items():
        d["photos"][name] = tmp / f"{name}.jpg"
        pp.render(d["strokes"], d["photos"][name], view, seed=len(name))
    return d


@pytest.fixture
def wall(tmp_path, drawn):
    return new_wall(tmp_path, drawn)


def _tape(w, a: int = 1, b: int = 16) -> list:
    d = float(np.hypot(*(w["dots"][a] - w["dots"][b]))) + TAPE_ERROR_MM
    return ["--distance", a, b, f"{d:.1f}"]


def _photo(capsys, w, *photos, extra=()):
    return run(capsys, ["--config", w["cfg"], "calibrate", "photo", *photos, "--pattern",
                        w["csv"], *_tape(w), *extra])


@pytest.mark.parametrize("kind", list(VIEWS))
def test_one_photo_and_one_tape_distance(wall, drawn, capsys, kind):
    before = draw_and_check(wall, "before") if kind == "straight" else 6.59  # the same wall
    found = wall["tmp"] / "found.png"
    code, out, _ = _photo(capsys, wall, drawn["photos"][kind], extra=["-o", found])
    assert code == 0
    after = draw_and_check(wall, "after")
    print(f"{kind}: {before:.2f} mm before, {after:.3f} mm after")
    assert before > 2.0 and after < 0.5
    for word in ("anchor_distance_mm", "stretch", "±", "residual on the wall", "16:",
                 "distance 1-16", "300 mm", "config.toml: written"):
        assert word in out
    with Image.open(found) as im:
        assert im.size[0] >= 800
    if kind == "oblique":
        assert "seen 2" in out                   # 25 degrees off-axis, more or less
    cfg = tc.load_config(wall["cfg"])
    assert cfg["cords"]["stretch"] > 0


def test_a_coarse_blurred_photo_off_axis(wall, drawn, capsys, tmp_path):
    """2 MP, 25 degrees off-axis, blurred 1.2 px: on the far side mark 1's ring does not close
    (no hole stands out as mark 1) and the faint circles do not close at the ink's threshold.
    Mark 1 is still told by its second circle, the faint circles are measured as `ink` finds
    them (without the number beside them): calibrated, as the sharper photos are."""
    photo = tmp_path / "coarse.jpg"
    pp.render(drawn["strokes"], photo, pp.View(
        size=(1633, 1225), yaw_deg=25, pitch_deg=6, roll_deg=-4, k1=-0.08, k2=0.012,
        light=0.65, noise=0.015, blur_px=1.2, quality=80), seed=1)
    code, out, err = _photo(capsys, wall, photo)
    assert code == 0, err
    assert "16 marks, seen 2" in out
    assert draw_and_check(wall, "after") < 0.5


def test_two_photos_together(wall, drawn, capsys):
    code, out, _ = _photo(capsys, wall, drawn["photos"]["oblique"], drawn["photos"]["portrait"])
    assert code == 0 and out.count("marks, seen") == 2
    assert draw_and_check(wall, "after") < 0.5


def test_dry_run_writes_nothing(wall, drawn, capsys):
    from vplotter.machine import state

    before, stored = wall["cfg"].read_bytes(), state.state_path().read_bytes()
    code, out, _ = _photo(capsys, wall, drawn["photos"]["straight"], extra=["--dry-run"])
    assert code == 0 and "dry run" in out and "16:" in out
    assert wall["cfg"].read_bytes() == before and state.state_path().read_bytes() == stored


def _bad(capsys, w, photo, extra=()) -> str:
    before = w["cfg"].read_bytes()
    code, _, err = _photo(capsys, w, photo, extra=extra)
    assert code == 2 and w["cfg"].read_bytes() == before
    print(err.strip())
    return err


def test_a_cut_off_photo_says_which_marks_are_missing(wall, drawn, capsys):
    cut = wall["tmp"] / "cut.jpg"
    with Image.open(drawn["photos"]["straight"]) as im:
        im.crop((0, 0, im.size[0], int(im.size[1] * 0.75))).save(cut, quality=90)
    found = wall["tmp"] / "found.png"
    err = _bad(capsys, wall, cut, extra=["-o", found])
    assert "found 12 of 16 marks: 13, 14, 15 and 16 not found (outside the photo?)" in err
    with Image.open(found) as im:                 # what was found, circled in green
        rgb = np.asarray(im.convert("RGB"), dtype=int)
    assert ((rgb[..., 1] > 150) & (rgb[..., 0] < 40)).any()


def test_a_blurred_photo_is_refused(wall, drawn, capsys, tmp_path):
    blurred = tmp_path / "blurred.jpg"
    pp.render(drawn["strokes"], blurred, pp.View(blur_px=5.0))
    assert "no calibration pattern found" in _bad(capsys, wall, blurred)


def test_no_pattern_in_the_photo(wall, capsys, tmp_path):
    rng = np.random.default_rng(3)
    texture = rng.uniform(0, 255, (150, 200)).astype(np.uint8)
    noise = tmp_path / "texture.png"
    Image.fromarray(texture).resize((2000, 1500), Image.Resampling.BICUBIC).save(noise)
    assert "no calibration pattern found" in _bad(capsys, wall, noise)


def test_another_pattern(wall, capsys, tmp_path):
    """A 3 x 5 pattern drawn on some other page: not the 16 marks of pattern.csv."""
    class Page:
        x_min_mm, x_max_mm, y_min_mm, y_max_mm = -200.0, 200.0, -180.0, 180.0

    strokes = [s.pts for m in pattern.grid(Page, 3, 5, 25.0) for s in pattern.mark_strokes(m)]
    other = tmp_path / "other.jpg"
    pp.render(strokes, other, pp.View())
    err = _bad(capsys, wall, other)
    assert "of 16 marks" in err and "3 marks that are not in the pattern" in err


def test_marks_that_do_not_fit_the_machine_are_refused(wall, drawn, capsys, tmp_path):
    """Every mark moved by about a millimetre (the pen knocked between the marks, or a photo
    of another drawing): no machine puts the dots there, the fit is not trusted. (Seeds 1 to
    5 and 7 are all refused so, 0.6 to 1.2 mm off; 5's fits give up soonest: 3 s, not 15.)"""
    dots = np.array(list(wall["dots"].values()))
    shift = np.random.default_rng(5).normal(0, 1.0, (len(dots), 2))
    moved = []
    for p in drawn["strokes"]:
        near = int(np.argmin(np.hypot(*(dots - p.mean(axis=0)).T)))
        moved.append(p + shift[near])
    photo = tmp_path / "moved.jpg"
    pp.render(moved, photo, pp.View())
    assert "do not fit the machine" in _bad(capsys, wall, photo)


def test_photo_and_distance_are_checked(wall, drawn, capsys):
    photo = drawn["photos"]["straight"]
    argv = ["--config", wall["cfg"], "calibrate", "photo", photo, "--pattern", wall["csv"]]
    assert run(capsys, argv)[2].count("--distance 1 16 MM") == 1
    assert "no mark 17" in run(capsys, argv + ["--distance", 1, 17, 500])[2]
    code, _, err = run(capsys, ["--config", wall["cfg"], "calibrate", "photo", "--pattern",
                                wall["csv"], "--distance", 1, 16, 500])
    assert code == 2 and "PHOTO.jpg" in err


def test_a_heic_photo_without_pillow_heif_says_how_to_get_it(wall, capsys, tmp_path,
                                                           monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pillow_heif", None)
    heic = tmp_path / "IMG_0001.HEIC"
    heic.write_bytes(b"\0\0\0\x18ftypheic")
    err = _bad(capsys, wall, heic)
    assert "pip install pillow-heif" in err


# ---------------------------------------------------------------- a gondola that tilts
MEASURED_GONDOLA = "cord_spacing_mm = 40.0\npen_below_mm = 12.0\n"


@pytest.fixture(scope="module")
def tilted(tmp_path_factory):
    """The pattern drawn on the wall whose gondola tilts (its centre of mass 30 mm below the
    pen, cords 40 mm apart, the pen 12 mm below them), config.toml without a [gondola]; its
    three photos."""
    tmp = tmp_path_factory.mktemp("tilted")
    d = draw_pattern(tmp, tilted=True)
    strokes = tc.drawn_polylines(d["dec"])
    d["photos"] = {}
    for name, view in VIEWS.items():
        d["photos"][name] = tmp / f"{name}.jpg"
        pp.render(strokes, d["photos"][name], view, seed=len(name))
    return d


def _level_instead(monkeypatch):
    """The photo route as if the photos could not tell the tilt: the level fit."""
    from vplotter.commands import calibrate_photo

    monkeypatch.setattr(calibrate_photo, "_told", lambda *a: False)


@pytest.mark.parametrize("kind", list(VIEWS))
def test_a_tilting_gondola_from_one_photo(tilted, tmp_path, capsys, monkeypatch, kind):
    """Exactly `calibrate photo PHOTO --pattern pattern.csv --distance 1 16 MM` on a config
    that says nothing about the gondola: the cord spacing, the pen offset and the centre of
    mass fitted with the rest, written to config.toml, and the 300 mm test drawing within
    0.5 mm of its true shape; the same photo fitted with a level gondola is refused (its marks
    do not fit) or draws worse. That last is a property of the wall (its tilt matters), not of
    the view, so it is checked on one view (oblique: its level fit gives up at once, the
    straight photo's takes 10 s of fitting to refuse)."""
    w = new_wall(tmp_path, tilted)
    code, out, _ = _photo(capsys, w, tilted["photos"][kind])
    assert code == 0 and "cannot tell" not in out
    after = draw_and_check(w, "after")
    gondola = tc.load_config(w["cfg"])["gondola"]
    assert 30.0 < gondola["cord_spacing_mm"] < 50.0 and 9.0 < gondola["pen_below_mm"] < 15.0
    assert 15.0 < gondola["mass_below_pen_mm"] < 45.0                  # truly 40, 12, 30
    assert after < 0.5
    if kind != "oblique":
        return
    (tmp_path / "level").mkdir()
    w = new_wall(tmp_path / "level", tilted)
    _level_instead(monkeypatch)
    code, out, _ = _photo(capsys, w, tilted["photos"][kind])
    level = draw_and_check(w, "after") if code == 0 else float("inf")
    assert "photos cannot tell" in out
    with capsys.disabled():
        print(f"tilted wall, {kind}: {after:.3f} mm; with a level gondola {level:.3f} mm")
    assert after < 0.5 and level > 2 * after


def test_a_measured_gondola_gets_its_centre_of_mass(tmp_path_factory, tmp_path, capsys,
                                                   monkeypatch):
    """config.toml with the gondola as a ruler gives it: the centre of mass alone is added,
    the cord spacing and pen offset kept; a level gondola is refused or draws worse. (The
    oblique view: the level fit of the straight one takes 11 s of fitting to refuse.)"""
    tmp = tmp_path_factory.mktemp("measured")
    d = draw_pattern(tmp, tilted=True, gondola=MEASURED_GONDOLA)
    photo = tmp / "oblique.jpg"
    pp.render(tc.drawn_polylines(d["dec"]), photo, VIEWS["oblique"], seed=8)
    results = {}
    for name in ("tilt", "level"):
        (tmp_path / name).mkdir()
        w = new_wall(tmp_path / name, d)
        if name == "level":
            _level_instead(monkeypatch)
        code, out, _ = _photo(capsys, w, photo)
        assert code == 0 or name == "level"       # a level gondola's marks may not fit
        results[name] = draw_and_check(w, "after") if code == 0 else float("inf")
        gondola = tc.load_config(w["cfg"])["gondola"]
        assert (gondola["cord_spacing_mm"], gondola["pen_below_mm"]) == (40.0, 12.0)
        if name == "tilt":
            assert 20.0 < gondola["mass_below_pen_mm"] < 40.0 and "cannot tell" not in out
        else:
            assert "mass_below_pen_mm" not in gondola and "photos cannot tell" in out
    with capsys.disabled():
        print(f"measured gondola: {results['tilt']:.3f} mm, level {results['level']:.3f} mm")
    assert results["tilt"] < 0.5 and results["level"] > 2 * results["tilt"]


# ---------------------------------------------------------------- the joint fit, the camera
def test_the_joint_fit_finds_a_tilting_gondola():
    """A gondola whose centre of mass hangs 35 mm below the pen, seen 25 degrees off-axis
    through a distorting lens with 0.1 px noise: fitted with the centre of mass, the machine
    puts the dots where they are; kept level, it cannot."""
    from dataclasses import replace

    from vplotter.calibration import fit, photo_fit

    true = fit.Machine(428.5, 480.0, 470.0, 25.375, 24.7, 0.003, 40.0, 12.0, 4096, 35.0)
    start = fit.Machine(422.5, 479.0, 479.0, 25.0, 25.0, 0.0, 40.0, 12.0, 4096, None)
    gx, gy = np.meshgrid(np.linspace(40, 380, 4), np.linspace(180, 680, 4))
    spots = np.column_stack((gx.ravel(), gy.ravel()))
    steps = (start.kin().inverse(spots) - [479.0, 479.0]) * start.steps_per_unit()
    wall = true.pen(steps)
    cam = np.array([0.1, 0.4, 0.02, -150, -400, 900, np.log(2000), -0.08, 0.01])
    px = camera.project(cam, (999.5, 749.5), wall)
    px += np.random.default_rng(1).normal(0, 0.1, px.shape)
    seen = [photo_fit.Seen("p", np.arange(16), px, (999.5, 749.5), 1800.0)]
    tape = np.array([[0, 15, np.hypot(*(wall[0] - wall[15])) + TAPE_ERROR_MM]])

    def shape_error(m):
        p, q = m.pen(steps), wall
        u, _, vt = np.linalg.svd((p - p.mean(0)).T @ (q - q.mean(0)))
        return np.hypot(*((p - p.mean(0)) @ (vt.T @ u.T).T + q.mean(0) - q).T).max()

    level = photo_fit.fit(start, fit.names(False), steps, seen, tape)
    tilt = photo_fit.fit(replace(start, mass_below_pen_mm=fit.MASS_START_MM),
                         fit.names(False, True), steps, seen, tape)
    assert shape_error(level.machine) > 1.0 and level.rms_mm > 0.15
    assert shape_error(tilt.machine) < 0.4 and tilt.rms_mm < 0.05
    assert tilt.machine.mass_below_pen_mm == pytest.approx(35.0, abs=4 * tilt.sigma[-1] + 1)


@given(st.floats(-0.25, 0.1), st.floats(-0.03, 0.05),
       st.lists(st.floats(-0.6, 0.6), min_size=2, max_size=2))
def test_lens_distortion_round_trip(k1, k2, u):
    p = np.array([u])
    assert np.allclose(camera.undistort(camera.distort(p, k1, k2), k1, k2), p, atol=1e-9)


@given(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-3.2, 3.2),
       st.floats(400, 2000), st.floats(-0.1, 0.05))
def test_project_and_back(yaw, pitch, roll, distance, k1):
    rot = camera.rotation([pitch, yaw, 0]) @ camera.rotation([0, 0, roll])
    centre = np.array([210.0, 400.0, 0.0])
    t = np.array([0, 0, distance]) - rot @ centre
    cam = np.concatenate((camera.rotation_vector(rot), t, [np.log(1800.0), k1, 0.0]))
    wall = centre[:2] + np.random.default_rng(0).uniform(-150, 150, (20, 2))
    px = camera.project(cam, (999.5, 749.5), wall)
    assert np.allclose(camera.backproject(cam, (999.5, 749.5), px), wall, atol=1e-6)
    # without distortion the plane maps by a homography, and the camera is found from it
    cam[7] = 0.0
    px = camera.project(cam, (999.5, 749.5), wall)
    h = camera.homography(wall, px)
    assert np.allclose(camera.apply(h, wall), px, atol=1e-6)
    again = camera.from_homography(h, (999.5, 749.5), 1800.0)
    assert np.allclose(camera.project(again, (999.5, 749.5), wall), px, atol=1e-5)


def test_fine_noise_is_no_pattern_though_some_holes_fall_on_a_grid(wall, capsys, tmp_path):
    """Pixel noise has thousands of mark-like holes, and some always lie near a grid's
    points (9 of 16 in this one): that is chance, not a pattern partly hidden."""
    noise = tmp_path / "noise.png"
    pixels = np.random.default_rng(2).uniform(0, 255, (1500, 2000)).astype(np.uint8)
    Image.fromarray(pixels).save(noise)
    err = _bad(capsys, wall, noise)
    assert "no calibration pattern found" in err and "in the pattern's grid" in err
    assert "Warning" not in err


def test_a_heic_photo_is_calibrated_like_its_jpeg(wall, drawn, capsys, tmp_path):
    """HEIC as an iPhone saves it, decoded by pillow-heif (libheif): the same fit as the JPEG."""
    pillow_heif = pytest.importorskip("pillow_heif")
    heic = tmp_path / "IMG_0002.HEIC"
    with Image.open(drawn["photos"]["straight"]) as im:
        # x265's fastest preset: the same HEVC HEIC to decode, 1 s to encode instead of 8
        pillow_heif.from_pillow(im).save(str(heic), quality=90,
                                         enc_params={"preset": "ultrafast"})
    assert heic.read_bytes()[4:12] == b"ftypheic"
    code, out, _ = _photo(capsys, wall, heic)
    assert code == 0 and "IMG_0002.HEIC: 16 marks" in out
    assert draw_and_check(wall, "after") < 0.5
