"""White as docs/pens.md says it (issue 33): strokes in white, a colour whose every channel is
#fd or more (#fdfdfd and lighter), are left out, since white does not show on paper; a faint
colour that is darker in one channel (#fcfdf8, a gradient's stop; `lightyellow` #ffffe0) is
drawn. In SVG strokes and hatched fills alike; a white pen in [pens] draws them all."""

from __future__ import annotations

import numpy as np
import pytest

from support import tracecheck as tc
from vplotter.cli import main
from vplotter.config.sections import PenSpec
from vplotter.drawing import pens
from vplotter.errors import ConfigError
from vplotter.inputs import colour as colours
from vplotter.inputs.strokes import Stroke

WHITE = ["#fdfdfd", "#fefefe", "#ffffff", "white", "#FFF", "rgb(253, 254, 255)"]
FAINT = ["#fcfdf8", "lightyellow", "#ffffe0", "#fdfdfc", "#fcfcfc", "ivory", "#f8f8f8"]


@pytest.mark.parametrize("colour", WHITE)
def test_white_is_every_channel_fd_or_more(colour):
    assert pens.is_white(colour)


@pytest.mark.parametrize("colour", FAINT + ["black", "#000000", "red", None, "not a colour"])
def test_a_faint_colour_is_not_white(colour):
    assert not pens.is_white(colour)


def test_resolve_leaves_out_white_and_draws_faint_colours():
    sq = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    # readers give '#rrggbb' (or no colour: the pen's name says it)
    strokes = [Stroke(sq + k, k + 1, pen=c, colour=None if c == "white" else colours.parse(c))
               for k, c in enumerate(WHITE + FAINT)]
    said: list[str] = []
    got = pens.resolve(strokes, (), said.append, "f.svg")
    assert [s.line for s in got] == [len(WHITE) + k + 1 for k in range(len(FAINT))]
    assert said == [f"f.svg: warning: {len(WHITE)} strokes in white left out (white does not "
                    f"show on paper; a white pen in [pens] draws them)"]
    # a pen in [pens] of the paper's white draws them; a faint pen does not count as one
    got = pens.resolve(strokes, (PenSpec("chalk", "#fefefe"), PenSpec("ink", "#101010")))
    assert len(got) == len(strokes)
    said.clear()
    got = pens.resolve(strokes, (PenSpec("cream", "#ffffe0"), PenSpec("ink", "#101010")),
                       said.append, "f.svg")
    assert len(got) == len(FAINT) and f"{len(WHITE)} strokes in white left out" in said[0]


def svg_of(colours: list[str], paint: str) -> str:
    """One 10 mm square per colour, 20 mm apart along X, stroked or filled (no stroke) in it,
    and a black square at the end that places the drawing."""
    rects = []
    for k, c in enumerate(colours + ["black"]):
        style = f'stroke="{c}" fill="none"' if paint == "stroke" else f'fill="{c}" stroke="none"'
        rects.append(f'<rect x="{5 + 20 * k}" y="5" width="10" height="10" {style}/>')
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{20 * len(rects)}mm" '
            f'height="20mm" viewBox="0 0 {20 * len(rects)} 20">{"".join(rects)}</svg>')


@pytest.mark.parametrize("paint", ["stroke", "fill"])
def test_svg_strokes_and_fills_in_white_are_left_out(tmp_path, capsys, config_path, paint):
    colours = ["#fcfdf8", "lightyellow", "#fdfdfd", "#ffffff", "white", "#ffffe0"]
    drawn = [True, True, False, False, False, True] + [True]
    p = tmp_path / f"{paint}.svg"
    p.write_text(svg_of(colours, paint))
    out = tmp_path / "o.ngc"
    fill = ["--fill", "hatch", "--fill-spacing", "1"] if paint == "fill" else []
    code = main(["--config", str(config_path), "convert", str(p), "-o", str(out), *fill])
    err = capsys.readouterr().err
    assert code == 0, err
    paths = tc.reference_path(out, spacing=0.1)
    pts = np.concatenate(paths)
    # the drawing is centred on X0: square k's middle lies at X = 20 k + 10 - width / 2
    width = 20 * len(drawn)
    for k, want in enumerate(drawn):
        x = 20 * k + 10 - width / 2
        inside = np.abs(pts[:, 0] - x) <= 5.5
        assert inside.any() == want, (colours + ["black"])[k]
    lines = [ln for ln in err.splitlines() if "in white left out" in ln]
    assert len(lines) == 1
    if paint == "stroke":                   # (a hatched square is several strokes)
        assert ": warning: 3 strokes in white left out" in lines[0]


def test_photo_colours_refuse_white(tmp_path):
    """--colours: a white pen draws nothing on paper; the same rule as strokes, so a faint
    pen that shows (lightyellow) is taken."""
    from vplotter.drawing import photo

    for name in ("white", "#fdfdfd", "#ffffff"):
        with pytest.raises(ConfigError, match="is white"):
            photo.pens_of((name, "black"))
    assert [p[0] for p in photo.pens_of(("lightyellow", "#fcfdf8", "black"))] == [
        "lightyellow", "#fcfdf8", "black"]
