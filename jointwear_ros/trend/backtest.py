"""Backtest the trend at every night of a joint's history against its known true wear.

At each night the trend sees only the estimates so far in the current segment
(after the last maintenance event up to that night), exactly what the
``wear_trend`` node would have said then. Scores over a fleet
(:func:`score_fleet`). "WARN" below is the forecast's signal, the alarm expected within the horizon
(:attr:`~jointwear_ros.trend.states.TrendStates.level`), and "ERROR" the trend's wear at the alarm: what a planner
acts on ahead of time; the condition level (docs/levels.md) is the estimates' own and is not scored here.

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

from ..contract import DiagnosticLevel
from .alarm import crossing_curves, crossing_quantiles, forecast_basis, tau_grid
from .config import DAY, TrendConfig
from .members import Member, RatePrior, bank_members
from .states import trend_states

__all__ = ["NightlyBacktest", "alpha_lambda", "backtest_joint", "joint_run", "lambda_index", "line_limit",
           "prognostic_horizon", "score_at_lead", "score_calibration", "score_fleet", "score_prognostics",
           "score_trial", "trial_summary", "tta_probability"]

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
    count: NDArray[np.int_]  # estimates in the segment so far


def backtest_joint(j: _Joint, cfg: TrendConfig, epoch0: float, prior: RatePrior | None = None) -> NightlyBacktest:
    """Run the trend as it would have run at every night of ``j``'s history."""
    t = np.asarray(j.times, float)
    n = len(t)
    level = np.zeros(n, int)
    growth = np.zeros(n, bool)
    qs = np.full((n, 3), np.inf)
    count = np.zeros(n, int)
    bounds = sorted(m for m in j.maintenance_times)
    seg_id = np.searchsorted(np.asarray(bounds, float), t, side="right") if bounds else np.zeros(n, int)
    for s in np.unique(seg_id):
        idx = np.nonzero(seg_id == s)[0]
        st = trend_states((t[idx] - t[idx[0]]) / DAY, np.asarray(j.wear)[idx], np.asarray(j.wear_std)[idx], cfg,
                          prior=prior)
        level[idx], growth[idx], qs[idx] = st.level, st.growth, st.quantiles
        count[idx] = np.arange(1, len(idx) + 1)
    days = (t - epoch0) / DAY
    crossings = getattr(j, "segment_crossings", None)  # all nights at once, where the joint offers it
    cross = (np.asarray(crossings(days, cfg.alarm), float) if crossings is not None
             else np.array([j.segment_crossing(float(d), cfg.alarm) for d in days]))
    return NightlyBacktest(days=days, level=level, growth=growth, lo90=qs[:, 0], median=qs[:, 1], hi90=qs[:, 2],
                           true_tta=cross - days, true_wear=np.asarray(j.true_wear(days), float), count=count)


def score_fleet(joints: Sequence[_Joint], cfg: TrendConfig, epoch0: float, span_days: float,
                backtests: Sequence[NightlyBacktest] | None = None) -> dict[str, Any]:
    """The four figures of the fleet benchmark, and counts behind them (``backtests``: the joints'
    :func:`backtest_joint` results when already run)."""
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
    for i, j in enumerate(joints):
        b = backtests[i] if backtests is not None else backtest_joint(j, cfg, epoch0)
        all_nights += len(b.days)
        early += int(((b.level >= DiagnosticLevel.WARN) & (b.true_tta > 2 * cfg.horizon_days)).sum())
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
        widths.extend((b.hi90[fin] - b.lo90[fin]).tolist())
        fin &= b.true_tta >= 1.0
        rel_widths.extend(((b.hi90[fin] - b.lo90[fin]) / b.true_tta[fin]).tolist())
        grid = np.linspace(0.0, span_days + 2 * cfg.horizon_days, 400)
        if float(np.max(j.true_wear(grid))) < cfg.alarm:
            never_nights += len(b.days)
            false_nights += int((b.level >= DiagnosticLevel.WARN).sum())
            if j.profile == "flat":
                false_flat += int((b.level >= DiagnosticLevel.WARN).sum())
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
        warn = np.nonzero(in_seg & (b.level >= DiagnosticLevel.WARN))[0]
        if len(warn) and b.days[warn[0]] <= d_cross:
            leads.append(d_cross - float(b.days[warn[0]]))
        else:
            missed += 1
        err = np.nonzero(in_seg & (b.level >= DiagnosticLevel.ERROR))[0]
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
                  lead_days: float = 60.0, backtests: Sequence[NightlyBacktest] | None = None) -> dict[str, Any]:
    """Per growing joint, the trend at the first night its true time to alarm is at most ``lead_days``.

    Returns how many joints were scored, the fraction whose 90 % interval holds the true time to alarm
    (a night without an interval counts as a miss), and the median of width / true time to alarm.
    ``backtests``: the joints' :func:`backtest_joint` results when already run.
    """
    hits = scored = 0
    ratios: list[float] = []
    for i, j in enumerate(joints):
        if j.profile == "flat":
            continue
        b = backtests[i] if backtests is not None else backtest_joint(j, cfg, epoch0)
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


