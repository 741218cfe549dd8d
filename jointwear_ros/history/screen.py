"""Screening of every estimate before it reaches the history, the trend or a report (pure; no database, no ROS).

One bad value must never hide an alarm: a wear of 1e300 turned a joint at ERROR
into OK with wear NaN, a std of 1e-300 made one estimate outweigh every other,
a stamp ten years ahead became the joint's "current" wear, a controller clock
reset to 2000 sorted the newest estimates into the past. Each estimate is
checked against stated physical bounds (:class:`ScreenConfig`); what fails is
**refused with a reason code** (:data:`REASONS`) and kept in the store's
``refused`` table, never fed to the trend and never lost.

Reasons
-------
``malformed``
    not a storable record at all (NaN/inf, std <= 0, an empty name, a cycle id out of range).
``wear_out_of_range``
    wear outside ``[wear_min, wear_max]`` (the estimators' wear grid is [0, 100]; the bounds leave room
    for noise around it).
``std_out_of_range``
    std outside ``[std_min, std_max]``: an estimate can be no more certain than the measurement allows
    (the suite's estimators report 0.3-2 wear units at the reference noise).
``time_before_min``
    stamped before ``min_time`` (2010-01-01): a controller clock reset (to 2000, to 1970) or a
    simulation clock starting at 0.
``time_in_future``
    stamped more than ``future_tolerance_s`` after now (the screening clock).
``clock_jump``
    the stamp disagrees with the clock that received the estimate (the recorder's log time of the bag)
    by more than ``clock_tolerance_s``, or, live, goes back more than that before the joint's newest
    estimate: the estimator's clock jumped.

>>> from jointwear_ros.history.records import EstimateRecord
>>> now = 1.8e9
>>> ok = EstimateRecord("r", "j", cycle_id=1, time=now - 60, wear=38.0, wear_std=0.8)
>>> screen_record(ok, now=now) is None
True
>>> screen_record(EstimateRecord("r", "j", 2, now, 1e300, 0.8), now=now).reason
'wear_out_of_range'
>>> screen_record(EstimateRecord("r", "j", 3, now, 0.0, 1e-300), now=now).reason
'std_out_of_range'
>>> screen_record(EstimateRecord("r", "j", 4, now + 10 * 365 * 86400, 36.0, 0.8), now=now).reason
'time_in_future'
>>> screen_record(EstimateRecord("r", "j", 5, 946684800.0, 40.0, 0.8), now=now).reason
'time_before_min'
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from ..errors import InputDataError
from .records import EstimateRecord

__all__ = ["REASONS", "Refusal", "ScreenConfig", "screen", "screen_record"]

#: the reason codes of a refused estimate, in the order they are checked
REASONS = ("malformed", "wear_out_of_range", "std_out_of_range", "time_before_min", "time_in_future", "clock_jump")


@dataclass(frozen=True)
class ScreenConfig:
    """The stated bounds of a physically possible estimate (see the module docstring)."""

    wear_min: float = -10.0
    wear_max: float = 150.0
    std_min: float = 1e-3
    std_max: float = 50.0
    #: 2010-01-01T00:00:00Z: nothing of this suite's kind stamped earlier is a real estimate
    min_time: float = 1262304000.0
    future_tolerance_s: float = 3600.0
    clock_tolerance_s: float = 3600.0

    def __post_init__(self) -> None:
        vals = [self.wear_min, self.wear_max, self.std_min, self.std_max, self.min_time,
                self.future_tolerance_s, self.clock_tolerance_s]
        if not all(math.isfinite(float(v)) for v in vals):
            raise InputDataError(f"screening bounds must be finite: {self}")
        if not (self.wear_min < self.wear_max and 0.0 < self.std_min < self.std_max
                and self.future_tolerance_s >= 0.0 and self.clock_tolerance_s > 0.0):
            raise InputDataError(f"screening bounds are inconsistent: {self}")

    def as_dict(self) -> dict[str, float]:
        return {k: float(getattr(self, k)) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class Refusal:
    """An estimate refused by the screening: the record, the reason code and a one-line explanation."""

    record: EstimateRecord
    reason: str
    detail: str

    def as_dict(self) -> dict[str, Any]:
        r = self.record
        return {"robot": r.robot, "joint": r.joint, "cycle_id": int(r.cycle_id), "time": _num(r.time),
                "time_iso": _iso(r.time), "wear": _num(r.wear), "wear_std": _num(r.wear_std),
                "source": r.source, "bag": r.bag, "reason": self.reason, "detail": self.detail}


def _num(x: float) -> float | str:
    x = float(x)
    return x if math.isfinite(x) else repr(x)


def _iso(t: float) -> str:
    try:
        return datetime.fromtimestamp(float(t), UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    except (ValueError, OverflowError, OSError):
        return repr(t)


def screen_record(r: EstimateRecord, *, now: float, cfg: ScreenConfig | None = None,
                  not_before: float | None = None) -> Refusal | None:
    """``None`` when ``r`` may reach the history and the trend, else the :class:`Refusal` with its reason.

    ``now`` is the screening clock (seconds since the epoch); ``r.received`` (when finite) is the time the
    estimate was received or recorded (a bag's log time); ``not_before`` the joint's newest estimate so far
    (live arrival order).
    """
    cfg = cfg or ScreenConfig()
    try:
        r.check(f"{r.robot}/{r.joint} cycle {r.cycle_id}")
    except InputDataError as exc:
        return Refusal(r, "malformed", str(exc))
    w, s, t = float(r.wear), float(r.wear_std), float(r.time)
    if not cfg.wear_min <= w <= cfg.wear_max:
        return Refusal(r, "wear_out_of_range", f"wear {w:.6g} is outside the physical range "
                                               f"[{cfg.wear_min:g}, {cfg.wear_max:g}]")
    if not cfg.std_min <= s <= cfg.std_max:
        return Refusal(r, "std_out_of_range", f"wear_std {s:.6g} is outside the physical range "
                                              f"[{cfg.std_min:g}, {cfg.std_max:g}]")
    if t < cfg.min_time:
        return Refusal(r, "time_before_min", f"stamped {_iso(t)}, before {_iso(cfg.min_time)}: a reset "
                                             "controller clock or a simulation clock starting at 0")
    if t > now + cfg.future_tolerance_s:
        return Refusal(r, "time_in_future", f"stamped {_iso(t)}, {(t - now) / 86400.0:.3g} days after now "
                                            f"({_iso(now)}; tolerance {cfg.future_tolerance_s:g} s)")
    rec = float(getattr(r, "received", math.nan))
    if math.isfinite(rec) and abs(t - rec) > cfg.clock_tolerance_s:
        return Refusal(r, "clock_jump", f"stamped {_iso(t)} but received/recorded at {_iso(rec)} "
                                        f"({(t - rec):+.6g} s; tolerance {cfg.clock_tolerance_s:g} s)")
    if not_before is not None and t < not_before - cfg.clock_tolerance_s:
        return Refusal(r, "clock_jump", f"stamped {_iso(t)}, {(not_before - t):.6g} s before the joint's newest "
                                        f"estimate ({_iso(not_before)}): the estimator's clock went back")
    return None


def screen(records: Iterable[EstimateRecord], *, now: float, cfg: ScreenConfig | None = None
           ) -> tuple[list[EstimateRecord], list[Refusal]]:
    """Split records into (accepted, refused), in their order."""
    ok: list[EstimateRecord] = []
    bad: list[Refusal] = []
    for r in records:
        ref = screen_record(r, now=now, cfg=cfg)
        if ref is None:
            ok.append(r)
        else:
            bad.append(ref)
    return ok, bad


def count_reasons(refusals: Iterable[Refusal | Mapping[str, Any]]) -> dict[str, int]:
    """reason -> count, in :data:`REASONS` order."""
    out: dict[str, int] = {}
    for f in refusals:
        reason = f.reason if isinstance(f, Refusal) else str(f["reason"])
        out[reason] = out.get(reason, 0) + 1
    return {k: out[k] for k in sorted(out, key=lambda k: REASONS.index(k) if k in REASONS else len(REASONS))}
