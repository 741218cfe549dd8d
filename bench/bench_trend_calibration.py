"""Calibration of the time to alarm on the histories a planner meets, before and after issue 23.

Usage: python bench/run_all.py trend_calibration   (or python bench/bench_trend_calibration.py
[--per-family N] [--days D] [--seed S] [--quick] [--trial] [--scores] [--set FIELD=VALUE ...]
[--derive-prior])

Seven families of joints with known true wear (``jointwear_ros.trend.families``: linear,
accelerating (half the paper's exponential shape, half a power law no model has), flat, a step
without a maintenance event, a gap of weeks, irregular cadence, estimate std varying by night),
backtested at every night: the trend sees only the estimates so far. Per family, for two banks:

- *before*: issue 13's bank (random-walk rates q = 1e-5, 1e-4, 1e-3 and the quadratic, equal
  prior weights);
- *after*: issue 23's (the line and the accelerated shapes with an unrecorded step, next to the
  adaptive members; documented prior weights, tempered evidence; ``TrendConfig()``).

Printed: coverage of the 90 % interval (target 85-95 % per family), the share of intervals without
an upper bound, the median width / true time to alarm (target <= 0.6; an unbounded interval counts as
infinitely wide), on linear joints the median width / the straight-line limit (target <= 2), WARN or
ERROR nights on flat joints (target 0), false ERROR nights (ERROR while the true wear is more than 1
below the alarm; target 0), early warnings (WARN/ERROR while the true time to alarm is > 60 days) per
1,000 joint-nights, the median lead of the first WARN before the true crossing. Scored nights: the true
time to alarm 1-365 days; once over every such night, once over those with at least 60 estimates in the
segment (the issue's "history of 60 nightly estimates").

Coverage comes with its standard error, the joint the sampling unit (a joint's nights share one fit and
one truth). Then the issue's own trial (``--trial`` alone): 90 joints, linear, accelerating and flat, each
looked at once at the last of 60 nightly estimates, for issue 13's bank, today's, the bank without each of
its parts (what the width is made of), the fleet prior of linear siblings and the information limit (each
joint's own law known). ``--derive-prior`` alone: the members' prior weights estimated by type-II maximum
likelihood over the reference histories (seeds 0 and 5), against which ``TrendConfig()``'s are checked.

``--trial`` also measures the fleet prior on the trial itself (each joint's prior from its 29 siblings of the
same seed, leave-one-out, pooled as ``--fleet-prior`` does, with type-II weights, or contaminated with
P(unlike siblings)), and on joints unlike their siblings (accelerating among linear).

Per bank, the standard prognostics scores per family next to the 90 % coverage (``--scores`` alone: only
these): alpha-lambda accuracy (alpha 0.2, lambda 0.5) and the prognostic horizon (+-5 % of EoL), as Saxena et
al. (2010) and NASA's progpy define them (docs/prognostics-scores.md). ``--set FIELD=VALUE`` (repeatable) adds a
bank, ``TrendConfig()`` with those settings, to every table and to the trial: a candidate setting measured
without touching the trend's defaults.

Then the fleet prior: young joints (8-20 estimates) whose 30 linear siblings have full histories, at
their last night, with and without :func:`jointwear_ros.trend.fleet_prior` (leave-one-out).
Benchmarks measure; they do not pass or fail.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import fields, replace

import numpy as np

from jointwear_ros.cli.common import format_table
from jointwear_ros.errors import JointwearError
from jointwear_ros.trend import (
    DAY,
    RatePrior,
    TrendConfig,
    analyze_joint,
    bank_members,
    fleet_prior,
    pool_prior,
    sibling_fit,
    trend_states,
    type2_weights,
)
from jointwear_ros.trend.backtest import (
    backtest_joint,
    score_calibration,
    score_prognostics,
    score_trial,
    trial_summary,
)
from jointwear_ros.trend.families import (
    EPOCH0,
    FAMILIES,
    CalibrationJoint,
    make_calibration_set,
    make_family,
    make_trial_set,
)

BEFORE = TrendConfig(accel_noise=(1e-5, 1e-4, 1e-3), jerk_noise=(1e-8,), efold_days=(), prior_line=0.0,
                     prior_accelerated=0.0, evidence_temperature=1.0, step_rate_per_day=0.0)
AFTER = TrendConfig()
#: what the trial's width is made of: the bank without one of its parts (its prior weight to the line)
ABLATIONS = {
    "  without the adaptive members": TrendConfig(prior_line=0.7, accel_noise=(), jerk_noise=()),
    "  without the unrecorded step": TrendConfig(step_rate_per_day=0.0),
    "  without the 60 and 45 d shapes": TrendConfig(efold_days=(160.0, 120.0, 90.0)),
    "  with half the accelerated weight (0.15, line 0.75)": TrendConfig(prior_line=0.75, prior_accelerated=0.15),
    "  untempered evidence": TrendConfig(evidence_temperature=1.0),
    "  the type-II ML prior (--derive-prior)": TrendConfig(prior_line=0.645, prior_accelerated=0.277,
                                                           efold_days=(160.0, 120.0, 90.0), accel_noise=()),
}


def pct(x: float) -> str:
    return "-" if math.isnan(x) else f"{100 * x:.1f}"


def num(x: float, spec: str = ".2f") -> str:
    return "-" if math.isnan(x) else ("inf" if math.isinf(x) else format(x, spec))


def table(score: dict[str, dict[str, float]]) -> str:
    rows = []
    for f in (*FAMILIES, "all"):
        v = score[f]
        rows.append([f, v["joints"], v["scored_nights"], f"{pct(v['coverage'])} ± {pct(v['coverage_se'])}", pct(v["interval_fraction"]),
                     pct(v["unbounded_fraction"]), num(v["median_width_over_true"]),
                     num(v["median_width_over_line"]), v["flat_warn_nights"], v["false_error_nights"],
                     num(v["early_warn_per_1000"]), num(v["median_lead_days"], ".1f"),
                     f"{v['joints_crossing'] - v['joints_missed']}/{v['joints_crossing']}"])
    return format_table(["family", "joints", "nights", "coverage % ± se", "with interval %", "unbounded %",
                         "width/true", "width/line", "flat warn", "false ERROR", "early /1000", "lead d",
                         "warned"], rows)


def scores_table(every: dict[str, dict[str, float]], sixty: dict[str, dict[str, float]],
                 prog: dict[str, dict[str, float]]) -> str:
    """The standard prognostics scores (docs/prognostics-scores.md) per family next to the 90 % coverage."""
    rows = []
    for f in (*FAMILIES, "all"):
        p = prog.get(f, {})
        n_al, n_ph = p.get("alpha_lambda_joints", 0), p.get("ph_joints", 0)
        al = f"{round(p['alpha_lambda'] * n_al)}/{n_al} ({pct(p['alpha_lambda'])})" if n_al else "-"
        alb = f"{round(p['alpha_lambda_beta'] * n_al)}/{n_al} ({pct(p['alpha_lambda_beta'])})" if n_al else "-"
        ph = (f"{num(p['ph_median_days'], '.0f')} ({num(p['ph_median_rel'])}), {p['ph_never']}" if n_ph else "-")
        st = (f"{num(p['ph_stay_median_days'], '.0f')} ({num(p['ph_stay_median_rel'])}), {p['ph_stay_never']}"
              if n_ph else "-")
        rows.append([f, f"{pct(sixty[f]['coverage'])} ± {pct(sixty[f]['coverage_se'])}", pct(every[f]["coverage"]),
                     al, alb, str(n_ph), ph, st])
    return format_table(["family", "coverage % (>= 60 est.)", "coverage % (every night)",
                         "alpha-lambda (a 0.2, l 0.5): median", "beta 0.5", "PH joints", "PH d (/ run), never",
                         "PH staying d (/ run), never"], rows)


def fleet_experiment(seed: int, siblings: int = 30, young: int = 20) -> list[list[str]]:
    """Young joints with and without the fleet prior of their siblings (same type: linear, rate 0.10-0.20)."""
    rng = np.random.default_rng(seed)
    fam = make_family("linear", siblings + young, days=180, seed=seed + 1)
    for j in fam:  # a joint type: rates spread less than the benchmark's 0.06-0.25
        j.rate = float(rng.uniform(0.10, 0.20))
        d = (j.times - EPOCH0) / DAY
        j.wear = j.true_wear(d) + rng.normal(0, 1, len(d)) * j.wear_std
    sibs = [((j.times - j.times[0]) / DAY, j.wear, j.wear_std) for j in fam[:siblings]]
    out = []
    t0 = time.perf_counter()
    pr = fleet_prior(sibs, AFTER)
    t_prior = time.perf_counter() - t0
    assert pr is not None
    robust = replace(pr, unlike=0.4)
    for use in (False, True, "unlike"):
        hits = n = 0
        widths: list[float] = []
        for k, j in enumerate(fam[siblings:]):
            m = 8 + (k % 13)
            # a joint whose history holds only its last m estimates (newly connected), 100-160 days in
            last = int(np.searchsorted(j.times, j.times[0] + (100 + 3 * k) * DAY))
            idx = slice(max(last - m, 0), last)
            t, w, s = j.times[idx], j.wear[idx], j.wear_std[idx]
            r = analyze_joint(t, w, s, cfg=AFTER, prior=robust if use == "unlike" else pr if use else None)
            d_last = (t[-1] - EPOCH0) / DAY
            true = j.segment_crossing(d_last) - d_last
            if not 1.0 <= true <= 365.0:
                continue
            n += 1
            tta = r.time_to_alarm
            if tta is not None and tta.lo90 <= true <= tta.hi90:
                hits += 1
            widths.append((tta.hi90 - tta.lo90) / true if tta is not None else math.inf)
        name = {False: "own estimates only", True: "with fleet prior", "unlike": "fleet prior, P(unlike) 0.4"}[use]
        out.append([name, str(n), pct(hits / n),
                    num(float(np.median(widths)))])
    out.append([f"fleet prior: rate N({pr.mean:.3f}, {pr.std:.3f}²) from {pr.joints} siblings in "
                f"{1000 * t_prior:.0f} ms", "", "", ""])
    return out


def own_law(j: CalibrationJoint) -> TrendConfig:
    """A bank of the joint's true law alone (no step): the line, or its exact accelerated shape; the power law,
    which no member has, gets the whole bank. What the trend could say if it knew which law the joint follows."""
    if j.shape == "linear":
        return TrendConfig(prior_line=1.0, prior_accelerated=0.0, accel_noise=(), jerk_noise=(), step_rate_per_day=0.0)
    if j.shape == "exp":
        return TrendConfig(efold_days=(j.tau,), prior_line=0.0, prior_accelerated=1.0, accel_noise=(), jerk_noise=(),
                           step_rate_per_day=0.0)
    return AFTER


def trial_rows(cfgs: dict[str, TrendConfig]) -> list[list[str]]:
    """The issue's own trial (30 joints per seed, seeds 100-102: linear, accelerating, flat; each seen once at
    the last of estimates 100-159), per bank: coverage, unbounded, median width / true, and where the weight
    sits (median over the growing joints) next to the straight-line limit's width / true."""
    joints = make_trial_set()
    sib = [((j.times[100:160] - j.times[100]) / DAY, j.wear[100:160], j.wear_std[100:160])
           for j in make_family("linear", 20, days=175, seed=200)]
    out = []
    runs: list[tuple[str, TrendConfig | None, RatePrior | None]] = [(name, cfg, None) for name, cfg in cfgs.items()]
    runs.append(("after, fleet prior of 20 linear siblings (linear joints)", AFTER, fleet_prior(sib, AFTER)))
    runs.append(("information limit: each joint's own law known", None, None))
    for name, cfg, prior in runs:
        js = [j for j in joints if j.profile == "linear"] if prior is not None else joints
        if cfg is None:  # the line for a linear joint, its exact accelerated shape for an exponential one
            s = trial_summary([x for j in js for x in score_trial([j], own_law(j), EPOCH0)["rows"]])
        else:
            s = score_trial(js, cfg, EPOCH0, prior=prior)
        grow = [x for x in s["rows"] if x["profile"] != "flat" and 1.0 <= x["true"] <= 365.0]
        med = {k: float(np.median([x[f"w_{k}"] for x in grow])) for k in ("line", "accelerated", "adaptive")}
        out.append([name, str(s["growing"]), pct(s["coverage"]), pct(s["median_within_20pct"]),
                    f"{s['no_interval']} / {s['unbounded']}",
                    num(s["median_width_over_true"]), num(s["median_line_width_over_true"]),
                    *(num(med[k]) for k in ("line", "accelerated", "adaptive")), str(s["flat_warn"])])
    return out