def line_limit(t_days: Array, y: Array, r: Array, cfg: TrendConfig) -> Array:
    """The straight-line limit: per night, the 90 % interval and median (n, 3) of the time to alarm that a
    straight line fitted (weighted least squares, flat prior) to all the estimates so far gives."""
    t = np.asarray(t_days, float)
    w = 1.0 / np.asarray(r, float) ** 2
    out = np.full((len(t), 3), np.inf)
    tau = tau_grid(float(cfg.max_horizon_days))
    C = np.cumsum(np.stack([w, w * t, w * t * t, w * y, w * t * y]), axis=1)
    nights: list[int] = []
    means: list[Array] = []
    covs: list[Array] = []
    for n in range(2, len(t)):
        sw, st, stt, sy, sty = C[:, n]
        tn = t[n]
        # design in (level at t_n, rate): x = [1, t - t_n]
        a11, a12 = sw, st - tn * sw
        a22 = stt - 2 * tn * st + tn * tn * sw
        b1, b2 = sy, sty - tn * sy
        det = a11 * a22 - a12 * a12
        if det <= 1e-12 * max(a11 * a22, 1e-300):
            continue
        cov = np.array([[a22, -a12], [-a12, a11]]) / det
        nights.append(n)
        covs.append(cov)
        means.append(cov @ np.array([b1, b2]))
    # the crossing CDFs of the nights' lines in blocks (crossing_cdf with q = 0), each night's forecast mean a
    # product of its own (the matrix product's last bit depends on its number of rows)
    H, extra = forecast_basis(Member("line", "adaptive", q=0.0, order=2), tau, cfg)
    for b0 in range(0, len(nights), 256):
        m, P = np.array(means[b0:b0 + 256]), np.array(covs[b0:b0 + 256])
        mu = np.concatenate([row[None, :] @ H for row in m])
        out[nights[b0:b0 + 256]] = crossing_quantiles(crossing_curves(m, P, H, extra, cfg.alarm, mu=mu), tau)
    return out


def _cluster_se(per_joint: Sequence[tuple[int, int]]) -> float:
    """Standard error of a coverage pooled over joints (``(nights, covered)`` per joint), the joint the cluster:
    a joint's nights are not independent (one fit, one truth), so a family of 20 joints is 20 samples, not
    thousands of nights (the ratio estimator's linearized variance)."""
    n = np.array([x[0] for x in per_joint], float)
    c = np.array([x[1] for x in per_joint], float)
    k = int((n > 0).sum())
    if k < 2:
        return math.nan
    p = c.sum() / n.sum()
    return float(math.sqrt(k / (k - 1) * float(((c - p * n) ** 2).sum())) / n.sum())


