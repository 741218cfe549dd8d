"""``jointwear demo --production`` on a real graph: the UR5's pick-and-place (two shifts of three cycles, a 2 kg part
carried one way, the product mix), its joint states played onto production_observer, wear_estimator,
cycle_on_demand and the recorder, the production estimates against the true wear, and the replay of the recorded
bag equal to live. About a minute of wall time.

The contract (issue 31): ``--json`` has ``wear`` (a list: ``joint``, ``estimate``, ``std``, ``source`` =
``production``), ``true_wear`` (a list: ``joint``, ``wear``) and the pass counts. The demo runs on this module's
ROS domain; ``JOINTWEAR_TEST_DOMAIN`` pins another.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytest.importorskip("rclpy")
pytest.importorskip("pinocchio")

pytestmark = [pytest.mark.ros]


@pytest.fixture(scope="module")
def run(tmp_path_factory, ros_domain_of_the_module):
    out = tmp_path_factory.mktemp("production")
    domain = os.environ.get("JOINTWEAR_TEST_DOMAIN") or str(ros_domain_of_the_module)
    proc = subprocess.run([sys.executable, "-m", "jointwear_ros", "demo", "--production", "--json", "--out",
                           str(out / "demo"), "--domain-id", domain], capture_output=True, text=True, timeout=600)
    return proc


def test_the_production_demo_estimates_every_moved_joint_within_3_std_and_the_held_one_says_it_cannot_tell(run):
    assert run.returncode == 0, run.stderr[-3000:]
    doc = json.loads(run.stdout)
    true = {t["joint"]: t["wear"] for t in doc["true_wear"]}
    assert list(true) == [f"joint_{i}" for i in range(1, 7)] and true["joint_3"] == 40.0
    by_joint = {w["joint"]: w for w in doc["wear"]}
    assert set(by_joint) == set(true)
    for joint, w in by_joint.items():
        assert w["source"] == "production"
        if joint == "joint_6":  # the program holds the flange joint: no number, the reason
            assert w["estimate"] is None and w["std"] is None
            assert "joint_6: never moved at a constant speed" in w["reason"]
            continue
        assert w["estimate"] is not None and w["std"] > 0, w
        assert abs(w["estimate"] - true[joint]) <= 3.0 * w["std"], (joint, w, true[joint])
    # the levels follow from the estimates by the one rule: joint_3 (true 40) in ERROR, joint_1 (true 10) OK
    assert by_joint["joint_3"]["level"] == "ERROR" and by_joint["joint_1"]["level"] == "OK"
    passes = {p["joint"]: p for p in doc["passes"]}
    assert doc["passes_seen"] == sum(p["seen"] for p in passes.values()) > 0
    assert doc["passes_paired"] > 0 and doc["passes_rejected"] > 0
    # the part carried one way: the loaded joints' pairs were corrected for it, and the reasons are counted
    assert passes["joint_2"]["payload_corrected"] > 0 and passes["joint_4"]["payload_corrected"] > 0
    assert passes["joint_6"]["seen"] == 0 and passes["joint_6"]["rejected"].get("held still", 0) > 0
    assert doc["test_cycles_run"] == 0 and doc["production_stopped_seconds"] == 0.0


def test_the_recorded_bag_replays_to_the_live_production_observations_and_estimates(run):
    assert run.returncode == 0, run.stderr[-3000:]
    doc = json.loads(run.stdout)
    assert doc["replay_equals_live"] is True, doc["replay"]
    assert doc["replay"]["estimates_compared"] >= 5 and doc["replay"]["estimates_max_abs_diff"] == 0.0
    assert doc["replay"]["observations"].endswith(" 0 differ")


def test_a_production_demo_on_no_arm_is_one_line_and_exit_2():
    proc = subprocess.run([sys.executable, "-m", "jointwear_ros", "demo", "--production", "--arm", "none"],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "jointwear: error: --arm: the production demo runs on an arm (ur5, panda), not 'none'"]
