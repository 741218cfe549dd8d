"""The real arm as the simulated plant (``jointwear_ros.sim.ArmSim``): Pinocchio's dynamics of a UR5 and a Panda.

Checked against the model's truth: the arms' data agree with their URDFs; at zero command the arm holds still
under gravity; every joint tracks its speed while the others move; and ARMS.md's claim on this simulator:
along one straight line in joint space, forward and back at constant speeds, (u+ - u-)/2 is each joint's
friction and (u+ + u-)/2 Pinocchio's gravity + velocity-quadratic torque, whatever the coupling.
"""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

from jointwear_ros.errors import ParameterError  # noqa: E402
from jointwear_ros.sim import ARMS, ArmSim, JointSimConfig, RobotSim, arm_configs, arm_spec  # noqa: E402
from jointwear_ros.sim.arms import LOOP_BANDWIDTH  # noqa: E402

#: one line in joint space per arm: every joint at its own speed (rad/s), signs mixed
LINES = {"ur5": [0.4, -0.3, 0.35, 0.5, -0.45, 0.6], "panda": [0.4, 0.3, -0.35, 0.3, 0.5, -0.45, 0.6]}
RAMP, CRUISE, DT = 0.1, 1.0, 1e-3


def _names(n: int) -> list[str]:
    return [f"joint_{i + 1}" for i in range(n)]


def _model(name: str, payload: float = 0.0):
    spec = arm_spec(name)
    sim = ArmSim(spec, _names(len(spec.joints)), arm_configs(spec, _names(len(spec.joints))),
                 seeds=range(len(spec.joints)), payload=payload)
    return spec, sim


def _line_sim(arm: str, *, noise: bool = True, payload: float = 0.0, seed: int = 0, **settings) -> tuple:
    """An arm set up for one straight line: every joint's ramp takes RAMP s (accel_limit = |speed| / RAMP), so
    the ramps stay on the line too; the sweep centred on the test pose."""
    spec = arm_spec(arm)
    c = np.array(LINES[arm])
    names = _names(len(c))
    start = np.array([j.home for j in spec.joints]) - c * (CRUISE + RAMP) / 2
    if not noise:
        settings = {"noise_std": 0.0, "effort_noise_std": 0.0, **settings}
    cfgs = [replace(cfg, accel_limit=abs(ci) / RAMP, initial_position=float(s))
            for cfg, ci, s in zip(arm_configs(spec, names, **settings), c, start, strict=True)]
    return ArmSim(spec, names, cfgs, seeds=range(seed, seed + len(c)), payload=payload), c, start


def _sweep(sim: ArmSim, c: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The open-loop velocity script: ramp up, cruise across the window, ramp down, rest; the same line back.
    Returns each direction's cruise samples (positions, velocities, efforts N·m)."""
    rec: dict[int, list] = {1: [], -1: []}

    def run(cmd: np.ndarray, seconds: float, sign: int = 0) -> None:
        sim.set_commands(list(cmd))
        for _ in range(round(seconds / DT)):
            sim.step(DT)
            if sign:
                rec[sign].append(sim.sample())

    for sign in (1, -1):
        run(sign * c, RAMP + 0.05)
        run(sign * c, CRUISE - 0.05, sign)
        run(0.0 * c, RAMP + 0.3)
    return {k: tuple(np.array([r[m] for r in v]) for m in range(3)) for k, v in rec.items()}  # type: ignore[misc]


def _matched(sim: ArmSim, rec: dict, c: np.ndarray, start: np.ndarray, points: int = 40):
    """At matched configurations (the same position along the line, both passes, the middle 80 % of the
    window): (u+ - u-)/2 with the sign of each joint's speed, (u+ + u-)/2, the true friction at the
    commanded speeds and Pinocchio's RNEA(q, v, 0), N·m, one row per configuration."""
    d = c / np.linalg.norm(c)
    qf, _, uf = rec[1]
    qb, _, ub = (a[::-1] for a in rec[-1])
    sf, sb = (qf - start) @ d, (qb - start) @ d
    lo, hi = max(sf.min(), sb.min()), min(sf.max(), sb.max())
    grid = np.linspace(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo), points)
    cols = range(len(c))
    up = np.array([np.interp(grid, sf, uf[:, i]) for i in cols]).T
    um = np.array([np.interp(grid, sb, ub[:, i]) for i in cols]).T
    q = np.array([(np.interp(grid, sf, qf[:, i]) + np.interp(grid, sb, qb[:, i])) / 2 for i in cols]).T
    friction = np.array([[sim.true_friction(n, abs(ci), qk, c) for n, ci in zip(sim.names, c, strict=True)]
                         for qk in q])
    bias = np.array([sim.inverse_dynamics(qk, c) for qk in q])
    return np.sign(c) * (up - um) / 2, (up + um) / 2, friction, bias


