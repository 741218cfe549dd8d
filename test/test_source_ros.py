"""The wear_estimator node on real DDS: a production shift (``/production/status`` and production observations)
gives a ``WearEstimate`` with ``source: production``, the test cycle with the same id one with ``test_cycle``."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")

from conftest import spin_until  # noqa: E402
from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from test_source import _obs  # noqa: E402

from jointwear_ros import contract  # noqa: E402
from jointwear_ros.nodes.friction_observer import high_rate_qos  # noqa: E402
from jointwear_ros.nodes.wear_estimator import WearEstimatorNode  # noqa: E402

pytestmark = pytest.mark.ros


def _status(cycle_id: int, state: contract.CycleState) -> TestCycleStatus:
    return contract.status_to_msg(contract.CycleStatus(cycle_id=cycle_id, state=state, speeds_total=3,
                                                       joint_name="joint_1"), TestCycleStatus)


def test_the_estimator_publishes_a_production_shifts_estimate_as_production_and_the_test_cycles_apart(ros_context):
    ns = "/jw_source_test"
    node = WearEstimatorNode(context=ros_context, parameter_overrides=[
        Parameter("observations_topic", value=f"{ns}/observations"),
        Parameter("status_topic", value=f"{ns}/status"),
        Parameter("production_status_topic", value=f"{ns}/production_status"),
        Parameter("estimate_topic", value=f"{ns}/wear_estimate"),
        Parameter("diagnostics_topic", value=f"{ns}/diagnostics"),
        Parameter("seed", value=1),
    ])
    io = rclpy.create_node("jw_source_test_io", context=ros_context)
    ex = SingleThreadedExecutor(context=ros_context)
    for n in (node, io):
        ex.add_node(n)
    got: list[WearEstimate] = []
    try:
        ob_pub = io.create_publisher(FrictionObservation, f"{ns}/observations", high_rate_qos())
        st_pub = io.create_publisher(TestCycleStatus, f"{ns}/status", high_rate_qos())
        pr_pub = io.create_publisher(TestCycleStatus, f"{ns}/production_status", high_rate_qos())
        io.create_subscription(WearEstimate, f"{ns}/wear_estimate", got.append, 10)
        assert spin_until(ex, lambda: all(p.get_subscription_count() > 0 for p in (ob_pub, st_pub, pr_pub)))
        # production shift 4 (wear 40) and test cycle 4 (wear 10), interleaved on the one observations topic
        pr_pub.publish(_status(4, contract.CycleState.RUNNING))
        st_pub.publish(_status(4, contract.CycleState.RUNNING))
        assert spin_until(ex, lambda: len(node.channels["joint_1"].monitor.open_cycles) == 2)
        for i, v in enumerate((20.0, 80.0, 160.0)):
            ob_pub.publish(contract.observation_to_msg(_obs(4, v, 40.0, "production", stamp=10.0 + i),
                                                       FrictionObservation))
            ob_pub.publish(contract.observation_to_msg(_obs(4, v, 10.0, stamp=10.5 + i), FrictionObservation))
        pr_pub.publish(_status(4, contract.CycleState.DONE))
        st_pub.publish(_status(4, contract.CycleState.DONE))
        assert spin_until(ex, lambda: len(got) == 2, timeout=15.0)
        by = {m.source: m for m in got}
        assert set(by) == {"production", "test_cycle"}
        assert by["production"].cycle_id == by["test_cycle"].cycle_id == 4
        assert abs(by["production"].wear - 40.0) < 0.5 and abs(by["test_cycle"].wear - 10.0) < 0.5
        assert node.ignored_messages == 0
    finally:
        ex.shutdown()
        for n in (node, io):
            n.destroy_node()
