"""What a photo's drawing says to a person: one line of what was chosen, the tone details only
with --verbose, and advice when the drawing will not show a face, with the size and the time
that would; followed, that advice gives a drawing that passes (drawing/advice.py)."""

from __future__ import annotations

import argparse
import json
import re

import numpy as np
import pytest
from PIL import Image, ImageDraw, ImageFilter

from vplotter import budget
from support.cli import run
from vplotter.drawing import advice


@pytest.fixture
def face(tmp_path):
    """A portrait-like picture, 3:4: a mid-grey face (an oval) with dark eyes, brows and
    mouth and a shaded cheek, dark hair, a light background and a dark collar."""
    w, h = 300, 400
    img = Image.new("L", (w, h), 225)
    d = ImageDraw.Draw(img)
    d.ellipse([60, 30, 240, 250], fill=50)                      # hair
    d.ellipse([80, 70, 220, 290], fill=165)                     # the face
    d.ellipse([80, 150, 130, 280], fill=135)                    # a shaded cheek
    for x in (115, 185):
        d.ellipse([x - 16, 145, x + 16, 165], fill=245)         # the eyes' whites
        d.ellipse([x - 7, 148, x + 7, 162], fill=20)
        d.line([(x - 22, 130), (x + 22, 126)], fill=40, width=7)
    d.polygon([(150, 170), (138, 215), (162, 215)], fill=125)   # the nose
    d.chord([115, 220, 185, 260], 0, 180, fill=60)              # the mouth
    d.rectangle([40, 320, 260, 400], fill=30)                   # the collar
    path = tmp_path / "face.png"
    img.filter(ImageFilter.GaussianBlur(2)).save(path)
    return path


def info(capsys, config_path, path, *argv) -> dict:
    code, out, err = run(capsys, ["--config", config_path, "info", path, "--json", *argv])
    assert code == 0, err
    return json.loads(out)


def spacing_of(got: dict) -> float:
    return next(float(m.group(1)) for d in got["details"]
                if (m := re.match(r"spacing ([0-9.]+) mm for a plot time", d)))


# ------------------------------------------------------------------ the words
def test_no_advice_when_the_spacing_shows_a_face():
    for kind, pens in advice.GOOD_PENS.items():
        assert advice.advise(kind, 0.5, pens * 0.5, 300, 400, 3500, 3600) == []
        assert advice.advise(kind, 0.5, pens * 0.5 * 0.7, 300, 400, 3500, 3600) == []
        assert advice.advise(kind, 0.5, pens * 0.5 * 1.1, 300, 400, 3500, 3600) != []


def test_advice_says_size_time_and_what_will_not_show():
    said, = advice.advise("hatch", 0.5, 5.4, 300, 400, 3550, 3600)
    assert said.startswith("at 300 x 400 mm in 1 h the lines are 5.4 mm apart, 10.8 pen "
                           "widths: only the darkest parts will show, not a face.")
    t = re.search(r"--max-time (\w+)\)", said).group(1)
    w = int(re.search(r"--width (\d+)\)", said).group(1))
    need = budget.parse_duration(t)                   # typed as --max-time takes it
    # the budget's model, time ~ spacing^-power, with its margin, rounded up
    assert need >= 3600 * (5.4 / 1.6) ** advice.TIME_POWER["hatch"] * advice.MARGIN
    assert need % 900 == 0 and advice.duration(need) in said
    # in the same time the area shrinks as the time would grow: time ~ area at a spacing
    k = advice.TIME_POWER["hatch"]
    assert w % 10 == 0 and f"{w} mm wide" in said
    assert 300 * (1.6 / 5.4) ** (k / 2) / advice.MARGIN ** 0.5 - 10 < w
    assert w <= 300 * (1.6 / 5.4) ** (k / 2) / advice.MARGIN ** 0.5
    # the spiral's spacing is not a distance between lines: said as line spread thin
    said, = advice.advise("spiral", 0.5, 16.964, 300, 300, 3500, 3600)
    assert "the line is spread thin (spacing 17 mm, 33.9 pen widths)" in said
    assert "track" not in said
    # a fixed --spacing: the spacing that would show one
    said, = advice.advise("stipple", 0.5, 7.0, 200, 200)
    assert said.startswith("at 200 x 200 mm the dots are 7 mm apart") and "--spacing 4 " in said


