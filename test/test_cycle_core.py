"""Test-cycle core: planning, limit checks, the state machine and every watchdog trip (no ROS)."""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import replace

import numpy as np
import pytest

from jointwear_ros.cycle import (
    DEFAULT_SPEEDS,
    CycleConfig,
    CycleRequestError,
    CycleRunner,
    CycleState,
    JointReading,
    Phase,
    move_duration,
    plan_cycle,
    run_up,
)
from jointwear_ros.sim import JointSim, JointSimConfig

CFG = CycleConfig()


# -- planning -----------------------------------------------------------------
def test_default_plan_uses_the_default_speeds_inside_the_limits():
    plan = plan_cycle(CFG)
    assert [s.speed for s in plan.speeds] == list(DEFAULT_SPEEDS)
    lo, hi = plan.extent
    assert CFG.joint_limits[0] + CFG.limit_margin <= lo and hi <= CFG.joint_limits[1] - CFG.limit_margin
    assert plan_cycle(CFG, []).speeds == plan.speeds


@pytest.mark.parametrize("speed", [10.0, 47.0, 160.0])
def test_run_up_gives_constant_speed_before_the_window(speed):
    plan = plan_cycle(CFG, [speed], center=0.2)
    sp = plan.speeds[0]
    w = speed / CFG.gear_ratio
    assert sp.velocity == pytest.approx(w)
    # accelerating takes w^2/2a, then steady_time at w, then the window starts
    assert sp.start + w * w / (2 * CFG.acceleration) + w * CFG.steady_time == pytest.approx(0.2 - CFG.window_half_width)
    assert sp.end - (w * w / (2 * CFG.acceleration) + w * CFG.steady_time) == pytest.approx(0.2 + CFG.window_half_width)
    assert sp.run_up == pytest.approx(run_up(w, CFG))


def test_move_duration_of_trapezoid_and_triangle():
    assert move_duration(1.0, 0.5, 4.0) == pytest.approx(1.0 / 0.5 + 0.5 / 4.0)
    assert move_duration(0.01, 0.5, 4.0) == pytest.approx(2 * math.sqrt(0.01 / 4.0))
    assert move_duration(-1.0, 0.5, 4.0) == move_duration(1.0, 0.5, 4.0)
    assert move_duration(0.0, 0.5, 4.0) == 0.0


def test_plan_duration_adds_approach_sweeps_and_settles():
    plan = plan_cycle(CFG, [50.0], center=0.0, start_position=0.0)
    sp = plan.speeds[0]
    expected = move_duration(sp.start, 0.5, 4.0) + 2 * move_duration(sp.end - sp.start, 0.5, 4.0) + 3 * 0.3
    assert plan.duration == pytest.approx(expected)
    assert "about" in plan.summary() and "50" in plan.summary()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"speeds": [10.0, math.nan]}, r"speed #2 = nan is not finite"),
        ({"speeds": [math.inf]}, r"speed #1 = inf is not finite"),
        ({"speeds": [0.0]}, r"must be > 0"),
        ({"speeds": [-20.0]}, r"must be > 0"),
        ({"speeds": [300.0]}, r"exceeds max_speed 280"),
        ({"center": math.nan}, r"position \(window centre\) nan is not finite"),
        ({"center": 1.45}, r"window 1.45 ± 0.1 rad is outside the joint limits"),
        ({"center": 1.0}, r"speed #\d+ = \d+ rad/s needs positions .* beyond the joint limits"),
        ({"start_position": 2.0}, r"joint is at 2.000 rad, outside the limits"),
        ({"start_position": math.nan}, r"current joint position nan is not finite"),
    ],
)
def test_plan_refuses_bad_requests_with_the_reason(kwargs, match):
    with pytest.raises(CycleRequestError, match=match):
        plan_cycle(CFG, **kwargs)


def test_run_up_near_a_limit_is_refused_only_for_fast_speeds():
    assert plan_cycle(CFG, [10.0], center=1.0)  # slow: run-up fits
    with pytest.raises(CycleRequestError, match="use a lower speed"):
        plan_cycle(CFG, [10.0, 160.0], center=1.0)


@pytest.mark.parametrize(
    ("field", "value"),
    [("acceleration", 0.0), ("gear_ratio", math.nan), ("joint_limits", (1.0, -1.0)), ("settle_time", -1.0)],
)
def test_bad_settings_are_refused(field, value):
    with pytest.raises(CycleRequestError, match=field):
        plan_cycle(replace(CFG, **{field: value}))


# -- the state machine on an ideal joint ----------------------------------------
class IdealJoint:
    """A kinematic joint: velocity = gain × command (+ ``sag`` rad/s when commanded to rest), effort fixed."""

    def __init__(self, gain: float = 1.0, effort: float = 20.0, position: float = 0.0, sag: float = 0.0):
        self.gain = gain
        self.effort = effort
        self.position = position
        self.velocity = 0.0
        self.sag = sag

    def step(self, command: float, dt: float) -> None:
        self.velocity = self.gain * command if command != 0.0 else self.sag
        self.position += self.velocity * dt


