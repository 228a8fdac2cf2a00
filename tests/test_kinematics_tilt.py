"""The tilting gondola ([gondola] mass_below_pen_mm, kinematics/tilt.py): the balance against
independent formulations (lowest centre of mass, torques from the force balance), inverse and
forward, exact slopes and bends, the step solver, the independent decoder, and a drawing on a
tilting gondola decoded by tracecheck. Unset, nothing changes (test_traces.py)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from support import kin_props as props
from vplotter import config
from vplotter.kinematics import from_config
from vplotter.kinematics.vplotter import TwoCord

D, OX, OY = 422.5, 211.25, 430.0
MODELS = {
    "tilt": TwoCord(D, OX, OY, 40.0, 12.0, mass_below_pen_mm=30.0),
    "tilt+stretch": TwoCord(D, OX, OY, 40.0, 12.0, 0.004, mass_below_pen_mm=30.0),
    "low mass": TwoCord(D, OX, OY, 40.0, 5.0, mass_below_pen_mm=120.0),
    "pen below": TwoCord(D, OX, OY, 40.0, 45.0, mass_below_pen_mm=-20.0),
}
gx = st.floats(-190, 190, allow_nan=False)
gy = st.floats(-240, 290, allow_nan=False)
angle = st.floats(0, 2 * math.pi, allow_nan=False)
model = st.sampled_from(sorted(MODELS))


def _body(kin, phi):
    """The turned gondola: from the pen to the cords' points and to the centre of mass."""
    c, s = math.cos(phi), math.sin(phi)
    rot = np.array([[c, -s], [s, c]])
    half, h = kin.spacing_mm / 2, kin.pen_below_mm
    return rot @ [-half, -h], rot @ [half, -h], rot @ [0.0, kin.mass_below_pen_mm]


def _lowest(kin, cords) -> np.ndarray:
    """Where the pen hangs on inextensible cords of these lengths: the turn that puts the
    centre of mass lowest (+y down), each turn's pen where the two circles meet (SciPy)."""
    from scipy.optimize import minimize_scalar

    def pen(phi):
        vl, vr, _ = _body(kin, phi)
        e_l, e_r = -vl, np.array([D, 0.0]) - vr
        dv = e_r - e_l
        d = np.hypot(*dv)
        a = (cords[0] ** 2 - cords[1] ** 2 + d * d) / (2 * d)
        h = math.sqrt(cords[0] ** 2 - a * a)
        return e_l + a * dv / d + h * np.array([-dv[1], dv[0]]) / d

    res = minimize_scalar(lambda phi: -(pen(phi) + _body(kin, phi)[2])[1], bounds=(-1.0, 1.0),
                          method="bounded", options={"xatol": 1e-12})
    return pen(res.x)


@pytest.mark.parametrize("name", ["tilt", "low mass", "pen below"])
def test_inverse_is_exact_against_the_lowest_centre_of_mass(name):
    """The pen the inverse plans for is where a gondola on those cords comes to rest: the
    balance of the torques is the lowest centre of mass (an independent formulation)."""
    kin = MODELS[name]
    rng = np.random.default_rng(3)
    g = np.column_stack((rng.uniform(-200, 200, 60), rng.uniform(-250, 300, 60)))
    g = np.vstack((g, [[-200, 300], [200, 300], [-200, -250], [200, -250]]))    # the corners
    m = kin.to_machine(g)
    q = kin.inverse(m)
    worst = max(np.hypot(*(_lowest(kin, c) - p)) for c, p in zip(q, m))
    assert worst < 1e-3


def _balance(kin, p, phi):
    """The cords' torque about the centre of mass (their tensions from the force balance),
    the tensions and the cords' lengths."""
    vl, vr, vg = _body(kin, phi)
    ul, ur = -(p + vl), np.array([D, 0.0]) - (p + vr)          # cords towards the anchors
    g = np.hypot(*ul), np.hypot(*ur)
    ul, ur = ul / g[0], ur / g[1]
    t = np.linalg.solve(np.column_stack((ul, ur)), [0.0, -1.0])  # they carry the weight
    torque = sum((v - vg)[0] * ti * u[1] - (v - vg)[1] * ti * u[0]
                 for v, ti, u in ((vl, t[0], ul), (vr, t[1], ur)))
    return torque, t, g


