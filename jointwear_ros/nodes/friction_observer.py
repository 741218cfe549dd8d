"""friction_observer: /joint_states + test-cycle status → one FrictionObservation per speed.

A thin rclpy adapter over :class:`~jointwear_ros.observer.FrictionObserverCore`
(the same core the offline replay runs). It picks the joint by name from each
``sensor_msgs/JointState``, feeds its position, velocity and effort with the
header stamp, feeds ``TestCycleStatus`` and (optionally) ``sensor_msgs/Temperature``,
publishes each finished observation on ``/jointwear/friction_observations`` and
logs every rejected window with its reason. A bad JointState (joint missing,
array lengths that do not match ``name``, no effort, NaN) is logged with the
reason, counted and skipped. Messages DDS reports lost before reception (the
publisher's history overflowed while this node was stalled) are logged and
counted per topic (``lost_messages``): the observations of that stretch rest on
fewer samples.

Diagnostics: ``friction_observer: <joint>`` on ``/diagnostics`` with the
counts (observations, rejected windows, bad and lost messages, samples): WARN
while the current cycle has had a rejected window, a lost or a bad message,
with the latest reason as the message; OK otherwise. The counts of "the
current cycle" restart when a new cycle id appears on the status topic.

Run-time parameters: the observer settings (tolerances, ``min_samples``,
``gear_ratio``, ...) can change between cycles; while a speed is being
observed a change is refused with the reason (live and replayed
observations must use the same settings). ``joint_name``, the topics and
the periods are read at start-up only (read-only parameters).

Parameters: see ``config/friction_observer.yaml`` and ``docs/nodes-observer-estimator.md``.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from typing import Any

from jointwear_msgs.msg import FrictionObservation, TestCycleStatus
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature

from .. import contract
from ..contract import observation_from_msg, stamp_to_seconds
from ..observer import FrictionObservationData, FrictionObserverCore, ObserverConfig, ObserverOutput
from .diagnostics import OK, WARN, NodeDiagnostics, Report
from .runtime import (
    ParamDecl,
    declare_parameters,
    on_parameter_change,
    overridable_qos,
    run_node,
    seconds_to_stamp,
    subscribe_reporting_loss,
)

__all__ = [
    "FrictionObserverNode",
    "main",
    "observation_from_msg",
    "observation_to_msg",
    "seconds_to_stamp",
    "stamp_to_seconds",
]

_DEFAULTS = ObserverConfig()

PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", _DEFAULTS.joint_name, "joint observed (looked up by name in each JointState)",
              read_only=True),
    ParamDecl("gear_ratio", _DEFAULTS.gear_ratio, "motor speed = joint speed x gear_ratio", 1e-6, 1e6),
    ParamDecl("torque_scale", _DEFAULTS.torque_scale, "N·m (joint side) per normalized torque unit", 1e-9, 1e9),
    ParamDecl("joint_states_topic", "/joint_states", "sensor_msgs/JointState input", read_only=True),
    ParamDecl("status_topic", "/test_cycle/status", "jointwear_msgs/TestCycleStatus input", read_only=True),
    ParamDecl("temperature_topic", "", "sensor_msgs/Temperature input (degC); empty = no temperature", read_only=True),
    ParamDecl("observations_topic", "/jointwear/friction_observations", "FrictionObservation output", read_only=True),
    ParamDecl("speed_tolerance", _DEFAULTS.speed_tolerance, "at speed: |v - v_cmd| <= this x v_cmd", 1e-6, 10.0),
    ParamDecl("speed_tolerance_min", _DEFAULTS.speed_tolerance_min, "floor of that tolerance, rad/s motor", 0.0, 1e6),
    ParamDecl("max_speed_std", _DEFAULTS.max_speed_std, "speed std limit over the at-speed samples, x v_cmd", 1e-6, 10.0),
    ParamDecl("max_speed_std_min", _DEFAULTS.max_speed_std_min, "floor of that limit, rad/s motor", 0.0, 1e6),
    ParamDecl("min_constant_fraction", _DEFAULTS.min_constant_fraction,
              "fraction of the moving window samples that must be at speed", 0.0, 1.0),
    ParamDecl("min_samples", _DEFAULTS.min_samples, "at-speed samples needed per direction"),
    ParamDecl("edge_trim", _DEFAULTS.edge_trim, "fraction of the half width trimmed off each window edge", 0.0, 0.99),
    ParamDecl("pass_gap", _DEFAULTS.pass_gap, "s without samples that separates two passes through the window",
              1e-4, 10.0),
    ParamDecl("n_batches", _DEFAULTS.n_batches, "batches of the batch-means standard error"),
    ParamDecl("reorder_margin", _DEFAULTS.reorder_margin, "s the inputs may be out of stamp order", 0.0, 60.0),
    ParamDecl("poll_grace", _DEFAULTS.poll_grace, "s of silence on every input after which finished speeds are processed",
              0.0, 60.0),
    ParamDecl("max_buffer_seconds", _DEFAULTS.max_buffer_seconds, "s of joint states kept at most", 1.0, 3600.0),
    ParamDecl("poll_period", 0.5, "s (wall) between checks for silent inputs", 0.01, 60.0, read_only=True),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True),
)
#: Parameters that can change at run time (between cycles)
LIVE_PARAMETERS = tuple(d.name for d in PARAMETERS if not d.read_only)


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
        p = declare_parameters(self, PARAMETERS)
        self.params = p
        self.core = FrictionObserverCore(ObserverConfig.from_mapping(p))
        self.joint_name: str = str(p["joint_name"])
        self.bad_messages: Counter[str] = Counter()
        #: per topic, messages DDS reported lost before they reached this node
        self.lost_messages: Counter[str] = Counter()
        self.observations_published = 0
        #: the last 1000 rejected windows (reasons); ``rejections_total`` counts them all
        self.rejections: list[str] = []
        self.rejections_total = 0
        # what happened during the current cycle (the diagnostics' WARN reasons)
        self._cycle_id = 0
        self._cycle_marks = (0, 0, 0)  # rejections, bad, lost at its start
        self._last_problem = ""
        self._index_cache: tuple[tuple[str, ...], int] | None = None
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
        self.diag = NodeDiagnostics(self, f"friction_observer: {self.joint_name}", self.joint_name,
                                    period=float(p["diagnostics_period"]), refresh=self._report)
        self.diag.update(*self._report())
        on_parameter_change(self, self._on_parameters, LIVE_PARAMETERS)
        self.get_logger().info(
            f"observing {self.joint_name} on {p['joint_states_topic']} (gear {p['gear_ratio']:g}, torque scale "
            f"{p['torque_scale']:g} N·m); status {p['status_topic']}; temperature "
            f"{p['temperature_topic'] or 'none'}; publishing {p['observations_topic']}"
        )

    # -- callbacks -----------------------------------------------------------------
    def _lost_callback(self, topic: str) -> Any:
        def cb(info: Any) -> None:
            # the events executor may repeat the event with total_count_change 0: count from the total
            change = int(info.total_count) - self.lost_messages[topic]
            if change <= 0:
                return
            self.lost_messages[topic] += change
            self._last_problem = f"{change} message(s) lost on {topic}"
            self.get_logger().warning(
                f"{change} message(s) on {topic} lost before reaching the observer ({info.total_count} in all): "
                "the publisher's history overflowed while this node was stalled; observations of that "
                "stretch rest on fewer samples", throttle_duration_sec=2.0,
            )

        return cb

    def _stamp(self, header_stamp: Any) -> float:
        t = stamp_to_seconds(header_stamp)
        if t > 0:
            return t
        return self.get_clock().now().nanoseconds * 1e-9

    def _bad(self, reason: str) -> None:
        self.bad_messages[reason.split(":")[0]] += 1
        self._last_problem = f"bad JointState: {reason}"
        self.get_logger().warning(f"JointState skipped: {reason}", throttle_duration_sec=5.0)

    def _on_joint_state(self, msg: JointState) -> None:
        names = msg.name
        cache = self._index_cache
        if cache is not None and len(names) > cache[1] and names[cache[1]] == self.joint_name:
            i = cache[1]
        else:
            try:
                i = list(names).index(self.joint_name)
            except ValueError:
                self._bad(f"joint {self.joint_name!r} not in name {list(names)!r}; set joint_name")
                return
            self._index_cache = (tuple(names), i)
        n = len(names)
        pos, vel, eff = msg.position, msg.velocity, msg.effort
        if len(eff) == 0:
            self._bad("no effort: the observer needs the applied torque in JointState.effort")
            return
        if len(pos) != n or len(vel) != n or len(eff) != n:
            self._bad(f"array lengths: name {n}, position {len(pos)}, velocity {len(vel)}, effort {len(eff)}; "
                      "each must match name")
            return
        p, v, e = float(pos[i]), float(vel[i]), float(eff[i])
        if not (math.isfinite(p) and math.isfinite(v) and math.isfinite(e)):
            self._bad(f"non-finite value for {self.joint_name}: position {p}, velocity {v}, effort {e}")
            return
        self._last_rx = time.monotonic()
        out = self.core.on_joint_state(self._stamp(msg.header.stamp), p, v, e)
        if out.observations or out.rejections:
            self._emit(out)

    def _on_status(self, msg: TestCycleStatus) -> None:
        self._last_rx = time.monotonic()
        if int(msg.cycle_id) != self._cycle_id and int(msg.cycle_id) > 0 and msg.joint_name in ("", self.joint_name):
            self._cycle_id = int(msg.cycle_id)
            self._cycle_marks = self._counts()
            self._last_problem = ""
        out = self.core.on_status(
            self._stamp(msg.header.stamp), int(msg.cycle_id), int(msg.state), int(msg.phase),
            float(msg.current_speed), int(msg.speeds_done), int(msg.speeds_total), float(msg.window_center),
            float(msg.window_half_width), str(msg.joint_name),
        )
        self._emit(out)

    def _on_temperature(self, msg: Temperature) -> None:
        self._emit(self.core.on_temperature(self._stamp(msg.header.stamp), float(msg.temperature)))

    def _on_poll(self) -> None:
        # Finished speeds are processed when a later-stamped message arrives; when the inputs fall
        # silent (end of a recording, a stopped driver) nothing will, so process them after poll_grace.
        if self.core.pending_segments and time.monotonic() - self._last_rx > self.core.config.poll_grace:
            self._emit(self.core.process_pending())

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: let reliable subscribers get the last observations."""
        try:
            self.pub.wait_for_all_acked(Duration(seconds=0.5))
        except Exception:  # pragma: no cover - best effort on the way out
            pass

    def _emit(self, out: ObserverOutput) -> None:
        for o in out.observations:
            self.pub.publish(observation_to_msg(o))
            self.observations_published += 1
            self.get_logger().info(
                f"cycle {o.cycle_id}: {o.speed:.1f} rad/s tau_f = {o.tau_f:.5f} ± {o.tau_f_std:.5f}, "
                f"tau_m = {o.load_torque:.4f}, samples {o.samples_plus}/{o.samples_minus}"
            )
        for r in out.rejections:
            self.rejections.append(str(r))
            self.rejections_total += 1
            if len(self.rejections) > 1000:
                del self.rejections[:-1000]
            self._last_problem = f"window rejected: {r}"
            self.get_logger().warning(f"window rejected: {r}")
        if out.observations or out.rejections:
            self.diag.update(*self._report())

    # -- health and run-time parameters -----------------------------------------------
    def _counts(self) -> tuple[int, int, int]:
        bad = sum(self.bad_messages.values()) + self.core.temperatures_skipped
        return self.rejections_total, bad, sum(self.lost_messages.values())

    def _report(self) -> Report:
        rej, bad, lost = self._counts()
        r0, b0, l0 = self._cycle_marks
        values = [("cycle_id", str(self._cycle_id)), ("observations", str(self.observations_published)),
                  ("rejected_windows", str(rej)), ("bad_messages", str(bad)), ("lost_messages", str(lost)),
                  ("rejected_windows_this_cycle", str(rej - r0)), ("lost_messages_this_cycle", str(lost - l0)),
                  ("samples_seen", str(self.core.samples_seen)), ("samples_skipped", str(self.core.samples_skipped)),
                  ("temperatures_skipped", str(self.core.temperatures_skipped)),
                  ("buffered_samples", str(self.core.buffered_samples))]
        if (rej - r0, bad - b0, lost - l0) != (0, 0, 0):
            text = (f"cycle {self._cycle_id}: {rej - r0} window(s) rejected, {bad - b0} bad and {lost - l0} lost "
                    f"message(s); latest: {self._last_problem}")
            return WARN, text, values
        return OK, f"{self.observations_published} observation(s), {rej} window(s) rejected in all", values

    def _on_parameters(self, changes: dict[str, Any]) -> str | None:
        cfg = self.core.config
        current = {f: getattr(cfg, f) for f in cfg.__dataclass_fields__}
        self.core.reconfigure(ObserverConfig.from_mapping(dict(current, **changes)))
        return None


def main(args: list[str] | None = None) -> int:
    """Console script ``friction_observer``."""
    # 2 kHz of JointState: the C++ events executor keeps the CPU use low (bench/bench_observer.py)
    return run_node(FrictionObserverNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