def score_calibration(joints: Sequence[Any], cfg: TrendConfig, epoch0: float, span_days: float,
                      max_true_days: float = 365.0, min_estimates: int = 0,
                      prior: RatePrior | None = None,
                      backtests: Sequence[NightlyBacktest] | None = None) -> dict[str, dict[str, Any]]:
    """Per family (``j.profile``) and ``"all"``: the calibration figures of docs/history-trend.md.

    Scored nights: before the true crossing, with a true time to alarm of 1 to ``max_true_days`` days and at
    least ``min_estimates`` estimates in the segment so far (60: a planner's "history of 60 nightly estimates").
    ``coverage`` over scored nights with an interval (``coverage_se``: its standard error with the joint as
    the sampling unit); ``median_width_over_true`` with an unbounded
    interval counted as infinitely wide; ``width_over_line`` (linear family) the width relative to the
    straight-line limit (:func:`line_limit`); false warnings on joints that never reach the alarm within
    the span plus twice the horizon, and ``early_warn_nights``: WARN or ERROR while the true time to alarm of
    the night's wear law is more than twice the horizon away (a step joint warned before its unrecorded
    replacement is not a false warning); ``false_error_nights``: ERROR while the true wear is more than 1
    below the alarm; lead of the first WARN before the true crossing (median, days). ``backtests``: the
    joints' :func:`backtest_joint` results when already run (to score them twice).
    """
    acc: dict[str, dict[str, Any]] = {}
    for i, j in enumerate(joints):
        b = backtests[i] if backtests is not None else backtest_joint(j, cfg, epoch0, prior)
        for key in (j.profile, "all"):
            a = acc.setdefault(key, {"joints": 0, "nights": 0, "scored": 0, "intervals": 0, "covered": 0,
                                     "unbounded": 0, "rel": [], "line": [], "never_nights": 0, "false_nights": 0,
                                     "false_error_nights": 0, "leads": [], "missed": 0, "crossing_joints": 0,
                                     "early": 0, "flat_warn": 0, "per_joint": []})
            a["joints"] += 1
            a["nights"] += len(b.days)
        ok = ((b.true_wear < cfg.alarm) & (b.true_tta >= 1.0) & (b.true_tta <= max_true_days)
              & (b.count >= min_estimates))
        has = ok & b.growth & np.isfinite(b.lo90)
        inside = has & (b.lo90 <= b.true_tta) & (b.true_tta <= b.hi90)
        rel = (b.hi90[has] - b.lo90[has]) / b.true_tta[has]  # an unbounded interval: inf
        line_ratio: list[float] = []
        if j.profile == "linear":
            lim = line_limit((np.asarray(j.times) - j.times[0]) / DAY, np.asarray(j.wear), np.asarray(j.wear_std), cfg)
            with np.errstate(invalid="ignore"):  # nights without a line interval: inf - inf
                lw = lim[:, 2] - lim[:, 0]
            fin = has & np.isfinite(lw) & (lw > 0)
            line_ratio = ((b.hi90[fin] - b.lo90[fin]) / lw[fin]).tolist()
        grid = np.linspace(0.0, span_days + 2 * cfg.horizon_days, 400)
        never = float(np.max(j.true_wear(grid))) < cfg.alarm
        false_error = int(((b.level >= DiagnosticLevel.ERROR) & (b.true_wear < cfg.alarm - 1.0)).sum())
        lead: float | None = None
        crossing = False
        reached = np.nonzero(b.true_wear >= cfg.alarm)[0]
        if len(reached):
            crossing = True
            k = int(reached[0])
            d_cross = float(b.days[k - 1] + b.true_tta[k - 1]) if k > 0 else float(b.days[k])
            seg0 = getattr(j, "step_day", math.nan)
            seg0 = seg0 if math.isfinite(seg0) and seg0 <= d_cross else -math.inf
            warn = np.nonzero((b.days >= seg0) & (b.level >= DiagnosticLevel.WARN))[0]
            if len(warn) and b.days[warn[0]] <= d_cross:
                lead = d_cross - float(b.days[warn[0]])
        for key in (j.profile, "all"):
            a = acc[key]
            a["scored"] += int(ok.sum())
            a["intervals"] += int(has.sum())
            a["covered"] += int(inside.sum())
            a["per_joint"].append((int(has.sum()), int(inside.sum())))
            a["unbounded"] += int((has & ~np.isfinite(b.hi90)).sum())
            a["rel"] += rel.tolist()
            a["line"] += line_ratio
            a["false_error_nights"] += false_error
            a["early"] += int(((b.level >= DiagnosticLevel.WARN) & (b.true_tta > 2 * cfg.horizon_days)).sum())
            if j.profile == "flat":
                a["flat_warn"] += int((b.level >= DiagnosticLevel.WARN).sum())
            if never:
                a["never_nights"] += len(b.days)
                a["false_nights"] += int((b.level >= DiagnosticLevel.WARN).sum())
            if crossing:
                a["crossing_joints"] += 1
                if lead is None:
                    a["missed"] += 1
                else:
                    a["leads"].append(lead)
    out: dict[str, dict[str, Any]] = {}
    for key, a in acc.items():
        out[key] = {
            "joints": a["joints"], "nights": a["nights"], "scored_nights": a["scored"],
            "interval_fraction": a["intervals"] / a["scored"] if a["scored"] else math.nan,
            "coverage": a["covered"] / a["intervals"] if a["intervals"] else math.nan,
            "coverage_se": _cluster_se(a["per_joint"]),
            "unbounded_fraction": a["unbounded"] / a["intervals"] if a["intervals"] else math.nan,
            "median_width_over_true": float(np.median(a["rel"])) if a["rel"] else math.nan,
            "median_width_over_line": float(np.median(a["line"])) if a["line"] else math.nan,
            "false_per_1000": 1000.0 * a["false_nights"] / a["never_nights"] if a["never_nights"] else math.nan,
            "false_nights": a["false_nights"], "false_error_nights": a["false_error_nights"],
            "early_warn_per_1000": 1000.0 * a["early"] / a["nights"] if a["nights"] else math.nan,
            "flat_warn_nights": a["flat_warn"],
            "median_lead_days": float(np.median(a["leads"])) if a["leads"] else math.nan,
            "joints_crossing": a["crossing_joints"], "joints_missed": a["missed"],
        }
    return out


