"""The wall fit (`calibrate pattern` / `calibrate fit`) on a simulated wall.

A machine whose true parameters differ from config.toml (anchor distance, the point where
`calibrate --at 0 0` really put the pen, both spool circumferences, a gondola that holds the
cords 40 mm apart, stretching cords) draws the calibration pattern; its trace is decoded
through the TRUE geometry by tracecheck (which knows nothing of vplotter) into dot positions;
the asked-for pairs are "measured" with 0.3 mm ruler noise; `calibrate fit` runs; a test
drawing about 300 mm across is drawn from the stored position and decoded through the true
geometry. Matched to the ideal by a rigid move only, it must be within 0.5 mm everywhere
(several mm off before the fit). The simulated wall is tests/support/wall.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from support import tracecheck as tc
from support.wall import (TRUE_ANCHOR_MM, TRUE_CIRC_MM, TRUE_SPACING_MM, draw_and_check,
                          draw_pattern, measure, new_wall, run)
from vplotter.calibration import fit, pattern


@pytest.fixture(scope="module")
def drawn_pattern(tmp_path_factory):
    """`calibrate --at 0 0` and the pattern drawn on the fake machine (once for this file):
    the files, the stored position, and the dots decoded through the true geometry."""
    return draw_pattern(tmp_path_factory.mktemp("pattern"))


@pytest.fixture
def wall(tmp_path, drawn_pattern):
    """A fresh copy of config.toml, pattern.csv and the stored position for each test."""
    return new_wall(tmp_path, drawn_pattern)


def test_the_pattern_and_its_file(drawn_pattern, tmp_path):
    f = tmp_path / "p.csv"
    f.write_text(drawn_pattern["csv"])
    pat = pattern.read(f)
    dec, idx = drawn_pattern["dec"], drawn_pattern["idx"]
    assert len(idx) == len(pat.marks) == 16 and 20 <= len(pat.pairs) <= 30
    assert drawn_pattern["csv"].startswith(pattern.HEADER + "\n")
    assert "kind,a,b,x_mm,y_mm,left_steps,right_steps,distance_mm\n" in drawn_pattern["csv"]
    # every mark's dot is made at the step counts written for it (relative to the reference)
    true_cfg = drawn_pattern["true"]
    spm = tc.steps_per_mm_pair(true_cfg)
    l0, r0 = tc.inverse_kinematics(true_cfg, 0.0, 0.0)
    for k, i in zip(sorted(pat.marks), idx):
        ls, rs = pat.marks[k].steps
        assert dec.left_mm[i] == pytest.approx(l0 + ls / spm[0], abs=1e-9)
        assert dec.right_mm[i] == pytest.approx(r0 + rs / spm[1], abs=1e-9)
        # its pen-down lasts without a step: the next point is the pen going up, same cords
        assert not dec.pen_down[i + 1] and dec.left_mm[i + 1] == dec.left_mm[i]


def test_fit_on_a_simulated_wall(wall, capsys):
    before = draw_and_check(wall, "before")
    measure(wall["csv"], wall["dots"], seed=12)
    capsys.readouterr()
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"]) == 0
    out = capsys.readouterr().out
    assert "outlier" not in out
    placed = []
    after = draw_and_check(wall, "after", placed)
    print(f"simulated wall: {before:.2f} mm before the fit, {after:.3f} mm after "
          f"({placed[0]:.3f} mm without the rigid move)")
    assert before > 2.0
    assert after < 0.5
    # the stored position and the origin were kept consistent: the drawing also lands where
    # the G-code puts it relative to the point calibrated with `calibrate --at 0 0`
    assert placed[0] < 1.0
    # the new values are in config.toml, comments kept; the drawing depends on D - spacing
    text = wall["cfg"].read_text()
    assert "# between the points where the cords leave the two spools" in text
    cfg = tc.load_config(wall["cfg"])
    d_eff = cfg["machine"]["anchor_distance_mm"] - cfg.get("gondola", {}).get("cord_spacing_mm", 0)
    assert d_eff == pytest.approx(TRUE_ANCHOR_MM - TRUE_SPACING_MM, abs=2.0)
    assert cfg["motors"]["left_spool_circumference_mm"] == pytest.approx(TRUE_CIRC_MM[0], rel=2e-3)
    assert cfg["motors"]["right_spool_circumference_mm"] == pytest.approx(TRUE_CIRC_MM[1], rel=2e-3)
    for word in ("anchor_distance_mm", "left_circumference_mm", "stretch", "±", "300 mm"):
        assert word in out


def test_a_mistyped_measurement_is_named_and_left_out(wall, capsys):
    measure(wall["csv"], wall["dots"], seed=5, typo=7)
    capsys.readouterr()
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"]) == 0
    out = capsys.readouterr().out
    outliers = [line for line in out.splitlines() if "outlier" in line]
    assert len(outliers) == 1
    bad = pattern.read(wall["csv"]).pairs[7]
    assert f"pair {bad.a}-{bad.b}" in outliers[0] and f"{bad.distance_mm:.2f}" in outliers[0]
    assert draw_and_check(wall, "after") < 0.5


def test_two_swapped_rows_are_named(wall, capsys):
    measure(wall["csv"], wall["dots"], seed=6)
    lines = wall["csv"].read_text().splitlines()
    rows = [i for i, line in enumerate(lines) if line.startswith("pair,")]
    i, j = rows[0], rows[10]          # a long diagonal and a short neighbour pair
    di, dj = lines[i].rsplit(",", 1)[1], lines[j].rsplit(",", 1)[1]
    lines[i] = lines[i].rsplit(",", 1)[0] + "," + dj
    lines[j] = lines[j].rsplit(",", 1)[0] + "," + di
    wall["csv"].write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"]) == 0
    out = capsys.readouterr().out
    assert len([line for line in out.splitlines() if "outlier" in line]) == 2
    assert draw_and_check(wall, "after") < 0.5


def test_fit_spacing_keeps_the_anchor_distance(wall, capsys):
    measure(wall["csv"], wall["dots"], seed=3)
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"], "--fit-spacing") == 0
    cfg = tc.load_config(wall["cfg"])
    assert cfg["machine"]["anchor_distance_mm"] == 422.5
    assert cfg["gondola"]["cord_spacing_mm"] == pytest.approx(422.5 - TRUE_ANCHOR_MM + TRUE_SPACING_MM,
                                                              abs=2.0)
    assert draw_and_check(wall, "after") < 0.5


def test_too_few_measurements_say_how_many_more(wall, capsys):
    measure(wall["csv"], wall["dots"], seed=1)
    lines = wall["csv"].read_text().splitlines()
    kept, n = [], 0
    for line in lines:
        if line.startswith("pair,"):
            n += 1
            if n > 9:
                line = line.rsplit(",", 1)[0] + ","
        kept.append(line)
    wall["csv"].write_text("\n".join(kept) + "\n")
    before = wall["cfg"].read_text()
    capsys.readouterr()
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"]) == 2
    err = capsys.readouterr().err
    assert "9 pairs measured" in err and "measure 3 more" in err and len(err.strip().splitlines()) == 1
    assert wall["cfg"].read_text() == before


def test_too_many_bad_measurements_refuse(wall, capsys):
    measure(wall["csv"], wall["dots"], seed=2)
    lines = wall["csv"].read_text().splitlines()
    rng = np.random.default_rng(0)
    out, n = [], 0
    for line in lines:
        if line.startswith("pair,"):
            n += 1
            if n % 3:
                line = line.rsplit(",", 1)[0] + f",{rng.uniform(50, 600):.1f}"
        out.append(line)
    wall["csv"].write_text("\n".join(out) + "\n")
    before = wall["cfg"].read_text()
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"]) == 2
    err = capsys.readouterr().err
    assert "fit together" in err and "Traceback" not in err
    assert wall["cfg"].read_text() == before


# ---------------------------------------------------------------- a gondola that tilts
MEASURED_GONDOLA = "cord_spacing_mm = 40.0\npen_below_mm = 12.0\n"


@pytest.fixture(scope="module")
def tilted_pattern(tmp_path_factory):
    """The pattern drawn on a wall whose gondola tilts (its centre of mass 30 mm below the
    pen), config.toml with the gondola's cord spacing and pen offset as a ruler gives them."""
    return draw_pattern(tmp_path_factory.mktemp("tilted"), tilted=True, gondola=MEASURED_GONDOLA)


