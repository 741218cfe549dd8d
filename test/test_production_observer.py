"""The production observer's pure core (jointwear_ros.observer.production) on the simulated UR5 and on synthetic
samples: paired friction against the model's truth, held joints, configuration and load mismatches, acceleration
left out, model-based observations, replay equal to live bit for bit, and bad input as one InputDataError line."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.errors import InputDataError
from jointwear_ros.observer import (
    REASONS,
    ProductionConfig,
    ProductionObserver,
    ProductionShift,
    observe_production,
)
from jointwear_ros.sim.arm import ArmSim, arm_configs
from jointwear_ros.sim.arms import arm_spec

UR5 = arm_spec("ur5")
NAMES = [f"joint_{i + 1}" for i in range(6)]
#: the program's line in joint space per unit of path speed: every joint moves but the last wrist
DIRECTION = np.array([1.0, 0.8, -0.6, 1.0, 0.7, 0.0])
SCALES = np.array([j.torque_scale for j in UR5.joints])
CONFIGS = [ProductionConfig(gear_ratio=j.gear_ratio, torque_scale=j.torque_scale) for j in UR5.joints]
RATE = 500.0  # /joint_states, Hz
CRUISE = 0.8  # s at cruise per pass
PATH_ACCEL = 2.0  # rad/s^2 of the path's trapezoid (per unit of DIRECTION)


def _program(speeds: tuple[float, ...] = (0.3, 0.6), reps: int = 3, payload_forward: float = 0.0,
             offset: tuple[int, float] | None = None, seed: int = 0
             ) -> tuple[ArmSim, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The UR5 along DIRECTION and back, ``reps`` times at each path speed (joint rad/s of a unit direction),
    all joints on one trapezoid (they reach cruise together), sampled at RATE. ``payload_forward`` kg is carried
    on the forward passes only; ``offset`` = (joint, rad) moves that joint away before each reverse pass and back
    after it."""
    arm = ArmSim(UR5, NAMES, arm_configs(UR5, NAMES), seeds=range(seed, seed + len(NAMES)))
    dt = 0.001
    every = round(1.0 / (RATE * dt))
    rows: list[tuple[float, list[float], list[float], list[float]]] = []

    def tick() -> None:
        arm.step(dt)
        if round(arm.time / dt) % every == 0:
            p, v, e = arm.sample()
            rows.append((arm.time, p, v, e))

    def leg(c: float, sign: float) -> None:
        ramp = c / PATH_ACCEL
        total = 2 * ramp + CRUISE
        for k in range(round(total / dt)):
            s = (k + 0.5) * dt
            arm.set_commands((sign * min(s / ramp, 1.0, (total - s) / ramp) * c * DIRECTION).tolist())
            tick()

    def dwell(seconds: float) -> None:
        arm.stop()
        for _ in range(round(seconds / dt)):
            tick()

    def shift_joint(sign: float) -> None:
        assert offset is not None
        cmd = np.zeros(len(NAMES))
        cmd[offset[0]] = 0.2 * sign
        arm.set_commands(cmd.tolist())
        for _ in range(round(offset[1] / 0.2 / dt)):
            tick()
        dwell(0.3)

    dwell(0.3)
    for c in speeds:
        for _ in range(reps):
            arm.set_payload(payload_forward)
            leg(c, 1.0)
            dwell(0.2)
            arm.set_payload(0.0)
            if offset:
                shift_joint(1.0)
            leg(c, -1.0)
            dwell(0.2)
            if offset:
                shift_joint(-1.0)
    t = np.array([r[0] for r in rows])
    q, v, u = (np.array([r[i] for r in rows]) for i in (1, 2, 3))
    return arm, t, q, v, u


def _model() -> ArmSim:
    return ArmSim(UR5, NAMES, arm_configs(UR5, NAMES), seeds=range(6))


