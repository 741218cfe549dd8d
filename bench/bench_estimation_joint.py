"""Joint estimation over one cycle's speeds against the paper's estimator at its best single speed.

Setting (the paper's Section 5.1): w0 = 35, sigma_e = 0.0015, tau_m = 0.1, true T ~ U(25, 55) drawn
once per cycle and shared by the cycle's speeds; at most 6 speeds. Printed: bias,
std of w_hat, the multi-speed bound and the ratio std / bound, the time per cycle;
beside it, in the same run and on the same temperatures, the paper's estimator
(Eq. 11, N = 200) at each speed of a scan, with its best speed's std, and the
ratio. Measures only; asserts nothing.

Run: python bench/run_all.py estimation_joint   (RUNS=... to change the run count)
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

from jointwear_ros.estimation import PaperEstimator
from jointwear_ros.estimation.crb import crb_multi_speed, crb_per_speed
from jointwear_ros.estimation.design import design_cycle
from jointwear_ros.estimation.joint import JointEstimator
from jointwear_ros.estimation.priors import normal_prior, uniform_prior
from jointwear_ros.model import load_parameter_set, paper_wear_model

RUNS = int(os.environ.get("RUNS", "3000"))
W0, SIGMA, LOAD = 35.0, 0.0015, 0.1
PRIOR = uniform_prior(25.0, 55.0)


def simulate(m, p, speeds, temps, rng):
    tau = m.evaluate(p, speed=speeds[None, :], load_torque=LOAD, temperature=temps[:, None], wear=W0)
    return tau + rng.normal(0.0, SIGMA, tau.shape)


def summary(name, w, bound_std, seconds):
    bias, std = float(w.mean() - W0), float(w.std(ddof=1))
    rmse = float(np.sqrt(np.mean((w - W0) ** 2)))
    ratio = std / bound_std if np.isfinite(bound_std) else float("nan")
    print(f"{name:<58} {bias:+7.3f} {std:7.3f} {rmse:7.3f} {bound_std:7.3f} {ratio:7.3f} {1e3 * seconds:9.2f}")
    return std


def main() -> int:
    m, p = paper_wear_model(), load_parameter_set("ref-2011r")
    rng = np.random.default_rng(2026)
    temps = PRIOR.sample(rng, RUNS)
    t0 = time.perf_counter()
    design = design_cycle(m, p, budget=90.0, wear=W0, load=LOAD, noise_std=SIGMA, prior=PRIOR)
    t_design = time.perf_counter() - t0
    cycles = {
        "designed (cycle design --budget 90)": np.asarray(design.speeds),
        "spread 0,20,40,60,100,150": np.array([0.0, 20.0, 40.0, 60.0, 100.0, 150.0]),
    }
    print(f"runs = {RUNS}, w0 = {W0}, sigma_e = {SIGMA}, tau_m = {LOAD}, true T ~ {PRIOR.label} (one T per cycle)")
    print(f"cycle design (budget 90 s, 14 s per speed): {list(design.speeds)} in {t_design:.1f} s\n")
    head = f"{'estimator':<58} {'bias':>7} {'std':>7} {'rmse':>7} {'bound':>7} {'std/bd':>7} {'ms/cycle':>9}"
    print(head)
    print("-" * len(head))
    joint_std = {}
    for label, speeds in cycles.items():
        bound_std = float(np.sqrt(crb_multi_speed(m, p, speeds, W0, load=LOAD, noise_std=SIGMA, prior=PRIOR)))
        tau = simulate(m, p, speeds, temps, rng)
        est = JointEstimator(m, p, prior=PRIOR, noise_std=SIGMA)
        est.estimate_arrays(speeds, LOAD, tau[:1])  # build the cached grid outside the timing
        t0 = time.perf_counter()
        out = est.estimate_arrays(speeds, LOAD, tau)
        dt = (time.perf_counter() - t0) / RUNS
        joint_std[label] = summary(f"joint, posterior mean: {label}", out["wear"], bound_std, dt)
        sub = min(RUNS, 500)
        mp = JointEstimator(m, p, prior=PRIOR, noise_std=SIGMA, point="map")
        t0 = time.perf_counter()
        outm = mp.estimate_arrays(speeds, LOAD, tau[:sub])
        dt = (time.perf_counter() - t0) / sub
        summary(f"joint, MAP ({sub} runs): {label}", outm["wear"], bound_std, dt)
        terr = out["temperature"] - temps
        print(f"{'   its temperature estimate: bias, std (degC)':<58} {terr.mean():+7.3f} {terr.std(ddof=1):7.3f}")
        cover = np.mean((out["wear_std"] > 0) & (np.abs(out["wear"] - W0) <= 2 * out["wear_std"]))
        print(f"{'   reported std (mean) / coverage of +-2 std':<58} {out['wear_std'].mean():7.3f} {cover:7.3f}")

    # the paper's estimator at single speeds, same temperatures: scan for its best speed
    print()
    scan = np.arange(20.0, 75.0, 5.0)
    single_bounds = crb_per_speed(m, p, scan, W0, load=LOAD, noise_std=SIGMA, prior=PRIOR)
    best = None
    for assumed in ((30.0, 50.0), (25.0, 55.0)):
        paper = PaperEstimator(m, p, temperature_range=assumed, noise_std=SIGMA, rng=np.random.default_rng(1))
        rows = []
        for i, v in enumerate(scan):
            tau = simulate(m, p, np.array([v]), temps, rng)[:, 0]
            t0 = time.perf_counter()
            w, _ = paper.estimate_rows(np.full(RUNS, v), LOAD, tau)
            dt = (time.perf_counter() - t0) / RUNS
            rows.append((float(np.sqrt(np.mean((w - W0) ** 2))), v, w, dt, float(np.sqrt(single_bounds[i]))))
        _rmse, v, w, dt, bd = min(rows, key=lambda r: r[0])
        std = summary(f"paper Eq. 11, T ~ U{assumed}, best speed {v:g}", w, bd, dt)
        if assumed == (25.0, 55.0):
            best = (v, std)
    if best is not None:
        v, std = best
        print()
        for label, js in joint_std.items():
            print(f"std ratio paper at {v:g} rad/s (matched prior) / joint {label}: {std / js:.2f}")
    # a temperature distribution other than the prior (narrower, inside it)
    print()
    other = normal_prior(40.0, 3.0).sample(rng, RUNS)
    speeds = np.asarray(design.speeds)
    tau = simulate(m, p, speeds, other, rng)
    out = JointEstimator(m, p, prior=PRIOR, noise_std=SIGMA).estimate_arrays(speeds, LOAD, tau)
    summary("joint (prior U(25,55)), true T ~ N(40, 3^2)", out["wear"], float("nan"), float("nan"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
