"""The vpype plugin (`vpype ... vplotter draw|convert|estimate`, docs/vpype.md), run in-process
through vpype's own command line: what it converts is what `vplotter convert` makes of the SVG
vpype writes (the same pen-down geometry within 0.02 mm, one pen per layer, in order), its dry
run plots what `draw` plots, placement options, errors, a stop resumed through vpype.
Skipped where vpype is not installed (it is in the `test` extra)."""

from __future__ import annotations

import signal

import numpy as np
import pytest

vpype_cli = pytest.importorskip("vpype_cli")

from click.testing import CliRunner  # noqa: E402

from support import REPO  # noqa: E402
from support import tracecheck as tc  # noqa: E402
from support.signals import interrupt_after  # noqa: E402
from vplotter.cli import main  # noqa: E402
from vplotter.machine import state  # noqa: E402

LAYERS = REPO / "svg_samples" / "inkscape_layers.svg"
GENERATIVE = REPO / "svg_samples" / "generative.svg"


def vpype(*argv) -> tuple[int, str, str]:
    result = CliRunner().invoke(vpype_cli.cli, [str(a) for a in argv], catch_exceptions=False)
    return result.exit_code, result.stdout, result.stderr


def vplotter(config_path, *argv) -> int:
    return main(["--config", str(config_path), *map(str, argv)])


def pens(path) -> list[str]:
    return [line.split("(pen: ", 1)[1].rstrip(")") for line in path.read_text().splitlines()
            if line.startswith("M0 (pen: ")]


def pen_down(path) -> list[np.ndarray]:
    """The pen-down polylines of a G-code file, by tracecheck's own G-code reader."""
    return tc.reference_path(path, spacing=1e9)


def same_lines(a: list[np.ndarray], b: list[np.ndarray], tol: float = 0.02) -> None:
    assert [len(x) for x in a] == [len(y) for y in b]
    assert max(float(np.abs(x - y).max()) for x, y in zip(a, b)) <= tol


@pytest.mark.parametrize("drawing", [LAYERS, GENERATIVE], ids=["layers", "generative"])
def test_convert_is_vplotter_convert_of_the_svg_vpype_writes(drawing, config_path, tmp_path):
    a, b_svg, b = tmp_path / "a.ngc", tmp_path / "b.svg", tmp_path / "b.ngc"
    code, _, _ = vpype("read", drawing, "linesort", "vplotter", "convert", "--config",
                       config_path, "-o", a, "write", b_svg)
    assert code == 0 and a.exists() and b_svg.exists()
    assert vplotter(config_path, "convert", b_svg, "--order", "keep", "-o", b) == 0
    same_lines(pen_down(a), pen_down(b))
    pa, pb = pens(a), pens(b)
    assert len(pa) == len(pb) and len(set(pa)) == len(pa)      # one pen per layer, in order


def test_each_layer_is_a_pen_named_by_its_name_else_its_colour(config_path, tmp_path):
    out = tmp_path / "a.ngc"
    code, _, _ = vpype("rect", "-l", "1", "0", "0", "40mm", "30mm",
                       "circle", "-l", "2", "0", "0", "10mm",
                       "line", "-l", "3", "0", "0", "30mm", "30mm",
                       "color", "-l", "1", "#101010", "color", "-l", "2", "#ffd000",
                       "name", "-l", "3", "fineliner",
                       "vplotter", "convert", "--config", config_path, "-o", out)
    assert code == 0
    # light to dark: the yellow layer, vpype's own colour for layer 3 (blue), then near-black
    assert pens(out) == ["#ffd000", "fineliner", "#101010"]


def test_placement_options_place_as_for_the_svg(config_path, tmp_path):
    a, b_svg, b = tmp_path / "a.ngc", tmp_path / "b.svg", tmp_path / "b.ngc"
    place = ["--fit", "--rotate", "30", "--margin", "10", "--align", "left", "--offset", "5",
             "-3"]
    code, _, _ = vpype("read", LAYERS, "linemerge", "linesort", "vplotter", "convert",
                       "--config", config_path, "-o", a, *place, "write", b_svg)
    assert code == 0
    assert vplotter(config_path, "convert", b_svg, "--order", "keep", "-o", b, *place) == 0
    same_lines(pen_down(a), pen_down(b))