@pytest.mark.parametrize("name", sorted(MODELS))
def test_inverse_against_a_root_per_point(name):
    """The cords the inverse gives against SciPy's root of the torque, point by point."""
    from scipy.optimize import brentq

    kin = MODELS[name]
    rng = np.random.default_rng(8)
    m = kin.to_machine(np.column_stack((rng.uniform(-190, 190, 80), rng.uniform(-240, 290, 80))))
    q = kin.inverse(m)
    for p, cords in zip(m, q):
        phi = brentq(lambda f, p=p: _balance(kin, p, f)[0], -1.0, 1.0, xtol=1e-15, rtol=1e-15)
        _, t, g = _balance(kin, p, phi)
        assert cords == pytest.approx(np.array(g) / (1.0 + kin.stretch * t), abs=1e-9)


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_array_solve_agrees_with_the_one_point_solve(name):
    """Arrays take Halley steps from the table of phi, their cos and sin turned by series; a
    few points take bracketed Newton steps from zero in Python floats: the same balance."""
    g = MODELS[name].gondola
    rng = np.random.default_rng(5)
    x, y = rng.uniform(0.1 * D, 0.9 * D, 2000), rng.uniform(0.3 * D, 1.8 * D, 2000)
    phi, c, s = g.solve(x, y)[:3]
    one = np.array([g.state_one(a, b)[0] for a, b in zip(x[:300].tolist(), y[:300].tolist())])
    assert np.abs(phi[:300] - one).max() < 1e-12
    assert np.abs(c - np.cos(phi)).max() < 1e-15 and np.abs(s - np.sin(phi)).max() < 1e-15
    assert np.abs(phi).max() > 0.01                      # (it does turn)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1e-9, 1.19))
def test_cos_and_sin_of_many_angles_from_the_table(seed, span):
    """On many points solve takes cos and sin of the table's guess from the nearest multiple
    of 1/1024 rad turned by the rest: within an ulp or two of np.cos and np.sin, on the
    unit circle; on a few points (or past the bracket) np.cos and np.sin themselves."""
    from vplotter.kinematics import tilt

    phi = np.random.default_rng(seed).uniform(-span, span, tilt.ANGLE_ROWS)
    c, s = tilt._cos_sin(phi)
    assert np.abs(c - np.cos(phi)).max() <= 4.5e-16
    assert np.abs(s - np.sin(phi)).max() <= 4.5e-16
    assert np.abs(c * c + s * s - 1.0).max() <= 1e-15
    for few in (phi[:tilt.ANGLE_ROWS - 1], np.r_[phi, 1.3]):
        c, s = tilt._cos_sin(few)
        assert np.array_equal(c, np.cos(few)) and np.array_equal(s, np.sin(few))


@settings(max_examples=100, deadline=None)
@given(model, gx, gy)
def test_the_torques_about_the_centre_of_mass_cancel(name, x, y):
    kin = MODELS[name]
    p = kin.to_machine(np.array([[x, y]]))[0]
    phi = float(kin.gondola.solve(p[:1], p[1:])[0][0])
    torque, t, _ = _balance(kin, p, phi)
    assert (t > 0).all()
    assert abs(torque) < 1e-9 * (abs(kin.mass_below_pen_mm) + kin.spacing_mm)
    assert kin.tension(p[None])[0] == pytest.approx(t, rel=1e-9)


@settings(max_examples=150, deadline=None)
@given(model, gx, gy)
def test_forward_inverts_inverse(name, x, y):
    props.forward_inverts_inverse(MODELS[name], x, y)


