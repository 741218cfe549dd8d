"""The test cycle on demand: the policy asks for each reason, and not otherwise (jointwear_ros.trend.ondemand)."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.condition import ALARM, WARN, forecast_of
from jointwear_ros.errors import InputDataError
from jointwear_ros.settings import declarations, from_mapping
from jointwear_ros.trend import DAY, Decision, OnDemandConfig, OnDemandPolicy, TrendConfig

SETTINGS = settings(max_examples=200, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow])
NOW = 1.7e9


def decide(estimate, forecast=None, quiet=0, last=None, cycle=None, policy=None) -> Decision:
    p = policy or OnDemandPolicy()
    return p.decide("joint_2", estimate, forecast, quiet_shifts=quiet,
                    last_cycle_time=None if last is None else NOW - last * DAY, now=NOW, last_cycle_estimate=cycle)


def test_policy_asks_when_the_production_estimate_straddles_the_alarm() -> None:
    d = decide((33.1, 2.4))
    assert (d.ask, d.kind) == (True, "straddle")
    assert d.reason.startswith("joint_2: production estimate 33.1 ± 2.4 straddles the ERROR threshold 35")


def test_policy_asks_when_the_production_estimate_straddles_the_warning_level() -> None:
    d = decide((29.0, 1.0))
    assert (d.ask, d.kind) == (True, "straddle")
    assert "straddles the WARN threshold 30" in d.reason


@pytest.mark.parametrize("estimate", [(20.0, 1.0), (27.0, 1.0), (31.0, 0.5), (40.0, 1.0)])
def test_policy_does_not_ask_when_the_production_estimate_decides_the_level(estimate: tuple[float, float]) -> None:
    d = decide(estimate)
    assert (d.ask, d.kind) == (False, "none")
    assert "decides the level" in d.reason


def test_policy_asks_after_max_quiet_shifts_without_informative_motion() -> None:
    n = OnDemandConfig().max_quiet_shifts
    assert decide(None, quiet=n - 1).ask is False
    d = decide(None, quiet=n)
    assert (d.ask, d.kind) == (True, "quiet")
    assert f"no informative production motion for {n} shifts" in d.reason


def test_policy_asks_when_the_trend_says_a_crossing_is_near() -> None:
    horizon = OnDemandConfig().crossing_horizon_days
    near = forecast_of(12.0, horizon - 1.0, 30.0, True, True, 30.0)
    far = forecast_of(80.0, horizon + 10.0, 200.0, True, True, 30.0)
    d = decide((20.0, 1.0), near)
    assert (d.ask, d.kind) == (True, "crossing")
    assert "may be crossed in 13 days" in d.reason
    assert decide((20.0, 1.0), far).ask is False
    assert decide((20.0, 1.0), forecast_of(None, None, None, False, True, 30.0)).ask is False
    at = decide((20.0, 1.0), forecast_of(0.0, 0.0, 0.0, True, True, 30.0))
    assert (at.ask, at.kind) == (True, "crossing") and "at the alarm" in at.reason


def test_policy_waits_min_interval_nights_after_a_cycle_unless_the_level_would_rise() -> None:
    n = OnDemandConfig().min_interval_nights
    near = forecast_of(12.0, 5.0, 30.0, True, True, 30.0)
    # a crossing forecast after a cycle that read 32 (WARN): held back within the interval, asked after it
    held = decide((32.5, 1.0), near, last=n - 2, cycle=(32.0, 0.85))
    assert (held.ask, held.kind) == (False, "crossing")
    assert f"not asked: the last dedicated test cycle was {n - 2} nights ago" in held.reason
    assert decide((32.5, 1.0), near, last=n, cycle=(32.0, 0.85)).ask is True
    # a production estimate that has grown past the cycle's and reads a higher level: asked at once
    d = decide((38.5, 1.7), near, last=1, cycle=(32.0, 0.85))
    assert d.ask is True and "it reads ERROR, above the WARN of the last dedicated test cycle 1 night ago" in d.reason


def test_policy_does_not_ask_for_a_straddle_the_last_cycle_already_decided() -> None:
    d = decide((28.5, 1.7), last=30, cycle=(27.0, 0.85))
    assert (d.ask, d.kind) == (False, "straddle")
    assert "agrees with the last dedicated test cycle's 27.0 ± 0.8" in d.reason
    assert decide((33.0, 1.7), last=30, cycle=(27.0, 0.85)).ask is True  # grown beyond it


def test_policy_does_not_ask_after_a_cycle_gave_error() -> None:
    d = decide((36.0, 1.7), forecast_of(0.0, 0.0, 0.0, True, True, 30.0), last=30, cycle=(36.0, 0.85))
    assert (d.ask, d.kind) == (False, "none")
    assert "alarm stands until maintenance" in d.reason


@pytest.mark.parametrize("estimate", [None, (math.nan, 1.0), (34.0, math.nan), (math.inf, 1.0)])
def test_a_cannot_tell_estimate_never_asks_for_a_straddle(estimate: object) -> None:
    d = decide(estimate)
    assert (d.ask, d.kind) == (False, "none")
    assert "production cannot tell" in d.reason


def test_policy_thresholds_are_the_level_rules() -> None:
    assert (OnDemandPolicy().warn, OnDemandPolicy().alarm) == (WARN, ALARM)
    cfg = TrendConfig(alarm=40.0, warn=32.0)
    p = OnDemandPolicy(warn=cfg.warn, alarm=cfg.alarm)
    assert decide((39.0, 1.0), policy=p).reason.startswith("joint_2: production estimate 39.0 ± 1.0 straddles "
                                                           "the ERROR threshold 40")
    assert decide((33.1, 2.4)).ask and not decide((33.1, 0.5), policy=p).ask


def test_on_demand_settings_are_node_parameters_with_ranges() -> None:
    names = [d.name for d in declarations(OnDemandConfig)]
    assert names == ["max_quiet_shifts", "crossing_horizon_days", "min_interval_nights", "allow_service_call"]
    assert all("threshold" not in n for n in names)  # the thresholds are the level rule's, not declared again
    assert from_mapping(OnDemandConfig, {"min_interval_nights": 3, "allow_service_call": True}).min_interval_nights == 3
    with pytest.raises(InputDataError, match="max_quiet_shifts"):
        OnDemandConfig(max_quiet_shifts=0)


def test_decide_many_decides_each_joint() -> None:
    out = OnDemandPolicy().decide_many(["joint_1", "joint_2"], [(10.0, 1.0), (34.0, 1.0)], [None, None],
                                       quiet_shifts=[0, 0], last_cycle_time=None, now=NOW)
    assert [(d.joint, d.ask, d.kind) for d in out] == [("joint_1", False, "none"), ("joint_2", True, "straddle")]
    with pytest.raises(InputDataError, match="one of each per joint"):
        OnDemandPolicy().decide_many(["joint_1"], [], [None], quiet_shifts=[0], last_cycle_time=None, now=NOW)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"estimate": (30.0,)}, "wear, std"),
    ({"estimate": ("30", 1.0)}, "a number is needed"),
    ({"estimate": (30.0, -1.0)}, "standard deviation"),
    ({"quiet": -1}, "quiet_shifts"),
    ({"last": -2.0}, "after now"),
])
def test_bad_input_is_one_input_data_error(kwargs: dict[str, object], match: str) -> None:
    args = {"estimate": (30.0, 1.0), **kwargs}
    with pytest.raises(InputDataError, match=match):
        decide(args.pop("estimate"), **args)  # type: ignore[arg-type]


number = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6), st.booleans(),
                   st.text(max_size=3), st.none())
maybe_pair = st.one_of(st.none(), st.tuples(number, number), st.lists(number, max_size=3), number)
forecasts = st.one_of(st.none(), st.builds(forecast_of, st.one_of(st.none(), st.floats(0, 4000)),
                                           st.one_of(st.none(), st.floats(0, 4000)),
                                           st.one_of(st.none(), st.floats(0, 4000)), st.booleans(), st.booleans(),
                                           st.floats(0, 3650)), number)


@SETTINGS
@given(joint=st.one_of(st.text(max_size=8), number), estimate=maybe_pair, forecast=forecasts,
       quiet=st.one_of(st.integers(-5, 10**6), number), last=st.one_of(st.none(), number), now=number,
       cycle=maybe_pair)
def test_policy_never_raises_anything_but_input_data_error(joint: object, estimate: object, forecast: object,
                                                           quiet: object, last: object, now: object,
                                                           cycle: object) -> None:
    try:
        d = OnDemandPolicy().decide(joint, estimate, forecast, quiet_shifts=quiet,  # type: ignore[arg-type]
                                    last_cycle_time=last, now=now, last_cycle_estimate=cycle)  # type: ignore[arg-type]
    except InputDataError as exc:
        assert "\n" not in str(exc)
        return
    assert isinstance(d, Decision) and d.kind in ("straddle", "crossing", "quiet", "none")
    assert d.ask == (d.ask and d.kind != "none")
    assert d.reason.startswith(f"{joint}: ") and "\n" not in d.reason


@pytest.mark.parametrize("joint", ["", "joint\n2", 2])
def test_a_joint_name_is_one_printable_line(joint: object) -> None:
    with pytest.raises(InputDataError, match="joint name"):
        OnDemandPolicy().decide(joint, (10.0, 1.0), None, quiet_shifts=0,  # type: ignore[arg-type]
                                last_cycle_time=None, now=NOW)


wear = st.floats(-50.0, 150.0)
stds = st.floats(0.0, 50.0)
estimates = st.one_of(st.none(), st.tuples(wear, stds),
                      st.tuples(st.sampled_from([math.nan, math.inf, -math.inf]), stds))
good_forecasts = st.one_of(st.none(), st.builds(forecast_of, st.one_of(st.none(), st.floats(0, 4000)),
                                                st.one_of(st.none(), st.floats(0, 4000)),
                                                st.one_of(st.none(), st.floats(0, 4000)), st.booleans(),
                                                st.booleans(), st.floats(0, 3650)))


@SETTINGS
@given(estimate=estimates, forecast=good_forecasts, quiet=st.integers(0, 10_000),
       ago=st.one_of(st.none(), st.floats(0.0, 400.0)), cycle=st.one_of(st.none(), st.tuples(wear, stds)))
def test_policy_decides_every_well_formed_input_and_asks_only_for_a_reason(
        estimate: tuple[float, float] | None, forecast: object, quiet: int, ago: float | None,
        cycle: tuple[float, float] | None) -> None:
    d = decide(estimate, forecast, quiet=quiet, last=ago, cycle=cycle)
    finite = estimate is not None and all(math.isfinite(x) for x in estimate)
    if d.kind == "straddle":
        assert finite
        assert estimate is not None
        lo, hi = estimate[0] - 1.645 * estimate[1], estimate[0] + 1.645 * estimate[1]
        assert any(lo < thr <= hi for thr in (WARN, ALARM))
    if d.kind == "quiet":
        assert quiet >= OnDemandConfig().max_quiet_shifts
    if d.ask and ago is not None and cycle is not None:
        assert cycle[0] < ALARM  # a cycle that gave ERROR ends the asks
    if ago is None and d.kind != "none":
        assert d.ask  # never tested: nothing holds an ask back
    assert d.reason.startswith("joint_2: ") and "\n" not in d.reason