def test_the_ruler_route_on_a_tilted_wall(tilted_pattern, tmp_path, capsys):
    """`calibrate fit --fit-mass` finds where the centre of mass is: a 300 mm drawing within
    0.5 mm of its true shape; the same measurements fitted with a level gondola are worse."""
    results = {}
    for name, extra in (("tilt", ["--fit-mass"]), ("level", [])):
        (tmp_path / name).mkdir()
        w = new_wall(tmp_path / name, tilted_pattern)
        measure(w["csv"], w["dots"], seed=12)
        capsys.readouterr()
        assert run(w["cfg"], "calibrate", "fit", w["csv"], *extra) == 0
        out = capsys.readouterr().out
        results[name] = draw_and_check(w, "after")
        cfg = tc.load_config(w["cfg"])
        if name == "tilt":
            assert "mass_below_pen_mm" in out and "cannot tell" not in out
            assert 15.0 < cfg["gondola"]["mass_below_pen_mm"] < 60.0        # truly 30
        else:
            assert "mass_below_pen_mm" not in cfg["gondola"]
    print(f"tilted wall: {results['tilt']:.3f} mm with the tilt fitted, {results['level']:.3f} mm "
          f"with a level gondola")
    assert results["tilt"] < 0.5
    assert results["level"] > 2 * results["tilt"]


