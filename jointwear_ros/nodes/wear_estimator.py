"""wear_estimator: FrictionObservation per cycle → WearEstimate and /diagnostics.

A thin rclpy adapter over :class:`~jointwear_ros.monitor.WearMonitor` (the
same core the offline replay runs). It gathers observations per cycle id,
estimates a cycle's wear when all its speeds are in or ``done_timeout`` after
its DONE status, publishes a ``jointwear_msgs/WearEstimate`` and a
``diagnostic_msgs/DiagnosticArray`` with one status named
``wear_estimator: <joint>``: level OK below ``warn_threshold``, WARN in
``[warn_threshold, alarm_threshold)``, ERROR at ``w_hat >= alarm_threshold``;
key/values wear, wear_std, method, cycle_id, temperature_estimate,
n_observations. The last status is republished every ``diagnostics_period``
so aggregators do not mark it stale.

Parameters: see ``config/wear_estimator.yaml`` and ``docs/nodes-observer-estimator.md``.
"""

from __future__ import annotations

import json
import math
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..errors import InputDataError
from ..monitor import OK, CycleResult, MonitorConfig, WearMonitor
from .friction_observer import observation_from_msg, seconds_to_stamp
from .runtime import ParamDecl, declare_parameters, run_node

__all__ = ["WearEstimatorNode", "diagnostic_status", "estimate_to_msg", "main"]

_D = MonitorConfig()

PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", _D.joint_name, "joint whose wear is estimated"),
    ParamDecl("hardware_id", "", "DiagnosticStatus.hardware_id (empty = the joint name)"),
    ParamDecl("method", _D.method, "estimator: paper, paper-grid, bayes, joint"),
    ParamDecl("params", _D.params, "friction-model parameter set"),
    ParamDecl("seed", _D.seed, "base seed; each cycle's seed derives from it and the cycle id"),
    ParamDecl("estimator_options", "", "JSON object of extra estimator options, e.g. {\"n_samples\": 200}"),
    ParamDecl("warn_threshold", _D.warn_threshold, "wear at which the level becomes WARN", 0.0, 100.0),
    ParamDecl("alarm_threshold", _D.alarm_threshold, "wear at which the level becomes ERROR (alarm)", 0.0, 100.0),
    ParamDecl("use_measured_temperature", _D.use_measured_temperature,
              "use the observations' temperature when present; else T is unknown (Eq. 11)"),
    ParamDecl("done_timeout", _D.done_timeout, "s after DONE before a cycle with missing speeds is estimated", 0.0, 600.0),
    ParamDecl("idle_timeout", _D.idle_timeout, "s after the last observation of a cycle without status", 0.0, 3600.0),
    ParamDecl("min_observations", _D.min_observations, "observations needed for an estimate"),
    ParamDecl("observation_noise_std", _D.observation_noise_std,
              "sweep-to-sweep scatter of tau_f added to each observation's window standard error", 0.0, 1.0),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications", 0.01, 60.0),
    ParamDecl("observations_topic", "/jointwear/friction_observations", "FrictionObservation input"),
    ParamDecl("status_topic", "/test_cycle/status", "TestCycleStatus input"),
    ParamDecl("estimate_topic", "/jointwear/wear_estimate", "WearEstimate output"),
    ParamDecl("diagnostics_topic", "/diagnostics", "DiagnosticArray output"),
)


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
    m.alarm = bool(res.wear >= r.alarm_threshold)
    return m


def diagnostic_status(name: str, hardware_id: str, level: int, message: str,
                      values: tuple[tuple[str, str], ...] | list[tuple[str, str]]) -> DiagnosticStatus:
    """A DiagnosticStatus (level as the message's byte value)."""
    s = DiagnosticStatus()
    s.level = bytes([int(level)])
    s.name = name
    s.hardware_id = hardware_id
    s.message = message
    s.values = [KeyValue(key=k, value=v) for k, v in values]
    return s


