"""cycle_on_demand: the dedicated test cycle asked for only when the production estimate cannot decide.

A thin rclpy adapter over :class:`~jointwear_ros.trend.OnDemandLedger` and
:class:`~jointwear_ros.trend.OnDemandPolicy` (docs/production-policy.md): it listens to

- ``jointwear_msgs/WearEstimate`` on ``estimate_topic``: a ``source: production`` estimate is a production
  shift's (NaN wear: that shift could not tell); a ``test_cycle`` one is the last dedicated cycle of its joint;
- ``jointwear_msgs/TestCycleStatus`` on ``production_status_topic``: a shift's DONE with ``speeds_total`` 0 for a
  joint is a shift in which the joint did not move at an informative speed (no estimate follows for it);
- ``jointwear_msgs/WearTrend`` on ``trend_topic``: the joint's forecast (the crossing reason).

After each production estimate or quiet shift of a joint the policy decides. The joints it asks for within
``gather_period`` wall seconds go out together (one dedicated cycle tests them all), each with its reason: as
one ``diagnostic_msgs/DiagnosticArray`` on ``request_topic`` (a status per asked joint, named
``cycle_on_demand: <joint>``, level OK: a request is not a condition, it never raises a joint's level), and with
``allow_service_call`` as a call to ``run_service`` (``/test_cycle/run`` with those joints; the answer is logged,
a refusal with its reason; a joint the cycle node does not drive is refused by it, nothing moves). The time the
policy counts nights in is the estimates' stamps, so a replayed cell decides as the live one did.

Parameters: the :class:`~jointwear_ros.trend.OnDemandConfig` settings (``max_quiet_shifts``,
``crossing_horizon_days``, ``min_interval_nights``, ``allow_service_call``; live), ``warn_threshold`` and
``alarm_threshold`` (the level rule's, as given to the wear_estimator), the topics and the service name (read
at start-up). See ``config/cycle_on_demand.yaml`` and docs/production-policy.md.
"""

from __future__ import annotations

import math
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from jointwear_msgs.msg import TestCycleStatus, WearEstimate, WearTrend
from jointwear_msgs.srv import RunTestCycle
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..condition import ALARM, WARN, Forecast
from ..contract import CycleState, DiagnosticLevel, Source, source_of, stamp_to_seconds
from ..errors import JointwearError
from ..settings import declarations, from_mapping
from ..trend import Decision, OnDemandConfig, OnDemandLedger, OnDemandPolicy
from .diagnostics import diagnostic_status
from .runtime import ParamDecl, declare_parameters, on_parameter_change, overridable_qos, run_node

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "CycleOnDemandNode", "main"]

PARAMETERS: tuple[ParamDecl, ...] = (
    *declarations(OnDemandConfig),  # the policy's settings, declared in OnDemandConfig (jointwear_ros.trend)
    ParamDecl("warn_threshold", WARN, "wear of WARN (the level rule's, as the wear_estimator has it)", 0.0, 100.0),
    ParamDecl("alarm_threshold", ALARM, "wear of ERROR (the level rule's, as the wear_estimator has it)", 0.0, 100.0),
    ParamDecl("gather_period", 1.0, "wall s the joints asked for are gathered into one request", 0.0, 600.0,
              read_only=True),
    ParamDecl("estimate_topic", "/jointwear/wear_estimate", "WearEstimate input (both sources)", read_only=True),
    ParamDecl("production_status_topic", "/production/status", "the production shifts' TestCycleStatus input",
              read_only=True),
    ParamDecl("trend_topic", "/jointwear/wear_trend", "WearTrend input (the forecast)", read_only=True),
    ParamDecl("request_topic", "/jointwear/cycle_request", "DiagnosticArray output: the joints asked for and why",
              read_only=True),
    ParamDecl("run_service", "/test_cycle/run", "the test cycle's RunTestCycle service (with allow_service_call)",
              read_only=True),
)
#: the states of ``WearTrend.forecast`` (another value is read as no trend)
FORECAST_STATES = ("at_alarm", "within_horizon", "beyond_horizon", "no_growth", "no_trend")
LIVE_PARAMETERS = tuple(d.name for d in PARAMETERS if not d.read_only)


def _policy(p: dict[str, Any]) -> OnDemandPolicy:
    return OnDemandPolicy(from_mapping(OnDemandConfig, p), warn=float(p["warn_threshold"]),
                          alarm=float(p["alarm_threshold"]))


