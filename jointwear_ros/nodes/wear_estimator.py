"""wear_estimator: FrictionObservation per cycle (or production shift) → WearEstimate and /diagnostics, per joint.

A thin rclpy adapter over :class:`~jointwear_ros.monitor.RobotMonitor` (the
same per-joint monitors and routing the offline replay runs), one
:class:`~jointwear_ros.monitor.WearMonitor` per joint it serves
(``joints``; empty = the single joint ``joint_name``, see docs/robot.md), each
with its own settings (``<joint>.params``, ``<joint>.hardware_id``,
``<joint>.warn_threshold``, ...: declared for every joint, by default the
node-level value). Observations go to the monitor of their ``joint_name``,
``TestCycleStatus`` to the monitor of its ``joint_name`` (a robot cycle tests
its joints one after another under one cycle id: each joint's monitor sees the
RUNNING → DONE stream of a one-joint cycle). A monitor gathers observations per
cycle id and estimates a cycle's wear when all its speeds are in or
``done_timeout`` after its DONE status; the node publishes one
``jointwear_msgs/WearEstimate`` per joint and cycle and keeps one
``diagnostic_msgs/DiagnosticStatus`` per joint named ``wear_estimator: <joint>``
(a held status each in one :class:`~jointwear_ros.nodes.diagnostics.Updater`:
all joints in one ``DiagnosticArray``): the joint's condition level
(:mod:`jointwear_ros.condition`, the same rule on every surface: ERROR at the alarm, WARN in the
warning band or when the estimate cannot rule the alarm out, else OK; a cycle from too few speeds,
with no observation or a held outlier leaves the level as it stood, docs/levels.md)
-- one joint's level never changes another's; key/values wear, wear_std,
method, cycle_id, temperature_estimate, n_observations (and
observations_rejected / temperatures_unknown when the screening dropped an
observation or made its temperature unknown, see
:mod:`jointwear_ros.monitor.validation`), ``calibrated`` (``true``/``false``: whether the
joint's wear scale is calibrated; false for a commissioned joint without wear data, whose
``wear_std`` then includes the wear scale's own uncertainty, ``wear_std_noise`` and
``wear_scale_std`` its parts, :mod:`jointwear_ros.estimation.wear_scale`) and
``wear_calibration`` (the set's label), from the start, before the first estimate. The statuses are republished every
``diagnostics_period`` so aggregators do not mark them stale. An observation
or status of a joint not served is ignored, counted (``ignored_messages``) and
logged (throttled).

**Sources.** ``observations_topic`` carries the observations of both sources, told apart by their
``source`` field (``test_cycle`` or ``production``); ``status_topic`` (``/test_cycle/status``) is the test
cycle's status stream, ``production_status_topic`` (``/production/status``, the same ``TestCycleStatus``
type) the production observer's: per joint a RUNNING then DONE with ``speeds_total`` the number of that
joint's observations in the shift and the shift id as ``cycle_id``. A production shift is estimated as a
unit like a test cycle, keyed apart from it (shift 3 and test cycle 3 never mix), and its ``WearEstimate``
says ``source: production``.

Run-time parameter changes (``ros2 param set``) of the estimator settings
(thresholds, method, parameter set, timeouts, ...) are checked and apply from
the next estimate: ``<joint>.<setting>`` to that joint only; a node-level
``<setting>`` to every joint (it sets every ``<joint>.<setting>`` in the same
call, replacing a value a joint had of its own: set ``<joint>.<setting>``
again afterwards to keep that joint different; the replaced values are
logged). Each joint's new settings are checked as a whole; a change that
cannot work for a joint is refused with the joint and the reason, and no joint
changes. Topics, ``joints``, ``joint_name``, ``hardware_id`` (node level and
per joint) and ``diagnostics_period`` are read at start-up only (read-only
parameters).

Parameters: see ``config/wear_estimator.yaml`` and ``docs/nodes-observer-estimator.md``.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping
from typing import Any

from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..contract import DiagnosticLevel, Source, observation_from_msg, status_from_msg
from ..errors import JointwearError, ParameterError
from ..estimation import wear_scale
from ..model import load_parameter_set_info
from ..monitor import CycleResult, MonitorConfig, RobotMonitor, WearMonitor
from ..settings import from_mapping, node_declarations, settings_of
from .diagnostics import HeldStatus, Updater, diagnostic_status
from .joints import declare_robot, propagate_node_level, replaced_own_values, split_per_joint
from .runtime import (
    ParamDecl,
    on_parameter_change,
    overridable_qos,
    run_node,
    seconds_to_stamp,
    wait_acked,
)

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "PER_JOINT", "WearEstimatorNode", "diagnostic_status", "estimate_to_msg",
           "main", "monitor_config", "parameters"]

#: the node's own settings (each joint's estimator settings are MonitorConfig's fields, declared there)
_NODE_HEAD: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", MonitorConfig.joint_name, "joint whose wear is estimated when joints is empty",
              read_only=True),
    ParamDecl("hardware_id", "", "DiagnosticStatus.hardware_id (empty = the joint name)", read_only=True,
              per_joint=True),
)
_NODE_TAIL: tuple[ParamDecl, ...] = (
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications", 0.01, 60.0, read_only=True),
    ParamDecl("observations_topic", "/jointwear/friction_observations", "FrictionObservation input", read_only=True),
    ParamDecl("status_topic", "/test_cycle/status", "TestCycleStatus input (the test cycle's)", read_only=True),
    ParamDecl("production_status_topic", "/production/status",
              "TestCycleStatus input of the production observer (a shift per cycle_id)", read_only=True),
    ParamDecl("estimate_topic", "/jointwear/wear_estimate", "WearEstimate output", read_only=True),
    ParamDecl("diagnostics_topic", "/diagnostics", "DiagnosticArray output", read_only=True),
)


def parameters(config: type = MonitorConfig) -> tuple[ParamDecl, ...]:
    """Every parameter of the node: its own and the estimator settings of ``config`` (its field metadata)."""
    return node_declarations(config, _NODE_HEAD, _NODE_TAIL).parameters


#: every parameter; those that apply at run time (from the next estimate); the settings each joint has of its own
#: (``<joint>.<setting>``, default: the node-level value)
PARAMETERS, LIVE_PARAMETERS, PER_JOINT = node_declarations(MonitorConfig, _NODE_HEAD, _NODE_TAIL)


def monitor_config(values: Mapping[str, Any], joint: str, config: type = MonitorConfig) -> MonitorConfig:
    """Joint ``joint``'s estimator settings from the node's parameter values (``<joint>.<setting>`` over the
    node-level ``<setting>``; :func:`jointwear_ros.settings.from_mapping`), checked."""
    cfg: MonitorConfig = from_mapping(config, values, joint=joint, joint_name=joint)
    return cfg


def _calibration_values(params: str) -> list[tuple[str, str]]:
    """``calibrated`` and ``wear_calibration`` of a joint's set (before its first estimate); none if it cannot load."""
    try:
        scale = wear_scale(load_parameter_set_info(params))
    except JointwearError:
        return []
    return [("calibrated", "true" if scale.calibrated else "false"), ("wear_calibration", scale.label)]


