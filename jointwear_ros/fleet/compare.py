"""Before and after a re-analysis: which joints' wear level, diagnostic level or time to alarm changed.

:func:`compare_trends` takes the trends of two analysis versions (one
:class:`~jointwear_ros.trend.TrendResult` per joint) and returns one
:class:`JointChange` per joint present in either, with the size of every
change: wear (and the change in units of the two estimates' combined std),
rate, the median time to alarm (days; ``None`` = no growth detected) and the
diagnostic level. A joint *changed* when its level differs, when a time to
alarm appears or disappears, when the median time to alarm moved by more than
``days_tol`` days *and* ``rel_tol`` of itself, or when the wear moved by more
than ``wear_tol``. Pure: no database (:func:`compare_versions` reads the store).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["JointChange", "compare_trends", "compare_versions"]


@dataclass(frozen=True)
class JointChange:
    """One joint before (``*_from``) and after (``*_to``) a re-analysis, and whether that is a change."""

    robot: str
    joint: str
    wear_from: float | None
    wear_to: float | None
    wear_std_from: float | None
    wear_std_to: float | None
    days_from: float | None  # median time to alarm, days; None = no growth detected (or no trend)
    days_to: float | None
    level_from: str | None  # None: the joint has no estimate in that version
    level_to: str | None
    rate_from: float | None
    rate_to: float | None
    changed: bool
    reasons: tuple[str, ...]

    @property
    def wear_change(self) -> float | None:
        if self.wear_from is None or self.wear_to is None:
            return None
        return self.wear_to - self.wear_from

    @property
    def wear_change_std(self) -> float | None:
        """The wear change in units of the two estimates' combined standard deviation."""
        d = self.wear_change
        if d is None or self.wear_std_from is None or self.wear_std_to is None:
            return None
        s = math.hypot(self.wear_std_from, self.wear_std_to)
        return d / s if s > 0 else None

    @property
    def days_change(self) -> float | None:
        if self.days_from is None or self.days_to is None:
            return None
        if math.isinf(self.days_from) and math.isinf(self.days_to):
            return 0.0
        return self.days_to - self.days_from

    def as_dict(self) -> dict[str, Any]:
        return {
            "robot": self.robot, "joint": self.joint, "changed": self.changed, "reasons": list(self.reasons),
            "wear": {"from": self.wear_from, "to": self.wear_to, "change": self.wear_change,
                     "change_in_std": self.wear_change_std},
            "wear_std": {"from": self.wear_std_from, "to": self.wear_std_to},
            "rate_per_day": {"from": self.rate_from, "to": self.rate_to},
            "time_to_alarm_days": {"from": self.days_from, "to": self.days_to, "change": self.days_change},
            "level": {"from": self.level_from, "to": self.level_to},
        }


def _finite(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(v) else v


def _days(t: Any) -> float | None:
    tta = getattr(t, "time_to_alarm", None)
    return None if tta is None else _finite(tta.median)


def compare_trends(before: Sequence[Any], after: Sequence[Any], *, wear_tol: float = 1.0, days_tol: float = 7.0,
                   rel_tol: float = 0.1) -> list[JointChange]:
    """One :class:`JointChange` per (robot, joint) in either list, changed ones first (largest wear change first).

    >>> from types import SimpleNamespace as N
    >>> a = [N(robot="r", joint="j", wear=20.0, wear_std=1.0, rate_per_day=0.1, level_name="OK",
    ...        time_to_alarm=N(median=150.0))]
    >>> b = [N(robot="r", joint="j", wear=26.0, wear_std=1.0, rate_per_day=0.1, level_name="WARN",
    ...        time_to_alarm=N(median=90.0))]
    >>> c = compare_trends(a, b)[0]
    >>> c.changed, c.reasons, c.wear_change, c.days_change
    (True, ('level OK -> WARN', 'time to alarm 150 -> 90 d', 'wear +6.0'), 6.0, -60.0)
    >>> compare_trends(a, a)[0].changed
    False
    """
    f = {(t.robot, t.joint): t for t in before}
    g = {(t.robot, t.joint): t for t in after}
    out = []
    for key in sorted(set(f) | set(g)):
        a, b = f.get(key), g.get(key)
        wa, wb = (_finite(a.wear) if a else None), (_finite(b.wear) if b else None)
        da, db = (_days(a) if a else None), (_days(b) if b else None)
        la, lb = (a.level_name if a else None), (b.level_name if b else None)
        reasons = []
        if a is None or b is None:
            reasons.append("only in " + ("the new" if a is None else "the old") + " version")
        else:
            if la != lb:
                reasons.append(f"level {la} -> {lb}")
            if (da is None) != (db is None):
                reasons.append("time to alarm " + ("appeared" if da is None else "disappeared (no growth)"))
            elif da is not None and db is not None and not (math.isinf(da) and math.isinf(db)):
                d = abs(db - da)
                if d > days_tol and d > rel_tol * min(abs(da), abs(db)):
                    reasons.append(f"time to alarm {da:.0f} -> {db:.0f} d")
            if wa is not None and wb is not None and abs(wb - wa) > wear_tol:
                reasons.append(f"wear {wb - wa:+.1f}")
        out.append(JointChange(
            robot=key[0], joint=key[1], wear_from=wa, wear_to=wb,
            wear_std_from=_finite(a.wear_std) if a else None, wear_std_to=_finite(b.wear_std) if b else None,
            days_from=da, days_to=db, level_from=la, level_to=lb,
            rate_from=_finite(a.rate_per_day) if a else None, rate_to=_finite(b.rate_per_day) if b else None,
            changed=bool(reasons), reasons=tuple(reasons)))
    out.sort(key=lambda c: (not c.changed, -abs(c.wear_change or 0.0), c.robot, c.joint))
    return out


def compare_versions(store: Any, from_version: str, to_version: str, cfg: Any = None,
                     **tolerances: float) -> list[JointChange]:
    """:func:`compare_trends` of two analysis versions in a history store (raises InputDataError for an
    unknown version, naming the versions there are)."""
    from ..errors import InputDataError
    from ..history import trends_from_store

    have = store.analysis_versions()
    for v in (from_version, to_version):
        if v not in have:
            raise InputDataError(f"analysis version {v!r} is not in {store.display_url} "
                                 f"(there: {', '.join(have) or 'none'})")
    before = trends_from_store(store, cfg, analysis_version=from_version)
    after = trends_from_store(store, cfg, analysis_version=to_version)
    return compare_trends(before, after, **tolerances)
