"""joint_sim and test_cycle on a real graph (rclpy over loopback DDS).

The simulated cell runs as child processes (their ``python -m`` entry points,
exactly as ``ros2 run`` would start them), joint_sim as the clock source at 4x
real time and every node on ``use_sim_time``; the test talks to it as an
operator would: the ``~/run`` and ``~/abort`` services and the status and
command topics.
"""

from __future__ import annotations

import itertools
import math
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import GraphClient, NodeProcess  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from jointwear_msgs.msg import TestCycleStatus  # noqa: E402  (a message, not a test class: conftest)
from jointwear_msgs.srv import RunTestCycle  # noqa: E402
from rcl_interfaces.msg import Parameter as ParameterMsg  # noqa: E402
from rcl_interfaces.msg import ParameterType, ParameterValue  # noqa: E402
from rcl_interfaces.srv import SetParameters, SetParametersAtomically  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from jointwear_ros.contract import RefusalReason  # noqa: E402
from jointwear_ros.cycle import CycleState, Phase  # noqa: E402
from jointwear_ros.nodes.cell import run_until_accepted  # noqa: E402

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[1]
QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
# the one-joint configuration of earlier versions (the config files now hold six joints)
ONE = {"joints": ["joint_1"]}
SIM_PARAMS = {"publish_clock": True, "real_time_factor": 4.0, "use_sim_time": True, **ONE}
CYCLE_PARAMS = {"simulator": True, "use_sim_time": True, **ONE}


class Operator(GraphClient):
    """The test's node: service clients, status and command listeners."""

    def __init__(self, context):
        super().__init__(context, "operator")
        self.status: list[TestCycleStatus] = []
        self.commands: list[float] = []
        self.joint_states = 0
        self.diag: list = []  # DiagnosticStatus of test_cycle
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, QOS)
        self.node.create_subscription(TestCycleStatus, "/test_cycle/status", self.status.append, QOS)
        self.node.create_subscription(
            Float64MultiArray, "/velocity_controller/commands", lambda m: self.commands.append(m.data[0] if len(m.data) else math.nan), QOS
        )
        self.node.create_subscription(JointState, "/joint_states", self._on_js, 1)
        self.run_client = self.node.create_client(RunTestCycle, "/test_cycle/run")
        self.abort_client = self.node.create_client(Trigger, "/test_cycle/abort")
        self.param_client = self.node.create_client(SetParameters, "/test_cycle/set_parameters")
        self.atomic_client = self.node.create_client(SetParametersAtomically, "/test_cycle/set_parameters_atomically")

    def _on_js(self, msg: JointState) -> None:
        self.joint_states += 1

    def _on_diag(self, msg: DiagnosticArray) -> None:
        self.diag += [s for s in msg.status if s.name == "test_cycle: joint_1"]

    def set_params(self, **values):
        """Set test_cycle parameters at run time, all or none (``~/set_parameters_atomically``); [the result]."""
        req = SetParametersAtomically.Request(
            parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        return [self.call(self.atomic_client, req).result]

    def call(self, client, request, timeout: float = 15.0, attempts: int = 1):
        """Call and wait; ``attempts`` > 1 re-sends a request that is safe to repeat: right after
        discovery the first response can be lost (the client's response reader not yet matched)."""
        assert self.spin_until(client.service_is_ready, timeout), f"service {client.srv_name} not available"
        for _ in range(attempts):
            fut = client.call_async(request)
            if self.spin_until(fut.done, timeout / attempts):
                return fut.result()
        raise AssertionError(f"no answer from {client.srv_name}")

    def run(self, attempts: int = 1, **kwargs) -> RunTestCycle.Response:
        return self.call(self.run_client, RunTestCycle.Request(**kwargs), attempts=attempts)

    def start(self, timeout: float = 20.0, **kwargs) -> RunTestCycle.Response:
        """Request a cycle as the cell library's operator does (retryable refusals re-sent: test_cycle may
        not have seen a joint state yet, it may start later than us)."""
        resp = run_until_accepted(lambda: self.run(**kwargs), lambda s: self.spin_until(lambda: False, s), timeout,
                                  pause=0.2)
        assert resp.accepted and resp.cycle_id > 0, resp.message
        return resp

    def wait_phase(self, cycle_id: int, phase: int, timeout: float = 20.0) -> None:
        def seen() -> bool:
            return any(m.cycle_id == cycle_id and (m.phase == phase or m.state > CycleState.RUNNING) for m in self.status)

        assert self.spin_until(seen, timeout), f"cycle {cycle_id} never reached phase {phase}"
        last = next(m for m in reversed(self.status) if m.cycle_id == cycle_id)
        assert last.state == CycleState.RUNNING, f"cycle {cycle_id} ended early: {last.message}"

    def set_param(self, name: str, value: bool) -> None:
        p = ParameterMsg(name=name, value=ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value))
        res = self.call(self.param_client, SetParameters.Request(parameters=[p]))
        assert res.results[0].successful

    def last_state(self, cycle_id: int | None = None) -> int | None:
        for m in reversed(self.status):
            if cycle_id is None or m.cycle_id == cycle_id:
                return m.state
        return None

    def wait_state(self, cycle_id: int, states: tuple[int, ...], timeout: float = 30.0) -> TestCycleStatus:
        assert self.spin_until(lambda: self.last_state(cycle_id) in states, timeout), (
            f"cycle {cycle_id} did not reach {states}; last status: {self.status[-1] if self.status else None}"
        )
        return next(m for m in reversed(self.status) if m.cycle_id == cycle_id)