def score_trial(joints: Sequence[Any], cfg: TrendConfig, epoch0: float, *, first: int = 100, count: int = 60,
                prior: RatePrior | None = None, max_true_days: float = 365.0) -> dict[str, Any]:
    """The planner trial (docs/history-trend.md): each joint looked at once, at the last of its estimates ``first`` to
    ``first + count - 1`` (a history of ``count`` nightly estimates that starts ``first`` estimates into the
    joint's wear). Growing joints (profile not ``flat``) with a true time to alarm of 1 to ``max_true_days``
    days are scored: coverage of the 90 % interval (no interval: a miss), joints without an interval
    (no growth detected), intervals without an upper bound,
    the median width / true time (no interval or unbounded: infinite); flat joints: how many warn. Per joint
    (``rows``): profile, true days, lo90, median, hi90 (nan without an interval), level, the weights on the
    line, on the accelerated shapes and on the adaptive members, and the straight-line limit's width."""
    members = bank_members(cfg)
    kinds = {"line": [i for i, m in enumerate(members) if m.name == "line"],
             "accelerated": [i for i, m in enumerate(members) if m.kind == "steady" and m.name != "line"],
             "adaptive": [i for i, m in enumerate(members) if m.kind == "adaptive"]}
    rows: list[dict[str, Any]] = []
    for j in joints:
        if len(j.times) < first + count:
            raise ValueError(f"{j.robot}/{j.joint}: {len(j.times)} estimates, the trial needs {first + count}")
        sl = slice(first, first + count)
        t, y, r = np.asarray(j.times)[sl], np.asarray(j.wear)[sl], np.asarray(j.wear_std)[sl]
        td = (t - t[0]) / DAY
        st = trend_states(td, y, r, cfg, rows=np.array([len(t) - 1]), prior=prior)
        d = (t[-1] - epoch0) / DAY
        true = float(j.segment_crossing(float(d), cfg.alarm) - d)
        has = bool(st.growth[0]) and math.isfinite(float(st.quantiles[0, 0]))
        lo, med, hi = (float(x) for x in st.quantiles[0]) if has else (math.nan,) * 3
        lim = line_limit(td, y, r, cfg)[-1]
        row = {"profile": j.profile, "true": true, "lo90": lo, "median": med, "hi90": hi, "level": int(st.level[0]),
               "line_width": float(lim[2] - lim[0]) if np.isfinite(lim[[0, 2]]).all() else math.inf}
        row.update({f"w_{k}": float(st.weights[ix, 0].sum()) for k, ix in kinds.items()})
        rows.append(row)
    return trial_summary(rows, max_true_days)


