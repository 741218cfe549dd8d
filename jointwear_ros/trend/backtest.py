"""Backtest the trend at every night of a joint's history against its known true wear.

At each night the trend sees only the estimates so far in the current segment
(after the last maintenance event up to that night), exactly what the
``wear_trend`` node would have said then. Scores over a fleet
(:func:`score_fleet`):

``coverage``
    over nights before the true crossing of the current segment's wear law
    (where the trend gives an interval), the fraction whose 90 % interval
    holds the true time to alarm;
``false_per_1000``
    WARN or ERROR nights per 1,000 joint-nights on joints whose true wear
    never reaches the alarm (within the span plus twice the horizon: a joint
    that crosses 35 days after the last night is not one that "never
    reaches" it, and a 5 % lower bound within 30 days is then expected);
``lead_days``
    for joints that reach the alarm within the span, the days from the first
    WARN (or ERROR) of that segment to the true crossing (median);
``lag_days``
    days from the true crossing to the first ERROR (median; negative: before);
``early_warn_per_1000``
    WARN or ERROR nights, per 1,000 joint-nights of all joints, when the true
    time to alarm was more than twice the horizon away.

Pure numpy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from .core import DAY, ERROR, WARN, TrendConfig, filter_bank, trend_states

__all__ = ["NightlyBacktest", "backtest_joint", "score_at_lead", "score_fleet"]

Array = NDArray[np.float64]


class _Joint(Protocol):
    profile: str
    times: Array
    wear: Array
    wear_std: Array

    @property
    def maintenance_times(self) -> list[float]: ...

    def true_wear(self, day: Array | float) -> Array: ...

    def segment_crossing(self, day: float, alarm: float = 35.0) -> float: ...


@dataclass
class NightlyBacktest:
    """Per night: level, growth, 90 % interval and median (days), the true time to alarm (days)."""

    days: Array
    level: NDArray[np.int_]
    growth: NDArray[np.bool_]
    lo90: Array
    median: Array
    hi90: Array
    true_tta: Array
    true_wear: Array


def backtest_joint(j: _Joint, cfg: TrendConfig, epoch0: float) -> NightlyBacktest:
    """Run the trend as it would have run at every night of ``j``'s history."""
    t = np.asarray(j.times, float)
    n = len(t)
    level = np.zeros(n, int)
    growth = np.zeros(n, bool)
    qs = np.full((n, 3), np.inf)
    bounds = sorted(m for m in j.maintenance_times)
    seg_id = np.searchsorted(np.asarray(bounds, float), t, side="right") if bounds else np.zeros(n, int)
    for s in np.unique(seg_id):
        idx = np.nonzero(seg_id == s)[0]
        bank = filter_bank((t[idx] - t[idx[0]]) / DAY, np.asarray(j.wear)[idx], np.asarray(j.wear_std)[idx], cfg)
        st = trend_states(bank, cfg)
        level[idx], growth[idx], qs[idx] = st.level, st.growth, st.quantiles
    days = (t - epoch0) / DAY
    cross = np.array([j.segment_crossing(float(d), cfg.alarm) for d in days])
    return NightlyBacktest(days=days, level=level, growth=growth, lo90=qs[:, 0], median=qs[:, 1], hi90=qs[:, 2],
                           true_tta=cross - days, true_wear=np.asarray(j.true_wear(days), float))


