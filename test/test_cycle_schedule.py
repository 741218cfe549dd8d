"""The robot-cycle rotation: the fewest nights, each within the budget, every joint once."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.cycle.schedule import ScheduleError, rotation_schedule


def _fewest_nights_brute_force(costs: list[float], budget: float) -> int:
    """Try every assignment of joints to nights (small n only)."""
    n = len(costs)
    for k in range(1, n + 1):
        for assign in itertools.product(range(k), repeat=n):
            loads = [0.0] * k
            for c, b in zip(costs, assign):
                loads[b] += c
            if max(loads) <= budget + 1e-9:
                return k
    raise AssertionError("unreachable: one joint per night always fits")


@settings(max_examples=150, deadline=None)
@given(st.lists(st.floats(1.0, 100.0), min_size=1, max_size=6), st.floats(100.0, 400.0))
def test_the_split_is_the_fewest_nights_and_each_fits(costs, budget):
    durations = {f"joint_{i + 1}": c for i, c in enumerate(costs)}
    s = rotation_schedule(durations, budget)
    tested = [j for night in s.nights for j in night]
    assert sorted(tested) == sorted(durations)  # every joint exactly once
    assert all(sec <= budget + 1e-6 for sec in s.night_seconds())
    assert s.period == _fewest_nights_brute_force(costs, budget)
    assert s.period >= math.ceil(sum(costs) / budget - 1e-9)
    for night in s.nights:  # test order kept within a night
        assert night == sorted(night, key=list(durations).index)


def test_a_six_joint_robot_at_the_papers_pace_needs_three_nights_of_five_minutes():
    # 8 speeds x 14 s (the paper) = 112 s per joint, plus 10 s to reach each joint's test pose
    s = rotation_schedule({f"joint_{k}": 112.0 for k in range(1, 7)}, budget=300.0, overhead=10.0)
    assert s.total == pytest.approx(6 * 122.0)
    assert s.period == 3 and all(len(n) == 2 for n in s.nights)
    assert not s.fits_one_night
    assert rotation_schedule({f"joint_{k}": 112.0 for k in range(1, 7)}, budget=6 * 122.0, overhead=10.0).period == 1


def test_a_joint_longer_than_the_budget_is_refused_with_what_to_do():
    with pytest.raises(ScheduleError, match="joint_2 alone needs 200 s, more than the 150 s budget.*cycle design"):
        rotation_schedule({"joint_1": 100.0, "joint_2": 200.0}, budget=150.0)


@pytest.mark.parametrize("durations,budget,overhead,match", [
    ({}, 100.0, 0.0, "no joints"),
    ({"j": 10.0}, 0.0, 0.0, "budget"),
    ({"j": 10.0}, math.nan, 0.0, "budget"),
    ({"j": -1.0}, 100.0, 0.0, "duration"),
    ({"j": math.inf}, 100.0, 0.0, "duration"),
    ({"j": 10.0}, 100.0, -5.0, "overhead"),
])
def test_bad_input_is_refused_with_the_reason(durations, budget, overhead, match):
    with pytest.raises(ScheduleError, match=match):
        rotation_schedule(durations, budget, overhead)
