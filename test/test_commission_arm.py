"""The plan of a commissioning run on a real arm (``jointwear demo --commission --arm ur5|panda``), pure.

What changes a joint's load from cycle to cycle on an arm is what changes it on the real one: the payload and
the pose (each window centre shifted inside the arm's limits); joint gravity settings do not apply. The plan's
load of a joint is the arm's gravity torque at the cycle's window centres and payload (Pinocchio). A joint whose
axis stays vertical (the UR5's and the Panda's base) has no gravity load in any pose: the plan says so and its
commissioning leaves the load out. The overload cycle carries a payload that takes one joint near its effort
limit at rest (the drive still holds it) and over test_cycle's limit once the arm accelerates.
"""

from __future__ import annotations

import numpy as np
import pytest

from jointwear_ros.commission.demo import (
    ARM_LOADING,
    arm_joints,
    load_identifiable,
    load_span,
    plan_arm_commissioning,
    unloaded_joints,
    window_range,
)
from jointwear_ros.sim.arm import ArmSim, arm_configs
from jointwear_ros.sim.arms import arm_spec

#: the joints of each arm whose gravity load the payload and pose change (shoulder, elbow, a wrist), and the
#: joints with no gravity load in any pose (a vertical axis, or the payload on the axis)
LOADED = {"ur5": ("joint_2", "joint_3", "joint_4"), "panda": ("joint_2", "joint_4", "joint_6")}
UNLOADED = {"ur5": {"joint_1", "joint_5"}, "panda": {"joint_1", "joint_7"}}  # vertical axes, loads through the axis


def _plan(arm: str, k: int = 6):
    n = len(arm_spec(arm).joints)
    js = arm_joints(arm, [f"joint_{i}" for i in range(1, n + 1)])
    return js, plan_arm_commissioning(arm, js, baseline_cycles=k, test_wear=(10, 30, 40))


@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_on_the_arm_payload_and_pose_change_each_loaded_joints_load_between_baseline_cycles(arm):
    js, plan = _plan(arm)
    baseline = [c for c in plan if c.stage == "baseline"]
    payloads = [c.payload for c in baseline]
    assert min(payloads) == 0.0 and max(payloads) == ARM_LOADING[arm].payload
    assert len(set(payloads)) == len(payloads)  # another payload every cycle
    spec = arm_spec(arm)
    allowed = window_range(arm, [j.name for j in js], ARM_LOADING[arm].reach)
    for i, j in enumerate(js):
        centres = [c.settings[j.name].position for c in baseline]
        lo, hi = allowed[j.name]
        assert all(lo - 1e-9 <= x <= hi + 1e-9 for x in centres), (j.name, centres, allowed[j.name])
        assert spec.joints[i].lower < lo <= hi < spec.joints[i].upper
        assert all(c.settings[j.name].wear == 0.0 for c in baseline)
    for name in LOADED[arm]:
        assert load_identifiable(plan, name), (name, load_span(plan, name))
        assert len({round(c.settings[name].position, 3) for c in baseline}) > 1 or name == "joint_1"
    # the planned load is the arm's gravity at the cycle's window centres and payload, normalized
    sim = ArmSim(spec, [j.name for j in js], arm_configs(spec, [j.name for j in js]), seeds=range(len(js)))
    c = baseline[2]
    sim.set_payload(c.payload)
    g = sim.inverse_dynamics([c.settings[j.name].position for j in js], [0.0] * len(js))
    np.testing.assert_allclose([c.settings[j.name].gravity_torque for j in js],
                               [g[i] / j.torque_scale for i, j in enumerate(js)], atol=1e-3)


@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_joints_whose_load_hardly_changes_are_named_with_the_reason(arm):
    _, plan = _plan(arm)
    unloaded = unloaded_joints(plan)
    assert set(unloaded) == UNLOADED[arm]
    for name, why in unloaded.items():
        assert not load_identifiable(plan, name)
        assert why.startswith(f"{name}: ") and "cannot be identified" in why and "without the load column" in why


