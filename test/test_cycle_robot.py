"""Robot cycle core: planning every joint of a request, the sequence, the watchdog over held joints (no ROS)."""

from __future__ import annotations

import math
import re
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.contract import RefusalReason
from jointwear_ros.cycle import (
    CycleConfig,
    CycleRequestError,
    CycleRunner,
    CycleState,
    JointReading,
    LineCycleRunner,
    RobotCycleRunner,
    plan_cycle,
    plan_line_cycle,
    plan_robot_cycle,
)
from jointwear_ros.sim import JointSimConfig, RobotSim

JOINTS = ("joint_1", "joint_2", "joint_3")
CONFIGS = {j: CycleConfig(joint_name=j) for j in JOINTS}
HOLD = 0.02


def _readings(sim: RobotSim, stamp: float | None = None) -> dict[str, JointReading]:
    pos, vel, eff = sim.sample()
    t = sim.time if stamp is None else stamp
    return {j: JointReading(t, pos[i], vel[i], eff[i]) for i, j in enumerate(sim.names)}


def _robot(configs=CONFIGS, gravity=(0.1, 0.2, 0.15)) -> RobotSim:
    names = list(configs)
    return RobotSim(names, [JointSimConfig(wear=10.0 * i, gravity_torque=g) for i, g in enumerate(gravity)],
                    seeds=range(len(names)))


def _run(runner: RobotCycleRunner, sim: RobotSim, max_time: float = 120.0, hook=None):
    """Step the robot at 500 Hz, the runner at 100 Hz, until the cycle ends; the status log, commands, samples."""
    dt = 0.002
    log, commands, samples = [], [], []
    k = 0
    while runner.running and sim.time < max_time:
        if k % 5 == 0:
            readings = _readings(sim)
            if hook is not None:
                readings = hook(sim, readings)
            cmd = runner.update(sim.time, readings)
            sim.set_commands([cmd[j] for j in sim.names])
            commands.append([cmd[j] for j in sim.names])
            s = runner.status()
            key = (s.joint_name, s.state, s.joints_done)
            if not log or log[-1] != key:
                log.append(key)
            under = s.joint_name if s.state == CycleState.RUNNING else ""
            samples.append((under, [r.position for r in readings.values()]))
        sim.step(dt)
        k += 1
    return log, commands, samples


def _start(runner: RobotCycleRunner, sim: RobotSim, joints=JOINTS, speeds=(40.0,), positions=None):
    now = _readings(sim)
    plan = plan_robot_cycle(runner.configs, joints, speeds, positions, {j: r.position for j, r in now.items()})
    runner.start(plan, 7, sim.time, {j: r.position for j, r in now.items()})
    return plan


# -- planning -----------------------------------------------------------------
def test_an_empty_request_plans_every_configured_joint_in_command_order():
    plan = plan_robot_cycle(CONFIGS)
    assert plan.joints == JOINTS
    assert plan.duration == pytest.approx(sum(plan_cycle(c).duration for c in CONFIGS.values()))
    assert plan.summary().endswith(f"3 joints, about {plan.duration:.1f} s in total")


@pytest.mark.parametrize(
    ("kwargs", "reason", "match"),
    [
        ({"joints": ["joint_1", "joint_9"]}, RefusalReason.WRONG_JOINT,
         r"unknown joint 'joint_9': this node drives 'joint_1', 'joint_2', 'joint_3'"),
        ({"joints": ["joint_2", "joint_2"]}, RefusalReason.WRONG_JOINT, r"'joint_2' is named more than once"),
        ({"joints": ["joint_1", "joint_2"], "positions": [0.0, 0.0, 0.0]}, RefusalReason.BAD_REQUEST,
         r"positions has 3 value\(s\) for 2 joint\(s\)"),
        ({"joints": ["joint_1", "joint_3"], "positions": [0.0, math.nan]}, RefusalReason.BAD_REQUEST,
         r"^joint_3: position \(window centre\) nan is not finite"),
        ({"speeds": [300.0]}, RefusalReason.BAD_SPEEDS, r"^joint_1: speed #1 = 300 rad/s .* exceeds max_speed 280"),
        ({"start_positions": {"joint_2": 2.0}}, RefusalReason.OUTSIDE_LIMITS, r"^joint_2: joint is at 2.000 rad"),
        ({"max_duration": 30.0}, RefusalReason.BAD_SPEEDS, r"robot cycle of 3 joint\(s\) would take about \d+ s, more "
                                                          r"than max_duration 30 s"),
    ],
)
def test_a_request_is_refused_as_a_whole_with_the_joint_and_the_reason(kwargs, reason, match):
    with pytest.raises(CycleRequestError, match=match) as exc:
        plan_robot_cycle(CONFIGS, **kwargs)
    assert exc.value.reason == reason