def _sigma(sim: ArmSim) -> np.ndarray:
    """The scatter of one (u+ - u-)/2 estimate averaged over a window, N·m: the per-sweep offsets' sigma_e
    (JointSim's noise design) and the white effort noise's share over about 40 matched points."""
    return np.array([np.hypot(j.config.noise_std, j.config.effort_noise_std / np.sqrt(2 * 40)) * j.config.torque_scale
                     for j in sim.joints])


# -- the arms' data ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(ARMS))
def test_the_arms_data_agree_with_their_urdfs_and_the_test_pose_is_inside_the_limits(name):
    spec, sim = _model(name)
    full = pin.buildModelFromUrdf(str(spec.urdf_path()))
    for aj in spec.joints:
        k = full.joints[full.getJointId(aj.name)].idx_q
        assert (aj.effort, aj.velocity) == pytest.approx((full.effortLimit[k], full.velocityLimit[k]), rel=1e-9), aj
        assert (aj.lower, aj.upper) == pytest.approx((full.lowerPositionLimit[k], full.upperPositionLimit[k]),
                                                     abs=1e-5), aj
        assert aj.lower < aj.home < aj.upper and aj.torque_limit * aj.torque_scale == aj.effort
    assert sim.model.nv == len(spec.joints) and list(sim.model.armature) == [aj.armature for aj in spec.joints]


@pytest.mark.parametrize("name", list(ARMS))
def test_each_joints_nominal_inertia_is_within_the_models_range_over_the_windows_and_payloads(name):
    """The gains are sized from it: within Pinocchio's M(q)_jj over the windows (±1.1 rad of the test pose)
    and payloads 0-5 kg, and the loop stays stable at 1 kHz at the smallest inertia (Kp dt / M_jj < 1)."""
    spec, sim = _model(name)
    rng = np.random.default_rng(0)
    lo, hi = np.array([j.lower for j in spec.joints]), np.array([j.upper for j in spec.joints])
    home = np.array([j.home for j in spec.joints])
    diag = []
    for kg in (0.0, 5.0):
        sim.set_payload(kg)
        for _ in range(400):
            q = np.clip(home + rng.uniform(-1.1, 1.1, home.size), lo, hi)
            diag.append(np.diag(pin.crba(sim.model, sim.data, q)).copy())
    m_min, m_max = np.min(diag, axis=0), np.max(diag, axis=0)
    for aj, a, b in zip(spec.joints, m_min, m_max, strict=True):
        assert 0.9 * a <= aj.inertia <= 1.1 * b, (aj.name, aj.inertia, a, b)
        kp_joint = aj.kp * aj.gear_ratio * aj.torque_scale  # N·m per joint rad/s
        assert kp_joint == pytest.approx(2 * LOOP_BANDWIDTH * aj.inertia)
        assert kp_joint * 1e-3 / a < 1.0, aj.name


