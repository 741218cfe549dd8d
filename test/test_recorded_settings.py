"""The recorded settings travel with every bag (issue 20, point 3): a recorder started after the nodes,
and one bag per cycle, still hold every node's parameters (metadata.yaml), run-time changes on top."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import spin_until  # noqa: E402
from jointwear_msgs.msg import TestCycleStatus  # noqa: E402  (a message, not a test class: conftest)
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402

from jointwear_ros.io.bags import recorded_settings  # noqa: E402
from jointwear_ros.nodes.recorder import RecorderNode  # noqa: E402

pytestmark = pytest.mark.ros


def test_per_cycle_bags_of_a_recorder_started_after_the_nodes_hold_their_settings(ros_context_per_test, tmp_path):
    ctx = ros_context_per_test
    ex = SingleThreadedExecutor(context=ctx)
    try:
        est = rclpy.create_node("wear_estimator", context=ctx)  # declared before any recorder runs
        est.declare_parameter("method", "paper")
        est.declare_parameter("params", "ref-2011r")
        est.declare_parameter("alarm_threshold", 35.0)
        ex.add_node(est)
        status = est.create_publisher(TestCycleStatus, "/rs_test/status", QoSProfile(
            depth=100, reliability=ReliabilityPolicy.RELIABLE))
        rec = RecorderNode(context=ctx, parameter_overrides=[
            Parameter("output_dir", value=str(tmp_path)), Parameter("discovery_period", value=0.1),
            Parameter("split", value="cycle"), Parameter("cycle_tail", value=0.0),
            Parameter("status_topic", value="/rs_test/status"),
            Parameter("include", value=["^/rs_test/status$", "^/parameter_events$"])])
        ex.add_node(rec)
        assert spin_until(ex, lambda: "wear_estimator" in rec._settings and "/rs_test/status" in rec.recorded_topics
                           and status.get_subscription_count() >= 1)

        def cycle(cid: int) -> None:
            n = len(rec.bags)
            for state in (CycleState_RUNNING, CycleState_DONE):
                status.publish(TestCycleStatus(joint_name="joint_1", cycle_id=cid, state=state, speeds_total=2))
                assert spin_until(ex, lambda: rec._queue.empty() and len(rec.bags) == n + 1), (rec.received, rec.bags, rec.recorded_topics, rec.dropped)
            assert spin_until(ex, lambda: rec._bag is None)

        CycleState_RUNNING, CycleState_DONE = TestCycleStatus.RUNNING, TestCycleStatus.DONE
        cycle(1)
        est.set_parameters([Parameter("method", value="bayes")])  # between cycles, seen on /parameter_events
        assert spin_until(ex, lambda: rec._settings.get("wear_estimator", {}).get("method") == "bayes")
        cycle(2)
        rec.on_shutdown()
        first, second = rec.bags
        s1, s2 = recorded_settings(first)["wear_estimator"], recorded_settings(second)["wear_estimator"]
        assert (s1["method"], s1["params"], s1["alarm_threshold"]) == ("paper", "ref-2011r", 35.0)
        assert (s2["method"], s2["params"]) == ("bayes", "ref-2011r")
        rec.destroy_node()
        est.destroy_node()
    finally:
        ex.shutdown()
