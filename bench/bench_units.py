"""Fits in the data's units, and the time-series converter on a real robot's log.

Usage: python bench/run_all.py units   (or python bench/bench_units.py [--panda-log DIR])

1. A real arm's friction sweep in N·m: the Franka Emika Panda's published friction model (Gaz et al.,
   IEEE RA-L 2019; :mod:`jointwear_ros.data.published`) swept at 0.001-0.5 rad/s, seven joints.
   ``model fit --model standard`` (the workbench, scaled to the data) against a plain scipy
   ``least_squares`` fit of the same four terms (best of 13 starts of the Stribeck speed) and against
   the workbench with the terms' paper-unit numbers (``rescale=False``, what it did before): RMSE
   ratio to the plain fit, and parameters left on a bound.
2. A clean joint recorded joint side (gear 120, 150 N·m per normalized unit): ``model diagnose
   --model paper`` verdict and CV RMSE / noise floor, scaled and unscaled.
3. With ``--panda-log DIR`` (or ``$JOINTWEAR_PANDA_LOG``): DIR holds ``exciting_traj_{time,positions,
   velocity,torques}.txt`` of ``matlab/data/Exciting_Traj/Trajectory_1/rbt_log`` of
   github.com/marcocognetti/FrankaEmikaPandaDynModel (GPL-3.0: not shipped here; download it). A real
   Panda's 1 kHz log of a continuous exciting trajectory (no plateaus), converted per joint by
   ``data from-timeseries`` (steady-speed bins) and compared with the published model at each bin's
   speed. Benchmarks measure; they do not pass or fail.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from jointwear_ros.cli.common import format_table
from jointwear_ros.data import panda_friction, panda_friction_sweep, synth_observations
from jointwear_ros.observer.timeseries import TimeseriesConfig, timeseries_observations
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench import diagnose, fit_model, parse_spec
from jointwear_ros.workbench.baseline import plain_standard_fit


def plain_rmse(table: ObservationTable) -> float:
    return plain_standard_fit(table.speed, table.tau_f, vs_range=(1e-3, 1.0)).rmse


def panda_sweeps() -> None:
    model = parse_spec("standard")
    rows = []
    for j in range(7):
        t = panda_friction_sweep(j)
        t0 = time.perf_counter()
        fit = fit_model(model, t, cv_folds=0)
        dt = time.perf_counter() - t0
        old = fit_model(model, t, cv_folds=0, rescale=False)
        p = plain_rmse(t)
        rows.append([f"panda_joint{j + 1}", p, fit.rmse / p, old.rmse / p,
                     ", ".join(h.name for h in old.at_bound) or "-", ", ".join(h.name for h in fit.at_bound) or "-",
                     f"{1000 * dt:.0f}"])
    print("# model fit --model standard on the Panda's published friction (N·m, 0.001-0.5 rad/s, noise 0.002)")
    print(format_table(["joint", "plain lsq RMSE", "scaled / plain", "unscaled / plain", "on bound (unscaled)",
                        "on bound (scaled)", "fit ms"], rows, floatfmt=".4g"))


def joint_side() -> None:
    ref = synth_observations(n_cycles=40, seed=0)
    cols = {n: ref[n].copy() for n in ref.names}
    cols["speed"] = cols["speed"] / 120.0
    for c in ("tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque"):
        cols[c] = cols[c] * 150.0
    js = ObservationTable(cols, source="joint side")
    rows = []
    for label, rescale in (("scaled to the data", True), ("paper-unit numbers", False)):
        t0 = time.perf_counter()
        base = fit_model(parse_spec("paper"), js, rescale=rescale)
        d = diagnose(js, base, n_bootstrap=0)
        rows.append([label, d.verdict, d.suggestion or "-", base.cv_rmse / d.noise.value, len(base.at_bound),
                     f"{time.perf_counter() - t0:.1f}"])
    print("\n# model diagnose --model paper, a clean joint recorded joint side (gear 120, 150 N·m; floor 0.225 N·m)")
    print(format_table(["fit", "verdict", "suggestion", "CV RMSE / floor", "on bound", "s"], rows, floatfmt=".3g"))


def panda_log(d: Path) -> None:
    def load(name: str) -> np.ndarray:
        return np.loadtxt(d / f"exciting_traj_{name}.txt")

    t = load("time")
    q, v, u = (load(n).reshape(-1, 7) for n in ("positions", "velocity", "torques"))
    print(f"\n# a real Panda's log: {t.size} samples at {1 / np.median(np.diff(t)):.0f} Hz, {t[-1]:.1f} s "
          "(Gaz et al., exciting trajectory 1); data from-timeseries, steady-speed bins")
    rows = []
    for j in range(7):
        r = timeseries_observations(t, q[:, j], v[:, j], u[:, j], config=TimeseriesConfig(n_bins=10))
        for row in r.rows:
            s = row["speed"]
            model = 0.5 * float(panda_friction(j, s) - panda_friction(j, -s))
            rows.append([f"panda_joint{j + 1}", r.method, s, row["tau_f"], row["tau_f_std"], model,
                         row["tau_f"] - model, int(row["samples_plus"]), int(row["samples_minus"]),
                         row["position_spread"]])
    print(format_table(["joint", "method", "speed", "tau_f", "std", "published", "diff", "n+", "n-", "pos spread"],
                       rows, floatfmt=".3g"))


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--panda-log", default=os.environ.get("JOINTWEAR_PANDA_LOG"),
                    help="directory with the Panda log's exciting_traj_*.txt files")
    args = ap.parse_args(argv)
    panda_sweeps()
    joint_side()
    if args.panda_log:
        panda_log(Path(args.panda_log))
    else:
        print("\n# real Panda log: not given (--panda-log DIR or $JOINTWEAR_PANDA_LOG; see the docstring)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
