"""The plant's view of the trend: one row per joint with its level, as the page, the API and the metrics show it.

Pure Python over :class:`~jointwear_ros.trend.TrendResult` (no web framework, no database): the same
function decides the level for ``jointwear trend --json``, the plant page, ``/api/joints`` and
``/metrics``, so they cannot disagree.

**Levels** (``diagnostic_msgs/DiagnosticStatus`` bytes): the joint's *condition level* OK (0), WARN (1) and
ERROR (2), the one rule of :mod:`jointwear_ros.condition` that the wear_estimator, the trend and
``estimate`` apply too; the *forecast* ("alarm expected within ``horizon_days``") is a separate field
(``alarm_expected``, ``forecast``) and never raises the level; **STALE** (3) when the joint's newest estimate (any segment) is older than ``stale_days``
and the trend's level is not ERROR: an alarm is never hidden by age, but a joint that has gone
silent is not shown as fine either. A joint whose history the trend refuses (:class:`InputDataError`)
is STALE too, with the reason: there is no current estimate anyone should trust.

>>> plant_level(DiagnosticLevel.OK, last_time=0.0, now=8 * DAY, stale_days=7), plant_level(DiagnosticLevel.ERROR, 0.0, 8 * DAY, 7)
(3, 2)
>>> level_name(plant_level(DiagnosticLevel.WARN, last_time=0.0, now=6 * DAY, stale_days=7))
'WARN'
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from ..condition import plant_level
from ..contract import DiagnosticLevel, level_name, level_rank
from ..errors import InputDataError
from ..trend import DAY, TrendConfig, TrendResult, analyze_joint

__all__ = [
    "JointHistory",
    "JointView",
    "SourceSummary",
    "analyze_plant",
    "joint_view",
    "level_counts",
    "plant_level",
    "rank_views",
    "refused_view",
    "source_summary",
]



@dataclass(frozen=True)
class JointHistory:
    """What the trend takes for one joint (times in s since the epoch, ascending)."""

    robot: str
    joint: str
    times: Sequence[float]
    wear: Sequence[float]
    wear_std: Sequence[float]
    cycle_ids: Sequence[int]
    maintenance_times: Sequence[float] = ()
    #: the parameter set the newest estimate names (whether its wear scale is calibrated is shown)
    params: str = ""
    #: each estimate's evidence (``complete``/``partial``); None: all complete
    evidence: Sequence[str] | None = None
    #: each estimate's source (``test_cycle``/``production``, the WearEstimate's); None: all test cycles
    sources: Sequence[str] | None = None


@dataclass(frozen=True)
class JointView:
    """One joint as the plant sees it. Times in s since the epoch, durations in days; NaN/None: unknown."""

    robot: str
    joint: str
    level: int
    trend_level: int
    wear: float
    wear_std: float
    rate_per_day: float
    time: float  # the newest estimate (any segment)
    age_days: float
    days_to_alarm: float | None  # median; inf = beyond the prediction horizon; None = no growth / no trend
    days_to_alarm_low: float | None
    days_to_alarm_high: float | None
    estimates: int
    estimates_total: int
    message: str
    refused: str = ""  # why the trend refused this joint's history ("" when it did not)
    #: stored estimates of the joint the history's screening refused (impossible values, bad times): never
    #: part of the trend, so one bad row cannot hide an alarm; counted so that someone looks
    rows_refused: int = 0
    #: whether the newest estimate's wear scale is calibrated (known wear levels), a prior (False), or unknown
    calibrated: bool | None = None
    #: the forecast: the alarm expected within the horizon, and its state (condition.Forecast.state)
    alarm_expected: bool = False
    forecast: str = ""
    #: the estimate the level stands on, its evidence, and the newest estimate's confirmation
    level_wear: float = math.nan
    level_wear_std: float = math.nan
    evidence: str = ""
    confirmation: str = ""
    #: the newest estimate's source (``test_cycle``/``production``; "" unknown) and, per source, its estimates
    #: (:func:`source_summary`: count, newest time, wear and std)
    newest_source: str = ""
    sources: tuple[tuple[str, SourceSummary], ...] = ()

    @property
    def level_name(self) -> str:
        return level_name(self.level)

    def as_api(self) -> dict[str, Any]:
        """``/api/joints`` row: the documented keys first (docs/plant.md) (level as its name, nulls where unknown), then extras."""

        def num(x: float | None) -> float | None:
            return None if x is None or not math.isfinite(x) else float(x)

        return {
            "robot": self.robot, "joint": self.joint, "level": self.level_name, "wear": num(self.wear),
            "wear_std": num(self.wear_std), "time": num(self.time), "days_to_alarm": num(self.days_to_alarm),
            "days_to_alarm_low": num(self.days_to_alarm_low), "days_to_alarm_high": num(self.days_to_alarm_high),
            "trend_level": level_name(self.trend_level), "age_days": num(self.age_days),
            "rate_per_day": num(self.rate_per_day), "estimates": self.estimates,
            "estimates_total": self.estimates_total, "message": self.message, "refused": self.refused or None,
            "rows_refused": self.rows_refused, "wear_scale_calibrated": self.calibrated,
            "alarm_expected": self.alarm_expected, "forecast": self.forecast or None,
            "level_wear": num(self.level_wear), "level_wear_std": num(self.level_wear_std),
            "evidence": self.evidence or None, "newest_estimate": self.confirmation or None,
            "newest_source": self.newest_source or None,
            "sources": {name: s.as_api() for name, s in self.sources},
        }


@dataclass(frozen=True)
class SourceSummary:
    """One source's estimates of a joint: how many, the newest's time (s since the epoch), wear and std."""

    estimates: int
    newest_time: float
    wear: float
    wear_std: float

    def as_api(self) -> dict[str, Any]:
        def num(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {"estimates": self.estimates, "newest_time": num(self.newest_time), "wear": num(self.wear),
                "wear_std": num(self.wear_std)}


def source_summary(times: Sequence[float], wear: Sequence[float], wear_std: Sequence[float],
                   sources: Sequence[str] | None) -> tuple[str, tuple[tuple[str, SourceSummary], ...]]:
    """The newest estimate's source and, per source present (test_cycle first), its :class:`SourceSummary`.

    >>> newest, per = source_summary([1.0, 2.0, 3.0], [10.0, 11.0, 12.0], [1.0, 2.0, 1.5],
    ...                              ["test_cycle", "production", "test_cycle"])
    >>> newest, [(name, s.estimates, s.wear) for name, s in per]
    ('test_cycle', [('test_cycle', 2, 12.0), ('production', 1, 11.0)])
    """
    src = list(sources) if sources is not None else ["test_cycle"] * len(times)
    if not len(times):
        return "", ()
    newest = max(range(len(times)), key=lambda i: float(times[i]))
    out: list[tuple[str, SourceSummary]] = []
    for name in ("test_cycle", "production", *sorted(set(src) - {"test_cycle", "production"})):
        idx = [i for i, s in enumerate(src) if s == name]
        if not idx:
            continue
        k = max(idx, key=lambda i: float(times[i]))
        out.append((name, SourceSummary(len(idx), float(times[k]), float(wear[k]), float(wear_std[k]))))
    return src[newest], tuple(out)


def joint_view(r: TrendResult, newest_time: float, now: float, stale_days: float) -> JointView:
    """The plant's row of one trend result; ``newest_time`` is the joint's newest estimate (any segment)."""
    tta = r.time_to_alarm
    level = plant_level(r.level, newest_time, now, stale_days)
    age = (now - newest_time) / DAY if math.isfinite(newest_time) else math.nan
    msg = r.message
    if level == DiagnosticLevel.STALE:
        msg = f"no estimate for {age:.1f} days (stale after {stale_days:g}); last trend: {r.level_name}, {msg}"
    return JointView(
        robot=r.robot, joint=r.joint, level=level, trend_level=int(r.level), wear=r.wear, wear_std=r.wear_std,
        rate_per_day=r.rate_per_day, time=newest_time, age_days=age,
        days_to_alarm=None if tta is None else tta.median, days_to_alarm_low=None if tta is None else tta.lo90,
        days_to_alarm_high=None if tta is None else tta.hi90, estimates=r.estimates,
        estimates_total=r.estimates_total, message=msg, alarm_expected=r.alarm_expected,
        forecast="" if r.forecast is None else r.forecast.state, level_wear=r.level_wear,
        level_wear_std=r.level_wear_std, evidence=r.evidence, confirmation=r.confirmation,
    )


def refused_view(robot: str, joint: str, reason: str, newest_time: float, now: float, n: int) -> JointView:
    """A joint whose history the trend refused: STALE with the reason (no number is shown as current)."""
    age = (now - newest_time) / DAY if math.isfinite(newest_time) else math.nan
    return JointView(robot, joint, int(DiagnosticLevel.STALE), int(DiagnosticLevel.STALE), math.nan, math.nan, math.nan, newest_time, age,
                     None, None, None, 0, n, f"history refused by the trend: {reason}", refused=reason)


def analyze_plant(histories: Iterable[JointHistory], cfg: TrendConfig, now: float, stale_days: float,
                  smooth: bool = False) -> list[tuple[JointView, TrendResult | None]]:
    """The trend and the plant's row of every joint (a refused history gives a row and ``None``)."""
    out: list[tuple[JointView, TrendResult | None]] = []
    for h in histories:
        newest = max((float(t) for t in h.times), default=math.nan)
        try:
            r = analyze_joint(h.times, h.wear, h.wear_std, cycle_ids=h.cycle_ids,
                              maintenance_times=h.maintenance_times, cfg=cfg, robot=h.robot, joint=h.joint,
                              smooth=smooth, evidence=h.evidence, sources=h.sources)
        except InputDataError as exc:
            out.append((refused_view(h.robot, h.joint, str(exc), newest, now, len(h.times)), None))
            continue
        view = joint_view(r, newest, now, stale_days)
        newest_source, per_source = source_summary(h.times, h.wear, h.wear_std, h.sources)
        out.append((replace(view, calibrated=calibrated_of(h.params), newest_source=newest_source,
                            sources=per_source), r))
    return out


def calibrated_of(params: str) -> bool | None:
    """Whether the wear scale of the set ``params`` names is calibrated (None: unknown here)."""
    from ..estimation.wear_scale import wear_scale_of

    scale = wear_scale_of(params)
    return None if scale is None else bool(scale.calibrated)


def rank_views(views: Iterable[JointView]) -> list[JointView]:
    """ERROR first, then WARN, STALE, OK (:func:`~jointwear_ros.contract.level_rank`); within a level the alarm
    expected within the horizon first, then the soonest time to alarm, then by name."""

    def key(v: JointView) -> tuple[int, int, float, str, str]:
        t = v.days_to_alarm
        return (-level_rank(v.level), 0 if v.alarm_expected else 1, math.inf if t is None or math.isnan(t) else t,
                v.robot, v.joint)

    return sorted(views, key=key)


def level_counts(views: Iterable[JointView]) -> dict[str, int]:
    """Joints per level name (every level present, zeros included)."""
    counts = {level_name(lv): 0 for lv in DiagnosticLevel}
    for v in views:
        counts[v.level_name] += 1
    return counts
