"""How many speeds does a wear level need? Estimates from the first k speeds of a cycle, per method.

A test cycle that FAILS (an effort limit, an operator stop) leaves the speeds it swept before: the first k
of ``config/test_cycle.yaml``'s eight (10 ... 160 rad/s). The suite gives a level only from an estimate of at
least :func:`jointwear_ros.condition.min_speeds` distinct speeds (3 with the temperature unknown, 1 with it
measured): two unknowns (w, T) and one speed left to check the model against. This bench measures it, per
method and k = 1 ... 8, at true wear 0, 20, 35 and a joint temperature the estimator does not know, noise as the
estimators assume (1.5e-3), in two cases:

- ``matched``: the joint is ``ref-2011r`` (load 0.1) and so is the estimator's set;
- ``issue-28``: the joint is ``cobot-j3`` at load 0.45 (issue 28's failed demo: ``--set joint_sim.params=cobot-j3
  --set joint_sim.gravity_torque=0.45``), estimated with ``ref-2011r`` (the wear_estimator's default): a model
  that does not fit, which one or two speeds cannot reveal.

Printed per k: the largest |error|, the share of estimates beyond 3 std, and the level errors of the rule of
docs/levels.md applied to each single estimate (true wear 0 read WARN or ERROR; true wear 35 read OK).

Run: ``python bench/bench_min_speeds.py [--quick]`` (minutes on one core).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from jointwear_ros.condition import condition_level
from jointwear_ros.estimation import make_estimator
from jointwear_ros.model import load_parameter_set, paper_wear_model
from jointwear_ros.types import ObservationTable

SPEEDS = (10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0, 160.0)
METHODS = ("paper", "paper-grid", "bayes", "joint")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one seed, two temperatures")
    ap.add_argument("--methods", default=",".join(METHODS), help="comma-separated methods (default: all)")
    args = ap.parse_args()
    model = paper_wear_model()
    seeds = (0,) if args.quick else (0, 1, 2)
    noise = 1.5e-3  # the estimators' default noise std (normalized torque)
    cases = (("matched", "ref-2011r", 0.1, (25.0, 40.0, 55.0)), ("issue-28", "cobot-j3", 0.45, (30.0, 47.0, 55.0)))
    print(f"{'case':<9} {'method':<11} {'k':>2} {'n':>4} {'max|err|':>9} {'>3 std':>7} {'w0 WARN+':>9} "
          f"{'w35 OK':>7}")
    for case, truth, load, temps in cases:
        params = load_parameter_set(truth)
        temps = temps[::2] if args.quick else temps
        for method in args.methods.split(","):
            for k in range(1, len(SPEEDS) + 1):
                errs, zs, false_alarm, missed, n = [], [], 0, 0, 0
                for wear in (0.0, 20.0, 35.0):
                    for temp in temps:
                        for seed in seeds:
                            rng = np.random.default_rng([seed, int(wear), int(temp), k])
                            v = np.array(SPEEDS[:k])
                            tau = np.array([float(model.evaluate(params, speed=s, load_torque=load,
                                                                 temperature=temp, wear=wear)) for s in v])
                            tau = tau + rng.normal(0.0, noise, k)
                            table = ObservationTable.from_arrays(
                                source="bench", speed=v, tau_f=tau, tau_f_std=np.full(k, noise),
                                load_torque=np.full(k, load), temperature=np.full(k, math.nan))
                            try:
                                r = make_estimator(method, params="ref-2011r", seed=seed).estimate(table)
                            except Exception as exc:  # an estimator that refuses so few speeds: said so
                                print(f"{case:<9} {method:<11} {k:>2} refused: {str(exc)[:80]}")
                                continue
                            n += 1
                            errs.append(abs(r.wear - wear))
                            zs.append(abs(r.wear - wear) / r.wear_std if r.wear_std > 0 else math.inf)
                            lv = condition_level(r.wear, r.wear_std)
                            false_alarm += wear == 0.0 and lv is not None and lv.name != "OK"
                            missed += wear == 35.0 and lv is not None and lv.name == "OK"
                if n:
                    print(f"{case:<9} {method:<11} {k:>2} {n:>4} {max(errs):>9.1f} "
                          f"{np.mean(np.array(zs) > 3):>7.0%} {false_alarm:>9} {missed:>7}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
