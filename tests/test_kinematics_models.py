"""Gondola and cord models in kinematics/vplotter.py: exact inverse/forward, true derivatives,
the step solver and the turning points under every model; the plain machine is unchanged."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support import kin_props as props
from vplotter import config
from vplotter.kinematics import from_config
from vplotter.kinematics.vplotter import TwoCord

PLAIN = TwoCord(422.5, 211.25, 430.0)
MODELS = {
    "spacing": TwoCord(422.5, 211.25, 430.0, cord_spacing_mm=40.0, pen_below_mm=15.0),
    "stretch": TwoCord(422.5, 211.25, 430.0, stretch=0.004),
    "both": TwoCord(422.5, 211.25, 430.0, cord_spacing_mm=40.0, pen_below_mm=15.0, stretch=0.004),
}
gx = st.floats(-170, 170, allow_nan=False)
gy = st.floats(-240, 290, allow_nan=False)
angle = st.floats(0, 2 * math.pi, allow_nan=False)
model = st.sampled_from(sorted(MODELS))


def test_defaults_are_the_plain_machine(config_path):
    kin = from_config(config.load(config_path))
    xy = PLAIN.to_machine(np.array([[0.0, 0.0], [-150.0, 250.0], [170.0, -200.0]]))
    assert np.array_equal(kin.inverse(xy), PLAIN.inverse(xy))
    assert np.array_equal(kin.inverse(xy)[:, 0], np.hypot(xy[:, 0], xy[:, 1]))


def test_gondola_is_a_shifted_anchor():
    kin = MODELS["spacing"]
    p = np.array([[200.0, 400.0]])
    left, right = kin.inverse(p)[0]
    # the cords end 20 mm left/right of the pen and 15 mm above it
    assert left == pytest.approx(math.hypot(200.0 - 20.0, 400.0 - 15.0), abs=1e-12)
    assert right == pytest.approx(math.hypot(422.5 - 220.0, 400.0 - 15.0), abs=1e-12)


def test_stretch_follows_the_static_balance():
    kin = MODELS["stretch"]
    # on the middle line both cords carry W / (2 sin angle) = W g / (2 y)
    p = np.array([[211.25, 430.0]])
    g = math.hypot(211.25, 430.0)
    t = g / (2 * 430.0)
    assert kin.tension(p)[0] == pytest.approx([t, t], rel=1e-12)
    assert kin.inverse(p)[0] == pytest.approx([g / (1 + 0.004 * t)] * 2, rel=1e-12)
    # forces: the two cords' pulls add up to the weight, straight up
    p = np.array([[100.0, 300.0]])
    rel = p[:, None, :] - kin.anchors[None]
    unit = -rel[0] / np.linalg.norm(rel[0], axis=1)[:, None]
    total = (kin.tension(p)[0][:, None] * unit).sum(axis=0)
    assert total == pytest.approx([0.0, -1.0], abs=1e-12)


@settings(max_examples=150, deadline=None)
@given(model, gx, gy)
def test_forward_inverts_inverse(name, x, y):
    props.forward_inverts_inverse(MODELS[name], x, y)


@settings(max_examples=150, deadline=None)
@given(model, gx, gy, angle)
def test_slope_and_bend_are_the_derivatives_along_the_line(name, x, y, a):
    props.derivatives_along_a_line(MODELS[name], x, y, a)


@settings(max_examples=150, deadline=None)
@given(model, gx, gy, angle, st.floats(1.0, 200.0), st.floats(0.01, 0.99))
def test_crossing_and_extrema(name, x, y, a, d, frac):
    props.extrema_and_crossing(MODELS[name], x, y, a, d, frac)


def test_crossing_many_rows_at_once():
    kin = MODELS["both"]
    rng = np.random.default_rng(7)
    n = 2000
    p0 = kin.to_machine(np.column_stack((rng.uniform(-150, 150, n), rng.uniform(-200, 250, n))))
    e = rng.normal(size=(n, 2))
    e /= np.linalg.norm(e, axis=1)[:, None]
    d = np.full(n, 5.0)
    ok = np.isnan(kin.extrema(p0, e, d)).all(axis=1)
    p0, e = p0[ok], e[ok]
    for motor in (0, 1):
        piece = np.repeat(np.arange(len(p0)), 3)          # three steps on every piece
        q0 = kin.inverse(p0)[piece, motor]
        q1 = kin.inverse(p0 + 5.0 * e)[piece, motor]
        target = q0 + rng.uniform(0, 1, len(piece)) * (q1 - q0)
        s = kin.crossing(p0, e, motor, piece, target, q1 > q0)
        got = kin.inverse(p0[piece] + e[piece] * s[:, None])[:, motor]
        assert np.abs(got - target).max() < 1e-9


def test_config_keys_and_per_motor_spools(config_path):
    import tomllib

    data = tomllib.loads(config_path.read_text())
    data["motors"]["left_spool_circumference_mm"] = 25.5
    data["gondola"] = {"cord_spacing_mm": 30.0, "pen_below_mm": 12.0}
    data["cords"] = {"stretch": 0.003}
    cfg = config.from_dict(data)
    assert cfg.motors.steps_per_unit == (4096 / 25.5, 4096 / 25.0)
    kin = from_config(cfg)
    assert (kin.spacing_mm, kin.pen_below_mm, kin.stretch) == (30.0, 12.0, 0.003)
    plain = config.load(config_path)
    assert plain.motors.steps_per_unit == (4096 / 25.0, 4096 / 25.0)
    assert (plain.gondola.cord_spacing_mm, plain.gondola.pen_below_mm, plain.cords.stretch) == (0, 0, 0)
    for section, key, value, words in (("cords", "stretch", -0.1, "between 0 and 0.5"),
                                       ("gondola", "cord_spacing_mm", 500.0, "below"),
                                       ("motors", "right_spool_circumference_mm", 0, "above 0")):
        bad = tomllib.loads(config_path.read_text())
        bad.setdefault(section, {})[key] = value
        with pytest.raises(config.ConfigError, match=key) as err:
            config.from_dict(bad)
        assert words in str(err.value)


# ---------------------------------------------------------------- traces under every model
MODEL_KEYS = {
    "spacing": "[gondola]\ncord_spacing_mm = 40.0\npen_below_mm = 15.0\n",
    "stretch": "[cords]\nstretch = 0.004\n",
    "spools": "",
    "all": "[gondola]\ncord_spacing_mm = 40.0\npen_below_mm = 15.0\n[cords]\nstretch = 0.004\n",
}


def model_config(tmp_path, config_path, name: str):
    text = config_path.read_text(encoding="utf-8")
    if name in ("spools", "all"):
        text = text.replace("right_reverse = false", "right_reverse = false\n"
                            "left_spool_circumference_mm = 25.3\nright_spool_circumference_mm = 24.7")
    path = tmp_path / f"{name}.toml"
    path.write_text(text + MODEL_KEYS[name], encoding="utf-8")
    return path


CASES = [("spacing", "corners.ngc"), ("stretch", "corners.ngc"), ("spools", "corners.ngc"),
         ("all", "car.ngc")]


@pytest.mark.parametrize("name,gname", CASES, ids=[f"{n}-{g}" for n, g in CASES])
def test_trace_under_the_models_draws_the_path(name, gname, config_path, tmp_path, capsys):
    """The dry-run trace decoded through the models by tracecheck (which knows nothing of
    vplotter) stays within 0.02 mm of the path both ways, within every motor limit."""
    from support import tracecheck as tc
    from support import REPO
    from vplotter.cli import main

    gfile = REPO / ("gcode_samples" if gname == "car.ngc" else "tests/data") / gname
    cfg_path = model_config(tmp_path, config_path, name)
    trace = tmp_path / "t.csv"
    assert main(["--config", str(cfg_path), "calibrate", "--at", "0", "0"]) == 0
    assert main(["--config", str(cfg_path), "draw", str(gfile), "--dry-run", "--trace", str(trace)]) == 0
    cfg = tc.load_config(cfg_path)
    tr = tc.read_trace(trace)
    assert tc.verify(tr, gfile, cfg, tol_mm=0.02) == []
    # the same trace read as the plain machine is off by far more: the check can fail. Every
    # 20th pen-down point is enough to show it (mm off): a subset's largest distance from the
    # path is a lower bound of accuracy()'s, so this passes only where accuracy() > 0.1 would
    plain = tc.decode(tr, tc.load_config(config_path))
    assert tc.distances_to_polylines(plain.down_points[::20], tc.reference_path(gfile)).max() > 0.1


def test_tracecheck_models_agree_with_the_package():
    from support import tracecheck as tc

    cfg = tc.load_config({"gondola": {"cord_spacing_mm": 40.0, "pen_below_mm": 15.0},
                          "cords": {"stretch": 0.004}})
    kin = MODELS["both"]
    g = np.array([[0.0, 0.0], [-150.0, 250.0], [170.0, -200.0]])
    left, right = tc.inverse_kinematics(cfg, g[:, 0], g[:, 1])
    assert np.allclose(np.column_stack((left, right)), kin.inverse(kin.to_machine(g)), atol=1e-9)
    x, y = tc.forward_kinematics(cfg, left, right)
    assert np.allclose(np.column_stack((x, y)), g, atol=1e-8)
