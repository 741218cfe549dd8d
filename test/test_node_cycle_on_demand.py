"""cycle_on_demand on a real graph: production estimates in, the dedicated test cycle asked for only when they cannot
decide (a request on /jointwear/cycle_request with the reason, and with allow_service_call a call to
/test_cycle/run, here answered by the test's own service).
"""

from __future__ import annotations

import math

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import GraphClient, NodeProcess  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from jointwear_msgs.msg import TestCycleStatus, WearEstimate  # noqa: E402
from jointwear_msgs.srv import RunTestCycle  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

from jointwear_ros.contract import CycleState  # noqa: E402

pytestmark = pytest.mark.ros

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SHIFT = 8 * 3600


class Plant(GraphClient):
    """The estimator's and the production observer's topics, and a stand-in for test_cycle's run service."""

    def __init__(self, context, children):
        super().__init__(context, "on_demand_plant", children)
        self.requests: list[DiagnosticArray] = []
        self.calls: list[list[str]] = []
        self.node.create_subscription(DiagnosticArray, "/jointwear/cycle_request", self.requests.append, LATCHED)
        self.node.create_service(RunTestCycle, "/test_cycle/run", self._run)
        self.est_pub = self.node.create_publisher(WearEstimate, "/jointwear/wear_estimate", RELIABLE)
        self.status_pub = self.node.create_publisher(TestCycleStatus, "/production/status", RELIABLE)

    def _run(self, req, resp):
        self.calls.append(list(req.joints))
        resp.accepted, resp.cycle_id = True, len(self.calls)
        return resp

    def estimate(self, joint: str, wear: float, std: float, stamp: int, source: str = "production") -> None:
        m = WearEstimate(joint_name=joint, wear=wear, wear_std=std, source=source)
        m.header.stamp.sec = stamp
        self.est_pub.publish(m)

    def quiet(self, joint: str, shift: int) -> None:
        m = TestCycleStatus(joint_name=joint, cycle_id=shift, state=int(CycleState.DONE), speeds_total=0)
        m.header.stamp.sec = shift * SHIFT
        self.status_pub.publish(m)

    def asked(self) -> dict[str, tuple[str, str]]:
        """joint -> (kind, reason) of every request heard."""
        return {s.hardware_id: (next(v.value for v in s.values if v.key == "kind"), s.message)
                for a in self.requests for s in a.status}


def test_the_cycle_is_asked_for_a_straddle_and_after_quiet_shifts_and_not_for_an_estimate_that_decides(ros_context):
    node = NodeProcess("cycle_on_demand", {"allow_service_call": True, "max_quiet_shifts": 2, "gather_period": 0.2})
    plant = Plant(ros_context, [node])
    try:
        plant.spin_until(lambda: plant.est_pub.get_subscription_count() > 0
                         and plant.status_pub.get_subscription_count() > 0, 30.0, "cycle_on_demand's subscriptions")
        plant.estimate("joint_1", 12.0, 1.0, SHIFT)          # decides OK: nothing asked
        plant.estimate("joint_2", 33.1, 2.4, SHIFT)          # straddles 35: asked
        plant.estimate("joint_4", math.nan, math.nan, SHIFT)  # cannot tell: counted as quiet, not asked yet
        plant.spin_until(lambda: plant.calls, 30.0, "the service call for joint_2")
        assert plant.calls == [["joint_2"]]
        kind, reason = plant.asked()["joint_2"]
        assert kind == "straddle" and reason.startswith("joint_2: production estimate 33.1 ± 2.4 straddles the ERROR")
        # the dedicated cycle's estimate decides the joint; production agreeing with it asks nothing more
        plant.estimate("joint_2", 31.0, 0.9, SHIFT + 3600, source="test_cycle")
        plant.estimate("joint_2", 33.4, 2.4, 2 * SHIFT)
        plant.quiet("joint_4", 2)                            # second quiet shift of joint_4: asked
        plant.spin_until(lambda: len(plant.calls) >= 2, 30.0, "the service call for joint_4")
        plant.spin_until(lambda: False, 1.0)                 # anything more would come within the gather period
        assert plant.calls == [["joint_2"], ["joint_4"]]
        kind, reason = plant.asked()["joint_4"]
        assert kind == "quiet" and "no informative production motion for 2 shifts" in reason
        assert "joint_1" not in plant.asked()
        node.stop()
        out = node.output()
        assert "test cycle for joint_2: accepted as cycle 1" in out and "test cycle for joint_4: accepted as cycle 2" in out
    finally:
        plant.close()
        node.stop()
        node.close()
