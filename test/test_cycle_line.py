"""The line cycle: every joint at once along one straight line in joint space and back (pure, closed loop).

The plant is the independent-joint ``RobotSim`` at 500 Hz, the runner at 100 Hz, and one
``FrictionObserverCore`` per joint fed with the samples and every joint's status, as the
friction_observer node feeds them.
"""

from __future__ import annotations

import math
import random
import re
from dataclasses import replace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.contract import CyclePhase, CycleState, RefusalReason
from jointwear_ros.cycle import (
    CycleConfig,
    CycleRequestError,
    JointReading,
    LineCycleRunner,
    RobotCycleRunner,
    plan_line_cycle,
    plan_robot_cycle,
    stop_allowance,
)
from jointwear_ros.observer import ObserverConfig
from jointwear_ros.observer.core import FrictionObserverCore
from jointwear_ros.sim import JointSimConfig, RobotSim

SIX = tuple(f"joint_{i}" for i in range(1, 7))
THREE = SIX[:3]


def _configs(names=SIX, **change):
    return {j: CycleConfig(joint_name=j, **change) for j in names}


def _robot(names, quiet=False) -> RobotSim:
    noise = {"noise_std": 0.0, "effort_noise_std": 0.0} if quiet else {}
    return RobotSim(names, [JointSimConfig(wear=10.0 * i, gravity_torque=0.1 + 0.02 * i, **noise)
                            for i in range(len(names))], seeds=range(len(names)))


def _readings(sim: RobotSim) -> dict[str, JointReading]:
    pos, vel, eff = sim.sample()
    return {j: JointReading(sim.time, pos[i], vel[i], eff[i]) for i, j in enumerate(sim.names)}


def _run(runner, sim: RobotSim, plan, hook=None, max_time: float = 400.0):
    """Start ``plan`` and step the robot at 500 Hz, the runner at 100 Hz, each joint's observer core fed, until the
    cycle ends. Returns (observations per joint, rejections per joint, statuses, commands, sweep samples)."""
    names = sim.names
    cores = {j: FrictionObserverCore(ObserverConfig(joint_name=j)) for j in names}
    obs: dict[str, list] = {j: [] for j in names}
    rej: dict[str, list] = {j: [] for j in names}

    def take(j, out):
        obs[j] += out.observations
        rej[j] += out.rejections

    start = _readings(sim)
    runner.start(plan, 7, sim.time, {j: r.position for j, r in start.items()})
    statuses, commands, sweeps = [], [], []
    k = 0
    while runner.running and sim.time < max_time:
        if k % 5 == 0:
            readings = _readings(sim)
            if hook is not None:
                readings = hook(sim, readings)
            cmd = runner.update(sim.time, readings)
            sim.set_commands([cmd[j] for j in names])
            commands.append([cmd[j] for j in names])
            sts = runner.statuses()
            statuses.append(sts)
            for s in sts:
                take(s.joint_name, cores[s.joint_name].on_status(replace(s, stamp=sim.time)))
        sim.step(0.002)
        k += 1
        pos, vel, eff = sim.sample()
        st0 = runner.statuses()[0]
        if runner.running and st0.phase in (CyclePhase.FORWARD, CyclePhase.REVERSE):
            sweeps.append((st0.speeds_done, pos))
        for i, j in enumerate(names):
            take(j, cores[j].on_joint_state(sim.time, pos[i], vel[i], eff[i]))
    for j in names:
        take(j, cores[j].flush())
    return obs, rej, statuses, commands, sweeps


def _off_line(plan, sweeps) -> float:
    """Largest distance of a joint from the line of its step (the measured configuration projected on it)."""
    worst = 0.0
    for k, q in sweeps:
        step = plan.steps[k]
        w, c = step.velocities, plan.centers
        sigma = sum((x - ci) * wi for x, ci, wi in zip(q, c, w)) / sum(wi * wi for wi in w)
        worst = max(worst, max(abs(x - ci - sigma * wi) for x, ci, wi in zip(q, c, w)))
    return worst