def _trial_rows(rows: list[dict]) -> list[list[str]]:
    out = []
    for fam in ("linear", "accelerating", "all"):
        s = trial_summary([x for x in rows if fam in ("all", x["profile"])])
        out.append([fam, str(s["growing"]), pct(s["coverage"]), f"{s['no_interval']} / {s['unbounded']}",
                    num(s["median_width_over_true"]), str(s["flat_warn"]) if fam == "all" else ""])
    return out


#: the priors the trial's fleet is measured with: none, ``--fleet-prior``'s, empirical Bayes over the weights
FLEET_WAYS = {"default prior (no fleet)": None, "fleet, pooled weights (--fleet-prior)": {"weights": "mean"},
              "fleet, type-II ML weights, floor 0.2": {"weights": "type2", "floor": 0.2},
              "fleet, type-II ML weights, floor 0.5": {"weights": "type2", "floor": 0.5},
              "fleet, pooled, P(unlike siblings) 0.2": {"unlike": 0.2},
              "fleet, pooled, P(unlike siblings) 0.4": {"unlike": 0.4}}


def trial_fleet_rows() -> list[list[str]]:
    """The trial as the fleet it is: each seed's 30 joints (10 linear, 10 accelerating, 10 flat) are one plant's
    joints of one type; each joint's prior comes from its 29 siblings' 60 estimates (leave-one-out: never its own),
    at the same look (the 60th estimate). Per family: coverage, no interval / unbounded, median width / true."""
    rows: dict[str, list[dict]] = {k: [] for k in FLEET_WAYS}
    for seed in (100, 101, 102):
        plant = make_trial_set(seeds=(seed,))
        fits = [sibling_fit((j.times[100:160] - j.times[100]) / DAY, j.wear[100:160], j.wear_std[100:160], AFTER)
                for j in plant]
        for i, j in enumerate(plant):
            sibs = fits[:i] + fits[i + 1:]
            for name, way in FLEET_WAYS.items():
                pr = None if way is None else pool_prior(sibs, AFTER, source=name, **way)
                rows[name] += score_trial([j], AFTER, EPOCH0, prior=pr)["rows"]
    return [[name, *r] for name, rr in rows.items() for r in _trial_rows(rr)]


