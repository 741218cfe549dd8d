"""Hostile observations thrown at the screening and the wear monitor (hypothesis)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.contract import CycleState, CycleStatus
from jointwear_ros.monitor import PLAUSIBLE_TEMPERATURE, MonitorConfig, WearMonitor, screen_observation
from jointwear_ros.observer import FrictionObservationData

VALID = {"speed": (0.0, 280.0), "load_torque": (0.0, 1.0), "temperature": (20.0, 60.0)}
anything = st.floats(allow_nan=True, allow_infinity=True)


def _obs(speed, tau_f, std, load, temperature, cycle_id=1, stamp=1.0):
    return FrictionObservationData(
        stamp=stamp, joint_name="joint_1", cycle_id=cycle_id, speed=speed, tau_f=tau_f, tau_f_std=std,
        tau_plus=0.1, tau_minus=-0.1, load_torque=load, temperature=temperature, position=0.0,
        samples_plus=100, samples_minus=100)


@settings(max_examples=400, deadline=None)
@given(anything, anything, anything, anything, anything)
def test_screening_never_passes_a_non_physical_value(speed, tau_f, std, load, temperature):
    kept, why = screen_observation(_obs(speed, tau_f, std, load, temperature), VALID)
    if kept is None:
        assert why.endswith("dropped")
        return
    assert math.isfinite(kept.speed) and 0.0 < kept.speed <= 280.0
    assert math.isfinite(kept.tau_f) and kept.tau_f >= 0.0
    assert math.isnan(kept.tau_f_std) or (math.isfinite(kept.tau_f_std) and kept.tau_f_std >= 0.0)
    assert math.isfinite(kept.load_torque) and abs(kept.load_torque) <= 1.0
    assert math.isnan(kept.temperature) or 20.0 <= kept.temperature <= 60.0
    assert (kept.temperature != temperature and not math.isnan(temperature)) == bool(why)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(anything, anything, anything, anything, anything), min_size=1, max_size=4))
def test_the_monitor_gives_a_result_for_any_cycle_and_never_raises(rows):
    mon = WearMonitor(MonitorConfig(seed=0, done_timeout=1.0, estimator_options={"n_samples": 20}))
    mon.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=len(rows), joint_name="joint_1"), now=0.0)
    results = []
    for i, r in enumerate(rows):
        results += mon.add(_obs(*r, stamp=1.0 + i))
    results += mon.on_status(CycleStatus(cycle_id=1, state=CycleState.DONE, speeds_done=len(rows), speeds_total=len(rows), joint_name="joint_1"), now=10.0)
    results += mon.poll(20.0)
    (res,) = results
    assert len(res.observations) + len(res.rejected) == len(rows)
    if res.result is not None:
        assert 0.0 <= res.result.wear <= 100.0 and res.result.wear_std >= 0.0


def test_plausible_range_is_a_robot_joints():
    lo, hi = PLAUSIBLE_TEMPERATURE
    assert lo > -273.15 and hi < 1000.0
    assert screen_observation(_obs(40.0, 0.09, 1e-4, 0.1, 40.0), VALID) == (_obs(40.0, 0.09, 1e-4, 0.1, 40.0), "")
    kept, why = screen_observation(_obs(40.0, 0.09, 1e-4, 0.1, 1000.0), VALID, use_temperature=False)
    assert kept is not None and why == "" and kept.temperature == 1000.0  # ignored anyway


@pytest.mark.parametrize("bad", [-300.0])
def test_prepare_rows_refuses_a_temperature_below_absolute_zero(bad):
    from jointwear_ros.errors import InputDataError
    from jointwear_ros.estimation._common import prepare_rows
    from jointwear_ros.types import ObservationTable

    t = ObservationTable.from_arrays(speed=[40.0], tau_f=[0.09], load_torque=[0.1], temperature=[bad])
    with pytest.raises(InputDataError, match="below absolute zero"):
        prepare_rows(t)
    t = ObservationTable.from_arrays(speed=[40.0], tau_f=[0.09], load_torque=[0.1], tau_f_std=[-1e-3])
    with pytest.raises(InputDataError, match="tau_f_std -0.001 is not a standard error"):
        prepare_rows(t)


def test_a_flood_of_bad_observations_keeps_memory_bounded():
    mon = WearMonitor(MonitorConfig())
    for i in range(5000):
        assert mon.add(_obs(math.nan, 0.09, 1e-4, 0.1, 40.0, cycle_id=1, stamp=float(i))) == []
    assert mon.rejected_count == 5000 and mon.notes_total == 5000
    assert len(mon.ignored) == mon.max_notes == 1000
    assert mon.notes_since(4998) == mon.ignored[-2:] and mon.notes_since(5000) == []
    (r,) = mon.on_status(CycleStatus(cycle_id=1, state=CycleState.DONE, speeds_total=3, joint_name="joint_1"), now=6000.0)  # 5000 heard >= 3 speeds: estimated now
    assert r.result is None and dict(r.values)["observations_rejected"] == "5000"
    assert len(r.rejected) == 5 and "and 4995 more" in r.message


@pytest.mark.parametrize(("temperature", "kept"), [
    (20.0, True), (60.0, True), (19.99, False), (60.01, False), (40.0, True),
    (PLAUSIBLE_TEMPERATURE[0], None), (PLAUSIBLE_TEMPERATURE[0] - 0.01, False),
    (PLAUSIBLE_TEMPERATURE[1] + 0.01, False),
])
def test_the_temperature_bounds_hold_exactly_on_both_sides(temperature, kept):
    """The parameter set's valid range [20, 60] degC and the plausible range, checked on both sides of each bound
    (a bound widened by a degree, or a < for a <=, fails here)."""
    o = _obs(50.0, 0.1, 3e-4, 0.1, temperature)
    out, why = screen_observation(o, {"temperature": (20.0, 60.0)})
    assert out is not None  # the friction measurement is kept; only its temperature may become unknown
    if kept is None:  # plausible, but outside the valid range
        assert math.isnan(out.temperature) and "valid range [20, 60]" in why
    elif kept:
        assert out.temperature == temperature and why == ""
    else:
        assert math.isnan(out.temperature) and "used as unknown" in why
    wide, why_wide = screen_observation(o, {"temperature": (-100.0, 300.0)})
    inside = PLAUSIBLE_TEMPERATURE[0] <= temperature <= PLAUSIBLE_TEMPERATURE[1]
    assert (wide.temperature == temperature) == inside, why_wide