def test_a_small_picture_needs_lines_across():
    """Fine enough for the tone, too few lines across a small picture: only more time helps
    (smaller, the same time would not give the lines; larger, the tone)."""
    assert advice.advise("hatch", 0.5, 1.5, 100, 130, 590, 600) == []
    said, = advice.advise("hatch", 0.5, 1.5, 40, 53, 590, 600)
    assert said.startswith("at 40 x 53 mm in 10 min the lines are 1.5 mm apart, 27 across: too "
                           "few for a face (40 would do).")
    assert "--max-time" in said
    # the spiral's tracks are at most 3.5 mm apart: below 140 mm they decide
    assert advice.good_spacing("spiral", 0.5, 300, 400) == 5.0
    assert advice.good_spacing("spiral", 0.5, 120, 160) == 3.0


def test_advice_never_suggests_what_cannot_be_given():
    # a month is --max-time's limit; a picture under MIN_MM is not suggested
    said, = advice.advise("stipple", 0.5, 200.0, 400, 400, 3500, 3600)
    assert "--max-time" not in said
    said, = advice.advise("stipple", 0.5, 400.0, 60, 60, 86000, 86400)
    assert "--max-time" not in said and "--width" not in said
    assert "smaller picture or another style" in said


@pytest.mark.parametrize("seconds,typed,words", [(3600, "1h", "1 h"), (2700, "45m", "45 min"),
                                                 (9000, "2h30m", "2 h 30 min")])
def test_durations_are_typed_as_max_time_takes_them(seconds, typed, words):
    assert advice.option_time(seconds) == typed and advice.duration(seconds) == words
    assert budget.parse_duration(typed) == seconds


def test_one_line_of_what_was_chosen():
    assert advice.chosen("hatch", 300, 400, 3.376, 3547, 3600) == (
        "photo: hatch, 300 x 400 mm, lines 3.38 mm apart, plot time 59:07 within 1:00:00")
    assert advice.chosen("tsp", 100, 67, 2.5, 590, 600, default=True, densest=True) == (
        "photo: stipple --tsp, 100 x 67 mm, dots 2.5 mm apart, plot time 9:50 within 10:00 "
        "(no --max-time: the default budget); as dense as the pen can show")
    assert advice.chosen("squiggle", 100, 67, 2.0) == (
        "photo: squiggle, 100 x 67 mm, spacing 2 mm (--spacing)")


# ------------------------------------------------------------------ said by the commands
def test_notes_in_words_details_with_verbose(capsys, config_path, face, tmp_path):
    out = tmp_path / "f.ngc"
    base = ["--config", config_path, "convert", face, "-o", out, "--width", 120,
            "--max-time", "10m", "--style", "spiral"]
    code, _, err = run(capsys, base)
    assert code == 0, err
    notes = [ln for ln in err.splitlines() if ln.startswith("note: photo:")]
    assert len(notes) == 1 and re.fullmatch(
        r"note: photo: spiral, 120 x 160 mm, spacing [0-9.]+ mm, plot time [0-9:]+ within "
        r"10:00", notes[0])
    # no exponents, correlations or pitches unless asked for
    for word in ("d^", "correlation", "pitch", "tries"):
        assert word not in err
    advised = [ln for ln in err.splitlines() if ln.startswith("advice: ")]
    assert len(advised) == 1 and "not a face" in advised[0]
    gcode = out.read_bytes()
    code, _, err = run(capsys, base + ["--verbose"])
    assert code == 0
    assert "correlation" in err and "track pitch" in err and "tries)" in err
    assert out.read_bytes() == gcode                    # what is said changes, not what is drawn


@pytest.mark.parametrize("command", ["info", "estimate", "preview"])
def test_every_file_command_takes_verbose(capsys, config_path, face, tmp_path, command):
    extra = ["-o", tmp_path / "p.png", "--size", 300] if command == "preview" else []
    code, out, err = run(capsys, ["--config", config_path, command, face, *extra, "--width", 60,
                                  "--max-time", "5m", "--verbose"])
    assert code == 0, err
    assert "tone curve" in out + err


