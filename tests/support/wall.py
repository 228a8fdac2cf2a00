"""The simulated wall of tests/test_wall_calibration.py (and bench/wall_fit.py).

A machine whose true parameters differ from config.toml (the TRUE_* values below: anchor
distance, the point where `calibrate --at 0 0` really put the pen, both spool circumferences, a
gondola that holds the cords 40 mm apart, stretching cords) draws the calibration pattern; its
trace is decoded through the TRUE geometry by tracecheck into dot positions, which `measure`
turns into a tape measure's readings; `draw_and_check` draws TEST_DRAWING and gives how far it
is off the ideal after a rigid move. bench/wall_fit.py sets the TRUE_* values of other walls.

The test drawing's 550,000 decoded points are checked a point every THIN_MM along each
stroke (`decode_true`; each stroke's ends and the pen-up points either side kept). A gondola
that tilts is slow to decode besides: tracecheck solves its balance point by point (a
bisection, some 40 us a point, 20 s for the pattern's 600,000 points), so its steps are
counted with the gondola held level and only the points kept are placed through the true
geometry (the tilted pattern too: its dots and strokes).
"""

from __future__ import annotations

import os
import tempfile

import numpy as np
from scipy.spatial import cKDTree

from vplotter.calibration import pattern
from vplotter.cli import main
from vplotter.machine import state

from . import REPO
from . import tracecheck as tc

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
TRUE_MASS_BELOW_MM = None         # the gondola's centre of mass below the pen (None: level)
TILTED_MASS_BELOW_MM = 30.0       # the tilted wall's (draw_pattern(tmp, tilted=True))
REF_OFF_MM = (5.0, -4.0)          # where the pen really was at `calibrate --at 0 0` (machine)
TRUE_SAG = None                   # (cords' g per m, gondola's g): cords that sag (None: straight)
SAG_WALL = (18.0, 200.0)          # the sagging wall's (draw_pattern(tmp, sag=SAG_WALL))
# the strokes checked a point every THIN_MM (the steps are some 0.005 mm apart): a skipped
# point is within THIN_MM / 2 of a kept one. Measured against every point: 0.1285 / 0.1311 mm
# after the fit, tilted 0.0840 / 0.0858 and 0.4377 / 0.4434 (limits 0.5 mm, level > 2 x tilt);
# before the fit 6.45 / 6.59 mm (ICP's rigid match of a badly bent drawing moves with its
# sample; the limit there is > 2 mm)
THIN_MM = 0.05


