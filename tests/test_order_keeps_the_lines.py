"""Ordering never moves a line (issue 21): whatever --order says, the pen draws the file's own
segments, and a pen-down join bridges only ends within the flattening tolerance.

Checked on the records prepare() gives the pipeline (random strokes with nearly touching ends
and closed rings: the drawn segments, as unordered pairs of points, are the input's plus joins
no longer than the join limit), and end to end on an SVG of smooth cubics under nested skewed
matrices (tests/support/bezier_svg.py), against its true curves computed there: the records and the
decoded dry-run trace of --order best lie within the tolerance of the true geometry both ways.
"""

from __future__ import annotations

import math
import types

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from support import bezier_svg
from support import tracecheck as tc
from support import REPO
from vplotter import config
from vplotter.cli import main
from vplotter.drawing import order
from vplotter.inputs.gcode import Move, Pen
from vplotter.inputs.strokes import Stroke
from vplotter.file_options import join_limit
from vplotter.prepare import Prepared, prepare

TOL = 0.0075            # the flattening tolerance of config.toml (0.75 x tolerance_mm 0.01)


def pen_down_segments(records) -> tuple[list[tuple], list[np.ndarray]]:
    """The pen-down moves of a record stream as (x0, y0, x1, y1), and the pen-down runs as
    polylines (a pen down and up at one point is a one-point run)."""
    segs, runs, down, cur = [], [], False, None
    for r in records:
        if isinstance(r, Pen):
            if r.down and not down:
                cur = None
            if down and not r.down:
                runs.append(np.array(cur if cur else [at]))
            down = r.down
        elif isinstance(r, Move):
            at = (r.x1, r.y1)
            if down:
                segs.append((r.x0, r.y0, r.x1, r.y1))
                cur = (cur or [(r.x0, r.y0)]) + [(r.x1, r.y1)]
    return segs, runs


def unordered(a, b) -> tuple:
    return tuple(sorted((tuple(a), tuple(b))))


def input_segments(ss: list[Stroke]) -> set:
    return {unordered(a, b) for s in ss for a, b in zip(s.pts.tolist(), s.pts[1:].tolist())
            if a != b}


def records_of(ss: list[Stroke], join_mm: float) -> list:
    prep = Prepared("x.svg", "svg", False, join_mm=join_mm, tol_mm=TOL)
    prep._strokes = ss
    return list(prep.records())


# ------------------------------------------------------------------ random strokes
coord = st.floats(-50, 50, allow_nan=False).map(lambda v: round(v, 3))
gap = st.sampled_from([0.0, 1e-9, 0.001, 0.005, 0.0075, 0.0076, 0.01, 0.03, 0.05, 0.09])


@st.composite
def near_strokes(draw, max_size=14):
    """Open strokes, closed rings and dots; many strokes start or end next to (0-0.09 mm from)
    an end or a vertex of a stroke drawn before them, on a random side."""
    out: list[Stroke] = []
    for i in range(draw(st.integers(1, max_size))):
        kind = draw(st.sampled_from(["open", "open", "closed", "dot"]))
        pts = [(draw(coord), draw(coord)) for _ in range(1 if kind == "dot" else
                                                         draw(st.integers(2, 5)))]
        if out and kind != "dot" and draw(st.booleans()):
            other = out[draw(st.integers(0, len(out) - 1))].pts
            at = other[draw(st.integers(0, len(other) - 1))]
            a = draw(st.floats(0, 2 * math.pi))
            g = draw(gap)
            p = (float(at[0] + g * math.cos(a)), float(at[1] + g * math.sin(a)))
            pts[draw(st.sampled_from([0, -1]))] = p
        if kind == "closed" and len(pts) >= 3:
            pts.append(pts[0])
        pts = [p for k, p in enumerate(pts) if k == 0 or p != pts[k - 1]]
        out.append(Stroke(np.array(pts, dtype=float), line=i + 1,
                          layer=draw(st.sampled_from([None, None, "b"]))))
    return out


