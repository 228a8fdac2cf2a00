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


@settings(max_examples=60, deadline=None)
@given(a=st.floats(0, 600), b=st.floats(50, 1e5), p=st.floats(0.7, 2.3),
       hours=st.floats(0.5, 4), gain=st.floats(0.85, 1.0), noise=st.sampled_from([0.0, 0.02]))
def test_fill_spends_what_the_final_order_saves(a, b, p, hours, gain, noise):
    """The search times a quick order; the final order takes `gain` of that. `fill` lands the
    final drawing within FILL_UNDER of the budget (a smooth power law) and never over it."""
    B = 3600 * hours

    def quick_time(s):
        return a + b / s ** p * (1 + noise * math.sin(37 * s))

    lo, hi = 0.2, 200.0
    try:
        made, choice = budget.fit(lambda s: ("quick", s), lambda d: quick_time(d[1]), B, 5.0,
                                  lo, hi, power=1.0)
    except ConfigError:
        return
    timed = []

    def plot_time(d):
        timed.append(d)
        return quick_time(d[1]) * (gain if d[0] == "final" else 1.0)

    drawn, c = budget.fill(made, choice, lambda s: ("quick", s),
                           lambda d: ("final", d[1]), plot_time, B, lo, power=1.0)
    assert c.time_s <= B and c.time_s == plot_time(drawn)
    assert drawn[0] == "final"
    assert c.time_s >= gain * choice.time_s * (1 - 1e-12)     # never less than it had
    assert c.spacing_mm <= choice.spacing_mm
    assert len(c.tries) - len(choice.tries) <= budget.FILL_TRIES
    if noise == 0 and c.spacing_mm > lo * 1.0001:
        assert c.time_s >= budget.FILL_UNDER * B


def test_fill_keeps_the_quick_order_when_the_final_one_is_longer():
    choice = budget.Choice(2.0, 3580.0, 3600.0, [(2.0, 3580.0)])
    drawn, c = budget.fill("quick", choice, lambda s: 1 / 0, lambda d: "final",
                           lambda d: 3590.0, 3600.0, 0.5, 1.0)
    assert drawn == "quick" and c.time_s == 3580.0 and c.spacing_mm == 2.0


def test_fill_keeps_the_longest_drawing_when_denser_ones_take_less():
    # a spiral whose tracks turn dashed: a denser spacing can take less time
    times = {2.0: 3400.0}

    def plot_time(s):
        return times.get(s, 3000.0 if s > 1.5 else 4000.0)

    choice = budget.Choice(2.0, 3400.0, 3600.0, [(2.0, 3400.0)])
    drawn, c = budget.fill(2.0, choice, lambda s: s, lambda d: d, plot_time, 3600.0, 0.5, 1.0)
    assert drawn == 2.0 and c.time_s == 3400.0
    assert "closest try" in c.text()


def test_fill_of_a_drawing_that_takes_no_time_leaves_it():
    """An all-white picture draws nothing at any spacing: nothing to fill, no error."""
    choice = budget.Choice(3.0, 0.0, 3600.0, [(3.0, 0.0)])
    drawn, c = budget.fill([], choice, lambda s: [], lambda d: d, lambda d: 0.0, 3600.0, 0.5, 1)
    assert drawn == [] and c.time_s == 0.0 and c.spacing_mm == 3.0
