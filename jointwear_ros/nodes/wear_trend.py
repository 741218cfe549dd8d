"""wear_trend: WearEstimate → wear history store → trend, time to alarm, /diagnostics.

A thin rclpy adapter over :class:`~jointwear_ros.history.HistoryStore` and the
pure trend core :func:`~jointwear_ros.trend.analyze_joint`. Every
``jointwear_msgs/WearEstimate`` on ``estimate_topic`` is appended to the store
(``db_url``: an SQLite file by default, or ``postgresql://...``) in its own
transaction *before* anything is published about it, so what the node has
reported is durable even when it is killed (SIGKILL) right after; a repeated
estimate (same robot, joint, cycle id and stamp: a bag played again, a
restarted node) is stored once. Then the joint's trend is recomputed from the
store and published:

- ``jointwear_msgs/WearTrend`` on ``trend_topic`` (wear, rate, time to alarm
  median and 90 % interval, level);
- ``/diagnostics``: one status per joint named ``wear_trend: <joint>``, OK /
  WARN when growth is detected and the 90 % interval's lower bound of the
  time to alarm is within ``horizon_days`` / ERROR when the current wear is at
  or above ``alarm_threshold``; republished every ``diagnostics_period``.

On start the node reloads the robot's history from the store and publishes
the trend of every joint it holds, so a restart loses nothing. The service
``~/record_maintenance`` (``jointwear_msgs/srv/RecordMaintenance``) records a
maintenance event (regrease, reducer replaced): the joint's trend starts a new
segment. A malformed estimate (NaN, std <= 0) is rejected with the reason,
logged and counted (``rejected`` in the diagnostics); the node keeps running.

Parameters: see ``config/wear_trend.yaml`` and ``docs/history-trend.md``.
"""

from __future__ import annotations

import math
from typing import Any

from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from jointwear_msgs.msg import WearEstimate, WearTrend
from jointwear_msgs.srv import RecordMaintenance
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .. import __version__
from ..contract import stamp_to_seconds
from ..errors import JointwearError
from ..history import LIVE, EstimateRecord, HistoryStore, MaintenanceEvent
from ..trend import ERROR, OK, WARN, TrendConfig, TrendResult, analyze_joint
from .diagnostics import diagnostic_status
from .runtime import ParamDecl, declare_parameters, overridable_qos, run_node

__all__ = ["PARAMETERS", "WearTrendNode", "main", "trend_to_msg"]

_T = TrendConfig()

PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("robot", "robot_1", "robot name the estimates belong to (WearEstimate has none)"),
    ParamDecl("db_url", "wear_history.db", "history store: a file path or sqlite:///path (SQLite, WAL), "
              "or postgresql://user@host/db"),
    ParamDecl("hardware_id", "", "DiagnosticStatus.hardware_id and stored hardware id (empty = robot/joint)"),
    ParamDecl("params", "ref-2011r", "friction-model parameter set the estimates were made with (stored)"),
    ParamDecl("alarm_threshold", _T.alarm, "wear at which the level is ERROR", 0.0, 100.0),
    ParamDecl("horizon_days", _T.horizon_days, "WARN when the 90 % interval's lower bound of the time to alarm "
              "is within this many days", 0.0, 3650.0),
    ParamDecl("min_estimates", _T.min_estimates, "estimates a segment needs before it has a trend"),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications", 0.01, 60.0),
    ParamDecl("estimate_topic", "/jointwear/wear_estimate", "WearEstimate input"),
    ParamDecl("trend_topic", "/jointwear/wear_trend", "WearTrend output (one message per joint and update)"),
    ParamDecl("diagnostics_topic", "/diagnostics", "DiagnosticArray output"),
)


