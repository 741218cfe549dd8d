"""production_observer: /joint_states during production → friction observations per shift, and the shift's status.

A thin rclpy adapter over :class:`~jointwear_ros.observer.ProductionObserver` (docs/production.md): it
watches the robot's own program on ``/joint_states`` (every joint of ``joints``: position, velocity and
effort) and ``/joint_temperature`` (``sensor_msgs/Temperature``, ``header.frame_id`` the joint), feeds the
observer every sample in stamp order, and at the end of each production shift publishes

- each of the shift's observations as a ``FrictionObservation`` (``source: production``, ``cycle_id`` the
  shift id) on ``observations_topic`` (``/jointwear/friction_observations``, where ``wear_estimator``
  listens), and
- per joint a ``TestCycleStatus`` RUNNING, then (after the observations) DONE on ``status_topic``
  (``/production/status``, the wear_estimator's ``production_status_topic``): ``cycle_id`` the shift id,
  ``speeds_total`` the joint's number of observations in the shift (0 for a joint with none), ``message``
  its counts (passes, paired, model, rejected by reason) or why it gave nothing (``joint_6: never moved
  at a constant speed >= 10 rad/s motor in this shift``): the wear_estimator estimates the shift as a unit.

**Stamps, never the wall clock.** Everything the observations depend on comes from the messages' header
stamps, so a replay of a bag gives what the live node gave (``jointwear data from-production``, the same
rules in :mod:`jointwear_ros.io.production_bag`). Each JointState is held until a message stamped
``reorder_margin`` s later has come (on either topic), then processed with each joint's latest temperature
stamped at or before it (NaN before the first reading): the temperature messages of that stretch have
come by then whatever the order the two topics are delivered in.

**Shifts** (:class:`~jointwear_ros.io.production_bag.ShiftClock`): shift ``1 + floor((stamp -
shift_origin) / shift_seconds)`` of the samples' stamps. The shift being observed ends when a sample of a
later shift is processed; when the node's clock is past the shift's end and no JointState came for
``shift_idle`` wall seconds (a driver that stopped publishing: its last samples are processed first); or
on the service ``~/end_shift`` (``std_srvs/Trigger``: the operator's or the plant's shift change). A
shift ended early leaves the rest of its period to the next id (ids always grow).

**Bad messages** (a JointState lacking a joint, arrays whose lengths differ from ``name``, a NaN, no
stamp, a stamp not after the previous one; a Temperature of a joint not served or not finite) are counted
by reason, logged (throttled) and skipped: never a crash.

**Diagnostics**: one ``production_observer: <joint>`` status per joint on ``/diagnostics`` (one
:class:`~jointwear_ros.nodes.diagnostics.Updater`, on every shift end and every ``diagnostics_period``)
with the shift being observed, the samples, and the last shift's passes, paired, model and rejected
counts by reason and its note. OK normally, also for a joint the program did not move (the message says
so); WARN only while the shift being observed has had bad messages (the observer's own fault), with the
latest reason. Never a wear level: that is the wear_estimator's.

**Arm model** (optional): ``arm`` (``ur5``, ``panda``; empty: none) gives the observer the arm's rigid-body
model (Pinocchio's RNEA on its URDF, :class:`~jointwear_ros.sim.arm.ArmModel`): the gravity of each
configuration and the torque of a part at the flange, so a pair whose passes carried different loads (a part
picked on one way, placed on the other) is corrected by the fitted payload (``payload`` kg when the part's mass
is known from commissioning) instead of rejected as a load mismatch; with ``model_based`` also u - tau_model for
passes without a reverse partner. Each joint's ``gear_ratio`` and ``torque_scale`` then default to the arm's
(``<joint>.gear_ratio`` overrides).

Parameters: ``config/production_observer.yaml``; every one is read at start-up (restart to change):
the observations of a shift must come from one set of settings. See docs/nodes-production.md.
"""

from __future__ import annotations

import math
import time
from collections import Counter, deque
from collections.abc import Mapping, Sequence
from dataclasses import replace
from functools import partial
from typing import Any

from jointwear_msgs.msg import FrictionObservation, TestCycleStatus
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature
from std_srvs.srv import Trigger