def test_level_on_the_centre_line_and_when_unset(config_path):
    kin = MODELS["tilt"]
    level = TwoCord(D, OX, OY, 40.0, 12.0)
    p = np.array([[D / 2, 300.0], [D / 2, 700.0]])
    assert np.abs(kin.gondola.solve(p[:, 0], p[:, 1])[0]).max() < 1e-12
    assert np.allclose(kin.inverse(p), level.inverse(p), atol=1e-9)
    # off the centre line it turns, and the cords differ from the level gondola's by mm
    p = np.array([[60.0, 200.0]])
    assert abs(kin.gondola.solve(p[:, 0], p[:, 1])[0][0]) > 0.1
    assert np.abs(kin.inverse(p) - level.inverse(p)).max() > 1.0
    # the key unset: the plain model (no balance solved at all)
    cfg = config.load(config_path)
    assert cfg.gondola.mass_below_pen_mm is None and from_config(cfg).gondola is None


@settings(max_examples=150, deadline=None)
@given(model, gx, gy, angle)
def test_slope_and_bend_are_the_derivatives_along_the_line(name, x, y, a):
    props.derivatives_along_a_line(MODELS[name], x, y, a)


@settings(max_examples=100, deadline=None)
@given(model, gx, gy, angle, st.floats(1.0, 200.0), st.floats(0.01, 0.99))
def test_extrema_and_crossing(name, x, y, a, d, frac):
    props.extrema_and_crossing(MODELS[name], x, y, a, d, frac, cord_tol=1e-5, piece_tol=1e-6)


@settings(max_examples=10, deadline=None)
@given(model, st.integers(0, 2**32 - 1))
def test_the_turns_one_by_one_and_many_at_once(name, seed):
    """The search for where the cords turn takes a few rows one by one in Python floats and
    many at once in arrays: both find the same points (pieces across each cord)."""
    from vplotter.kinematics import tilt

    kin = MODELS[name]
    rng = np.random.default_rng(seed)
    n = 3 * tilt.FEW
    mid = kin.to_machine(np.c_[rng.uniform(-150, 150, n), rng.uniform(-150, 250, n)])
    m = rng.integers(0, 2, n)                           # the cord each piece crosses
    arm = np.c_[np.where(m == 0, -0.5, 0.5) * kin.spacing_mm, np.full(n, -kin.pen_below_mm)]
    r = mid + arm - kin.anchors[m]                      # (about: the gondola turns a little)
    e = np.c_[-r[:, 1], r[:, 0]] / np.hypot(r[:, 0], r[:, 1])[:, None]
    e = e @ np.array([[1.0, 0.05], [-0.05, 1.0]]).T * rng.choice([-1.0, 1.0], (n, 1))
    e /= np.hypot(e[:, 0], e[:, 1])[:, None]
    d = rng.uniform(60.0, 120.0, n)           # (the turn is off the foot: the tilt)
    p0 = mid - e * (d * rng.uniform(0.4, 0.6, n))[:, None]
    many = kin.extrema(p0, e, d)
    one = np.array([kin.extrema(p0[i:i + 1], e[i:i + 1], d[i:i + 1])[0] for i in range(n)])
    assert np.count_nonzero(np.isfinite(many)) > tilt.FEW
    assert np.array_equal(np.isnan(many), np.isnan(one))
    assert np.nanmax(np.abs(many - one)) < 1e-9


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_step_solver_on_a_polyline(name):
    """Steps all along a long polyline of pieces that follow one another (as the schedule
    gives them): every step's cord within 1e-5 mm of its target (a step is 6e-3 mm)."""
    rng = np.random.default_rng(11)
    g = np.cumsum(rng.normal(0, 40, (40, 2)), axis=0)
    g = np.clip(g - g.mean(axis=0), [-190, -240], [190, 290])
    count, error = _steps_on(MODELS[name], g)
    assert count > 10_000 and error < 1e-5