class WearEstimatorNode(Node):
    """The wear estimator node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wear_estimator", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.params = p
        options: dict[str, Any] = {}
        if p["estimator_options"]:
            try:
                options = dict(json.loads(str(p["estimator_options"])))
            except (ValueError, TypeError) as exc:
                raise InputDataError(
                    f"parameter estimator_options = {p['estimator_options']!r} is not a JSON object: {exc}"
                ) from None
        cfg = MonitorConfig.from_mapping(dict(p, estimator_options=options))
        self.monitor = WearMonitor(cfg)
        self.joint_name = cfg.joint_name
        self.status_name = f"wear_estimator: {self.joint_name}"
        self.hardware_id = str(p["hardware_id"]) or self.joint_name
        self.results: list[CycleResult] = []
        self.ignored_messages = 0
        self._status = diagnostic_status(
            self.status_name, self.hardware_id, OK, "no test cycle estimated yet",
            [("method", cfg.method), ("warn_threshold", f"{cfg.warn_threshold:g}"),
             ("alarm_threshold", f"{cfg.alarm_threshold:g}")],
        )
        reliable = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
        self.estimate_pub = self.create_publisher(WearEstimate, str(p["estimate_topic"]), 10)
        self.diag_pub = self.create_publisher(DiagnosticArray, str(p["diagnostics_topic"]), 10)
        self.create_subscription(FrictionObservation, str(p["observations_topic"]), self._on_observation, reliable)
        self.create_subscription(TestCycleStatus, str(p["status_topic"]), self._on_status, reliable)
        # wall-clock timer: diagnostics keep coming (not stale) even when /clock (use_sim_time) stops
        self.create_timer(float(p["diagnostics_period"]), self._on_timer, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(
            f"estimating wear of {self.joint_name} with method {cfg.method!r} ({cfg.params}); "
            f"WARN at {cfg.warn_threshold:g}, ERROR at {cfg.alarm_threshold:g}; "
            f"measured temperature {'used' if cfg.use_measured_temperature else 'ignored'}"
        )
        self._publish_diagnostics()

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_observation(self, msg: FrictionObservation) -> None:
        try:
            obs = observation_from_msg(msg)
        except (TypeError, ValueError) as exc:  # pragma: no cover - typed message fields
            self.ignored_messages += 1
            self.get_logger().warning(f"FrictionObservation skipped: {exc}")
            return
        n_ignored = len(self.monitor.ignored)
        self._handle(self.monitor.add(obs, now=self._now()))
        if len(self.monitor.ignored) > n_ignored:
            self.ignored_messages += 1
            self.get_logger().warning(self.monitor.ignored[-1])

    def _on_status(self, msg: TestCycleStatus) -> None:
        # timeouts run on this node's clock at receipt, whatever clock stamped the messages
        n_ignored = len(self.monitor.ignored)
        self._handle(self.monitor.on_status(self._now(), int(msg.cycle_id), int(msg.state), int(msg.speeds_done),
                                            int(msg.speeds_total), str(msg.joint_name)))
        for note in self.monitor.ignored[n_ignored:]:
            self.get_logger().warning(note)

    def _on_timer(self) -> None:
        self._handle(self.monitor.poll(self._now()))
        self._publish_diagnostics()

    def _handle(self, results: list[CycleResult]) -> None:
        for r in results:
            self.results.append(r)
            if r.result is not None:
                self.estimate_pub.publish(estimate_to_msg(r))
            if r is self.monitor.last:  # a revision of an older cycle does not replace a newer cycle's status
                self._status = diagnostic_status(self.status_name, self.hardware_id, r.level, r.message, r.values)
            log = self.get_logger()
            (log.info if r.level == OK else log.warning if r.level == 1 else log.error)(
                f"{self.joint_name}: {r.level_name}: {r.message}"
            )
            self._publish_diagnostics()

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: let reliable subscribers (the recorder) get the last results."""
        for pub in (self.estimate_pub, self.diag_pub):
            try:
                pub.wait_for_all_acked(Duration(seconds=0.5))
            except Exception:  # pragma: no cover - best effort on the way out
                pass

    def _publish_diagnostics(self) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [self._status]
        self.diag_pub.publish(arr)


def main(args: list[str] | None = None) -> int:
    """Console script ``wear_estimator``."""
    return run_node(WearEstimatorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