def trend_to_msg(r: TrendResult, stamp: TimeMsg, horizon_days: float, alarm: float) -> WearTrend:
    """The WearTrend message of a trend result."""
    m = WearTrend()
    m.header.stamp = stamp
    m.robot = r.robot
    m.joint_name = r.joint
    m.estimates = int(r.estimates)
    m.estimates_total = int(r.estimates_total)
    m.wear, m.wear_std = float(r.wear), float(r.wear_std)
    m.rate_per_day, m.rate_std_per_day = float(r.rate_per_day), float(r.rate_std)
    tta = r.time_to_alarm
    m.time_to_alarm_median = math.nan if tta is None else float(tta.median)
    m.time_to_alarm_lo90 = math.nan if tta is None else float(tta.lo90)
    m.time_to_alarm_hi90 = math.nan if tta is None else float(tta.hi90)
    m.alarm_threshold = float(alarm)
    m.horizon_days = float(horizon_days)
    m.growth_detected = bool(r.growth_detected)
    m.level = int(r.level)
    m.message = r.message
    return m


class WearTrendNode(Node):
    """The wear trend node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wear_trend", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.params = p
        self.robot = str(p["robot"])
        self.cfg = TrendConfig(alarm=float(p["alarm_threshold"]), horizon_days=float(p["horizon_days"]),
                               min_estimates=int(p["min_estimates"]))
        self.store = HistoryStore(str(p["db_url"]))
        self.stored = 0
        self.duplicates = 0
        self.rejected = 0
        self.trends: dict[str, TrendResult] = {}
        self._statuses: dict[str, DiagnosticStatus] = {}
        reliable = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
        latched = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.trend_pub = self.create_publisher(WearTrend, str(p["trend_topic"]), latched,
                                               qos_overriding_options=overridable_qos())
        self.diag_pub = self.create_publisher(DiagnosticArray, str(p["diagnostics_topic"]), 10)
        self.create_subscription(WearEstimate, str(p["estimate_topic"]), self._on_estimate, reliable,
                                 qos_overriding_options=overridable_qos())
        self.create_service(RecordMaintenance, "~/record_maintenance", self._on_maintenance)
        self.create_timer(float(p["diagnostics_period"]), self._publish_diagnostics,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))
        joints = [j for r, j in self.store.joints(LIVE) if r == self.robot]
        for joint in joints:
            self._update(joint)
        self.get_logger().info(
            f"wear history of {self.robot} in {self.store.display_url}: {self.store.count(LIVE)} estimates, "
            f"{len(joints)} joint(s) reloaded; WARN when the alarm {self.cfg.alarm:g} may come within "
            f"{self.cfg.horizon_days:g} days, ERROR at it"
        )
        self._publish_diagnostics()

    # ------------------------------------------------------------------ callbacks
    def _on_estimate(self, msg: WearEstimate) -> None:
        joint = str(msg.joint_name)
        t = stamp_to_seconds(msg.header.stamp)
        if t <= 0:
            t = self.get_clock().now().nanoseconds * 1e-9
        rec = EstimateRecord(
            robot=self.robot, joint=joint, cycle_id=int(msg.cycle_id), time=t, wear=float(msg.wear),
            wear_std=float(msg.wear_std), hardware_id=str(self.params["hardware_id"]) or f"{self.robot}/{joint}",
            temperature=float(msg.temperature_estimate), method=str(msg.method), params=str(self.params["params"]),
            software_version=__version__, bag="", analysis_version=LIVE, source="live",
        )
        try:
            n = self.store.add_estimates([rec])
        except JointwearError as exc:
            self.rejected += 1
            self.get_logger().warning(f"WearEstimate of {joint!r} cycle {msg.cycle_id} not stored: {exc}")
            return
        if n:
            self.stored += 1
        else:
            self.duplicates += 1
        self._update(joint)

    def _on_maintenance(self, req: RecordMaintenance.Request,
                        res: RecordMaintenance.Response) -> RecordMaintenance.Response:
        robot = str(req.robot) or self.robot
        t = stamp_to_seconds(req.stamp)
        if t <= 0:
            t = self.get_clock().now().nanoseconds * 1e-9
        try:
            new = self.store.add_maintenance(MaintenanceEvent(robot, str(req.joint_name), t, str(req.kind),
                                                              str(req.note)))
        except JointwearError as exc:
            res.success, res.message = False, str(exc)
            self.get_logger().warning(f"maintenance event refused: {exc}")
            return res
        res.success = True
        res.message = (f"{req.kind} of {robot}/{req.joint_name} at {t:.3f} recorded" if new
                       else f"{req.kind} of {robot}/{req.joint_name} at {t:.3f} was already recorded")
        self.get_logger().info(res.message)
        if robot == self.robot:
            self._update(str(req.joint_name))
        return res

    # ------------------------------------------------------------------ trend
    def _update(self, joint: str) -> None:
        hist = self.store.history(LIVE, robot=self.robot, joint=joint).get((self.robot, joint))
        if hist is None:
            return
        recs, events = hist
        try:
            r = analyze_joint([x.time for x in recs], [x.wear for x in recs], [x.wear_std for x in recs],
                              cycle_ids=[x.cycle_id for x in recs], maintenance_times=[e.time for e in events],
                              cfg=self.cfg, robot=self.robot, joint=joint)
        except JointwearError as exc:  # pragma: no cover - the store only holds checked records
            self.get_logger().error(f"trend of {joint} failed: {exc}")
            return
        previous = self.trends.get(joint)
        self.trends[joint] = r
        self.trend_pub.publish(trend_to_msg(r, self.get_clock().now().to_msg(), self.cfg.horizon_days, self.cfg.alarm))
        tta = r.time_to_alarm
        values = [("robot", self.robot), ("wear", f"{r.wear:.3f}"), ("wear_std", f"{r.wear_std:.3f}"),
                  ("rate_per_day", f"{r.rate_per_day:.4f}"), ("estimates", str(r.estimates)),
                  ("estimates_total", str(r.estimates_total)),
                  ("time_to_alarm_median", "nan" if tta is None else f"{tta.median:.1f}"),
                  ("time_to_alarm_lo90", "nan" if tta is None else f"{tta.lo90:.1f}"),
                  ("time_to_alarm_hi90", "nan" if tta is None else f"{tta.hi90:.1f}"),
                  ("horizon_days", f"{self.cfg.horizon_days:g}")]
        hw = str(self.params["hardware_id"]) or f"{self.robot}/{joint}"
        self._statuses[joint] = diagnostic_status(f"wear_trend: {joint}", hw, r.level, r.message, values)
        if previous is None or previous.level != r.level:
            log = self.get_logger()
            text = f"{self.robot}/{joint}: {r.level_name}: {r.message}"
            if r.level == ERROR:
                log.error(text)
            elif r.level == WARN:
                log.warning(text)
            else:
                log.info(text)
        self._publish_diagnostics()

    def _publish_diagnostics(self) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        statuses = []
        for j in sorted(self._statuses):  # the node's counters as of now, on every joint's status
            s = self._statuses[j]
            statuses.append(diagnostic_status(s.name, s.hardware_id, s.level[0], s.message,
                                    [(kv.key, kv.value) for kv in s.values]
                                    + [("stored", str(self.stored)), ("duplicates", str(self.duplicates)),
                                       ("rejected", str(self.rejected))]))
        arr.status = statuses or [diagnostic_status(
            "wear_trend: history", str(self.params["hardware_id"]) or self.robot, OK,
            "no wear estimates stored yet", [("robot", self.robot)])]
        self.diag_pub.publish(arr)

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: let reliable subscribers get the last trends; close the store."""
        try:
            self.trend_pub.wait_for_all_acked(Duration(seconds=0.5))
        except Exception:  # pragma: no cover - best effort on the way out
            pass
        self.store.close()


def main(args: list[str] | None = None) -> int:
    """Console script ``wear_trend``."""
    return run_node(WearTrendNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