def score_fleet(joints: Sequence[_Joint], cfg: TrendConfig, epoch0: float, span_days: float) -> dict[str, Any]:
    """The four figures of the fleet benchmark, and counts behind them."""
    covered = total_cov = nights_pred_possible = 0
    widths: list[float] = []
    rel_widths: list[float] = []
    false_nights = never_nights = 0
    false_flat = 0
    leads: list[float] = []
    lags: list[float] = []
    missed = 0
    per_profile: dict[str, dict[str, int]] = {}
    early = all_nights = 0
    for j in joints:
        b = backtest_joint(j, cfg, epoch0)
        all_nights += len(b.days)
        early += int(((b.level >= WARN) & (b.true_tta > 2 * cfg.horizon_days)).sum())
        pp = per_profile.setdefault(j.profile, {"covered": 0, "intervals": 0})
        before = (b.true_wear < cfg.alarm) & np.isfinite(b.true_tta)
        nights_pred_possible += int(before.sum())
        has = before & b.growth & np.isfinite(b.lo90)
        inside = has & (b.lo90 <= b.true_tta) & (b.true_tta <= b.hi90)
        covered += int(inside.sum())
        total_cov += int(has.sum())
        pp["covered"] += int(inside.sum())
        pp["intervals"] += int(has.sum())
        fin = has & np.isfinite(b.hi90)
        widths.extend((b.hi90 - b.lo90)[fin].tolist())
        fin &= b.true_tta >= 1.0
        rel_widths.extend(((b.hi90 - b.lo90)[fin] / b.true_tta[fin]).tolist())
        grid = np.linspace(0.0, span_days + 2 * cfg.horizon_days, 400)
        if float(np.max(j.true_wear(grid))) < cfg.alarm:
            never_nights += len(b.days)
            false_nights += int((b.level >= WARN).sum())
            if j.profile == "flat":
                false_flat += int((b.level >= WARN).sum())
            continue
        # joints that reach the alarm inside the span: lead of the first WARN, lag of the first ERROR
        reached = np.nonzero(b.true_wear >= cfg.alarm)[0]
        if len(reached) == 0:
            continue
        k = int(reached[0])
        d_cross = float(b.days[k] + b.true_tta[k]) if b.true_tta[k] <= 0 else float(b.days[k])
        d_cross = float(b.days[k - 1] + b.true_tta[k - 1]) if k > 0 and math.isfinite(b.true_tta[k - 1]) else d_cross
        seg_start = max([(m - epoch0) / DAY for m in j.maintenance_times if (m - epoch0) / DAY <= d_cross],
                        default=-math.inf)
        in_seg = b.days >= seg_start
        warn = np.nonzero(in_seg & (b.level >= WARN))[0]
        if len(warn) and b.days[warn[0]] <= d_cross:
            leads.append(d_cross - float(b.days[warn[0]]))
        else:
            missed += 1
        err = np.nonzero(in_seg & (b.level >= ERROR))[0]
        if len(err):
            lags.append(float(b.days[err[0]]) - d_cross)
    return {
        "coverage": covered / total_cov if total_cov else math.nan,
        "nights_with_interval": total_cov,
        "nights_before_crossing": nights_pred_possible,
        "interval_fraction": total_cov / nights_pred_possible if nights_pred_possible else math.nan,
        "median_width_days": float(np.median(widths)) if widths else math.nan,
        "median_width_over_true": float(np.median(rel_widths)) if rel_widths else math.nan,
        "false_per_1000": 1000.0 * false_nights / never_nights if never_nights else math.nan,
        "false_nights": false_nights,
        "never_reaching_nights": never_nights,
        "false_flat_nights": false_flat,
        "early_warn_per_1000": 1000.0 * early / all_nights if all_nights else math.nan,
        "median_lead_days": float(np.median(leads)) if leads else math.nan,
        "joints_warned_before_crossing": len(leads),
        "joints_missed": missed,
        "median_lag_days": float(np.median(lags)) if lags else math.nan,
        "coverage_by_profile": {k: (v["covered"] / v["intervals"] if v["intervals"] else math.nan)
                                for k, v in per_profile.items()},
    }


def score_at_lead(joints: Sequence[_Joint], cfg: TrendConfig, epoch0: float,
                  lead_days: float = 60.0) -> dict[str, Any]:
    """Per growing joint, the trend at the first night its true time to alarm is at most ``lead_days``.

    Returns how many joints were scored, the fraction whose 90 % interval holds the true time to alarm
    (a night without an interval counts as a miss), and the median of width / true time to alarm.
    """
    hits = scored = 0
    ratios: list[float] = []
    for j in joints:
        if j.profile == "flat":
            continue
        b = backtest_joint(j, cfg, epoch0)
        k = np.nonzero((b.true_tta <= lead_days) & (b.true_tta > 1.0) & (b.true_wear < cfg.alarm))[0]
        if len(k) == 0:
            continue
        i = int(k[0])
        scored += 1
        if b.growth[i] and b.lo90[i] <= b.true_tta[i] <= b.hi90[i]:
            hits += 1
        ratios.append(float((b.hi90[i] - b.lo90[i]) / b.true_tta[i]) if b.growth[i] else math.inf)
    return {"joints": scored, "coverage": hits / scored if scored else math.nan,
            "median_width_over_true": float(np.median(ratios)) if ratios else math.nan}
