"""The flow style (streamlines along the picture's shapes, spaced by tone), --style auto (every
style tried, the best kept) and the budgeted stipple's choice between its dots and its tour."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image

from support import tracecheck as tc
from support.cli import run
from vplotter.drawing import photo_auto
from vplotter.inputs.image import flow, score
from vplotter.inputs.image.picture import Picture


def _disc(w_mm=80.0, h_mm=60.0, px=0.25, r_mm=18.0):
    """A dark disc on a light grey ground."""
    rows, cols = round(h_mm / px), round(w_mm / px)
    yy, xx = np.mgrid[0:rows, 0:cols]
    x, y = (xx + 0.5) * px, h_mm - (yy + 0.5) * px
    d = np.where(np.hypot(x - w_mm / 2, y - h_mm / 2) < r_mm, 0.9, 0.15).astype(np.float32)
    return Picture(d, w_mm, h_mm, "disc")


def test_lines_follow_the_edges():
    """Near the disc's edge the lines run along it (across the gradient), not into it."""
    pic = _disc()
    strokes = flow.strokes(pic, 1.0, 0.5)
    seg = np.concatenate([np.diff(s.pts, axis=0) for s in strokes])
    mid = np.concatenate([(s.pts[1:] + s.pts[:-1]) / 2 for s in strokes])
    radial = mid - np.array([40.0, 30.0])
    r = np.hypot(*radial.T)
    near = (r > 16) & (r < 20)
    cos = np.abs((seg[near] * radial[near]).sum(1)) / (np.hypot(*seg[near].T) * r[near])
    assert near.sum() > 100 and np.median(cos) < 0.25, np.median(cos)


def test_long_strokes_few_lifts():
    """On a flat grey the lines are long: few pen lifts for the line drawn."""
    pic = Picture(np.full((240, 320), 0.8, np.float32), 80, 60)
    strokes = flow.strokes(pic, 1.0, 0.5)
    lengths = np.array([s.length_mm() for s in strokes])
    assert lengths.sum() > 1000 and lengths.mean() > 10, (lengths.sum(), lengths.mean())


def test_dark_gets_denser_lines_and_the_tone_shows():
    """The separation follows the tone: more line on the disc than around it, and the ink
    correlates with the darkness."""
    pic = _disc()
    strokes = flow.strokes(pic, 1.5, 0.5)
    pts = np.concatenate([s.pts for s in strokes])
    inside = np.hypot(pts[:, 0] - 40, pts[:, 1] - 30) < 17
    disc_area, rest = np.pi * 17 ** 2, 80 * 60 - np.pi * 19 ** 2
    assert inside.sum() / disc_area > 2 * (~inside).sum() / rest
    assert score.correlation(strokes, pic, 0.5) > 0.6


def test_the_same_streamlines_for_every_try():
    """The budget's tries draw on one set of streamlines: a second drawing costs little and
    a denser spacing adds lines where the coarser drew (the nesting)."""
    pic = _disc()
    a = flow.strokes(pic, 3.0, 0.5)
    made = flow.lines(pic, 0.5)
    b = flow.strokes(pic, 1.5, 0.5)
    assert flow.lines(pic, 0.5) is made
    assert sum(s.length_mm() for s in b) > 1.5 * sum(s.length_mm() for s in a)
    again = flow.strokes(pic, 3.0, 0.5)                     # deterministic
    assert len(again) == len(a) and all(np.array_equal(x.pts, y.pts) for x, y in zip(a, again))


def test_a_white_picture_draws_nothing():
    assert flow.strokes(Picture(np.zeros((40, 60), np.float32), 60, 40), 1.0, 0.5) == []


@pytest.fixture
def photo(tmp_path):
    """A 240 x 160 px picture: a dark disc on a left-to-right ramp."""
    h, w = 160, 240
    x = np.linspace(40, 255, w, dtype=np.float32)[None, :].repeat(h, 0)
    yy, xx = np.mgrid[0:h, 0:w]
    x[(xx - 120) ** 2 + (yy - 80) ** 2 < 45 ** 2] = 15
    path = tmp_path / "photo.png"
    Image.fromarray(x.astype(np.uint8)).save(path)
    return path


def _estimate(capsys, config, path) -> float:
    code, out, _ = run(capsys, ["--config", config, "estimate", path])
    assert code == 0
    return float(re.search(r"\(([\d.]+) s\)", out).group(1))


def test_flow_fits_the_budget(capsys, config_path, photo, tmp_path):
    out = tmp_path / "flow.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--style", "flow", "--width", 120, "--max-time", "10m"])
    assert code == 0, err
    assert "photo: flow, 120 x 80 mm" in err and "within 10:00" in err
    assert _estimate(capsys, config_path, out) <= 600 * 1.01
    pts = np.concatenate(tc.reference_path(str(out)))
    assert np.all(np.abs(pts[:, 0]) <= 60 + 1e-3) and np.all(np.abs(pts[:, 1]) <= 40 + 1e-3)


def test_flow_in_four_pens(capsys, config_path, photo, tmp_path):
    out = tmp_path / "cmyk.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--style", "flow", "--cmyk", "--width", 100, "--max-time",
                                "10m"])
    assert code == 0, err
    assert "(layer black" in out.read_text()                # a grey picture: the black pen