# -- the closed loop ------------------------------------------------------------------------------------------
def test_six_joints_at_once_are_each_observed_at_every_speed_on_one_line_in_a_sixth_of_the_time():
    configs = _configs()
    sim = _robot(SIX)
    plan = plan_line_cycle(configs, start_positions=dict.fromkeys(SIX, 0.0))
    sequential = plan_robot_cycle(configs, start_positions=dict.fromkeys(SIX, 0.0))
    assert plan.sequential_duration == pytest.approx(sequential.duration)
    runner = LineCycleRunner(configs)
    obs, rej, _statuses, commands, sweeps = _run(runner, sim, plan)
    assert runner.state == CycleState.DONE, runner.message
    assert runner.message.startswith("done: 6 joints at once, 8 speed step(s) in ")
    speeds = CycleConfig().speeds
    errors = []
    for j in SIX:
        assert rej[j] == [], (j, rej[j])
        assert [round(o.speed) for o in obs[j]] == [round(s) for s in speeds], j
        assert all(o.tau_f > 0 and o.samples_plus >= 20 and o.samples_minus >= 20 for o in obs[j])
        errors += [o.tau_f - sim[j].true_friction(o.speed, o.position) for o in obs[j]]
    # each observation is the joint's friction, scattered as the sim's noise_std (0.0015) says
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    assert rms < 2 * JointSimConfig().noise_std and abs(sum(errors) / len(errors)) < 1e-3, rms
    # every joint moved at every update of a sweep: all at once, not one after another
    moving = [c for c in commands if any(c)]
    assert moving and sum(all(v != 0.0 for v in c) for c in moving) > 0.9 * len(moving)
    assert commands[-1] == [0.0] * 6
    # one straight line: no joint farther than a fraction of a milliradian from it
    dev = _off_line(plan, sweeps)
    print(f"six joints: planned {plan.duration:.1f} s at once vs {sequential.duration:.1f} s one after another, "
          f"ran {sim.time:.1f} s; largest distance from the line {dev * 1e3:.3f} mrad "
          f"(runner: {runner.max_deviation * 1e3:.3f} mrad)")
    assert dev < 2e-3 and runner.max_deviation < 2e-3
    assert plan.duration < 0.3 * sequential.duration
    assert sim.time == pytest.approx(plan.duration, rel=0.05)


def test_each_joints_status_stream_is_a_one_joint_cycle_and_the_last_joint_ends_the_robot_cycle():
    configs = _configs(THREE)
    sim = _robot(THREE)
    plan = plan_line_cycle(configs, speeds=[40.0, 160.0])
    _, _, statuses, _, _ = _run(LineCycleRunner(configs), sim, plan)
    for batch in statuses:
        assert [s.joint_name for s in batch] == list(THREE)
        assert [s.joints_done for s in batch] == [0, 1, 2]
        assert all(s.joints == THREE and s.speeds_total == 2 for s in batch)
        assert len({(s.state, s.phase, s.speeds_done, s.message) for s in batch}) == 1
    for i, _j in enumerate(THREE):
        mine = [b[i] for b in statuses]
        seq = []
        for s in mine:
            key = (s.state, s.speeds_done, s.current_speed)
            if not seq or seq[-1] != key:
                seq.append(key)
        assert seq == [(CycleState.RUNNING, 0, 40.0), (CycleState.RUNNING, 1, 160.0), (CycleState.DONE, 2, 0.0)], seq
        assert all(s.window_center == 0.0 and s.window_half_width == pytest.approx(0.1) for s in mine)
    over = [(s.joint_name, s.robot_cycle_over) for b in statuses for s in b if s.state == CycleState.DONE]
    assert over == [("joint_1", False), ("joint_2", False), ("joint_3", True)]


def test_the_observations_equal_the_one_at_a_time_cycles():
    configs = _configs(THREE)
    speeds = [10.0, 40.0, 160.0]
    line_sim, seq_sim = _robot(THREE, quiet=True), _robot(THREE, quiet=True)
    line, _, _, _, _ = _run(LineCycleRunner(configs), line_sim, plan_line_cycle(configs, speeds=speeds))
    seq, _, _, _, _ = _run(RobotCycleRunner(configs), seq_sim, plan_robot_cycle(configs, speeds=speeds))
    worst = 0.0
    for j in THREE:
        assert len(line[j]) == len(seq[j]) == 3, j
        for a, b in zip(line[j], seq[j]):
            assert a.speed == pytest.approx(b.speed, rel=1e-3)
            worst = max(worst, abs(a.tau_f - b.tau_f) / b.tau_f)
            assert a.tau_f == pytest.approx(b.tau_f, rel=0.01), (j, a.speed, a.tau_f, b.tau_f)
            assert a.load_torque == pytest.approx(b.load_torque, rel=0.01)
    print(f"noise-free sims: largest relative difference of tau_f, at once vs one at a time: {100 * worst:.2f} %")


