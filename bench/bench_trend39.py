"""CPU cost of the trend's core, this checkout against another (issue 29: the quick tier; stop 39's speed-ups).

Usage: python bench/bench_trend39.py [--against DIR] [--runs N]

``DIR``: a checkout of another commit, e.g. ``git archive 0486d97 | tar -x -C /tmp/before`` (the code before
stop 39's speed-ups). Each tree is measured in its own process (its package imported from that tree) N times
(default 3); printed: the minimum CPU seconds (user + system of the process, which a shared machine disturbs
less than wall time; the minimum is the run the other processes disturbed least) of

- ``fleet``: the model-averaged trend at every night of the 40 joints of ``test_trend_core``'s fleet (240
  days, seed 11; ``trend_states`` of each segment, what ``backtest_joint`` spends its time in), and the
  joint-nights per CPU second;
- ``calibration``: ``test_trend_bank``'s calibration backtest (12 joints of four families over 150 days, with
  each night's true time to alarm) and its scores with the straight-line limit;
- ``siblings``: 40 sibling fits of 120 nightly estimates (the fleet prior: the trend at one night);

and, with ``--against``, the ratio of the other tree's to this one's.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys
import numpy as np
from jointwear_ros.data.fleet import make_fleet
from jointwear_ros.trend import DAY, TrendConfig, sibling_fit, trend_states
from jointwear_ros.trend.backtest import backtest_joint, score_calibration
from jointwear_ros.trend.families import EPOCH0, FAMILIES, make_family

def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime

cfg = TrendConfig()
fleet = make_fleet(n_joints=40, days=240, seed=11)
cal = [j for i, f in enumerate(FAMILIES) if f in ("linear", "accelerating", "flat", "step")
       for j in make_family(f, 3, days=150, seed=5, first=3 * i)]
rng = np.random.default_rng(0)
sibs = [(np.arange(120.0), 5 + rng.uniform(0.05, 0.2) * np.arange(120.0) + rng.normal(0, 0.85, 120),
         np.full(120, 0.85)) for _ in range(40)]
out = {}
c = cpu()
nights = 0
for j in fleet:
    t = np.asarray(j.times, float)
    seg = np.searchsorted(np.asarray(sorted(j.maintenance_times), float), t, side="right")
    for s in np.unique(seg):
        idx = np.nonzero(seg == s)[0]
        trend_states((t[idx] - t[idx[0]]) / DAY, j.wear[idx], j.wear_std[idx], cfg)
        nights += len(idx)
out["fleet"] = cpu() - c
out["nights"] = nights
c = cpu()
runs = [backtest_joint(j, cfg, EPOCH0) for j in cal]
score_calibration(cal, cfg, EPOCH0, 150, min_estimates=60, backtests=runs)
out["calibration"] = cpu() - c
c = cpu()
for s in sibs:
    sibling_fit(*s, cfg)
out["siblings"] = cpu() - c
print(json.dumps(out))
"""


def measure(tree: Path, runs: int) -> dict[str, float]:
    best: dict[str, float] = {}
    for _ in range(runs):
        r = subprocess.run([sys.executable, "-c", CHILD], cwd=tree, env={"PYTHONPATH": str(tree), "PATH": "/usr/bin"},
                           capture_output=True, text=True, check=True)
        got = json.loads(r.stdout.strip().splitlines()[-1])
        best = {k: min(v, best.get(k, v)) for k, v in got.items()}
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--against", type=Path, help="a checkout of another commit")
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args(argv)
    if a.against is not None and not (a.against / "jointwear_ros" / "trend").is_dir():
        print(f"bench_trend39: --against {a.against} is not a checkout of jointwear (no jointwear_ros/trend)")
        return 2
    trees = [("this", ROOT)] + ([("against", a.against.resolve())] if a.against is not None else [])
    res = {name: measure(tree, max(1, a.runs)) for name, tree in trees}
    print(f"{'CPU s (min of ' + str(a.runs) + ')':22s} {'fleet':>8s} {'calibration':>12s} {'siblings':>9s} "
          f"{'joint-nights / CPU s':>21s}")
    for name, r in res.items():
        print(f"{name:22s} {r['fleet']:8.2f} {r['calibration']:12.2f} {r['siblings']:9.2f} "
              f"{r['nights'] / r['fleet']:21.0f}")
    if "against" in res:
        t, o = res["this"], res["against"]
        print(f"{'against / this':22s} {o['fleet'] / t['fleet']:8.2f} {o['calibration'] / t['calibration']:12.2f} "
              f"{o['siblings'] / t['siblings']:9.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