def _truth(arm: ArmSim, q: np.ndarray, v: np.ndarray, joint: str, speed_motor: float) -> float:
    """The model's friction (normalized) at that joint speed, averaged over the forward cruise samples."""
    j = NAMES.index(joint)
    vj = speed_motor / UR5.joints[j].gear_ratio
    sel = np.flatnonzero(np.abs(v[:, j] - vj) < 0.02 * vj)
    sel = sel[:: max(1, sel.size // 30)]
    return float(np.mean([arm.true_friction(joint, vj, positions=q[i], velocities=v[i]) for i in sel])) / SCALES[j]


@pytest.fixture(scope="module")
def line() -> tuple[ArmSim, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return _program()


@pytest.fixture(scope="module")
def gravity():
    model = _model()
    return lambda q: model.inverse_dynamics(q, np.zeros(6))


@pytest.fixture(scope="module")
def rigid_body():
    model = _model()
    return lambda q, v, a: model.inverse_dynamics(q, v, a)


def test_production_observer_reads_every_moving_joints_friction_within_3_std(line, gravity) -> None:
    arm, t, q, v, u = line
    shift = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, gravity=gravity, shift_id=7)
    z = {}
    for obs, kind in zip(shift.levels, shift.level_kinds, strict=True):
        assert kind == "paired" and obs.cycle_id == 7
        truth = _truth(arm, q, v, obs.joint_name, obs.speed)
        z[(obs.joint_name, round(obs.speed))] = (obs.tau_f - truth) / obs.tau_f_std
    # every moving joint at both speed levels (motor rad/s: 100 x path speed x its DIRECTION)
    assert sorted(z) == sorted((NAMES[j], round(100 * c * abs(DIRECTION[j]))) for j in range(5) for c in (0.3, 0.6))
    assert all(abs(x) <= 3.0 for x in z.values()), z
    for name in NAMES[:5]:
        c = shift.joints[name]
        assert (c.passes, c.paired, c.model, c.rejected_total, c.informative) == (12, 12, 0, 0, True)
        assert len(c.speed_levels) == 2
    # the load column is the gravity torque of the configuration: the shoulder lift carries it, the base not
    load = {o.joint_name: o.load_torque for o in shift.levels}
    assert load["joint_2"] > 0.2 and load["joint_1"] < 1e-3


def test_production_observer_says_a_wrist_held_still_gave_nothing(line, gravity) -> None:
    _, t, q, v, u = line
    shift = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, gravity=gravity)
    wrist = shift.joints["joint_6"]
    assert not [o for o in shift.levels if o.joint_name == "joint_6"]
    assert wrist.passes == 0 and not wrist.informative and wrist.speed_levels == ()
    assert wrist.rejected == {"held still": 12}  # one for each motion of the others
    assert wrist.note == "joint_6: never moved at a constant speed >= 10 rad/s motor in this shift"
    assert "joint_6: 0 passes" in shift.summary()


def test_production_observer_rejects_a_reverse_pass_at_another_configuration(gravity) -> None:
    # the last wrist moves 0.05 rad (5 x the configuration tolerance) before each reverse pass
    _, t, q, v, u = _program(speeds=(0.5,), reps=1, offset=(5, 0.05))
    shift = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, gravity=gravity)
    assert shift.levels == ()
    for name in NAMES[:5]:
        assert shift.joints[name].rejected["configuration mismatch"] == 2
        assert shift.joints[name].paired == 0
    # the same passes within the tolerance pair
    loose = [replace(c, configuration_tolerance=0.1) for c in CONFIGS]
    shift = observe_production(t, q, v, u, joint_names=NAMES, config=loose, gravity=gravity)
    assert {o.joint_name for o in shift.levels} == set(NAMES[:5])


def test_production_observer_leaves_the_accelerations_out(line, gravity) -> None:
    _, t, q, v, u = line
    shift = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, gravity=gravity)
    cruise = CRUISE * RATE  # samples at cruise in one pass
    for obs in shift.observations:
        assert 0.7 * cruise <= obs.samples_plus <= cruise and 0.7 * cruise <= obs.samples_minus <= cruise
    # a trapezoid whose inertial torque is 50 x its friction during the ramps: tau_f exact at cruise
    tt = np.arange(0.0, 10.0, 0.004)
    ramp = np.clip(np.minimum(tt, 4.0 - tt) / 0.5, 0.0, 1.0) - np.clip(np.minimum(tt - 5.0, 9.0 - tt) / 0.5, 0.0, 1.0)
    vel = 0.5 * ramp
    acc = np.gradient(vel, tt)
    pos = np.concatenate(([0.0], np.cumsum(vel[:-1]) * 0.004))
    eff = np.sign(vel) * 2.0 + 100.0 * acc + 10.0 * np.cos(pos)
    shift = observe_production(tt, pos, vel, eff)
    (obs,) = shift.levels
    assert obs.tau_f == pytest.approx(0.02, abs=1e-5)  # 2 N·m / torque_scale 100 (ramps: 1.0)
    # a motion that only accelerates (a triangle): no constant speed, said so
    tri = np.clip(1.0 - np.abs(tt - 2.0), 0.0, None) - np.clip(1.0 - np.abs(tt - 6.0), 0.0, None)
    shift = observe_production(tt, np.cumsum(tri) * 0.004, tri, np.sign(tri) * 2.0)
    assert shift.levels == () and shift.joints["joint_1"].rejected == {"acceleration": 2}
    # a slow ramp within the acceleration limit: no constant speed either
    slow = np.where(tt < 8.0, 0.1 + 0.02 * tt, 0.0)
    shift = observe_production(tt, np.cumsum(slow) * 0.004, slow, np.full(tt.size, 2.0))
    assert shift.joints["joint_1"].rejected == {"speed spread": 1}


