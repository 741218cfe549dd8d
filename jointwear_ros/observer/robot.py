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

Pure; no ROS import. Each input returns what happened (:class:`Routed`, :class:`JointStateOutcome`)
and the adapter decides what to log, count or publish.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from ..contract import CycleStatus
from .core import FrictionObserverCore, receipt_stamp
from .types import ObserverConfig, ObserverOutput

__all__ = ["JointStateOutcome", "RobotObserver", "Routed", "receipt_stamp"]

#: name lists remembered at most (a publisher that changes its names every time)
_INDEX_CACHE_SIZE = 64


@dataclass
class Routed:
    """An input routed to one joint's core: the joint and what its core returned."""

    joint: str
    output: ObserverOutput


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


class RobotObserver:
    """One friction observer core per joint (``configs``: joint -> its settings, in serving order)."""

    def __init__(self, configs: Mapping[str, ObserverConfig]) -> None:
        if not configs:
            raise ValueError("the robot observer needs at least one joint")
        self.cores: dict[str, FrictionObserverCore] = {j: FrictionObserverCore(c) for j, c in configs.items()}
        self.joints: list[str] = list(self.cores)
        self._index: dict[tuple[str, ...], tuple[list[tuple[str, int]], tuple[str, ...]]] = {}

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
            return JointStateOutcome(unusable=why, missing=missing, new_names=new)
        n = len(names)
        if len(effort) == 0:
            return JointStateOutcome(unusable="no effort: the observer needs the applied torque in JointState.effort",
                                     missing=missing, new_names=new)
        if len(position) != n or len(velocity) != n or len(effort) != n:
            return JointStateOutcome(
                unusable=f"array lengths: name {n}, position {len(position)}, velocity {len(velocity)}, "
                         f"effort {len(effort)}; each must match name", missing=missing, new_names=new)
        out = JointStateOutcome(missing=missing, new_names=new)
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
                out.outputs.append(Routed(j, o))
        return out

    def on_status(self, status: CycleStatus, now: float) -> Routed | None:
        """A cycle status, to its joint's core (None: a joint not served)."""
        j = self.route(status.joint_name)
        if j is None:
            return None
        return Routed(j, self.cores[j].on_status(status, now))

    def on_temperature(self, stamp: float, frame_id: str, celsius: float, now: float) -> Routed | None:
        """A temperature reading of the joint ``frame_id`` names (None: a joint not served)."""
        j = self.route(frame_id)
        if j is None:
            return None
        return Routed(j, self.cores[j].on_temperature(receipt_stamp(stamp, now), float(celsius)))

    def process_pending(self, silent: float) -> list[Routed]:
        """The finished speeds of each joint whose inputs have been silent for longer than its ``poll_grace``
        (``silent`` s, measured by the adapter) processed now."""
        return [Routed(j, c.process_pending()) for j, c in self.cores.items()
                if c.pending_segments and silent > c.config.poll_grace]

    def flush(self) -> list[Routed]:
        """Every joint's remaining speeds processed (the end of a recording)."""
        return [Routed(j, c.flush()) for j, c in self.cores.items()]