class CycleOnDemandNode(Node):
    """The test cycle on demand (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("cycle_on_demand", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.params = p
        self.ledger = OnDemandLedger(_policy(p))
        self.pending: dict[str, Decision] = {}
        self.requests = 0
        self.calls: list[str] = []  # the answers of the service calls made, newest last (bounded)
        self._future: Any = None
        self._future_joints: list[str] = []
        reliable = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
        latched = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.request_pub = self.create_publisher(DiagnosticArray, str(p["request_topic"]), latched,
                                                 qos_overriding_options=overridable_qos())
        self.create_subscription(WearEstimate, str(p["estimate_topic"]), self._on_estimate, reliable)
        self.create_subscription(TestCycleStatus, str(p["production_status_topic"]), self._on_status, reliable)
        self.create_subscription(WearTrend, str(p["trend_topic"]), self._on_trend, latched)
        self.run_client = self.create_client(RunTestCycle, str(p["run_service"]))
        self.create_timer(max(float(p["gather_period"]), 0.05), self._flush,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        on_parameter_change(self, self._on_parameters, LIVE_PARAMETERS)
        cfg = self.ledger.policy.config
        self.get_logger().info(
            f"cycle_on_demand: asks for the dedicated test cycle when a production estimate straddles "
            f"{self.ledger.policy.warn:g}/{self.ledger.policy.alarm:g}, after {cfg.max_quiet_shifts} quiet shifts or a "
            f"crossing within {cfg.crossing_horizon_days:g} days; "
            + (f"calls {p['run_service']}" if cfg.allow_service_call else f"publishes the request on {p['request_topic']}"))

    # -- inputs --------------------------------------------------------------------------------------------
    def _on_estimate(self, msg: Any) -> None:
        try:
            source = source_of(getattr(msg, "source", ""))
            stamp = stamp_to_seconds(msg.header.stamp)
            joint = str(msg.joint_name)
            if source == Source.TEST_CYCLE:
                self.ledger.test_cycle_estimate(joint, float(msg.wear), float(msg.wear_std), stamp=stamp)
                self.pending.pop(joint, None)  # a cycle ran for it: what was gathered is answered
                return
            self._decided(self.ledger.production_estimate(joint, float(msg.wear), float(msg.wear_std), stamp=stamp))
        except JointwearError as exc:
            self.get_logger().warning(f"estimate ignored: {exc}", throttle_duration_sec=10.0)

    def _on_status(self, msg: Any) -> None:
        if int(msg.state) != CycleState.DONE or int(msg.speeds_total) != 0 or not msg.joint_name:
            return  # a shift with observations of the joint: its estimate decides
        try:
            self._decided(self.ledger.quiet_shift(str(msg.joint_name), stamp=stamp_to_seconds(msg.header.stamp)))
        except JointwearError as exc:
            self.get_logger().warning(f"production status ignored: {exc}", throttle_duration_sec=10.0)

    def _on_trend(self, msg: Any) -> None:
        def num(x: float) -> float | None:
            return float(x) if math.isfinite(float(x)) else None

        state = str(msg.forecast) if str(msg.forecast) in FORECAST_STATES else "no_trend"
        fc = Forecast(bool(msg.alarm_expected), float(msg.horizon_days), num(msg.time_to_alarm_median),
                      num(msg.time_to_alarm_lo90), num(msg.time_to_alarm_hi90), state)
        try:
            self.ledger.forecast(str(msg.joint_name), fc)
        except JointwearError as exc:
            self.get_logger().warning(f"trend ignored: {exc}", throttle_duration_sec=10.0)

    def _decided(self, d: Decision) -> None:
        if d.ask:
            self.pending[d.joint] = d
            self.get_logger().info(f"asks for the test cycle: {d.reason}")
        else:
            self.get_logger().debug(d.reason)

    # -- outputs -------------------------------------------------------------------------------------------
    def _flush(self) -> None:
        if not self.pending or self._future is not None:
            return
        asked = [self.pending[j] for j in sorted(self.pending)]
        self.pending.clear()
        self.requests += 1
        cfg = self.ledger.policy.config
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [diagnostic_status(f"cycle_on_demand: {d.joint}", d.joint, DiagnosticLevel.OK, d.reason,
                                        (("kind", d.kind), ("request", str(self.requests)),
                                         ("service_call", str(cfg.allow_service_call).lower())))
                      for d in asked]
        self.request_pub.publish(arr)
        if not cfg.allow_service_call:
            return
        joints = [d.joint for d in asked]
        if not self.run_client.service_is_ready():
            self._answer(joints, f"{self.params['run_service']} is not available: the request stands on "
                                 f"{self.params['request_topic']}")
            return
        self._future = self.run_client.call_async(RunTestCycle.Request(joints=joints))
        self._future_joints = joints
        self._future.add_done_callback(self._on_answer)

    def _on_answer(self, future: Any) -> None:
        joints, self._future, self._future_joints = self._future_joints, None, []
        try:
            r = future.result()
        except Exception as exc:  # the service went away mid-call
            self._answer(joints, f"no answer: {exc}")
            return
        if r.accepted:
            self._answer(joints, f"accepted as cycle {r.cycle_id}")
        else:
            self._answer(joints, f"refused (reason {int(r.reason)}): {r.message}")

    def _answer(self, joints: list[str], text: str) -> None:
        line = f"test cycle for {', '.join(joints)}: {text}"
        self.calls.append(line)
        del self.calls[:-100]
        self.get_logger().info(line)

    def _on_parameters(self, changes: dict[str, Any]) -> str | None:
        p = {**self.params, **changes}
        try:
            policy = _policy(p)
        except JointwearError as exc:
            return str(exc)
        self.params = p
        self.ledger.policy = policy
        return None


def main(args: list[str] | None = None) -> int:
    """Console script ``cycle_on_demand``."""
    # rclpy's C++ EventsExecutor: on sim time its /clock subscription woke the Python executor at every tick of
    # a played bag (its timer runs on the steady clock)
    return run_node(CycleOnDemandNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