def test_a_payload_carried_one_way_biases_tau_f_and_the_pairing_rejects_it(gravity) -> None:
    arm, t, q, v, u = _program(reps=2, payload_forward=3.0)
    blind = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS)
    # gravity given, its check switched off: the configurations match, yet the bias stays
    unchecked = observe_production(t, q, v, u, joint_names=NAMES, gravity=gravity,
                                   config=[replace(c, load_tolerance_gravity=1e6) for c in CONFIGS])
    for shift in (blind, unchecked):
        for obs in shift.levels:
            if obs.joint_name in ("joint_2", "joint_3"):
                assert abs(obs.tau_f - _truth(arm, q, v, obs.joint_name, obs.speed)) > 20 * obs.tau_f_std
    checked = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, gravity=gravity)
    for name in ("joint_2", "joint_3"):
        assert checked.joints[name].rejected == {"load mismatch": 8}
        assert not [o for o in checked.levels if o.joint_name == name]


def test_model_based_observations_come_only_from_unpaired_segments(line, rigid_body) -> None:
    _, t, q, v, u = line
    paired = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, rigid_body=rigid_body)
    assert set(paired.level_kinds) == {"paired"} and all(paired.joints[n].model == 0 for n in NAMES)
    arm, t, q, v, u = _program(speeds=(0.5,), reps=2, offset=(5, 0.05))
    shift = observe_production(t, q, v, u, joint_names=NAMES, config=CONFIGS, rigid_body=rigid_body)
    assert set(shift.level_kinds) == {"model"}
    for name in NAMES[:5]:
        c = shift.joints[name]
        assert (c.passes, c.paired, c.model, c.rejected_total) == (4, 0, 4, 0)
        for obs in (o for o in shift.levels if o.joint_name == name):
            truth = _truth(arm, q, v, name, obs.speed)
            assert abs(obs.tau_f - truth) <= 3.0 * obs.tau_f_std, (name, obs.tau_f, truth, obs.tau_f_std)


def test_streaming_batch_and_chunked_give_the_same_shift_bit_for_bit(line, gravity) -> None:
    _, t, q, v, u = line
    temps = 40.0 + 0.001 * np.arange(t.size)[:, None] + np.arange(6)[None, :]
    batch = observe_production(t, q, v, u, temps, joint_names=NAMES, config=CONFIGS, gravity=gravity, shift_id=3)
    live = ProductionObserver(NAMES, CONFIGS, gravity=gravity)
    for k in range(t.size):
        live.add(float(t[k]), q[k].tolist(), v[k].tolist(), u[k].tolist(), temps[k].tolist())
    assert live.waiting == 0  # every pass found its partner as it ended: nothing kept but the pairs
    streamed = live.end_shift(3)
    assert batch.levels and all(math.isfinite(o.temperature) for o in batch.levels)
    for chunk in (1, 7, 1000):
        chunked = observe_production(t, q, v, u, temps, joint_names=NAMES, config=CONFIGS, gravity=gravity,
                                     shift_id=3, chunk=chunk)
        assert repr(chunked) == repr(batch)
    assert repr(streamed) == repr(batch)
    # the next shift starts empty
    assert live.end_shift(4).levels == ()


