"""A simulated year: wear from production estimates and the test cycle on demand against a nightly test cycle.

Usage: python bench/run_all.py production_year   (or python bench/bench_production_year.py [--seeds N]
[--ratios R ...] [--nights D] [--shifts S] [--std-cycle S] [--quick])

:func:`jointwear_ros.trend.simulate_year` with its default joints (a UR5's six: joint_2 grows linearly and crosses
the alarm 35 at night 180, joint_3 accelerates and crosses at night 224, the other four stay below 30), three
production shifts a day, 10 % of shifts and a five-night changeover of joint_6 without informative motion; the
dedicated cycle's std 0.85 (the joint estimator's, docs/nodes-bag-demo.md) and the production estimate's std a
ratio of it (1.0, 1.5, 2.0: 2 is the most the issue allows). Two schemes on the same draws, both through the live
monitor's level and confirmation rule (``condition.standing`` over its last 8 estimates):

- *nightly*: the dedicated cycle every night;
- *production*: every shift's production estimate, and the dedicated cycle only on the nights the on-demand policy
  (``OnDemandPolicy()``, default settings) asks for it.

Printed per std ratio, over the seeds: per growing joint the true crossing night, the first ERROR night of each
scheme (median and range) and the delay production - nightly (target <= 3 nights; negative: production earlier);
false ERROR nights on the joints that stay below 30 (target 0); dedicated cycles asked (target <= 10 % of nights)
and by reason; CPU time per simulated year. Then the stress case the level rule allows: a flat joint at 29 (1 below
the warning level). Benchmarks measure; they do not pass or fail.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from jointwear_ros.errors import JointwearError
from jointwear_ros.fmt import format_table
from jointwear_ros.trend import WearPath, YearResult, simulate_year
from jointwear_ros.trend.year import DEFAULT_JOINTS, STD_CYCLE


def _span(xs: list[int | None]) -> str:
    v = [x for x in xs if x is not None]
    never = len(xs) - len(v)
    if not v:
        return "never"
    out = f"{int(np.median(v))} ({min(v)}-{max(v)})"
    return out + (f", never in {never}" if never else "")


def summarize(runs: list[YearResult]) -> tuple[list[list[object]], list[list[object]]]:
    r0 = runs[0]
    joints: list[list[object]] = []
    for j in r0.growing:
        delays = [r.delays()[j] for r in runs]
        d = [x for x in delays if x is not None]
        joints.append([j, r0.true_crossing[j], _span([r.nightly.first_error[j] for r in runs]),
                       _span([r.production.first_error[j] for r in runs]),
                       f"{int(np.median(d))} ({min(d)} to {max(d)})" if d else "n/a",
                       sum(1 for x in d if x > 3)])
    asked = [r.production.cycles for r in runs]
    kinds: dict[str, int] = {}
    for r in runs:
        for k, v in r.production.asked_by_kind().items():
            kinds[k] = kinds.get(k, 0) + v
    total: list[list[object]] = [[sum(r.nightly.false_errors for r in runs), sum(r.production.false_errors for r in runs),
              f"{int(np.median(asked))} ({min(asked)}-{max(asked)})",
              f"{100 * np.median(asked) / r0.nights:.1f} ({100 * max(asked) / r0.nights:.1f})",
              ", ".join(f"{k} {v / len(runs):.1f}" for k, v in sorted(kinds.items()))]]
    return joints, total


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    ap.add_argument("--seeds", type=int, default=20, help="years per std ratio (seeds 0..N-1)")
    ap.add_argument("--ratios", type=float, nargs="+", default=[1.0, 1.5, 2.0],
                    help="production std / dedicated cycle std")
    ap.add_argument("--nights", type=int, default=365)
    ap.add_argument("--shifts", type=int, default=3, help="production shifts per day")
    ap.add_argument("--std-cycle", type=float, default=STD_CYCLE, help="the dedicated cycle's wear std")
    ap.add_argument("--quick", action="store_true", help="5 seeds")
    a = ap.parse_args(argv)
    n = 5 if a.quick else a.seeds
    if n < 1:
        print("bench_production_year: --seeds must be >= 1", file=sys.stderr)
        return 2
    print(f"{n} simulated years per ratio, {a.nights} nights, {a.shifts} production shifts a day, "
          f"dedicated cycle std {a.std_cycle:g}; policy: OnDemandPolicy() default settings")
    try:
        for ratio in a.ratios:
            t0 = time.process_time()
            runs = [simulate_year(nights=a.nights, shifts_per_day=a.shifts, std_cycle=a.std_cycle,
                                  std_prod=ratio * a.std_cycle, seed=s) for s in range(n)]
            dt = (time.process_time() - t0) / n
            joints, total = summarize(runs)
            print(f"\nstd ratio {ratio:g} (production std {ratio * a.std_cycle:.2f}), CPU {dt:.2f} s per year")
            print(format_table(["growing joint", "true crossing night", "nightly: first ERROR night",
                                "production: first ERROR night", "delay prod - nightly: median (range)",
                                "years delay > 3"], joints))
            print(format_table(["false ERROR nights, nightly", "false ERROR nights, production",
                                "cycles asked: median (range)", "% of nights: median (max)",
                                "asks per year by reason"], total))
        print("\nstress: joint_5 flat at 29 (1 below the warning level), the rest as above")
        stress = tuple(WearPath("joint_5", 29.0) if p.joint == "joint_5" else p for p in DEFAULT_JOINTS)
        rows = []
        for ratio in a.ratios:
            runs = [simulate_year(stress, nights=a.nights, shifts_per_day=a.shifts, std_cycle=a.std_cycle,
                                  std_prod=ratio * a.std_cycle, seed=s) for s in range(n)]
            rows.append([f"{ratio:g}", sum(r.nightly.false_error_nights["joint_5"] for r in runs),
                         sum(r.production.false_error_nights["joint_5"] for r in runs),
                         sum(1 for r in runs if r.production.false_error_nights["joint_5"]),
                         f"{int(np.median([r.production.cycles for r in runs]))}"])
        print(format_table(["std ratio", "false ERROR nights, nightly", "false ERROR nights, production",
                            f"years (of {n}) with one", "cycles asked: median"], rows))
    except JointwearError as e:
        print(f"bench_production_year: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