def test_a_single_speed_set_shorter_than_the_others_is_stretched_over_the_steps():
    configs = dict(_configs(THREE), joint_2=replace(CycleConfig(joint_name="joint_2"), speeds=(20.0, 40.0)),
                   joint_3=replace(CycleConfig(joint_name="joint_3"), speeds=(30.0,)))
    configs["joint_1"] = replace(configs["joint_1"], speeds=(10.0, 20.0, 40.0, 80.0))
    plan = plan_line_cycle(configs)
    assert len(plan.steps) == 4
    assert plan.speeds_of("joint_1") == (10.0, 20.0, 40.0, 80.0)
    assert plan.speeds_of("joint_2") == (20.0, 20.0, 40.0, 40.0)
    assert plan.speeds_of("joint_3") == (30.0,) * 4
    sim = _robot(THREE)
    obs, rej, _, _, _ = _run(LineCycleRunner(configs), sim, plan)
    assert all(rej[j] == [] for j in THREE), rej
    assert [round(o.speed) for o in obs["joint_2"]] == [20, 20, 40, 40]
    assert [round(o.speed) for o in obs["joint_3"]] == [30] * 4


# -- planning ---------------------------------------------------------------------------------------------------
def test_a_joint_whose_line_leaves_its_limits_is_refused_although_it_fits_alone():
    # joint_1 at 10 rad/s needs 2 s in its window: joint_2 at 160 rad/s covers 1.6 rad in that time
    configs = {"joint_1": CycleConfig(joint_name="joint_1", speeds=(10.0,)),
               "joint_2": CycleConfig(joint_name="joint_2", speeds=(160.0,))}
    plan_robot_cycle(configs)  # one after another: fine
    with pytest.raises(CycleRequestError, match=r"^joint_2: speed #1 = 160 rad/s needs positions \[-2\.\d+, 2\.\d+\] "
                                                r"rad on the line of 2 joints .*sweep: sequential") as exc:
        plan_line_cycle(configs)
    assert exc.value.reason == RefusalReason.OUTSIDE_LIMITS


@pytest.mark.parametrize(
    ("kwargs", "reason", "match"),
    [
        ({"joints": ["joint_1", "joint_9"]}, RefusalReason.WRONG_JOINT, r"unknown joint 'joint_9'"),
        ({"joints": ["joint_2", "joint_2"]}, RefusalReason.WRONG_JOINT, r"'joint_2' is named more than once"),
        ({"speeds": [300.0]}, RefusalReason.BAD_SPEEDS, r"^joint_1: speed #1 = 300 rad/s .* exceeds max_speed"),
        ({"joints": ["joint_1", "joint_3"], "positions": [0.0, 1.0], "speeds": [120.0]}, RefusalReason.OUTSIDE_LIMITS,
         r"^joint_3: speed #1 = 120 rad/s needs positions"),
        ({"max_duration": 10.0}, RefusalReason.BAD_SPEEDS, r"line cycle of 3 joint\(s\) would take about \d+ s, more "
                                                          r"than max_duration 10 s"),
    ],
)
def test_a_request_is_refused_before_anything_moves_with_the_joint_and_the_reason(kwargs, reason, match):
    with pytest.raises(CycleRequestError, match=match) as exc:
        plan_line_cycle(_configs(THREE), **kwargs)
    assert exc.value.reason == reason


limits = st.tuples(st.floats(-3.0, -0.3), st.floats(0.3, 3.0))


@st.composite
def joint_settings(draw, name: str) -> CycleConfig:
    lo, hi = draw(limits)
    return CycleConfig(
        joint_name=name, joint_limits=(lo, hi), gear_ratio=draw(st.floats(20.0, 200.0)),
        window_half_width=draw(st.floats(0.02, 0.3)), position=draw(st.floats(lo / 2, hi / 2)),
        acceleration=draw(st.floats(1.0, 10.0)), approach_speed=draw(st.floats(0.1, 1.0)),
        steady_time=draw(st.floats(0.0, 0.5)),
        speeds=tuple(draw(st.lists(st.floats(1.0, 280.0), min_size=1, max_size=6))))


@settings(max_examples=200, deadline=None)
@given(a=joint_settings("joint_1"), b=joint_settings("joint_2"), c=joint_settings("joint_3"),
       speeds=st.none() | st.lists(st.floats(1.0, 280.0), min_size=1, max_size=4),
       start=st.floats(-0.2, 0.2))
