"""Cords that sag ([cords] mass_g_per_m, [gondola] mass_g; kinematics/sag.py): the catenary
against tracecheck's own (cords shot from the gondola, another parameterisation), the limit of
light cords, inverse and forward, exact slopes and bends, turning points and the step solver,
the config keys, the calibration's machine, and a drawing decoded by tracecheck. Unset,
nothing changes (test_traces.py)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support import tracecheck as tc
from support.cli import run
from support import kin_props as props
from vplotter import config
from vplotter.calibration import fit
from vplotter.kinematics import from_config
from vplotter.kinematics.vplotter import TwoCord

D, OX, OY = 422.5, 211.25, 430.0
MU = 18.0 / 1000.0 / 200.0          # ball chain of 18 g/m on a gondola of 200 g
SHAPES = {   # cord spacing, pen below, stretch, centre of mass below the pen
    "level": (0.0, 0.0, 0.0, None),
    "gondola+stretch": (40.0, 12.0, 0.004, None),
    "tilt": (40.0, 12.0, 0.0, 30.0),
    "tilt+stretch": (40.0, 12.0, 0.004, 30.0),
}
MODELS = {name: TwoCord(D, OX, OY, s, h, k, mass_below_pen_mm=m, sag_per_mm=MU)
          for name, (s, h, k, m) in SHAPES.items()}
# the page less its outer 30 mm: beyond, the gondola's points come within a few mm of straight
# below an anchor, the other cord carries almost nothing and hangs in a loop
gx = st.floats(-170, 170, allow_nan=False)
gy = st.floats(-240, 290, allow_nan=False)
angle = st.floats(0, 2 * math.pi, allow_nan=False)
model = st.sampled_from(sorted(MODELS))


def _tc_config(name: str, per_m: float = 18.0) -> dict:
    s, h, k, m = SHAPES[name]
    gondola = {"cord_spacing_mm": s, "pen_below_mm": h, "mass_g": 200.0}
    if m is not None:
        gondola["mass_below_pen_mm"] = m
    return tc.load_config({"gondola": gondola, "cords": {"stretch": k, "mass_g_per_m": per_m}})


def _points(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    g = np.column_stack((rng.uniform(-170, 170, n), rng.uniform(-240, 290, n)))
    return np.vstack((g, [[-170, 290], [170, 290], [-170, -240], [170, -240]]))


@pytest.mark.parametrize("name", sorted(MODELS))
def test_inverse_and_forward_against_tracecheck(name):
    """The package's cords against an independent catenary (shot from the gondola's end with
    its pulls H and V, Newton on the balance with a numerical Jacobian): within 1e-6 mm both
    ways, where the cords sag by up to tens of mm."""
    kin = MODELS[name]
    g = _points(150, 2)
    q = kin.inverse(kin.to_machine(g))
    left, right = tc.inverse_kinematics(_tc_config(name), g[:, 0], g[:, 1])
    assert np.abs(np.column_stack((left, right)) - q).max() < 1e-6
    x, y = tc.forward_kinematics(_tc_config(name), q[:, 0], q[:, 1])
    assert np.abs(np.column_stack((x, y)) - g).max() < 1e-6
    straight = TwoCord(D, OX, OY, *SHAPES[name][:3], mass_below_pen_mm=SHAPES[name][3])
    assert np.abs(straight.inverse(kin.to_machine(g)) - q).max() > 1.0


def test_catenary_by_hand():
    """On the centre line each cord carries half the weight: H from the catenary's own
    equation, its length the arc of y = a cosh(x / a) between the apex's offsets."""
    from scipy.optimize import brentq

    kin = MODELS["level"]
    p = np.array([[D / 2, 300.0]])
    h, v = D / 2, 300.0

    def pull(H):
        a = H / MU
        # apex at x0 (from the anchor); the anchor a cosh(x0/a) - a cosh((x0 - h)/a) = v above
        x0 = brentq(lambda x0: a * (math.cosh(x0 / a) - math.cosh((x0 - h) / a)) - v, -1e5, 1e5)
        return H * math.sinh((x0 - h) / a), a * (math.sinh(x0 / a) - math.sinh((x0 - h) / a))

    H = brentq(lambda H: pull(H)[0] - 0.5, 0.05, 5.0, xtol=1e-15)
    assert kin.inverse(p)[0] == pytest.approx([pull(H)[1]] * 2, abs=1e-7)
    assert kin.tension(p)[0] == pytest.approx([math.hypot(H, 0.5)] * 2, rel=1e-9)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_light_cords_are_the_straight_ones(name):
    """mu -> 0: the catenary's limits without cancellation; mu 0: the models as they were."""
    s, h, k, m = SHAPES[name]
    straight = TwoCord(D, OX, OY, s, h, k, mass_below_pen_mm=m)
    light = TwoCord(D, OX, OY, s, h, k, mass_below_pen_mm=m, sag_per_mm=1e-13)
    xy = straight.to_machine(_points(50, 4))
    assert np.abs(light.inverse(xy) - straight.inverse(xy)).max() < 1e-8
    assert TwoCord(D, OX, OY, s, h, k, mass_below_pen_mm=m, sag_per_mm=0.0).sag is None