def trial_summary(rows: Sequence[dict[str, Any]], max_true_days: float = 365.0) -> dict[str, Any]:
    """The figures of :func:`score_trial` from its per-joint ``rows`` (rows of several runs may be joined);
    ``median_within_20pct``: the share of growing joints whose median lies within ±20 % of the true time to
    alarm (the α-λ cone, α = 0.2, at the trial's one look)."""
    grow = [x for x in rows if x["profile"] != "flat" and 1.0 <= x["true"] <= max_true_days]
    inside = [math.isfinite(x["lo90"]) and x["lo90"] <= x["true"] <= x["hi90"] for x in grow]
    width = [(x["hi90"] - x["lo90"]) / x["true"] if math.isfinite(x["lo90"]) else math.inf for x in grow]
    line = [x["line_width"] / x["true"] for x in grow]
    # the α-λ cone (α = 0.2) at the trial's one look: the median within (1 ± 0.2) of the true time to alarm
    cone = [math.isfinite(x["median"]) and abs(x["median"] - x["true"]) <= 0.2 * x["true"] for x in grow]
    return {"joints": len(rows), "growing": len(grow),
            "coverage": float(np.mean(inside)) if grow else math.nan,
            "median_within_20pct": float(np.mean(cone)) if grow else math.nan,
            "no_interval": sum(1 for x in grow if math.isnan(x["lo90"])),
            "unbounded": sum(1 for x in grow if math.isfinite(x["lo90"]) and not math.isfinite(x["hi90"])),
            "median_width_over_true": float(np.median(width)) if grow else math.nan,
            "median_line_width_over_true": float(np.median(line)) if grow else math.nan,
            "flat_warn": sum(1 for x in rows if x["profile"] == "flat" and x["level"] >= DiagnosticLevel.WARN),
            "rows": rows}


# ---------------------------------------------------------------------------------------------------------------
# Standard prognostics scores (Saxena, Celaya, Saha, Saha, Goebel, "Metrics for offline evaluation of prognostic
# performance", IJPHM 1 (2010); NASA progpy ``progpy.metrics.alpha_lambda`` / ``prognostic_horizon``).
# The event is the alarm (wear reaching ``TrendConfig.alarm``); its true time is the end of life (EoL); a
# prediction made at time t is a remaining useful life (RUL) r(t), the trend's time to alarm.


def _in_fraction(rul: Array, lo: Array, hi: Array) -> Array:
    """Per prediction (rows of ``rul``, each one point or samples), the fraction of it within [lo, hi]."""
    r = np.asarray(rul, float)
    r2 = r[:, None] if r.ndim == 1 else r
    with np.errstate(invalid="ignore"):
        inside = (r2 >= np.asarray(lo, float)[:, None]) & (r2 <= np.asarray(hi, float)[:, None])
    return np.asarray(inside.mean(axis=1), float)


def lambda_index(t_pred: Array, eol: float, t_start: float, lam: float = 0.5) -> int | None:
    """Index of the prediction α-λ is decided with: the first made at or after t_λ = t_P + λ (EoL − t_P) and
    before EoL (progpy's rule); None when there is none.

    >>> lambda_index(np.array([0.0, 30.0, 55.0, 80.0]), 100.0, 0.0)
    2
    """
    t = np.asarray(t_pred, float)
    k = np.nonzero((t >= t_start + lam * (eol - t_start)) & (t < eol))[0]
    return int(k[0]) if len(k) else None