def test_draw_verbose_says_the_tone_details_too(capsys, config_path, face):
    code, _, err = run(capsys, ["--config", config_path, "draw", face, "--dry-run", "--width", 60,
                                "--max-time", "5m", "--verbose"])
    assert code == 0, err
    assert "note: photo: hatch, 60 x 80 mm" in err and "tone curve" in err


def test_the_advice_is_a_value_of_the_prepared_drawing(config_path, face):
    """The page reads `Prepared.advice` (and `notes`): the same words as the command line."""
    from vplotter.commands.common import load_config, position
    from vplotter.commands.files import prepare_file

    args = argparse.Namespace(file=str(face), config=config_path, width=120.0, max_time="10m",
                              style="hatch")
    cfg = load_config(args)
    prep = prepare_file(args, cfg, position(cfg, args, True), say_notes=False)
    assert prep.notes[0].startswith("photo: hatch, 120 x 160 mm, lines ")
    assert len(prep.advice) == 1 and prep.advice[0].startswith("at 120 x 160 mm in 10 min the "
                                                               "lines are ")
    assert any("tone curve" in d for d in prep.details)


# ------------------------------------------------------------------ the advice, followed
@pytest.mark.parametrize("style,width", [("hatch", 120), ("spiral", 150)])
def test_the_advice_followed_shows_a_face(capsys, config_path, face, style, width):
    """A sparse drawing is advised a time and a size (the spiral at 150 mm: only a time, its
    tracks at most 3.5 mm apart are too few across a smaller picture); each, given, draws at
    a spacing at which a face shows (`good_spacing` at its size), and says no more advice."""
    sparse = info(capsys, config_path, face, "--width", width, "--max-time", "10m",
                  "--style", style)
    assert spacing_of(sparse) > advice.good_spacing(style, 0.5, width, width * 4 / 3)
    assert len(sparse["advice"]) == 1
    said = sparse["advice"][0]
    t = re.search(r"--max-time (\w+)\)", said).group(1)
    w = re.search(r"--width (\d+)\)", said)
    assert (w is not None) == (style == "hatch")
    w = int(w.group(1)) if w else None
    for size, limit in ((width, t), (w, "10m")) if w else ((width, t),):
        got = info(capsys, config_path, face, "--width", size, "--max-time", limit,
                   "--style", style)
        good = advice.good_spacing(style, 0.5, size, size * 4 / 3)
        assert spacing_of(got) <= good and got["advice"] == [], (size, limit)
    assert (w is None or w < width) and budget.parse_duration(t) > 600


def test_advice_costs_nothing_next_to_the_search():
    import time

    t0 = time.perf_counter()
    for _ in range(1000):
        advice.advise("hatch", 0.5, 5.4, 300, 400, 3550, 3600)
    assert (time.perf_counter() - t0) / 1000 < 1e-3       # a convert takes seconds
    assert np.isfinite(advice.needed_time(2.0, 14.0, 4.0, 3600))


def test_the_time_follows_the_budgets_own_tries():
    """time ~ spacing^-k: k from the densest try to the drawing chosen, never under the
    style's floor nor over MAX_POWER; no denser try: the floor."""
    assert advice.time_power("spiral", 11.7, 591, []) == advice.TIME_POWER["spiral"]
    k = advice.time_power("spiral", 11.7, 591, [(1.5, 14839), (11.7, 591), (15.0, 560)])
    assert k == pytest.approx(np.log(14839 / 591) / np.log(11.7 / 1.5))
    assert advice.time_power("hatch", 3.0, 3600, [(1.5, 4000)]) == advice.TIME_POWER["hatch"]
    assert advice.time_power("hatch", 3.0, 3600, [(1.5, 1e9)]) == advice.MAX_POWER
    short = advice.advise("spiral", 0.5, 11.7, 300, 400, 591, 600)
    steep = advice.advise("spiral", 0.5, 11.7, 300, 400, 591, 600, [(1.5, 14839)])
    t = [budget.parse_duration(re.search(r"--max-time (\w+)\)", a[0]).group(1))
         for a in (short, steep)]
    assert t[1] > t[0]
