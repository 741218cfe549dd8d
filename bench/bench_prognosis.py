"""Prognosis on a synthetic fleet: is the time to alarm honest, are there false alarms, how early is the WARN?

Usage: python bench/run_all.py prognosis   (or python bench/bench_prognosis.py [--joints N] [--days D]
[--seed S] [--calibrate])

A fleet of joints (linear, accelerating, flat, maintained; nightly estimates
with the joint estimator's calibrated noise, ``jointwear_ros.data.fleet``) is
backtested at every night: the trend sees only the estimates so far, as the
``wear_trend`` node would. Printed, with issue 13's targets:

- coverage of the 90 % time-to-alarm interval over all nights that have one
  (target >= 90 %), per profile, and the share of nights before the crossing
  that have an interval (the rest: no growth detected yet);
- the same at the night each growing joint's true time to alarm reaches the
  30-day horizon (the acceptance test: >= 80 %, median width <= true time);
- false WARN/ERROR per 1,000 joint-nights on joints that never reach 35
  (target <= 1) and early WARN/ERROR (true time to alarm > 60 days) per 1,000
  joint-nights of all joints;
- median lead time of the first WARN before the true crossing, and the alarm
  lag (first ERROR after the crossing);
- the standard prognostics scores per profile next to its coverage: alpha-lambda accuracy (alpha 0.2,
  lambda 0.5) and the prognostic horizon (docs/prognostics-scores.md);
- the cost: trend updates per second (one update = one joint-night), and the
  history store: writing the fleet to SQLite and the trend of every joint from it.

``--calibrate`` first re-runs the estimator-noise calibration (the real joint
estimator on simulated cycles) and prints it. Benchmarks measure; they do not
pass or fail.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

from jointwear_ros.cli.common import format_table
from jointwear_ros.data.fleet import EPOCH0, calibrate_estimator_noise, make_fleet
from jointwear_ros.history import EstimateRecord, HistoryStore, MaintenanceEvent, trends_from_store
from jointwear_ros.trend import TrendConfig
from jointwear_ros.trend.backtest import backtest_joint, score_at_lead, score_fleet, score_prognostics


def pct(x: float) -> str:
    return "n/a" if math.isnan(x) else f"{100 * x:.1f} %"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--joints", type=int, default=200)
    ap.add_argument("--days", type=int, default=240)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--calibrate", action="store_true")
    a = ap.parse_args()

    if a.calibrate:
        cal = calibrate_estimator_noise(wears=(2, 5, 10, 15, 20, 27, 35, 45), runs=40)
        print("estimator noise (joint estimator, 8 speeds, T in {32, 40, 48} degC, 40 cycles per point):")
        fit = cal["fit"]
        print(format_table(["wear", "rms error", "reported std"],
                           [[w, e, r] for w, e, r in zip(fit.wears, fit.actual, fit.reported)], ".2f"))

    cfg = TrendConfig()
    fleet = make_fleet(n_joints=a.joints, days=a.days, seed=a.seed)
    nights = sum(len(j.times) for j in fleet)
    t0 = time.perf_counter()
    runs = [backtest_joint(j, cfg, EPOCH0) for j in fleet]
    dt = time.perf_counter() - t0
    s = score_fleet(fleet, cfg, EPOCH0, a.days, backtests=runs)
    lead = score_at_lead(fleet, cfg, EPOCH0, lead_days=cfg.horizon_days)
    print(f"fleet: {a.joints} joints ({', '.join(sorted({j.profile for j in fleet}))}), {a.days} nights each, "
          f"{nights} estimates, seed {a.seed}; horizon {cfg.horizon_days:g} days, alarm {cfg.alarm:g}")
    rows = [
        ["coverage of the 90 % interval, every night", pct(s["coverage"]), ">= 90 %"],
        *[[f"  {k}", pct(v), ""] for k, v in sorted(s["coverage_by_profile"].items())],
        ["nights before the crossing with an interval", pct(s["interval_fraction"]), ""],
        ["median width / true time to alarm, every night", f"{s['median_width_over_true']:.2f}", ""],
        [f"coverage at true time to alarm <= {cfg.horizon_days:g} d ({lead['joints']} joints)",
         pct(lead["coverage"]), ">= 80 %"],
        ["  median width / true time there", f"{lead['median_width_over_true']:.2f}", "<= 1"],
        ["false WARN/ERROR per 1,000 joint-nights (never reach 35)", f"{s['false_per_1000']:.2f}", "<= 1"],
        ["  of them on flat joints (nights)", str(s["false_flat_nights"]), "0"],
        ["early WARN/ERROR per 1,000 joint-nights (true time > 60 d)", f"{s['early_warn_per_1000']:.2f}", ""],
        ["median lead of the first WARN before the crossing, days", f"{s['median_lead_days']:.1f}", ""],
        ["  joints warned before / missed", f"{s['joints_warned_before_crossing']} / {s['joints_missed']}", ""],
        ["median alarm lag (first ERROR after the crossing), days", f"{s['median_lag_days']:.2f}", ""],
        ["trend updates per second (backtest, one joint-night each)", f"{nights / dt:.0f}", ""],
    ]
    print(format_table(["figure", "value", "target"], rows))
    prog = score_prognostics(fleet, runs, cfg, beta_criterion=True)
    print("standard prognostics scores (docs/prognostics-scores.md), one run per joint after its last maintenance: "
          "alpha-lambda (alpha 0.2, lambda 0.5) with the median and with >= 50 % of the distribution in the cone; "
          "prognostic horizon of the median, +-5 % of the run's EoL, over the joints whose alarm falls within the span")
    prows = []
    for k in (*sorted(s["coverage_by_profile"]), "all"):
        p = prog.get(k, {})
        n_al, n_ph = p.get("alpha_lambda_joints", 0), p.get("ph_joints", 0)
        prows.append([k, pct(s["coverage_by_profile"].get(k, s["coverage"])),
                      f"{round(p['alpha_lambda'] * n_al)}/{n_al}" if n_al else "-",
                      f"{round(p['alpha_lambda_beta'] * n_al)}/{n_al}" if n_al else "-", str(n_ph),
                      f"{p['ph_median_days']:.0f} ({p['ph_median_rel']:.2f})" if n_ph else "-",
                      f"{p['ph_stay_median_days']:.0f} ({p['ph_stay_median_rel']:.2f})" if n_ph else "-"])
    print(format_table(["profile", "coverage (every night)", "alpha-lambda, median", "beta 0.5", "PH joints",
                        "PH d (/ run)", "PH staying d (/ run)"], prows))

    with tempfile.TemporaryDirectory() as d:
        store = HistoryStore(Path(d) / "fleet.db")
        recs = [EstimateRecord(j.robot, j.joint, cycle_id=int(c), time=float(t), wear=float(w), wear_std=float(sd))
                for j in fleet for c, t, w, sd in zip(j.cycle_ids, j.times, j.wear, j.wear_std)]
        t0 = time.perf_counter()
        added = store.add_estimates(recs)
        t_write = time.perf_counter() - t0
        for j in fleet:
            for m in j.maintenance_times:
                store.add_maintenance(MaintenanceEvent(j.robot, j.joint, m, "regrease"))
        t0 = time.perf_counter()
        trends = trends_from_store(store, cfg)
        t_trend = time.perf_counter() - t0
        again = store.add_estimates(recs)
        store.close()
    print(f"history store (SQLite, WAL): {added} estimates written in {t_write:.1f} s ({added / t_write:.0f}/s), "
          f"written again: {again} added; trend of all {len(trends)} joints from the store in {t_trend:.2f} s "
          f"({1000 * t_trend / max(len(trends), 1):.0f} ms per joint)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