def unusual_joint_rows() -> list[list[str]]:
    """A joint unlike its siblings: the trial's accelerating joints, each with the prior of 20 linear siblings."""
    fits = [sibling_fit((j.times[100:160] - j.times[100]) / DAY, j.wear[100:160], j.wear_std[100:160], AFTER)
            for j in make_family("linear", 20, days=175, seed=200)]
    acc = [j for j in make_trial_set() if j.profile == "accelerating"]
    out = []
    for name, way in FLEET_WAYS.items():
        pr = None if way is None else pool_prior(fits, AFTER, **way)
        s = score_trial(acc, AFTER, EPOCH0, prior=pr)
        out.append([name, str(s["growing"]), pct(s["coverage"]), f"{s['no_interval']} / {s['unbounded']}",
                    num(s["median_width_over_true"]), ""])
    return out


def unusual_young_rows() -> list[list[str]]:
    """A joint unlike its siblings early in its wear: 20 accelerating joints (the paper's shape, rate 0.06-0.15
    wear/day e-folding in 45-120 days, 60 nightly estimates from w = 5, std 0.85), each with the prior of 20
    linear siblings (0.12-0.18 wear/day, 120 estimates; the tests' siblings); missed: too late / too early."""
    rng = np.random.default_rng(0)
    sib = []
    for _ in range(20):
        rate = rng.uniform(0.12, 0.18)
        sib.append((np.arange(120.0), 5.0 + rate * np.arange(120.0) + rng.normal(0, 0.85, 120), np.full(120, 0.85)))
    fits = [sibling_fit(*x, AFTER) for x in sib]
    out = []
    for name, way in FLEET_WAYS.items():
        pr = None if way is None else pool_prior(fits, AFTER, **way)
        hit, late, early, widths = 0, 0, 0, []
        for rate, tau in ((0.1, 60.0), (0.08, 45.0), (0.12, 90.0), (0.06, 60.0), (0.15, 120.0)):
            for seed in range(4):
                d = np.arange(60.0)
                y = 5 + rate * tau * np.expm1(d / tau) + np.random.default_rng(seed).normal(0, 0.85, 60)
                true = tau * math.log1p(30 / (rate * tau)) - 59.0
                tta = analyze_joint(EPOCH0 + d * DAY, y, np.full(60, 0.85), cfg=AFTER, prior=pr).time_to_alarm
                if tta is None or tta.lo90 > true:
                    late += 1
                elif tta.hi90 < true:
                    early += 1
                else:
                    hit += 1
                widths.append((tta.hi90 - tta.lo90) / true if tta is not None else math.inf)
        out.append([name, "20", f"{hit} / {late} / {early}", num(float(np.median(widths)))])
    return out


