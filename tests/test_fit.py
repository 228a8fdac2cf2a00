"""The wall fit on a simulated wall.

A machine whose true parameters differ from config.toml (anchor distance, the point where
`calibrate --at 0 0` really put the pen, both spool circumferences, a gondola that holds the
cords 40 mm apart, stretching cords) draws the calibration pattern; its trace is decoded
through the TRUE geometry by tracecheck (which knows nothing of vplotter) into dot positions;
the asked-for pairs are "measured" with 0.3 mm ruler noise; `calibrate fit` runs; a test
drawing about 300 mm across is drawn from the stored position and decoded through the true
geometry. Matched to the ideal by a rigid move only, it must be within 0.5 mm everywhere
(several mm off before the fit).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import tracecheck as tc
from conftest import REPO
from vplotter.calibration import fit, pattern
from vplotter.machine import state
from vplotter.cli import main

TEST_DRAWING = """G21 G90
G0 X-150 Y25
M3
G1 X150 Y25 F600
M5
G0 X-100 Y-75
M3
G1 X100 Y-75
G1 X100 Y125
G1 X-100 Y125
G1 X-100 Y-75
G1 X100 Y125
M5
G0 X100 Y25
M3
G2 X100 Y25 I-100 J0
M5
"""

# the true wall: off from config.toml as a tape measure and a home-made gondola are
TRUE_ANCHOR_MM = 422.5 + 6.0
TRUE_SPACING_MM = 40.0
TRUE_PEN_BELOW_MM = 12.0
TRUE_CIRC_MM = (25.0 * 1.015, 25.0 * 0.988)
TRUE_STRETCH = 0.003
REF_OFF_MM = (5.0, -4.0)          # where the pen really was at `calibrate --at 0 0` (machine)


def true_config() -> dict:
    # G-code X0 Y0 of this config is where the pen really was at the reference
    return tc.load_config({
        "machine": {"anchor_distance_mm": TRUE_ANCHOR_MM},
        "origin": {"x_mm": 211.25 + REF_OFF_MM[0], "y_mm": 430.0 + REF_OFF_MM[1]},
        "motors": {"left_spool_circumference_mm": TRUE_CIRC_MM[0],
                   "right_spool_circumference_mm": TRUE_CIRC_MM[1]},
        "gondola": {"cord_spacing_mm": TRUE_SPACING_MM, "pen_below_mm": TRUE_PEN_BELOW_MM},
        "cords": {"stretch": TRUE_STRETCH},
    })


def run(cfg_path, *args) -> int:
    return main(["--config", str(cfg_path), *map(str, args)])


def dots(dec) -> np.ndarray:
    """Pen-down strokes without a step: the dots, in the order they were made."""
    down = np.asarray(dec.pen_down)
    single = down.copy()
    single[1:] &= ~down[:-1]
    single[:-1] &= ~down[1:]
    idx = np.flatnonzero(single)
    return np.column_stack((dec.x[idx], dec.y[idx])), idx


def true_start(true_cfg, counts_at_reference) -> tuple[float, float]:
    """Where the pen really is after the given step counts from the reference."""
    spm = tc.steps_per_mm_pair(true_cfg)
    l0, r0 = tc.inverse_kinematics(true_cfg, 0.0, 0.0)
    x, y = tc.forward_kinematics(true_cfg, l0 + counts_at_reference[0] / spm[0],
                                 r0 + counts_at_reference[1] / spm[1])
    return float(x), float(y)


def measure(csv_path, positions: dict[int, np.ndarray], seed: int, typo: int | None = None):
    """Write the dots' true distances with 0.3 mm noise into pattern.csv; `typo`: that pair
    row gets its digits mistyped (123.4 -> 1234)."""
    rng = np.random.default_rng(seed)
    out, k = [], 0
    for line in csv_path.read_text().splitlines():
        if line.startswith("pair,"):
            _, a, b = line.split(",")[:3]
            d = float(np.hypot(*(positions[int(a)] - positions[int(b)]))) + rng.normal(0, 0.3)
            if k == typo:
                d *= 10
            line = f"pair,{a},{b},,,,,{d:.1f}"
            k += 1
        out.append(line)
    csv_path.write_text("\n".join(out) + "\n")


def rigid_error(dec, gfile) -> float:
    """Worst distance, both ways, between the drawing and the ideal path after the best rigid
    move (rotation and translation, no scale) of the drawing onto it (ICP with Kabsch on a
    sample of the drawn points; the distances on all of them)."""
    ideal = tc.reference_path(gfile, spacing=0.05)
    ref_pts = np.vstack(ideal)
    tree = cKDTree(ref_pts)
    down = np.column_stack((dec.x, dec.y))[np.asarray(dec.pen_down)]
    sample = down[::max(1, len(down) // 5000)]
    rot, shift = np.eye(2), ref_pts.mean(axis=0) - sample.mean(axis=0)
    for _ in range(40):
        moved = sample @ rot.T + shift
        target = ref_pts[tree.query(moved)[1]]
        pc, tc_ = sample.mean(axis=0), target.mean(axis=0)
        u, _, vt = np.linalg.svd((sample - pc).T @ (target - tc_))
        sign = np.sign(np.linalg.det(vt.T @ u.T))
        new_rot = vt.T @ np.diag([1.0, sign]) @ u.T
        new_shift = tc_ - pc @ new_rot.T
        done = np.abs(new_rot - rot).max() < 1e-12 and np.abs(new_shift - shift).max() < 1e-9
        rot, shift = new_rot, new_shift
        if done:
            break
    drawn = [p @ rot.T + shift for p in tc.drawn_polylines(dec)]
    # segments of 0.05 mm: within 0.025 mm of exact, against limits of 0.5 and 2 mm
    there = tc.distances_to_polylines(down @ rot.T + shift, ideal, spacing=0.05).max()
    back = tc.distances_to_polylines(ref_pts, drawn, spacing=0.05).max()
    return float(max(there, back))


@pytest.fixture(scope="module")
def drawn_pattern(tmp_path_factory):
    """`calibrate --at 0 0` and the pattern drawn on the fake machine (once for this file):
    the files, the stored position, and the dots decoded through the true geometry."""
    import os

    tmp = tmp_path_factory.mktemp("pattern")
    saved = os.environ.get("XDG_STATE_HOME")
    os.environ["XDG_STATE_HOME"] = str(tmp / "state")
    try:
        cfg_path = tmp / "config.toml"
        cfg_path.write_text((REPO / "config.toml").read_text())
        csv_path = tmp / "pattern.csv"
        trace = tmp / "pattern_trace.csv"
        assert run(cfg_path, "calibrate", "--at", 0, 0) == 0
        assert run(cfg_path, "calibrate", "pattern", "--backend", "fake", "--trace", trace,
                   "-o", csv_path) == 0
        stored = state.state_path().read_text()
        counts = state.load().counts
    finally:
        if saved is None:
            del os.environ["XDG_STATE_HOME"]
        else:
            os.environ["XDG_STATE_HOME"] = saved
    true_cfg = true_config()
    dec = tc.decode(tc.read_trace(trace), true_cfg, (0.0, 0.0))
    pts, idx = dots(dec)
    return {"csv": csv_path.read_text(), "state": stored, "dec": dec, "pts": pts, "idx": idx,
            "start": true_start(true_cfg, counts), "true": true_cfg}


@pytest.fixture
def wall(tmp_path, drawn_pattern):
    """A fresh copy of config.toml, pattern.csv and the stored position for each test."""
    cfg_path = tmp_path / "config.toml"
    cfg_path.write_text((REPO / "config.toml").read_text())
    csv_path = tmp_path / "pattern.csv"
    csv_path.write_text(drawn_pattern["csv"])
    state.state_path().parent.mkdir(parents=True, exist_ok=True)
    state.state_path().write_text(drawn_pattern["state"])
    gfile = tmp_path / "test.ngc"
    gfile.write_text(TEST_DRAWING)
    pat = pattern.read(csv_path)
    return {"cfg": cfg_path, "csv": csv_path, "true": drawn_pattern["true"], "tmp": tmp_path,
            "gfile": gfile, "dots": dict(zip(sorted(pat.marks), drawn_pattern["pts"])),
            "start": drawn_pattern["start"]}


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


def draw_and_check(w, name: str, placed: list | None = None) -> float:
    trace = w["tmp"] / f"{name}.csv"
    assert run(w["cfg"], "draw", w["gfile"], "--dry-run", "--trace", trace) == 0
    dec = tc.decode(tc.read_trace(trace), w["true"], w["start"])
    assert not dec.problems
    if placed is not None:      # without any move: G-code X0 Y0 is where the pen was calibrated
        placed.append(max(tc.accuracy(dec, tc.reference_path(w["gfile"], spacing=0.05),
                                      spacing=0.05)))
    return rigid_error(dec, w["gfile"])


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