@pytest.fixture
def operator(ros_context) -> Iterator[Operator]:
    op = Operator(ros_context)
    yield op
    op.close()


@pytest.fixture(scope="class")
def cell(ros_context) -> Iterator[tuple[NodeProcess, NodeProcess]]:
    sim = NodeProcess("joint_sim", SIM_PARAMS)
    cyc = NodeProcess("test_cycle", CYCLE_PARAMS)
    yield sim, cyc
    codes = (cyc.stop(), sim.stop())
    out = f"{cyc.output()}\n{sim.output()}"
    cyc.close()
    sim.close()
    assert codes == (0, 0), f"exit codes {codes}\n{out}"


def _ready(op: Operator) -> None:
    assert op.spin_until(lambda: op.joint_states > 20 and op.run_client.service_is_ready() and op.status, 30.0), (
        "cell did not come up"
    )


# -- the service refuses bad requests -----------------------------------------------
BAD_REQUESTS = [
    ({"joint_name": "joint_9"}, RefusalReason.WRONG_JOINT, "unknown joint 'joint_9': this node drives 'joint_1'"),
    ({"speeds": [20.0, math.nan]}, RefusalReason.BAD_SPEEDS, "speed #2 = nan is not finite"),
    ({"speeds": [math.inf]}, RefusalReason.BAD_SPEEDS, "speed #1 = inf is not finite"),
    ({"speeds": [-10.0]}, RefusalReason.BAD_SPEEDS, "must be > 0"),
    ({"speeds": [400.0]}, RefusalReason.BAD_SPEEDS, "exceeds max_speed 280"),
    ({"position": 1.45}, RefusalReason.OUTSIDE_LIMITS, "window 1.45 ± 0.1 rad is outside the joint limits [-1.5, 1.5]"),
    ({"position": 1.0}, RefusalReason.OUTSIDE_LIMITS, "beyond the joint limits"),
    ({"position": math.nan}, RefusalReason.BAD_REQUEST, "position (window centre) nan is not finite"),
    ({"speeds": [1e-6]}, RefusalReason.BAD_SPEEDS, "speed #1 = 1e-06 rad/s (motor side) is below min_speed 1 rad/s"),
    ({"speeds": [20.0] * 1000}, RefusalReason.BAD_SPEEDS, "1000 speeds asked for; at most max_speeds = 32"),
]