def estimate_to_msg(r: CycleResult) -> WearEstimate:
    """The WearEstimate of a cycle result that has an estimate."""
    res = r.result
    assert res is not None
    m = WearEstimate()
    m.header.stamp = seconds_to_stamp(r.stamp)
    m.joint_name = r.joint_name
    m.cycle_id = int(r.cycle_id)
    m.method = res.method
    m.wear = float(res.wear)
    m.wear_std = float(res.wear_std)
    m.wear_low = float(res.wear_low)
    m.wear_high = float(res.wear_high)
    m.temperature_estimate = float(res.temperature)
    m.speeds = [float(s) for s in res.speeds]
    per = list(res.per_speed_wear)
    m.per_speed_wear = [float(w) for w in per] if len(per) == len(res.speeds) else [math.nan] * len(res.speeds)
    m.alarm_threshold = float(r.alarm_threshold)
    m.alarm = bool(r.alarm)
    m.level = int(r.level)
    m.evidence = r.evidence
    m.confirmation = r.confirmation
    m.source = str(r.source)
    return m


class _Joint:
    """One joint's monitor (in the robot monitor), its results and its ``wear_estimator: <joint>`` status."""

    def __init__(self, name: str, monitor: WearMonitor, held: HeldStatus) -> None:
        self.name = name
        self.monitor = monitor
        self.held = held
        self.results: list[CycleResult] = []