def test_any_plannable_request_keeps_every_planned_position_inside_the_limits(a, b, c, speeds, start):
    configs = {"joint_1": a, "joint_2": b, "joint_3": c}
    try:
        plan = plan_line_cycle(configs, speeds=speeds, start_positions=dict.fromkeys(configs, start))
    except CycleRequestError as exc:
        assert exc.reason != RefusalReason.NONE and str(exc)
        return
    for i, j in enumerate(plan.joints):
        cfg = configs[j]
        lo, hi = cfg.joint_limits
        for step in plan.steps:
            w = step.velocities[i]
            allow = cfg.limit_margin + stop_allowance(w, cfg)
            for p in (step.start[i], step.end[i]):
                assert lo + allow - 1e-9 <= p <= hi - allow + 1e-9, (j, p)
            assert step.half_widths[i] >= cfg.window_half_width * (1 - 1e-9)  # every joint covers its window
            assert step.acceleration * abs(w) <= cfg.acceleration * (1 + 1e-9)  # and accelerates within its limit
            assert step.end[i] - step.start[i] == pytest.approx(2 * step.reach * w)  # one line through the centres
            assert (step.start[i] + step.end[i]) / 2 == pytest.approx(plan.centers[i])
    # no claim on the duration here: joints with very unlike gears, windows and accelerations can make the line
    # slower than one joint after another (the summary says both; the six-joint test holds the usual case)
    assert f"one joint after another: {plan.sequential_duration:.1f} s" in plan.summary()


# -- the watchdog -----------------------------------------------------------------------------------------------
def _change(joint: str, after: float, **f):
    def hook(sim, readings):
        if sim.time >= after:
            r = readings[joint]
            readings[joint] = replace(r, **{k: fn(getattr(r, k)) for k, fn in f.items()})
        return readings
    return hook


@pytest.mark.parametrize(
    ("hook", "joint", "match"),
    [
        (_change("joint_2", 2.0, effort=lambda e: 400.0), "joint_2",
         r"^watchdog: joint joint_2: \|effort\| 400\.0 N·m > effort_limit 150 N·m"),
        (_change("joint_3", 2.0, position=lambda p: p + 0.05), "joint_3",
         r"^watchdog: joint_3 0\.0\d\d rad off the line of the \w+ move \(hold_tolerance 0\.02 rad\)"),
        (_change("joint_1", 0.0, velocity=lambda v: 0.8 * v), "joint_1",
         r"^watchdog: joint_1: speed not reached at the window start"),
        (_change("joint_2", 2.0, stamp=lambda t: t - 1.0), "joint_2", r"^watchdog: joint state of joint joint_2 stale"),
        (_change("joint_3", 2.0, velocity=lambda v: math.nan), "joint_3", r"^watchdog: joint state of joint joint_3 "
                                                                         r"not finite"),
    ],
)
def test_a_trip_on_any_joint_fails_the_cycle_for_all_with_zero_for_every_joint(hook, joint, match):
    configs = _configs(THREE)
    sim = _robot(THREE)
    runner = LineCycleRunner(configs)
    _, _, statuses, commands, _ = _run(runner, sim, plan_line_cycle(configs, speeds=[40.0, 160.0]), hook=hook)
    assert runner.state == CycleState.FAILED and runner.fault_joint == joint
    assert re_search(match, runner.message), runner.message
    assert commands[-1] == [0.0, 0.0, 0.0] and runner.commands == dict.fromkeys(THREE, 0.0)
    assert all(s.state == CycleState.FAILED and s.robot_cycle_over for s in statuses[-1])
    assert all(r.state == CycleState.FAILED for r in runner.results.values())


def re_search(pattern: str, text: str) -> bool:
    return re.search(pattern, text) is not None


def test_a_driven_joint_not_in_the_request_is_held_and_watched():
    configs = _configs(THREE)
    sim = _robot(THREE)
    runner = LineCycleRunner(configs)
    plan = plan_line_cycle(configs, ["joint_1", "joint_3"], speeds=[40.0])
    _, _, _, commands, _ = _run(runner, sim, plan)
    assert runner.state == CycleState.DONE and all(c[1] == 0.0 for c in commands)
    runner = LineCycleRunner(configs)
    _run(runner, _robot(THREE), plan, hook=_change("joint_2", 1.0, position=lambda p: p + 0.03))
    assert runner.state == CycleState.FAILED and runner.fault_joint == "joint_2"
    assert runner.message.startswith("watchdog: held joint joint_2 moved +0.030 rad"), runner.message


def test_abort_stops_every_joint():
    configs = _configs(THREE)
    sim = _robot(THREE)
    runner = LineCycleRunner(configs)

    def hook(s, readings):
        if s.time >= 3.0 and runner.running:
            runner.abort("aborted by operator")
        return readings

    _, _, statuses, _commands, _ = _run(runner, sim, plan_line_cycle(configs, speeds=[40.0]), hook=hook)
    assert runner.state == CycleState.ABORTED and runner.commands == dict.fromkeys(THREE, 0.0)
    assert [s.state for s in statuses[-1]] == [CycleState.ABORTED] * 3
    assert all(r.state == CycleState.ABORTED for r in runner.results.values())


