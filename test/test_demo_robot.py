"""The six-joint demo: one robot cycle through one process per node, every joint estimated.

The same five node processes as the one-joint demo, configured for six joints as ``jointwear demo --joints 6``
runs them: joint_sim simulates the UR5 (Pinocchio's rigid-body dynamics from its URDF) on one /joint_states,
test_cycle sweeps every joint at once along one line under one cycle id, friction_observer and
wear_estimator serve all six. Each joint has its own true wear (OK, WARN and
ERROR joints in one robot); each estimate must lie within 3 of its standard deviations of the true
wear, each joint's /diagnostics level must be the one its estimate calls for, and the bag's offline
replay must give the same estimates per joint.
"""

from __future__ import annotations

import json
import math

import pytest

pytest.importorskip("rclpy")

from jointwear_ros.cli.demo_cmd import DEFAULT_ROBOT_WEAR, run_demo
from jointwear_ros.io.bags import read_messages

pytestmark = [pytest.mark.ros, pytest.mark.slow]

SPEEDS = [20.0, 40.0, 80.0, 160.0]
JOINTS = [f"joint_{k}" for k in range(1, 7)]
WARN_AT, ALARM_AT = 30.0, 35.0  # config/wear_estimator.yaml


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    return run_demo(list(DEFAULT_ROBOT_WEAR), SPEEDS, tmp_path_factory.mktemp("robot"), real_time_factor=3.0,
                    timeout=240.0, joints=6, arm="ur5", sweep="simultaneous")


def test_every_joint_is_tested_in_one_robot_cycle_and_estimated_within_3_std(robot):
    assert robot.final_state == "DONE"
    assert [j.joint for j in robot.joints] == JOINTS
    for j in robot.joints:
        assert j.final_state == "DONE", j.joint
        obs = [o for o in robot.observations if o["joint_name"] == j.joint]
        # measured mean speeds (joint_6 read above 160.5 at 160 on a loaded CI machine), within 1 % of the plan
        assert sorted(o["speed"] for o in obs) == pytest.approx(SPEEDS, rel=0.01), j.joint
        e = j.estimate
        assert e["cycle_id"] == robot.cycle_id and e["joint_name"] == j.joint
        assert 0 < e["wear_std"] < 5.0
        assert abs(e["wear"] - j.true_wear) <= 3.0 * e["wear_std"], (j.joint, e["wear"], e["wear_std"], j.true_wear)
    assert len(robot.observations) == 6 * len(SPEEDS)


def test_each_joint_has_its_own_diagnostic_level(robot):
    for j in robot.joints:
        w = j.estimate["wear"]
        expected = "ERROR" if w >= ALARM_AT else "WARN" if w >= WARN_AT else "OK"
        assert j.diagnostic_level == expected, (j.joint, w, j.diagnostic_message)
        assert j.estimate["alarm"] is (w >= ALARM_AT)
    levels = {j.diagnostic_level for j in robot.joints}
    assert "OK" in levels and "ERROR" in levels  # one robot, joints at different levels
    assert robot.diagnostic_level == "ERROR"  # the worst joint


def test_the_joints_are_tested_at_once_on_the_arm_in_the_cell_time_of_one(robot):
    cells = [j.cell_seconds for j in robot.joints]
    assert all(math.isfinite(c) and c > 0 for c in cells)
    assert max(cells) - min(cells) < 1.0  # every joint from the first status to the common end
    assert robot.cell_seconds < 30.0  # four speeds at once: 17.5 s planned; one after another plans 104.7 s
    assert (robot.arm, robot.sweep) == ("ur5", "simultaneous")
    assert robot.as_dict()["arm"] == "ur5"


def test_the_json_gives_wear_and_true_wear_as_lists_per_joint(robot):
    d = robot.as_dict()
    assert [w["joint"] for w in d["wear"]] == JOINTS
    assert set(d["wear"][0]) >= {"joint", "estimate", "std", "method", "temperature"}
    assert d["true_wear"] == [{"joint": j, "wear": w} for j, w in zip(JOINTS, DEFAULT_ROBOT_WEAR)]
    json.dumps(d)


def test_the_bag_holds_one_estimate_per_joint_of_the_cycle(robot):
    ests = [m.msg for m in read_messages(robot.bag, topics=["/jointwear/wear_estimate"])]
    newest = {}
    for e in ests:
        if e.cycle_id == robot.cycle_id:
            newest[e.joint_name] = e
    assert sorted(newest) == JOINTS
    for j in robot.joints:
        assert newest[j.joint].wear == j.estimate["wear"]


def test_robot_demo_arguments_are_checked_before_anything_starts(tmp_path, capsys):
    """In this process (the CLI's own main, no interpreter start per case): nothing is started."""
    from jointwear_ros.cli import main

    for args, match in ((["--joints", "0"], "--joints"), (["--joints", "3", "--wear", "1,2"], "2 values for --joints 3"),
                        (["--wear", "10,20"], "needs --joints"), (["--joints", "2", "--wear", "10,120"], "outside 0-100")):
        rc = main(["demo", *args, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert rc == 2 and match in err, (args, err)
        assert not (tmp_path / "o").exists()


def test_the_robot_bag_replays_offline_to_the_live_estimates_of_every_joint(robot):
    from jointwear_ros.io.params import node_params_from_yaml
    from jointwear_ros.replay import replay_bag
    from jointwear_ros.resources import config_path

    rep = replay_bag(robot.bag, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
                     node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))
    cmp_ = rep.comparison()
    assert cmp_["observations"]["max_abs_diff"] == 0.0 and cmp_["estimates"]["max_abs_diff"] == 0.0
    replayed = {(c.joint_name, c.cycle_id): c.result for c in rep.cycles if c.result is not None}
    for j in robot.joints:
        r = replayed[(j.joint, robot.cycle_id)]
        assert (r.wear, r.wear_std) == (j.estimate["wear"], j.estimate["wear_std"])
    assert len(rep.observations) == len(robot.observations)