def true_config(mass_below_mm: float | None = None, sag: tuple | None = None) -> dict:
    # G-code X0 Y0 of this config is where the pen really was at the reference
    gondola = {"cord_spacing_mm": TRUE_SPACING_MM, "pen_below_mm": TRUE_PEN_BELOW_MM}
    mass = TRUE_MASS_BELOW_MM if mass_below_mm is None else mass_below_mm
    if mass is not None:
        gondola["mass_below_pen_mm"] = mass
    cords = {"stretch": TRUE_STRETCH}
    sag = TRUE_SAG if sag is None else sag
    if sag is not None:
        cords["mass_g_per_m"], gondola["mass_g"] = sag
    return tc.load_config({
        "machine": {"anchor_distance_mm": TRUE_ANCHOR_MM},
        "origin": {"x_mm": 211.25 + REF_OFF_MM[0], "y_mm": 430.0 + REF_OFF_MM[1]},
        "motors": {"left_spool_circumference_mm": TRUE_CIRC_MM[0],
                   "right_spool_circumference_mm": TRUE_CIRC_MM[1]},
        "gondola": gondola,
        "cords": cords,
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


def decode_true(trace, true_cfg: dict, start, thin: bool = True) -> tc.Decoded:
    """The trace decoded through the true geometry; thinned (`thin`, and always for a gondola
    that tilts): its pen-down points a point every THIN_MM along each stroke, each stroke's
    ends and the pen-up points either side (the rest are left out)."""
    tilted = true_cfg.get("gondola", {}).get("mass_below_pen_mm") is not None
    if not (thin or tilted):
        return tc.decode(trace, true_cfg, start)
    if tilted:          # the same steps, cords and pen states with the gondola held level
        level = {**true_cfg, "gondola": {k: v for k, v in true_cfg["gondola"].items()
                                         if k != "mass_below_pen_mm"}}
        cords = tuple(float(v) for v in tc.inverse_kinematics(true_cfg, *start))
        dec = tc.decode(trace, level, start, start_q=cords)
    else:
        dec = tc.decode(trace, true_cfg, start)
    keep = _thinned(dec)
    x, y = (tc.forward_kinematics(true_cfg, dec.left_mm[keep], dec.right_mm[keep]) if tilted
            else (dec.x[keep], dec.y[keep]))
    out = tc.Decoded(cfg=true_cfg, start_xy=dec.start_xy, start_cords=dec.start_cords,
                     steps=dec.steps, illegal=dec.illegal, n_illegal=dec.n_illegal,
                     pen_values=dec.pen_values, pen_events=dec.pen_events, t=dec.t[keep],
                     x=x, y=y, pen_down=dec.pen_down[keep], left_mm=dec.left_mm[keep],
                     right_mm=dec.right_mm[keep], end_time=dec.end_time,
                     problems=list(dec.problems))
    if tilted and np.isnan(y).any():
        out.problems.append(f"{int(np.isnan(y).sum())} cord states cannot be triangulated")
    return out


def _thinned(dec) -> np.ndarray:
    """Indices of the pen-down points a point every THIN_MM along each stroke (as `dec`
    places them: a tilt held level moves them by millimetres, their spacing by a few
    percent), each stroke's first and last, and the pen-up points next to a stroke."""
    down = np.asarray(dec.pen_down, dtype=bool)
    step = np.hypot(np.diff(dec.x, prepend=dec.x[:1]), np.diff(dec.y, prepend=dec.y[:1]))
    start = down & ~np.concatenate(([False], down[:-1]))
    # arc length along the strokes, restarting at each stroke's first point
    along = np.cumsum(np.where(down & ~start, step, 0.0))
    along -= np.maximum.accumulate(np.where(start, along, 0.0))
    bucket = np.floor(along / THIN_MM)
    keep = down & (start | (bucket != np.concatenate(([-1.0], bucket[:-1]))))
    edge = down != np.concatenate((down[1:], [False]))          # last of a stroke, or before one
    keep |= edge | np.concatenate(([False], edge[:-1] & down[:-1]))   # and after one
    return np.flatnonzero(keep)


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


def draw_pattern(tmp, tilted: bool = False, gondola: str = "", sag: tuple | None = None) -> dict:
    """`calibrate --at 0 0` and the pattern drawn on the fake machine, in folder `tmp`: the
    files, the stored position, and the dots decoded through the true geometry (`tilted`: a
    gondola whose centre of mass is TILTED_MASS_BELOW_MM below the pen; `gondola`: keys of
    a [gondola] section the person measured and added to config.toml; `sag`: cords that sag,
    (g per m, the gondola's g), written in config.toml too)."""
    if sag is not None:
        gondola += f"mass_g = {sag[1]:g}\n\n[cords]\nmass_g_per_m = {sag[0]:g}\n"
    saved = os.environ.get("XDG_STATE_HOME")
    # the stored position in memory where there is /dev/shm: the pattern's draw fsyncs some
    # 1,800 journal records (5 ms each on a busy disk)
    memory = "/dev/shm" if os.access("/dev/shm", os.W_OK) else None
    home = tempfile.TemporaryDirectory(prefix="vplotter-wall-", dir=memory)
    os.environ["XDG_STATE_HOME"] = home.name
    try:
        cfg_path = tmp / "config.toml"
        cfg_path.write_text(_config(gondola))
        csv_path = tmp / "pattern.csv"
        trace = tmp / "pattern_trace.csv"
        assert run(cfg_path, "calibrate", "--at", 0, 0) == 0
        assert run(cfg_path, "calibrate", "pattern", "--backend", "fake", "--trace", trace,
                   "-o", csv_path) == 0
        stored = state.state_path().read_text()
        counts = state.load().counts
    finally:
        home.cleanup()
        if saved is None:
            del os.environ["XDG_STATE_HOME"]
        else:
            os.environ["XDG_STATE_HOME"] = saved
    true_cfg = true_config(TILTED_MASS_BELOW_MM if tilted else None, sag)
    dec = decode_true(tc.read_trace(trace), true_cfg, (0.0, 0.0), thin=False)
    pts, idx = dots(dec)
    return {"csv": csv_path.read_text(), "state": stored, "dec": dec, "pts": pts, "idx": idx,
            "start": true_start(true_cfg, counts), "true": true_cfg, "gondola": gondola}


def _config(gondola: str) -> str:
    return (REPO / "config.toml").read_text() + (f"\n[gondola]\n{gondola}" if gondola else "")


def new_wall(tmp_path, drawn_pattern: dict) -> dict:
    """A fresh copy of config.toml (as the pattern was drawn with it), pattern.csv and the
    stored position in `tmp_path`."""
    cfg_path = tmp_path / "config.toml"
    cfg_path.write_text(_config(drawn_pattern.get("gondola", "")))
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


def draw_and_check(w, name: str, placed: list | None = None) -> float:
    trace = w["tmp"] / f"{name}.csv"
    assert run(w["cfg"], "draw", w["gfile"], "--dry-run", "--trace", trace) == 0
    dec = decode_true(tc.read_trace(trace), w["true"], w["start"])
    assert not dec.problems
    if placed is not None:      # without any move: G-code X0 Y0 is where the pen was calibrated
        placed.append(max(tc.accuracy(dec, tc.reference_path(w["gfile"], spacing=0.05),
                                      spacing=0.05)))
    return rigid_error(dec, w["gfile"])
