"""joint_sim with a real arm (``arm: ur5``) on a real graph: the node as ``ros2 run`` starts it, over loopback DDS.

/joint_states carries the arm's six joints at its test pose, the arm holds still under gravity, a velocity
command moves a joint while the others stay held, a payload set at run time loads the shoulder; an unknown
arm, or more joints than the arm has, is one line and exit status 2.
"""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("pinocchio")
from conftest import GraphClient, NodeProcess  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

from jointwear_ros.sim.arms import arm_spec  # noqa: E402

pytestmark = pytest.mark.ros

SIX = [f"joint_{i}" for i in range(1, 7)]
HOME = np.array([j.home for j in arm_spec("ur5").joints])


class Client(GraphClient):
    """Listens to /joint_states; sends a velocity command at 50 Hz (wall) while ``command`` is set."""

    def __init__(self, context, children):
        super().__init__(context, "arm_client", children)
        self.states: list[JointState] = []
        self.command: list[float] | None = None
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.node.create_subscription(JointState, "/joint_states", self.states.append, qos)
        self.pub = self.node.create_publisher(Float64MultiArray, "/velocity_controller/commands", 10)
        self.node.create_timer(0.02, self._send)

    def _send(self) -> None:
        if self.command is not None:
            self.pub.publish(Float64MultiArray(data=self.command))

    def positions(self, last: int) -> np.ndarray:
        return np.array([m.position for m in self.states[-last:]])

    def efforts(self, last: int) -> np.ndarray:
        return np.array([m.effort for m in self.states[-last:]])


def test_joint_sim_on_a_ur5_publishes_its_six_joints_holds_still_moves_on_command_and_takes_a_payload(ros_context):
    sim = NodeProcess("joint_sim", {"arm": "ur5"})
    client = Client(ros_context, [sim])
    try:
        client.spin_until(lambda: len(client.states) >= 300, 60.0, "300 joint states")
        first = client.states[0]
        assert list(first.name) == SIX and len(first.position) == len(first.velocity) == len(first.effort) == 6
        held = client.positions(300)
        assert np.abs(held - HOME).max() < 1e-3  # the test pose, held under gravity
        assert np.abs(np.array([m.velocity for m in client.states[-300:]])).max() < 1e-3
        shoulder = client.efforts(300)[:, 1].mean()
        assert -25.0 < shoulder < -15.0  # the shoulder holds the arm (Pinocchio's gravity: -20.2 N·m)

        client.command = [0.3, 0.0, 0.0, 0.0, 0.0, 0.0]
        client.spin_until(lambda: client.states[-1].position[0] > HOME[0] + 0.2, 30.0, "joint_1 moving 0.2 rad")
        moving = client.states[-1]
        assert moving.velocity[0] == pytest.approx(0.3, rel=0.02)
        assert np.abs(np.array(moving.position[1:]) - HOME[1:]).max() < 2e-3  # the others held under the coupling
        client.command = [0.0] * 6
        client.spin_until(lambda: abs(client.states[-1].velocity[0]) < 1e-6, 30.0, "joint_1 at rest")

        results = client.set_parameters("joint_sim", payload=5.0)
        assert results[0].successful, results[0].reason
        n = len(client.states)
        client.spin_until(lambda: len(client.states) > n + 500, 30.0, "joint states after the payload")
        # 5 kg at the flange pull on the shoulder (18 N·m; the joint at rest, static friction holds up to ~11 of them)
        assert client.efforts(200)[:, 1].mean() < shoulder - 5.0
        assert np.abs(client.positions(200)[:, 1:] - HOME[1:]).max() < 5e-3  # caught by the drives
    finally:
        client.close()
        code = sim.stop()
        out = sim.output()
        sim.close()
    assert code == 0, out[-3000:]


@pytest.mark.parametrize(("params", "line"), [
    ({"arm": "kuka"}, "joint_sim: unknown arm 'kuka'; known arms: ur5, panda"),
    ({"arm": "ur5", "joints": [*SIX, "joint_7"]},
     "joint_sim: arm ur5 has 6 joints (shoulder_pan_joint, shoulder_lift_joint, elbow_joint, wrist_1_joint, "
     "wrist_2_joint, wrist_3_joint); 7 joint names given (joint_1, joint_2, joint_3, joint_4, joint_5, joint_6, "
     "joint_7)"),
])
def test_an_unknown_arm_or_more_joints_than_it_has_is_one_line_and_exit_status_2(params, line):
    sim = NodeProcess("joint_sim", params)
    try:
        code = sim.proc.wait(60)
        out = sim.output()
    finally:
        sim.close()
    assert code == 2, out
    assert [s for s in out.strip().splitlines() if not s.startswith("$ ")] == [line]  # the log starts with the command
