"""The wear monitor: estimates per cycle, thresholds, timeouts, determinism."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from jointwear_ros.contract import CycleState, CycleStatus, DiagnosticLevel
from jointwear_ros.errors import InputDataError
from jointwear_ros.model import load_parameter_set, paper_wear_model
from jointwear_ros.monitor import MonitorConfig, WearMonitor, diagnostic_level
from jointwear_ros.observer import FrictionObservationData
from jointwear_ros.types import WearResult

SPEEDS = (30.0, 40.0, 50.0)
MODEL, PARAMS = paper_wear_model(), load_parameter_set("ref-2011r")


def _obs(cycle_id: int, wear: float, temperature: float = math.nan, speeds=SPEEDS, t0: float = 10.0):
    out = []
    for i, v in enumerate(speeds):
        tau = float(MODEL.evaluate(PARAMS, speed=v, load_torque=0.1, temperature=40.0, wear=wear))
        out.append(FrictionObservationData(
            stamp=t0 + i, joint_name="joint_1", cycle_id=cycle_id, speed=v, tau_f=tau, tau_f_std=3e-4,
            tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1, temperature=temperature, position=0.0,
            samples_plus=500, samples_minus=500))
    return out


def _run(monitor, cycle_id, wear, **kw):
    monitor.on_status(CycleStatus(cycle_id=cycle_id, state=CycleState.RUNNING, speeds_total=len(SPEEDS), joint_name="joint_1"), now=9.0)
    results = []
    for o in _obs(cycle_id, wear, **kw):
        results += monitor.add(o)
    return results


def test_levels_at_the_thresholds():
    assert diagnostic_level(29.999, 0.1, 30, 35) == DiagnosticLevel.OK
    assert diagnostic_level(30.0, 0.1, 30, 35) == DiagnosticLevel.WARN
    assert diagnostic_level(34.999, 0.1, 30, 35) == DiagnosticLevel.WARN
    assert diagnostic_level(35.0, 0.1, 30, 35) == DiagnosticLevel.ERROR
    # the uncertainty counts: an estimate that cannot rule out the alarm is WARN, whatever its point value
    assert diagnostic_level(25.0, 7.0, 30, 35) == DiagnosticLevel.WARN
    assert diagnostic_level(25.0, 6.0, 30, 35) == DiagnosticLevel.OK
    assert diagnostic_level(float("nan"), 1.0, 30, 35) == DiagnosticLevel.STALE


@pytest.mark.parametrize(("wear", "level"), [(5.0, DiagnosticLevel.OK), (32.5, DiagnosticLevel.WARN), (45.0, DiagnosticLevel.ERROR)])
def test_monitor_estimates_a_complete_cycle_with_its_level(wear, level):
    mon = WearMonitor(MonitorConfig(seed=1))
    results = _run(mon, 7, wear, temperature=40.0)
    assert len(results) == 1
    r = results[0]
    assert isinstance(r.result, WearResult)
    assert r.result.wear == pytest.approx(wear, abs=0.5)
    assert r.level == level and r.cycle_id == 7
    keys = dict(r.values)
    for k in ("wear", "wear_std", "method", "cycle_id", "temperature_estimate", "n_observations"):
        assert k in keys
    assert keys["method"] == mon.config.method and keys["cycle_id"] == "7" and keys["n_observations"] == "3"
    assert r.alarm == (level == DiagnosticLevel.ERROR)
    assert mon.last is r


def test_monitor_thresholds_are_configurable():
    mon = WearMonitor(MonitorConfig(warn_threshold=10.0, alarm_threshold=20.0))
    assert _run(mon, 1, 15.0, temperature=40.0)[0].level == DiagnosticLevel.WARN


def test_unknown_temperature_uses_the_uncertain_temperature_estimator():
    mon = WearMonitor(MonitorConfig(method="paper", seed=3))
    r = _run(mon, 1, 35.0)[0]
    assert r.result is not None and r.result.info["known_temperature"] == [False] * 3
    assert abs(r.result.wear - 35.0) < 3 * r.result.wear_std + 1.0
    assert 0.5 < r.result.wear_std < 4.0  # honest, and bounded: a huge std would pass the line above
    mon2 = WearMonitor(MonitorConfig(method="paper", seed=3, use_measured_temperature=False))
    r2 = _run(mon2, 1, 35.0, temperature=40.0)[0]
    assert r2.result is not None and r2.result.info["known_temperature"] == [False] * 3


def test_cycle_is_estimated_after_timeout_following_done():
    mon = WearMonitor(MonitorConfig(done_timeout=2.0))
    mon.on_status(CycleStatus(cycle_id=4, state=CycleState.RUNNING, speeds_total=5, joint_name="joint_1"), now=9.0)
    for o in _obs(4, 20.0, temperature=40.0):
        assert mon.add(o) == []
    assert mon.on_status(CycleStatus(cycle_id=4, state=CycleState.DONE, speeds_done=5, speeds_total=5, joint_name="joint_1"), now=20.0) == []
    assert mon.poll(21.9) == []
    results = mon.poll(22.0)
    assert len(results) == 1 and results[0].level == DiagnosticLevel.OK
    assert "3 of 5 speeds observed" in results[0].message
    assert mon.poll(30.0) == []  # once only
    assert mon.add(_obs(4, 20.0)[0]) == [] and "received twice" in mon.ignored[-1]


def test_a_late_observation_revises_the_cycle_estimate():
    mon = WearMonitor(MonitorConfig(done_timeout=2.0, seed=5))
    speeds = (20.0, 30.0, 40.0, 50.0)
    obs = _obs(4, 36.0, temperature=40.0, speeds=speeds)
    mon.on_status(CycleStatus(cycle_id=4, state=CycleState.RUNNING, speeds_total=4, joint_name="joint_1"), now=9.0)
    for o in obs[:3]:
        assert mon.add(o) == []
    mon.on_status(CycleStatus(cycle_id=4, state=CycleState.DONE, speeds_done=4, speeds_total=4, joint_name="joint_1"), now=20.0)
    (first,) = mon.poll(22.0)
    assert first.revision == 0 and "3 of 4 speeds observed" in first.message
    assert "revision" not in dict(first.values)
    (rev,) = mon.add(obs[3], now=22.5)  # the last speed, after the estimate
    assert rev.cycle_id == 4 and rev.revision == 1 and mon.last is rev
    assert "revision 1" in rev.message and "late observation(s) at 50 rad/s" in rev.message
    assert "speeds observed" not in rev.message
    assert dict(rev.values)["revision"] == "1" and dict(rev.values)["n_observations"] == "4"
    assert rev.result is not None and rev.result.speeds == speeds
    # the revision equals what an on-time cycle with all four speeds gives
    on_time = WearMonitor(MonitorConfig(done_timeout=2.0, seed=5))
    on_time.on_status(CycleStatus(cycle_id=4, state=CycleState.RUNNING, speeds_total=4, joint_name="joint_1"), now=9.0)
    (full,) = [r for o in obs for r in on_time.add(o)]
    assert full.result is not None and rev.result.wear == full.result.wear
    # a repeat, and an observation beyond the cycle's speeds, are ignored with the reason
    assert mon.add(obs[3]) == [] and "received twice" in mon.ignored[-1]
    extra = replace(obs[0], speed=60.0, stamp=30.0)
    assert mon.add(extra) == [] and "already has all 4 speeds" in mon.ignored[-1]


def test_a_cycle_id_reused_after_a_test_cycle_restart_is_a_new_cycle():
    mon = WearMonitor(MonitorConfig(seed=4))
    (old,) = _run(mon, 1, 10.0, temperature=40.0)
    # test_cycle restarted: its next cycle is cycle 1 again, RUNNING, at another wear
    (new,) = _run(mon, 1, 45.0, temperature=40.0)
    assert "reuses the id" in mon.ignored[-1]
    assert new.revision == 0 and new.result is not None and new.result.wear == pytest.approx(45.0, abs=0.5)
    assert old.result is not None and old.result.wear == pytest.approx(10.0, abs=0.5)
    assert mon.last is new


def test_a_revision_of_an_older_cycle_does_not_replace_the_newest_status():
    mon = WearMonitor(MonitorConfig(done_timeout=1.0, seed=6))
    speeds = (20.0, 30.0, 40.0, 50.0)
    late = _obs(2, 20.0, temperature=40.0, speeds=speeds)
    mon.on_status(CycleStatus(cycle_id=2, state=CycleState.RUNNING, speeds_total=4, joint_name="joint_1"), now=1.0)
    for o in late[:3]:
        mon.add(o)
    mon.on_status(CycleStatus(cycle_id=2, state=CycleState.DONE, speeds_done=4, speeds_total=4, joint_name="joint_1"), now=5.0)
    (first,) = mon.poll(7.0)
    assert mon.last is first and "3 of 4 speeds observed" in first.message
    (newer,) = _run(mon, 3, 40.0, temperature=40.0)
    assert mon.last is newer
    (rev,) = mon.add(late[3], now=60.0)  # cycle 2's last speed, very late
    assert rev.cycle_id == 2 and rev.revision == 1
    assert mon.last is newer  # the status stays with the newest cycle


def test_finished_cycles_are_remembered_up_to_a_bound():
    mon = WearMonitor(MonitorConfig(seed=2))
    mon.max_finished_cycles = 4
    for cid in range(1, 8):
        assert len(_run(mon, cid, 10.0, temperature=40.0)) == 1
    assert len(mon._finished) <= 4 and ("test_cycle", 7) in mon._finished


def test_aborted_cycle_without_observations_gives_no_level_and_names_the_cycles_reason():
    mon = WearMonitor(MonitorConfig(done_timeout=1.0))
    mon.on_status(CycleStatus(cycle_id=9, state=CycleState.RUNNING, speeds_total=8, joint_name="joint_1"), now=1.0)
    mon.on_status(CycleStatus(cycle_id=9, state=CycleState.ABORTED, speeds_total=8, joint_name="joint_1", message="effort limit 12 N·m exceeded"), now=2.0)
    (r,) = mon.poll(3.5)
    assert r.result is None and r.level == DiagnosticLevel.STALE and r.stale and not r.alarm
    assert "ABORTED" in r.message and "no usable friction observation" in r.message
    assert "test_cycle: effort limit 12 N·m exceeded" in r.message and "friction_observer" not in r.message


def test_cycle_without_status_is_estimated_after_idle_timeout():
    mon = WearMonitor(MonitorConfig(idle_timeout=5.0))
    for o in _obs(2, 10.0, temperature=40.0):
        assert mon.add(o) == []
    assert mon.poll(16.0) == []
    (r,) = mon.poll(17.0)
    assert r.result is not None and r.level == DiagnosticLevel.OK


def test_estimate_is_deterministic_and_independent_of_arrival_order():
    a = WearMonitor(MonitorConfig(seed=11))
    b = WearMonitor(MonitorConfig(seed=11))
    ra = _run(a, 5, 33.0)[0]
    b.on_status(CycleStatus(cycle_id=5, state=CycleState.RUNNING, speeds_total=len(SPEEDS), joint_name="joint_1"), now=9.0)
    rb = next(r for o in reversed(_obs(5, 33.0)) for r in b.add(o))
    assert ra.result is not None and rb.result is not None
    assert ra.result.wear == rb.result.wear and ra.result.wear_std == rb.result.wear_std
    assert ra.values == rb.values
    c = WearMonitor(MonitorConfig(seed=12))
    rc = _run(c, 5, 33.0)[0]
    assert rc.result is not None and rc.result.wear != ra.result.wear  # the seed matters (T unknown)


def test_observations_of_another_joint_are_ignored():
    mon = WearMonitor()
    o = replace(_obs(1, 10.0)[0], joint_name="joint_2")
    assert mon.add(o) == [] and mon.open_cycles == ()


def test_estimator_failure_is_reported_not_raised():
    def broken(method, seed):
        class E:
            name = "broken"

            def estimate(self, table):
                raise InputDataError("no good")

        return E()

    mon = WearMonitor(MonitorConfig(), estimator_factory=broken)
    (r,) = _run(mon, 1, 10.0)
    assert r.result is None and r.level == DiagnosticLevel.STALE and r.stale and "no good" in r.message


def test_config_rejects_inverted_thresholds():
    with pytest.raises(InputDataError, match="warn_threshold <= alarm_threshold"):
        MonitorConfig(warn_threshold=40.0, alarm_threshold=35.0)


def test_unknown_method_is_reported():
    mon = WearMonitor(MonitorConfig(method="nonsense"))
    (r,) = _run(mon, 1, 10.0)
    assert r.result is None and "unknown wear estimation method" in r.message


def test_estimator_gets_the_window_std_plus_the_sweep_to_sweep_scatter():
    seen = []

    def spy(method, seed):
        class E:
            name = "spy"

            def estimate(self, table):
                seen.append(table["tau_f_std"].copy())
                return WearResult(wear=1.0, wear_std=0.1, wear_low=0.8, wear_high=1.2, method="spy")

        return E()

    mon = WearMonitor(MonitorConfig(observation_noise_std=0.0015), estimator_factory=spy)
    (r,) = _run(mon, 1, 10.0)
    assert r.level == DiagnosticLevel.OK and seen[0] == pytest.approx([math.hypot(3e-4, 0.0015)] * 3)


def _fixed(wear):
    """An estimator factory whose estimate is exactly ``wear`` (to probe the thresholds)."""
    def factory(method, seed):
        class E:
            name = "fixed"

            def estimate(self, table):
                return WearResult(wear=wear, wear_std=0.5, wear_low=wear - 1, wear_high=wear + 1, method="fixed")

        return E()

    return factory


@pytest.mark.parametrize(("wear", "level", "alarm"), [
    (29.999, DiagnosticLevel.OK, False), (30.0, DiagnosticLevel.WARN, False), (34.999, DiagnosticLevel.WARN, False), (35.0, DiagnosticLevel.ERROR, True), (35.001, DiagnosticLevel.ERROR, True)])
def test_level_and_alarm_at_exactly_the_thresholds(wear, level, alarm):
    (r,) = _run(WearMonitor(MonitorConfig(), estimator_factory=_fixed(wear)), 1, 10.0)
    assert r.level == level and r.alarm is alarm
    assert r.result is not None and r.result.wear == wear


# -- screening: a bad observation is dropped (or its temperature made unknown), the cycle still estimated --
@pytest.mark.parametrize("temperature", [-300.0, 1000.0, math.inf, -math.inf, 70.0, 5.0])
def test_one_impossible_temperature_does_not_hide_the_alarm(temperature):
    mon = WearMonitor(MonitorConfig(seed=1, use_measured_temperature=True))
    mon.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=3, joint_name="joint_1"), now=9.0)
    obs = _obs(1, 40.0, temperature=40.0)
    obs[1] = replace(obs[1], temperature=temperature)
    (r,) = [x for o in obs for x in mon.add(o)]
    assert r.level == DiagnosticLevel.ERROR and r.alarm
    assert r.result is not None and r.result.wear == pytest.approx(40.0, abs=1.5)
    assert 0.5 < r.result.wear_std < 5.0  # an honest spread, not the std near 0 of the bug
    assert r.result.info["known_temperature"] == [True, False, True]
    assert r.rejected == () and len(r.temperature_unknown) == 1
    assert dict(r.values)["temperatures_unknown"] == "1" and "observations_rejected" not in dict(r.values)
    assert "used as unknown" in r.message and "used as unknown" in mon.ignored[-1]
    assert dict(r.values)["n_observations"] == "3"


@pytest.mark.parametrize(("field", "value", "why"), [
    ("speed", -40.0, "speed -40 rad/s must be finite and > 0"), ("speed", 0.0, "speed 0 rad/s"),
    ("speed", math.nan, "speed nan"), ("speed", math.inf, "speed inf"), ("speed", 400.0, "valid range [0, 280]"),
    ("tau_f", math.nan, "tau_f nan"), ("tau_f", -0.05, "is negative"), ("tau_f_std", -1e-3, "tau_f_std -0.001"),
    ("tau_f_std", math.inf, "tau_f_std inf"), ("load_torque", math.nan, "load_torque nan"),
    ("load_torque", 3.0, "|load_torque| 3")])
def test_a_non_physical_observation_is_dropped_and_the_rest_estimated(field, value, why):
    mon = WearMonitor(MonitorConfig(seed=1))
    mon.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=3, joint_name="joint_1"), now=9.0)
    obs = _obs(1, 40.0, temperature=40.0)
    obs[1] = replace(obs[1], **{field: value})
    results = [x for o in obs for x in mon.add(o)]
    (r,) = results  # the dropped one still counts: the cycle completes at its third observation
    assert r.level == DiagnosticLevel.ERROR and r.alarm and r.result is not None
    assert r.result.speeds == (30.0, 50.0)
    assert r.result.wear == pytest.approx(40.0, abs=1.5)
    assert len(r.rejected) == 1 and why in r.rejected[0] and "dropped" in r.rejected[0]
    assert dict(r.values)["observations_rejected"] == "1" and dict(r.values)["n_observations"] == "2"
    assert "1 observation(s) rejected" in r.message and why in r.message
    assert mon.rejected_count == 1 and why in mon.ignored[-1]


def test_a_cycle_whose_observations_are_all_dropped_gives_no_level_with_the_reasons():
    mon = WearMonitor(MonitorConfig(seed=1))
    mon.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=3, joint_name="joint_1"), now=9.0)
    (r,) = [x for o in _obs(1, 40.0) for x in mon.add(replace(o, tau_f=math.nan))]
    assert r.result is None and r.level == DiagnosticLevel.STALE and r.stale and not r.alarm
    assert "no usable friction observation" in r.message and "3 observation(s) rejected" in r.message


def test_nan_tau_f_std_means_not_given_and_is_kept():
    mon = WearMonitor(MonitorConfig(seed=1))
    mon.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=3, joint_name="joint_1"), now=9.0)
    (r,) = [x for o in _obs(1, 40.0, temperature=40.0) for x in mon.add(replace(o, tau_f_std=math.nan))]
    assert r.rejected == () and r.result is not None and r.level == DiagnosticLevel.ERROR


@pytest.mark.parametrize("method", ["paper", "joint", "bayes"])
def test_a_revision_with_a_middle_speed_late_equals_the_on_time_estimate_exactly(method):
    # the observer can finish a speed of a joint after later ones (a window waiting for its temperature,
    # a loaded machine): the estimate of every observation must not depend on the order they came in,
    # or a replay (which may hear them in another order) differs from the live estimate
    speeds = (20.0, 30.0, 40.0, 50.0, 60.0)
    obs = _obs(7, 33.0, temperature=40.0, speeds=speeds)
    late = WearMonitor(MonitorConfig(done_timeout=2.0, seed=5, method=method))
    late.on_status(CycleStatus(cycle_id=7, state=CycleState.RUNNING, speeds_total=5, joint_name="joint_1"), now=9.0)
    for o in (obs[0], obs[2], obs[3], obs[4]):
        assert late.add(o) == []
    late.on_status(CycleStatus(cycle_id=7, state=CycleState.DONE, speeds_done=5, speeds_total=5, joint_name="joint_1"), now=20.0)
    (partial,) = late.poll(22.5)
    assert partial.revision == 0 and "4 of 5 speeds observed" in partial.message
    (rev,) = late.add(obs[1], now=23.0)
    assert rev.revision == 1 and rev.result is not None
    on_time = WearMonitor(MonitorConfig(done_timeout=2.0, seed=5, method=method))
    on_time.on_status(CycleStatus(cycle_id=7, state=CycleState.RUNNING, speeds_total=5, joint_name="joint_1"), now=9.0)
    (full,) = [r for o in obs for r in on_time.add(o)]
    assert full.result is not None
    assert (rev.result.wear, rev.result.wear_std) == (full.result.wear, full.result.wear_std)
    assert rev.result.speeds == full.result.speeds == speeds


def test_a_cycle_the_model_cannot_explain_says_so_in_its_status():
    """At 20 degC with no sensor the default prior pins T at 25: the status names the misfit and the prior's
    edge, and carries the fit's p value; a cycle at 40 degC carries its p value and no such words."""
    speeds = (20.0, 40.0, 45.0, 55.0, 65.0, 80.0, 120.0, 160.0)

    def cycle(mon, cid, temp):
        mon.on_status(CycleStatus(cycle_id=cid, state=CycleState.RUNNING, speeds_total=len(speeds), joint_name="joint_1"), now=9.0)
        out = []
        for i, v in enumerate(speeds):
            tau = float(MODEL.evaluate(PARAMS, speed=v, load_torque=0.1, temperature=temp, wear=30.0))
            out += mon.add(FrictionObservationData(
                stamp=10.0 + i, joint_name="joint_1", cycle_id=cid, speed=v, tau_f=tau, tau_f_std=3e-4,
                tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1, temperature=math.nan, position=0.0,
                samples_plus=500, samples_minus=500))
        [r] = out
        return r, dict(r.values)

    mon = WearMonitor(MonitorConfig(method="joint", seed=1))  # the nodes' configured method
    cold, kv = cycle(mon, 1, 20.0)
    assert "unexplained" in cold.message and "edge of its prior" in cold.message
    assert float(kv["fit_p"]) < 1e-3 and kv["misfit"] in cold.message
    assert abs(cold.result.wear - 30.0) <= 3.0 * cold.result.wear_std
    warm, kv = cycle(mon, 2, 40.0)
    assert "unexplained" not in warm.message and "misfit" not in kv and float(kv["fit_p"]) > 1e-3