#: the candidate bank the default prior weights are estimated over: every member issue 23 considered
CANDIDATES = TrendConfig(efold_days=(160.0, 120.0, 90.0, 60.0, 45.0), accel_noise=(1e-4, 1e-3), jerk_noise=(1e-8,))


def derive_prior(seeds: tuple[int, ...] = (0, 5), per_family: int = 10) -> list[list[str]]:
    """The default prior weights, estimated: type-II maximum likelihood (:func:`type2_weights`) of the candidate
    members' weights over the reference histories (every family, seeds 0 and 5, never the benchmark's seed),
    each looked at after 60 and 120 estimates and at its last, with the members' tempered evidence."""
    members = bank_members(CANDIDATES)
    flat = RatePrior(weights=tuple([1.0] * len(members)))  # equal prior: the posterior is the normalized evidence
    post = []
    for seed in seeds:
        for j in make_calibration_set(per_family, days=180, seed=seed):
            t = (j.times - j.times[0]) / DAY
            looks = sorted({min(59, len(t) - 1), min(119, len(t) - 1), len(t) - 1})
            st = trend_states(t, j.wear, j.wear_std, CANDIDATES, rows=np.array(looks), prior=flat)
            post += list(st.weights.T)
    pi = type2_weights(np.array(post), flat.member_weights(CANDIDATES))
    return [[m.name, f"{w:.3f}"] for m, w in zip(members, pi)]