def test_the_step_solver_on_a_large_wall():
    """Long pieces on a 2 m wall, where the tilted cord bends the other way than a level
    one's in places (the step solver's model is mirrored there), laid out with the cords'
    derivatives the planner asked for at the pieces' ends (as it does for a window): every
    step's cord within 1e-5 mm of its target."""
    kin = TwoCord(2000.0, 1000.0, 600.0, 40.0, 15.0, mass_below_pen_mm=30.0)
    rng = np.random.default_rng(5)
    g = np.cumsum(rng.normal(0, 200, (40, 2)), axis=0)
    g = np.clip(g - g.mean(axis=0), [-800, -500], [800, 500])[:8]
    count, error = _steps_on(kin, g, planner=True)
    assert count > 100_000 and error < 1e-5


def _steps_on(kin, g, planner=False) -> tuple:
    """(steps, the largest distance of a step's cord from its target) of the steps of 6e-3 mm
    along the polyline g (G-code mm), cut where a motor turns round (as the planner does),
    their spacing told to the solver as the schedule tells it."""
    g = g[np.r_[True, (np.diff(g, axis=0) != 0).any(axis=1)]]
    verts = kin.to_machine(g)
    seg = np.diff(verts, axis=0)
    d = np.hypot(*seg.T)
    e = seg / d[:, None]
    ext = kin.extrema(verts[:-1], e, d)
    pts = [verts[0]]
    for i in range(len(d)):
        for s in sorted(v for v in ext[i] if not math.isnan(v)):
            pts.append(verts[i] + e[i] * s)
        pts.append(verts[i + 1])
    verts = np.array(pts)
    seg = np.diff(verts, axis=0)
    d = np.hypot(*seg.T)
    keep = d > 1e-6
    verts = np.vstack((verts[:1], verts[1:][keep]))
    seg = np.diff(verts, axis=0)
    e = seg / np.hypot(*seg.T)[:, None]
    q = kin.inverse(verts)
    if planner:
        kin.slope_bend(verts[:-1], e)
        kin.slope_bend(verts[1:], e)
    count, error = 0, 0.0
    for m in (0, 1):
        n = np.floor(np.abs(np.diff(q[:, m])) / 0.006).astype(int)
        piece = np.repeat(np.arange(len(n)), n)
        j = np.arange(len(piece)) - np.repeat(np.cumsum(n) - n, n)
        sign = np.sign(np.diff(q[:, m]))[piece]
        target = q[piece, m] + sign * 0.006 * (j + 0.5)
        s = kin.crossing(verts[:-1], e, m, piece, target, sign > 0, 0.006)
        got = kin.inverse(verts[:-1][piece] + e[piece] * s[:, None])[:, m]
        count, error = count + len(target), max(error, float(np.abs(got - target).max()))
    return count, error


@pytest.mark.parametrize("stretch", [0.0, 0.003])
def test_tracecheck_tilt_agrees_with_the_package(stretch):
    from support import tracecheck as tc

    cfg = tc.load_config({"gondola": {"cord_spacing_mm": 40.0, "pen_below_mm": 12.0,
                                      "mass_below_pen_mm": 30.0}, "cords": {"stretch": stretch}})
    kin = TwoCord(D, OX, OY, 40.0, 12.0, stretch, mass_below_pen_mm=30.0)
    rng = np.random.default_rng(5)
    g = np.column_stack((rng.uniform(-200, 200, 300), rng.uniform(-250, 300, 300)))
    left, right = tc.inverse_kinematics(cfg, g[:, 0], g[:, 1])
    assert np.abs(np.column_stack((left, right)) - kin.inverse(kin.to_machine(g))).max() < 1e-6
    x, y = tc.forward_kinematics(cfg, left, right)
    assert np.abs(np.column_stack((x, y)) - g).max() < 1e-6


def test_config_key(config_path):
    import tomllib

    data = tomllib.loads(config_path.read_text())
    data["gondola"] = {"cord_spacing_mm": 40.0, "pen_below_mm": 12.0, "mass_below_pen_mm": 30.0}
    kin = from_config(config.from_dict(data))
    assert kin.mass_below_pen_mm == 30.0 and kin.gondola is not None
    data["gondola"]["mass_below_pen_mm"] = -12.0        # at the cords' line: it would tip over
    with pytest.raises(config.ConfigError, match="mass_below_pen_mm") as err:
        config.from_dict(data)
    assert "tip over" in str(err.value) and "\n" not in str(err.value)


