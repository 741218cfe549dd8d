"""OnDemandLedger: the per-joint memory the cycle_on_demand node keeps from the cell's stream (pure)."""

from __future__ import annotations

import math

import pytest

from jointwear_ros.condition import Forecast
from jointwear_ros.errors import InputDataError
from jointwear_ros.trend import OnDemandConfig, OnDemandLedger, OnDemandPolicy

SHIFT = 8 * 3600.0
DAY = 86400.0


def ledger(**cfg) -> OnDemandLedger:
    return OnDemandLedger(OnDemandPolicy(OnDemandConfig(**cfg)))


def test_quiet_shifts_count_until_the_cycle_is_asked_for_and_an_informative_estimate_resets_them():
    led = ledger(max_quiet_shifts=3)
    kinds = [led.quiet_shift("joint_6", stamp=k * SHIFT).kind for k in range(1, 4)]
    assert kinds == ["none", "none", "quiet"]
    assert led.last_decision("joint_6").ask
    assert "no informative production motion for 3 shifts" in led.last_decision("joint_6").reason
    d = led.production_estimate("joint_6", 12.0, 1.5, stamp=4 * SHIFT)
    assert (d.ask, d.kind) == (False, "none")
    assert led.quiet_shift("joint_6", stamp=5 * SHIFT).kind == "none"  # counting starts again at 1


def test_a_production_estimate_that_cannot_tell_counts_as_quiet_and_never_asks_for_a_straddle():
    led = ledger(max_quiet_shifts=2)
    d = led.production_estimate("joint_2", math.nan, math.nan, stamp=SHIFT)
    assert (d.ask, d.kind) == (False, "none") and "cannot tell" in d.reason
    d = led.production_estimate("joint_2", 34.0, math.nan, stamp=2 * SHIFT)
    assert (d.ask, d.kind) == (True, "quiet")


def test_a_straddle_is_asked_for_once_and_then_held_back_by_the_dedicated_cycle_that_decided_it():
    led = ledger()
    d = led.production_estimate("joint_2", 33.1, 2.4, stamp=SHIFT)
    assert (d.ask, d.kind) == (True, "straddle") and d.reason.endswith("no dedicated test cycle yet")
    led.test_cycle_estimate("joint_2", 31.0, 0.9, stamp=SHIFT + 3600.0)
    d = led.production_estimate("joint_2", 33.5, 2.4, stamp=2 * SHIFT)
    assert (d.ask, d.kind) == (False, "straddle") and "agrees with the last dedicated test cycle's 31.0" in d.reason
    # grown beyond the cycle by more than 3 std of the difference and reading a higher level: asked again at once
    d = led.production_estimate("joint_2", 36.5, 1.5, stamp=3 * SHIFT)
    assert d.ask and "above the WARN of the last dedicated test cycle" in d.reason


def test_a_forecast_crossing_within_the_horizon_asks_and_a_cycle_giving_error_stops_asking():
    led = ledger(crossing_horizon_days=14.0)
    led.forecast("joint_3", Forecast(True, 30.0, 20.0, 9.0, 40.0, "within_horizon"))
    d = led.production_estimate("joint_3", 25.0, 1.0, stamp=SHIFT)
    assert (d.ask, d.kind) == (True, "crossing") and "in 9 days" in d.reason
    led.test_cycle_estimate("joint_3", 36.0, 0.5, stamp=SHIFT + 60.0)
    d = led.production_estimate("joint_3", 25.0, 1.0, stamp=2 * SHIFT)
    assert not d.ask and "gave ERROR" in d.reason


@pytest.mark.parametrize("call", [
    lambda led: led.quiet_shift("", stamp=1.0),
    lambda led: led.quiet_shift("joint_1", stamp=math.nan),
    lambda led: led.production_estimate("joint_1", 10.0, -1.0, stamp=1.0),
    lambda led: led.forecast("joint_1", "soon"),
])
def test_bad_input_is_one_input_data_error(call):
    with pytest.raises(InputDataError):
        call(ledger())