@pytest.mark.parametrize("late", [0.03, 0.1])
def test_late_control_updates_keep_every_joint_within_its_stopping_allowance(late):
    """Every update late by up to ``late`` s (``reaction_time`` is 0.1 s): the cycle still ends DONE with every
    observation, and no joint passes its sweep ends by more than its stopping allowance."""
    configs = _configs(THREE)
    sim = _robot(THREE)
    plan = plan_line_cycle(configs, speeds=[40.0, 160.0])
    runner = LineCycleRunner(configs)
    rng = random.Random(1)
    due = 0.0
    runner.start(plan, 1, 0.0, dict.fromkeys(THREE, 0.0))
    lo = dict.fromkeys(THREE, 0.0)
    hi = dict.fromkeys(THREE, 0.0)
    while runner.running and sim.time < 60.0:
        if sim.time >= due - 1e-9:
            cmd = runner.update(sim.time, _readings(sim))
            sim.set_commands([cmd[j] for j in THREE])
            due = sim.time + 0.01 + rng.uniform(0.0, late)
        sim.step(0.002)
        for j, p in zip(THREE, sim.sample()[0]):
            lo[j], hi[j] = min(lo[j], p), max(hi[j], p)
    assert runner.state == CycleState.DONE, runner.message
    for j in THREE:
        a, b = plan.extent(j)
        allow = stop_allowance(1.6, configs[j])
        print(f"{j}: planned [{a:.3f}, {b:.3f}] rad, reached [{lo[j]:.3f}, {hi[j]:.3f}] rad")
        assert a - allow < lo[j] and hi[j] < b + allow


@pytest.mark.parametrize("phase", [CyclePhase.FORWARD, CyclePhase.REVERSE])
@pytest.mark.parametrize("jump", [0.3, 1.0, 3.0])
def test_a_clock_that_jumps_at_a_sweeps_start_does_not_run_the_profile_on_without_the_arm(phase, jump):
    """A starved controller on sim time: the simulator's clock ran on while every joint was commanded to rest
    (a settle), so the sweep's first command reaches the arm ``jump`` s after the controller computed it and its
    next update sees the clock that much later. The reference waits for the arm (``reference_holds``): every
    joint's windows are still swept at constant speed, so every observation is kept and none is rejected (the
    profile used to run on without the arm; its deceleration fell inside the windows: "speed not constant")."""
    configs = _configs(THREE)
    sim = _robot(THREE)
    plan = plan_line_cycle(configs, speeds=[40.0, 160.0])
    runner = LineCycleRunner(configs)
    cores = {j: FrictionObserverCore(ObserverConfig(joint_name=j)) for j in THREE}
    obs: dict[str, list] = {j: [] for j in THREE}
    rej: dict[str, list] = {j: [] for j in THREE}

    def step_and_observe():
        sim.step(0.002)
        pos, vel, eff = sim.sample()
        for i, j in enumerate(THREE):
            out = cores[j].on_joint_state(sim.time, pos[i], vel[i], eff[i])
            obs[j] += out.observations
            rej[j] += out.rejections

    runner.start(plan, 1, sim.time, {j: r.position for j, r in _readings(sim).items()})
    k, jumped, before = 0, False, None
    while runner.running and sim.time < 60.0:
        if k % 5 == 0:
            cmd = runner.update(sim.time, _readings(sim))
            now_phase = runner.statuses()[0].phase
            if not jumped and now_phase == phase and before != phase:
                jumped = True
                for _ in range(round(jump / 0.002)):  # the arm at rest, the clock running
                    step_and_observe()
            before = now_phase
            sim.set_commands([cmd[j] for j in THREE])
            for s in runner.statuses():
                out = cores[s.joint_name].on_status(replace(s, stamp=sim.time))
                obs[s.joint_name] += out.observations
                rej[s.joint_name] += out.rejections
        step_and_observe()
        k += 1
    for j in THREE:
        out = cores[j].flush()
        obs[j] += out.observations
        rej[j] += out.rejections
    assert jumped and runner.state == CycleState.DONE, runner.message
    assert runner.reference_holds >= 1
    assert {j: len(obs[j]) for j in THREE} == dict.fromkeys(THREE, 2), rej
    assert rej == {j: [] for j in THREE}
