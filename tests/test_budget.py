"""The plot-time budget: --max-time parsing and the spacing search (on model drawings whose
plot time is a known function of the spacing, so that the answer is known)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings, strategies as st

from vplotter import budget
from vplotter.errors import ConfigError


@pytest.mark.parametrize("text, seconds", [("2h", 7200), ("45m", 2700), ("1h30m", 5400),
                                           ("90s", 90), ("5400", 5400), ("1.5h", 5400),
                                           ("1h 5m 10s", 3910), ("20min", 1200)])
def test_durations(text, seconds):
    assert budget.parse_duration(text) == seconds


@pytest.mark.parametrize("text", ["", "h", "2x", "-1h", "1h-5m", "10", "40d", "1e9"])
def test_bad_durations_are_one_line(text):
    with pytest.raises(ConfigError) as e:
        budget.parse_duration(text)
    assert "\n" not in str(e.value) and "--max-time" in str(e.value)


@settings(max_examples=60, deadline=None)
@given(a=st.floats(0, 600), b=st.floats(50, 1e5), p=st.floats(0.7, 2.3),
       hours=st.floats(0.5, 4), start=st.floats(0.3, 20), noise=st.floats(0, 0.02))
def test_the_search_lands_just_under_the_budget(a, b, p, hours, start, noise):
    B = 3600 * hours
    calls = []

    def model(s):               # a power law with a little wobble (ordering, pen lifts)
        return a + b / s ** p * (1 + noise * math.sin(37 * s))

    def plot_time(s):
        calls.append(s)
        return model(s)

    lo, hi = 0.2, 200.0
    drawing, choice = (None, None)
    try:
        drawing, choice = budget.fit(lambda s: s, plot_time, B, start, lo, hi, power=1.0)
    except ConfigError as e:
        assert model(hi) > B and "too short" in str(e)      # even the sparsest is over
        return
    assert drawing == choice.spacing_mm and choice.time_s == model(drawing)
    assert choice.time_s <= B
    if choice.spacing_mm > lo * 1.0001 and not choice.limit:
        assert choice.time_s >= budget.UNDER * B
    if choice.spacing_mm <= lo * 1.0001:
        assert "as dense as the pen" in choice.text()
    assert len(choice.tries) <= budget.TRIES
    spacings = [s for s, _ in choice.tries]
    assert len(set(spacings)) == len(spacings) == len(calls)     # no spacing timed twice


def test_the_choice_says_what_and_why():
    _, c = budget.fit(lambda s: s, lambda s: 3000 / s, 3600, 2.0, 0.1, 50)
    text = c.text()
    assert "spacing" in text and "within 1:00:00" in text and "tries" in text
    assert 0.96 * 3600 <= c.time_s <= 3600


def test_the_search_makes_at_most_what_it_is_allowed():
    made = []

    def make(s):
        made.append(s)
        return s

    # time = 3600 / s (s in mm): from a start far off, two drawings cannot land within 4 %
    drawing, choice = budget.fit(make, lambda s: 3600.0 / s, 1800.0, 20.0, 0.5, 50.0, most=2)
    assert len(made) == 2 and len(choice.tries) == 2
    assert 3600.0 / drawing <= 1800.0
