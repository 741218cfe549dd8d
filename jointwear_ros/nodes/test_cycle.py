"""``test_cycle``: runs a friction test cycle on one joint when asked by service call.

Services: ``~/run`` (``jointwear_msgs/srv/RunTestCycle``; answers at once with
accepted, cycle_id, the refusal ``reason`` code and the plan or the reason in words) and ``~/abort``
(``std_srvs/srv/Trigger``). Publishes ``~/status`` (``TestCycleStatus``) on
every change and at ``status_rate``. While a cycle runs it streams velocity
commands (``Float64MultiArray``, data[0] joint rad/s) at ``command_rate`` (forward
command controllers hold the last command forever) and sends zero on finish,
abort, error, watchdog trip and node exit.

Safety: ``motion_enabled`` must be true to move a real joint; a simulated cell
is marked with ``simulator: true``. The watchdog (see
:mod:`jointwear_ros.cycle.runner`) runs in node time (``use_sim_time``
honoured); a second check in wall time catches a joint-state source that
stops together with the clock it provides. A request is refused when the
joint state is older than ``state_timeout`` in node time or
``state_timeout_wall`` in wall time (a simulator that died stops the sim
clock too, so its last state never looks old in sim time).

Run-time parameters: setting ``motion_enabled`` to false stops a running
cycle at once (zero command, state ABORTED with the reason), also on a
simulator. The cycle settings (speeds, limits, ``max_speed``, timeouts,
tolerances, ...) apply to the next request; while a cycle runs a change is
refused with the reason (the running plan and its watchdog were checked
with the old values). Topics, ``joint_name``, ``gear_ratio`` and the rates are
read at start-up only (read-only parameters).

Diagnostics: ``test_cycle: <joint>`` on ``/diagnostics``: OK while idle,
running or after a DONE cycle; WARN after an ABORTED cycle; ERROR after a
FAILED one (a watchdog stop), with the reason as the message; key/values
state, cycle_id, speeds_done, speeds_total, last_fault, refused_requests,
commands_sent.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from jointwear_msgs.msg import TestCycleStatus
from jointwear_msgs.srv import RunTestCycle
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from ..contract import RefusalReason
from ..cycle import (
    DEFAULT_SPEEDS,
    CycleConfig,
    CycleRequestError,
    CycleRunner,
    CycleState,
    JointReading,
    plan_cycle,
)
from ..errors import JointwearError
from .diagnostics import ERROR, OK, WARN, NodeDiagnostics
from .runtime import ParamDecl, declare_parameters, on_parameter_change, overridable_qos, run_node

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "TestCycleNode", "main"]

PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", "joint_1", "the joint this node drives (looked up by name in /joint_states)",
              read_only=True),
    ParamDecl("command_topic", "/velocity_controller/commands", "velocity command topic (Float64MultiArray)",
              read_only=True),
    ParamDecl("joint_states_topic", "/joint_states", "joint state topic", read_only=True),
    ParamDecl("gear_ratio", 100.0, "motor speed / joint speed", 1e-3, 1e6, read_only=True),
    ParamDecl("speeds", list(DEFAULT_SPEEDS), "default speeds, motor side, rad/s"),
    ParamDecl("window_half_width", 0.1, "observation window half width, joint rad", 1e-4, 10.0),
    ParamDecl("position", 0.0, "default window centre, joint rad", -100.0, 100.0),
    ParamDecl("joint_limits", [-1.5, 1.5], "allowed joint positions [low, high], rad"),
    ParamDecl("limit_margin", 0.02, "planned positions stay this far inside the limits, rad", 0.0, 10.0),
    ParamDecl("max_speed", 280.0, "largest allowed speed, motor side, rad/s", 1e-3, 1e6),
    ParamDecl("min_speed", 1.0, "smallest allowed speed, motor side, rad/s", 1e-3, 1e6),
    ParamDecl("max_speeds", 32, "most speeds in one cycle"),
    ParamDecl("max_duration", 3600.0, "longest planned cycle, s", 1.0, 1e6),
    ParamDecl("acceleration", 4.0, "joint acceleration of every move, rad/s^2", 1e-3, 1e4),
    ParamDecl("approach_speed", 0.5, "joint speed of approach moves, rad/s", 1e-3, 100.0),
    ParamDecl("steady_time", 0.3, "time at constant speed before the window, s", 0.0, 100.0),
    ParamDecl("settle_time", 0.3, "time at rest after each move, s", 0.0, 100.0),
    ParamDecl("state_timeout", 0.25, "watchdog: joint state older than this (s) stops the cycle", 1e-3, 100.0),
    ParamDecl(
        "state_timeout_wall", 1.0,
        "watchdog: no joint state for this many wall-clock s stops the cycle (catches a clock source that died)",
        1e-3, 100.0,
    ),
    ParamDecl("speed_tolerance", 0.05, "watchdog: relative speed error allowed at the window start", 1e-4, 10.0),
    ParamDecl("approach_tolerance", 0.01, "the joint must stand this close to a sweep start, rad", 1e-4, 1.0),
    ParamDecl("effort_limit", 150.0, "watchdog: largest allowed |effort|, N·m", 1e-3, 1e9),
    ParamDecl("command_rate", 100.0, "velocity command rate while running, Hz (node time)", 1.0, 10000.0,
              read_only=True),
    ParamDecl("status_rate", 10.0, "periodic status rate, Hz (node time)", 0.1, 1000.0, read_only=True),
    ParamDecl("motion_enabled", False, "allow motion of a real joint (not needed when simulator is true); "
              "setting it false stops a running cycle at once"),
    ParamDecl("simulator", False, "the joint is the simulator (joint_sim): motion allowed without motion_enabled"),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True),
)
#: Parameter name -> CycleConfig field, for the settings that apply from the next request
_CYCLE_FIELDS = ("speeds", "window_half_width", "position", "joint_limits", "limit_margin", "max_speed", "min_speed",
                 "max_speeds", "max_duration", "acceleration", "approach_speed", "steady_time", "settle_time",
                 "state_timeout", "speed_tolerance", "effort_limit", "approach_tolerance")
#: Parameters that can change at run time
LIVE_PARAMETERS = tuple(d.name for d in PARAMETERS if not d.read_only)


def _cycle_value(name: str, value: Any) -> Any:
    if name == "speeds":
        return tuple(float(v) for v in value)
    if name == "joint_limits":
        limits = [float(x) for x in value]
        if len(limits) != 2:
            raise CycleRequestError(f"joint_limits must be [low, high], got {limits}")
        return (limits[0], limits[1])
    if name == "max_speeds":
        return int(value)
    return float(value)

_RELIABLE_1 = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
_RELIABLE_10 = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
_RELIABLE_100 = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


class TestCycleNode(Node):
    """The test-cycle node (see the module docstring)."""

    __test__ = False  # not a pytest test class

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("test_cycle", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        limits = list(_cycle_value("joint_limits", p["joint_limits"]))
        self.config = CycleConfig(
            joint_name=str(p["joint_name"]), gear_ratio=float(p["gear_ratio"]),
            **{name: _cycle_value(name, p[name]) for name in _CYCLE_FIELDS},
        )
        self.config.check()
        plan_cycle(self.config)  # the default speeds must be plannable
        self.runner = CycleRunner(self.config)
        self.joint_name = self.config.joint_name
        self.next_cycle_id = 1
        self.reading: JointReading | None = None
        self._wall_last_state: float | None = None
        self.state_timeout_wall = float(p["state_timeout_wall"])
        self._last_status_key: tuple[Any, ...] | None = None
        self._last_status_time = -math.inf
        self.status_period = 1.0 / float(p["status_rate"])
        self.commands_sent = 0
        self.last_command: float | None = None
        self.refused_requests = 0
        self.last_fault = ""

        self.cmd_pub = self.create_publisher(Float64MultiArray, str(p["command_topic"]), _RELIABLE_10)
        self.status_pub = self.create_publisher(TestCycleStatus, "~/status", _RELIABLE_100,
                                                qos_overriding_options=overridable_qos())
        # only the newest state matters here: depth 1 never queues stale positions behind a busy executor
        self.create_subscription(JointState, str(p["joint_states_topic"]), self._on_joint_state, _RELIABLE_1,
                                 qos_overriding_options=overridable_qos())
        self.create_service(RunTestCycle, "~/run", self._on_run)
        self.create_service(Trigger, "~/abort", self._on_abort)
        self.create_timer(1.0 / float(p["command_rate"]), self._tick)
        self._wall = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(0.05, self._wall_watchdog, clock=self._wall)
        self.diag = NodeDiagnostics(self, f"test_cycle: {self.joint_name}", self.joint_name,
                                    period=float(p["diagnostics_period"]), message="idle")
        on_parameter_change(self, self._on_parameters, LIVE_PARAMETERS)
        self._publish_status(force=True)
        self._update_diagnostics()
        self.get_logger().info(
            f"test cycle for {self.joint_name}: speeds {list(self.config.speeds)} rad/s (motor), window "
            f"{self.config.position:g} ± {self.config.window_half_width:g} rad, limits {limits} rad"
            + (", simulator" if p["simulator"] else f", motion_enabled={p['motion_enabled']}")
        )

    # -- time ----------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- inputs --------------------------------------------------------------
    def _on_joint_state(self, msg: JointState) -> None:
        try:
            i = list(msg.name).index(self.joint_name)
        except ValueError:
            return
        try:
            pos = float(msg.position[i])
            vel = float(msg.velocity[i]) if len(msg.velocity) > i else math.nan
            eff = float(msg.effort[i]) if len(msg.effort) > i else math.nan
        except IndexError:
            self.get_logger().warning(
                f"JointState names {self.joint_name} but has no position for it; ignored", throttle_duration_sec=2.0
            )
            return
        now = self._now()
        self._wall_last_state = time.monotonic()
        if now <= 0.0:
            # use_sim_time and no /clock yet: the receipt time would be 0 and the state look
            # 1.8e9 s old; wait for a state received on a running clock
            return
        self.reading = JointReading(now, pos, vel, eff)

    def _on_run(self, req: RunTestCycle.Request, resp: RunTestCycle.Response) -> RunTestCycle.Response:
        resp.accepted = False
        resp.cycle_id = 0
        resp.reason = RefusalReason.NONE
        try:
            resp.message = self._start(req)
            resp.accepted = True
            resp.cycle_id = 0 if req.dry_run else self.runner.cycle_id
        except CycleRequestError as exc:
            resp.reason = exc.reason
            resp.message = f"refused: {exc}"
            self.refused_requests += 1
            self.get_logger().warning(f"run request refused: {exc}")
            self._update_diagnostics()
        return resp

    def _start(self, req: RunTestCycle.Request) -> str:
        if self.runner.running:
            st = self.runner.status()
            raise CycleRequestError(
                f"cycle {st.cycle_id} is running (speed {st.speeds_done + 1} of {st.speeds_total}); "
                "wait for it to finish or call ~/abort", RefusalReason.BUSY,
            )
        joint = req.joint_name or self.joint_name
        if joint != self.joint_name:
            raise CycleRequestError(f"unknown joint {joint!r}: this node drives {self.joint_name!r}",
                                    RefusalReason.WRONG_JOINT)
        simulator = bool(self.get_parameter("simulator").value)
        enabled = bool(self.get_parameter("motion_enabled").value)
        if not req.dry_run and not simulator and not enabled:
            raise CycleRequestError(
                f"motion is disabled for {self.joint_name}: make sure the cell is clear and the velocity "
                f"controller is active, then enable with 'ros2 param set {self.get_fully_qualified_name()} "
                "motion_enabled true' (or start with -p motion_enabled:=true)", RefusalReason.MOTION_DISABLED,
            )
        now = self._now()
        r = self.reading
        speeds = [float(v) for v in req.speeds]
        plan = plan_cycle(self.config, speeds, req.position, None if r is None else r.position)
        if r is None and not req.dry_run:
            raise CycleRequestError(
                f"no joint state for {self.joint_name} received yet on {self.get_parameter('joint_states_topic').value}; "
                "is the joint_state_broadcaster (or joint_sim) running?", RefusalReason.STATE_MISSING,
            )
        if r is not None and not req.dry_run and now - r.stamp > self.config.state_timeout:
            raise CycleRequestError(
                f"the joint state of {self.joint_name} is {now - r.stamp:.2f} s old (state_timeout "
                f"{self.config.state_timeout:g} s); is the driver still publishing?", RefusalReason.STATE_STALE,
            )
        wall_age = math.inf if self._wall_last_state is None else time.monotonic() - self._wall_last_state
        if r is not None and not req.dry_run and wall_age > self.state_timeout_wall:
            # on sim time a simulator that died stops the clock too: its last state never ages in node time
            raise CycleRequestError(
                f"the joint state of {self.joint_name} is stale: none received for {wall_age:.2f} s of wall time "
                f"(state_timeout_wall {self.state_timeout_wall:g} s); is the driver (or joint_sim) still running?", RefusalReason.STATE_STALE,
            )
        if req.dry_run:
            return f"dry run OK: {plan.summary()}; plan duration {plan.duration:.1f} s"
        cycle_id = self.next_cycle_id
        self.next_cycle_id += 1
        self.runner.start(plan, cycle_id, now)
        self.get_logger().info(f"cycle {cycle_id} started: {plan.summary()}")
        self._publish_status(force=True)
        self._update_diagnostics()
        return f"cycle {cycle_id} started: {plan.summary()}"

    def _on_abort(self, req: Trigger.Request, resp: Trigger.Response) -> Trigger.Response:
        cid = self.runner.cycle_id
        if self.runner.abort("aborted by operator"):
            self._send(0.0)
            self._publish_status(force=True)
            self.get_logger().warning(f"cycle {cid} aborted by operator")
            self._note_end()
            resp.success = True
            resp.message = f"cycle {cid} aborted; zero velocity sent"
        else:
            resp.success = False
            resp.message = f"no cycle running (state {self.runner.state.name})"
        return resp

    # -- outputs -------------------------------------------------------------
    def _send(self, velocity: float) -> None:
        self.cmd_pub.publish(Float64MultiArray(data=[float(velocity)]))
        self.commands_sent += 1
        self.last_command = float(velocity)

    def _publish_status(self, force: bool = False) -> None:
        st = self.runner.status()
        key = (st.cycle_id, st.state, st.phase, st.current_speed, st.speeds_done, st.speeds_total, st.message)
        now = self._now()
        if not force and key == self._last_status_key and now - self._last_status_time < self.status_period:
            return
        msg = TestCycleStatus()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.joint_name = self.joint_name
        msg.cycle_id = st.cycle_id
        msg.state = int(st.state)
        msg.phase = int(st.phase)
        msg.current_speed = float(st.current_speed)
        msg.speeds_done = st.speeds_done
        msg.speeds_total = st.speeds_total
        msg.window_center = float(st.window_center)
        msg.window_half_width = float(st.window_half_width)
        msg.message = st.message
        self.status_pub.publish(msg)
        if key != self._last_status_key and hasattr(self, "diag"):
            self._update_diagnostics(publish=False)  # the periodic republication shows the progress
        self._last_status_key = key
        self._last_status_time = now

    def _tick(self) -> None:
        if self.runner.running:
            wall_age = None
            if self.get_parameter("use_sim_time").value and self._wall_last_state is not None:
                wall_age = time.monotonic() - self._wall_last_state
            cmd = self.runner.update(self._now(), self.reading, wall_age)
            self._send(cmd)
            if not self.runner.running:
                self._report_end()
        self._publish_status()

    def _report_end(self) -> None:
        st = self.runner.status()
        text = f"cycle {st.cycle_id} {st.state.name}: {st.message}; zero velocity sent"
        # one call site per severity (rclpy keys a logger's severity by call site)
        if st.state == CycleState.DONE:
            self.get_logger().info(text)
        elif st.state == CycleState.ABORTED:
            self.get_logger().warning(text)
        else:
            self.get_logger().error(text)
        self._note_end()

    def _note_end(self) -> None:
        st = self.runner.status()
        if st.state in (CycleState.ABORTED, CycleState.FAILED):
            self.last_fault = f"cycle {st.cycle_id} {st.state.name}: {st.message}"
        self._update_diagnostics()

    def _update_diagnostics(self, publish: bool = True) -> None:
        st = self.runner.status()
        level = {CycleState.ABORTED: WARN, CycleState.FAILED: ERROR}.get(st.state, OK)
        if st.state == CycleState.RUNNING:
            message = f"cycle {st.cycle_id} running: speed {st.speeds_done + 1} of {st.speeds_total}"
        elif st.state == CycleState.IDLE:
            message = "idle"
        else:
            message = f"cycle {st.cycle_id} {st.state.name}: {st.message}"
        values = [("state", st.state.name), ("cycle_id", str(st.cycle_id)), ("speeds_done", str(st.speeds_done)),
                  ("speeds_total", str(st.speeds_total)), ("last_fault", self.last_fault or "none"),
                  ("refused_requests", str(self.refused_requests)), ("commands_sent", str(self.commands_sent))]
        if publish:
            self.diag.update(level, message, values)
        else:
            self.diag.set(level, message, values)

    # -- run-time parameters -------------------------------------------------
    def _on_parameters(self, changes: dict[str, Any]) -> str | None:
        # safety first: a stop request stops the cycle even if other changes in the same call are refused
        simulator = bool(changes.get("simulator", self.get_parameter("simulator").value))
        enabled = bool(changes.get("motion_enabled", self.get_parameter("motion_enabled").value))
        if self.runner.running and (("motion_enabled" in changes and not enabled) or not (simulator or enabled)):
            why = ("motion_enabled set to false" if "motion_enabled" in changes and not enabled
                   else "simulator set to false while motion_enabled is false")
            cid = self.runner.cycle_id
            self.runner.abort(f"stopped: {why} at run time")
            self._send(0.0)
            self._publish_status(force=True)
            self.get_logger().warning(f"cycle {cid} stopped: {why}; zero velocity sent")
            self._note_end()
        cycle = {k: _cycle_value(k, v) for k, v in changes.items() if k in _CYCLE_FIELDS}
        if cycle and self.runner.running:
            return (f"cycle {self.runner.cycle_id} is running: {', '.join(sorted(cycle))} cannot change during a "
                    "cycle (its plan and watchdog use the old values); set it again when the cycle has ended, or "
                    "call ~/abort first")
        new = self.config
        if cycle:
            new = replace(self.config, **cycle)
            try:
                new.check()
                plan_cycle(new)  # the default speeds must still be plannable
            except JointwearError as exc:
                return str(exc)
        wall = float(changes.get("state_timeout_wall", self.state_timeout_wall))
        if not (math.isfinite(wall) and wall > 0):
            return f"state_timeout_wall {wall!r} must be a number of seconds > 0"
        self.config = new
        self.runner.config = new
        self.state_timeout_wall = wall
        return None

    def _wall_watchdog(self) -> None:
        # node time may stop with the joint-state source (a simulator that is also the clock)
        if not self.runner.running:
            return
        last = self._wall_last_state
        age = math.inf if last is None else time.monotonic() - last
        if age > self.state_timeout_wall:
            self.runner.fail(
                f"watchdog: no joint state of {self.joint_name} for {age:.3f} s wall time "
                f"(state_timeout_wall {self.state_timeout_wall:g} s)"
            )
            self._send(0.0)
            self._report_end()
            self._publish_status(force=True)

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: stop a running cycle and send zero velocity."""
        if self.runner.abort("node shutting down"):
            self._publish_status(force=True)
        self._send(0.0)
        for pub in (self.cmd_pub, self.status_pub):
            try:
                pub.wait_for_all_acked(Duration(seconds=0.5))
            except Exception:  # pragma: no cover - best effort on the way out
                pass


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point ``test_cycle``."""
    return run_node(TestCycleNode, args)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