def test_each_joint_is_planned_with_its_own_settings_and_centre():
    configs = dict(CONFIGS, joint_2=replace(CONFIGS["joint_2"], joint_limits=(-0.5, 0.5), speeds=(20.0, 30.0)))
    plan = plan_robot_cycle(configs, ["joint_2", "joint_1"], positions=[0.1, -0.2])
    assert [len(p.speeds) for p in plan.plans] == [2, 8]
    assert plan.plan_of("joint_2").center == 0.1 and plan.plan_of("joint_1").center == -0.2
    with pytest.raises(CycleRequestError, match=r"^joint_2: speed #1 = 160 rad/s needs positions") as exc:
        plan_robot_cycle(configs, ["joint_1", "joint_2"], speeds=[160.0])
    assert exc.value.reason == RefusalReason.OUTSIDE_LIMITS


names = st.sampled_from(["joint_1", "joint_2", "joint_3", "joint_9", ""])
floats = st.floats(allow_nan=True, allow_infinity=True, width=64) | st.floats(-2.0, 2.0)


@settings(max_examples=150, deadline=None)
@given(joints=st.lists(names, max_size=5), positions=st.lists(floats, max_size=4),
       speeds=st.lists(floats | st.floats(0.5, 300.0), max_size=4))
def test_any_request_is_planned_or_refused_with_a_reason(joints, positions, speeds):
    try:
        plan = plan_robot_cycle(CONFIGS, joints, speeds, positions)
    except CycleRequestError as exc:
        assert exc.reason in RefusalReason and exc.reason != RefusalReason.NONE and str(exc)
        return
    assert plan.joints == (tuple(joints) if joints else JOINTS)
    assert len(set(plan.joints)) == len(plan.joints)
    for j, p in zip(plan.joints, plan.plans, strict=True):
        lo, hi = CONFIGS[j].joint_limits
        a, b = p.extent
        assert lo < a and b < hi
    assert plan.duration == pytest.approx(sum(p.duration for p in plan.plans))


# -- the sequence -------------------------------------------------------------
def test_a_robot_cycle_tests_each_joint_in_turn_and_holds_the_others_still():
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, speeds=(40.0, 160.0))
    log, commands, samples = _run(runner, sim)
    assert runner.state == CycleState.DONE and runner.message.startswith("done: 3 joints in ")
    assert log == [(j, s, k) for k, j in enumerate(JOINTS) for s in (CycleState.RUNNING, CycleState.DONE)]
    # one joint moves at a time; the held ones get at most their small hold correction (back to where they are held)
    cap = 0.2 * CONFIGS["joint_1"].approach_speed
    assert all(sum(1 for v in c if abs(v) > cap + 1e-12) <= 1 for c in commands)
    movers = [next(i for i, v in enumerate(c) if abs(v) > cap) for c in commands if any(abs(v) > cap for v in c)]
    assert movers == sorted(movers) and set(movers) == {0, 1, 2}
    assert commands[-1] == [0.0, 0.0, 0.0]
    assert all(r.state == CycleState.DONE and r.speeds_done == 2 for r in runner.results.values())
    # the held joints barely move (the velocity loop holds them against gravity): far inside the tolerance
    for k, j in enumerate(JOINTS):
        for other in JOINTS:
            held = [p[k] for under, p in samples if under == other != j]
            assert not held or max(held) - min(held) < HOLD / 10, (j, other, max(held) - min(held))


