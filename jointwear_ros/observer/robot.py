"""The robot observer: one :class:`FrictionObserverCore` per joint and the routing of the inputs to them.

The ``friction_observer`` node and the offline replay both feed a :class:`RobotObserver`, so the
rules of which joint an input belongs to exist once (docs/robot.md):

- a ``JointState`` is split by name (the name -> index lookup cached per name list; a name given
  twice counts by its first entry); a message with none of the joints, no effort, or arrays whose
  lengths do not match ``name`` is unusable as a whole; a non-finite value skips that joint's sample;
- a cycle status goes to the core of its ``joint_name``, a temperature to the core of its
  ``header.frame_id``; an empty name means the joint of a one-joint setup; a joint not served
  is not routed (the caller counts and logs it);
- a header stamp of 0 is replaced by the caller's clock at receipt (``now``).

It also keeps each joint's health (:class:`JointHealth`, the counts of the node's ``friction_observer: <joint>``
status, :meth:`RobotObserver.health_report`) and the robot's counts of bad, ignored and lost messages:

- a JointState that cannot be used as a whole is one bad message, counted for every joint; a non-finite
  value is one bad message of its joint only; a served joint the message lacks counts ``joint_missing``;
- every observation and rejected window counts for its joint, a finished speed whose temperature reading
  never came (the core's ``temperatures_missing`` grew) is that joint's latest problem;
- a status or temperature naming a joint not served is ignored and counted (the name kept);
- messages lost on a topic count for the robot and are every joint's latest problem (:meth:`RobotObserver.lost`);
- the counts "this cycle" restart when a status of that joint brings a new cycle id (> 0); the totals never do.

Pure; no ROS import, no clock. Each input returns what happened (:class:`Routed`, :class:`JointStateOutcome`)
and the adapter decides what to log and publishes the health.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..contract import CycleStatus, DiagnosticLevel
from .core import FrictionObserverCore, receipt_stamp
from .types import ObserverConfig, ObserverOutput

__all__ = ["HealthReport", "JointHealth", "JointStateOutcome", "RobotObserver", "Routed", "receipt_stamp"]

#: name lists remembered at most (a publisher that changes its names every time)
_INDEX_CACHE_SIZE = 64
#: rejected windows (their reasons) kept, every joint; ``rejections_total`` counts them all
REJECTIONS_KEPT = 1000


@dataclass
class Routed:
    """An input routed to one joint's core: the joint and what its core returned."""

    joint: str
    output: ObserverOutput
    #: a problem this input revealed beyond the output (a speed's temperature reading that never came)
    note: str = ""


@dataclass
class JointStateOutcome:
    """What one ``JointState`` did.

    ``unusable``: why the whole message was skipped ("" when it was used). ``outputs``: each fed
    joint's core output (joints whose core returned nothing are left out). ``skipped``: (joint,
    reason) of joints whose sample was not fed (a non-finite value, the joint missing while it is
    being tested). ``missing``: the served joints the message lacks. ``new_names``: this name list
    was seen for the first time (the adapter warns once per list, not per message).
    """

    unusable: str = ""
    outputs: list[Routed] = field(default_factory=list)
    skipped: list[tuple[str, str]] = field(default_factory=list)
    missing: tuple[str, ...] = ()
    new_names: bool = False

    @property
    def used(self) -> bool:
        return not self.unusable


@dataclass
class JointHealth:
    """The counts of one joint's health (module docstring). ``bad`` counts the bad messages that concern the joint
    (a whole bad message counts for every joint), ``missing`` the JointStates without it; ``marks`` are the
    rejections, bad and lost messages when its current cycle began, ``observations_mark`` its observations then."""

    observations: int = 0
    rejections: int = 0
    bad: int = 0
    missing: int = 0
    cycle_id: int = 0
    marks: tuple[int, int, int] = (0, 0, 0)
    observations_mark: int = 0
    last_problem: str = ""
    temperatures_missing_seen: int = 0


@dataclass(frozen=True)
class HealthReport:
    """One joint's health as of now: the ``DiagnosticStatus`` level, the one-line message and the key/values.

    WARN while the joint's current cycle has had a rejected window, a bad or a lost message (the latest
    reason as the message); OK otherwise."""

    level: DiagnosticLevel
    message: str
    values: tuple[tuple[str, str], ...]