def alpha_lambda(t_pred: Array, rul_pred: Array, eol: float, t_start: float, *, alpha: float = 0.2,
                 lam: float = 0.5, beta: float = 0.5) -> bool | None:
    """α-λ accuracy of one run: is the RUL predicted at t_λ within (1 ± α) of the true RUL?

    Saxena et al. (2010), Sec. "α-λ accuracy": with t_λ = t_P + λ (EoL − t_P) and the true RUL r*(t) = EoL − t,
    the test holds when (1 − α) r*(t_λ) ≤ r(t_λ) ≤ (1 + α) r*(t_λ), for a distribution when at least β of its
    probability mass lies in that cone (the β-criterion). As in progpy, the prediction used is the first one
    made at or after t_λ (the cone is taken at that prediction's own time).

    Parameters
    ----------
    t_pred : (n,) times of the predictions, ascending (days).
    rul_pred : (n,) point predictions of the RUL (days; ``inf``: no prediction, "never") or (n, m) samples of
        each prediction's RUL distribution.
    eol : the true time of the event (days, same clock).
    t_start : t_P, the time of the first prediction the run is scored from (days).
    alpha, lam, beta : the cone's half-width (relative), where between t_P and EoL the test is made, the share
        of a distribution that must be inside (a point prediction is inside or not).

    Returns
    -------
    True or False; None when no prediction was made between t_λ and EoL (the run cannot be scored).

    Examples
    --------
    True RUL at t = 50 of a run from 0 to EoL 100 is 50; the cone is [40, 60]:

    >>> t = np.arange(0.0, 100.0, 10.0)
    >>> alpha_lambda(t, 100.0 - t, 100.0, 0.0)          # a perfect predictor
    True
    >>> alpha_lambda(t, 100.0 - t + 15.0, 100.0, 0.0)   # 15 days late: 65 at t_λ
    False
    >>> alpha_lambda(t, np.c_[100.0 - t - 5.0, 100.0 - t + 30.0], 100.0, 0.0)  # half the mass inside
    True
    >>> alpha_lambda(t, 100.0 - t, 100.0, 0.0, lam=0.95) is None  # no prediction in [95, 100)
    True
    """
    t = np.asarray(t_pred, float)
    i = lambda_index(t, eol, t_start, lam)
    if i is None:
        return None
    r_true = eol - t[i]
    r = np.asarray(rul_pred, float)[i:i + 1]
    frac = _in_fraction(r, np.array([(1.0 - alpha) * r_true]), np.array([(1.0 + alpha) * r_true]))
    return bool(frac[0] >= beta)


def prognostic_horizon(t_pred: Array, rul_pred: Array, eol: float, *, alpha: float = 0.05, beta: float = 0.5,
                       t_origin: float = 0.0, stay: bool = False) -> float:
    """Prognostic horizon of one run: EoL − the first time the predictions are within ±α·EoL of the truth.

    Saxena et al. (2010), Sec. "Prognostic horizon": PH = EoL − t_{i_α}, i_α the first prediction whose
    predicted EoL (t + r(t)) lies within EoL ± α·EoL (a distribution: at least β of its mass), with the
    *constant* accuracy zone of half-width α·EoL, EoL counted from the run's origin ``t_origin`` (the start
    of the run's life). That is Saxena's definition and what progpy's ``prognostic_horizon`` computes with
    that criterion (its first prediction meeting the criterion before the event). ``stay=True``: the
    stricter reading, the first prediction *from which on* every prediction before EoL is within the zone.

    Parameters
    ----------
    t_pred, rul_pred : as :func:`alpha_lambda` (predictions at or after ``eol`` are ignored).
    eol : the true time of the event.
    alpha, beta : the zone's half-width relative to EoL − ``t_origin``, the share of a distribution inside.
    t_origin : time zero of the run (its EoL is ``eol - t_origin`` long).
    stay : the predictions must stay within the zone until EoL.

    Returns
    -------
    PH in the unit of the times; ``nan`` when no prediction before EoL meets the criterion (progpy: None).

    Examples
    --------
    A run from 0 to EoL 100 (zone: predicted EoL within 100 ± 5):

    >>> t = np.arange(0.0, 100.0, 10.0)
    >>> float(prognostic_horizon(t, 100.0 - t, 100.0))          # perfect: from the first prediction
    100.0
    >>> float(prognostic_horizon(t, 100.0 - t + 20.0, 100.0))   # always 20 days late: never
    nan
    >>> conv = (100.0 - t) * 1.5                                # converging: predicted EoL 150 - t / 2
    >>> float(prognostic_horizon(t, conv, 100.0))               # within 5 from t = 90
    10.0
    >>> wobble = 100.0 - t + np.where(t == 50.0, 9.0, 0.0)      # one prediction out at t = 50
    >>> float(prognostic_horizon(t, wobble, 100.0)), float(prognostic_horizon(t, wobble, 100.0, stay=True))
    (100.0, 40.0)
    """
    t = np.asarray(t_pred, float)
    r = np.asarray(rul_pred, float)
    keep = t < eol
    t, r = t[keep], r[keep]
    if len(t) == 0:
        return math.nan
    half = alpha * (eol - t_origin)
    r_true = eol - t
    ok = _in_fraction(r, r_true - half, r_true + half) >= beta
    if stay:
        # from index i on, all within: the suffix of ``ok`` that is all True
        bad = np.nonzero(~ok)[0]
        first = int(bad[-1]) + 1 if len(bad) else 0
        if first >= len(t):
            return math.nan
    else:
        hit = np.nonzero(ok)[0]
        if len(hit) == 0:
            return math.nan
        first = int(hit[0])
    return float(eol - t[first])