from .. import contract
from ..contract import CycleState, CycleStatus, DiagnosticLevel, Source, stamp_to_seconds, status_to_msg
from ..errors import JointwearError, ParameterError
from ..io.production_bag import JointStateRows, ShiftClock, TemperatureTrack
from ..observer import FrictionObservationData, ProductionConfig, ProductionObserver
from ..observer.production import NO_ARM_MODEL, ProductionShift
from ..settings import from_mapping, node_declarations
from ..sim.arm import ArmModel
from .diagnostics import Status, Updater
from .joints import declare_robot
from .runtime import ParamDecl, overridable_qos, run_node_refusing, subscribe_reporting_loss, wait_acked

__all__ = ["PARAMETERS", "PER_JOINT", "ProductionObserverNode", "main", "production_config", "shift_statuses"]

_NODE_HEAD: tuple[ParamDecl, ...] = (
    ParamDecl("joint_name", "joint_1", "joint observed when joints is empty (looked up by name in each JointState)",
              read_only=True),
    ParamDecl("arm", "", "the arm's model (ur5, panda; empty: none): pairs whose load differs (a part carried one "
              "way) are corrected for the payload's torque, else rejected as a load mismatch", read_only=True),
    ParamDecl("payload", 0.0, "kg of the part the program carries on some passes (identified at commissioning; "
              "0: fitted per pair from the load the arm's model leaves)", 0.0, 1000.0, read_only=True, unit="kg"),
    ParamDecl("model_based", False, "with an arm: a pass without a reverse partner gives u - tau_model (the "
              "arm's inverse dynamics, no part carried) as friction", read_only=True),
)
_NODE_TAIL: tuple[ParamDecl, ...] = (
    ParamDecl("joint_states_topic", "/joint_states", "sensor_msgs/JointState input (every joint)", read_only=True),
    ParamDecl("temperature_topic", "/joint_temperature", "sensor_msgs/Temperature input (header.frame_id = joint); "
              "empty = no temperature", read_only=True),
    ParamDecl("observations_topic", "/jointwear/friction_observations", "FrictionObservation output (source "
              "production)", read_only=True),
    ParamDecl("status_topic", "/production/status", "TestCycleStatus output: per joint RUNNING, DONE at a shift's end",
              read_only=True),
    ParamDecl("shift_seconds", 8 * 3600.0, "length of a production shift, s of the stamps", 1e-3, 1e9,
              read_only=True, unit="s"),
    ParamDecl("shift_origin", 0.0, "stamp (s of the epoch, or sim time) at which shift 1 starts", -1e12, 1e12,
              read_only=True, unit="s"),
    ParamDecl("shift_idle", 60.0, "wall s without a JointState, once the shift's end time has passed, that end it "
              "(a robot that stopped)", 0.0, 1e7, read_only=True, unit="s"),
    ParamDecl("reorder_margin", 0.5, "s of stamps a JointState waits for the temperatures stamped up to it",
              0.0, 60.0, read_only=True, unit="s"),
    ParamDecl("poll_period", 0.5, "s (wall) between checks of the idle rule", 0.01, 60.0, read_only=True),
    ParamDecl("diagnostics_period", 1.0, "s between /diagnostics republications (wall time)", 0.01, 60.0,
              read_only=True),
)


def _read_only(decls: Sequence[ParamDecl]) -> tuple[ParamDecl, ...]:
    return tuple(replace(d, read_only=True) for d in decls)


_DECLS = node_declarations(ProductionConfig, _NODE_HEAD, _NODE_TAIL)
#: every parameter (all read at start-up: a shift's observations come from one set of settings); the settings
#: each joint may have of its own (``<joint>.<setting>``, default: the node-level value or the arm's)
PARAMETERS: tuple[ParamDecl, ...] = _read_only(_DECLS.parameters)
LIVE_PARAMETERS: tuple[str, ...] = ()
PER_JOINT: tuple[str, ...] = _DECLS.per_joint


def production_config(values: Mapping[str, Any], joint: str) -> ProductionConfig:
    """Joint ``joint``'s observer settings from the node's parameter values (``<joint>.<setting>`` over the
    node-level ``<setting>``), checked: one :class:`ParameterError` line naming the joint."""
    try:
        cfg: ProductionConfig = from_mapping(ProductionConfig, values, joint=joint)
    except JointwearError as exc:
        raise ParameterError(f"production_observer: {joint}: {exc}") from None
    return cfg


def _arm_defaults(params: dict[str, Any], joints: list[str]) -> dict[str, list[float]]:
    """Each joint's gear_ratio and torque_scale from the arm's spec (none without an arm)."""
    arm = str(params.get("arm", "") or "")
    if not arm:
        return {}
    from ..sim.arms import arm_spec

    spec = arm_spec(arm)  # a ParameterError naming the arms for an unknown one
    arm_joints = spec.for_names(joints)
    return {"gear_ratio": [float(j.gear_ratio) for j in arm_joints],
            "torque_scale": [float(j.torque_scale) for j in arm_joints]}


