"""friction_observer: /joint_states + test-cycle status → one FrictionObservation per speed, per joint.

A thin rclpy adapter over :class:`~jointwear_ros.observer.RobotObserver` (the
same per-joint cores and routing the offline replay runs), one core per joint
it serves (``joints``; empty = the single joint ``joint_name``, see
docs/robot.md). Each ``sensor_msgs/JointState`` is split by name into the cores
(the name -> index lookup is cached while the names stay the same), each
``TestCycleStatus`` goes to the core of its ``joint_name`` (a robot cycle tests
its joints one after another under one cycle id) and each
``sensor_msgs/Temperature`` to the core of its ``header.frame_id`` (empty = the
joint of a one-joint setup). Finished
observations (they carry ``joint_name``) are published on
``/jointwear/friction_observations``; every rejected window is logged with its
reason. A bad JointState (none of the joints in it, array lengths that do not
match ``name``, no effort, NaN) is logged with the reason, counted and skipped
(a NaN only for its joint); a JointState without one of the joints is fed to
the others and counted for that joint (a fault while that joint is being
tested). A status, temperature or observation of a joint that is not served
is ignored, counted and logged (throttled): never a crash. Messages DDS
reports lost before reception (the publisher's history overflowed while this
node was stalled) are logged and counted per topic (``lost_messages``): the
observations of that stretch rest on fewer samples.

Diagnostics: one ``friction_observer: <joint>`` status per joint on
``/diagnostics`` (a task each of one :class:`~jointwear_ros.nodes.diagnostics.Updater`:
all joints in one ``DiagnosticArray``, on every change and every
``diagnostics_period``) with the counts (observations, rejected windows, bad and lost
messages, samples): WARN while that joint's current cycle has had a rejected
window, a lost or a bad message, with the latest reason as the message; OK
otherwise. The counts of "the current cycle" restart when a new cycle id of
that joint appears on the status topic. The robot observer keeps these counts
and decides the status (:meth:`~jointwear_ros.observer.RobotObserver.health_report`);
the node publishes it.

Run-time parameters: the observer settings (tolerances, ``min_samples``,
``gear_ratio``, ``torque_scale``, ...) are declared for every joint
(``<joint>.<setting>``, by default the node-level value) and can change
between cycles: ``<joint>.<setting>`` for that joint only, a node-level
``<setting>`` for every joint (it sets every ``<joint>.<setting>`` in the same
call, replacing a value a joint had of its own: set ``<joint>.<setting>``
again afterwards to keep that joint different; the replaced values are
logged). A change that would alter the settings of a joint while a speed of
that joint is being observed is refused with the reason (live and replayed
observations must use the same settings), as is a value a joint's settings
cannot take; nothing changes then. ``joints``, ``joint_name``, the topics and
the periods are read at start-up only (read-only parameters).

Parameters: see ``config/friction_observer.yaml`` and ``docs/nodes-observer-estimator.md``.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Mapping
from functools import partial
from typing import Any

from jointwear_msgs.msg import FrictionObservation, TestCycleStatus
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature

from .. import contract
from ..contract import observation_from_msg, stamp_to_seconds, status_from_msg
from ..errors import JointwearError
from ..observer import FrictionObservationData, ObserverConfig, RobotObserver
from ..observer.robot import Routed
from ..settings import from_mapping, node_declarations, settings_of
from .diagnostics import Status, Updater
from .joints import declare_robot, propagate_node_level, replaced_own_values, split_per_joint
from .runtime import (
    ParamDecl,
    on_parameter_change,
    overridable_qos,
    run_node,
    seconds_to_stamp,
    subscribe_reporting_loss,
    wait_acked,
)

__all__ = [
    "LIVE_PARAMETERS",
    "PARAMETERS",
    "PER_JOINT",
    "FrictionObserverNode",
    "main",
    "observation_from_msg",
    "observation_to_msg",
    "observer_config",
    "parameters",
    "seconds_to_stamp",
    "stamp_to_seconds",
]

#: the node's own settings (each joint's observer settings are ObserverConfig's fields, declared there)
_NODE_HEAD: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", ObserverConfig.joint_name,
              "joint observed when joints is empty (looked up by name in each JointState)", read_only=True),
)
_NODE_TAIL: tuple[ParamDecl, ...] = (
    ParamDecl("joint_states_topic", "/joint_states", "sensor_msgs/JointState input", read_only=True),
    ParamDecl("status_topic", "/test_cycle/status", "jointwear_msgs/TestCycleStatus input", read_only=True),
    ParamDecl("temperature_topic", "", "sensor_msgs/Temperature input (degC); empty = no temperature", read_only=True),
    ParamDecl("observations_topic", "/jointwear/friction_observations", "FrictionObservation output", read_only=True),
    ParamDecl("poll_period", 0.5, "s (wall) between checks for silent inputs", 0.01, 60.0, read_only=True),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True),
)


def parameters(config: type = ObserverConfig) -> tuple[ParamDecl, ...]:
    """Every parameter of the node: its own and the observer settings of ``config`` (its field metadata)."""
    return node_declarations(config, _NODE_HEAD, _NODE_TAIL).parameters


#: every parameter; those that can change at run time (between cycles); the settings each joint has of its own
#: (``<joint>.<setting>``, default: the node-level value)
PARAMETERS, LIVE_PARAMETERS, PER_JOINT = node_declarations(ObserverConfig, _NODE_HEAD, _NODE_TAIL)


def observer_config(values: Mapping[str, Any], joint: str, config: type = ObserverConfig) -> ObserverConfig:
    """Joint ``joint``'s observer settings from the node's parameter values (``<joint>.<setting>`` over the
    node-level ``<setting>``; :func:`jointwear_ros.settings.from_mapping`), checked."""
    cfg: ObserverConfig = from_mapping(config, values, joint=joint, joint_name=joint)
    return cfg


def observation_to_msg(o: FrictionObservationData) -> FrictionObservation:
    """The message of an observation (header stamp = ``o.stamp``): the contract's conversion."""
    return contract.observation_to_msg(o, FrictionObservation)


