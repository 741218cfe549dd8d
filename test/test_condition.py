"""One condition level, one rule; only evidence moves it (jointwear_ros.condition, the monitor, the trend).

The done-when of "one alarm, one meaning": a FAILED cycle with 1 of 8 speeds, a cycle with no observation and
one outlier estimate 20 above a flat history leave a joint's level as it was; a step confirmed by a second
estimate moves it at once; the wear_estimator's monitor and the trend over the same estimates say the same.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jointwear_ros.condition import (
    ALARM,
    WARN,
    Z_ONE_SIDED,
    condition_level,
    confirm,
    evidence_of,
    forecast_of,
    min_speeds,
    standing,
)
from jointwear_ros.contract import CycleState, CycleStatus, DiagnosticLevel
from jointwear_ros.model import load_parameter_set, paper_wear_model
from jointwear_ros.monitor import MonitorConfig, WearMonitor
from jointwear_ros.observer import FrictionObservationData
from jointwear_ros.trend import analyze_joint

OK, WARN_, ERROR, STALE = DiagnosticLevel.OK, DiagnosticLevel.WARN, DiagnosticLevel.ERROR, DiagnosticLevel.STALE
MODEL, PARAMS = paper_wear_model(), load_parameter_set("ref-2011r")
EIGHT = (20.0, 40.0, 60.0, 80.0, 100.0, 130.0, 160.0, 200.0)
DAY = 86400.0


# ---------------------------------------------------------------------------- the rule


@given(st.floats(-50, 150), st.floats(0.0, 40.0))
def test_the_rule_orders_levels_by_wear_and_by_uncertainty(w, s):
    lv = condition_level(w, s)
    if w >= ALARM:
        assert lv == ERROR
    elif w >= WARN or w + Z_ONE_SIDED * s >= ALARM:
        assert lv == WARN_
    else:
        assert lv == OK
    # more wear never lowers the level; more uncertainty never lowers it below the alarm
    assert condition_level(w + 1.0, s) >= lv
    if w < ALARM:
        assert condition_level(w, s + 1.0) >= lv


def test_no_finite_wear_has_no_level():
    assert condition_level(math.nan, 1.0) is None and condition_level(math.inf, 1.0) is None


@given(st.lists(st.tuples(st.floats(0, 100), st.floats(0.1, 10)), min_size=1, max_size=12))
def test_confirmation_never_lets_one_estimate_move_the_level_alone(seq):
    times = [float(i) for i in range(len(seq))]
    conf = confirm(seq, times)
    stand = [c.standing for c in conf]
    assert stand[0] == 0
    for i in range(1, len(seq)):
        if stand[i] == i and stand[i - 1] != i - 1 and conf[i].status == "step":
            # a step: the held estimate and this one agree
            assert conf[i - 1].status == "step"
        # the standing estimate is always this one or an earlier one
        assert stand[i] is not None and stand[i] <= i


def test_an_outlier_is_held_then_refuted_and_a_step_is_confirmed_by_the_next_estimate():
    flat = [(10.0, 1.0)] * 5
    conf = confirm([*flat, (30.0, 1.0), (10.2, 1.0)], list(range(7)))
    assert [c.status for c in conf][-2:] == ["outlier", "confirmed"] and conf[-1].standing == 6
    conf = confirm([*flat, (30.0, 1.0), (30.4, 1.0)], list(range(7)))
    assert [c.status for c in conf][-2:] == ["step", "step"] and conf[-2].standing == 4 and conf[-1].standing == 6


def test_growth_between_estimates_far_apart_is_not_an_outlier():
    conf = confirm([(10.0, 1.0), (25.0, 1.0)], [0.0, 20.0])  # 15 in 20 days: 0.75 / day
    assert [c.status for c in conf] == ["confirmed", "confirmed"]


def test_evidence_and_the_speeds_a_level_needs():
    assert min_speeds(temperature_known=False) == 3 and min_speeds(temperature_known=True) == 1
    assert evidence_of(8, 8, False, False) == "complete"
    assert evidence_of(4, 8, True, False) == "partial"
    assert evidence_of(8, 8, True, False) == "partial"  # FAILED after its last speed: still partial
    assert evidence_of(1, 8, True, False) == "insufficient" and evidence_of(1, 8, True, True) == "partial"


def test_standing_leaves_out_insufficient_estimates_and_says_why():
    s = standing([12.0, 60.0], [1.0, 7.6], [0.0, 1.0], ["complete", "insufficient"])
    assert s.level == OK and s.wear == 12.0 and "too few speeds" in s.reason
    s = standing([60.0], [7.6], [0.0], ["insufficient"])
    assert s.level is None


def test_the_forecast_is_separate_from_the_level():
    f = forecast_of(40.0, 20.0, 90.0, True, True, 30.0)
    assert f.expected_within_horizon and f.state == "within_horizon"
    assert not forecast_of(40.0, 35.0, 90.0, True, True, 30.0).expected_within_horizon
    assert forecast_of(None, None, None, False, True, 30.0).state == "no_growth"
    assert forecast_of(None, None, None, False, False, 30.0).state == "no_trend"


# ---------------------------------------------------------------------------- the live monitor


def _obs(cycle_id, wear, speeds=EIGHT, t0=0.0, temperature=math.nan):
    out = []
    for i, v in enumerate(speeds):
        tau = float(MODEL.evaluate(PARAMS, speed=v, load_torque=0.1, temperature=40.0, wear=wear))
        out.append(FrictionObservationData(
            stamp=t0 + i, joint_name="joint_1", cycle_id=cycle_id, speed=v, tau_f=tau, tau_f_std=3e-4,
            tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1, temperature=temperature, position=0.0,
            samples_plus=500, samples_minus=500))
    return out


def _cycle(mon, cid, wear, *, speeds=EIGHT, end=CycleState.DONE, reason="", day=None, temperature=math.nan):
    t0 = (cid if day is None else day) * DAY
    mon.on_status(CycleStatus(cycle_id=cid, state=CycleState.RUNNING, speeds_total=len(EIGHT), joint_name="joint_1"), now=t0)
    out = []
    for o in _obs(cid, wear, speeds, t0 + 1.0, temperature):
        out += mon.add(o)
    out += mon.on_status(CycleStatus(cycle_id=cid, state=end, speeds_done=len(speeds), speeds_total=len(EIGHT), joint_name="joint_1", message=reason), now=t0 + 20.0)
    out += mon.poll(t0 + 100.0)
    return out[-1]


def _flat_history(mon, n=4, wear=10.0, temperature=math.nan):
    for cid in range(1, n + 1):
        r = _cycle(mon, cid, wear, temperature=temperature)
        assert r.level == OK and r.evidence == "complete" and r.confirmation == "confirmed", r.message
    return r


def test_a_failed_cycle_with_one_speed_leaves_the_level_as_it_was_and_names_test_cycles_reason():
    mon = WearMonitor(MonitorConfig(seed=1, done_timeout=5.0))
    _flat_history(mon)
    r = _cycle(mon, 5, 0.0, speeds=EIGHT[:1], end=CycleState.FAILED, reason="effort limit exceeded at 20 rad/s")
    assert r.result is None and r.level == OK and r.stale and r.evidence == "insufficient"
    assert "1 speed(s) observed; a wear level needs 3" in r.message
    assert "test_cycle: effort limit exceeded at 20 rad/s" in r.message and "friction_observer" not in r.message


def test_a_cycle_with_no_observation_leaves_the_level_as_it_was():
    mon = WearMonitor(MonitorConfig(seed=1, done_timeout=5.0))
    for cid in range(1, 4):
        assert _cycle(mon, cid, 40.0).level == ERROR
    mon.on_status(CycleStatus(cycle_id=9, state=CycleState.RUNNING, speeds_total=8, joint_name="joint_1"), now=10 * DAY)
    mon.on_status(CycleStatus(cycle_id=9, state=CycleState.ABORTED, speeds_total=8, joint_name="joint_1", message="operator stop"), now=10 * DAY + 5)
    (r,) = mon.poll(10 * DAY + 60)
    assert r.result is None and r.level == ERROR and r.alarm and r.stale  # the alarm is never hidden by a failure
    assert "operator stop" in r.message


def test_a_partial_cycle_with_enough_speeds_stands_marked_partial():
    mon = WearMonitor(MonitorConfig(seed=1, done_timeout=5.0))
    r = _cycle(mon, 1, 5.0, speeds=EIGHT[:4], end=CycleState.FAILED, reason="effort limit")
    assert r.result is not None and r.evidence == "partial" and r.level == OK
    assert "partial: 4 of 8 speeds" in r.message and dict(r.values)["evidence"] == "partial"


def test_one_outlier_20_above_a_flat_history_is_held_and_a_confirmed_step_moves_the_level_at_once():
    mon = WearMonitor(MonitorConfig(seed=1, done_timeout=5.0))
    _flat_history(mon, wear=15.0, temperature=40.0)
    r = _cycle(mon, 5, 35.0 + 2.0, temperature=40.0)
    assert r.result is not None and r.result.wear > 35 and r.confirmation == "unconfirmed"
    assert r.level == OK and not r.alarm and "held unconfirmed" in r.message
    r = _cycle(mon, 6, 15.0, temperature=40.0)
    assert r.level == OK and r.confirmation == "confirmed"  # the outlier was refuted
    r = _cycle(mon, 7, 37.0, temperature=40.0)
    assert r.level == OK and r.confirmation == "unconfirmed"
    r = _cycle(mon, 8, 37.0, temperature=40.0)
    assert r.level == ERROR and r.alarm and r.confirmation == "step" and "step confirmed" in r.message


@pytest.mark.parametrize("temperature", [40.0, math.nan])
def test_the_monitor_and_the_trend_agree_on_the_same_estimates(temperature):
    """The wear_estimator (monitor) and the trend (history) apply the same rule to the same sequence."""
    mon = WearMonitor(MonitorConfig(seed=1, done_timeout=5.0))
    wears = [10.0, 10.0, 11.0, 33.0, 11.0, 12.0, 31.0, 31.5, 32.0, 45.0, 46.0]
    times, w, s, seen = [], [], [], []
    for k, x in enumerate(wears, start=1):
        r = _cycle(mon, k, x, temperature=temperature)
        times.append(k * DAY + 20.0)
        w.append(r.result.wear)
        s.append(r.result.wear_std)
        trend = analyze_joint(times, w, s, cycle_ids=list(range(1, k + 1)))
        assert trend.level == r.level, (k, r.message, trend.message)
        assert trend.confirmation == r.confirmation and trend.level_wear == pytest.approx(r.standing_wear)
        seen.append((DiagnosticLevel(r.level).name, r.confirmation))
    if temperature == 40.0:  # sharp estimates: the lone 33 and the first 45 are held
        assert seen[3] == ("OK", "unconfirmed") and seen[4] == ("OK", "confirmed")
        assert seen[9] == ("WARN", "unconfirmed") and seen[10] == ("ERROR", "step")
    assert seen[-1][0] == "ERROR"


def test_a_trend_leaves_a_held_outlier_out_of_its_fit_and_shows_it():
    t = 1.7e9 + DAY * np.arange(30)
    w = np.full(30, 12.0)
    w[-1] = 32.0
    r = analyze_joint(t, w, np.full(30, 0.85))
    assert r.level == OK and r.confirmation == "unconfirmed" and r.held[-1][1] == 32.0
    assert r.estimates == 29 and abs(r.wear - 12.0) < 0.5
    assert r.as_dict()["condition"]["held"][-1]["status"] == "unconfirmed"


@pytest.mark.parametrize("evidence", ["partial", "complete"])
def test_a_partial_estimate_stands_in_the_trend_and_says_so(evidence):
    t = 1.7e9 + DAY * np.arange(6)
    r = analyze_joint(t, np.full(6, 31.0), np.full(6, 0.85), evidence=["complete"] * 5 + [evidence])
    assert r.level == WARN_ and r.evidence == evidence


def test_estimate_cli_conditions_equal_the_trends_over_the_same_cycles():
    """``jointwear estimate``'s level column (commission.estimate.conditions) is the rule the trend applies."""
    from jointwear_ros.commission.estimate import CycleEstimate, conditions
    from jointwear_ros.types import WearResult

    wears = [10.0, 10.5, 31.0, 11.0, 30.5, 31.0, 12.0, 48.0, 47.5]
    cycles = [CycleEstimate("t.csv", "joint_2", k, 1.7e9 + k * DAY, WearResult(w, 0.8, w - 1.6, w + 1.6, "joint"))
              for k, w in enumerate(wears, start=1)]
    cycles.insert(3, CycleEstimate("t.csv", "joint_2", 99, 1.7e9 + 3.5 * DAY, WearResult(70.0, 9.0, 52.0, 88.0, "joint"),
                                   evidence="insufficient"))
    conds = conditions(cycles, WARN, ALARM)
    for k in range(1, len(cycles) + 1):
        seen = cycles[:k]
        r = analyze_joint([c.time for c in seen], [c.result.wear for c in seen], [c.result.wear_std for c in seen],
                          cycle_ids=[c.cycle for c in seen], evidence=[c.evidence for c in seen])
        assert conds[k - 1].level == r.level_name, (k, conds[k - 1], r.message)
    assert conds[3].evidence == "insufficient" and conds[3].level == "OK"  # 70 from too few speeds: no level
    assert [c.confirmation for c in conds][-2:] == ["unconfirmed", "step"] and conds[-1].level == "ERROR"


