"""Photos through the whole pipeline: `convert`/`estimate`/`info`/`preview` of a picture in each
style, read back by tracecheck's own G-code reader: within the budget, inside the placed
picture, upright, transparent parts blank, bad files one line and exit 2, and the same drawing
when a draw is resumed from where it started."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image, ImageDraw

from support import tracecheck as tc
from support import REPO
from vplotter import budget
from support.cli import run

STYLES = ("hatch", "spiral", "squiggle", "stipple", "flow")
PAGE_CENTRE = (0.0, 0.0)         # where a photo is centred: G-code X0 Y0 (docs: Placement)


@pytest.fixture
def photo(tmp_path):
    """A 300 x 200 px picture: dark disc on a left-to-right ramp, a white box bottom left."""
    h, w = 200, 300
    x = np.linspace(0, 255, w, dtype=np.float32)[None, :].repeat(h, 0)
    img = Image.fromarray(np.dstack([x, x, x]).astype(np.uint8))
    d = ImageDraw.Draw(img)
    d.ellipse([100, 50, 200, 150], fill=(10, 10, 10))
    d.rectangle([10, 140, 80, 190], fill=(255, 255, 255))
    path = tmp_path / "photo.jpg"
    img.save(path, quality=92)
    return path


def estimate_s(capsys, config, path) -> float:
    code, out, _ = run(capsys, ["--config", config, "estimate", path])
    assert code == 0
    return float(re.search(r"\(([\d.]+) s\)", out).group(1))


@pytest.mark.parametrize("style", STYLES + ("stipple --tsp",))
def test_convert_fits_the_budget_and_the_picture(capsys, config_path, photo, tmp_path, style):
    out = tmp_path / f"{style.split()[-1]}.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--style", *style.split(), "--width", 150, "--max-time", "10m",
                                "--verbose"])
    assert code == 0, err
    assert "within 10:00" in err                              # says what it chose (and
    # with --verbose, when the time jumps with the spacing, that it does)
    t = estimate_s(capsys, config_path, out)
    assert t <= 600 * 1.01
    # the time the final order saves is spent (unless the time jumps with the spacing)
    assert t >= 600 * budget.FILL_UNDER or "closest try under the budget" in err
    polys = tc.reference_path(str(out))
    pts = np.concatenate(polys)
    cx, cy = PAGE_CENTRE
    w, h = 150.0, 100.0
    assert pts[:, 0].min() >= cx - w / 2 - 1 and pts[:, 0].max() <= cx + w / 2 + 1
    assert pts[:, 1].min() >= cy - h / 2 - 1 and pts[:, 1].max() <= cy + h / 2 + 1
    # more ink on the dark (left) third than on the light (right) third of the ramp
    left = pts[:, 0] < cx - w / 6
    right = pts[:, 0] > cx + w / 6
    assert left.sum() > 1.3 * right.sum()


def test_the_pictures_frame_is_what_is_placed(capsys, config_path, photo, tmp_path):
    """--align/--valign put the picture's frame (not its first ink) on the page's edge, less
    --margin, the same for every density tried; a frame off the page is one line, exit 2."""
    out = tmp_path / "a.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--width", 90, "--align", "left", "--valign", "top",
                                "--margin", 5, "--max-time", "5m"])
    assert code == 0, err
    pts = np.concatenate(tc.reference_path(str(out)))
    x0, top = -200 + 5, 300 - 5                     # the seed page X -200..200, Y -250..300
    assert pts[:, 0].min() >= x0 - 1e-3 and pts[:, 0].max() <= x0 + 90 + 1e-3
    assert pts[:, 1].max() <= top + 1e-3 and pts[:, 1].min() >= top - 60 - 1e-3
    assert pts[:, 0].min() < x0 + 10                # ink near the frame's left edge (dark side)
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--width", 300, "--offset", 150, 0, "--max-time", "5m"])
    assert code == 2 and len(err.strip().splitlines()[-1:]) == 1
    assert "the picture (300 x 200 mm) reaches X300.0" in err and "off the page" in err


def test_a_longer_budget_draws_more(capsys, config_path, photo, tmp_path):
    lengths = []
    for limit in ("15m", "45m"):
        out = tmp_path / f"{limit}.ngc"
        assert run(capsys, ["--config", config_path, "convert", photo, "-o", out, "--width",
                            150, "--max-time", limit])[0] == 0
        lengths.append(sum(float(np.hypot(*np.diff(p, axis=0).T).sum())
                           for p in tc.reference_path(str(out))))
    assert lengths[1] > 2 * lengths[0]


def test_info_says_what_the_budget_chose(capsys, config_path, photo):
    code, out, _ = run(capsys, ["--config", config_path, "info", photo, "--json",
                                "--width", 100, "--style", "squiggle"])
    assert code == 0
    info = json.loads(out)
    assert any("no --max-time" in n for n in info["notes"])    # the default budget, said
    assert any("within 1:00:00" in n for n in info["notes"])
    assert info["time_s"]["best"] <= 3600 and "100 x 67 mm" in info["notes"][0]
    # one line of what was chosen, in words; what is drawn (the track pitch and the tone
    # curve) among the details (said with --verbose)
    assert re.fullmatch(r"photo: squiggle, 100 x 67 mm, spacing [0-9.]+ mm, plot time "
                        r"[0-9:]+ within 1:00:00 \(no --max-time: the default budget\)",
                        info["notes"][0])
    assert any(re.search(r"track pitch [0-9.]+ mm .*tone curve (d\^[0-9.]+|fitted)", n)
               for n in info["details"])


def test_exif_orientation_makes_it_upright(capsys, config_path, tmp_path):
    # a landscape file whose EXIF says "rotate 90": upright it is a portrait
    img = Image.new("L", (120, 60), 255)
    ImageDraw.Draw(img).rectangle([0, 0, 59, 59], fill=0)
    exif = Image.Exif()
    exif[0x0112] = 6
    path = tmp_path / "phone.jpg"
    img.save(path, exif=exif)
    out = tmp_path / "phone.ngc"
    assert run(capsys, ["--config", config_path, "convert", path, "-o", out, "--height", 100,
                        "--spacing", 2])[0] == 0
    pts = np.concatenate(tc.reference_path(str(out)))
    # upright: 50 mm wide, 100 high; orientation 6 turns the file's left (dark) half to the
    # top (unturned it would be 200 mm wide with the dark half on the left)
    assert np.ptp(pts[:, 0]) <= 51
    assert pts[:, 1].min() >= PAGE_CENTRE[1] - 3 and pts[:, 1].max() <= PAGE_CENTRE[1] + 51
    assert np.ptp(pts[:, 1]) > 45


def test_transparent_parts_stay_blank(capsys, config_path, tmp_path):
    img = Image.new("RGBA", (200, 100), (0, 0, 0, 255))
    ImageDraw.Draw(img).rectangle([0, 0, 99, 99], fill=(0, 0, 0, 0))    # left half clear
    path = tmp_path / "clear.png"
    img.save(path)
    out = tmp_path / "clear.ngc"
    assert run(capsys, ["--config", config_path, "convert", path, "-o", out, "--width", 100,
                        "--spacing", 2])[0] == 0
    pts = np.concatenate(tc.reference_path(str(out)))
    assert pts[:, 0].min() > PAGE_CENTRE[0] - 1.5       # nothing on the clear left half
    assert pts[:, 0].max() > PAGE_CENTRE[0] + 40        # the black half is drawn


@pytest.mark.parametrize("content, what", [(b"", "empty"), (b"G1 X10\n", "not an image"),
                                           (b"\x89PNG\r\n\x1a\n" + b"\0" * 20, "")])
def test_bad_images_are_one_line_and_exit_2(capsys, config_path, tmp_path, content, what):
    path = tmp_path / "bad.png"
    path.write_bytes(content)
    code, _, err = run(capsys, ["--config", config_path, "estimate", path])
    assert code == 2
    errors = [line for line in err.splitlines() if "error:" in line]
    assert len(errors) == 1 and str(path) in errors[0] and what in errors[0]


@pytest.mark.parametrize("command", ["estimate", "convert", "draw"])
def test_a_missing_file_or_a_folder_is_the_same_line_in_every_command(capsys, config_path,
                                                                     tmp_path, command):
    for path, said in ((tmp_path / "gone.png", ": error: no such file"),
                       (tmp_path, ": error: is a directory")):
        extra = {"convert": ["-o", tmp_path / "o.ngc"], "draw": ["--dry-run"]}.get(command, [])
        code, _, err = run(capsys, ["--config", config_path, command, path, *extra])
        errors = [line for line in err.splitlines() if "error:" in line]
        assert code == 2 and errors == [errors[0]] and errors[0].startswith(f"{path}{said}")


def test_photo_options_on_other_files_are_errors(capsys, config_path):
    car = REPO / "gcode_samples" / "car.ngc"
    for extra in (["--style", "spiral"], ["--max-time", "1h"], ["--tsp"]):
        code, _, err = run(capsys, ["--config", config_path, "estimate", car, *extra])
        assert code == 2 and "is for photos" in err
    code, _, err = run(capsys, ["--config", config_path, "estimate", REPO / "gcode_samples" /
                                "square.ngc", "--width", 50, "--fit"])
    assert code == 2 and "not two of them" in err


def test_a_budget_too_short_says_so(capsys, config_path, photo):
    code, _, err = run(capsys, ["--config", config_path, "estimate", photo, "--width", 390,
                                "--style", "stipple", "--max-time", "1m"])
    assert code == 2 and "too short" in err


def test_the_drawing_depends_on_where_it_starts_not_on_the_motors(config_path, photo):
    """A resumed draw re-makes the photo from the first draw's start point: the budget's
    timing follows from that point alone, so the same strokes come out."""
    import argparse

    from vplotter import config
    from vplotter.commands.files import prepare_file
    from vplotter.machine.state import Position

    cfg = config.load(config_path)
    args = argparse.Namespace(file=str(photo), width=120.0, max_time="15m", style="spiral",
                              order=None)
    spu = cfg.motors.steps_per_unit
    a = Position(479.0891, 479.0891, 0, 0, spu)
    b = Position(479.0891 + 5000 / spu[0], 479.0891 - 3000 / spu[1], 5000, -3000, spu)
    assert np.allclose(a.ref_mm, b.ref_mm) and a.counts != b.counts
    pa = prepare_file(args, cfg, a, warn=lambda m: None, start_xy=(10.0, 20.0), say_notes=False)
    pb = prepare_file(args, cfg, b, warn=lambda m: None, start_xy=(10.0, 20.0), say_notes=False)
    assert pa.key == pb.key
    assert len(pa.strokes) == len(pb.strokes)
    assert all(np.array_equal(s.pts, t.pts) for s, t in zip(pa.strokes, pb.strokes))


def test_ink_preview_is_dark_where_the_photo_is(capsys, config_path, photo, tmp_path):
    png = tmp_path / "ink.png"
    code, out, err = run(capsys, ["--config", config_path, "preview", photo, "-o", png, "--ink",
                                  "--width", 150, "--max-time", "20m", "--size", 800])
    assert code == 0, err and "ink of a pen 0.5 mm wide" in out
    grey = np.asarray(Image.open(png).convert("L"), dtype=float)
    assert grey.min() < 80                        # black ink is there


@pytest.mark.parametrize("style", ["squiggle", "hatch", "stipple --tsp"])
def test_info_says_which_tone_curve_the_picture_got(capsys, config_path, photo, style):
    """The tone curve is chosen per picture: info names the curves tried with their scores,
    the one drawn scored best, and the drawing still fits the budget."""
    code, out, _ = run(capsys, ["--config", config_path, "info", photo, "--json",
                                "--width", 100, "--style", *style.split(), "--max-time", "20m"])
    assert code == 0
    info = json.loads(out)
    note = next(n for n in info["details"] if "chosen for this picture" in n)
    curve = r"d\^[0-9.]+|fitted \(ink from darkness [0-9.]+ up\)"
    chosen = re.search(rf"tone curve ({curve}) chosen", note).group(1)
    tried = {g: float(r) for g, r in re.findall(rf"({curve}) (-?[0-9.]+)", note.split(": ", 1)[1])}
    assert len(tried) >= 3 and tried[chosen] == max(tried.values())
    assert any("fitted" in g for g in tried)           # the measured response was tried too
    assert any(f"tone curve {chosen}" in n and re.search("pitch|as many dots", n)
               for n in info["details"])
    assert info["time_s"]["best"] <= 1200


@pytest.mark.parametrize("style", ["hatch", "spiral", "squiggle", "stipple --tsp", "flow",
                                   "auto"])
@pytest.mark.parametrize("limit", ["15m", "45m"])
def test_a_chosen_curve_keeps_ink_rising_with_darkness(capsys, config_path, tmp_path, style, limit):
    """Five grey bands (linear darkness 0.2 to 1.0) through the whole budget search, the
    fitted curves (ink from a threshold up) among those tried: each darker band gets more
    ink, the lightest some."""
    bands = 5
    v = [round(255 * (1 - d) ** (1 / 2.2)) for d in np.linspace(0.2, 1.0, bands)]
    img = Image.fromarray(np.repeat(np.array(v, np.uint8), 60)[None, :].repeat(40, 0))
    src, out = tmp_path / "bands.png", tmp_path / "bands.ngc"
    img.save(src)
    code, _, err = run(capsys, ["--config", config_path, "convert", src, "-o", out, "--style",
                                *style.split(), "--width", 150, "--max-time", limit])
    assert code == 0, err
    x0 = PAGE_CENTRE[0] - 75
    ink = np.zeros(bands)
    for p in tc.reference_path(str(out)):
        if len(p) == 1:                           # a dot (a tour's lone stipple): pen-wide
            p, seg = p, np.array([0.5])
        else:
            seg = np.hypot(*np.diff(p, axis=0).T)
            p = (p[1:] + p[:-1]) / 2
        ink += np.bincount(np.clip(((p[:, 0] - x0) / 30).astype(int), 0, bands - 1), seg, bands)
    assert ink[0] > 0 and np.all(np.diff(ink) > 0), (ink, err)


def test_a_dot_is_a_move_in_the_gcode(capsys, config_path, photo, tmp_path):
    """Each stipple is pen down, a G1 to where the pen is, pen up: a reader that keeps only
    the pen-down moves (as many previewers do) still sees every dot."""
    out = tmp_path / "dots.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--style", "stipple", "--width", 150, "--spacing", 4])
    assert code == 0, err
    down, dots, moved = False, 0, []
    for line in out.read_text().splitlines():
        if line.startswith("G1 Z-"):
            down, dots = True, dots + 1
            moved.append(0)
        elif line.startswith("G0 Z"):
            down = False
        elif down and line.startswith("G1 X"):
            moved[-1] += 1
    assert dots > 50 and moved == [1] * dots
    assert len(tc.reference_path(str(out))) == dots