@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_the_overload_cycle_carries_a_payload_held_at_rest_below_one_joints_effort_limit(arm):
    _, plan = _plan(arm)
    first = plan[0]
    assert first.stage == "overload" and first.payload == ARM_LOADING[arm].overload_payload
    assert first.payload > max(c.payload for c in plan if c.stage == "baseline")
    j = first.overloaded
    # test_cycle's effort limit is 95 % of the URDF's: 1.9 torque scales; the drive saturates at 2.0. Held at rest the
    # payload stays below it (the arm is not overloaded standing still); moving, gravity, the acceleration and the
    # friction take that joint over it (test_commission_arm_run.py: the cycle fails there and is skipped by name)
    load = abs(first.settings[j].gravity_torque)
    assert 0.5 * 1.9 < load < 1.9, (j, load)
    assert load > max(abs(c.settings[j].gravity_torque) for c in plan if c.stage == "baseline")
    assert {c.stage for c in _plan_without_overload(arm)} == {"baseline", "test"}


def _plan_without_overload(arm: str):
    js, _ = _plan(arm)
    return plan_arm_commissioning(arm, js, baseline_cycles=4, overload=False)


@pytest.mark.parametrize("arm", ["ur5", "panda"])
def test_the_arms_joints_run_ref_2011r_and_are_commissioned_in_the_joint_frame_warming_up(arm):
    js, plan = _plan(arm)
    spec = arm_spec(arm)
    for j, aj in zip(js, spec.joints, strict=True):
        assert (j.params, j.frame, j.gear_ratio, j.torque_scale) == ("ref-2011r", "joint", aj.gear_ratio,
                                                                      aj.effort / 2)
    temps = [c.settings["joint_1"].temperature for c in plan if c.stage == "baseline"]
    assert temps == sorted(temps) and temps[-1] - temps[0] >= 20.0
    test = plan[-1]
    assert test.stage == "test" and [test.settings[j.name].wear for j in js[:3]] == [10.0, 30.0, 40.0]
    assert 0.0 < test.payload < ARM_LOADING[arm].payload  # inside the baseline's span
    for j in js:  # the test cycle's loads lie inside the baseline's span (or the joint has none)
        _, hi = load_span(plan, j.name)
        assert abs(test.settings[j.name].gravity_torque) <= hi + 0.02, j.name


def test_commissioning_demo_on_the_arm_checks_its_arguments_before_anything_starts(tmp_path, capsys, monkeypatch):
    from jointwear_ros.cli import demo_cmd, main

    started = []
    monkeypatch.setattr(demo_cmd, "run_commission_demo", lambda *a, **k: started.append((a, k)) or 1 / 0)
    for args, match in ((["--payload", "2"], "--payload"), (["--arm", "kuka"], "--arm"),
                        (["--joints", "7"], "has 6"), (["--arm", "panda", "--joints", "8"], "has 7")):
        rc = main(["demo", "--commission", *args, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert rc == 2 and match in err and err.count("\n") == 1, (args, err)
    assert not started and not (tmp_path / "o").exists()


def test_commissioning_demo_runs_on_the_ur5_every_joint_at_once_unless_told_otherwise(tmp_path, monkeypatch):
    from jointwear_ros.cli import demo_cmd, main

    calls = []

    def fake(*a, **k):
        calls.append(k)
        raise demo_cmd.DemoError("stopped here")

    monkeypatch.setattr(demo_cmd, "run_commission_demo", fake)
    for args in ([], ["--arm", "panda", "--joints", "7"], ["--sweep", "sequential"], ["--arm", "none"]):
        main(["demo", "--commission", *args, "--out", str(tmp_path / "o")])
    assert [(c["arm"], c["sweep"]) for c in calls] == [("ur5", "simultaneous"), ("panda", "simultaneous"),
                                                       ("ur5", "sequential"), (None, None)]