def tta_probability(j: Any, cfg: TrendConfig, night: int, lo: float, hi: float,
                    prior: RatePrior | None = None) -> float:
    """P(``lo`` <= time to alarm <= ``hi`` days) under the trend's whole time-to-alarm distribution at night
    index ``night`` of ``j``'s history, the segment run as :func:`backtest_joint` runs it: the mixture of its
    members' crossing CDFs (the distribution whose 5, 50 and 95 % points are the backtest's ``lo90``, ``median``
    and ``hi90``), for the β-criterion of :func:`alpha_lambda`. Mass beyond ``cfg.max_horizon_days`` is "never"."""
    from scipy.special import ndtr

    t = np.asarray(j.times, float)
    bounds = sorted(j.maintenance_times)
    seg = np.searchsorted(np.asarray(bounds, float), t, side="right") if bounds else np.zeros(len(t), int)
    idx = np.nonzero(seg == seg[night])[0]
    st = trend_states((t[idx] - t[idx[0]]) / DAY, np.asarray(j.wear)[idx], np.asarray(j.wear_std)[idx], cfg,
                      rows=np.array([night - idx[0]]), prior=prior, keep=True)
    members = bank_members(cfg)
    tau = tau_grid(float(cfg.max_horizon_days))
    F = np.zeros(len(tau))
    for c in st.mixtures[0]:
        # the component's wear tau days ahead is N(mean @ H, H' cov H + extra); P(crossed by tau) is the running
        # maximum of P(above the alarm at tau), as the trend's own quantiles are computed
        H, extra = forecast_basis(members[c.member], tau, cfg)
        v = np.einsum("ig,ij,jg->g", H, c.cov, H) + extra
        above = ndtr((c.mean @ H - cfg.alarm) / np.sqrt(np.maximum(v, 1e-12)))
        F += c.weight * np.maximum.accumulate(above)
    return float(np.interp(hi, tau, F, right=F[-1]) - np.interp(lo, tau, F, left=0.0))


def joint_run(j: Any, b: NightlyBacktest, alarm: float) -> tuple[NDArray[np.int_], float, float] | None:
    """The run a joint's backtest is scored over: the nights of its last segment (after the last recorded
    maintenance or unrecorded step, ``j.step_day``), the run's first night t_P and its true EoL (the day the
    wear law of that segment reaches ``alarm``; may lie after the last night). None when the wear is at the
    alarm already at t_P."""
    days = b.days
    marks = [(m - float(j.times[0]) + days[0] * DAY) / DAY for m in j.maintenance_times]
    step = getattr(j, "step_day", math.nan)
    if isinstance(step, float) and math.isfinite(step):
        marks.append(step)
    start = max([m for m in marks if m <= days[-1]], default=-math.inf)
    idx = np.nonzero(days >= start)[0]
    if len(idx) == 0:
        return None
    t_p = float(days[idx[0]])
    eol = float(j.segment_crossing(t_p, alarm))
    if not eol > t_p:
        return None
    return idx, t_p, eol