@settings(max_examples=40, deadline=None)
@given(model, gx, gy)
def test_forward_inverts_inverse(name, x, y):
    props.forward_inverts_inverse(MODELS[name], x, y)


@settings(max_examples=40, deadline=None)
@given(model, gx, gy, angle)
def test_slope_and_bend_are_the_derivatives_along_the_line(name, x, y, a):
    props.derivatives_along_a_line(MODELS[name], x, y, a)


@settings(max_examples=25, deadline=None)
@given(model, gx, gy, angle, st.floats(1.0, 150.0), st.floats(0.01, 0.99))
def test_extrema_and_crossing(name, x, y, a, d, frac):
    d = min(d, _inside(x, y, a))          # the piece ends on the page less its edge
    props.extrema_and_crossing(MODELS[name], x, y, a, d, frac, cord_tol=1e-6, piece_tol=1e-6)


NEAR_ANCHOR = TwoCord(354.693, 175.2091, 416.8164, stretch=0.00521, sag_per_mm=MU)
NEAR_ANCHOR_2 = TwoCord(388.6432, 196.6448, 414.0284, stretch=0.00301, sag_per_mm=MU)


@pytest.mark.parametrize("kin, path", [
    (MODELS["tilt+stretch"], [[-150.0, 250.0], [-100.0, 200.0], [-100.0, 120.0], [-140.0, 100.0]]),
    # a line ending 30 mm left of below the right anchor: a first guess from the straight cord
    # would land beyond its end, where the left cord goes slack
    (NEAR_ANCHOR, [[-150.0, 25.0], [150.0, 25.0]]),
    (NEAR_ANCHOR_2, [[-150.0, 25.0], [150.0, 25.0]]),
], ids=["tilt+stretch", "near an anchor", "near an anchor, one piece"])
def test_the_step_solver_on_pieces(kin, path):
    """Steps along several pieces at once (as the schedule gives them): each within 1e-6 mm."""
    verts = kin.to_machine(np.array(path))
    seg = np.diff(verts, axis=0)
    e = seg / np.hypot(*seg.T)[:, None]
    q = kin.inverse(verts)
    for m in (0, 1):
        n = np.floor(np.abs(np.diff(q[:, m])) / 0.05).astype(int)
        piece = np.repeat(np.arange(len(n)), n)
        j = np.arange(len(piece)) - np.repeat(np.cumsum(n) - n, n)
        sign = np.sign(np.diff(q[:, m]))[piece]
        target = q[piece, m] + sign * 0.05 * (j + 0.5)
        s = kin.crossing(verts[:-1], e, m, piece, target, sign > 0)
        got = kin.inverse(verts[:-1][piece] + e[piece] * s[:, None])[:, m]
        assert len(target) > 500 and np.abs(got - target).max() < 1e-6


def test_config_keys(config_path, capsys, tmp_path):
    import tomllib

    data = tomllib.loads(config_path.read_text())
    data["gondola"] = {"mass_g": 200.0}
    data["cords"] = {"mass_g_per_m": 18.0}
    kin = from_config(config.from_dict(data))
    assert kin.sag_per_mm == pytest.approx(MU) and kin.sag is not None
    data["cords"] = {"mass_g_per_m": 0.0}                       # no mass: no sag
    assert from_config(config.from_dict(data)).sag is None
    assert from_config(config.load(config_path)).sag is None    # the seed machine
    text = config_path.read_text()
    for extra, words in (("[cords]\nmass_g_per_m = 18.0\n", "needs [gondola] mass_g"),
                         ("[cords]\nmass_g_per_m = -1.0\n", "mass_g_per_m"),
                         ("[gondola]\nmass_g = 0.0\n", "mass_g must be above 0")):
        bad = tmp_path / "bad.toml"
        bad.write_text(text + extra)
        code, _, err = run(capsys, ["--config", bad, "info", tc_path()])
        assert code == 2 and words in err and len(err.strip().splitlines()) == 1