def test_a_dry_run_plots_what_draw_plots(config_path, tmp_path, capsys):
    t_vpype, t_draw = tmp_path / "vpype.csv", tmp_path / "draw.csv"
    b_svg, a = tmp_path / "b.svg", tmp_path / "a.ngc"
    code, said, _ = vpype("read", LAYERS, "linesort", "write", b_svg,
                          "vplotter", "draw", "--config", config_path, "--dry-run", "--trace",
                          t_vpype, "vplotter", "convert", "--config", config_path, "-o", a)
    assert code == 0 and "pause: put in the Arcs pen" in said
    assert vplotter(config_path, "draw", b_svg, "--order", "keep", "--dry-run",
                    "--trace", t_draw) == 0
    cfg = tc.load_config(config_path)
    tr_v, tr_d = tc.read_trace(t_vpype), tc.read_trace(t_draw)
    # both draw the converted file's path within 0.02 mm both ways, in the same time
    assert tc.verify(tr_v, a, cfg, tol_mm=0.02) == []
    assert tc.verify(tr_d, a, cfg, tol_mm=0.02) == []
    assert tc.plot_time(tr_v) == pytest.approx(tc.plot_time(tr_d), rel=1e-3)
    steps = [tc.decode(t, cfg) for t in (tr_v, tr_d)]
    assert abs(len(steps[0].x) - len(steps[1].x)) <= 1e-4 * len(steps[1].x)


def test_estimate_says_what_vplotter_estimate_says(config_path, tmp_path, capsys):
    b_svg = tmp_path / "b.svg"
    code, said, _ = vpype("read", GENERATIVE, "linesort", "write", b_svg,
                          "vplotter", "estimate", "--config", config_path, "--order", "best")
    assert code == 0
    assert vplotter(config_path, "estimate", b_svg, "--order", "best") == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    mine = said.strip().splitlines()[-1]
    assert mine.endswith(" s)") and " pen lifts, " in mine

    def seconds(line: str) -> float:
        return float(line.rsplit("(", 1)[1].split()[0])

    # the SVG's coordinates are rounded to 0.0001 px: the same plot time within 0.1 %
    assert seconds(mine) == pytest.approx(seconds(last), rel=1e-3)
    assert mine.split(" pen lifts")[0].split()[-1] == last.split(" pen lifts")[0].split()[-1]


def test_bad_options_are_refused_in_one_line(config_path, tmp_path):
    code, _, err = vpype("read", LAYERS, "vplotter", "convert", "--config", config_path,
                         "-o", tmp_path / "a.ngc", "--align", "sideways")
    assert code == 2 and "--align sideways: not a choice" in err
    assert len([line for line in err.splitlines() if "error" in line.lower()]) == 1
    code, _, err = vpype("read", LAYERS, "vplotter", "convert", "--config", config_path,
                         "-o", tmp_path / "a.ngc", "--dry-run")
    assert code == 2 and "--dry-run is for `vplotter draw`" in err
    code, _, err = vpype("read", LAYERS, "vplotter", "estimate", "--config", tmp_path / "no.toml")
    assert code == 2 and "Traceback" not in err


def test_a_stopped_draw_resumes_through_vpype(config_path, tmp_path, monkeypatch):
    from vplotter.backends.fake import FakeBackend

    assert vplotter(config_path, "calibrate", "--at", "0", "0") == 0
    orig = interrupt_after(monkeypatch, 20_000, signal.SIGINT)
    # one layer (one pen: no pen-change pause to wait at)
    pipeline = ["read", LAYERS, "lmove", "all", "1", "linesort", "vplotter", "draw",
                "--config", config_path, "--backend", "fake"]
    code, _, err = vpype(*pipeline, "--trace", tmp_path / "t1.csv")
    assert code == 130 and "--resume" in err
    resume = state.load().extra["resume"]
    assert resume["file"].endswith(".vpype.npz") and resume["line"] > 0
    monkeypatch.setattr(FakeBackend, "play", orig)
    code, _, err = vpype(*pipeline, "--resume", "--trace", tmp_path / "t2.csv")
    assert code == 0, err
    assert "resume" not in state.load().extra
    cfg = tc.load_config(config_path)
    a = tmp_path / "a.ngc"
    assert vpype(*pipeline[:6], "vplotter", "convert", "--config", config_path, "-o", a)[0] == 0
    ref = pen_down(a)
    start2 = tc.decode(tc.read_trace(tmp_path / "t1.csv"), cfg)
    dec2 = tc.decode(tc.read_trace(tmp_path / "t2.csv"), cfg,
                     (float(start2.x[-1]), float(start2.y[-1])))
    pts = np.column_stack((dec2.x, dec2.y))[dec2.pen_down]
    assert len(pts) and tc.distances_to_polylines(pts, ref).max() <= 0.02
