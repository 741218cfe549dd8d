"""A robot cycle on a real graph: joint_sim with three joints and test_cycle driving them (rclpy over DDS).

The same two processes (console scripts, as ``ros2 run`` starts them; joint_sim the clock
source at 4x real time, both on sim time) serve every test of the class, through several
robot cycles: refusals that move nothing, a dry run, a full robot cycle (status order, one
cycle id, ``joints_done``, every joint DONE, the held joints still in ``/joint_states``, zero
for all at the end), a held joint pushed by gravity and a held joint over its effort limit
(FAILED, zero for all, the joints not tested named), an abort in the middle of the second
joint, and the simulator's per-joint run-time parameters.
"""

from __future__ import annotations

import bisect
import math
import time
from collections.abc import Iterator

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import GraphClient, NodeProcess  # noqa: E402
from jointwear_msgs.msg import TestCycleStatus  # noqa: E402  (a message, not a test class: conftest)
from jointwear_msgs.srv import RunTestCycle  # noqa: E402
from rcl_interfaces.srv import GetParameters  # noqa: E402
from rclpy.parameter import parameter_value_to_python  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from jointwear_ros.contract import RefusalReason  # noqa: E402
from jointwear_ros.cycle import CycleState, Phase  # noqa: E402
from jointwear_ros.nodes.cell import run_until_accepted  # noqa: E402

pytestmark = pytest.mark.ros

JOINTS = ["joint_1", "joint_2", "joint_3"]
HOLD = 0.02  # test_cycle's hold_tolerance (config default), rad
QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
SIM = {"joints": "[joint_1, joint_2, joint_3]", "publish_clock": True, "real_time_factor": 4.0, "use_sim_time": True}
CYCLE = {"joints": "[joint_1, joint_2, joint_3]", "simulator": True, "use_sim_time": True}
ENDED = (CycleState.DONE, CycleState.ABORTED, CycleState.FAILED)


def _level(s) -> int:
    return s.level[0] if isinstance(s.level, bytes) else int(s.level)


class Operator(GraphClient):
    """The test's node: the services, the parameter clients, and what the cell publishes."""

    def __init__(self, context):
        super().__init__(context, "robot_operator", diagnostics=["/diagnostics"], qos=QOS)
        n = self.node
        self.status: list[TestCycleStatus] = []
        self.commands: list[list[float]] = []
        #: (stamp, positions) per /joint_states sample (sim time; the subscriber may lag behind the status)
        self.samples: list[tuple[float, list[float]]] = []
        self.temperatures: dict[str, float] = {}
        n.create_subscription(TestCycleStatus, "/test_cycle/status", self.status.append, QOS)
        n.create_subscription(Float64MultiArray, "/velocity_controller/commands",
                              lambda m: self.commands.append(list(m.data)), QOS)
        n.create_subscription(JointState, "/joint_states", self._on_js, QOS)
        n.create_subscription(Temperature, "/joint_temperature",
                              lambda m: self.temperatures.__setitem__(m.header.frame_id, m.temperature), QOS)
        self.run_client = n.create_client(RunTestCycle, "/test_cycle/run")
        self.abort_client = n.create_client(Trigger, "/test_cycle/abort")
        self.get_client = n.create_client(GetParameters, "/joint_sim/get_parameters")

    def _on_js(self, msg: JointState) -> None:
        pos = dict(zip(msg.name, msg.position, strict=False))
        self.samples.append((msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, [pos[j] for j in JOINTS]))

    def attributed(self, cid: int) -> list[tuple[str, list[float]]]:
        """Each joint-state sample with the joint under test at its stamp ("" between joints), by the status stamps
        (both sim time): this subscriber may take the joint states later than the status that followed them."""
        marks = [(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9,
                  m.joint_name if m.state == CycleState.RUNNING else "") for m in self.mine(cid)]
        times = [t for t, _ in marks]
        out = []
        for t, pos in self.samples:
            i = bisect.bisect_right(times, t) - 1
            if 0 <= i < len(marks) - 1:  # within the cycle
                out.append((marks[i][1], pos))
        return out

    def run(self, **kwargs) -> RunTestCycle.Response:
        return self.call(self.run_client, RunTestCycle.Request(**kwargs))

    def start(self, timeout: float = 20.0, **kwargs) -> int:
        """Request a cycle as the cell library's operator does (retryable refusals re-sent)."""
        resp = run_until_accepted(lambda: self.run(**kwargs), lambda s: self.spin_until(lambda: False, s), timeout,
                                  pause=0.2)
        assert resp.accepted and resp.cycle_id > 0, resp.message
        return int(resp.cycle_id)

    def set_params(self, node: str, **values) -> list:
        return self.set_parameters(node, **values)

    def sim_params(self, *names: str) -> list:
        res = self.call(self.get_client, GetParameters.Request(names=list(names)))
        return [parameter_value_to_python(v) for v in res.values]

    def mine(self, cid: int) -> list[TestCycleStatus]:
        return [m for m in self.status if m.cycle_id == cid]

    def wait_end(self, cid: int, timeout: float = 60.0) -> TestCycleStatus:
        def ended() -> bool:
            m = self.mine(cid)
            if not m or m[-1].state not in ENDED:
                return False
            last = m[-1]
            return last.state != CycleState.DONE or last.joints_done + 1 == len(last.joints)

        assert self.spin_until(ended, timeout), f"cycle {cid} did not end; last: {self.status[-1] if self.status else None}"
        return self.mine(cid)[-1]

    def wait_running(self, cid: int, joint: str, phase: int, timeout: float = 30.0) -> None:
        def seen() -> bool:
            return any(m.joint_name == joint and m.phase == phase for m in self.mine(cid)) or any(
                m.state in (CycleState.ABORTED, CycleState.FAILED) for m in self.mine(cid))

        assert self.spin_until(seen, timeout), f"cycle {cid} never reached {joint} phase {phase}"
        last = self.mine(cid)[-1]
        assert last.state == CycleState.RUNNING, f"cycle {cid} ended early: {last.message}"

    def zero_after(self, n: int) -> None:
        """The stream (100 Hz while running) stopped within 5 s, its last command zero for every joint."""
        end = time.monotonic() + 5.0
        while True:
            k = len(self.commands)
            self.spin_until(lambda: False, 0.5)
            if len(self.commands) == k:
                break
            assert time.monotonic() < end, "the command stream did not stop"
        assert len(self.commands) > n and self.commands[-1] == [0.0] * len(JOINTS), self.commands[-3:]


