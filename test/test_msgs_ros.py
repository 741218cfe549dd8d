"""Each jointwear_msgs message, published and received over a real rclpy graph (loopback DDS)."""

from __future__ import annotations

import math

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import spin_until  # noqa: E402
from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate  # noqa: E402
from jointwear_msgs.srv import RunTestCycle  # noqa: E402

pytestmark = pytest.mark.ros


def _observation() -> FrictionObservation:
    m = FrictionObservation()
    m.header.frame_id = "joint2"
    m.joint_name = "joint2"
    m.cycle_id = 7
    m.speed = 47.0
    m.tau_f = 0.0907
    m.tau_f_std = 0.0004
    m.tau_plus = 0.31
    m.tau_minus = -0.13
    m.load_torque = 0.09
    m.temperature = math.nan
    m.position = 0.25
    m.samples_plus = 2000
    m.samples_minus = 1999
    return m


def _estimate() -> WearEstimate:
    m = WearEstimate()
    m.joint_name = "joint2"
    m.cycle_id = 7
    m.method = "joint"
    m.wear = 36.2
    m.wear_std = 1.1
    m.wear_low = 34.0
    m.wear_high = 38.4
    m.temperature_estimate = 41.5
    m.speeds = [30.0, 47.0, 80.0]
    m.per_speed_wear = [35.0, 36.5, math.nan]
    m.alarm_threshold = 35.0
    m.alarm = True
    return m


def _status() -> TestCycleStatus:
    m = TestCycleStatus()
    m.joint_name = "joint2"
    m.cycle_id = 7
    m.state = TestCycleStatus.FAILED
    m.current_speed = 47.0
    m.speeds_done = 3
    m.speeds_total = 8
    m.message = "watchdog: joint state stale for 0.25 s"
    return m


def _same(a, b) -> bool:
    for field in a.get_fields_and_field_types():
        va, vb = getattr(a, field), getattr(b, field)
        if isinstance(va, float) and math.isnan(va):
            if not math.isnan(vb):
                return False
        elif hasattr(va, "__len__") and not isinstance(va, str):
            if len(va) != len(vb) or any(
                not (x == y or (isinstance(x, float) and math.isnan(x) and math.isnan(y))) for x, y in zip(va, vb)
            ):
                return False
        elif va != vb:
            return False
    return True


@pytest.mark.parametrize(("msg_type", "make"), [(FrictionObservation, _observation), (WearEstimate, _estimate), (TestCycleStatus, _status)])
def test_message_round_trips_over_dds(ros_context, msg_type, make):
    from rclpy.executors import SingleThreadedExecutor

    topic = f"/jointwear_test/{msg_type.__name__.lower()}"
    pub_node = rclpy.create_node("jw_test_pub", context=ros_context)
    sub_node = rclpy.create_node("jw_test_sub", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(pub_node)
    executor.add_node(sub_node)
    received: list = []
    try:
        sub_node.create_subscription(msg_type, topic, received.append, 10)
        pub = pub_node.create_publisher(msg_type, topic, 10)
        sent = make()
        assert spin_until(executor, lambda: pub.get_subscription_count() > 0)
        pub.publish(sent)
        assert spin_until(executor, lambda: len(received) > 0), f"no {msg_type.__name__} received"
        assert _same(received[0], sent)
    finally:
        executor.shutdown()
        pub_node.destroy_node()
        sub_node.destroy_node()


def test_run_test_cycle_service_round_trips_over_dds(ros_context):
    from rclpy.executors import SingleThreadedExecutor

    server = rclpy.create_node("jw_test_srv", context=ros_context)
    client_node = rclpy.create_node("jw_test_cli", context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(server)
    executor.add_node(client_node)

    def handle(req, resp):
        resp.accepted = req.joint_name == "joint2" and not req.dry_run
        resp.cycle_id = 42 if resp.accepted else 0
        resp.message = f"{len(req.speeds)} speeds at {req.position:g} rad"
        return resp

    try:
        server.create_service(RunTestCycle, "/jointwear_test/run", handle)
        client = client_node.create_client(RunTestCycle, "/jointwear_test/run")
        assert spin_until(executor, client.service_is_ready)
        req = RunTestCycle.Request(joint_name="joint2", speeds=[10.0, 47.0], position=0.5, dry_run=False)
        fut = client.call_async(req)
        assert spin_until(executor, fut.done)
        resp = fut.result()
        assert resp.accepted and resp.cycle_id == 42 and resp.message == "2 speeds at 0.5 rad"
    finally:
        executor.shutdown()
        server.destroy_node()
        client_node.destroy_node()
