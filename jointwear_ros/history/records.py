"""The history's records: one wear estimate of one joint, one maintenance event (pure; no database, no ROS).

The store (:mod:`~jointwear_ros.history.store`) writes and reads them, the screening
(:mod:`~jointwear_ros.history.screen`) checks them and the outbox (:mod:`~jointwear_ros.history.outbox`)
keeps them while the store fails; each of those imports this module, none imports another for them.

>>> r = EstimateRecord("robot_1", "joint_1", cycle_id=1, time=1.7e9, wear=10.0, wear_std=0.8)
>>> r.time_ns, r.analysis_version
(1700000000000000000, 'live')
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import __version__
from ..errors import InputDataError

__all__ = ["LIVE", "EstimateRecord", "MaintenanceEvent"]

#: analysis_version of the estimates the cell made (live node, recorded bags, CSV tables)
LIVE = "live"


@dataclass(frozen=True)
class EstimateRecord:
    """One wear estimate of one joint (a row of ``estimates``). ``time`` is seconds since the epoch."""

    robot: str
    joint: str
    cycle_id: int
    time: float
    wear: float
    wear_std: float
    hardware_id: str = ""
    temperature: float = math.nan
    method: str = ""
    params: str = ""
    software_version: str = __version__
    bag: str = ""
    analysis_version: str = LIVE
    source: str = "live"
    #: ``complete`` or ``partial`` (a FAILED/ABORTED cycle or one that missed speeds:
    #: :mod:`jointwear_ros.condition`); an estimate from too few speeds carries no level and is not stored
    evidence: str = "complete"
    #: where the estimate's observations came from: ``test_cycle`` (the dedicated cycle; ``cycle_id`` its id)
    #: or ``production`` (a production shift; ``cycle_id`` the shift's): the WearEstimate's ``source``
    #: (:class:`jointwear_ros.contract.Source`). Not ``source``, which says how the row entered the history.
    cycle_source: str = "test_cycle"
    #: when the estimate was received or recorded (a bag's log time), seconds since the epoch; NaN when
    #: unknown. Not stored: the screening compares it with ``time`` to detect a jumped clock.
    received: float = math.nan

    @property
    def time_ns(self) -> int:
        """The stored time: ns since the epoch, rounded to the microsecond (a float of seconds since the epoch
        keeps microseconds exactly, so the identity survives any float round trip: CSV, JSON, messages)."""
        return round(self.time * 1e6) * 1000

    def check(self, where: str = "estimate") -> EstimateRecord:
        """Raise :class:`InputDataError` unless the record is storable (names, finite wear, std > 0)."""
        if not self.robot or not self.joint:
            raise InputDataError(f"{where}: robot {self.robot!r} and joint {self.joint!r} must be non-empty")
        for name in ("time", "wear", "wear_std"):
            v = float(getattr(self, name))
            if not math.isfinite(v):
                raise InputDataError(f"{where}: {name} = {v!r} is not a finite number")
        if not 0.0 < float(self.wear_std) < 1e6:
            raise InputDataError(f"{where}: wear_std = {self.wear_std!r} must be > 0 (the estimate's standard deviation)")
        if not -1e9 < self.time < 1e11:
            raise InputDataError(f"{where}: time = {self.time!r} is not seconds since the epoch")
        if self.cycle_id < 0 or self.cycle_id >= 2**31:
            raise InputDataError(f"{where}: cycle_id = {self.cycle_id!r} must be in [0, 2^31)")
        if self.cycle_source not in ("test_cycle", "production"):
            raise InputDataError(f"{where}: cycle_source = {self.cycle_source!r} must be 'test_cycle' or 'production'")
        return self


@dataclass(frozen=True)
class MaintenanceEvent:
    """A maintenance event of one joint (regrease, reducer replaced, ...); starts a new trend segment."""

    robot: str
    joint: str
    time: float
    kind: str
    note: str = ""

    @property
    def time_ns(self) -> int:
        return round(self.time * 1e6) * 1000

    def check(self, where: str = "maintenance event") -> MaintenanceEvent:
        if not self.robot or not self.joint or not self.kind:
            raise InputDataError(f"{where}: robot, joint and kind must be non-empty "
                                 f"(got {self.robot!r}, {self.joint!r}, {self.kind!r})")
        if not (math.isfinite(self.time) and -1e9 < self.time < 1e11):
            raise InputDataError(f"{where}: time = {self.time!r} is not seconds since the epoch")
        return self