TILT_KEYS = "[gondola]\ncord_spacing_mm = 40.0\npen_below_mm = 12.0\nmass_below_pen_mm = 30.0\n"


def test_a_checked_drawing_plays_as_it_streams(config_path, monkeypatch, tmp_path):
    """`draw` checks and plans the whole file first and plays the kept plan after: each
    block finds its window's layout by the array its vertices view, however long after it
    was planned (no block laid out on its own, which cost the 16k-line file 80 % more CPU
    than level), and the rows are exactly those of planning as it plays."""
    from vplotter import pipeline
    from vplotter.inputs import gcode
    from vplotter.kinematics import tilt_kept, tilt_steps

    import tomllib

    cfg = config.from_dict({**tomllib.loads(config_path.read_text()),
                            "gondola": {"cord_spacing_mm": 40.0, "pen_below_mm": 12.0,
                                        "mass_below_pen_mm": 30.0}})
    # many short moves: the planner's windows, more than the machine keeps besides
    t = np.linspace(0.0, 12 * np.pi, 12_000)
    xy = np.column_stack((t * np.cos(t), t * np.sin(t))) * 1.5
    gfile = str(tmp_path / "spiral.ngc")
    with open(gfile, "w") as f:
        f.write("G21 G90\nG0 Z5\nG0 X0 Y0\nG1 Z-1 F600\n")
        f.writelines(f"G1 X{x:.4f} Y{y:.4f}\n" for x, y in xy)
        f.write("G0 Z5\n")
    kin = from_config(cfg)
    q0 = kin.inverse(kin.to_machine(np.zeros((1, 2))))[0]

    def rows(stream):
        out = [r for r in stream if hasattr(r, "t_us")]
        return np.concatenate([r.t_us for r in out]), np.concatenate([r.coils for r in out])

    streamed = rows(pipeline.stream(cfg, gcode.read(gfile, warn=print), (0, 0), q0, gfile))
    summary = pipeline.validate(cfg, gcode.read(gfile, warn=print), (0, 0), q0, gfile)
    assert summary.plan is not None
    monkeypatch.setattr(tilt_steps, "_block_layout", lambda *a: pytest.fail("laid alone"))
    # the windows the planner is done with keep of their balance what their layouts take
    kept = [w for entries in tilt_kept._BY_VERTS.values() for _, _, w in entries]
    assert sum(w.state[1] is None and w.state[0] is not None for w in kept) >= 3
    replayed = rows(pipeline.replay(cfg, summary.plan, (0, 0), q0))
    assert sum(1 for _ in tilt_kept._BY_VERTS) > tilt_kept.WINDOWS     # (kept by the plan)
    assert len(streamed[0]) > 50_000
    for a, b in zip(streamed, replayed):
        assert np.array_equal(a, b)