def test_auto_lists_every_style_and_keeps_the_best(capsys, config_path, photo):
    """info --style auto: one note names the style kept and every style's score and plot
    time (those finished, then the quick ranking of the rest); the one kept scores best of
    those finished, and the best of the quick ranking was finished."""
    code, out, err = run(capsys, ["--config", config_path, "info", photo, "--json",
                                  "--style", "auto", "--width", 100, "--max-time", "8m"])
    assert code == 0, err
    note = json.loads(out)["notes"][0]
    m = re.match(r"--style auto chose (\S+( --tsp)?) \(tone ([0-9.]+), [0-9:]+; (.*); quick: "
                 r"(.*)\): .* the best ([0-9]) finished$", note)
    assert m, note
    style = r"([a-z]+(?: --tsp)?) ([0-9.]+), [0-9:]+"
    done = {s: float(v) for s, v in re.findall(style, m.group(4))}
    quick = {s: float(v) for s, v in re.findall(style, m.group(5))}
    assert set(done) | set(quick) | {m.group(1)} == {"hatch", "squiggle", "spiral", "flow",
                                                     "stipple --tsp"}    # a photograph: no dots
    assert 1 <= len(done) + 1 == int(m.group(6)) <= photo_auto.FINISHED + 1
    assert "hatch" in set(done) | {m.group(1)}          # always finished
    assert float(m.group(3)) >= max(done.values())
    assert json.loads(out)["time_s"]["best"] <= 480 * 1.01


def test_auto_finishes_only_the_styles_ranked_best(monkeypatch):
    """--style auto finishes (curves fitted to the budget, the final order) only the first by
    the quick score, the one of the rest whose bound is highest (if near the first's score) and
    the hatch, and keeps the best of those by its own score."""
    from vplotter.drawing import photo, photo_fork

    monkeypatch.setattr(photo_fork, "WORKERS", 1)       # every search seen here

    class Searched:
        def __init__(self, quick, d):
            self.quick, self.d = quick, d
            self.choice = type("C", (), {"time_s": 60.0, "spacing_mm": 2})

    quick = {"hatch": 0.70, "squiggle": 0.75, "spiral": 0.74, "flow": 0.60, "stipple": 0.73}
    final = {"hatch": 0.71, "squiggle": 0.71, "spiral": 0.72, "flow": 0.99, "stipple": 0.99}
    searched = []

    def search(d):
        searched.append(d.style)
        return Searched(quick[d.style], d)

    def finished(s, said):
        style = next(k for k, v in quick.items() if v == s.quick)
        return [style], said, style, 55.0

    bound = {"hatch": 0.70, "squiggle": 0.75, "spiral": 0.74, "flow": 0.74, "stipple": 0.745}
    monkeypatch.setattr("vplotter.drawing.photo_curve.quick_score",
                        lambda s, dark: (s.quick, bound[next(k for k, v in quick.items()
                                                             if v == s.quick)]))
    monkeypatch.setattr(photo_auto, "tone_score", lambda raw, pictures, pen: final[raw])
    opts = [photo.PhotoOptions(style=s) for s in photo_auto.AUTO_STYLES]
    begin = lambda o: (type("D", (), {"style": o.style, "drawn_last": {1: 2}})(),  # noqa: E731
                       photo.advice.Said())
    pic = Picture(np.linspace(0, 1, 64, dtype=np.float32).reshape(8, 8), 8.0, 8.0)
    placed, said = photo_auto.auto(opts, begin, search, finished, (pic, None, None))
    # squiggle first; of the rest the stipple's bound is highest (within MARGIN); the hatch
    assert placed == ["stipple"]
    assert said.notes[0].startswith("--style auto chose stipple (tone 0.990, 0:55; squiggle "
                                    "0.710, 0:55; hatch 0.710, 0:55; quick: spiral 0.740, "
                                    "1:00; flow 0.600, 1:00): ")
    assert searched == list(photo_auto.AUTO_STYLES)      # each style's budget searched once


def test_a_budgeted_stipple_of_a_photograph_draws_the_tour(capsys, config_path, photo,
                                                           tmp_path):
    """A photograph (little of it white): the tour alone, said so, one search."""
    out = tmp_path / "st.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", photo, "-o", out,
                                "--style", "stipple", "--width", 100, "--max-time", "5m"])
    assert code == 0, err
    assert re.search(r"stipple: the tour through the dots \(tone [0-9.]+, [0-9:]+; dots not "
                     r"tried: [0-9]+% of the picture is white", err), err
    polys = tc.reference_path(str(out))
    assert sum(1 for p in polys if len(p) > 1) > 0


def test_a_budgeted_stipple_of_line_art_says_dots_or_tour(capsys, config_path, tmp_path):
    """Line art (mostly white): the dots and the tour both drawn, the better kept."""
    a = np.full((160, 240), 255, np.uint8)
    a[40:44, 20:220] = a[100:140, 60:64] = a[60:120, 150:190] = 0
    path = tmp_path / "lines.png"
    Image.fromarray(a).save(path)
    out = tmp_path / "st.ngc"
    code, _, err = run(capsys, ["--config", config_path, "convert", path, "-o", out,
                                "--style", "stipple", "--width", 100, "--max-time", "5m"])
    assert code == 0, err
    m = re.search(r"stipple: (dots|the tour through the dots) \(tone ([0-9.]+), [0-9:]+; "
                  r"stipple(?: --tsp)? ([0-9.]+)", err)
    assert m and float(m.group(2)) >= float(m.group(3)), err
    polys = tc.reference_path(str(out))
    dots = sum(1 for p in polys if len(p) == 1)
    assert (dots == len(polys)) == (m.group(1) == "dots")


def test_auto_on_a_bad_image_is_one_line(capsys, config_path, tmp_path):
    bad = tmp_path / "cut.png"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n" + b"\0" * 20)
    code, _, err = run(capsys, ["--config", config_path, "convert", bad, "-o",
                                tmp_path / "o.ngc", "--style", "auto", "--max-time", "5m"])
    assert code == 2 and len(err.strip().splitlines()) == 1 and str(bad) in err
