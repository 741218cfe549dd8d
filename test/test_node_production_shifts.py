"""The production observer's shift rule and input rules, without ROS: ShiftClock (by the stamps: a shift ends at
the first sample of a later period, or when ended early; ids grow from 1), TemperatureTrack (the latest reading
at or before a sample, whatever order the readings came in), JointStateRows (by name; the reason when a message
cannot be used), and production_shifts equal to observe_production per shift, bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.errors import ParameterError
from jointwear_ros.io.production_bag import (
    JointStateRows,
    ProductionSamples,
    ShiftClock,
    TemperatureTrack,
    production_shifts,
)
from jointwear_ros.observer import ProductionConfig, observe_production


@settings(deadline=None, derandomize=True, max_examples=200)
@given(st.lists(st.floats(0.0, 1000.0), min_size=1, max_size=60, unique=True),
       st.floats(0.5, 200.0), st.floats(-500.0, 500.0))
def test_a_shift_is_the_period_of_its_stamps_and_ends_at_the_first_sample_of_a_later_period(stamps, seconds, origin):
    clock = ShiftClock(seconds=seconds, origin=origin)
    ids, ended = [], []
    for t in sorted(stamps):
        e = clock.on_sample(t)
        if e is not None:
            ended.append(e)
        ids.append(clock.current)
    periods = [1 + math.floor((t - origin) / seconds) for t in sorted(stamps)]
    assert all(i >= 1 for i in ids) and ids == sorted(ids)
    # each new shift begins exactly where the period changes, and ends the one before it
    changes = [k for k in range(1, len(periods)) if periods[k] != periods[k - 1]]
    assert [k for k in range(1, len(ids)) if ids[k] != ids[k - 1]] == changes
    assert ended == [ids[k - 1] for k in changes]
    if periods[0] >= 1:  # stamps at or after the origin: the id is the period
        assert ids == periods
    assert clock.end() == ids[-1] and clock.current is None and clock.end() is None


def test_a_shift_ended_early_leaves_the_rest_of_its_period_to_the_next_id():
    clock = ShiftClock(seconds=10.0)
    assert [clock.on_sample(t) for t in (1.0, 2.0)] == [None, None] and clock.current == 1
    assert clock.end() == 1  # the operator's end_shift
    assert clock.on_sample(3.0) is None and clock.current == 2  # the rest of period 1
    assert clock.on_sample(11.0) == 2 and clock.current == 3  # period 2: the ids stay ahead, never reused
    assert clock.on_sample(25.0) == 3 and clock.current == 4


def test_the_idle_rule_needs_the_shifts_end_time_passed_and_the_silence():
    clock = ShiftClock(seconds=10.0)
    assert not clock.idle_due(100.0, 1e9, 5.0)  # no shift being observed
    clock.on_sample(1.0)
    assert not clock.idle_due(9.9, 60.0, 5.0)  # before the shift's end time
    assert not clock.idle_due(10.0, 4.9, 5.0)  # not silent long enough
    assert clock.idle_due(10.0, 5.0, 5.0)


@pytest.mark.parametrize(("seconds", "origin"), [(0.0, 0.0), (-1.0, 0.0), (math.nan, 0.0), (10.0, math.inf)])
def test_a_shift_length_or_origin_that_cannot_be_is_one_parameter_error(seconds, origin):
    with pytest.raises(ParameterError, match=r"^shift_(seconds|origin) must be"):
        ShiftClock(seconds=seconds, origin=origin)


@settings(deadline=None, derandomize=True, max_examples=100)
@given(st.lists(st.tuples(st.sampled_from(["a", "b"]), st.integers(0, 40), st.floats(-20.0, 120.0)), max_size=40),
       st.randoms(use_true_random=False))
def test_each_sample_takes_each_joints_latest_reading_at_or_before_it_in_any_arrival_order(readings, rnd):
    shuffled = list(readings)
    rnd.shuffle(shuffled)
    track = TemperatureTrack(["a", "b"])
    for j, s, x in shuffled:
        assert track.add(j, s * 0.5, x)
    for t in np.arange(-0.5, 21.0, 0.25):
        got = track.at(float(t))
        for i, j in enumerate("ab"):
            mine = [(s * 0.5, k) for k, (jj, s, _) in enumerate(readings) if jj == j and s * 0.5 <= t]
            if not mine:
                assert math.isnan(got[i])
            else:  # the latest stamp; of equal stamps, the one that came last
                latest = max(s for s, _ in mine)
                candidates = {readings[k][2] for s, k in mine if s == latest}
                assert got[i] in candidates


def test_a_temperature_of_another_joint_or_not_finite_is_not_kept():
    track = TemperatureTrack(["a"])
    assert not track.add("b", 1.0, 40.0)
    assert not track.add("a", 1.0, math.nan)
    assert not track.add("a", math.inf, 40.0)
    assert math.isnan(track.at(2.0)[0])


def test_a_joint_state_is_read_by_name_or_refused_with_its_reason():
    rows = JointStateRows(["j1", "j2"])
    q, v, u = rows.row(["j2", "x", "j1"], [2.0, 9.0, 1.0], [0.2, 9.0, 0.1], [20.0, 9.0, 10.0])  # type: ignore[misc]
    assert (q.tolist(), v.tolist(), u.tolist()) == ([1.0, 2.0], [0.1, 0.2], [10.0, 20.0])
    assert rows.row(["j1"], [0.0], [0.0], [0.0])[0] == "joint missing"
    assert rows.row(["j1", "j2"], [0.0, 0.0], [0.0], [0.0, 0.0]) == ("lengths", "velocity has 1 value(s) for 2 name(s)")
    assert rows.row(["j1", "j2"], [0.0, 0.0], [0.0, 0.0], []) == ("lengths", "effort has 0 value(s) for 2 name(s)")
    assert rows.row(["j1", "j2"], [0.0, math.nan], [0.0, 0.0], [0.0, 0.0])[0] == "not finite"


def _back_and_forth(n_cycles: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One joint out and back at 0.5 rad/s (motor 50), friction 0.2, sampled at 500 Hz."""
    dt = 0.002
    leg = np.concatenate([np.zeros(100), np.full(1800, 0.5), np.zeros(100), np.full(1800, -0.5)])
    v = np.tile(leg, n_cycles)[:, None]
    t = np.arange(v.shape[0]) * dt + dt
    q = np.concatenate(([0.0], np.cumsum(v[:-1, 0]) * dt))[:, None]
    rng = np.random.default_rng(4)
    u = np.sign(v) * 20.0 + 5.0 + 40.0 * q + rng.normal(0.0, 0.5, v.shape)
    return t, q, v, u


def test_production_shifts_equal_observe_production_of_each_shifts_samples_bit_for_bit():
    t, q, v, u = _back_and_forth(3)
    temps = 40.0 + t[:, None] / 100.0
    cfg = ProductionConfig(gear_ratio=100.0, torque_scale=100.0)
    samples = ProductionSamples(("joint_1",), t, q, v, u, temps)
    shifts = production_shifts(samples, cfg, clock=ShiftClock(seconds=8.0))
    period = 1 + np.floor(t / 8.0).astype(int)
    assert [s.shift_id for s in shifts] == sorted(set(period.tolist())) and len(shifts) == 3
    for s in shifts:
        sel = period == s.shift_id
        want = observe_production(t[sel], q[sel], v[sel], u[sel], temps[sel], joint_names=["joint_1"], config=cfg,
                                  shift_id=s.shift_id)
        assert s.observations == want.observations and s.joints == want.joints and s.samples == want.samples
        assert s.observations  # every shift pairs passes
