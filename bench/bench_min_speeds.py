"""How many speeds does a wear level need? Estimates from the first k speeds of a cycle, per method.

A test cycle that FAILS (an effort limit, an operator stop) leaves the speeds it swept before: the first k
of ``config/test_cycle.yaml``'s eight (10 ... 160 rad/s). The suite gives a level only from an estimate of at
least :func:`jointwear_ros.condition.min_speeds` distinct speeds (3 with the temperature unknown, 1 with it
measured). This bench measures why: for every method, k = 1 ... 8 speeds, true wear 0, 20, 35 and a joint
temperature the estimator does not know (25, 40, 55 degC), several noise seeds, the ``ref-2011r`` set's model
(Eq. 9) with its noise, and prints per k the largest |error|, the share of estimates beyond 3 std, and the
level errors (true wear 0 read WARN or ERROR; true wear 35 read OK), the rule of docs/levels.md applied to
each single estimate.

Run: ``python bench/bench_min_speeds.py [--quick]`` (a minute or two on one core).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from jointwear_ros.condition import condition_level  # noqa: E402
from jointwear_ros.estimation import make_estimator  # noqa: E402
from jointwear_ros.model import load_parameter_set, paper_wear_model  # noqa: E402
from jointwear_ros.types import ObservationTable  # noqa: E402

SPEEDS = (10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0, 160.0)
METHODS = ("paper", "paper-grid", "bayes", "joint")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one seed, two temperatures")
    args = ap.parse_args()
    model, params = paper_wear_model(), load_parameter_set("ref-2011r")
    seeds = (0,) if args.quick else (0, 1, 2)
    temps = (25.0, 55.0) if args.quick else (25.0, 40.0, 55.0)
    noise = 0.003  # N·m normalized: the observer's scatter of one speed's (u+ - u-)/2 on the simulated joint
    print(f"{'method':<11} {'k':>2} {'n':>4} {'max|err|':>9} {'>3 std':>7} {'w0 read WARN+':>14} {'w35 read OK':>12}")
    for method in METHODS:
        for k in range(1, len(SPEEDS) + 1):
            errs, zs, false_alarm, missed, n = [], [], 0, 0, 0
            for wear in (0.0, 20.0, 35.0):
                for temp in temps:
                    for seed in seeds:
                        rng = np.random.default_rng([seed, int(wear), int(temp), k])
                        v = np.array(SPEEDS[:k])
                        tau = np.array([float(model.evaluate(params, speed=s, load_torque=0.1, temperature=temp,
                                                             wear=wear)) for s in v])
                        tau = tau + rng.normal(0.0, noise, k)
                        table = ObservationTable.from_arrays(
                            source="bench", speed=v, tau_f=tau, tau_f_std=np.full(k, noise),
                            load_torque=np.full(k, 0.1), temperature=np.full(k, math.nan))
                        try:
                            r = make_estimator(method, params="ref-2011r", seed=seed).estimate(table)
                        except Exception as exc:  # an estimator that refuses so few speeds: counted as such
                            print(f"{method:<11} {k:>2} refused: {str(exc)[:80]}")
                            continue
                        n += 1
                        errs.append(abs(r.wear - wear))
                        zs.append(abs(r.wear - wear) / r.wear_std if r.wear_std > 0 else math.inf)
                        lv = condition_level(r.wear, r.wear_std)
                        false_alarm += wear == 0.0 and lv is not None and lv.name != "OK"
                        missed += wear == 35.0 and lv is not None and lv.name == "OK"
            if n:
                print(f"{method:<11} {k:>2} {n:>4} {max(errs):>9.1f} {np.mean(np.array(zs) > 3):>7.0%} "
                      f"{false_alarm:>14} {missed:>12}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