def test_the_windows_go_with_the_drawing(config_path, tmp_path):
    """The machine keeps each planned window (its balance, for the steps) only while the
    planner's vertices' array lives: once a drawing is played, or its checked plan dropped,
    none of its windows is left (a plot of a 97,000-line file grew by 100 MB when every
    window was kept for the process's life)."""
    import gc

    from vplotter import pipeline
    from vplotter.inputs import gcode
    from vplotter.kinematics import tilt_kept

    import tomllib

    cfg = config.from_dict({**tomllib.loads(config_path.read_text()),
                            "gondola": {"cord_spacing_mm": 40.0, "pen_below_mm": 12.0,
                                        "mass_below_pen_mm": 33.0}})
    t = np.linspace(0.0, 8 * np.pi, 3_000)
    gfile = str(tmp_path / "spiral.ngc")
    with open(gfile, "w") as f:
        f.write("G21 G90\nG0 Z5\nG0 X0 Y0\nG1 Z-1 F600\n")
        f.writelines(f"G1 X{a * math.cos(a):.4f} Y{a * math.sin(a):.4f}\n" for a in t * 1.5)
        f.write("G0 Z5\n")
    kin = from_config(cfg)
    q0 = kin.inverse(kin.to_machine(np.zeros((1, 2))))[0]
    key = tilt_kept._machine(kin)

    def kept() -> int:
        gc.collect()
        return sum(m == key for entries in list(tilt_kept._BY_VERTS.values())
                   for _, m, _ in entries)

    before, most = kept(), 0
    for _ in pipeline.stream(cfg, gcode.read(gfile, warn=print), (0, 0), q0, gfile):
        most = max(most, sum(m == key for entries in tilt_kept._BY_VERTS.values()
                             for _, m, _ in entries))
    assert most >= 1 and kept() == before
    summary = pipeline.validate(cfg, gcode.read(gfile, warn=print), (0, 0), q0, gfile)
    assert summary.plan is not None and kept() > before          # (kept by the plan)
    del summary
    assert kept() == before


def test_a_slim_window_is_solved_again_off_its_directions():
    """A window the planner is done with keeps phi and the cords; a layout along other
    directions than its kept derivatives' takes the whole balance, solved again."""
    import weakref

    from vplotter.kinematics import tilt_kept

    kin = TwoCord(D, OX, OY, 40.0, 12.0, mass_below_pen_mm=30.0)
    verts = kin.to_machine(np.array([[0.0, 0.0], [10.0, 5.0], [20.0, -5.0], [30.0, 0.0]]))
    full = kin.gondola.solve(verts[:, 0], verts[:, 1])
    e = np.diff(verts, axis=0)
    e /= np.hypot(e[:, 0], e[:, 1])[:, None]
    w = tilt_kept.Window(weakref.ref(verts), full, jets0=(e,), jets1=(e,))
    tilt_kept._slim(w)
    assert w.state[1] is None and w.state[0] is full[0] and w.state[6] is full[6]
    assert tilt_kept.layout_state(kin, w, e) is w.state
    again = tilt_kept.layout_state(kin, w, -e)
    for a, b in zip(again[:6], full[:6]):
        assert np.array_equal(a, b)


def test_the_tables_of_phi_kept_are_few():
    """Each gondola's first guesses come from a table of phi made once; a fit tries many
    gondolas, so only the last TABLES are kept, and a table made again answers the same."""
    from vplotter.kinematics import tilt

    x = np.linspace(120.0, 300.0, tilt.FEW + 4)            # (more than a few: the table's way)
    y = np.linspace(250.0, 550.0, tilt.FEW + 4)
    first = tilt.Gondola(D, 40.0, 12.0, 30.0).solve(x, y)[0]
    for c in np.linspace(31.0, 90.0, tilt.TABLES + 8):
        tilt.Gondola(D, 40.0, 12.0, float(c)).solve(x, y)
        assert len(tilt._TABLES) <= tilt.TABLES
    again = tilt.Gondola(D, 40.0, 12.0, 30.0)
    assert (again.d_mm, again.v, again.a) not in tilt._TABLES        # (let go: made again)
    assert np.array_equal(again.solve(x, y)[0], first)