def shift_statuses(shift: ProductionShift, joints: Sequence[str]) -> tuple[list[CycleStatus], list[CycleStatus]]:
    """The RUNNING and DONE status of every joint for ``shift``: ``cycle_id`` the shift id, ``speeds_total``
    the joint's observations in it, ``message`` its counts, or why it gave nothing."""
    counts = Counter(o.joint_name for o in shift.observations)
    lines = dict(zip(shift.joints, shift.summary().splitlines(), strict=True))
    running: list[CycleStatus] = []
    done: list[CycleStatus] = []
    for k, j in enumerate(joints):
        c = shift.joints[j]
        n = counts.get(j, 0)
        message = c.note if (n == 0 and c.note) else lines[j]
        st = CycleStatus(cycle_id=shift.shift_id, state=CycleState.RUNNING, speeds_total=n,
                         message=f"production shift {shift.shift_id}", joint_name=j, joints=tuple(joints),
                         joints_done=k, stamp=shift.t_end if math.isfinite(shift.t_end) else 0.0)
        running.append(st)
        done.append(replace(st, state=CycleState.DONE, speeds_done=n, message=message))
    return running, done


def _reliable(depth: int) -> QoSProfile:
    return QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=depth)


class ProductionObserverNode(Node):
    """The production observer node (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("production_observer", **kwargs)
        try:
            p, self.joints, values = declare_robot(self, PARAMETERS, PER_JOINT, _arm_defaults)
        except (InvalidParameterValueException, InvalidParameterTypeException) as exc:  # out of range, wrong type
            raise ParameterError(f"production_observer: {' '.join(str(exc).split())}") from None
        self.params = p
        configs = [production_config({**p, **values[j]}, j) for j in self.joints]
        arm = str(p["arm"] or "")
        payload = float(p["payload"])
        models = ArmModel(arm, self.joints).observer_models(
            payload_mass=payload if payload > 0 else None, model_based=bool(p["model_based"])) if arm else {}
        try:
            self.observer = ProductionObserver(self.joints, configs, **models)
        except JointwearError as exc:
            raise ParameterError(f"production_observer: {exc}") from None
        #: the shift rule (by the stamps)
        self.clock = ShiftClock(float(p["shift_seconds"]), float(p["shift_origin"]))
        self._idle = float(p["shift_idle"])
        self._margin = float(p["reorder_margin"])
        self._rows = JointStateRows(self.joints)
        self._temps = TemperatureTrack(self.joints)
        #: JointState samples waiting for their temperatures: (stamp, q, v, u)
        self._held: deque[tuple[float, Any, Any, Any]] = deque()
        self._latest = -math.inf  # the latest stamp of any message received
        self._last_js = -math.inf  # the latest JointState stamp taken
        self._last_rx = time.monotonic()
        #: every ended shift, in order; the samples fed to the observer
        self.shifts: list[ProductionShift] = []
        self.samples = 0
        self.shift_samples = 0
        self.observations_published = 0
        #: bad messages by reason (all shifts); the latest reason and the count in the shift being observed
        self.bad_messages: Counter[str] = Counter()
        self._bad_in_shift = 0
        self._bad_last = ""
        self.lost_messages: Counter[str] = Counter()
        self.cpu_seconds = 0.0  # CPU time spent in the JointState callbacks (process time; rclpy's own not counted)

        self.obs_pub = self.create_publisher(FrictionObservation, str(p["observations_topic"]), _reliable(1000),
                                             qos_overriding_options=overridable_qos())
        self.status_pub = self.create_publisher(TestCycleStatus, str(p["status_topic"]), _reliable(100),
                                                qos_overriding_options=overridable_qos())
        qos = _reliable(10000)  # as the recorder's queue_depth: a starved observer keeps seconds of 1 kHz states
        subscribe_reporting_loss(self, JointState, str(p["joint_states_topic"]), self._on_joint_state, qos,
                                 self._lost_callback(str(p["joint_states_topic"])),
                                 qos_overriding_options=overridable_qos())
        if p["temperature_topic"]:
            subscribe_reporting_loss(self, Temperature, str(p["temperature_topic"]), self._on_temperature, qos,
                                     self._lost_callback(str(p["temperature_topic"])),
                                     qos_overriding_options=overridable_qos())
        self.create_service(Trigger, "~/end_shift", self._on_end_shift)
        # wall-clock timer: the idle rule must be checked when the inputs (and /clock) stop
        self.create_timer(float(p["poll_period"]), self._on_poll, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.health = Updater(self, "production_observer", period=float(p["diagnostics_period"]))
        for j in self.joints:
            self.health.add(j, partial(self._joint_health, j), hardware_id=j)
        self.health.update()
        self.get_logger().info(
            f"observing production of {', '.join(self.joints)} on {p['joint_states_topic']} (temperature "
            f"{p['temperature_topic'] or 'none'}); arm model {arm or 'none'}"
            + ((f", a part of {payload:g} kg" if payload > 0 else ", the part's mass fitted per pair") if arm else "")
            + f"; shifts of {float(p['shift_seconds']):g} s from {float(p['shift_origin']):g} s; publishing "
            f"{p['observations_topic']} and {p['status_topic']}")
        if not arm:
            self.get_logger().warning(f"production_observer: {NO_ARM_MODEL}")

    # -- inputs -----------------------------------------------------------------------
    def _lost_callback(self, topic: str) -> Any:
        def cb(info: Any) -> None:
            change = int(info.total_count) - self.lost_messages[topic]
            if change <= 0:
                return
            self.lost_messages[topic] = int(info.total_count)
            self.get_logger().warning(
                f"{change} message(s) on {topic} lost before reaching the production observer "
                f"({info.total_count} in all): the shift's observations rest on fewer samples",
                throttle_duration_sec=2.0)

        return cb

    def _bad(self, reason: str, text: str) -> None:
        self.bad_messages[reason] += 1
        self._bad_in_shift += 1
        self._bad_last = f"{reason}: {text}"
        self.get_logger().warning(f"message skipped ({reason}): {text}; {sum(self.bad_messages.values())} "
                                  "bad message(s) so far", throttle_duration_sec=5.0)

    def _on_joint_state(self, msg: JointState) -> None:
        c0 = time.process_time()
        self._last_rx = time.monotonic()
        stamp = stamp_to_seconds(msg.header.stamp)
        got = self._rows.row(msg.name, msg.position, msg.velocity, msg.effort)
        if isinstance(got[0], str):
            self._bad(str(got[0]), str(got[1]))
        elif not stamp > 0:
            self._bad("no stamp", "a JointState without a header stamp (the observer runs on the stamps)")
        elif not stamp > self._last_js:
            self._bad("stamp not after the previous", f"stamp {stamp:.9f} s after {self._last_js:.9f} s")
        else:
            self._last_js = stamp
            self._held.append((stamp, got[0], got[1], got[2]))
            self._advance(stamp)
        self.cpu_seconds += time.process_time() - c0

    def _on_temperature(self, msg: Temperature) -> None:
        joint = str(msg.header.frame_id)
        stamp = stamp_to_seconds(msg.header.stamp)
        if joint not in self.joints:
            self._bad("temperature of another joint", f"header.frame_id {joint!r} is not one of {self.joints!r}")
            return
        if not self._temps.add(joint, stamp, float(msg.temperature)):
            self._bad("temperature not finite", f"{joint}: {float(msg.temperature)!r} at {stamp:.9f} s")
            return
        self._advance(stamp)

    def _advance(self, stamp: float) -> None:
        """Process the held samples stamped ``reorder_margin`` before the latest message or earlier."""
        self._latest = max(self._latest, stamp)
        limit = self._latest - self._margin
        while self._held and self._held[0][0] <= limit:
            self._process(*self._held.popleft())

    def _flush(self) -> None:
        while self._held:
            self._process(*self._held.popleft())

    def _process(self, t: float, q: Any, v: Any, u: Any) -> None:
        ended = self.clock.on_sample(t)
        if ended is not None:
            self._finish(ended)
        try:
            self.observer.add(t, q, v, u, self._temps.at(t))
        except JointwearError as exc:  # a value beyond any arm's (the rows checked the rest)
            self._bad("value out of range", str(exc))
            return
        self.samples += 1
        self.shift_samples += 1

    # -- shift ends ---------------------------------------------------------------------
    def _on_poll(self) -> None:
        silent = time.monotonic() - self._last_rx
        if self._held and silent >= self._idle:
            self._flush()
        now = self.get_clock().now().nanoseconds * 1e-9
        if self.clock.idle_due(now, silent, self._idle):
            sid = self.clock.end()
            assert sid is not None
            self.get_logger().info(f"production shift {sid}: no JointState for {silent:.1f} s after its end time: "
                                   "the shift ends")
            self._finish(sid)

    def _on_end_shift(self, req: Trigger.Request, resp: Trigger.Response) -> Trigger.Response:
        self._flush()
        sid = self.clock.end()
        if sid is None:
            resp.success = False
            resp.message = "no production shift is being observed (no sample since the last shift ended)"
            return resp
        shift = self._finish(sid)
        resp.success = True
        resp.message = (f"production shift {sid} ended: {len(shift.observations)} observation(s) from "
                        f"{shift.samples} samples")
        return resp

    def _finish(self, sid: int) -> ProductionShift:
        """End shift ``sid`` in the observer and publish its observations and statuses."""
        shift = self.observer.end_shift(sid)
        self.shifts.append(shift)
        running, done = shift_statuses(shift, self.joints)
        for st in running:
            self.status_pub.publish(status_to_msg(st, TestCycleStatus))
        for o in shift.observations:
            self.obs_pub.publish(observation_to_msg(o))
            self.observations_published += 1
        for st in done:
            self.status_pub.publish(status_to_msg(st, TestCycleStatus))
        self.get_logger().info(f"production shift {sid}: {shift.samples} samples, {len(shift.observations)} "
                               f"observation(s)\n{shift.summary()}")
        self._bad_in_shift = 0
        self.shift_samples = 0
        self.health.update()
        return shift

    def on_shutdown(self) -> None:
        """Called by ``run_node`` on exit: let reliable subscribers get the last shift's messages."""
        wait_acked([self.obs_pub, self.status_pub])

    # -- health --------------------------------------------------------------------------
    def _joint_health(self, joint: str, stat: Status) -> None:
        bad = sum(self.bad_messages.values())
        stat.extend([("shift", str(self.clock.current or 0)), ("samples", str(self.samples)),
                     ("held", str(len(self._held))),
                     ("shift_samples", str(self.shift_samples)), ("bad_messages", str(bad)),
                     ("lost_messages", str(sum(self.lost_messages.values()))),
                     ("cpu_us_per_sample", f"{1e6 * self.cpu_seconds / self.samples:.0f}" if self.samples else "")])
        stat.extend((f"bad_{k.replace(' ', '_')}", str(v)) for k, v in sorted(self.bad_messages.items()))
        last = self.shifts[-1] if self.shifts else None
        if last is None:
            message = (f"observing production shift {self.clock.current}; no shift ended yet" if self.clock.current
                       else "no production sample yet")
        else:
            c = last.joints[joint]
            n = sum(1 for o in last.observations if o.joint_name == joint)
            stat.extend([("last_shift", str(last.shift_id)), ("observations", str(n)), ("passes", str(c.passes)),
                         ("paired", str(c.paired)), ("model", str(c.model)), ("rejected", str(c.rejected_total))])
            stat.extend((f"rejected_{k.replace(' ', '_')}", str(v)) for k, v in c.rejected.items())
            stat.extend([("speed_levels", ", ".join(f"{s:.1f}" for s in c.speed_levels)),
                         ("informative", "true" if c.informative else "false")])
            if c.note:
                stat.add("note", c.note)
            message = f"shift {last.shift_id}: " + (c.note or f"{n} observation(s); {c.passes} passes, {c.paired} "
                                                    f"paired, {c.model} model, {c.rejected_total} rejected")
        if self._bad_in_shift:
            stat.summary(DiagnosticLevel.WARN, f"{self._bad_in_shift} bad message(s) in this shift, latest: "
                                               f"{self._bad_last}")
        else:
            stat.summary(DiagnosticLevel.OK, message)

    def health_of(self, joint: str) -> Status:
        """The ``production_observer: <joint>`` status as of now (not published)."""
        stat = Status(f"{self.health.prefix}: {joint}", joint)
        self._joint_health(joint, stat)
        return stat


def observation_to_msg(o: FrictionObservationData) -> FrictionObservation:
    """The message of a production observation (``source: production``; header stamp = ``o.stamp``)."""
    return contract.observation_to_msg(replace(o, source=Source.PRODUCTION.value), FrictionObservation)


def main(args: list[str] | None = None) -> int:
    """Console script ``production_observer``."""
    # rclpy's C++ EventsExecutor: every /joint_states message of the played or live production woke the Python
    # executor (its timer runs on the steady clock)
    return run_node_refusing("production_observer", ProductionObserverNode, args, events=True)


if __name__ == "__main__":
    raise SystemExit(main())
