"""A late control loop cannot carry a joint past its limits (pure cores: CycleRunner driving the simulated joint).

A velocity command holds until the next control update: an update that comes late (a starved
process, a simulator faster than real time) lets the joint travel on at its speed. The runner
brakes early by its own measured update interval, and the planner keeps every position of a
speed its stopping allowance inside the limits (docs/nodes-sim-cycle.md, "Late control updates").
Here the runner drives :class:`jointwear_ros.sim.JointSim` stepped at 500 Hz, the control updates
at ``control_period`` plus a configurable lateness: deterministic (seeded, no clocks).
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.cycle import (
    CycleConfig,
    CycleRequestError,
    CycleRunner,
    CycleState,
    JointReading,
    Phase,
    plan_cycle,
    run_up,
    stop_allowance,
)
from jointwear_ros.sim import JointSim, JointSimConfig

CFG = CycleConfig()
DT = 0.002  # joint_sim's default integration step (500 Hz)


def outermost_centre(cfg: CycleConfig, speed: float) -> float:
    """The largest window centre the planner accepts for ``speed`` alone (bisection on its answer)."""
    lo, hi = 0.0, cfg.joint_limits[1]
    for _ in range(60):
        mid = (lo + hi) / 2
        try:
            plan_cycle(cfg, [speed], mid, mid)
            lo = mid
        except CycleRequestError:
            hi = mid
    return lo


def run_cycle(cfg: CycleConfig, speed: float, centre: float, *, late: float = 0.0, stall: float = 0.0,
              stall_at: float = 1.0, temperature: float = 40.0, accel_limit: float | None = None):
    """Run a one-speed cycle; every control update ``late`` s after ``control_period``, and one update
    ``stall`` s later still once the forward sweep has covered ``stall_at`` of its way.

    Returns the runner, the plan and the joint's lowest and highest position (every simulation step).
    """
    sim_cfg = JointSimConfig(temperature=temperature, initial_position=centre)
    if accel_limit is not None:
        sim_cfg = replace(sim_cfg, accel_limit=accel_limit)
    sim = JointSim(sim_cfg, seed=3)
    plan = plan_cycle(cfg, [speed], centre, centre)
    sp = plan.speeds[0]
    runner = CycleRunner(cfg)
    runner.start(plan, 1, 0.0)
    next_update, stalled = 0.0, stall <= 0.0
    low = high = sim.position
    while runner.running and sim.time < 60.0:
        if sim.time + 1e-9 >= next_update:
            s = sim.sample()
            sim.set_command(runner.update(sim.time, JointReading(sim.time, s.position, s.velocity, s.effort)))
            next_update = sim.time + cfg.control_period + late
            if not stalled and runner.phase == Phase.FORWARD and s.position >= sp.start + stall_at * (sp.end - sp.start):
                stalled = True
                next_update += stall
        sim.step(DT)
        low, high = min(low, sim.position), max(high, sim.position)
    return runner, plan, low, high


@pytest.mark.parametrize("temperature", [20.0, 40.0])
def test_a_controller_late_by_the_reaction_time_at_1_6_rad_s_stays_inside_the_limits(temperature):
    # 160 rad/s motor = 1.6 rad/s joint, the window as near the upper limit as the planner allows,
    # every control update reaction_time late (110 ms apart instead of 10): the plain sqrt(2 a rem)
    # braking with only limit_margin (0.02 rad = 12.5 ms at 1.6 rad/s) left the limits here
    speed = 160.0
    centre = outermost_centre(CFG, speed)
    runner, plan, low, high = run_cycle(CFG, speed, centre, late=CFG.reaction_time, temperature=temperature)
    lo, hi = CFG.joint_limits
    assert runner.state == CycleState.DONE, runner.message
    assert lo <= low and high <= hi, (low, high, plan.extent)


@settings(max_examples=12, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(late=st.floats(0.0, 0.06), speed=st.sampled_from([40.0, 80.0, 120.0, 160.0]),
       temperature=st.sampled_from([20.0, 40.0]))
def test_the_runner_stops_at_its_targets_whatever_its_steady_lateness(late, speed, temperature):
    # braking one measured update interval early: a loop steadily late by up to 60 ms stops within 10 mrad
    # of each sweep end (the plain sqrt(2 a rem) went 20-30 mrad past at 60 ms late)
    runner, plan, low, high = run_cycle(CFG, speed, 0.0, late=late, temperature=temperature)
    sp = plan.speeds[0]
    assert runner.state == CycleState.DONE, runner.message
    assert high - sp.end <= 0.01 and sp.start - low <= 0.01, (high - sp.end, sp.start - low)


@settings(max_examples=10, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(stall_at=st.floats(0.5, 1.0), temperature=st.sampled_from([20.0, 40.0]))
def test_one_update_late_by_the_reaction_time_anywhere_in_the_braking_stays_inside_the_limits(stall_at, temperature):
    # a sudden stall the measured interval could not foresee, on a drive that brakes no harder than the
    # cycle plans (accel_limit = acceleration): what the planner's stopping allowance is for
    speed = 160.0
    centre = outermost_centre(CFG, speed)
    runner, plan, _low, high = run_cycle(CFG, speed, centre, stall=CFG.reaction_time, stall_at=stall_at,
                                        temperature=temperature, accel_limit=CFG.acceleration)
    assert runner.state == CycleState.DONE, runner.message
    assert high <= CFG.joint_limits[1], (high, plan.extent)


# -- the plan and the lead -------------------------------------------------------------
def test_the_stopping_allowance_is_the_travel_while_an_update_is_late():
    w = 1.6
    assert stop_allowance(w, CFG) == pytest.approx(w * (CFG.control_period + CFG.reaction_time + CFG.velocity_lag))
    assert stop_allowance(-w, CFG) == stop_allowance(w, CFG)
    # a slow sweep still gets the allowance of the approach that ends at its start
    assert stop_allowance(0.05, CFG) == pytest.approx(CFG.approach_speed * 0.13)
    # the outermost centre leaves exactly margin + allowance to the limit
    c = outermost_centre(CFG, 160.0)
    assert c + CFG.window_half_width + run_up(w, CFG) == pytest.approx(
        CFG.joint_limits[1] - CFG.limit_margin - stop_allowance(w, CFG), abs=1e-9)


def test_a_speed_whose_stopping_allowance_does_not_fit_is_refused_with_the_reason():
    # fits with the margin alone (end 1.47 <= 1.48) but not with the 0.208 rad allowance of 1.6 rad/s
    centre = 1.47 - CFG.window_half_width - run_up(1.6, CFG)
    with pytest.raises(CycleRequestError, match=r"stopping allowance 0\.208 rad .*= 0\.13 s\)") as exc:
        plan_cycle(CFG, [160.0], centre, centre)
    assert exc.value.reason.name == "OUTSIDE_LIMITS"
    plan_cycle(replace(CFG, reaction_time=0.0, velocity_lag=0.0, control_period=1e-6), [160.0], centre, centre)


@pytest.mark.parametrize(("field", "value"), [("reaction_time", -0.1), ("velocity_lag", float("nan")),
                                               ("control_period", 0.0)])
def test_bad_lateness_settings_are_refused(field, value):
    with pytest.raises(CycleRequestError, match=field):
        plan_cycle(replace(CFG, **{field: value}))


def test_the_braking_lead_follows_the_measured_interval_within_its_bounds():
    runner = CycleRunner(CFG)
    runner.start(plan_cycle(CFG, [40.0]), 1, 0.0)
    reading = JointReading(0.0, 0.0, 0.0, 20.0)
    assert runner.lead == CFG.control_period  # nothing measured yet
    t = 0.0
    for dt in (0.01, 0.04, 0.01):
        t += dt
        runner.update(t, replace(reading, stamp=t))
    assert runner.lead == pytest.approx(0.04)  # the longest recent interval
    t += 1.0  # a stall longer than the plan allows for: capped at control_period + reaction_time
    runner.update(t, replace(reading, stamp=t - 0.1))
    assert runner.lead == pytest.approx(CFG.control_period + CFG.reaction_time)
    # braking from the lead: travelling T at the speed and then braking at a ends at the target
    w, T, a = runner.brake_speed(0.3), runner.lead, CFG.acceleration
    assert w * T + w * w / (2 * a) == pytest.approx(0.3)
    # never reaching back into the window: capped at steady_time too
    short = CycleRunner(replace(CFG, steady_time=0.05))
    short.start(plan_cycle(replace(CFG, steady_time=0.05), [40.0]), 1, 0.0)
    short.update(0.0, reading)
    short.update(0.5, replace(reading, stamp=0.5))
    assert short.lead == pytest.approx(0.05)
