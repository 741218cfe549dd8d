"""test_cycle with ``arm: ur5`` on a real graph: every planned cycle is checked against the arm's model before
anything moves (joint_sim simulating the UR5, test_cycle with the cell's settings on it, over loopback DDS).

A request whose sweep would take the wrist into the table is refused (BAD_REQUEST) naming the step, the links and
the configuration, and no joint is commanded; a clear one is accepted and says its closest approach; an unknown arm
is one line and exit status 2.
"""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("pinocchio")
from conftest import GraphClient, NodeProcess  # noqa: E402
from jointwear_msgs.srv import RunTestCycle  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

from jointwear_ros.contract import RefusalReason  # noqa: E402
from jointwear_ros.nodes.cell import run_until_accepted  # noqa: E402
from jointwear_ros.simcell import arm_cell_parameters  # noqa: E402

pytestmark = pytest.mark.ros

SIX = [f"joint_{i}" for i in range(1, 7)]
QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


class Operator(GraphClient):
    def __init__(self, context, children):
        super().__init__(context, "collision_operator", children)
        self.states: list[JointState] = []
        self.commands: list[list[float]] = []
        self.node.create_subscription(JointState, "/joint_states", self.states.append, QOS)
        self.node.create_subscription(Float64MultiArray, "/velocity_controller/commands",
                                      lambda m: self.commands.append(list(m.data)), QOS)
        self.run_client = self.node.create_client(RunTestCycle, "/test_cycle/run")

    def run(self, **fields) -> RunTestCycle.Response:
        """Ask as an operator does: a retryable refusal (test_cycle has not seen a joint state yet) is asked again."""
        return run_until_accepted(lambda: self.call(self.run_client, RunTestCycle.Request(**fields), 30.0),
                                  lambda s: self.spin_until(lambda: False, s), 30.0, pause=0.5)


def test_a_cycle_whose_path_would_hit_the_table_is_refused_before_anything_moves_and_a_clear_one_is_accepted(
        ros_context):
    params = arm_cell_parameters("ur5", SIX)
    sim = NodeProcess("joint_sim", {**params["joint_sim"], "joints": SIX})
    cycle = NodeProcess("test_cycle", {**params["test_cycle"], "joints": SIX, "arm": "ur5", "simulator": True})
    op = Operator(ros_context, [sim, cycle])
    try:
        op.spin_until(lambda: len(op.states) >= 50, 60.0, "joint states")
        # the shoulder's window moved down to -0.4 rad (inside its limits): the wrist reaches the table
        resp = op.run(joints=["joint_2"], positions=[-0.4], speeds=[40.0])
        assert not resp.accepted and resp.reason == RefusalReason.BAD_REQUEST, resp.message
        assert resp.message.startswith("refused: joint_2, speed #1 (40 rad/s): wrist_"), resp.message
        assert "the table (z = 0 of the base) at q = [" in resp.message
        assert resp.message.endswith("rad (clearance 1 cm, arm ur5); narrow the speeds or move the window centres")
        n = len(op.states)
        op.spin_until(lambda: len(op.states) > n + 50, 30.0, "joint states after the refusal")
        assert all(not any(c) for c in op.commands)  # nothing moved: no command but zero
        # the same joint at its test pose: clear, the closest approach said
        resp = op.run(joints=["joint_2"], speeds=[40.0], dry_run=True)
        assert resp.accepted, resp.message
        assert "path clear of the ur5's links and the table (closest: " in resp.message, resp.message
    finally:
        op.close()
        for child in (cycle, sim):
            child.stop()
            child.close()


def test_an_unknown_arm_is_one_line_and_exit_status_2():
    node = NodeProcess("test_cycle", {"arm": "kuka"})
    try:
        code = node.proc.wait(60)
        out = node.output()
    finally:
        node.close()
    assert code == 2, out
    assert [s for s in out.strip().splitlines() if not s.startswith("$ ")] == [
        "test_cycle: unknown arm 'kuka'; known arms: ur5, panda"]
