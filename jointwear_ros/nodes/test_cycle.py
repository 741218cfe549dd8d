"""``test_cycle``: runs a friction test cycle on the joints of a robot when asked by service call.

The node drives the joints of its ``joints`` parameter (empty: the one joint
``joint_name``), in that order in the velocity command array, as a ros2_control
``JointGroupVelocityController`` does. Each joint has its own settings
(``<joint>.<setting>``, e.g. ``joint_3.joint_limits``; the node-level value is
the default, see docs/robot.md).

Services: ``~/run`` (``jointwear_msgs/srv/RunTestCycle``; answers at once with
accepted, cycle_id, the refusal ``reason`` code and the plan or the reason in words) and ``~/abort``
(``std_srvs/srv/Trigger``). A request names the joints to test (``joints``; empty:
``joint_name``, or every driven joint when that is empty too), one window centre
per joint (``positions``) and the speeds; the whole request is checked and every
joint planned before anything moves. The parameter ``sweep`` (read at each request)
says how a request of several joints runs: ``sequential`` (the default) tests the
joints one after another under one cycle id, every other joint held at zero velocity
(:class:`jointwear_ros.cycle.RobotCycleRunner`); ``simultaneous`` sweeps every
requested joint at once along one straight line in joint space and back, each joint
at its own speeds (:mod:`jointwear_ros.cycle.line`; a driven joint not requested is
held). A request of one joint runs as ``sequential`` either way. On a node that drives one
joint, ``position`` applies as in earlier versions (also without ``joint_name``).

Publishes ``~/status`` (``TestCycleStatus``: the joint under test, its state
and phase, ``joints`` and ``joints_done``) on every change and at ``status_rate``;
in a simultaneous cycle one status per requested joint each time, in the request's
order (the last joint's ended status ends the robot cycle).
While a cycle runs it streams velocity commands (``Float64MultiArray``, one
joint rad/s per driven joint: the sweep for the joint under test, 0 for the
others) at ``command_rate`` (forward command controllers hold the last command
forever) and sends zero for every joint on finish, abort, error, watchdog trip
and node exit.

Safety: ``motion_enabled`` must be true to move a real joint; a simulated cell
is marked with ``simulator: true``. With ``arm`` (read-only; an arm of
:mod:`jointwear_ros.sim.arms`, e.g. ``ur5``) every planned cycle is checked against
the arm's model before anything moves (:func:`jointwear_ros.sim.collision.check_plan`:
each step's approach and sweep, no two links and no link and the table closer than
1 cm): a path that comes closer is refused (``BAD_REQUEST``) with the step, the links
and the configuration; an accepted plan says its closest approach. Empty (the
default): no check. The watchdog (see
:mod:`jointwear_ros.cycle.runner` and :mod:`jointwear_ros.cycle.robot`: every
driven joint is watched, a held joint may not move more than ``hold_tolerance``)
runs in node time (``use_sim_time``
honoured); a second check in wall time catches a joint-state source that
stops together with the clock it provides. A request is refused when the
joint state is older than ``state_timeout`` in node time or
``state_timeout_wall`` in wall time (a simulator that died stops the sim
clock too, so its last state never looks old in sim time).

Run-time parameters: setting ``motion_enabled`` to false stops a running
cycle at once (zero command, state ABORTED with the reason), also on a
simulator. The cycle settings (speeds, limits, ``max_speed``, timeouts,
tolerances, ``hold_tolerance``, ...) apply to the next request; while a cycle
runs a change is refused with the reason (the running plan and its watchdog
were checked with the old values). A node-level setting set at run time
applies to every joint (its ``<joint>.<setting>`` parameters are set with it);
``<joint>.<setting>`` to that joint only. Topics, ``joint_name``, ``joints``,
``gear_ratio`` and the rates are read at start-up only (read-only parameters).

Diagnostics: ``test_cycle: <joint>`` on ``/diagnostics`` per driven joint: OK
while idle, running or after a DONE cycle; WARN after an ABORTED cycle; ERROR
after a FAILED one (a watchdog stop, also when a held joint tripped it), with
the reason as the message; key/values state, cycle_id, speeds_done,
speeds_total, last_fault, refused_requests, commands_sent. ``test_cycle: robot``
reports the robot cycle as a whole the same way (key/values state, cycle_id,
joints, joints_done, last_fault, refused_requests, commands_sent).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from functools import partial
from typing import Any

from jointwear_msgs.msg import TestCycleStatus
from jointwear_msgs.srv import RunTestCycle
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from ..contract import DiagnosticLevel, RefusalReason, status_to_msg
from ..cycle import (
    CycleConfig,
    CycleRequestError,
    CycleState,
    JointReading,
    LineCycleRunner,
    RobotCycleRunner,
    plan_line_cycle,
    plan_robot_cycle,
)
from ..errors import JointwearError, ParameterError
from ..settings import declarations, from_mapping, node_declarations
from ..sim.arms import arm_spec
from .diagnostics import Status, Updater
from .joints import declare_robot, propagate_node_level
from .runtime import ParamDecl, on_parameter_change, overridable_qos, run_node_refusing, wait_acked

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "PER_JOINT", "TestCycleNode", "main", "parameters"]

#: the node's own settings (the cycle's are CycleConfig's fields, declared there with their metadata)
_NODE_HEAD: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", "joint_1", "the joint this node drives when joints is empty (looked up by name in "
              "/joint_states)", read_only=True),
    ParamDecl("joints", [], "the joints this node drives, in velocity-command order (empty: joint_name)",
              read_only=True),
    ParamDecl("command_topic", "/velocity_controller/commands", "velocity command topic (Float64MultiArray)",
              read_only=True),
    ParamDecl("joint_states_topic", "/joint_states", "joint state topic", read_only=True),
)
_NODE_TAIL: tuple[ParamDecl, ...] = (
    ParamDecl(
        "state_timeout_wall", 1.0,
        "watchdog: no joint state for this many wall-clock s stops the cycle (catches a clock source that died)",
        1e-3, 100.0, unit="s",
    ),
    ParamDecl("hold_tolerance", 0.02, "watchdog: largest move of a held joint from where the cycle found it, and "
              "(sweep simultaneous) largest distance of a joint from the line, rad", 1e-5, 10.0, unit="rad"),
    ParamDecl("sweep", "sequential", "how a request of several joints runs: sequential (one joint after another, "
              "the others held) or simultaneous (every joint at once along one straight line in joint space and "
              "back); read at each request"),
    ParamDecl("arm", "", "the arm of jointwear_ros.sim.arms (ur5, panda) whose model every planned cycle is checked "
              "against before anything moves (self-collision and the table, 1 cm clearance; the i-th of joints is "
              "the arm's i-th joint); empty: no check (a robot whose model the node does not know)", read_only=True),
    ParamDecl("command_rate", 100.0, "velocity command rate while running, Hz (node time)", 1.0, 10000.0,
              read_only=True, unit="Hz"),
    ParamDecl("status_rate", 10.0, "periodic status rate, Hz (node time)", 0.1, 1000.0, read_only=True, unit="Hz"),
    ParamDecl("first_cycle_id", 0, "id of the first cycle after start, each next one +1; 0: the wall-clock "
              "second (Unix time) the node started, so ids stay unique per joint across restarts of the node "
              "and of the cell (the history and the trend tell cycles apart by id)", read_only=True),
    ParamDecl("motion_enabled", False, "allow motion of a real joint (not needed when simulator is true); "
              "setting it false stops a running cycle at once"),
    ParamDecl("simulator", False, "the joint is the simulator (joint_sim): motion allowed without motion_enabled"),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True, unit="s"),
)


def parameters(config: type = CycleConfig) -> tuple[ParamDecl, ...]:
    """Every parameter of the node: its own and the cycle settings of ``config`` (its field metadata)."""
    return node_declarations(config, _NODE_HEAD, _NODE_TAIL).parameters


#: every parameter; those that can change at run time (the per-joint ones, ``<joint>.<setting>``, too); the
#: settings each joint may have of its own (``<joint>.<setting>``; the node-level value is the default)
PARAMETERS, LIVE_PARAMETERS, PER_JOINT = node_declarations(CycleConfig, _NODE_HEAD, _NODE_TAIL)
#: The cycle settings (CycleConfig fields); those not read-only apply from the next request
_CYCLE_SETTINGS = frozenset(d.name for d in declarations(CycleConfig))
_DECLS = {d.name: d for d in PARAMETERS}

_RELIABLE_1 = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
_RELIABLE_10 = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
_RELIABLE_100 = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
_LEVEL = {CycleState.ABORTED: DiagnosticLevel.WARN, CycleState.FAILED: DiagnosticLevel.ERROR}
#: the values of ``sweep``
SWEEPS = ("sequential", "simultaneous")


def _check_sweep(value: Any) -> str | None:
    """Why ``value`` is not a ``sweep`` (None: it is one)."""
    if value in SWEEPS:
        return None
    return f"sweep {value!r} must be one of {', '.join(SWEEPS)}"


class TestCycleNode(Node):
    """The test-cycle node (see the module docstring)."""

    __test__ = False  # not a pytest test class

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("test_cycle", **kwargs)
        p, self.joints, self._values = declare_robot(self, PARAMETERS, PER_JOINT)
        self.joint_name = self.joints[0]
        live = [n for n in PER_JOINT if not _DECLS[n].read_only]
        self.node_values = {name: p[name] for name in _CYCLE_SETTINGS}  # node level (each joint's own: _values)
        self.control_period = 1.0 / float(p["command_rate"])  # the runner's update interval
        self.configs = self._build_configs(self._values, self.node_values)
        self.hold_tolerance = float(p["hold_tolerance"])
        self.max_duration = float(p["max_duration"])
        plan_robot_cycle(self.configs)  # the default speeds of every joint must be plannable
        bad = _check_sweep(p["sweep"])
        if bad is not None:
            raise ParameterError(f"test_cycle: {bad}")
        #: the arm's collision check of every plan (None: ``arm`` empty, no check); built once, at start-up
        self.collision: Any = None
        arm = str(p["arm"]).strip()
        if arm:
            arm_spec(arm).for_names(self.joints)  # an unknown arm or too many joints: one line, before the model
            from ..sim.collision import collision_checker  # Pinocchio: imported only by a node that checks

            self.collision = collision_checker(arm, len(self.joints))
        self.sequential = RobotCycleRunner(self.configs, self.hold_tolerance)
        self.line = LineCycleRunner(self.configs, self.hold_tolerance)
        self.line.results = self.sequential.results  # one outcome per joint, whichever sweep tested it last
        #: the runner of the current (or last) cycle
        self.runner: RobotCycleRunner | LineCycleRunner = self.sequential
        first = int(p["first_cycle_id"])
        if not 0 <= first < 2**32 - 10**6:
            raise ParameterError(f"test_cycle: first_cycle_id = {first} must be 0 (Unix time) or 1 to {2**32 - 10**6 - 1}")
        self.next_cycle_id = first or int(time.time())
        self.readings: dict[str, JointReading] = {}
        self._wall_last: dict[str, float] = {}
        self.state_timeout_wall = float(p["state_timeout_wall"])
        self._last_status_key: tuple[Any, ...] | None = None
        self._last_status_time = -math.inf
        self.status_period = 1.0 / float(p["status_rate"])
        self.commands_sent = 0
        self.last_command: list[float] | None = None
        self.refused_requests = 0
        self.last_fault = ""
        self.last_faults: dict[str, str] = {}

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
        # health: the robot's cycle and each driven joint's, one task each (read at every update)
        self.health = Updater(self, "test_cycle", period=float(p["diagnostics_period"]))
        self.health.add("robot", self._robot_health, hardware_id="robot")
        for j in self.joints:
            self.health.add(j, partial(self._joint_health, j), hardware_id=j)
        self.add_pre_set_parameters_callback(propagate_node_level(live, self.joints))
        on_parameter_change(self, self._on_parameters,
                            LIVE_PARAMETERS + tuple(f"{j}.{n}" for j in self.joints for n in live))
        self._publish_status(force=True)
        self._update_diagnostics()
        for j in self.joints:
            c = self.configs[j]
            self.get_logger().info(
                f"test cycle for {j}: speeds {list(c.speeds)} rad/s (motor), window {c.position:g} ± "
                f"{c.window_half_width:g} rad, limits {list(c.joint_limits)} rad"
            )
        self.get_logger().info(
            f"driving {len(self.joints)} joint(s) {', '.join(self.joints)}, hold_tolerance {self.hold_tolerance:g} rad"
            + (", simulator" if p["simulator"] else f", motion_enabled={p['motion_enabled']}")
        )

    def _build_configs(self, values: Mapping[str, Mapping[str, Any]],
                       node_values: Mapping[str, Any]) -> dict[str, CycleConfig]:
        """Each joint's :class:`CycleConfig`: its own settings over the node-level ones
        (:func:`jointwear_ros.settings.from_mapping`), checked."""
        configs: dict[str, CycleConfig] = {}
        for j, vals in values.items():
            try:
                cfg = from_mapping(CycleConfig, {**node_values, **vals}, joint_name=j,
                                   control_period=self.control_period)
                cfg.check()
            except CycleRequestError as exc:
                raise CycleRequestError(f"{j}: {exc}", exc.reason) from None
            except ParameterError as exc:
                raise ParameterError(f"{j}: {exc}") from None
            configs[j] = cfg
        return configs

    # -- time ----------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- inputs --------------------------------------------------------------
    def _on_joint_state(self, msg: JointState) -> None:
        names = list(msg.name)
        now: float | None = None
        wall = time.monotonic()
        for j in self.joints:
            try:
                i = names.index(j)
            except ValueError:
                continue
            try:
                pos = float(msg.position[i])
                vel = float(msg.velocity[i]) if len(msg.velocity) > i else math.nan
                eff = float(msg.effort[i]) if len(msg.effort) > i else math.nan
            except IndexError:
                self.get_logger().warning(
                    f"JointState names {j} but has no position for it; ignored", throttle_duration_sec=2.0
                )
                continue
            if now is None:
                now = self._now()
            self._wall_last[j] = wall
            if now <= 0.0:
                # use_sim_time and no /clock yet: the receipt time would be 0 and the state look
                # 1.8e9 s old; wait for a state received on a running clock
                continue
            self.readings[j] = JointReading(now, pos, vel, eff)

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

    def _request(self, req: RunTestCycle.Request) -> tuple[list[str], list[float] | None]:
        """The joints and window centres a request asks for (see the module docstring)."""
        if len(req.joints):
            return [str(j) for j in req.joints], [float(x) for x in req.positions] if len(req.positions) else None
        if req.joint_name or len(self.joints) == 1:  # the one-joint form of the request (joint_name, position)
            return [req.joint_name or self.joint_name], [float(req.position)]
        return [], [float(x) for x in req.positions] if len(req.positions) else None

    def _start(self, req: RunTestCycle.Request) -> str:
        if self.runner.running:
            st = self.runner.status()
            raise CycleRequestError(
                f"cycle {st.cycle_id} is running ({st.joint_name}: speed {st.speeds_done + 1} of {st.speeds_total}); "
                "wait for it to finish or call ~/abort", RefusalReason.BUSY,
            )
        joints, positions = self._request(req)
        unknown = [j for j in joints if j not in self.configs]
        if unknown:
            drives = ", ".join(f"'{j}'" for j in self.joints)
            raise CycleRequestError(f"unknown joint {unknown[0]!r}: this node drives {drives}",
                                    RefusalReason.WRONG_JOINT)
        simulator = bool(self.get_parameter("simulator").value)
        enabled = bool(self.get_parameter("motion_enabled").value)
        if not req.dry_run and not simulator and not enabled:
            raise CycleRequestError(
                f"motion is disabled for {', '.join(joints or self.joints)}: make sure the cell is clear and the "
                f"velocity controller is active, then enable with 'ros2 param set {self.get_fully_qualified_name()} "
                "motion_enabled true' (or start with -p motion_enabled:=true)", RefusalReason.MOTION_DISABLED,
            )
        now = self._now()
        speeds = [float(v) for v in req.speeds]
        here = {j: r.position for j, r in self.readings.items()}
        at_once = self.get_parameter("sweep").value == "simultaneous" and len(joints or self.joints) > 1
        if at_once:
            line = plan_line_cycle(self.configs, joints, speeds, positions, here, self.max_duration)
            summary, duration = line.summary(), line.duration
        else:
            plan = plan_robot_cycle(self.configs, joints, speeds, positions, here, self.max_duration)
            summary, duration = plan.summary(), plan.duration
        if self.collision is not None:  # every move of the plan against the arm's model, before anything moves
            from ..sim.collision import check_plan

            clear = check_plan(self.collision, line if at_once else plan, self.configs, self.joints, here)
            c = clear.contact
            summary += (f"; path clear of the {self.collision.spec.name}'s links and the table (closest: {c.first} "
                        f"and {c.second}, {100 * c.distance:.1f} cm, {clear.step})")
        if not req.dry_run:
            self._check_states(now)
        if req.dry_run:
            return f"dry run OK: {summary}; plan duration {duration:.1f} s"
        cycle_id = self.next_cycle_id
        self.next_cycle_id += 1
        if at_once:
            self.runner = self.line
            self.line.start(line, cycle_id, now, here)
        else:
            self.runner = self.sequential
            self.sequential.start(plan, cycle_id, now, here)
        self.get_logger().info(f"cycle {cycle_id} started: {summary}")
        self._publish_status(force=True)
        self._update_diagnostics()
        return f"cycle {cycle_id} started: {summary}"

    def _check_states(self, now: float) -> None:
        """Refuse when a driven joint's state is missing or stale (every joint is watched, not only those tested)."""
        topic = self.get_parameter("joint_states_topic").value
        for j in self.joints:
            r = self.readings.get(j)
            if r is None:
                raise CycleRequestError(
                    f"no joint state for {j} received yet on {topic}; "
                    "is the joint_state_broadcaster (or joint_sim) running?", RefusalReason.STATE_MISSING,
                )
            timeout = self.configs[j].state_timeout
            if now - r.stamp > timeout:
                raise CycleRequestError(
                    f"the joint state of {j} is {now - r.stamp:.2f} s old (state_timeout "
                    f"{timeout:g} s); is the driver still publishing?", RefusalReason.STATE_STALE,
                )
            wall_age = time.monotonic() - self._wall_last.get(j, -math.inf)
            if wall_age > self.state_timeout_wall:
                # on sim time a simulator that died stops the clock too: its last state never ages in node time
                raise CycleRequestError(
                    f"the joint state of {j} is stale: none received for {wall_age:.2f} s of wall time "
                    f"(state_timeout_wall {self.state_timeout_wall:g} s); is the driver (or joint_sim) still running?",
                    RefusalReason.STATE_STALE,
                )

    def _on_abort(self, req: Trigger.Request, resp: Trigger.Response) -> Trigger.Response:
        cid = self.runner.cycle_id
        if self.runner.abort("aborted by operator"):
            self._send_zero()
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
    def _send(self, commands: Mapping[str, float]) -> None:
        data = [float(commands.get(j, 0.0)) for j in self.joints]
        self.cmd_pub.publish(Float64MultiArray(data=data))
        self.commands_sent += 1
        self.last_command = data

    def _send_zero(self) -> None:
        self._send({})

    def _publish_status(self, force: bool = False) -> None:
        """The runner's statuses (one; one per joint in a simultaneous cycle, in order) on a change, when forced
        and every status period."""
        sts = self.runner.statuses()
        key = tuple((st.cycle_id, st.joint_name, st.joints_done, st.state, st.phase, st.current_speed,
                     st.speeds_done, st.speeds_total, st.message) for st in sts)
        now = self._now()
        if not force and key == self._last_status_key and now - self._last_status_time < self.status_period:
            return
        stamp = self.get_clock().now().to_msg()
        for st in sts:
            msg = status_to_msg(st, TestCycleStatus)
            msg.header.stamp = stamp
            self.status_pub.publish(msg)
        self._last_status_key = key
        self._last_status_time = now

    def _tick(self) -> None:
        if self.runner.running:
            wall_ages = None
            if self.get_parameter("use_sim_time").value:
                mono = time.monotonic()
                wall_ages = {j: mono - t for j, t in self._wall_last.items()}
            cmd = self.runner.update(self._now(), self.readings, wall_ages)
            self._send(cmd)
            if not self.runner.running:
                self._report_end()
            elif self.runner.status().state == CycleState.DONE:
                self._publish_status(force=True)  # one joint done: its DONE goes out before the next joint starts
                return
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
            for j, res in self.runner.results.items():
                if res.cycle_id == st.cycle_id and res.state in (CycleState.ABORTED, CycleState.FAILED):
                    self.last_faults[j] = f"cycle {res.cycle_id} {res.state.name}: {res.message}"
        self._update_diagnostics()

    def _update_diagnostics(self) -> None:
        """Publish the health now (on a cycle's start, end and refusals; the periodic update shows progress)."""
        self.health.update()

    def _counters(self) -> list[tuple[str, str]]:
        return [("refused_requests", str(self.refused_requests)), ("commands_sent", str(self.commands_sent))]

    def _robot_health(self, stat: Status) -> None:
        st = self.runner.status()
        if self.runner.running and self.runner is self.line:
            message = (f"cycle {st.cycle_id} running: {len(st.joints)} joints at once, speed "
                       f"{st.speeds_done + 1} of {st.speeds_total}")
        elif self.runner.running:
            message = f"cycle {st.cycle_id} running: {st.joint_name} ({st.joints_done + 1} of {len(st.joints)})"
        elif st.state == CycleState.IDLE:
            message = "idle"
        else:
            message = f"cycle {st.cycle_id} {st.state.name}: {st.message}"
        robot_state = CycleState.RUNNING if self.runner.running else st.state
        stat.summary(_LEVEL.get(robot_state, DiagnosticLevel.OK), message)
        stat.extend([("state", robot_state.name), ("cycle_id", str(st.cycle_id)), ("joints", ",".join(st.joints)),
                     ("joints_done", str(st.joints_done)), ("last_fault", self.last_fault or "none"),
                     *self._counters()])

    def _joint_health(self, j: str, stat: Status) -> None:
        res = self.runner.results.get(j)
        if res is None:
            stat.summary(DiagnosticLevel.OK, "idle")
            stat.extend([("state", "IDLE"), ("cycle_id", "0"), ("speeds_done", "0"), ("speeds_total", "0")])
        else:
            st = self.runner.status()
            state = res.state
            speeds_done = res.speeds_done
            if state == CycleState.RUNNING and j == st.joint_name and self.runner.running:
                state, speeds_done = st.state, st.speeds_done
            if state == CycleState.RUNNING:
                message = f"cycle {res.cycle_id} running: speed {speeds_done + 1} of {res.speeds_total}"
            elif state == CycleState.IDLE:
                message = res.message
            else:
                message = f"cycle {res.cycle_id} {state.name}: {res.message}"
            stat.summary(_LEVEL.get(state, DiagnosticLevel.OK), message)
            stat.extend([("state", state.name), ("cycle_id", str(res.cycle_id)), ("speeds_done", str(speeds_done)),
                         ("speeds_total", str(res.speeds_total))])
        stat.extend([("last_fault", self.last_faults.get(j, "none")), *self._counters()])

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
            self._send_zero()
            self._publish_status(force=True)
            self.get_logger().warning(f"cycle {cid} stopped: {why}; zero velocity sent")
            self._note_end()
        cycle = {k: v for k, v in changes.items()
                 if k in _CYCLE_SETTINGS or k == "hold_tolerance" or ("." in k and k.split(".", 1)[0] in self.configs)}
        if cycle and self.runner.running:
            # name what was asked for: a node-level name, not the <joint>.<name> it set with it
            asked = sorted(k for k in cycle if not ("." in k and k.split(".", 1)[1] in cycle))
            return (f"cycle {self.runner.cycle_id} is running: {', '.join(asked)} cannot change during a "
                    "cycle (its plan and watchdog use the old values); set it again when the cycle has ended, or "
                    "call ~/abort first")
        values = {j: dict(v) for j, v in self._values.items()}
        node_values = dict(self.node_values)
        for k, v in cycle.items():
            if "." in k:
                j, name = k.split(".", 1)
                values[j][name] = v
            elif k in node_values:
                node_values[k] = v
        bad = _check_sweep(changes.get("sweep", "sequential"))
        if bad is not None:
            return bad
        hold = float(changes.get("hold_tolerance", self.hold_tolerance))
        max_duration = float(changes.get("max_duration", self.max_duration))
        configs = self.configs
        if cycle:
            try:
                configs = self._build_configs(values, node_values)
                plan_robot_cycle(configs, max_duration=max_duration)  # the default speeds must still be plannable
            except JointwearError as exc:
                return str(exc)
        wall = float(changes.get("state_timeout_wall", self.state_timeout_wall))
        if not (math.isfinite(wall) and wall > 0):
            return f"state_timeout_wall {wall!r} must be a number of seconds > 0"
        if not (math.isfinite(hold) and hold > 0):
            return f"hold_tolerance {hold!r} must be a distance in rad > 0"
        self._values, self.node_values, self.configs = values, node_values, configs
        self.max_duration = max_duration
        self.hold_tolerance = hold
        self.sequential.reconfigure(configs, hold)
        self.line.reconfigure(configs, hold)
        self.state_timeout_wall = wall
        return None

    def _wall_watchdog(self) -> None:
        # node time may stop with the joint-state source (a simulator that is also the clock)
        if not self.runner.running:
            return
        now = time.monotonic()
        ages = {j: now - self._wall_last.get(j, -math.inf) for j in self.joints}
        j = max(ages, key=lambda k: ages[k])
        if ages[j] > self.state_timeout_wall:
            self.runner.fail(
                f"watchdog: no joint state of {j} for {ages[j]:.3f} s wall time "
                f"(state_timeout_wall {self.state_timeout_wall:g} s)", j,
            )
            self._send_zero()
            self._report_end()
            self._publish_status(force=True)

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: stop a running cycle and send zero velocity to every joint."""
        if self.runner.abort("node shutting down"):
            self._publish_status(force=True)
        self._send_zero()
        wait_acked([self.cmd_pub, self.status_pub])


def main(args: Sequence[str] | None = None) -> int:
    """Console entry point ``test_cycle``: exit status 2 with one line on stderr for a bad start-up setting (an
    unknown ``arm``, more joints than the arm has, a value out of range)."""
    # rclpy's Python executor, not the C++ EventsExecutor (which took test_cycle's CPU in a six-joint demo from
    # 6.7 s to 4.2 s at stop 42): on it the sim-time command timer once stopped firing while /clock had passed its
    # deadline. joint_sim's lockstep then held the clock for the command that never came, and the wall watchdog
    # failed the cycle (`demo --wear 40`, 3.046 s without a joint state; a five-cycle graph test, 1.047 s); the
    # recorded bag shows the clock past the timer's next call and no command for 3 s (docs/testing.md, stop 43)
    return run_node_refusing("test_cycle", TestCycleNode, args)

if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
