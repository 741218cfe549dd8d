"""wear_trend: WearEstimate → wear history store → trend, time to alarm, /diagnostics.

A thin rclpy adapter over :class:`~jointwear_ros.history.HistoryStore`, its
outbox and the pure trend core :func:`~jointwear_ros.trend.analyze_joint`. Every
``jointwear_msgs/WearEstimate`` on ``estimate_topic`` is appended to the store
(``db_url``: an SQLite file by default, or ``postgresql://...``) in its own
transaction *before* anything is published about it, so what the node has
reported is durable even when it is killed (SIGKILL) right after; a repeated
estimate (same robot, joint, cycle id and stamp: a bag played again, a
restarted node) is stored once. Then the joint's trend is recomputed from the
store and published:

- ``jointwear_msgs/WearTrend`` on ``trend_topic`` (wear, rate, time to alarm
  median and 90 % interval, the forecast ``alarm_expected``, the condition level);
- ``/diagnostics``: one status per joint named ``wear_trend: <joint>`` with the
  joint's *condition level* (:mod:`jointwear_ros.condition`: the same rule and
  value as the wear_estimator's for the same estimates; STALE without one) and the
  forecast in its values (``alarm_expected``, ``forecast``: never the level);
  republished every ``diagnostics_period``.

On start the node reloads the robot's history from the store and publishes
the trend of every joint it holds, so a restart loses nothing. The service
``~/record_maintenance`` (``jointwear_msgs/srv/RecordMaintenance``) records a
maintenance event (regrease, reducer replaced): the joint's trend starts a new
segment; an event in the future or of a joint the history does not know (a
misspelt name) is refused with the reason.

Every estimate is screened first (:mod:`~jointwear_ros.history.screen`): a
malformed one (NaN, std <= 0), a wear or std outside the physical range, a stamp
before 2010, beyond ``future_tolerance`` ahead of the node's clock, or more than
``clock_tolerance`` before the joint's newest estimate (the estimator's clock
jumped back) is refused with the reason, kept in the store's ``refused`` table,
logged and counted (``rejected`` and ``refused_<reason>`` in the diagnostics; the
joint's message names it while its newest estimate is a refused one); it never
reaches the trend. The node keeps running.

**Nothing reported is lost.** Estimates go to the store through the history's
outbox (:class:`~jointwear_ros.history.outbox.Outbox`, which holds the policy;
the node only feeds it and calls its retry on a timer). When the store fails
(disk full, PostgreSQL down, a locked or damaged file), the estimates it could
not take wait in a bounded buffer (``buffer_max``), spooled to ``buffer_path``
(default under ``$ROS_HOME``, never beside the store's file; the node warns when
it shares the store's disk) and, when that cannot be written either (the same
disk is full), to a RAM file in ``/dev/shm`` that survives the node being
killed; both are reloaded on start.
A locked store makes a statement fail after ``store_lock_timeout`` (0.5 s), never
blocking the node: its diagnostics keep their period. They are written again every ``retry_period`` until the store takes them
(inserts are idempotent: none twice); meanwhile ``/diagnostics`` says ERROR on
``wear_trend: history`` and names the failure on every joint ("history store
failing: ...", ``buffered``) without changing its condition level, and each joint's
trend includes its buffered estimates,
so the level follows the newest estimate, not the last stored one. A failed read
keeps the last history read; nothing ends the node. A store that cannot be opened
at start is opened again at every retry. ``alarm_threshold``, ``warn_threshold``, ``horizon_days``,
``min_estimates``, ``future_tolerance`` and ``clock_tolerance`` apply at run time
(every joint's trend recomputed); a bad value is refused with the reason; the
others are read at start-up.

Parameters: see ``config/wear_trend.yaml`` and ``docs/history-trend.md``.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any

from builtin_interfaces.msg import Time as TimeMsg
from jointwear_msgs.msg import WearEstimate, WearTrend
from jointwear_msgs.srv import RecordMaintenance
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .. import __version__
from ..contract import DiagnosticLevel, source_of, stamp_to_seconds
from ..errors import JointwearError
from ..history import LIVE, EstimateRecord, HistoryStore, MaintenanceEvent, backend_for, screened_history
from ..history.outbox import Outbox, SpoolPaths, same_disk
from ..history.screen import REASONS, Refusal, ScreenConfig, screen_record
from ..settings import declarations, from_mapping
from ..trend import TrendConfig, TrendResult, analyze_joint
from .diagnostics import HeldStatus, Status, Updater
from .runtime import ParamDecl, declare_parameters, on_parameter_change, overridable_qos, run_node, wait_acked

__all__ = ["LIVE_PARAMETERS", "PARAMETERS", "WearTrendNode", "main", "trend_to_msg"]

_S = ScreenConfig()

PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("robot", "robot_1", "robot name the estimates belong to (WearEstimate has none)", read_only=True),
    ParamDecl("db_url", "wear_history.db", "history store: a file path or sqlite:///path (SQLite, WAL), "
              "or postgresql://user@host/db", read_only=True),
    ParamDecl("hardware_id", "", "DiagnosticStatus.hardware_id and stored hardware id (empty = robot/joint)",
              read_only=True),
    ParamDecl("params", "ref-2011r", "friction-model parameter set the estimates were made with (stored)",
              read_only=True),
    *declarations(TrendConfig),  # the trend settings, declared in TrendConfig (jointwear_ros.trend.config)
    ParamDecl("future_tolerance", _S.future_tolerance_s, "s an estimate may be stamped ahead of the node's clock",
              0.0, 86400.0),
    ParamDecl("clock_tolerance", _S.clock_tolerance_s, "s an estimate may be stamped before its joint's newest "
              "one (more: the estimator's clock jumped back)", 1.0, 86400.0 * 365),
    ParamDecl("buffer_max", 10000, "estimates kept while the store fails (the oldest dropped beyond, counted)",
              read_only=True),
    ParamDecl("buffer_path", "", "spool file of the estimates waiting for the store (empty: "
              "$ROS_HOME/wear_trend_<robot>.pending.jsonl; put it on another disk than the store's; when it "
              "cannot be written, /dev/shm holds them)", read_only=True),
    ParamDecl("store_lock_timeout", 0.5, "s a write or read waits for another writer's lock before it counts as a "
              "store failure (buffered, retried): the node's diagnostics keep their period", 0.01, 30.0,
              read_only=True),
    ParamDecl("retry_period", 1.0, "s between attempts to write the buffered estimates", 0.05, 600.0,
              read_only=True),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications", 0.01, 60.0, read_only=True),
    ParamDecl("estimate_topic", "/jointwear/wear_estimate", "WearEstimate input", read_only=True),
    ParamDecl("trend_topic", "/jointwear/wear_trend", "WearTrend output (one message per joint and update)",
              read_only=True),
    ParamDecl("diagnostics_topic", "/diagnostics", "DiagnosticArray output", read_only=True),
)
LIVE_PARAMETERS = tuple(d.name for d in PARAMETERS if not d.read_only)


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
    m.alarm_expected = bool(r.alarm_expected)
    m.forecast = "" if r.forecast is None else r.forecast.state
    m.level = int(r.level)
    m.level_wear, m.level_wear_std = float(r.level_wear), float(r.level_wear_std)
    m.evidence, m.confirmation = r.evidence, r.confirmation
    m.message = r.message
    return m


class WearTrendNode(Node):
    """The wear trend node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("wear_trend", **kwargs)
        p = declare_parameters(self, PARAMETERS)
        self.params = p
        self.robot = str(p["robot"])
        self.cfg: TrendConfig = from_mapping(TrendConfig, p)
        self.screen_cfg = replace(_S, future_tolerance_s=float(p["future_tolerance"]),
                                  clock_tolerance_s=float(p["clock_tolerance"]))
        self.rejected = 0
        self.refused_by_reason: dict[str, int] = {}
        self._repeats = 0  # estimates received again that the store holds (screened as a clock jump)
        self.trends: dict[str, TrendResult] = {}
        #: joint -> its trend's status (set at each analysis; the node's counters are added at each update)
        self._trend_status: dict[str, HeldStatus] = {}
        #: joint -> (records, events) of the last successful read (used while reads fail)
        self._cache: dict[str, tuple[list[EstimateRecord], list[MaintenanceEvent]]] = {}
        #: the estimates on their way to the store: buffer, spool and retry (the pure history component)
        paths = SpoolPaths.for_store(str(p["db_url"]), self.robot, str(p["buffer_path"]))
        self.outbox = Outbox(self._open_store, paths, clock=self._now, screen=self.screen_cfg,
                             max_items=int(p["buffer_max"]), log=self._log)
        self.spool_same_disk = same_disk(paths.spool, backend_for(str(p["db_url"])).file)
        if self.spool_same_disk:
            self.get_logger().warning(
                f"the buffer spool {paths.spool} is on the store's disk: when that disk fills, buffered estimates go "
                f"to {paths.fallback} (RAM: kept through a kill, not a reboot); set buffer_path to another disk")
        self._newest: dict[str, float] = {}  # joint -> newest accepted stamp (live arrival order)
        self._last_refusal: dict[str, Refusal | None] = {}
        reliable = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
        latched = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        self.trend_pub = self.create_publisher(WearTrend, str(p["trend_topic"]), latched,
                                               qos_overriding_options=overridable_qos())
        # health: one task per joint (added as joints appear) and the store's, republished on a wall-clock timer
        self.health = Updater(self, "wear_trend", period=float(p["diagnostics_period"]),
                              topic=str(p["diagnostics_topic"]))
        self.health.add("history", self._history_health, hardware_id=str(p["hardware_id"]) or self.robot)
        self.outbox.open()
        self.outbox.load()
        self.create_subscription(WearEstimate, str(p["estimate_topic"]), self._on_estimate, reliable,
                                 qos_overriding_options=overridable_qos())
        self.create_service(RecordMaintenance, "~/record_maintenance", self._on_maintenance)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(float(p["retry_period"]), self._retry, clock=steady)
        on_parameter_change(self, self._on_parameters, LIVE_PARAMETERS)
        if self.outbox.pending:
            self.outbox.flush()
        joints = self._known_joints()
        for joint in joints:
            self._update(joint)
        self.get_logger().info(
            f"wear history of {self.robot} in {self._url()}: "
            f"{self._count()} estimates, "
            f"{len(joints)} joint(s) reloaded; condition level: WARN from {self.cfg.warn:g} (or when an estimate "
            f"cannot rule the alarm out), ERROR at {self.cfg.alarm:g}; forecast: alarm expected when it may come "
            f"within {self.cfg.horizon_days:g} days"
        )
        self.health.update()

    # ------------------------------------------------------------------ store plumbing
    @property
    def store(self) -> HistoryStore | None:
        return self.outbox.store  # type: ignore[return-value]

    @property
    def pending(self) -> Any:
        """The estimates (and refusals) waiting for the store, oldest first."""
        return self.outbox.pending

    @property
    def store_error(self) -> str | None:
        return self.outbox.error

    @property
    def stored(self) -> int:
        return self.outbox.stored

    @property
    def duplicates(self) -> int:
        return self.outbox.duplicates + self._repeats

    @property
    def dropped(self) -> int:
        return self.outbox.dropped

    @property
    def spool(self) -> Path:
        return self.outbox.paths.spool

    def _log(self, level: str, message: str) -> None:
        """The outbox's log lines (rclpy wants one call site per severity)."""
        log = self.get_logger()
        if level == "error":
            log.error(message)
        elif level == "warning":
            log.warning(message)
        else:
            log.info(message)

    def _count(self) -> str:
        if self.store is None or self.store_error is not None:
            return "?"
        try:
            return str(self.store.count(LIVE))
        except Exception as exc:  # a failed read never ends the node
            self.outbox.fail("cannot read", exc)
            return "?"

    def _url(self) -> str:
        return self.store.display_url if self.store is not None else str(self.params["db_url"])

    def _open_store(self) -> HistoryStore:
        return HistoryStore(str(self.params["db_url"]), lock_timeout_s=float(self.params["store_lock_timeout"]),
                            write_attempts=1)

    def _known_joints(self) -> list[str]:
        joints = set(self._cache) | {r.joint for r, _ in self.pending}
        if self.store is not None:
            try:
                joints |= {j for r, j in self.store.joints(LIVE) if r == self.robot}
            except Exception as exc:  # any driver error is a store failure
                self.outbox.fail("cannot read", exc)
        return sorted(joints)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _retry(self) -> None:
        if self.outbox.retry():  # the store came back: every joint's trend from what it holds now
            for joint in self._known_joints():
                self._update(joint)
            self.health.update()

    # ------------------------------------------------------------------ callbacks
    def _on_estimate(self, msg: WearEstimate) -> None:
        joint = str(msg.joint_name)
        t = stamp_to_seconds(msg.header.stamp)
        if t <= 0:
            t = self._now()
        try:
            cycle_source = source_of(getattr(msg, "source", ""))  # empty (an older estimator): a test cycle's
        except JointwearError as exc:
            self.rejected += 1
            self.get_logger().warning(f"WearEstimate of {joint!r} cycle {msg.cycle_id} ignored: {exc}")
            return
        rec = EstimateRecord(
            robot=self.robot, joint=joint, cycle_id=int(msg.cycle_id), time=t, wear=float(msg.wear),
            wear_std=float(msg.wear_std), hardware_id=str(self.params["hardware_id"]) or f"{self.robot}/{joint}",
            temperature=float(msg.temperature_estimate), method=str(msg.method), params=str(self.params["params"]),
            software_version=__version__, bag="", analysis_version=LIVE, source="live",
            evidence=str(getattr(msg, "evidence", "") or "complete"), cycle_source=cycle_source,
        )
        f = screen_record(rec, now=self._now(), cfg=self.screen_cfg, not_before=self._newest.get(joint))
        if f is not None and f.reason == "clock_jump" and self._stored_already(rec):
            self._repeats += 1  # the same estimate again (a bag played onto the graph, a restarted estimator)
            return
        if f is not None:
            self.rejected += 1
            self.refused_by_reason[f.reason] = self.refused_by_reason.get(f.reason, 0) + 1
            self._last_refusal[joint] = f
            self.get_logger().warning(f"WearEstimate of {joint!r} cycle {msg.cycle_id} refused "
                                      f"({f.reason}): {f.detail}; kept in the history's refused table")
        else:
            self._newest[joint] = max(self._newest.get(joint, -math.inf), rec.time)
            self._last_refusal[joint] = None
        self.outbox.put(rec, f)  # stored now, or buffered, spooled and retried while the store fails
        self._update(joint)

    def _stored_already(self, rec: EstimateRecord) -> bool:
        recs = self._cache.get(rec.joint, ([], []))[0]
        if any(r.cycle_id == rec.cycle_id and r.time_ns == rec.time_ns for r in recs):
            return True
        if self.store is None:
            return False
        try:
            return self.store.has_estimate(rec)
        except Exception:  # unknown while the store fails: screened as refused
            return False

    def _on_maintenance(self, req: RecordMaintenance.Request,
                        res: RecordMaintenance.Response) -> RecordMaintenance.Response:
        robot = str(req.robot) or self.robot
        t = stamp_to_seconds(req.stamp)
        if t <= 0:
            t = self._now()
        try:
            if not self.outbox.open():
                raise JointwearError(f"the history store is failing ({self.store_error}); try again later")
            assert self.store is not None
            new = self.store.add_maintenance(MaintenanceEvent(robot, str(req.joint_name), t, str(req.kind),
                                                              str(req.note)),
                                             now=self._now(), future_tolerance_s=self.screen_cfg.future_tolerance_s,
                                             known_joints=self._known_joints() if robot == self.robot else None)
        except JointwearError as exc:
            res.success, res.message = False, str(exc)
            self.get_logger().warning(f"maintenance event refused: {exc}")
            return res
        except Exception as exc:  # the store failing is an answer, not a crash
            res.success, res.message = False, f"the history store is failing: {exc}"
            self.get_logger().warning(f"maintenance event not recorded: {res.message}")
            return res
        res.success = True
        res.message = (f"{req.kind} of {robot}/{req.joint_name} at {t:.3f} recorded" if new
                       else f"{req.kind} of {robot}/{req.joint_name} at {t:.3f} was already recorded")
        self.get_logger().info(res.message)
        if robot == self.robot:
            self._update(str(req.joint_name))
        return res

    def _on_parameters(self, changes: dict[str, Any]) -> str | None:
        p = {**self.params, **changes}
        cfg = from_mapping(TrendConfig, p)
        scfg = replace(self.screen_cfg, future_tolerance_s=float(p["future_tolerance"]),
                       clock_tolerance_s=float(p["clock_tolerance"]))
        self.params.update(changes)
        self.cfg, self.screen_cfg = cfg, scfg
        self.outbox.screen = scfg
        for joint in self._known_joints():
            self._update(joint)
        return None

    # ------------------------------------------------------------------ trend
    def _read(self, joint: str) -> tuple[list[EstimateRecord], list[MaintenanceEvent]] | None:
        if not self.outbox.open():
            return self._cache.get(joint)
        assert self.store is not None
        try:
            hist, _refused = screened_history(self.store, LIVE, robot=self.robot, joint=joint, now=self._now(),
                                              cfg=self.screen_cfg)
        except Exception as exc:  # a failed read keeps the last history read
            self.outbox.fail("cannot read", exc)
            return self._cache.get(joint)
        got = hist.get((self.robot, joint))
        if got is not None:
            self._cache[joint] = got
            if got[0]:
                self._newest[joint] = max(self._newest.get(joint, -math.inf), max(r.time for r in got[0]))
        return got

    def _update(self, joint: str) -> None:
        got = self._read(joint)
        recs, events = got if got is not None else ([], [])
        waiting = self.outbox.waiting(joint)
        if waiting:  # the newest estimates the store has not taken yet count: the level follows them
            have = {(r.cycle_id, r.time_ns) for r in recs}
            recs = sorted([*recs, *(r for r in waiting if (r.cycle_id, r.time_ns) not in have)],
                          key=lambda r: (r.time, r.cycle_id))
        if not recs:
            if self._last_refusal.get(joint) is not None:
                self._set_status(joint, None)
            return
        try:
            r = analyze_joint([x.time for x in recs], [x.wear for x in recs], [x.wear_std for x in recs],
                              cycle_ids=[x.cycle_id for x in recs], maintenance_times=[e.time for e in events],
                              cfg=self.cfg, robot=self.robot, joint=joint, evidence=[x.evidence for x in recs])
        except JointwearError as exc:  # pragma: no cover - only screened records get here
            self.get_logger().error(f"trend of {joint} failed: {exc}")
            return
        previous = self.trends.get(joint)
        self.trends[joint] = r
        self.trend_pub.publish(trend_to_msg(r, self.get_clock().now().to_msg(), self.cfg.horizon_days, self.cfg.alarm))
        self._set_status(joint, r)
        if previous is None or previous.level != r.level:
            log = self.get_logger()
            text = f"{self.robot}/{joint}: {r.level_name}: {r.message}"
            if r.level == DiagnosticLevel.ERROR:
                log.error(text)
            elif r.level == DiagnosticLevel.WARN:
                log.warning(text)
            else:
                log.info(text)
        self.health.update()

    def _set_status(self, joint: str, r: TrendResult | None) -> None:
        if r is None:
            values = [("robot", self.robot)]
            level, message = DiagnosticLevel.STALE, "no usable wear estimate stored yet: no level"
        else:
            tta = r.time_to_alarm
            values = [("robot", self.robot), ("wear", f"{r.wear:.3f}"), ("wear_std", f"{r.wear_std:.3f}"),
                      ("rate_per_day", f"{r.rate_per_day:.4f}"), ("estimates", str(r.estimates)),
                      ("estimates_total", str(r.estimates_total)),
                      ("time_to_alarm_median", "nan" if tta is None else f"{tta.median:.1f}"),
                      ("time_to_alarm_lo90", "nan" if tta is None else f"{tta.lo90:.1f}"),
                      ("time_to_alarm_hi90", "nan" if tta is None else f"{tta.hi90:.1f}"),
                      ("horizon_days", f"{self.cfg.horizon_days:g}"),
                      ("alarm_threshold", f"{self.cfg.alarm:g}"),
                      ("level_wear", f"{r.level_wear:.3f}"), ("level_wear_std", f"{r.level_wear_std:.3f}"),
                      ("evidence", r.evidence or "none"), ("newest_estimate", r.confirmation or "none"),
                      ("alarm_expected", "true" if r.alarm_expected else "false"),
                      ("forecast", "" if r.forecast is None else r.forecast.state)]
            level, message = DiagnosticLevel(r.level), r.message
        held = self._trend_status.get(joint)
        if held is None:
            held = self._trend_status[joint] = HeldStatus(joint)
            self.health.add(joint, partial(self._joint_health, joint),
                            hardware_id=str(self.params["hardware_id"]) or f"{self.robot}/{joint}")
        held.set(level, message, values)

    def _counters(self) -> list[tuple[str, str]]:
        """The node's counters as of now (on every joint's status and the store's)."""
        counters = [("stored", str(self.stored)), ("duplicates", str(self.duplicates)),
                    ("rejected", str(self.rejected)), ("buffered", str(len(self.pending))),
                    ("dropped", str(self.dropped))]
        return counters + [(f"refused_{k}", str(self.refused_by_reason[k])) for k in REASONS
                           if k in self.refused_by_reason]

    def _joint_health(self, joint: str, stat: Status) -> None:
        """A joint's trend, with its newest refusal and the store's failure said first."""
        held = self._trend_status[joint]
        level, message = held.level, held.message
        last = self._last_refusal.get(joint)
        if last is not None:  # the joint's newest estimate is unusable: say so (the level stays the trend's)
            message = f"newest estimate refused ({last.reason}: {last.detail}); {message}"
        failing = self.store_error
        if failing is not None:  # the store's own status is ERROR; the joint's condition level stays its own
            waiting = sum(1 for r, f in self.pending if r.joint == joint)
            message = f"history store failing ({failing}); {waiting} estimate(s) of {joint} buffered; {message}"
        stat.summary(level, message)
        stat.extend([*held.values, *self._counters()])

    def _history_health(self, stat: Status) -> bool | None:
        """The store's own status: while it fails, or before any joint has one."""
        failing = self.store_error
        if failing is None and self._trend_status:
            return False
        if failing is not None:
            stat.summary(DiagnosticLevel.ERROR,
                         f"history store {self._url()} failing: {failing}; {len(self.pending)} estimate(s) "
                         f"buffered, retried every {float(self.params['retry_period']):g} s")
        else:
            stat.summary(DiagnosticLevel.OK, "no wear estimates stored yet")
        stat.extend([("robot", self.robot), ("db_url", self._url()), ("buffer_path", str(self.spool)),
                     ("spool_same_disk", "true" if self.spool_same_disk else "false"), *self._counters()])
        return None

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: a last attempt at the buffer (kept in its spool file otherwise); let
        reliable subscribers get the last trends; close the store."""
        self.outbox.close()  # a last attempt; what the store did not take stays in a spool file (logged)
        wait_acked([self.trend_pub])


def main(args: list[str] | None = None) -> int:
    """Console script ``wear_trend``."""
    return run_node(WearTrendNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