def config_from_sets(items: list[str]) -> TrendConfig:
    """``TrendConfig()`` with ``FIELD=VALUE`` settings (a tuple field: comma-separated numbers, empty for none);
    a bad name or value raises ``ValueError`` with one line saying which."""
    kinds = {f.name: type(getattr(AFTER, f.name)) for f in fields(TrendConfig)}
    changes: dict[str, object] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep or name not in kinds:
            raise ValueError(f"--set {item!r}: expected FIELD=VALUE with FIELD one of {', '.join(kinds)}")
        try:
            kind = kinds[name]
            changes[name] = (tuple(float(x) for x in value.split(",") if x.strip()) if kind is tuple
                             else kind(value))
        except ValueError:
            raise ValueError(f"--set {item!r}: {value!r} is not a {kinds[name].__name__}") from None
    try:
        return replace(AFTER, **changes)  # type: ignore[arg-type]
    except JointwearError as e:
        raise ValueError(f"--set: {e}") from None


def print_trial(extra: dict[str, TrendConfig] | None = None) -> None:
    print("\nthe issue's trial: 90 joints (seeds 100-102), each at the last of 60 estimates (estimates 100-159)")
    print(format_table(["bank", "growing", "coverage %", "median within 20 %", "no interval / unbounded",
                        "width/true", "line width/true",
                        "weight line", "accelerated", "adaptive", "flat warn"],
                       trial_rows({"before (issue 13 bank)": BEFORE, "after (TrendConfig())": AFTER, **ABLATIONS,
                                   **(extra or {})})))
    head = ["family", "growing", "coverage %", "no interval / unbounded", "width/true", "flat warn"]
    print("\nthe trial as a fleet: each joint's prior from its 29 siblings of the same seed (leave-one-out), "
          "at the 60th estimate")
    print(format_table(["prior", *head], trial_fleet_rows()))
    print("\na joint unlike its siblings: the trial's accelerating joints, each with the prior of 20 linear siblings")
    print(format_table(["prior", *head[1:]], unusual_joint_rows()))
    print("\na joint unlike its siblings early in its wear: 20 accelerating joints, 60 estimates from w = 5, each with "
          "the prior of 20 linear siblings")
    print(format_table(["prior", "joints", "covered / too late / too early", "width/true"], unusual_young_rows()))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-family", type=int, default=20)
    ap.add_argument("--days", type=int, default=180)
    ap.add_argument("--seed", type=int, default=2027)
    ap.add_argument("--quick", action="store_true", help="5 joints per family")
    ap.add_argument("--trial", action="store_true", help="only the issue's trial")
    ap.add_argument("--scores", action="store_true",
                    help="only the coverage and the standard prognostics scores per family (alpha-lambda, PH)")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="a further bank: TrendConfig() with this setting (repeatable; tuples comma-separated), "
                         "scored next to the others and in the trial")
    ap.add_argument("--derive-prior", action="store_true",
                    help="only the estimate of the default prior weights (reference seeds 0 and 5)")
    a = ap.parse_args()
    banks = [("before (issue 13 bank)", BEFORE), ("after (issue 23 bank, TrendConfig())", AFTER)]
    extra: dict[str, TrendConfig] = {}
    if a.set:
        try:
            extra[f"TrendConfig({', '.join(a.set)})"] = config_from_sets(a.set)
        except ValueError as e:
            print(f"bench_trend_calibration: {e}", file=sys.stderr)
            return 2
        banks += list(extra.items())
    if a.derive_prior:
        print("prior weights, type-II maximum likelihood over the reference histories (seeds 0 and 5):")
        print(format_table(["member", "weight"], derive_prior()))
        return 0
    if a.trial:
        print_trial(extra)
        return 0
    n = 5 if a.quick else a.per_family
    joints = [j for i, f in enumerate(FAMILIES) for j in make_family(f, n, days=a.days, seed=a.seed, first=i * n)]
    nights = sum(len(j.times) for j in joints)
    print(f"{len(joints)} joints ({n} per family), {a.days} days, {nights} estimates, seed {a.seed}")
    for name, cfg in banks:
        t0 = time.process_time()
        runs = [backtest_joint(j, cfg, EPOCH0) for j in joints]
        dt = time.process_time() - t0
        cal = {}
        for m in (0, 60):
            cal[m] = s = score_calibration(joints, cfg, EPOCH0, a.days, min_estimates=m, backtests=runs)
            if not a.scores:
                print(f"\n{name}; nights with >= {m} estimates in the segment:")
                print(table(s))
        print(f"{nights / dt:.0f} trend updates (joint-nights) per CPU second")
        print(f"\n{name}: standard prognostics scores, one run per joint (after its last step); alpha-lambda decided "
              "with the median, and with >= 50 % of the distribution in the cone; PH (the median's): +-5 % of the "
              "run's EoL, median over the joints whose alarm falls within the history")
        print(scores_table(cal[0], cal[60], score_prognostics(joints, runs, cfg, beta_criterion=True)))
    if a.scores:
        return 0
    print_trial(extra)
    print("\nfleet prior: young joints (8-20 estimates) at their last night, 30 siblings of the same type")
    print(format_table(["trend", "joints", "coverage %", "median width/true"], fleet_experiment(a.seed)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
