"""An integer where a double is declared is taken as that double, on every path a parameter is set:
a params file / ``--ros-args -p`` (the declaration's overrides), ``ros2 param set`` (the node's
``~/set_parameters`` service, over DDS) and ``jointwear demo --set`` (issue 24, point 3)."""

from __future__ import annotations

import time

import pytest
import rclpy

pytestmark = pytest.mark.ros


def _set_over_dds(ros_context_per_test, node, params):
    """``ros2 param set``: the node's ``~/set_parameters`` service called from another node over DDS."""
    from rcl_interfaces.srv import SetParameters
    from rclpy.executors import SingleThreadedExecutor

    client_node = rclpy.create_node("param_setter", context=ros_context_per_test)
    ex = SingleThreadedExecutor(context=ros_context_per_test)
    ex.add_node(node)
    ex.add_node(client_node)
    try:
        client = client_node.create_client(SetParameters, f"{node.get_fully_qualified_name()}/set_parameters")
        end = time.monotonic() + 20
        while not client.service_is_ready():
            assert time.monotonic() < end, "set_parameters service never appeared"
            ex.spin_once(timeout_sec=0.1)
        future = client.call_async(SetParameters.Request(parameters=[p.to_parameter_msg() for p in params]))
        while not future.done():
            assert time.monotonic() < end, "set_parameters never answered"
            ex.spin_once(timeout_sec=0.1)
        return future.result().results
    finally:
        ex.remove_node(node)
        client_node.destroy_node()
        ex.shutdown()


def test_joint_sim_takes_an_integer_temperature_from_its_overrides_and_at_run_time(ros_context_per_test):
    from rclpy.parameter import Parameter

    from jointwear_ros.nodes.joint_sim import JointSimNode

    node = JointSimNode(context=ros_context_per_test, parameter_overrides=[Parameter("temperature", value=30)])
    try:
        value = node.get_parameter("temperature").value
        assert isinstance(value, float) and value == 30.0
        (res,) = _set_over_dds(ros_context_per_test, node, [Parameter("temperature", value=35)])
        assert res.successful, res.reason
        value = node.get_parameter("temperature").value
        assert isinstance(value, float) and value == 35.0
        # a string is still refused: only an integer for a double is converted
        (res,) = _set_over_dds(ros_context_per_test, node, [Parameter("temperature", value="hot")])
        assert not res.successful
        assert node.get_parameter("temperature").value == 35.0
    finally:
        node.destroy_node()


def test_per_joint_double_settings_take_integers_and_a_node_level_integer_reaches_every_joint(ros_context_per_test):
    from rclpy.parameter import Parameter

    from jointwear_ros.nodes.wear_estimator import WearEstimatorNode

    node = WearEstimatorNode(context=ros_context_per_test, parameter_overrides=[
        Parameter("joints", value=["joint_1", "joint_2"]), Parameter("joint_2.alarm_threshold", value=40),
        Parameter("warn_threshold", value=28)])
    try:
        assert node.get_parameter("joint_2.alarm_threshold").value == 40.0
        assert isinstance(node.get_parameter("joint_1.warn_threshold").value, float)
        assert node.get_parameter("joint_1.warn_threshold").value == 28.0
        (res,) = _set_over_dds(ros_context_per_test, node, [Parameter("alarm_threshold", value=36)])
        assert res.successful, res.reason
        for j in ("joint_1", "joint_2"):
            v = node.get_parameter(f"{j}.alarm_threshold").value
            assert isinstance(v, float) and v == 36.0
        # an integer outside the declared range is refused as the double would be
        (res,) = _set_over_dds(ros_context_per_test, node, [Parameter("joint_1.alarm_threshold", value=150)])
        assert not res.successful
        assert node.get_parameter("joint_1.alarm_threshold").value == 36.0
    finally:
        node.destroy_node()


def test_an_integer_array_for_a_double_array_parameter(ros_context_per_test):
    from rclpy.node import Node
    from rclpy.parameter import Parameter

    from jointwear_ros.nodes.runtime import ParamDecl, declare_parameters

    node = Node("arrays", context=ros_context_per_test, parameter_overrides=[Parameter("speeds", value=[20, 40])])
    try:
        p = declare_parameters(node, [ParamDecl("speeds", [10.0, 30.0], "speeds"), ParamDecl("n", 3, "a count")])
        assert p["speeds"] == [20.0, 40.0] and all(isinstance(v, float) for v in p["speeds"])
        res = node.set_parameters([Parameter("n", value=4), Parameter("speeds", value=[5, 6])])
        assert all(r.successful for r in res)
        assert node.get_parameter("n").value == 4 and isinstance(node.get_parameter("n").value, int)
        assert list(node.get_parameter("speeds").value) == [5.0, 6.0]
    finally:
        node.destroy_node()


def test_demo_set_takes_an_integer_for_a_double_and_refuses_a_word_up_front():
    from jointwear_ros.cli import UsageError
    from jointwear_ros.cli.demo_cmd import check_overrides, parse_overrides

    o = parse_overrides(["joint_sim.temperature=30"])
    check_overrides(o)
    assert o["joint_sim"]["temperature"] == 30.0 and isinstance(o["joint_sim"]["temperature"], float)
    with pytest.raises(UsageError, match="joint_sim.temperature"):
        check_overrides(parse_overrides(["joint_sim.temperature=warm"]))


def test_cycle_ids_stay_unique_across_restarts_of_test_cycle(ros_context_per_test, monkeypatch):
    """Issue 24, point 7: every run of the demo used cycle 1, so runs collapsed into one history entry."""
    from rclpy.parameter import Parameter

    import jointwear_ros.nodes.test_cycle as tc

    ids = []
    for now in (1_795_600_000.2, 1_795_600_031.9):  # a node started, stopped, started again 31 s later
        monkeypatch.setattr(tc.time, "time", lambda now=now: now)
        node = tc.TestCycleNode(context=ros_context_per_test)
        ids.append(node.next_cycle_id)
        node.destroy_node()
    assert ids == [1_795_600_000, 1_795_600_031]
    node = tc.TestCycleNode(context=ros_context_per_test, parameter_overrides=[Parameter("first_cycle_id", value=7)])
    try:
        assert node.next_cycle_id == 7
    finally:
        node.destroy_node()
