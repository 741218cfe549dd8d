"""The robot monitor: one :class:`WearMonitor` per joint and the routing of observations and statuses to them.

The ``wear_estimator`` node and the offline replay both feed a :class:`RobotMonitor`: an
observation goes to the monitor of its ``joint_name``, a cycle status to the monitor of its
``joint_name`` with its source (a robot cycle tests its joints one after another under one cycle id: each joint's
monitor sees the RUNNING -> DONE stream of a one-joint cycle); an empty name means the joint of a
one-joint setup, a joint not served is not routed (None: the caller counts and logs it). Timeouts
run on the caller's clock (``now``). Pure; no ROS import.
"""

from __future__ import annotations

from collections.abc import Mapping

from ..contract import CycleStatus, Source
from ..observer.types import FrictionObservationData
from .core import CycleResult, EstimatorFactory, MonitorConfig, WearMonitor

__all__ = ["RobotMonitor"]


class RobotMonitor:
    """One wear monitor per joint (``configs``: joint -> its settings, in serving order)."""

    def __init__(self, configs: Mapping[str, MonitorConfig], estimator_factory: EstimatorFactory | None = None) -> None:
        if not configs:
            raise ValueError("the robot monitor needs at least one joint")
        self.monitors: dict[str, WearMonitor] = {j: WearMonitor(c, estimator_factory) for j, c in configs.items()}
        self.joints: list[str] = list(self.monitors)

    def route(self, joint: str) -> str | None:
        """The served joint an observation or status naming ``joint`` is for (empty name: the joint of a
        one-joint setup), or None when it is not served."""
        if not joint:
            return self.joints[0] if len(self.joints) == 1 else None
        return joint if joint in self.monitors else None

    def add(self, observation: FrictionObservationData, now: float) -> list[CycleResult] | None:
        """An observation, to its joint's monitor (None: a joint not served)."""
        j = self.route(observation.joint_name)
        if j is None:
            return None
        return self.monitors[j].add(observation, now=now)

    def on_status(self, status: CycleStatus, now: float, source: str = Source.TEST_CYCLE) -> list[CycleResult] | None:
        """A cycle status of ``source`` (``/test_cycle/status``: test_cycle; ``/production/status``: production),
        to its joint's monitor at ``now`` (None: a joint not served)."""
        j = self.route(status.joint_name)
        if j is None:
            return None
        return self.monitors[j].on_status(status, now, source)

    def poll(self, now: float) -> list[CycleResult]:
        """Every joint's timeouts at ``now``."""
        return [r for m in self.monitors.values() for r in m.poll(now)]

    def finish(self, now: float) -> list[CycleResult]:
        """The end of the input: every open cycle estimated (polled past its joint's timeouts)."""
        out: list[CycleResult] = []
        for m in self.monitors.values():
            cfg = m.config
            out.extend(m.poll(now + cfg.done_timeout + cfg.idle_timeout + 1.0))
        return out