def high_rate_qos() -> QoSProfile:
    """RELIABLE, KEEP_LAST 1000: every sample of a 2 kHz stream reaches the observer."""
    return QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)


class FrictionObserverNode(Node):
    """The friction observer node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("friction_observer", **kwargs)
        p, self.joints, values = declare_robot(self, PARAMETERS, PER_JOINT)
        self.params = p
        #: one core per joint, the routing of the inputs to them (the same as replay's) and their health counts
        self.observer = RobotObserver({j: observer_config({**p, **values[j]}, j) for j in self.joints})
        self._last_rx = time.monotonic()
        qos = high_rate_qos()
        self.pub = self.create_publisher(FrictionObservation, str(p["observations_topic"]), qos,
                                         qos_overriding_options=overridable_qos())
        for msg_type, topic, cb in ((JointState, p["joint_states_topic"], self._on_joint_state),
                                    (TestCycleStatus, p["status_topic"], self._on_status),
                                    (Temperature, p["temperature_topic"], self._on_temperature)):
            if topic:
                subscribe_reporting_loss(self, msg_type, str(topic), cb, qos, self._lost_callback(str(topic)),
                                         qos_overriding_options=overridable_qos())
        # wall-clock timer: it must fire even when /clock (use_sim_time) stops
        self.create_timer(float(p["poll_period"]), self._on_poll, clock=Clock(clock_type=ClockType.STEADY_TIME))
        # health: one task per joint, all in one updater (republished every diagnostics_period, wall time)
        self.health = Updater(self, "friction_observer", period=float(p["diagnostics_period"]))
        for j in self.joints:
            self.health.add(j, partial(self._joint_health, j), hardware_id=j)
        self.health.update()
        self.add_pre_set_parameters_callback(propagate_node_level(PER_JOINT, self.joints))
        on_parameter_change(self, self._on_parameters,
                            LIVE_PARAMETERS + tuple(f"{j}.{n}" for j in self.joints for n in PER_JOINT))
        for j, core in self.observer.cores.items():
            cfg = core.config
            self.get_logger().info(
                f"observing {j} on {p['joint_states_topic']} (gear {cfg.gear_ratio:g}, torque scale "
                f"{cfg.torque_scale:g} N·m); status {p['status_topic']}; temperature "
                f"{p['temperature_topic'] or 'none'}; publishing {p['observations_topic']}"
            )

    # -- the robot observer's counts, read-only ----------------------------------------
    @property
    def bad_messages(self) -> Counter[str]:
        """Bad messages by kind (:attr:`RobotObserver.bad_messages`)."""
        return self.observer.bad_messages

    @property
    def lost_messages(self) -> Counter[str]:
        """Per topic, messages DDS reported lost before they reached this node."""
        return self.observer.lost_messages

    @property
    def ignored_messages(self) -> int:
        """Statuses and temperatures naming a joint this node does not serve (the names in ``unknown_joints``)."""
        return self.observer.ignored_messages

    @property
    def unknown_joints(self) -> set[str]:
        return self.observer.unknown_joints

    @property
    def rejections(self) -> list[str]:
        """The last rejected windows, every joint (``rejections_total`` counts them all)."""
        return self.observer.rejections

    @property
    def rejections_total(self) -> int:
        return self.observer.rejections_total

    # -- callbacks -----------------------------------------------------------------
    def _lost_callback(self, topic: str) -> Any:
        def cb(info: Any) -> None:
            # the events executor may repeat the event with total_count_change 0: counted from the total
            change = self.observer.lost(topic, int(info.total_count))
            if change <= 0:
                return
            self.get_logger().warning(
                f"{change} message(s) on {topic} lost before reaching the observer ({info.total_count} in all): "
                "the publisher's history overflowed while this node was stalled; observations of that "
                "stretch rest on fewer samples", throttle_duration_sec=2.0,
            )

        return cb

    def _bad(self, reason: str) -> None:
        """A bad JointState (counted by the robot observer): logged, throttled."""
        self.get_logger().warning(f"JointState skipped: {reason}", throttle_duration_sec=5.0)

    def _ignore(self, what: str, joint: str) -> None:
        """A message of a joint this node does not serve (counted by the robot observer): logged, throttled."""
        self.get_logger().warning(
            f"{what} for joint {joint!r} ignored: this observer serves {self.joints!r} (parameter joints); "
            f"{self.ignored_messages} such message(s) so far", throttle_duration_sec=5.0)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_joint_state(self, msg: JointState) -> None:
        stamp = stamp_to_seconds(msg.header.stamp)  # the clock is read only for a message without a stamp (2 kHz)
        js = self.observer.on_joint_state(stamp, msg.name, msg.position, msg.velocity, msg.effort,
                                          stamp if stamp > 0 else self._now())
        if js.new_names and 0 < len(js.missing) < len(self.joints):  # once per name list, not per message
            self.get_logger().warning(
                f"JointState names {list(msg.name)!r} lack joint(s) {list(js.missing)!r}: their samples "
                "are missing from these messages (counted as joint_missing; a fault while such a joint is tested)")
        if not js.used:
            self._bad(js.unusable)
            return
        for _, reason in js.skipped:
            self._bad(reason)
        self._last_rx = time.monotonic()
        for routed in js.outputs:
            self._emit(routed)

    def _on_status(self, msg: TestCycleStatus) -> None:
        self._last_rx = time.monotonic()
        st = status_from_msg(msg)
        routed = self.observer.on_status(st, self._now())
        if routed is None:
            self._ignore("TestCycleStatus", st.joint_name)
            return
        self._emit(routed)

    def _on_temperature(self, msg: Temperature) -> None:
        joint = str(msg.header.frame_id)
        routed = self.observer.on_temperature(stamp_to_seconds(msg.header.stamp), joint, float(msg.temperature),
                                              self._now())
        if routed is None:
            self._ignore("Temperature (header.frame_id names the joint)", joint)
            return
        self._emit(routed)

    def _on_poll(self) -> None:
        # Finished speeds are processed when a later-stamped message arrives; when the inputs fall
        # silent (end of a recording, a stopped driver) nothing will, so process them after poll_grace.
        for routed in self.observer.process_pending(time.monotonic() - self._last_rx):
            self._emit(routed)

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: let reliable subscribers get the last observations."""
        wait_acked([self.pub])

    @property
    def observations_published(self) -> int:
        """Observations published, every joint."""
        return self.observer.observations

    def _emit(self, routed: Routed) -> None:
        """A core's output (already counted by the robot observer): published and logged."""
        out = routed.output
        for o in out.observations:
            self.pub.publish(observation_to_msg(o))
            self.get_logger().info(
                f"{o.joint_name} cycle {o.cycle_id}: {o.speed:.1f} rad/s tau_f = {o.tau_f:.5f} ± {o.tau_f_std:.5f}, "
                f"tau_m = {o.load_torque:.4f}, samples {o.samples_plus}/{o.samples_minus}"
            )
        for r in out.rejections:
            self.get_logger().warning(f"{routed.joint}: window rejected: {r}")
        if routed.note:
            self.get_logger().warning(f"{routed.joint}: {routed.note}", throttle_duration_sec=5.0)
        if out.observations or out.rejections:
            self.health.update()

    # -- health and run-time parameters -----------------------------------------------
    def _joint_health(self, joint: str, stat: Status) -> None:
        """The ``friction_observer: <joint>`` status (a task of the updater, run at every update): the robot
        observer's report and this node's subscribers."""
        report = self.observer.health_report(joint)
        stat.extend([*report.values, ("observation_subscribers", str(self.pub.get_subscription_count()))])
        stat.summary(report.level, report.message)

    def health_of(self, joint: str) -> Status:
        """The ``friction_observer: <joint>`` status as of now (not published)."""
        stat = Status(f"{self.health.prefix}: {joint}", joint)
        self._joint_health(joint, stat)
        return stat

    def _on_parameters(self, changes: dict[str, Any]) -> str | None:
        # a node-level change arrives with every joint's <joint>.<setting> (propagate_node_level);
        # every joint or none: the new configs are built and the joints they change checked first
        new: dict[str, ObserverConfig] = {}
        for j, mine in split_per_joint(changes, self.joints).items():
            cfg = self.observer.cores[j].config
            if not mine:
                continue
            try:
                new[j] = observer_config({**{n: getattr(cfg, n) for n in settings_of(type(cfg))}, **mine}, j, type(cfg))
            except (JointwearError, ValueError, TypeError) as exc:
                return f"{j}: {exc}"
        for j, cfg in new.items():
            if cfg != self.observer.cores[j].config:
                why = self.observer.busy_reason(j)
                if why:
                    return why
        replaced = replaced_own_values(self, changes, self.joints)
        for j, cfg in new.items():
            self.observer.cores[j].reconfigure(cfg)
        if replaced:
            self.get_logger().info(f"node-level change replaced joints' own values: {', '.join(replaced)}")
        return None


def main(args: list[str] | None = None) -> int:
    """Console script ``friction_observer``."""
    # 2 kHz of JointState: the C++ events executor keeps the CPU use low (bench/bench_observer.py)
    return run_node(FrictionObserverNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