class RobotObserver:
    """One friction observer core per joint (``configs``: joint -> its settings, in serving order)."""

    def __init__(self, configs: Mapping[str, ObserverConfig]) -> None:
        if not configs:
            raise ValueError("the robot observer needs at least one joint")
        self.cores: dict[str, FrictionObserverCore] = {j: FrictionObserverCore(c) for j, c in configs.items()}
        self.joints: list[str] = list(self.cores)
        self._index: dict[tuple[str, ...], tuple[list[tuple[str, int]], tuple[str, ...]]] = {}
        #: each joint's health counts
        self.health: dict[str, JointHealth] = {j: JointHealth() for j in self.joints}
        #: bad messages by kind (the reason up to its first colon)
        self.bad_messages: Counter[str] = Counter()
        #: per topic, messages lost before they reached the adapter
        self.lost_messages: Counter[str] = Counter()
        #: statuses and temperatures naming a joint not served (the names in ``unknown_joints``)
        self.ignored_messages = 0
        self.unknown_joints: set[str] = set()
        #: the last :data:`REJECTIONS_KEPT` rejected windows (``<joint>: <reason>``), every joint
        self.rejections: list[str] = []
        self.rejections_total = 0

    # -- routing -------------------------------------------------------------------
    def route(self, joint: str) -> str | None:
        """The served joint a status or temperature naming ``joint`` is for (empty name: the joint of a
        one-joint setup), or None when this observer does not serve it."""
        if not joint:
            return self.joints[0] if len(self.joints) == 1 else None
        return joint if joint in self.cores else None

    def lookup(self, names: Sequence[str]) -> tuple[list[tuple[str, int]], tuple[str, ...], bool]:
        """(joint, index) of the served joints in ``names``, the served joints missing, and whether
        the list is new (cached per name list)."""
        key = tuple(names)
        hit = self._index.get(key)
        if hit is not None:
            return hit[0], hit[1], False
        at: dict[str, int] = {}
        for i, name in enumerate(key):
            at.setdefault(name, i)  # a name given twice: its first entry, as list.index
        present = [(j, at[j]) for j in self.joints if j in at]
        missing = tuple(j for j in self.joints if j not in at)
        if len(self._index) >= _INDEX_CACHE_SIZE:
            self._index.clear()
        self._index[key] = (present, missing)
        return present, missing, True

    # -- inputs --------------------------------------------------------------------
    def on_joint_state(self, stamp: float, names: Sequence[str], position: Sequence[float],
                       velocity: Sequence[float], effort: Sequence[float], now: float) -> JointStateOutcome:
        """One ``JointState`` (header stamp ``stamp``, 0 = none: ``now`` is used) split into the cores."""
        present, missing, new = self.lookup(names)
        if not present:
            if len(self.joints) == 1:
                why = f"joint {self.joints[0]!r} not in name {list(names)!r}; set joint_name"
            else:
                why = f"none of the joints {self.joints!r} in name {list(names)!r}; set joints"
            return self._unusable(JointStateOutcome(unusable=why, missing=missing, new_names=new))
        n = len(names)
        if len(effort) == 0:
            return self._unusable(JointStateOutcome(
                unusable="no effort: the observer needs the applied torque in JointState.effort", missing=missing,
                new_names=new))
        if len(position) != n or len(velocity) != n or len(effort) != n:
            return self._unusable(JointStateOutcome(
                unusable=f"array lengths: name {n}, position {len(position)}, velocity {len(velocity)}, "
                         f"effort {len(effort)}; each must match name", missing=missing, new_names=new))
        out = JointStateOutcome(missing=missing, new_names=new)
        for j in missing:
            self.health[j].missing += 1
        for j in missing:
            if self.cores[j].active_segment is not None:  # the joint under test is not in the message: a fault
                out.skipped.append((j, f"joint {j!r} not in name {list(names)!r} while it is being tested"))
        t = receipt_stamp(stamp, now)
        for j, i in present:
            p, v, e = float(position[i]), float(velocity[i]), float(effort[i])
            if not (math.isfinite(p) and math.isfinite(v) and math.isfinite(e)):
                out.skipped.append((j, f"non-finite value for {j}: position {p}, velocity {v}, effort {e}"))
                continue
            o = self.cores[j].on_joint_state(t, p, v, e)
            if o.observations or o.rejections:
                out.outputs.append(self._account(j, o))
        for j, reason in out.skipped:
            self._bad(reason, (j,))
        return out

    def _unusable(self, out: JointStateOutcome) -> JointStateOutcome:
        self._bad(out.unusable, self.joints)
        return out

    def on_status(self, status: CycleStatus, now: float) -> Routed | None:
        """A cycle status, to its joint's core (None: a joint not served)."""
        j = self.route(status.joint_name)
        if j is None:
            self._ignore(status.joint_name)
            return None
        output = self.cores[j].on_status(status, now)
        h = self.health[j]
        if status.cycle_id != h.cycle_id and status.cycle_id > 0:  # a new cycle of this joint: its counts restart
            h.cycle_id = int(status.cycle_id)
            h.marks = self.counts(j)
            h.observations_mark = h.observations
            h.last_problem = ""
        return self._account(j, output)

    def on_temperature(self, stamp: float, frame_id: str, celsius: float, now: float) -> Routed | None:
        """A temperature reading of the joint ``frame_id`` names (None: a joint not served)."""
        j = self.route(frame_id)
        if j is None:
            self._ignore(frame_id)
            return None
        return self._account(j, self.cores[j].on_temperature(receipt_stamp(stamp, now), float(celsius)))

    def process_pending(self, silent: float) -> list[Routed]:
        """The finished speeds of each joint whose inputs have been silent for longer than its ``poll_grace``
        (``silent`` s, measured by the adapter) processed now."""
        return [self._account(j, c.process_pending()) for j, c in self.cores.items()
                if c.pending_segments and silent > c.config.poll_grace]

    def flush(self) -> list[Routed]:
        """Every joint's remaining speeds processed (the end of a recording)."""
        return [self._account(j, c.flush()) for j, c in self.cores.items()]

    # -- health ----------------------------------------------------------------------
    def lost(self, topic: str, total: int) -> int:
        """``total`` messages lost on ``topic`` so far (as DDS reports it, possibly repeated): the new ones, counted
        for the robot and every joint's latest problem."""
        change = int(total) - self.lost_messages[topic]
        if change <= 0:
            return 0
        self.lost_messages[topic] += change
        for h in self.health.values():
            h.last_problem = f"{change} message(s) lost on {topic}"
        return change

    def busy_reason(self, joint: str) -> str | None:
        """Why ``joint``'s settings cannot change now (a speed being observed), else None."""
        core = self.cores[joint]
        seg = core.active_segment or next(iter(core.pending_segments), None)
        if seg is None:
            return None
        return (f"{joint}: cycle {seg.cycle_id} speed #{seg.speed_index + 1} is being observed; change the "
                "observer settings between cycles")

    @property
    def observations(self) -> int:
        """Observations made, every joint."""
        return sum(h.observations for h in self.health.values())

    def counts(self, joint: str) -> tuple[int, int, int]:
        """``joint``'s rejected windows, bad messages (temperature readings skipped or missing included) and the
        robot's lost messages, in all."""
        h, core = self.health[joint], self.cores[joint]
        return h.rejections, h.bad + core.temperatures_skipped + core.temperatures_missing, sum(self.lost_messages.values())

    def health_report(self, joint: str) -> HealthReport:
        """``joint``'s health as of now (the adapter adds what only it knows, e.g. its subscribers)."""
        h, core = self.health[joint], self.cores[joint]
        rej, bad, lost = self.counts(joint)
        r0, b0, l0 = h.marks
        values = (("cycle_id", str(h.cycle_id)), ("observations", str(h.observations)),
                  ("rejected_windows", str(rej)), ("bad_messages", str(bad)), ("lost_messages", str(lost)),
                  ("observations_this_cycle", str(h.observations - h.observations_mark)),
                  ("rejected_windows_this_cycle", str(rej - r0)), ("lost_messages_this_cycle", str(lost - l0)),
                  ("samples_seen", str(core.samples_seen)), ("samples_skipped", str(core.samples_skipped)),
                  ("temperatures_skipped", str(core.temperatures_skipped)),
                  ("temperatures_missing", str(core.temperatures_missing)),
                  ("buffered_samples", str(core.buffered_samples)), ("joint_missing", str(h.missing)),
                  ("gear_ratio", f"{core.config.gear_ratio:g}"), ("torque_scale", f"{core.config.torque_scale:g}"),
                  ("ignored_messages", str(self.ignored_messages)))
        if (rej - r0, bad - b0, lost - l0) != (0, 0, 0):
            return HealthReport(DiagnosticLevel.WARN, f"cycle {h.cycle_id}: {rej - r0} window(s) rejected, {bad - b0} "
                                f"bad and {lost - l0} lost message(s); latest: {h.last_problem}", values)
        return HealthReport(DiagnosticLevel.OK, f"{h.observations} observation(s), {rej} window(s) rejected in all",
                            values)

    def _bad(self, reason: str, joints: Sequence[str]) -> None:
        """A bad JointState: counted once, and for each joint it concerns."""
        self.bad_messages[reason.split(":")[0]] += 1
        for j in joints:
            self.health[j].bad += 1
            self.health[j].last_problem = f"bad JointState: {reason}"

    def _ignore(self, joint: str) -> None:
        self.ignored_messages += 1
        self.unknown_joints.add(joint)

    def _account(self, joint: str, out: ObserverOutput) -> Routed:
        """``joint``'s core output counted into its health."""
        h, core = self.health[joint], self.cores[joint]
        h.observations += len(out.observations)
        for r in out.rejections:
            self.rejections.append(f"{joint}: {r}")
            self.rejections_total += 1
            h.rejections += 1
            h.last_problem = f"window rejected: {r}"
        if len(self.rejections) > REJECTIONS_KEPT:
            del self.rejections[:-REJECTIONS_KEPT]
        note = ""
        if core.temperatures_missing > h.temperatures_missing_seen:
            h.temperatures_missing_seen = core.temperatures_missing
            note = h.last_problem = (
                f"no temperature reading within temperature_wait ({core.config.temperature_wait:g} s) after a "
                "speed's end: the sensor stopped or is late; that observation's temperature is unknown")
        return Routed(joint, out, note)