def score_prognostics(joints: Sequence[Any], backtests: Sequence[NightlyBacktest], cfg: TrendConfig, *,
                      alpha: float = 0.2, lam: float = 0.5, ph_alpha: float = 0.05, beta: float = 0.5,
                      beta_criterion: bool = False,
                      prior: RatePrior | None = None) -> dict[str, dict[str, Any]]:
    """Per family (``j.profile``) and ``"all"``: α-λ accuracy and prognostic horizon of the trend's time to
    alarm, one run per joint (:func:`joint_run`), the prediction of each night the trend's *median* (a point
    prediction; a night without a time to alarm, no growth detected, predicts "never").

    ``alpha_lambda``: the fraction of the scoreable joints (a night between t_λ and EoL in the history) that
    pass :func:`alpha_lambda` (α = ``alpha``, λ = ``lam``, decided with the median); ``alpha_lambda_joints``
    how many were scoreable. ``ph_*``: over the joints whose EoL falls within their history (whose every
    prediction up to the event is seen), the median prognostic horizon (days; a joint never within the zone
    counts 0), the median PH / (EoL − t_P), how many joints never entered the zone; ``ph_stay_*`` the same with
    ``stay=True``. The zone: ±``ph_alpha``·(EoL − t_P). With ``beta_criterion`` also
    ``alpha_lambda_beta``: α-λ decided with the β-criterion on the trend's whole distribution at the same night
    (:func:`tta_probability` of the cone ≥ ``beta``; a night without growth detected fails), which re-runs the
    trend once per joint.
    """
    acc: dict[str, dict[str, list[Any]]] = {}
    for j, b in zip(joints, backtests):
        rows = [acc.setdefault(k, {"al": [], "alb": [], "ph": [], "ph_rel": [], "stay": [], "stay_rel": []})
                for k in (j.profile, "all")]
        run = joint_run(j, b, cfg.alarm)
        if run is None:
            continue
        idx, t_p, eol = run
        t = b.days[idx]
        rul = np.where(b.growth[idx] & np.isfinite(b.lo90[idx]), b.median[idx], np.inf)
        al = alpha_lambda(t, rul, eol, t_p, alpha=alpha, lam=lam)
        alb: bool | None = None
        k = lambda_index(t, eol, t_p, lam)
        if beta_criterion and k is not None:
            night = int(idx[k])
            r_true = eol - float(t[k])
            alb = bool(np.isfinite(rul[k])) and tta_probability(
                j, cfg, night, (1 - alpha) * r_true, (1 + alpha) * r_true, prior) >= beta
        seen = eol <= float(b.days[-1]) + 1.0
        ph = prognostic_horizon(t, rul, eol, alpha=ph_alpha, t_origin=t_p) if seen else math.nan
        ph_s = prognostic_horizon(t, rul, eol, alpha=ph_alpha, t_origin=t_p, stay=True) if seen else math.nan
        for a in rows:
            if al is not None:
                a["al"].append(al)
            if alb is not None:
                a["alb"].append(alb)
            if seen:
                for key, v in (("ph", ph), ("stay", ph_s)):
                    a[key].append(0.0 if math.isnan(v) else v)
                    a[key + "_rel"].append(0.0 if math.isnan(v) else v / (eol - t_p))
    out: dict[str, dict[str, Any]] = {}
    for key, a in acc.items():
        out[key] = {
            "alpha_lambda": float(np.mean(a["al"])) if a["al"] else math.nan,
            "alpha_lambda_joints": len(a["al"]),
            "alpha_lambda_beta": float(np.mean(a["alb"])) if a["alb"] else math.nan,
            "ph_joints": len(a["ph"]),
            "ph_median_days": float(np.median(a["ph"])) if a["ph"] else math.nan,
            "ph_median_rel": float(np.median(a["ph_rel"])) if a["ph_rel"] else math.nan,
            "ph_never": sum(1 for v in a["ph"] if v == 0.0),
            "ph_stay_median_days": float(np.median(a["stay"])) if a["stay"] else math.nan,
            "ph_stay_median_rel": float(np.median(a["stay_rel"])) if a["stay_rel"] else math.nan,
            "ph_stay_never": sum(1 for v in a["stay"] if v == 0.0),
        }
    return out