def _level(s) -> int:
    return s.level[0] if isinstance(s.level, bytes) else int(s.level)


@pytest.mark.usefixtures("cell")
class TestSimulatedCell:
    """One simulated cell (joint_sim at 4x real time + test_cycle) for these tests, stopped after them."""

    def test_service_refuses_bad_requests_with_clear_messages(self, cell, operator):
        _ready(operator)
        for kwargs, reason, text in BAD_REQUESTS:
            resp = operator.run(**kwargs)
            assert not resp.accepted and resp.cycle_id == 0, kwargs
            assert resp.reason == reason, (kwargs, RefusalReason.name_of(resp.reason), resp.message)
            assert resp.message.startswith("refused: ") and text in resp.message, (kwargs, resp.message)
        # nothing moved: no command was streamed
        assert operator.commands == []


    def test_dry_run_plans_without_moving(self, cell, operator):
        _ready(operator)
        resp = operator.run(dry_run=True)
        assert resp.accepted and resp.cycle_id == 0 and resp.reason == RefusalReason.NONE
        assert "dry run OK" in resp.message and "8 speed(s)" in resp.message and "plan duration" in resp.message
        operator.spin_until(lambda: False, 0.3)
        assert operator.commands == [] and operator.last_state() == CycleState.IDLE


    def test_real_joint_needs_motion_enabled(self, cell, operator):
        _ready(operator)
        operator.set_param("simulator", False)
        try:
            resp = operator.run(speeds=[20.0])
            assert not resp.accepted and resp.reason == RefusalReason.MOTION_DISABLED
            assert "motion_enabled true" in resp.message  # the text tells a person what to do
            assert operator.run(speeds=[20.0], dry_run=True).accepted  # planning needs no motion
        finally:
            operator.set_param("simulator", True)


    def test_full_cycle_reaches_done_with_a_consistent_status_sequence(self, cell, operator):
        _ready(operator)
        resp = operator.start(speeds=[40.0, 160.0])
        cid = resp.cycle_id
        # a second request while running is refused
        busy = operator.run(speeds=[20.0])
        assert not busy.accepted and busy.reason == RefusalReason.BUSY and RefusalReason.BUSY.retryable
        assert f"cycle {cid} is running" in busy.message and "~/abort" in busy.message
        final = operator.wait_state(cid, (CycleState.DONE, CycleState.FAILED, CycleState.ABORTED), 40.0)
        assert final.state == CycleState.DONE, final.message
        mine = [m for m in operator.status if m.cycle_id == cid]
        assert all(m.joint_name == "joint_1" and m.speeds_total == 2 for m in mine)
        assert all(m.window_center == 0.0 and m.window_half_width == pytest.approx(0.1) for m in mine)
        done = [m.speeds_done for m in mine]
        assert done == sorted(done) and done[-1] == 2
        running = [m for m in mine if m.state == CycleState.RUNNING]
        assert {m.current_speed for m in running} == {40.0, 160.0}
        for k, speed in enumerate((40.0, 160.0)):
            phases = [m.phase for m in running if m.speeds_done == k]
            assert all(m.current_speed == speed for m in running if m.speeds_done == k)
            seq = [phases[0]] + [b for a, b in itertools.pairwise(phases) if a != b]
            # an approach that overshoots (late joint states on a busy machine) is repeated
            assert seq[-4:] == [Phase.FORWARD, Phase.SETTLE, Phase.REVERSE, Phase.SETTLE]
            assert seq[:-4] and seq[:-4] == [Phase.APPROACH, Phase.SETTLE] * (len(seq[:-4]) // 2)
        states = [m.state for m in mine]
        assert states.index(CycleState.DONE) == len(states) - 1 or set(states[states.index(CycleState.DONE):]) == {
            CycleState.DONE
        }
        assert operator.spin_until(lambda: operator.commands and operator.commands[-1] == 0.0, 5.0)
        assert max(abs(c) for c in operator.commands) == pytest.approx(1.6)


    def test_motion_enabled_false_stops_a_running_cycle_at_once(self, cell, operator):
        _ready(operator)
        # three speeds (about 25 s): the cycle is still running when a starved operator has caught up with its
        # first forward commands (with one speed, a burst of late messages once ended in the cycle's DONE)
        resp = operator.start(speeds=[5.0, 8.0, 10.0])
        operator.wait_phase(resp.cycle_id, Phase.FORWARD)
        ok = operator.spin_until(lambda: any(c > 0.0 for c in operator.commands), 5.0)
        assert ok, (operator.commands[-5:], operator.status[-1])
        (res,) = operator.set_params(motion_enabled=False)
        assert res.successful
        final = operator.wait_state(resp.cycle_id, (CycleState.ABORTED,), 5.0)
        assert final.message == "stopped: motion_enabled set to false at run time"
        assert operator.spin_until(lambda: operator.commands[-1] == 0.0, 5.0)
        n = len(operator.commands)
        operator.spin_until(lambda: False, 0.5)
        assert operator.commands[n:] == []  # the stream stopped with the zero
        assert operator.spin_until(lambda: operator.diag and "motion_enabled set to false" in operator.diag[-1].message, 5.0)
        assert _level(operator.diag[-1]) == 1  # WARN: aborted
        # a simulator may still move with motion_enabled false (as before), so the next cycle is accepted
        assert operator.run(speeds=[20.0], dry_run=True).accepted

    def test_cycle_settings_apply_to_the_next_request_and_are_refused_during_a_cycle(self, cell, operator):
        _ready(operator)
        (alone,) = operator.set_params(max_speed=50.0)  # the default speeds go up to 160: refused
        assert not alone.successful and "speed #6 = 80 rad/s (motor side) exceeds max_speed 50" in alone.reason
        res = operator.set_params(max_speed=50.0, speeds=[10.0, 20.0, 30.0, 40.0, 50.0])
        assert [r.successful for r in res] == [True], res
        try:
            refused = operator.run(speeds=[160.0])
            assert not refused.accepted and refused.reason == RefusalReason.BAD_SPEEDS
            assert "exceeds max_speed 50" in refused.message
            resp = operator.start(speeds=[40.0])
            (busy,) = operator.set_params(max_speed=280.0)
            assert not busy.successful
            assert f"cycle {resp.cycle_id} is running: max_speed cannot change during a cycle" in busy.reason
            final = operator.wait_state(resp.cycle_id, (CycleState.DONE, CycleState.FAILED, CycleState.ABORTED), 40.0)
            assert final.state == CycleState.DONE, final.message
        finally:
            assert operator.spin_until(lambda: operator.last_state() != CycleState.RUNNING, 30.0)
            back = operator.set_params(max_speed=280.0, speeds=[10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0, 160.0])
            assert all(r.successful for r in back), back
        assert operator.run(speeds=[160.0], dry_run=True).accepted
        # invalid values and start-up-only parameters are refused with the reason, nothing changes
        (bad,) = operator.set_params(joint_limits=[1.0, -1.0])
        assert not bad.successful and "joint_limits [1.0, -1.0] must be finite" in bad.reason
        (bad,) = operator.set_params(min_speed=500.0)
        assert not bad.successful and "must not exceed max_speed" in bad.reason
        (ro,) = operator.set_params(joint_name="joint_2")
        assert not ro.successful and "read-only" in ro.reason
        assert operator.run(speeds=[160.0], dry_run=True).accepted

    def test_abort_stops_the_cycle_with_zero(self, cell, operator):
        _ready(operator)
        # four sweeps at 10 rad/s (about 16 s of sim time): the abort lands inside the cycle on a loaded
        # machine too (one speed could end before the abort call was served; a slower speed sticks)
        resp = operator.start(speeds=[10.0] * 4)
        operator.wait_phase(resp.cycle_id, Phase.FORWARD)
        ans = operator.call(operator.abort_client, Trigger.Request())
        assert ans.success and f"cycle {resp.cycle_id} aborted" in ans.message
        final = operator.wait_state(resp.cycle_id, (CycleState.ABORTED,), 10.0)
        assert final.message == "aborted by operator" and final.phase == Phase.NONE
        assert operator.spin_until(lambda: operator.commands[-1] == 0.0, 5.0)
        n = len(operator.commands)
        operator.spin_until(lambda: False, 0.5)
        assert operator.commands[n:] == []  # no more streaming after the stop
        again = operator.call(operator.abort_client, Trigger.Request())
        assert not again.success and "no cycle running" in again.message


# -- the watchdog and the exit path, each on a cell of its own ----------------------
def test_watchdog_stops_the_joint_when_joint_states_stop(ros_context, operator):
    # no sim time here: node time is wall time (0.5 s: tolerant of a loaded machine)
    cyc = NodeProcess("test_cycle", {"simulator": True, "state_timeout": 0.5, **ONE})
    sim = None
    try:
        assert operator.spin_until(lambda: operator.run_client.service_is_ready(), 30.0)
        early = operator.run(speeds=[20.0], attempts=3)  # a refusal: safe to re-send
        assert not early.accepted and early.reason == RefusalReason.STATE_MISSING
        sim = NodeProcess("joint_sim", ONE)
        assert operator.spin_until(lambda: operator.joint_states > 20, 30.0)
        resp = operator.start(speeds=[10.0])
        operator.wait_phase(resp.cycle_id, Phase.FORWARD)
        sim.stop(signal.SIGKILL)
        final = operator.wait_state(resp.cycle_id, (CycleState.FAILED,), 10.0)
        assert final.message.startswith("watchdog: ") and "joint_1" in final.message
        assert "stale" in final.message or "no joint state" in final.message
        assert operator.spin_until(lambda: operator.commands[-1] == 0.0, 5.0)
    finally:
        if sim is not None:
            sim.close()
        code, out = cyc.stop(), cyc.output()
        cyc.close()
        assert code == 0, out


def test_a_simulator_that_died_is_a_watchdog_error_and_then_a_stale_state_refusal(ros_context, operator):
    # on sim time the simulator is also the clock: when it dies, node time stops and its last
    # joint state never ages in node time; the refusal must come from wall time
    # (the node's own 1 s watchdog, not the harness's floor for a simulated cell: the simulator is killed here)
    sim = NodeProcess("joint_sim", SIM_PARAMS)
    cyc = NodeProcess("test_cycle", {**CYCLE_PARAMS, "state_timeout_wall": 1.0})
    try:
        _ready(operator)
        resp = operator.start(speeds=[10.0])
        operator.wait_phase(resp.cycle_id, Phase.FORWARD)
        sim.stop(signal.SIGKILL)
        final = operator.wait_state(resp.cycle_id, (CycleState.FAILED,), 10.0)
        assert final.message.startswith("watchdog: ")
        assert operator.spin_until(lambda: any(_level(s) == 2 and "watchdog" in s.message for s in operator.diag), 5.0)
        err = next(s for s in operator.diag if _level(s) == 2)
        kv = {v.key: v.value for v in err.values}
        assert kv["state"] == "FAILED" and kv["cycle_id"] == str(resp.cycle_id) and "watchdog" in kv["last_fault"]
        operator.spin_until(lambda: False, 3.0)  # joint_sim died 3 s ago
        late = operator.run(speeds=[20.0])
        assert not late.accepted and late.cycle_id == 0 and late.reason == RefusalReason.STATE_STALE
        assert "joint state of joint_1 is stale: none received for" in late.message
        assert operator.last_state() == CycleState.FAILED  # nothing was started
    finally:
        code, out = cyc.stop(), cyc.output()
        cyc.close()
        sim.close()
    assert code == 0, out


def test_zero_velocity_is_sent_when_test_cycle_exits_mid_cycle(ros_context, operator):
    sim = NodeProcess("joint_sim", SIM_PARAMS)
    cyc = NodeProcess("test_cycle", CYCLE_PARAMS)
    try:
        _ready(operator)
        resp = operator.start(speeds=[10.0])
        operator.wait_phase(resp.cycle_id, Phase.FORWARD)
        assert operator.spin_until(lambda: operator.commands and operator.commands[-1] > 0.0, 5.0)
        assert cyc.stop(signal.SIGINT) == 0, cyc.output()
        assert operator.spin_until(lambda: operator.commands[-1] == 0.0, 5.0)
        final = operator.wait_state(resp.cycle_id, (CycleState.ABORTED,), 5.0)
        assert final.message == "node shutting down"
    finally:
        cyc.close()
        sim.close()


# -- joint_sim on its own, in this process ----------------------------------------
def test_joint_sim_ignores_bad_commands_and_stops_after_the_command_timeout(ros_context, operator):
    from rclpy.parameter import Parameter

    from jointwear_ros.nodes.joint_sim import JointSimNode

    node = JointSimNode(
        context=ros_context,
        parameter_overrides=[Parameter("command_timeout", value=0.3), Parameter("wear", value=20.0)],
    )
    operator.executor.add_node(node)
    temps: list[Temperature] = []
    last: list[JointState] = []
    operator.node.create_subscription(Temperature, "/joint_temperature", temps.append, QOS)
    operator.node.create_subscription(JointState, "/joint_states", lambda m: last.__setitem__(slice(None), [m]), QOS)
    pub = operator.node.create_publisher(Float64MultiArray, "/velocity_controller/commands", QOS)
    try:
        assert operator.spin_until(lambda: pub.get_subscription_count() > 0 and last and temps, 20.0)
        assert temps[-1].temperature == 40.0 and temps[-1].header.frame_id == "joint_1"
        for bad in ([], [math.nan], [math.inf, 0.0]):
            pub.publish(Float64MultiArray(data=bad))
        assert operator.spin_until(lambda: node.bad_commands == 3, 10.0)
        assert node.sim["joint_1"].command == 0.0
        # a valid command moves the joint; streaming it keeps it moving (streamed until the joint is at speed, at
        # most 10 s: a fixed second of streaming left it at rest on a machine at load 12, its ticks starved)
        def at_speed() -> bool:
            return bool(last) and last[-1].velocity[0] == pytest.approx(0.2, rel=0.05)

        end, moving_since = time.monotonic() + 10.0, None
        while time.monotonic() < end and (moving_since is None or time.monotonic() - moving_since < 0.5):
            pub.publish(Float64MultiArray(data=[0.2]))
            operator.spin_until(lambda: False, 0.05)
            moving_since = (moving_since or time.monotonic()) if at_speed() else None
        assert last[-1].name == ["joint_1"] and at_speed(), last[-1].velocity
        # no more commands: the sim brings the joint to rest by itself
        assert operator.spin_until(lambda: abs(last[-1].velocity[0]) < 1e-6, 10.0)
        assert node.sim["joint_1"].command == 0.0
        # run-time parameters: physical ones apply at once, identity ones are refused with the reason
        res = node.set_parameters_atomically([Parameter("wear", value=45.0), Parameter("temperature", value=30.0)])
        assert res.successful and node.sim["joint_1"].config.wear == 45.0 and node.sim["joint_1"].config.temperature == 30.0
        assert operator.spin_until(lambda: temps[-1].temperature == 30.0, 5.0)
        res = node.set_parameters_atomically([Parameter("hidden_effects", value="bogus")])
        assert not res.successful and "unknown hidden effect(s) bogus" in res.reason
        res = node.set_parameters_atomically([Parameter("params", value="paper-printed")])
        assert not res.successful and "read-only" in res.reason
        res = node.set_parameters_atomically([Parameter("wear", value=500.0)])  # outside the declared range
        assert not res.successful and node.sim["joint_1"].config.wear == 45.0
    finally:
        operator.executor.remove_node(node)
        node.destroy_node()