def test_production_observer_refuses_bad_samples_in_one_line_and_keeps_its_state() -> None:
    obs = ProductionObserver(["a", "b"])
    obs.add(0.0, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputDataError, match=r"positions has 3 value\(s\); the arm has 2 joints"):
        obs.add(0.01, [0.0, 0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputDataError, match="efforts of b is nan; expected a finite number"):
        obs.add(0.01, [0.0, 0.0], [0.0, 0.0], [0.0, math.nan])
    with pytest.raises(InputDataError, match="not after the previous sample's 0.0 s"):
        obs.add(-0.01, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(InputDataError, match="stamp is inf"):
        obs.add(math.inf, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0])
    obs.add(0.01, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [math.nan, 30.0])  # an unknown temperature is fine
    assert obs.end_shift(1).samples == 2
    with pytest.raises(InputDataError, match="joint names must be non-empty and unique"):
        ProductionObserver(["a", "a"])
    with pytest.raises(InputDataError, match="configuration_tolerance concerns the whole arm"):
        ProductionObserver(["a", "b"], [ProductionConfig(), ProductionConfig(configuration_tolerance=0.5)])
    with pytest.raises(InputDataError, match=r"production observer setting max_accel=-1: outside the declared range"):
        ProductionConfig(max_accel=-1.0)
    with pytest.raises(InputDataError, match=r"velocities has shape \(3, 1\); expected \(4, 1\)"):
        observe_production(np.arange(4.0), np.zeros(4), np.zeros(3), np.zeros(4))


def test_every_rejection_reason_is_one_of_the_documented_reasons(line, gravity) -> None:
    _, t, q, v, u = line
    half = t.size // 3  # a shift cut in the middle of the program: its last motion stops with the data
    shift = observe_production(t[:half], q[:half], v[:half], u[:half], joint_names=NAMES, config=CONFIGS,
                               gravity=gravity)
    reasons = {r for c in shift.joints.values() for r in c.rejected}
    assert reasons <= set(REASONS) and "held still" in reasons


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_random_samples_raise_nothing_but_input_data_error(data: st.DataObject) -> None:
    n_joints = data.draw(st.integers(1, 3))
    obs = ProductionObserver([f"j{i}" for i in range(n_joints)], ProductionConfig(min_samples=2, min_duration=0.0,
                                                                                 min_bins=1, moving_speed=0.5))
    floats = st.floats(allow_nan=True, allow_infinity=True, width=64) | st.floats(-3.0, 3.0)
    t = 0.0
    row: list[list[float]] = [[0.0] * n_joints] * 3
    for _ in range(data.draw(st.integers(0, 60))):
        # a new random row, the last one held (runs at one speed: segments) or reversed (pairs)
        what = data.draw(st.sampled_from(["new", "hold", "reverse"]))
        if what == "reverse":  # the same speeds the other way at the same positions: a pair
            row = [row[0], [-x for x in row[1]], row[2]]
        elif what == "new":
            sizes = data.draw(st.lists(st.sampled_from([n_joints, n_joints, n_joints, n_joints + 1]), min_size=3,
                                       max_size=3))
            row = [data.draw(st.lists(floats, min_size=k, max_size=k)) for k in sizes]
        temps = data.draw(st.none() | st.lists(floats, min_size=n_joints, max_size=n_joints))
        for _ in range(data.draw(st.sampled_from([1, 1, 20]))):
            t += data.draw(st.sampled_from([0.002, 0.002, 0.002, 0.5, -0.001, 0.0]))
            try:
                obs.add(t, row[0], row[1], row[2], temps)
            except InputDataError as exc:
                assert "\n" not in str(exc)
    shift = obs.end_shift(1)
    assert isinstance(shift, ProductionShift)


def test_a_pass_waits_pair_horizon_for_its_reverse_partner_then_gives_up() -> None:
    # forward at 0.5 rad/s, then (the arm stopped 100 s, no samples) the same path in reverse
    t = np.arange(0.0, 4.0, 0.004)
    v = np.where((t > 0.2) & (t < 3.8), 0.5, 0.0)
    q = np.concatenate(([0.0], np.cumsum(v[:-1]) * 0.004))
    tt = np.concatenate((t, t + 104.0))
    vv = np.concatenate((v, -v))
    qq = np.concatenate((q, q[-1] - q))
    uu = np.sign(vv) * 20.0 + 5.0
    waits = observe_production(tt, qq, vv, uu, config=ProductionConfig(pair_horizon=200.0))
    assert waits.level_kinds == ("paired",) and waits.levels[0].tau_f == pytest.approx(0.2)
    gives_up = observe_production(tt, qq, vv, uu, config=ProductionConfig(pair_horizon=50.0))
    assert gives_up.levels == () and gives_up.joints["joint_1"].rejected == {"no reverse partner": 2}