def test_importing_the_sim_package_does_not_import_pinocchio_until_the_arm_is_used():
    code = ("import sys, jointwear_ros.sim as s; before = 'pinocchio' in sys.modules; s.ArmSim; "
            "print(before, 'pinocchio' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "True"]


def test_unknown_arms_too_many_joints_and_a_pose_outside_the_limits_are_one_line_errors():
    with pytest.raises(ParameterError, match=r"^unknown arm 'kuka'; known arms: ur5, panda$"):
        arm_spec("kuka")
    spec = arm_spec("ur5")
    with pytest.raises(ParameterError, match=r"arm ur5 has 6 joints \(shoulder_pan_joint, .*7 joint names"):
        ArmSim(spec, _names(7), [], seeds=range(7))
    cfgs = arm_configs(spec, _names(6))
    cfgs[2] = replace(cfgs[2], initial_position=4.0)
    with pytest.raises(ParameterError, match=r"joint_3 \(elbow_joint\) initial_position 4 rad is outside"):
        ArmSim(spec, _names(6), cfgs, seeds=range(6))



@pytest.mark.parametrize("kind", ["arm", "robot"])
def test_a_command_of_the_wrong_length_or_not_finite_is_refused_whole(kind):
    """All or none, on the arm and on the independent-joint robot alike: the message names the slip and
    every joint keeps the command it had."""
    if kind == "arm":
        _spec, sim = _model("ur5")
        owner = r"the arm has 6 driven joint\(s\)"
    else:
        sim = RobotSim(_names(6), [JointSimConfig()] * 6, seeds=range(6))
        owner = r"the robot has 6 joint\(s\)"
    sim.set_commands([0.1, -0.2, 0.0, 0.0, 0.3, 0.0])
    before = sim.commands
    with pytest.raises(ParameterError, match=rf"^command has 5 value\(s\), {owner} \(joint_1, .*, joint_6\)$"):
        sim.set_commands([0.5] * 5)
    with pytest.raises(ParameterError, match=r"^command not finite: data\[1\] = nan, data\[4\] = inf$"):
        sim.set_commands([0.5, float("nan"), 0.5, 0.5, float("inf"), 0.5])
    assert sim.commands == before


# -- holding and tracking ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(ARMS))
@pytest.mark.parametrize("payload", [0.0, 3.0])
def test_at_zero_command_the_arm_holds_still_under_gravity(name, payload):
    _spec, sim = _model(name, payload)
    q0 = sim.positions
    assert np.abs(sim.gravity()).max() > 20.0  # there is gravity to hold
    worst = 0.0
    for _ in range(3000):
        sim.step(DT)
        worst = max(worst, float(np.abs(sim.positions - q0).max()))
    assert worst < 1e-4, worst
    # the drives hold the gravity torque (the efforts, N·m, are the drive torques), within the breakaway
    # friction and the effort noise
    _, vel, eff = sim.sample()
    assert vel == [0.0] * len(vel)
    for j, e, gj in zip(sim.joints, eff, sim.gravity(), strict=True):
        ts = j.config.torque_scale
        assert abs(e - gj) < (j.friction(0.0, abs(gj) / ts) + 5 * j.config.effort_noise_std) * ts, (e, gj)


def test_a_payload_set_while_holding_sags_the_arm_until_its_drives_catch_it():
    _spec, sim = _model("ur5")
    q0 = sim.positions
    sim.step(0.5)
    sim.set_payload(5.0)  # at the test pose 3 kg stays within the shoulder's static friction: it would not sag
    sag = 0.0
    for _ in range(2000):
        sim.step(DT)
        sag = max(sag, float(np.abs(sim.positions - q0).max()))
    assert 1e-4 < sag < 0.02  # it moved, and not far
    assert np.abs(sim.positions - q0).max() < 2e-3  # and is back, within the breakaway band
    assert sim.gravity()[1] < _model("ur5")[1].gravity()[1] - 10.0  # 5 kg pull on the shoulder


@pytest.mark.parametrize("speed", [0.4, -0.4])
def test_one_joint_at_speed_drives_its_friction_while_a_nearly_coaxial_joint_is_held_by_static_friction(speed):
    """At the Panda's test pose joints 1 and 3 are nearly coaxial (M[0, 2] 1.05 against M[0, 0] 1.14 kg·m²):
    joint 1's run-up at 8 rad/s² pushes joint 3 past its breakaway and it comes to rest again, held by its
    static friction. The stick band then has to be solved with the swept joint's acceleration of the same
    step: with the previous step's, the two chattered (±7 rad/s² every step) and joint 1's drive torque at
    constant speed read 2.5 times its friction (the one-after-another cycle: 192 % off on joint 1)."""
    spec = arm_spec("panda")
    names = _names(7)
    cfgs = [replace(c, accel_limit=8.0, noise_std=0.0, effort_noise_std=0.0)
            for c in arm_configs(spec, names, wear=20.0)]
    sim = ArmSim(spec, names, cfgs, seeds=range(7))
    sim.set_commands([speed] + [0.0] * 6)
    sim.step(0.3)  # the run-up (0.05 s) and the loop's settling
    held = sim.positions[1:]
    eff, vel = [], []
    for _ in range(200):
        sim.step(DT)
        _, v, e = sim.sample()
        eff.append(e)
        vel.append(v)
    truth = sim.true_friction("joint_1")
    u = np.array(eff)
    assert np.abs(u[:, 0] - np.sign(speed) * truth).max() < 0.005 * truth, (u[:, 0].min(), u[:, 0].max(), truth)
    assert np.abs(np.array(vel)[:, 0] - speed).max() < 1e-6
    assert np.array(vel)[:, 1:].tolist() == [[0.0] * 6] * 200  # the others at rest, held
    assert np.abs(sim.positions[1:] - held).max() == 0.0


@pytest.mark.parametrize("name", list(ARMS))
def test_every_joint_tracks_its_constant_speed_within_1_percent_while_the_others_move(name):
    sim, c, _start = _line_sim(name, payload=3.0)
    rec = _sweep(sim, c)
    for sign in (1, -1):
        vel = rec[sign][1][round(0.05 / DT):]  # cruise: from 0.1 s after the ramps (the loop has settled)
        err = np.abs(vel - sign * c).max(axis=0) / np.abs(c)
        assert (err < 0.01).all(), (sign, err)
        assert (np.abs(rec[sign][0] - rec[sign][0][0]).max(axis=0) > 0.2).all()  # every joint moved


def test_the_drive_keeps_to_the_urdfs_velocity_and_position_limits():
    spec = arm_spec("panda")
    names = _names(7)
    sim = ArmSim(spec, names, arm_configs(spec, names), seeds=range(7))
    sim.set_commands([5.0, 0, 0, 2.0, 0, 0, 0])  # joint 1 above 2.175 rad/s; joint 4 towards its upper limit
    top = 0.0
    for _ in range(2500):
        sim.step(DT)
        top = max(top, abs(sim.velocities[0]))
    assert top == pytest.approx(spec.joints[0].velocity, rel=0.01)
    assert spec.joints[3].upper - 0.01 < sim.positions[3] <= spec.joints[3].upper
    assert abs(sim.velocities[3]) < 1e-6


# -- Eq. (5) on the coupled arm ---------------------------------------------------------------------
@pytest.mark.parametrize("name", list(ARMS))
def test_reversed_sweeps_along_one_line_give_each_joints_friction_and_the_models_gravity_without_noise(name):
    """ARMS.md's claim, on the arm's truth: at matched configurations and constant speeds, (u+ - u-)/2 is each
    joint's friction and (u+ + u-)/2 is RNEA(q, v, 0) = g(q) + C(q, v) v, for every joint at once."""
    sim, c, start = _line_sim(name, noise=False)
    half_diff, half_sum, friction, bias = _matched(sim, _sweep(sim, c), c, start)
    residual = np.abs(half_diff - friction).max(axis=0) / friction.mean(axis=0)
    assert (residual < 0.005).all(), residual  # < 0.5 % of each joint's friction, every configuration
    coupling = np.abs(bias - sim.gravity()).max()  # the sum carries more than gravity: C(q, v) v and the load
    assert np.abs(half_sum - bias).max() < 0.01, np.abs(half_sum - bias).max(axis=0)
    assert coupling > 1.0


@pytest.mark.parametrize("name", list(ARMS))
def test_with_noise_each_joints_reversed_sweep_estimate_is_its_friction_within_the_noise(name):
    sim, c, start = _line_sim(name, seed=11)
    half_diff, _half_sum, friction, _bias = _matched(sim, _sweep(sim, c), c, start)
    err = np.abs(half_diff.mean(axis=0) - friction.mean(axis=0))
    assert (err < 4 * _sigma(sim)).all(), (err, _sigma(sim))


def test_a_payload_moves_the_sum_by_its_gravity_and_the_difference_only_by_the_friction_models_load_term():
    """0 -> 3 kg between two sweeps on the same line: (u+ + u-)/2 moves by the payload's RNEA torque; (u+ - u-)/2
    moves by what the true friction moves with the new load |g_j(q) + C_j(q, v) v| (ref-2011r's load term), within
    the noise, so hardly on the base joint (vertical axis: no gravity torque, only the coupling's)."""
    sim, c, start = _line_sim("ur5", seed=3)
    d0, s0, f0, b0 = _matched(sim, _sweep(sim, c), c, start)
    sim.set_payload(3.0)
    sim.step(1.0)
    d3, s3, f3, b3 = _matched(sim, _sweep(sim, c), c, start)
    sigma = _sigma(sim)
    white = np.array([j.config.effort_noise_std * j.config.torque_scale for j in sim.joints]) / np.sqrt(40)
    moved = (s3 - s0).mean(axis=0)
    assert np.abs(moved - (b3 - b0).mean(axis=0)).max() < (4 * white + 4 * sigma).max()
    assert moved[1] < -10.0 and moved[2] < -5.0  # the shoulder and elbow carry 3 kg (11 and 7.5 N·m)
    change = (d3 - d0).mean(axis=0) - (f3 - f0).mean(axis=0)
    assert (np.abs(change) < 4 * np.sqrt(2) * sigma).all(), (change, sigma)
    assert abs((d3 - d0).mean(axis=0)[0]) < 4 * np.sqrt(2) * sigma[0]


def test_wear_and_temperature_set_live_change_that_joints_friction_only():
    sim, c, start = _line_sim("ur5", noise=False)
    d0, _, _f0, _ = _matched(sim, _sweep(sim, c), c, start)
    j2, j4 = sim["joint_2"], sim["joint_4"]
    sim.reconfigure("joint_2", replace(j2.config, wear=40.0))
    sim.reconfigure("joint_4", replace(j4.config, temperature=25.0))
    d1, _, f1, _ = _matched(sim, _sweep(sim, c), c, start)
    change = (d1 - d0).mean(axis=0) / d0.mean(axis=0)
    assert change[1] > 0.05 and change[3] > 0.05, change  # worn, and colder: more friction
    assert np.abs(np.delete(change, [1, 3])).max() < 0.005, change
    assert np.abs(d1 - f1).max(axis=0).max() / f1.mean() < 0.01  # the estimate follows the new friction