def test_fit_mass_says_when_the_data_cannot_tell(wall, capsys):
    """On the level wall's config (no gondola: the pen where the cords meet) the centre of mass
    changes nothing: one line says so, nothing about it is written, the fit is as without."""
    measure(wall["csv"], wall["dots"], seed=12)
    capsys.readouterr()
    assert run(wall["cfg"], "calibrate", "fit", wall["csv"], "--fit-mass") == 0
    out = capsys.readouterr().out
    said = [line for line in out.splitlines() if "cannot tell" in line]
    assert len(said) == 1 and "kept unset" in said[0]
    assert "mass_below_pen_mm" not in wall["cfg"].read_text()
    assert draw_and_check(wall, "after") < 0.5


# ---------------------------------------------------------------- units
def test_pairs_cover_rows_columns_diagonals_and_spans():
    pairs = [(p.a, p.b) for p in pattern.choose_pairs(4, 4)]
    assert 20 <= len(pairs) <= 30 and len(set(pairs)) == len(pairs)
    assert (1, 16) in pairs and (4, 13) in pairs          # both diagonals
    assert (1, 4) in pairs and (1, 13) in pairs           # a row and a column end to end
    assert (1, 2) in pairs and (1, 5) in pairs            # neighbours


def test_the_fit_recovers_a_machine_from_exact_distances():
    true = fit.Machine(428.0, 480.0, 470.0, 25.3, 24.8, 0.003, 0.0, 0.0, 4096)
    start = fit.Machine(422.5, 479.0, 475.0, 25.0, 25.0, 0.0, 0.0, 0.0, 4096)
    gx, gy = np.meshgrid(np.linspace(40, 380, 4), np.linspace(160, 700, 4))
    spots = np.column_stack((gx.ravel(), gy.ravel()))
    steps = (start.kin().inverse(spots) - [479.0, 475.0]) * start.steps_per_unit()
    a, b = np.triu_indices(16, 1)
    dist = fit.predicted(true, steps, a, b)
    res, outliers = fit.fit(start, steps, a, b, dist)
    assert outliers == []
    for k in fit.names(False):
        assert getattr(res.machine, k) == pytest.approx(getattr(true, k), rel=1e-6, abs=1e-8)