@settings(max_examples=80)
@given(near_strokes(), st.tuples(coord, coord), st.sampled_from([0.0, 0.001, TOL]))
def test_every_order_draws_the_input_segments_and_joins_within_the_limit(ss, start, join):
    """The pen-down moves of every order are exactly the input's segments (unordered pairs of
    points, bit for bit), plus joins: each no longer than the join limit and between two stroke
    points of the input; dots are drawn where they are."""
    want = input_segments(ss)
    points = {tuple(p) for s in ss for p in s.pts.tolist()}
    dots = sorted(tuple(s.pts[0]) for s in ss if len(s.pts) == 1)
    drawn = {}
    for method in order.METHODS:
        out = order.order(ss, method, start)
        segs, runs = pen_down_segments(records_of(out, join))
        got = {unordered(s[:2], s[2:]) for s in segs}
        bridges = got - want
        assert want <= got, method
        for a, b in bridges:
            assert math.dist(a, b) <= join and a in points and b in points, (method, a, b)
        assert sorted(tuple(r[0]) for r in runs if len(r) == 1) == dots
        drawn[method] = got
    # the orders differ by joins only, each within the limit
    for method in order.METHODS:
        assert all(math.dist(a, b) <= join for a, b in drawn[method] ^ want)


def test_join_is_at_most_the_flattening_tolerance():
    said = []
    assert join_limit(None, TOL, said.append) == TOL and not said
    assert join_limit(0.001, TOL, said.append) == 0.001 and not said
    assert join_limit(0.0, TOL, said.append) == 0.0 and not said
    assert join_limit(0.05, TOL, said.append) == TOL
    assert len(said) == 1 and "--join 0.05 mm is more than the flattening tolerance" in said[0]


def test_ends_0_04_mm_apart_are_not_joined_by_default():
    """The pair of issue 21: two curves whose ends are 0.04 mm apart are drawn as two strokes
    (a bridge would run up to 0.02 mm off the file); ends 0.005 mm apart are joined."""
    a = Stroke(np.array([[0.0, 0], [10, 0]]), line=1)
    for g, joins in ((0.04, False), (0.005, True)):
        b = Stroke(np.array([[20.0, 0], [10, g]]), line=2)
        out = order.order([a, b], "best", (0, 0))
        recs = records_of(out, TOL)
        assert sum(isinstance(r, Pen) and r.down for r in recs) == (1 if joins else 2)


# ------------------------------------------------------------------ an SVG end to end
@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    # ends 0.045-0.05 mm apart: a join of them would draw up to 0.025 mm off the file (before
    # issue 21 best drew 0.0225 mm off in the trace, keep 0.0138 mm)
    text, true = bezier_svg.make(7, n_paths=24, pairs=10, width=160.0, height=200.0,
                                 gap=(0.045, 0.05), n=600)
    path = tmp_path_factory.mktemp("gen") / "gen.svg"
    path.write_text(text)
    return path, true


def _both_ways(drawn: list[np.ndarray], true: list[np.ndarray]) -> tuple[float, float]:
    pts = np.concatenate([tc.distances._densify(p, 0.01) for p in drawn])
    d1 = tc.distances_to_polylines(pts, true, spacing=0.01)
    d2 = tc.distances_to_polylines(np.concatenate(true), drawn, spacing=0.01)
    return float(d1.max()), float(d2.max())


def test_generated_svg_records_are_the_true_curves_in_every_order(generated):
    """keep, greedy and best: the pen-down moves lie within the flattening tolerance of the
    true curves (de Casteljau through the nested matrices) and cover them, both ways."""
    path, true = generated
    cfg = config.load(REPO / "config.toml")
    for method in order.METHODS:
        prep = prepare(str(path), cfg, types.SimpleNamespace(order=method), warn=lambda m: None)
        _, runs = pen_down_segments(prep.records())
        d1, d2 = _both_ways(runs, true)
        assert d1 <= TOL + 1e-4 and d2 <= TOL + 1e-4, (method, d1, d2)


def test_generated_svg_dry_run_best_is_within_the_tolerance_both_ways(capsys, generated,
                                                                     tmp_path):
    """The decoded dry-run trace of --order best (default join) lies within 0.02 mm of the
    true curves and covers them within 0.02 mm."""
    path, true = generated
    trace = tmp_path / "t.csv"
    cfg_path = REPO / "config.toml"
    assert main(["--config", str(cfg_path), "calibrate", "--at", "0", "0"]) == 0
    assert main(["--config", str(cfg_path), "draw", str(path), "--dry-run", "--trace",
                 str(trace), "--order", "best"]) == 0
    capsys.readouterr()
    dec = tc.decode(tc.read_trace(trace), tc.load_config(cfg_path))
    d1, d2 = tc.accuracy(dec, true)
    assert d1 <= 0.02 and d2 <= 0.02, (d1, d2)