def _run(runner: CycleRunner, joint: IdealJoint, dt: float = 0.01, t_end: float = 120.0, hook=None):
    t = 0.0
    log = []
    while runner.running and t < t_end:
        reading = JointReading(t, joint.position, joint.velocity, joint.effort)
        if hook is not None:
            reading = hook(t, reading)
        cmd = runner.update(t, reading)
        log.append((t, runner.phase, runner.speeds_done, cmd, joint.position, joint.velocity))
        joint.step(cmd, dt)
        t += dt
    return log


def test_runner_goes_through_every_phase_of_every_speed_to_done():
    runner = CycleRunner(CFG)
    plan = plan_cycle(CFG, [20.0, 120.0], start_position=0.0)
    runner.start(plan, 7, 0.0)
    assert runner.status().state == CycleState.RUNNING and runner.status().speeds_total == 2
    log = _run(runner, IdealJoint())
    assert runner.state == CycleState.DONE and runner.speeds_done == 2 and runner.command == 0.0
    assert runner.status().cycle_id == 7 and "done" in runner.message
    for i in range(2):
        phases = [p for (_, p, k, *_rest) in log if k == i]
        seq = [phases[0]] + [b for a, b in itertools.pairwise(phases) if a != b]
        assert seq == [Phase.APPROACH, Phase.SETTLE, Phase.FORWARD, Phase.SETTLE, Phase.REVERSE, Phase.SETTLE]
    # inside the window the command is the sweep speed, constant, in each direction
    for i, sp in enumerate(plan.speeds):
        for phase, sign in ((Phase.FORWARD, 1.0), (Phase.REVERSE, -1.0)):
            cmds = [c for (_, p, k, c, x, _v) in log if k == i and p == phase and abs(x) <= CFG.window_half_width]
            assert len(cmds) > 5
            assert np.allclose(cmds, sign * sp.velocity)
    # speeds_done never goes back, the joint never leaves the planned extent
    done = [k for (_, _, k, *_rest) in log]
    assert all(b >= a for a, b in itertools.pairwise(done))
    lo, hi = plan.extent
    assert all(lo - 0.01 <= x <= hi + 0.01 for (*_a, x, _v) in log)


def test_runner_abort_stops_at_once_with_zero():
    runner = CycleRunner(CFG)
    runner.start(plan_cycle(CFG, [20.0]), 1, 0.0)
    _run(runner, IdealJoint(), t_end=1.0)
    assert runner.abort("aborted by operator")
    assert runner.state == CycleState.ABORTED and runner.phase == Phase.NONE and runner.command == 0.0
    assert runner.update(1.1, JointReading(1.1, 0.0, 0.0, 0.0)) == 0.0
    assert not runner.abort()


def test_runner_refuses_to_start_twice():
    runner = CycleRunner(CFG)
    runner.start(plan_cycle(CFG, [20.0]), 1, 0.0)
    with pytest.raises(RuntimeError, match="already running"):
        runner.start(plan_cycle(CFG, [20.0]), 2, 0.0)


def test_late_joint_states_make_the_approach_overshoot_and_it_is_repeated():
    # readings arrive 80 ms late (a busy executor) but look fresh: approaches overshoot
    queue: list[JointReading] = []

    def late(t, r):
        queue.append(r)
        return replace(queue[max(0, len(queue) - 9)], stamp=t)

    runner = CycleRunner(CFG)
    plan = plan_cycle(CFG, [10.0, 160.0], start_position=0.0)
    runner.start(plan, 1, 0.0)
    log = _run(runner, IdealJoint(), hook=late)
    assert runner.state == CycleState.DONE, runner.message
    approaches = [b for (_, a, *_r), (_, b, *_s) in itertools.pairwise(log) if a != b and b == Phase.APPROACH]
    assert len(approaches) > 2  # at least one speed needed a second approach


# -- every watchdog trip ----------------------------------------------------------
def _trip(hook=None, joint=None, config=CFG, speeds=(20.0,)):
    runner = CycleRunner(config)
    runner.start(plan_cycle(config, list(speeds)), 3, 0.0)
    _run(runner, joint or IdealJoint(), hook=hook, t_end=60.0)
    return runner


def test_watchdog_trips_on_stale_joint_state():
    last: list[JointReading] = []

    def hook(t, r):  # the joint state stops updating at t = 1 s
        if t < 1.0 or not last:
            last[:] = [r]
        return last[0]

    runner = _trip(hook)
    assert runner.state == CycleState.FAILED and runner.command == 0.0
    assert re.search(r"watchdog: joint state of joint_1 stale for 0\.2[5-9]\d* s \(state_timeout 0\.25 s\)", runner.message)


def test_stale_check_in_sim_time_also_needs_wall_time_age():
    runner = CycleRunner(CFG)
    runner.start(plan_cycle(CFG, [20.0]), 1, 0.0)
    old = JointReading(0.0, 0.0, 0.0, 0.0)
    runner.update(0.5, old, wall_age=0.05)  # clock jumped ahead of a fresh reading: not stale
    assert runner.running
    runner.update(0.6, old, wall_age=0.3)
    assert runner.state == CycleState.FAILED and "stale for 0.600 s" in runner.message