def test_one_joint_runs_exactly_as_the_one_joint_runner():
    one = {"joint_1": CONFIGS["joint_1"]}
    sims = [_robot(one, (0.1,)), _robot(one, (0.1,))]
    robot = RobotCycleRunner(one, HOLD)
    plan = _start(robot, sims[0], joints=[], speeds=(30.0, 80.0))
    single = CycleRunner(CONFIGS["joint_1"])
    single.start(plan.plans[0], 7, 0.0)
    dt = 0.002
    k = 0
    while robot.running or single.running:
        if k % 5 == 0:
            a = robot.update(sims[0].time, _readings(sims[0]))["joint_1"]
            b = single.update(sims[1].time, _readings(sims[1])["joint_1"])
            assert a == b and robot.status().phase == single.phase
            sims[0].set_commands([a])
            sims[1].set_commands([b])
        for s in sims:
            s.step(dt)
        k += 1
    assert robot.state == single.state == CycleState.DONE and robot.message == single.message


# -- the watchdog over every joint -------------------------------------------
def _push(joint: str, after: float, **change):
    """A hook that changes ``joint``'s reading from sim time ``after`` on."""

    def hook(sim, readings):
        if sim.time >= after:
            r = readings[joint]
            readings[joint] = JointReading(r.stamp, *(change.get(f, getattr(r, f)) if not callable(change.get(f))
                                                      else change[f](getattr(r, f)) for f in ("position", "velocity", "effort")))
        return readings

    return hook


@pytest.mark.parametrize(
    ("hook", "match"),
    [
        (_push("joint_3", 1.0, position=lambda p: p - 0.025), r"^watchdog: held joint joint_3 moved -0.025 rad from"),
        (_push("joint_3", 1.0, effort=160.0), r"^watchdog: held joint joint_3: \|effort\| 160.0 N·m > effort_limit 150"),
        (_push("joint_2", 1.0, position=-1.6), r"^watchdog: held joint joint_2 at -1.600 rad, outside its joint limits"),
        (_push("joint_2", 1.0, velocity=math.nan), r"^watchdog: joint state of held joint joint_2 not finite"),
    ],
)
def test_a_fault_on_a_held_joint_fails_the_cycle_with_zero_for_all(hook, match):
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, speeds=(10.0,))
    _, commands, _ = _run(runner, sim, hook=hook)
    assert runner.state == CycleState.FAILED
    status = runner.status()
    assert status.joint_name == "joint_1" and status.joints_done == 0 and status.state == CycleState.FAILED
    assert re_match(match, status.message) and status.message.endswith("; not tested: joint_2, joint_3")
    assert commands[-1] == [0.0, 0.0, 0.0] and runner.commands == dict.fromkeys(JOINTS, 0.0)
    assert sim.time < 1.1  # at once
    assert runner.results["joint_1"].state == CycleState.FAILED
    assert runner.fault_joint in ("joint_2", "joint_3")
    assert runner.results[runner.fault_joint].state == CycleState.FAILED
    assert [runner.results[j].state for j in JOINTS if j not in ("joint_1", runner.fault_joint)] == [CycleState.IDLE]


def re_match(pattern: str, text: str) -> bool:
    import re

    return re.search(pattern, text) is not None


def test_a_held_joint_moving_less_than_the_tolerance_does_not_trip():
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, speeds=(40.0,))
    _run(runner, sim, hook=_push("joint_3", 1.0, position=lambda p: p - 0.015))
    assert runner.state == CycleState.DONE, runner.message


