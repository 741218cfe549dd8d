"""QoS is overridable the rclpy way: a best-effort ``/joint_states`` driver reaches the friction observer
when its params YAML says ``qos_overrides.<topic>.subscription.reliability: best_effort``, and does not
without it (a reliable reader never matches a best-effort writer)."""

from __future__ import annotations

import time

import pytest
import yaml

rclpy = pytest.importorskip("rclpy")
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from jointwear_ros.nodes.friction_observer import FrictionObserverNode  # noqa: E402

TOPIC = "/qos_test/joint_states"  # a topic of its own: nothing else on the domain publishes here


def _observer(ros_context_per_test, tmp_path, override: bool) -> FrictionObserverNode:
    params = {"joint_states_topic": TOPIC, "status_topic": "/qos_test/status", "temperature_topic": "",
              "observations_topic": "/qos_test/observations"}
    if override:
        params[f"qos_overrides.{TOPIC}.subscription.reliability"] = "best_effort"
    f = tmp_path / "friction_observer.yaml"
    f.write_text(yaml.safe_dump({"friction_observer": {"ros__parameters": params}}))
    return FrictionObserverNode(context=ros_context_per_test, cli_args=["--ros-args", "--params-file", str(f)])


def _received(ros_context_per_test, node: FrictionObserverNode, expect: bool) -> tuple[int, int, int]:
    """Publish best effort (JointStates without effort, which the observer counts as bad input, so each one
    it receives is counted) until a best-effort probe beside the observer got 20 (discovery is done and
    samples flow) and, when ``expect``, the observer too; return (matched readers, probe's, observer's)."""
    driver = rclpy.create_node("best_effort_driver", context=ros_context_per_test)
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    pub = driver.create_publisher(JointState, TOPIC, best_effort)
    probe: list[JointState] = []
    driver.create_subscription(JointState, TOPIC, probe.append, best_effort)
    ex = SingleThreadedExecutor(context=ros_context_per_test)
    ex.add_node(node)
    ex.add_node(driver)
    try:
        end = time.monotonic() + 30.0
        while time.monotonic() < end:
            pub.publish(JointState(name=["joint_1"], position=[0.0], velocity=[0.0]))
            ex.spin_once(timeout_sec=0.02)
            if len(probe) >= 20 and (not expect or node.bad_messages["no effort"] >= 20):
                break
        return pub.get_subscription_count(), len(probe), node.bad_messages["no effort"]
    finally:
        ex.shutdown()
        driver.destroy_node()
        node.destroy_node()


def test_a_best_effort_driver_reaches_the_observer_with_the_qos_override(ros_context_per_test, tmp_path):
    node = _observer(ros_context_per_test, tmp_path, override=True)
    assert node.get_parameter(f"qos_overrides.{TOPIC}.subscription.reliability").value == "best_effort"
    matched, probe, received = _received(ros_context_per_test, node, expect=True)
    assert matched == 2 and probe >= 20 and received >= 20


def test_without_the_override_the_reliable_subscription_does_not_match_a_best_effort_driver(ros_context_per_test, tmp_path):
    node = _observer(ros_context_per_test, tmp_path, override=False)
    assert node.get_parameter(f"qos_overrides.{TOPIC}.subscription.reliability").value == "reliable"
    matched, probe, received = _received(ros_context_per_test, node, expect=False)
    assert probe >= 20, "the best-effort probe got nothing: the test proves nothing"
    assert matched == 1 and received == 0  # only the probe matched