def test_watchdog_trips_on_missing_joint_state():
    runner = CycleRunner(CFG)
    runner.start(plan_cycle(CFG, [20.0]), 1, 0.0)
    assert runner.update(0.0, None) == 0.0
    assert runner.state == CycleState.FAILED and "no joint state" in runner.message


def test_watchdog_trips_on_effort_over_limit():
    runner = _trip(hook=lambda t, r: replace(r, effort=-180.0) if t > 2.0 else r)
    assert runner.state == CycleState.FAILED
    assert "|effort| 180.0 N·m > effort_limit 150 N·m" in runner.message
    assert runner.fault_joint == runner.config.joint_name  # the watchdog names the joint it tripped on


def test_watchdog_trips_when_the_speed_is_not_reached_at_the_window_start():
    runner = _trip(joint=IdealJoint(gain=0.9))  # the joint runs 10 % slow
    assert runner.state == CycleState.FAILED
    assert "speed not reached at the window start" in runner.message and "± 5 %" in runner.message
    assert runner.command == 0.0


def test_slightly_slow_joint_within_tolerance_completes():
    assert _trip(joint=IdealJoint(gain=0.97)).state == CycleState.DONE


def test_watchdog_trips_on_non_finite_state():
    runner = _trip(hook=lambda t, r: replace(r, velocity=math.nan) if t > 0.5 else r)
    assert runner.state == CycleState.FAILED and "not finite" in runner.message


def test_watchdog_trips_outside_the_joint_limits():
    runner = _trip(hook=lambda t, r: replace(r, position=1.6) if t > 0.5 else r)
    assert runner.state == CycleState.FAILED and "outside its joint limits" in runner.message


def test_watchdog_trips_when_the_joint_cannot_be_positioned_at_the_sweep_start():
    runner = _trip(joint=IdealJoint(sag=-0.1))  # drifts 0.1 rad/s whenever commanded to rest
    assert runner.state == CycleState.FAILED
    assert "after 4 approaches, not within 0.01 rad of the sweep start" in runner.message


def test_watchdog_trips_when_a_move_does_not_finish():
    runner = _trip(joint=IdealJoint(gain=0.0))  # a joint that does not move
    assert runner.state == CycleState.FAILED and "approach move" in runner.message and "not finished" in runner.message


# -- both cores together: the cycle on the simulated joint --------------------------
@pytest.mark.parametrize("rate", [500.0, 2000.0])
def test_cycle_on_the_simulated_joint_reaches_done_and_observes_friction(rate):
    sim = JointSim(JointSimConfig(wear=35.0), seed=4)
    runner = CycleRunner(CFG)
    speeds = [10.0, 47.0, 160.0]
    runner.start(plan_cycle(CFG, speeds, start_position=sim.position), 1, 0.0)
    dt = 1.0 / rate
    every = int(rate / 100)  # commands at 100 Hz
    rows = []
    k = 0
    while runner.running and sim.time < 60.0:
        if k % every == 0:
            s = sim.sample()
            sim.set_command(runner.update(sim.time, JointReading(sim.time, s.position, s.velocity, s.effort)))
        _t, p, _v, e = sim.run(1, dt)
        rows.append((p[0], e[0], runner.phase, runner.speeds_done))
        k += 1
    assert runner.state == CycleState.DONE, runner.message
    a = np.array(rows, dtype=float)
    for i, speed in enumerate(speeds):
        inside = (a[:, 3] == i) & (np.abs(a[:, 0]) <= CFG.window_half_width)
        up = a[inside & (a[:, 2] == Phase.FORWARD), 1].mean() / 200.0
        um = a[inside & (a[:, 2] == Phase.REVERSE), 1].mean() / 200.0
        assert (up - um) / 2 == pytest.approx(sim.true_friction(speed, 0.0), abs=4 * 0.0015)
        assert (up + um) / 2 == pytest.approx(0.1, abs=4 * 0.0015)



def test_plan_refuses_a_crawl_too_many_speeds_and_an_endless_cycle():
    from jointwear_ros.cycle import CycleConfig, CycleRequestError, plan_cycle

    cfg = CycleConfig()
    with pytest.raises(CycleRequestError, match=r"speed #1 = 1e-06 rad/s \(motor side\) is below min_speed 1 rad/s"):
        plan_cycle(cfg, [1e-6])
    with pytest.raises(CycleRequestError, match="1000 speeds asked for; at most max_speeds = 32"):
        plan_cycle(cfg, [20.0] * 1000)
    assert len(plan_cycle(cfg, [20.0] * 32).speeds) == 32
    with pytest.raises(CycleRequestError, match=r"about 13\d\d s, more than max_duration 600 s"):
        plan_cycle(CycleConfig(max_duration=600.0), [1.0] * 32)
    with pytest.raises(CycleRequestError, match="no speeds to sweep"):
        plan_cycle(CycleConfig(speeds=()))
    with pytest.raises(CycleRequestError, match="min_speed 300 rad/s must not exceed max_speed 280"):
        plan_cycle(CycleConfig(min_speed=300.0), [20.0])