class WearEstimatorNode(Node):
    """The wear estimator node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wear_estimator", **kwargs)
        p, self.joints, values = declare_robot(self, PARAMETERS, PER_JOINT)
        self.params = p
        configs: dict[str, MonitorConfig] = {}
        for j in self.joints:
            try:
                configs[j] = monitor_config({**p, **values[j]}, j)
            except (JointwearError, ValueError, TypeError) as exc:
                raise ParameterError(f"wear_estimator: {j}: {exc}") from None
        try:
            #: one monitor per joint and the routing of observations and statuses to them (the same as replay's)
            self.robot_monitor = RobotMonitor(configs)
        except (JointwearError, ValueError, TypeError) as exc:
            raise ParameterError(f"wear_estimator: {exc}") from None
        #: every joint's cycle results, in the order they came
        self.results: list[CycleResult] = []
        #: observations and statuses not used: a joint not served, a repeat, screened out, ...
        self.ignored_messages = 0
        self.unknown_joints: set[str] = set()
        reliable = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
        self.estimate_pub = self.create_publisher(WearEstimate, str(p["estimate_topic"]), 10,
                                                  qos_overriding_options=overridable_qos())
        # health: one held status per joint in one updater, republished on a wall-clock timer (diagnostics keep
        # coming, not stale, even when /clock stops)
        self.health = Updater(self, "wear_estimator", topic=str(p["diagnostics_topic"]),
                              period=float(p["diagnostics_period"]))
        self.channels: dict[str, _Joint] = {}
        for j in self.joints:
            monitor = self.robot_monitor.monitors[j]
            held = HeldStatus(j, str({**p, **values[j]}["hardware_id"]) or j, DiagnosticLevel.OK,
                              "no test cycle estimated yet", self._idle_values(monitor.config))
            self.health.add(held)
            self.channels[j] = _Joint(j, monitor, held)
        self.create_subscription(FrictionObservation, str(p["observations_topic"]), self._on_observation, reliable,
                                 qos_overriding_options=overridable_qos())
        self.create_subscription(TestCycleStatus, str(p["status_topic"]), self._on_status, reliable,
                                 qos_overriding_options=overridable_qos())
        self.create_subscription(TestCycleStatus, str(p["production_status_topic"]), self._on_production_status,
                                 reliable, qos_overriding_options=overridable_qos())
        self.create_timer(float(p["diagnostics_period"]), self._on_timer, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.add_pre_set_parameters_callback(propagate_node_level(LIVE_PARAMETERS, self.joints))
        on_parameter_change(self, self._on_parameters,
                            LIVE_PARAMETERS + tuple(f"{j}.{n}" for j in self.joints for n in LIVE_PARAMETERS))
        for ch in self.channels.values():
            cfg = ch.monitor.config
            self.get_logger().info(
                f"estimating wear of {ch.name} with method {cfg.method!r} ({cfg.params}); "
                f"WARN at {cfg.warn_threshold:g}, ERROR at {cfg.alarm_threshold:g}; "
                f"measured temperature {'used' if cfg.use_measured_temperature else 'ignored'}"
            )
        self.health.update()
        # the estimates' numerical modules load beside the executor, not in it: a cell waits for this node's
        # subscriptions and its first status stamped on sim time before it starts a cycle, and for its estimate
        # after DONE; loaded in a callback (1.4 s of CPU on a 2-core EPYC with scipy.stats, which no estimate loads
        # now) they held both up
        threading.Thread(target=_warm_up, name="wear_estimator warm-up", daemon=True).start()

    @staticmethod
    def _idle_values(cfg: MonitorConfig) -> list[tuple[str, str]]:
        out = [("method", cfg.method), ("warn_threshold", f"{cfg.warn_threshold:g}"),
               ("alarm_threshold", f"{cfg.alarm_threshold:g}")]
        return out + _calibration_values(cfg.params)

    def _on_parameters(self, changes: dict[str, Any]) -> str | None:
        # a node-level change arrives with every joint's <joint>.<setting> (propagate_node_level);
        # every joint or none: all new configs are built first, a joint whose estimator cannot be
        # built refuses the change (naming the joint) and the joints already changed go back
        per_joint = split_per_joint(changes, self.joints)
        new: dict[str, MonitorConfig] = {}
        for j, mine in per_joint.items():
            if not mine:
                continue
            cfg = self.channels[j].monitor.config
            current = {n: getattr(cfg, n) for n in settings_of(type(cfg))}
            try:
                new[j] = monitor_config({**current, **mine}, j, type(cfg))
            except (JointwearError, ValueError, TypeError) as exc:
                return f"{j}: {exc}"
        done: list[tuple[_Joint, MonitorConfig]] = []
        try:
            for ch in (self.channels[j] for j in new):
                old = ch.monitor.config
                ch.monitor.reconfigure(new[ch.name])  # raises with the reason when unusable
                done.append((ch, old))
        except (JointwearError, ValueError, TypeError) as exc:
            failed = ch.name
            for back, old in done:
                back.monitor.reconfigure(old)
            return f"{failed}: {exc}"
        replaced = replaced_own_values(self, changes, self.joints)
        if replaced:
            self.get_logger().info(f"node-level change replaced joints' own values: {', '.join(replaced)}")
        for j in new:
            ch = self.channels[j]
            if not ch.results:
                ch.held.set(DiagnosticLevel.OK, "no test cycle estimated yet", self._idle_values(ch.monitor.config))
        if any(not self.channels[j].results for j in new):
            self.health.update()
        return None

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _ignore(self, what: str, joint: str) -> None:
        self.ignored_messages += 1
        self.unknown_joints.add(joint)
        self.get_logger().warning(
            f"{what} for joint {joint!r} ignored: this estimator serves {self.joints!r} (parameter joints); "
            f"{len(self.unknown_joints)} unknown joint(s) so far", throttle_duration_sec=5.0)

    def _served(self, what: str, joint: str) -> _Joint | None:
        """The joint a message naming ``joint`` is for (the robot monitor's routing); None, counted and logged,
        when this node does not serve it."""
        j = self.robot_monitor.route(joint)
        if j is None:
            self._ignore(what, joint)
            return None
        return self.channels[j]

    def _on_observation(self, msg: FrictionObservation) -> None:
        try:
            obs = observation_from_msg(msg)
        except (TypeError, ValueError, JointwearError) as exc:  # a source outside the vocabulary
            self.ignored_messages += 1
            self.get_logger().warning(f"FrictionObservation skipped: {exc}")
            return
        ch = self._served("FrictionObservation", obs.joint_name)
        if ch is None:
            return
        monitor = ch.monitor
        before, dropped = monitor.notes_total, monitor.rejected_count
        self._handle(self.robot_monitor.add(obs, self._now()) or [])
        notes = monitor.notes_since(before)
        for note in notes:
            self.get_logger().warning(f"{ch.name}: {note}")
        if monitor.rejected_count > dropped or (notes and "used as unknown" not in notes[-1]):
            self.ignored_messages += 1  # dropped (screening), a repeat, or beyond the cycle's speeds

    def _on_status(self, msg: TestCycleStatus, source: Source = Source.TEST_CYCLE) -> None:
        st = status_from_msg(msg)
        ch = self._served("TestCycleStatus" if source is Source.TEST_CYCLE else "production status", st.joint_name)
        if ch is None:
            return
        # timeouts run on this node's clock at receipt, whatever clock stamped the messages
        monitor = ch.monitor
        before = monitor.notes_total
        self._handle(self.robot_monitor.on_status(st, self._now(), source) or [])
        for note in monitor.notes_since(before):
            self.get_logger().warning(f"{ch.name}: {note}")

    def _on_production_status(self, msg: TestCycleStatus) -> None:
        self._on_status(msg, Source.PRODUCTION)

    def _on_timer(self) -> None:
        self._handle(self.robot_monitor.poll(self._now()))

    def _handle(self, results: list[CycleResult]) -> None:
        for r in results:
            ch = self.channels[r.joint_name]  # a monitor's results carry its joint's name
            self.results.append(r)
            ch.results.append(r)
            if r.result is not None:
                self.estimate_pub.publish(estimate_to_msg(r))
            if r is ch.monitor.last:  # a revision of an older cycle does not replace a newer cycle's status
                ch.held.set(r.level, r.message, r.values)
            self._log_result(r)
            self.health.update()

    def _log_result(self, r: CycleResult) -> None:
        # rclpy keys a logger's severity by call site: one line per severity, never one line that picks it
        text = f"{r.joint_name}: {r.level_name}: {r.message}"
        if r.level == DiagnosticLevel.ERROR:
            self.get_logger().error(text)
        elif r.level == DiagnosticLevel.WARN:
            self.get_logger().warning(text)
        else:
            self.get_logger().info(text)

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: let reliable subscribers (the recorder) get the last results."""
        wait_acked([self.estimate_pub, self.health.pub])


def _warm_up() -> None:
    """Load what an estimate imports on use (scipy.optimize, the joint estimator's and the production monitor's),
    once (a thread: an estimate that needs it first waits on the import lock). The temperature priors need no
    scipy.stats (:mod:`jointwear_ros.estimation.priors`)."""
    import scipy.optimize  # noqa: F401


def main(args: list[str] | None = None) -> int:
    """Console script ``wear_estimator``."""
    # the C++ EventsExecutor: its /clock subscription (sim time, 200 Hz of wall time in a demo) woke the Python
    # executor at every tick; with the priors' own laws its CPU in a six-joint demo is 5.6 s -> 2.7 s (stop 42)
    return run_node(WearEstimatorNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