@pytest.fixture(scope="module")
def cell(ros_context) -> Iterator[tuple[NodeProcess, NodeProcess]]:
    sim = NodeProcess("joint_sim", SIM)
    cyc = NodeProcess("test_cycle", CYCLE)
    yield sim, cyc
    codes = (cyc.stop(), sim.stop())
    out = f"{cyc.log_tail(20)}\n{sim.log_tail(20)}"
    cyc.close()
    sim.close()
    assert codes == (0, 0), out


@pytest.fixture
def op(ros_context, cell) -> Iterator[Operator]:
    o = Operator(ros_context)
    assert o.spin_until(lambda: len(o.samples) > 20 and o.run_client.service_is_ready() and o.status, 30.0), (
        "cell did not come up: " + cell[1].log_tail())
    yield o
    o.close()


@pytest.mark.usefixtures("cell")
class TestRobotCycle:
    def test_a_request_naming_an_unknown_joint_is_refused_and_nothing_moves(self, op):
        cases = [
            ({"joints": ["joint_1", "joint_9"]}, RefusalReason.WRONG_JOINT,
             "unknown joint 'joint_9': this node drives 'joint_1', 'joint_2', 'joint_3'"),
            ({"joint_name": "joint_7"}, RefusalReason.WRONG_JOINT, "unknown joint 'joint_7'"),
            ({"joints": ["joint_2", "joint_1", "joint_2"]}, RefusalReason.WRONG_JOINT, "'joint_2' is named more than once"),
            ({"joints": ["joint_1", "joint_2"], "positions": [0.0]}, RefusalReason.BAD_REQUEST,
             "positions has 1 value(s) for 2 joint(s)"),
            ({"joints": ["joint_1", "joint_2"], "positions": [0.0, 1.45]}, RefusalReason.OUTSIDE_LIMITS,
             "joint_2: window 1.45 ± 0.1 rad is outside the joint limits"),
            ({"speeds": [400.0]}, RefusalReason.BAD_SPEEDS, "joint_1: speed #1 = 400 rad/s (motor side) exceeds max_speed"),
        ]
        for kwargs, reason, text in cases:
            resp = op.run(**kwargs)
            assert not resp.accepted and resp.cycle_id == 0, kwargs
            assert resp.reason == reason, (kwargs, RefusalReason.name_of(resp.reason), resp.message)
            assert text in resp.message, (kwargs, resp.message)
        op.spin_until(lambda: False, 0.3)
        assert op.commands == [] and all(m.state == CycleState.IDLE for m in op.status)

    def test_dry_run_plans_every_joint_and_the_total(self, op):
        resp = op.run(speeds=[40.0, 80.0], dry_run=True)
        assert resp.accepted and resp.cycle_id == 0, resp.message
        for j in JOINTS:
            assert f"{j}: 2 speed(s) 40, 80 rad/s" in resp.message
        assert "3 joints, about" in resp.message and "plan duration" in resp.message
        op.spin_until(lambda: False, 0.3)
        assert op.commands == []

    def test_a_robot_cycle_tests_each_joint_in_turn_and_holds_the_others_still(self, op):
        cid = op.start(joints=JOINTS, speeds=[40.0])
        busy = op.run(speeds=[20.0])
        assert not busy.accepted and busy.reason == RefusalReason.BUSY
        final = op.wait_end(cid)
        assert final.state == CycleState.DONE, final.message
        mine = op.mine(cid)
        assert all(list(m.joints) == JOINTS for m in mine)
        # RUNNING .. DONE per joint, in order, joints_done counting the finished ones
        seq = []
        for m in mine:
            key = (m.joint_name, m.state, m.joints_done)
            if not seq or seq[-1] != key:
                seq.append(key)
        assert seq == [(j, s, k) for k, j in enumerate(JOINTS) for s in (CycleState.RUNNING, CycleState.DONE)], seq
        assert final.message.startswith("done: 3 joints in ")
        # every command carries every joint; one joint moves at a time, in test order; zero for all at the end
        assert all(len(c) == len(JOINTS) for c in op.commands)
        # (a held joint gets at most its hold correction, a fifth of its approach speed, back to where it is held)
        cap = 0.2 * 0.5 + 1e-9  # config/test_cycle.yaml: approach_speed 0.5 rad/s
        assert all(sum(1 for v in c if abs(v) > cap) <= 1 for c in op.commands)
        movers = [next(i for i, v in enumerate(c) if abs(v) > cap) for c in op.commands if any(abs(v) > cap for v in c)]
        assert sorted(set(movers)) == [0, 1, 2] and movers == sorted(movers)
        op.zero_after(0)
        # the held joints: still within hold_tolerance of where they were when the other joint started
        samples = op.attributed(cid)
        for k, j in enumerate(JOINTS):
            for other in JOINTS:
                if other == j:
                    continue
                pos = [p[k] for under, p in samples if under == other]
                assert len(pos) > 100, (j, other, len(pos))
                assert max(pos) - min(pos) <= HOLD, (j, other, min(pos), max(pos))
        # each tested joint really moved
        for k, j in enumerate(JOINTS):
            pos = [p[k] for under, p in samples if under == j]
            assert max(pos) - min(pos) > 0.4, (j, min(pos), max(pos))
        assert op.spin_until(lambda: op.diag.get("test_cycle: robot") and "DONE" in op.diag["test_cycle: robot"][-1].message, 5.0)
        for j in JOINTS:
            assert op.spin_until(lambda j=j: op.diag.get(f"test_cycle: {j}")
                                 and f"cycle {cid} DONE" in op.diag[f"test_cycle: {j}"][-1].message, 5.0)
            assert _level(op.diag[f"test_cycle: {j}"][-1]) == 0

    def test_a_held_joint_pushed_by_gravity_fails_the_cycle_with_zero_for_all(self, op):
        cid = op.start(joints=JOINTS, speeds=[10.0])
        op.wait_running(cid, "joint_1", Phase.FORWARD)
        # joint_2's drive loses its grip and gravity pulls it: kp = ki = 0 (the integral torque stays), g = 0.5
        res = op.set_params("joint_sim", **{"joint_2.kp": 0.0, "joint_2.ki": 0.0, "joint_2.gravity_torque": 0.5})
        try:
            assert all(r.successful for r in res), res
            final = op.wait_end(cid, 20.0)
            n = len(op.commands)
        finally:
            back = op.set_params("joint_sim", **{"joint_2.kp": 0.05, "joint_2.ki": 1.0, "joint_2.gravity_torque": 0.1})
            assert all(r.successful for r in back), back
        assert final.state == CycleState.FAILED and final.joint_name == "joint_1" and final.joints_done == 0
        assert final.message.startswith("watchdog: held joint joint_2 moved -0.0"), final.message
        assert "(hold_tolerance 0.02 rad); not tested: joint_2, joint_3" in final.message
        op.zero_after(n - 1)
        assert op.spin_until(lambda: op.diag.get("test_cycle: joint_2")
                             and _level(op.diag["test_cycle: joint_2"][-1]) == 2, 5.0)
        assert "held joint joint_2 moved" in op.diag["test_cycle: joint_2"][-1].message
        assert _level(op.diag["test_cycle: joint_1"][-1]) == 2  # the joint under test was stopped by it
        assert op.spin_until(lambda: _level(op.diag["test_cycle: robot"][-1]) == 2, 5.0)

    def test_a_held_joint_over_its_effort_limit_fails_the_cycle(self, op):
        # joint_2 holds gravity 0.1 x torque_scale 200 = ~20 N·m at rest: a 12 N·m limit trips while joint_1 moves
        (res,) = op.set_params("test_cycle", **{"joint_2.effort_limit": 12.0})
        assert res.successful, res.reason
        try:
            cid = op.start(joints=["joint_1", "joint_2"], speeds=[10.0])
            final = op.wait_end(cid, 20.0)
        finally:
            (back,) = op.set_params("test_cycle", **{"joint_2.effort_limit": 150.0})
            assert back.successful, back.reason
        assert final.state == CycleState.FAILED and final.joint_name == "joint_1"
        assert final.message.startswith("watchdog: held joint joint_2: |effort| ") and "> effort_limit 12 N·m" in final.message
        assert final.message.endswith("; not tested: joint_2")
        assert op.spin_until(lambda: op.commands and op.commands[-1] == [0.0] * 3, 5.0)

    def test_abort_in_the_middle_of_a_robot_cycle_stops_every_joint(self, op):
        cid = op.start(joints=["joint_3", "joint_1", "joint_2"], speeds=[40.0], positions=[0.1, 0.0, -0.1])
        op.wait_running(cid, "joint_1", Phase.FORWARD, 40.0)
        n = len(op.commands)
        ans = op.call(op.abort_client, Trigger.Request())
        assert ans.success and f"cycle {cid} aborted" in ans.message
        final = op.wait_end(cid, 10.0)
        assert final.state == CycleState.ABORTED and final.joint_name == "joint_1" and final.joints_done == 1
        assert final.message == "aborted by operator; not tested: joint_2"
        done = [m for m in op.mine(cid) if m.state == CycleState.DONE]
        assert done and {m.joint_name for m in done} == {"joint_3"} and done[0].window_center == pytest.approx(0.1)
        op.zero_after(n)
        assert op.spin_until(lambda: "not tested: cycle" in op.diag["test_cycle: joint_2"][-1].message, 5.0)
        assert _level(op.diag["test_cycle: joint_1"][-1]) == 1  # WARN: aborted

    def test_the_simulator_takes_per_joint_settings_at_run_time(self, op):
        assert op.spin_until(lambda: set(op.temperatures) == set(JOINTS), 10.0), op.temperatures
        (res,) = op.set_params("joint_sim", wear=30.0)  # node level: every joint, read back per joint
        assert res.successful, res.reason
        assert op.sim_params("wear", "joint_1.wear", "joint_2.wear", "joint_3.wear") == [30.0] * 4
        (res,) = op.set_params("joint_sim", **{"joint_3.wear": 45.0})
        assert res.successful, res.reason
        assert op.sim_params("joint_1.wear", "joint_2.wear", "joint_3.wear") == [30.0, 30.0, 45.0]
        (bad,) = op.set_params("joint_sim", **{"joint_3.hidden_effects": "bogus"})
        assert not bad.successful and "unknown hidden effect(s) bogus" in bad.reason
        (ro,) = op.set_params("joint_sim", **{"joint_3.seed": 9})
        assert not ro.successful and "read-only" in ro.reason

        def wear_of(j: str) -> str:
            st = op.diag.get(f"joint_sim: {j}")
            return {v.key: v.value for v in st[-1].values}["wear"] if st else ""

        assert op.spin_until(lambda: wear_of("joint_3") == "45" and wear_of("joint_1") == "30", 5.0)
        # a command of the wrong length moves nothing and is counted
        pub = op.node.create_publisher(Float64MultiArray, "/velocity_controller/commands", QOS)
        assert op.spin_until(lambda: pub.get_subscription_count() >= 1, 5.0)
        pub.publish(Float64MultiArray(data=[0.3]))

        def bad_commands() -> int:
            st = op.diag.get("joint_sim: joint_1")
            return int({v.key: v.value for v in st[-1].values}["bad_commands"]) if st else -1

        assert op.spin_until(lambda: bad_commands() >= 1, 5.0)
        k = len(op.samples)
        op.spin_until(lambda: len(op.samples) > k + 50, 5.0)
        assert all(math.isclose(a, b, abs_tol=1e-3) for a, b in zip(op.samples[k][1], op.samples[-1][1], strict=True))

    def test_zero_for_every_joint_when_test_cycle_exits_mid_robot_cycle(self, op, cell):
        # the last test of the class: it stops the cell's test_cycle (SIGINT, as Ctrl-C would)
        n0 = len(op.commands)
        cid = op.start(joints=JOINTS, speeds=[10.0])
        op.wait_running(cid, "joint_1", Phase.FORWARD)
        # joint_1 is sweeping forward (this subscriber may take the commands later than the status)
        assert op.spin_until(lambda: any(c[0] > 0.0 for c in op.commands[n0:]), 10.0), op.commands[-3:]
        n = len(op.commands)
        cyc = cell[1]
        cyc.stop()
        assert cyc.proc.returncode == 0, cyc.log_tail(20)
        op.zero_after(n)
        final = op.wait_end(cid, 5.0)
        assert final.state == CycleState.ABORTED and final.message == "node shutting down; not tested: joint_2, joint_3"