def _inside(x, y, a) -> float:
    """How far a line from G-code (x, y) at angle a runs inside the box of gx and gy."""
    out = []
    for v, c, lo, hi in ((x, math.cos(a), -170, 170), (y, math.sin(a), -240, 290)):
        if c > 1e-12:
            out.append((hi - v) / c)
        elif c < -1e-12:
            out.append((lo - v) / c)
    return max(min(out), 1.0)


def tc_path():
    from support import REPO

    return REPO / "tests/data/corners.ngc"


def test_the_calibration_machine_sags():
    m = fit.Machine(D, 480.0, 470.0, 25.0, 25.0, 0.0, 0.0, 0.0, 4096, None, MU)
    kin = m.kin()
    assert kin.sag is not None
    steps = np.array([[0.0, 0.0], [-30000.0, 40000.0]])       # the middle; the right edge
    straight = fit.Machine(D, 480.0, 470.0, 25.0, 25.0, 0.0, 0.0, 0.0, 4096)
    assert np.abs(m.pen(steps) - straight.pen(steps)).max() > 0.5
    assert np.allclose(kin.inverse(m.pen(steps)), m.cords(steps), atol=1e-9)


SAG_KEYS = ("[gondola]\ncord_spacing_mm = 40.0\npen_below_mm = 12.0\nmass_below_pen_mm = 30.0\n"
            "mass_g = 200.0\n\n[cords]\nstretch = 0.003\nmass_g_per_m = 18.0\n")
DRAWING = "G21 G90\nG0 X-60 Y-50\nM3\nG1 X-20 Y-50 F600\nG1 X-20 Y-10\nG1 X-60 Y-50\nM5\n"


def test_a_drawing_with_sagging_cords(config_path, tmp_path):
    """The dry-run trace of a tilting gondola on sagging, stretching cords, decoded through
    tracecheck's own catenary: within 0.016 mm of the path and every motor limit; read as
    straight cords it is off by far more."""
    from vplotter.cli import main

    gfile = tmp_path / "d.ngc"
    gfile.write_text(DRAWING)
    cfg_path = tmp_path / "sag.toml"
    cfg_path.write_text(config_path.read_text() + SAG_KEYS)
    trace = tmp_path / "t.csv"
    assert main(["--config", str(cfg_path), "calibrate", "--at", "0", "0"]) == 0
    assert main(["--config", str(cfg_path), "draw", str(gfile), "--dry-run", "--trace",
                 str(trace)]) == 0
    tr = tc.read_trace(trace)
    assert tc.verify(tr, gfile, tc.load_config(cfg_path), tol_mm=0.016) == []
    # the path's points where the cords put them, read as straight cords
    ref = np.vstack(tc.reference_path(gfile))
    left, right = tc.inverse_kinematics(tc.load_config(cfg_path), ref[:, 0], ref[:, 1])
    straight = tc.load_config(cfg_path)
    straight["cords"]["mass_g_per_m"] = 0.0
    x, y = tc.forward_kinematics(straight, left, right)
    far = np.hypot(x - ref[:, 0], y - ref[:, 1]).max()
    assert far > 0.1


def test_a_point_near_straight_below_an_anchor_is_refused(config_path, tmp_path, capsys):
    """Near straight below an anchor the other cord hangs slack in a deep bow (a plan there
    came out 0.4 m off, its cords no triangle): `info` and `draw` refuse that point in one
    line, exit 2; the same drawing away from the side plans."""
    cfg_path = tmp_path / "sag.toml"
    cfg_path.write_text(config_path.read_text() + "[gondola]\nmass_g = 150.0\n"
                        "cord_spacing_mm = 20.0\npen_below_mm = 12.0\n[cords]\n"
                        "mass_g_per_m = 18.0\n")
    for x, ok in ((-196.25, False), (-100.0, True)):
        gfile = tmp_path / "e.ngc"
        gfile.write_text(f"G0 X0 Y0\nG0 X{x} Y-249\nG0 X0 Y0\n")
        for cmd in ("info", "draw"):
            extra = ["--dry-run"] if cmd == "draw" else []
            code, _, err = run(capsys, ["--config", cfg_path, cmd, gfile, *extra])
            if ok:
                assert code == 0, err
            else:
                assert code == 2 and err.count("\n") == 1 and "Warning" not in err
                assert f"e.ngc:2:1: error: the pen cannot reach X{x:.3f} Y-249.000" in err