def test_a_stale_held_joint_fails_the_cycle():
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, speeds=(10.0,))

    def hook(s, readings):
        if s.time >= 1.0:
            r = readings["joint_2"]
            readings["joint_2"] = JointReading(1.0, r.position, r.velocity, r.effort)
        return readings

    _run(runner, sim, hook=hook)
    assert runner.state == CycleState.FAILED and 1.25 <= sim.time < 1.27  # the first update past state_timeout
    assert runner.message.startswith("watchdog: joint state of held joint joint_2 stale for 0.2")
    assert "(state_timeout 0.25 s); not tested: joint_2, joint_3" in runner.message


def test_a_joint_tested_earlier_is_held_where_its_test_left_it():
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, speeds=(40.0,))
    # joint_1 ends its test at its sweep start, about -0.24 rad; pushing it back to 0 while joint_2 runs trips
    _run(runner, sim, hook=lambda s, rd: {**rd, "joint_1": replace(rd["joint_1"], position=0.0)}
         if runner.status().joint_name == "joint_2" and runner.status().state == CycleState.RUNNING else rd)
    assert runner.state == CycleState.FAILED and runner.status().joint_name == "joint_2"
    assert runner.message.startswith("watchdog: held joint joint_1 moved +0.2")
    assert runner.message.endswith("; not tested: joint_3")
    assert runner.results["joint_1"].state == CycleState.FAILED  # tested DONE, then tripped the cycle


def test_the_joint_under_tests_own_watchdog_still_applies_and_names_the_rest():
    configs = dict(CONFIGS, joint_2=replace(CONFIGS["joint_2"], effort_limit=5.0))
    sim = _robot(configs)
    runner = RobotCycleRunner(configs, HOLD)
    # joint_2 is tested first: its own limit trips at once (|effort| ~ 40 N·m at rest against gravity 0.2)
    _start(runner, sim, joints=["joint_2", "joint_1", "joint_3"], speeds=(40.0,))
    _run(runner, sim)
    assert runner.state == CycleState.FAILED and runner.status().joint_name == "joint_2"
    assert runner.message.startswith("watchdog: joint_2: |effort| ") and runner.message.endswith("; not tested: joint_1, joint_3")
    assert runner.fault_joint == "joint_2"


def test_abort_between_two_joints_names_the_next_joint():
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, speeds=(40.0,))
    # step until joint_1's DONE is the status (between two joints), then abort
    dt = 0.002
    k = 0
    while runner.status().state != CycleState.DONE:
        if k % 5 == 0:
            cmd = runner.update(sim.time, _readings(sim))
            sim.set_commands([cmd[j] for j in JOINTS])
        sim.step(dt)
        k += 1
    assert runner.running and runner.status().joint_name == "joint_1"
    assert runner.abort("aborted by operator")
    st_ = runner.status()
    assert st_.state == CycleState.ABORTED and st_.joint_name == "joint_2" and st_.joints_done == 1
    assert st_.message == "aborted by operator; not tested: joint_3"
    assert runner.results["joint_1"].state == CycleState.DONE
    assert runner.results["joint_2"].state == CycleState.ABORTED and runner.results["joint_3"].state == CycleState.IDLE
    assert not runner.abort() and runner.commands == dict.fromkeys(JOINTS, 0.0)


@settings(max_examples=25, deadline=None)
@given(joint=st.sampled_from(["joint_2", "joint_3"]), at=st.floats(0.2, 3.0),
       # a held joint sags up to ~1.5 mrad while its velocity loop takes up gravity: stay 3 mrad off the tolerance
       offset=st.floats(-0.05, 0.05).filter(lambda d: abs(abs(d) - HOLD) > 0.003))
def test_a_held_joint_trips_exactly_when_it_moves_beyond_the_tolerance(joint, at, offset):
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, joints=["joint_1"], speeds=(40.0,))
    _run(runner, sim, hook=_push(joint, at, position=lambda p: p + offset))
    if abs(offset) > HOLD:
        assert runner.state == CycleState.FAILED and f"held joint {joint} moved" in runner.message
    else:
        assert runner.state == CycleState.DONE, runner.message