def test_points_put_in_keep_the_balance_of_the_old_vertices(monkeypatch):
    """The planner cuts a window's pieces where the cords turn and finer (refine.put_in) and
    then asks for the cords at the new vertices: the machine takes the balance at the old
    vertices row by row and solves only the points put in, and it is the balance a solve of
    every vertex finds."""
    from vplotter.kinematics import tilt, tilt_along
    from vplotter.motion.refine import put_in, scaled

    kin = TwoCord(D, OX, OY, 40.0, 12.0, mass_below_pen_mm=30.0)
    rng = np.random.default_rng(3)
    verts = np.cumsum(rng.normal(0.0, 4.0, (400, 2)), axis=0) + [D / 2, OY]
    diff = np.diff(verts, axis=0)
    d = np.hypot(diff[:, 0], diff[:, 1])
    e = scaled(diff, d, divide=True)
    kin.extrema(verts[:-1], e, d)                   # (the planner's first ask: a solve)
    piece = np.repeat(np.arange(len(d)), np.where(np.arange(len(d)) % 7 == 0, 3, 1))
    first = np.r_[True, piece[1:] != piece[:-1]]
    last = np.r_[piece[1:] != piece[:-1], True]
    s = np.where(last, d[piece], d[piece] * np.where(first, 0.3, 0.6))
    solved = []
    real = tilt.Gondola.solve
    monkeypatch.setattr(tilt.Gondola, "solve",
                        lambda self, x, y, phi=None: solved.append(np.size(x)) or
                        real(self, x, y, phi))
    new = put_in(kin, verts, e, piece, s, last)
    cords = kin.inverse(new)
    assert len(new) == len(verts) + np.count_nonzero(~last)
    assert sum(solved) <= np.count_nonzero(~last)           # (the points put in)
    # refine asks for the slopes at both ends of the new pieces: those the search for the
    # turning points worked out, carried on (the points put in worked out), not solved again
    diff = np.diff(new, axis=0)
    e_new = scaled(diff, np.hypot(diff[:, 0], diff[:, 1]), divide=True)
    ends = kin.slope(new[:-1], e_new), kin.slope(new[1:], e_new)
    assert sum(solved) <= np.count_nonzero(~last)
    monkeypatch.setattr(tilt.Gondola, "solve", real)
    fresh = TwoCord(D, OX, OY, 40.0, 12.0, mass_below_pen_mm=30.0)

    def exact(xy):          # (not fresh.inverse: the machine's windows are kept by machine)
        return tilt_along.cords_value(fresh.gondola.solve(xy[:, 0], xy[:, 1])[6], 0.0)

    assert np.abs(cords - exact(new)).max() < 1e-9
    for got, at in zip(ends, (new[:-1], new[1:])):
        st = fresh.gondola.solve(at[:, 0], at[:, 1])
        assert np.abs(got - fresh.gondola.slopes(at, e_new, st)).max() < 1e-12
    # points put in twice before the balance is asked for (the turns, then refine's cuts)
    kin2 = TwoCord(D, OX, OY, 40.0, 12.0, mass_below_pen_mm=30.0)
    kin2.extrema(verts[:-1], e, d)
    once = put_in(kin2, verts, e, piece, s, last)
    piece2 = np.repeat(np.arange(len(once) - 1), np.where(np.arange(len(once) - 1) % 5 == 0, 2, 1))
    last2 = np.r_[piece2[1:] != piece2[:-1], True]
    d2 = np.hypot(*np.diff(once, axis=0).T)
    twice = put_in(kin2, once, scaled(np.diff(once, axis=0), d2, divide=True), piece2,
                   np.where(last2, d2[piece2], 0.5 * d2[piece2]), last2)
    assert np.abs(kin2.inverse(twice) - exact(twice)).max() < 1e-9
    # the whole balance (the planner's slopes and bends take phi's derivatives from it)
    from vplotter.kinematics import tilt_kept
    kept = tilt_kept.balance(kin2, twice)
    st = fresh.gondola.solve(twice[:, 0], twice[:, 1])
    for got, want in zip((*kept[:6], *kept[6]), (*st[:6], *st[6])):
        assert np.allclose(got, want, rtol=1e-9, atol=1e-9)