def test_a_partial_estimate_stays_partial_through_the_store_and_a_csv_round_trip(tmp_path):
    """Evidence is data: stored, exported, imported back; a table without the column is complete; a bad cell is
    refused in one line."""
    from jointwear_ros.errors import InputDataError
    from jointwear_ros.history import EstimateRecord, HistoryStore
    from jointwear_ros.history.importers import estimates_from_csv, write_csv

    recs = [EstimateRecord("cell_1", "joint_4", cycle_id=k, time=1.7e9 + k * DAY, wear=12.0, wear_std=0.8,
                           evidence="partial" if k == 3 else "complete") for k in (1, 2, 3)]
    with HistoryStore(f"sqlite:///{tmp_path / 'h.db'}") as store:
        store.add_estimates(recs)
        stored = store.estimates(robot="cell_1", joint="joint_4")
    assert [r.evidence for r in stored] == ["complete", "complete", "partial"]
    write_csv(stored, tmp_path / "h.csv")
    assert [r.evidence for r in estimates_from_csv(tmp_path / "h.csv")] == ["complete", "complete", "partial"]
    (tmp_path / "old.csv").write_text("robot,joint,time,wear,wear_std\ncell_1,joint_4,2026-01-01T00:00:00Z,12,0.8\n")
    assert estimates_from_csv(tmp_path / "old.csv")[0].evidence == "complete"
    (tmp_path / "bad.csv").write_text("robot,joint,time,wear,wear_std,evidence\n"
                                      "cell_1,joint_4,2026-01-01T00:00:00Z,12,0.8,maybe\n")
    with pytest.raises(InputDataError, match="bad.csv:2: evidence = 'maybe'"):
        estimates_from_csv(tmp_path / "bad.csv")


def test_a_complete_cycle_that_sweeps_a_speed_twice_is_complete_and_one_missing_step_is_partial():
    """A line cycle stretches a joint's shorter set over its steps (four speeds over eight steps: each twice), and a
    request may name a speed twice: every step observed is a complete cycle, though it has fewer speed levels than
    steps; one step short is partial ("7 of 8 steps")."""
    twice = tuple(v for v in EIGHT[::2] for _ in range(2))
    mon = WearMonitor(MonitorConfig(seed=1, done_timeout=5.0))
    r = _cycle(mon, 1, 10.0, speeds=twice)
    assert r.result is not None and r.evidence == "complete" and "partial" not in r.message, r.message
    r = _cycle(mon, 2, 10.0, speeds=twice[:-1], end=CycleState.FAILED, reason="effort limit")
    assert r.evidence == "partial" and "partial: 7 of 8 steps (4 speeds)" in r.message, r.message