def test_settings_cannot_change_while_a_cycle_runs():
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim)
    with pytest.raises(RuntimeError, match="running"):
        runner.reconfigure(CONFIGS)
    runner.abort()
    runner.reconfigure(CONFIGS, 0.05)
    assert runner.hold_tolerance == 0.05
    with pytest.raises(CycleRequestError, match="the driven joints cannot change"):
        runner.reconfigure({"joint_1": CONFIGS["joint_1"]})
    with pytest.raises(CycleRequestError, match="hold_tolerance must be finite and > 0"):
        RobotCycleRunner(CONFIGS, 0.0)


@pytest.mark.parametrize("joint", ["joint_2", "joint_3"])
def test_a_held_joint_drifting_slowly_beyond_the_tolerance_fails_the_cycle(joint):
    """A slow drift (gravity creeping through a brake), not a step: 4x hold_tolerance over one second. The
    reference is where the joint was put, not where it has crept to (a reference that follows the joint let a
    drift of 4x the tolerance end DONE)."""
    sim = _robot()
    runner = RobotCycleRunner(CONFIGS, HOLD)
    _start(runner, sim, joints=["joint_1"], speeds=(40.0,))
    drift = 4.0 * HOLD  # rad per second from t = 0.2 s
    _run(runner, sim, hook=lambda s, readings: _push(joint, 0.2, position=lambda p: p + drift * (s.time - 0.2))(
        s, readings))
    # the hold correction pulls the joint back (the reading drifts on): the drift shows as the net correction
    assert runner.state == CycleState.FAILED, runner.message
    assert re.search(rf"held joint {joint} (moved|keeps being pushed away)", runner.message), runner.message
    assert sim.time < 0.2 + 1.5 * HOLD / drift + 0.1  # tripped as the drift passed the tolerance


@pytest.mark.parametrize("kind", ["robot", "line"])
def test_both_multi_joint_machines_check_their_joints_and_change_settings_only_between_cycles(kind):
    """One after another (robot) or all at once (line): no joints, a hold tolerance that is no distance and new
    settings while a cycle runs or for other joints are refused, each naming the machine; between cycles the
    new settings are taken; abort and fail say False when no cycle runs."""
    machine = RobotCycleRunner if kind == "robot" else LineCycleRunner
    with pytest.raises(CycleRequestError, match=rf"^a {kind} cycle needs at least one joint$"):
        machine({})
    for bad in (0.0, -0.1, math.nan, math.inf):
        with pytest.raises(CycleRequestError, match=r"^hold_tolerance must be finite and > 0 rad"):
            machine(CONFIGS, hold_tolerance=bad)
    runner = machine(CONFIGS)
    assert not runner.abort() and not runner.fail("watchdog: x", "joint_2") and runner.state == CycleState.IDLE
    slower = {j: replace(c, approach_speed=c.approach_speed / 2) for j, c in CONFIGS.items()}
    runner.reconfigure(slower, hold_tolerance=0.05)
    assert runner.configs == slower and runner.hold_tolerance == 0.05
    with pytest.raises(CycleRequestError, match=r"^the driven joints cannot change: \['joint_1', 'joint_2', 'joint_3'\] "
                                                r"-> \['joint_1', 'joint_2'\]$"):
        runner.reconfigure({j: slower[j] for j in JOINTS[:2]})
    start = dict.fromkeys(JOINTS, 0.0)
    plan = (plan_robot_cycle(slower, start_positions=start) if kind == "robot"
            else plan_line_cycle(slower, start_positions=start))
    runner.start(plan, 7, 0.0, start)
    assert runner.running
    with pytest.raises(RuntimeError, match=rf"^a {kind} cycle is running$"):
        runner.reconfigure(CONFIGS)
    assert runner.fail("watchdog: joint_2 stale", "joint_2") and runner.fault_joint == "joint_2"
    assert runner.state == CycleState.FAILED and not runner.running and not runner.abort()
    assert all(v == 0.0 for v in runner.commands.values())