@settings(max_examples=10, deadline=None)
@given(model, st.integers(0, 2**32 - 1))
def test_the_bend_inside_a_piece(name, seed):
    """The bend at a piece's middle (bend_inside): from the slopes and bends at its ends for
    pieces up to a tenth of the shorter cord, within 1e-4 of the largest bend at its ends and
    middle; longer ones solved there. 4,000 pieces on the page, up to a fifth of the cord."""
    kin = MODELS[name]
    rng = np.random.default_rng(seed)
    n = 4000
    p0 = kin.to_machine(np.c_[rng.uniform(-190, 190, n), rng.uniform(-240, 290, n)])
    a = rng.uniform(0, 2 * math.pi, n)
    e = np.c_[np.cos(a), np.sin(a)]
    near = np.min([np.hypot(*(p0 - kin.anchors[m]).T) for m in (0, 1)], axis=0)
    d = rng.uniform(0.01, 0.2, n) * near
    mid, p1 = p0 + e * d[:, None] / 2, p0 + e * d[:, None]
    keep = np.min([np.hypot(*(mid - kin.anchors[m]).T) for m in (0, 1)], axis=0) > 60
    p0, p1, mid, e, d = p0[keep], p1[keep], mid[keep], e[keep], d[keep]
    (k0, b0), (k1, b1) = kin.slope_bend(p0, e), kin.slope_bend(p1, e)
    got = kin.bend_inside(mid, e, d, k0.T, k1.T, b0.T, b1.T)
    exact = kin.bend(mid, e).T
    largest = np.maximum(np.maximum(np.abs(b0.T), np.abs(b1.T)), np.abs(exact))
    assert np.all(np.abs(got - exact) <= 1e-4 * largest)


@pytest.mark.parametrize("stretch", ["", "[cords]\nstretch = 0.004\n"], ids=["tilt", "stretch"])
def test_a_drawing_on_a_tilting_gondola(stretch, config_path, tmp_path):
    """The dry-run trace decoded through the tilting gondola by tracecheck (which knows
    nothing of vplotter) stays within 0.02 mm of the path, within every motor limit; read
    as a level gondola it is off by far more."""
    from support import REPO
    from support import tracecheck as tc
    from vplotter.cli import main

    gfile = REPO / "tests/data/corners.ngc"
    cfg_path = tmp_path / "tilt.toml"
    cfg_path.write_text(config_path.read_text() + TILT_KEYS + stretch)
    trace = tmp_path / "t.csv"
    assert main(["--config", str(cfg_path), "calibrate", "--at", "0", "0"]) == 0
    assert main(["--config", str(cfg_path), "draw", str(gfile), "--dry-run", "--trace",
                 str(trace)]) == 0
    tr = tc.read_trace(trace)
    assert tc.verify(tr, gfile, tc.load_config(cfg_path), tol_mm=0.02) == []
    level = tc.load_config(cfg_path)
    del level["gondola"]["mass_below_pen_mm"]
    dec = tc.decode(tr, level)
    assert tc.distances_to_polylines(dec.down_points[::20], tc.reference_path(gfile)).max() > 0.5


@settings(max_examples=60, deadline=None)
@given(model, st.lists(st.tuples(gx, gy), min_size=4, max_size=12, unique=True))
def test_both_ends_of_each_piece_at_once(name, pts):
    """`ends` (each vertex's share worked out once for its two pieces: phi's gradient and
    Hessian) gives the slopes and bends `slope_bend` gives at the pieces' starts and ends;
    with stretch it leaves them to slope_bend."""
    kin = MODELS[name]
    verts = kin.to_machine(np.array(pts))
    diff = np.diff(verts, axis=0)
    d = np.hypot(diff[:, 0], diff[:, 1])
    keep = np.r_[True, d > 1e-3]
    verts = verts[keep]
    diff = np.diff(verts, axis=0)
    e = diff / np.hypot(diff[:, 0], diff[:, 1])[:, None]
    got = kin.ends(verts, e)
    if kin.stretch:
        assert got is None                  # (with stretch: slope_bend at each end)
        return
    k0, b0, k1, b1 = got
    for at, k, b in ((verts[:-1], k0, b0), (verts[1:], k1, b1)):
        ks, bs = kin.slope_bend(at, e)
        assert np.abs(k - ks.T).max() < 1e-12
        assert np.abs(b - bs.T).max() < 1e-12
