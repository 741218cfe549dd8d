"""The trend of one joint: current wear and rate, time to alarm with a 90 % interval, a level (pure numpy/scipy).

:func:`analyze_joint` takes a joint's estimates and maintenance events and puts the parts together: the
current segment (:mod:`~jointwear_ros.trend.segments`), the bank's model-averaged states
(:mod:`~jointwear_ros.trend.states`) and the time to alarm (:mod:`~jointwear_ros.trend.alarm`).

**Condition level and forecast** (two quantities, :mod:`jointwear_ros.condition`): the *condition
level* (``diagnostic_msgs/DiagnosticStatus`` bytes) is the one rule of the suite applied to the joint's
standing estimate (the newest confirmed one of the segment: an estimate far from it is held
``unconfirmed`` and left out of the trend until the next one confirms it as a step or refutes it as an
outlier; estimates from too few speeds carry no level), exactly what the wear_estimator publishes for
the same sequence; STALE when the segment has no estimate. The *forecast* is the time to alarm: *alarm
expected within* ``horizon_days`` when growth is detected and the 90 % interval's lower bound is within
it; when the rate is not credibly positive there is no time to alarm: *no growth detected*. The forecast
never changes the condition level. Fewer than ``min_estimates`` estimates in the current segment give no
trend.

>>> import numpy as np
>>> t = 1.7e9 + 86400.0 * np.arange(60)
>>> w = 10.0 + 0.3 * np.arange(60)
>>> r = analyze_joint(t, w, np.full(60, 0.85))
>>> round(r.rate_per_day, 2), r.level_name, round(r.time_to_alarm.median), r.forecast.text
(0.3, 'OK', 24, 'alarm expected within 30 days')
>>> max(r.time_to_alarm.model_weights, key=r.time_to_alarm.model_weights.get)
'line'
>>> analyze_joint(t, np.full(60, 12.0), np.full(60, 0.85)).time_to_alarm is None
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..condition import INSUFFICIENT, Forecast, forecast_of, standing
from ..contract import DiagnosticLevel, level_name
from ..errors import InputDataError
from .alarm import TimeToAlarm
from .config import DAY, Array, TrendConfig
from .filters import FilterOutput, kalman_llt, rts_smooth
from .members import Component, Member, RatePrior, bank_members
from .segments import collapse_revisions, current_segment, last_segment, revision_keys
from .states import trend_states, unbounded_reason

__all__ = ["TrendResult", "analyze_joint"]


@dataclass
class TrendResult:
    """The trend of one joint (its current segment)."""

    robot: str
    joint: str
    estimates: int
    estimates_total: int
    wear: float
    wear_std: float
    rate_per_day: float
    rate_std: float
    time_to_alarm: TimeToAlarm | None
    level: int
    message: str
    growth_detected: bool
    last_time: float
    segment_start: float
    segments: int
    filtered: FilterOutput | None = None
    smoothed: FilterOutput | None = None
    times: Array = field(default_factory=lambda: np.zeros(0))
    wears: Array = field(default_factory=lambda: np.zeros(0))
    wear_stds: Array = field(default_factory=lambda: np.zeros(0))
    model_weights: dict[str, float] = field(default_factory=dict)
    step_probability: float = 0.0
    step_time: float = math.nan
    components: list[Component] = field(default_factory=list)
    members: list[Member] = field(default_factory=list)
    prior: RatePrior | None = None
    #: the forecast (time to alarm, alarm expected within the horizon); its own quantity, not the level
    forecast: Forecast | None = None
    #: the estimate the condition level stands on, its evidence, and the newest estimate's confirmation
    level_wear: float = math.nan
    level_wear_std: float = math.nan
    evidence: str = ""
    confirmation: str = ""
    #: estimates of the segment left out of the trend: held (unconfirmed) or refuted (outlier): times, wear, std
    held: tuple[tuple[float, float, float, str], ...] = ()

    @property
    def level_name(self) -> str:
        return level_name(self.level)

    @property
    def alarm_expected(self) -> bool:
        return bool(self.forecast is not None and self.forecast.expected_within_horizon)

    def as_dict(self) -> dict[str, Any]:
        """The ``trend --json`` contract (plus a few extra keys)."""
        return {
            "robot": self.robot, "joint": self.joint, "estimates": self.estimates,
            "wear": self.wear, "wear_std": self.wear_std, "rate_per_day": self.rate_per_day,
            "time_to_alarm_days": None if self.time_to_alarm is None else self.time_to_alarm.as_dict(),
            "level": self.level_name,
            "rate_std_per_day": self.rate_std, "growth_detected": self.growth_detected,
            "estimates_total": self.estimates_total, "segments": self.segments,
            "last_time": self.last_time, "segment_start": self.segment_start, "message": self.message,
            "step_probability": self.step_probability,
            "condition": {"level": self.level_name, "wear": _num(self.level_wear),
                          "wear_std": _num(self.level_wear_std), "evidence": self.evidence or None,
                          "newest_estimate": self.confirmation or None,
                          "held": [{"time": h[0], "wear": h[1], "wear_std": h[2], "status": h[3]} for h in self.held]},
            "forecast": None if self.forecast is None else self.forecast.as_dict(),
            "alarm_expected": self.alarm_expected,
            "fleet_prior": None if self.prior is None or self.prior.source == "default" else self.prior.as_dict(),
        }


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def analyze_joint(
    times: Array | Sequence[float],
    wear: Array | Sequence[float],
    wear_std: Array | Sequence[float],
    *,
    cycle_ids: Array | Sequence[int] | None = None,
    maintenance_times: Sequence[float] = (),
    cfg: TrendConfig | None = None,
    robot: str = "",
    joint: str = "",
    smooth: bool = False,
    prior: RatePrior | None = None,
    evidence: Sequence[str] | None = None,
    sources: Sequence[str] | None = None,
) -> TrendResult:
    """The trend of one joint from its estimates (times in seconds since the epoch); ``prior``: a fleet prior;
    ``evidence``: each estimate's (``complete``, ``partial``, ``insufficient``; default complete); ``sources``:
    each estimate's (``test_cycle``, ``production``; default test_cycle): the estimates of both sources make one
    trend, and a production shift is never taken for a revision of the test cycle with the same id."""
    cfg = cfg or TrendConfig()
    if sources is not None:
        cycle_ids = revision_keys(np.zeros(len(times), int) if cycle_ids is None else cycle_ids,
                                  sources).tolist()
    t, w, s, total, seg_start, segs = current_segment(times, wear, wear_std, cycle_ids, maintenance_times, cfg,
                                             f"{robot}/{joint}")
    ev = _segment_evidence(times, cycle_ids, maintenance_times, evidence, cfg)
    n_all = len(t)
    if n_all == 0:
        return TrendResult(robot, joint, 0, total, math.nan, math.nan, math.nan, math.nan, None,
                           DiagnosticLevel.STALE, "no estimates since the last maintenance event", False, math.nan,
                           seg_start, segs, prior=prior, forecast=forecast_of(None, None, None, False, False,
                                                                              cfg.horizon_days))
    days = (t - t[0]) / DAY
    cond = standing(w.tolist(), s.tolist(), days.tolist(), ev, cfg.warn, cfg.alarm)
    out = {i: st_i for i, st_i in enumerate(cond.statuses) if st_i in ("unconfirmed", "outlier", INSUFFICIENT)}
    held = tuple((float(t[i]), float(w[i]), float(s[i]), out[i]) for i in sorted(out))
    fit = np.array([i for i in range(n_all) if i not in out], dtype=int)
    last_time = float(t[-1])
    t, w, s = t[fit], w[fit], s[fit]
    n = len(t)
    level = int(DiagnosticLevel.STALE if cond.level is None else cond.level)
    lv_ev = "" if cond.index is None else ev[cond.index]
    if n == 0:
        return TrendResult(robot, joint, 0, total, math.nan, math.nan, math.nan, math.nan, None, level,
                           cond.reason, False, last_time, seg_start, segs, prior=prior,
                           forecast=forecast_of(None, None, None, False, False, cfg.horizon_days),
                           level_wear=cond.wear, level_wear_std=cond.wear_std, evidence=lv_ev,
                           confirmation=cond.newest_status, held=held)
    members = bank_members(cfg)
    st = trend_states((t - t[0]) / DAY, w, s, cfg, rows=np.array([n - 1]), prior=prior, keep=True)
    qs = st.quantiles
    growth = bool(st.growth[0])
    wear_now, wear_sd = float(st.wear[0]), float(st.wear_std[0])
    rate, rate_sd = float(st.rate[0]), float(st.rate_std[0])
    weights = {m.name: round(float(x), 4) for m, x in zip(members, st.weights[:, 0])}
    comps = st.mixtures[0]
    step_p = float(st.step_probability[0])
    step_time = math.nan
    if step_p >= 0.5:
        by_k: dict[int, float] = {}
        for c in comps:
            if c.step_at >= 0:
                by_k[c.step_at] = by_k.get(c.step_at, 0.0) + c.weight
        step_time = float(t[max(by_k, key=lambda k: by_k[k])])
    adaptive = [i for i, m in enumerate(members) if m.kind == "adaptive"]
    f = None
    if adaptive:
        best = max(adaptive, key=lambda i: st.weights[i, 0])
        m = members[best]
        f = kalman_llt((t - t[0]) / DAY, w, s, cfg, m.q, m.order, prior)
    tta: TimeToAlarm | None
    if wear_now >= cfg.alarm:
        tta = TimeToAlarm(0.0, 0.0, 0.0, weights)
        fmsg = f"the trend's wear {wear_now:.1f} ± {wear_sd:.1f} is at or above the alarm {cfg.alarm:g}"
    elif n < cfg.min_estimates:
        tta = None
        fmsg = f"{n} estimate(s) in this segment: a trend needs {cfg.min_estimates}"
    elif not growth:
        tta = None
        fmsg = f"no growth detected (rate {rate:+.3f} ± {rate_sd:.3f} /day); trend wear {wear_now:.1f} ± {wear_sd:.1f}"
    else:
        reason = unbounded_reason(st, 0, members, cfg)
        tta = TimeToAlarm(float(qs[0, 1]), float(qs[0, 0]), float(qs[0, 2]), weights, reason)
        fmsg = (f"alarm {cfg.alarm:g} in {_days(tta.median)} (90 %: {_days(tta.lo90)} to {_days(tta.hi90)}); "
                f"trend wear {wear_now:.1f} ± {wear_sd:.1f}, rate {rate:+.3f} /day")
        if reason:
            fmsg += f"; no upper bound: {reason}"
    fc = forecast_of(None if tta is None else tta.median, None if tta is None else tta.lo90,
                     None if tta is None else tta.hi90, growth, n >= cfg.min_estimates, cfg.horizon_days)
    if fc.expected_within_horizon and fc.state == "within_horizon":
        fmsg = f"alarm expected within {cfg.horizon_days:g} days: " + fmsg
    msg = f"{cond.reason}; forecast: {fmsg}"
    if step_p >= 0.5:
        from datetime import UTC, datetime

        msg += (f"; a step in the estimates at {datetime.fromtimestamp(step_time, UTC):%Y-%m-%d} without a "
                f"maintenance event (P = {step_p:.2f}): the trend follows the estimates after it")
    return TrendResult(
        robot=robot, joint=joint, estimates=n, estimates_total=total, wear=wear_now, wear_std=wear_sd,
        rate_per_day=rate, rate_std=rate_sd, time_to_alarm=tta, level=level, message=msg,
        growth_detected=growth, last_time=last_time, segment_start=float(seg_start), segments=segs,
        filtered=f, smoothed=rts_smooth(f, cfg) if (smooth and f is not None) else None, times=t, wears=w,
        wear_stds=s, model_weights=weights, step_probability=step_p, step_time=step_time, components=comps,
        members=members, prior=prior, forecast=fc, level_wear=cond.wear, level_wear_std=cond.wear_std,
        evidence=lv_ev, confirmation=cond.newest_status, held=held,
    )


def _segment_evidence(times: Any, cycle_ids: Any, maintenance_times: Sequence[float],
                      evidence: Sequence[str] | None, cfg: TrendConfig) -> list[str]:
    """The evidence of the estimates :func:`current_segment` keeps, in its order."""
    t = np.asarray(times, float)
    if evidence is None:
        ev = np.array(["complete"] * len(t), dtype=object)
    else:
        ev = np.array([str(x) or "complete" for x in evidence], dtype=object)
        if len(ev) != len(t):
            raise InputDataError(f"evidence has {len(ev)} entries for {len(t)} estimates")
    if not len(t):
        return []
    cid = np.zeros(len(t), int) if cycle_ids is None else np.asarray(cycle_ids)
    keep = collapse_revisions(t, cid, cfg.revision_window_s)
    first, _, _ = last_segment(t[keep], maintenance_times)
    return [str(x) for x in ev[keep][first:]]


def _days(x: float) -> str:
    return "unbounded" if not math.isfinite(x) else f"{x:.0f} d"