@pytest.mark.parametrize("text,where", [
    ("kind,a,b\n", ":1:1: error: not a vplotter calibration pattern"),
    (pattern.HEADER + "\n" + ",".join(pattern.COLUMNS) + "\nmark,1,,x,0,0,0,\n", ":3:"),
    (pattern.HEADER + "\n" + ",".join(pattern.COLUMNS) + "\npair,1,2,,,,,5\n", "names mark 1"),
    (pattern.HEADER + "\n" + ",".join(pattern.COLUMNS) + "\nmark,1,,0,0,0,0,\nmark,2,,0,0,0,0,\n"
     "pair,1,2,,,,,-3\n", "must be above 0"),
])
def test_bad_pattern_files_are_one_line_errors(tmp_path, config_path, capsys, text, where):
    f = tmp_path / "p.csv"
    f.write_text(text)
    assert run(config_path, "calibrate", "fit", f) == 2
    err = capsys.readouterr().err
    assert where in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_pattern_options_are_checked(config_path, tmp_path, capsys):
    assert run(config_path, "calibrate", "pattern", "--dry-run", "--rows", "1",
               "-o", tmp_path / "p.csv") == 2
    assert run(config_path, "calibrate", "pattern", "--dry-run", "--margin", "1",
               "-o", tmp_path / "p.csv") == 2
    err = capsys.readouterr().err
    assert "--rows" in err and "--margin" in err
    assert not (tmp_path / "p.csv").exists()


def test_the_marks_grow_with_a_large_page(config_path, tmp_path, capsys):
    """Up to pattern.PAGE_MM across the marks are 3 mm circles (the seed page's), then they
    grow with the page, their margin too, so that a phone photo of the whole pattern on a
    2 m wall shows them as large as on the seed machine's: the trace's circles say so."""
    text = config_path.read_text()
    for key, value in (("anchor_distance_mm", 2000.0), ("x_mm", 1000.0), ("y_mm", 1300.0),
                       ("x_min_mm", -600.0), ("x_max_mm", 600.0), ("y_min_mm", -500.0),
                       ("y_max_mm", 500.0)):
        text = "\n".join(f"{key} = {value}" if line.split("=")[0].strip() == key else line
                         for line in text.splitlines())
    big = tmp_path / "big.toml"
    big.write_text(text + "\n")
    assert pattern.mark_size(_page(-200, 200, -250, 300)) == 1.0        # config.toml's
    assert pattern.mark_size(_page(-600, 600, -500, 500)) == 2.0
    trace = tmp_path / "t.csv"
    assert run(big, "calibrate", "pattern", "--dry-run", "--trace", trace,
               "-o", tmp_path / "p.csv") == 0
    dec = tc.decode(tc.read_trace(trace), tc.load_config(big))
    marks = pattern.read(tmp_path / "p.csv").marks
    first = marks[1]
    assert first.x_mm == pytest.approx(-600 + 2 * pattern.MARGIN_MM)        # the margin grew
    down = np.asarray(dec.pen_down)
    xy = np.column_stack((dec.x, dec.y))[down]
    # round mark 1: its circle at 6 mm, its ring at 12 mm (twice CIRCLE_MM, FIRST_MM), its
    # number from 17 mm on
    near = np.hypot(*(xy - [first.x_mm, first.y_mm]).T)
    assert near[near < 1.25 * 2 * pattern.FIRST_MM].max() == pytest.approx(
        2 * pattern.FIRST_MM, abs=0.05)
    assert near[near < 1.5 * 2 * pattern.CIRCLE_MM].max() == pytest.approx(
        2 * pattern.CIRCLE_MM, abs=0.05)
    assert run(big, "calibrate", "pattern", "--dry-run", "--margin", "25",
               "-o", tmp_path / "q.csv") == 2
    assert "31.4 mm or more" in capsys.readouterr().err


def _page(x0, x1, y0, y1):
    from types import SimpleNamespace

    return SimpleNamespace(x_min_mm=x0, x_max_mm=x1, y_min_mm=y0, y_max_mm=y1)
