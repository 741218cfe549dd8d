"""Commissioning a robot that is not the paper's, and what it does to the wear estimate (issue 18).

Prints three tables:

1. A simulated six-joint robot whose joints use ``arm6-base`` (joint side, N·m),
   ``cobot-j3`` (normalized) and ``arm6-wrist`` (joint side, N·m): baseline cycles at
   w = 0 over a warm-up (18-52 degC, 16 cycles) commissioned into one set per joint
   (joint-side joints commissioned from joint-side tables), then test cycles at
   wear 10, 30, 40 (one window position per cycle, temperature unknown) estimated
   with the commissioned set, the true set and ``ref-2011r``: mean estimate, mean
   std, the largest |error|/std, and the std ratio commissioned / true.
2. A hidden position ripple (``ripple``: 0.004 sin(3 position + 0.7), the test
   cycles at one window position): the workbench's verdict on the baseline, and the
   wear-estimate error before (model ``paper``) and after (model with the suggestion).
3. Ahead of a plain pipeline: on four robots (normalized, two joint-side, one with
   the hidden ripple) the RMS wear error of commission + estimate and of a plain
   scipy ``least_squares`` pipeline (nominal fit on the baseline with T known from
   the paper's start values, then a joint (w, T) least-squares fit per cycle), and
   their ratio.

Run: ``python bench/bench_commission.py`` (about a minute on one core).
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from jointwear_ros.commission import commission
from jointwear_ros.data import synth_observations
from jointwear_ros.estimation import JointEstimator, set_frame_table
from jointwear_ros.model import ParameterSet, SetUnits, load_parameter_set_info, paper_model, paper_wear_model
from jointwear_ros.types import ObservationTable

WEARS = (10.0, 30.0, 40.0)
N_TEST = 4  # test cycles per wear level
TEST_POSITION = 0.3


def baseline(set_name: str, seed: int, hidden: tuple[str, ...] = ()) -> ObservationTable:
    return synth_observations(n_cycles=16, seed=seed, params=set_name, temperature=(18.0, 52.0), effects=hidden)


def tests(set_name: str, seed: int, hidden: tuple[str, ...] = ()) -> list[tuple[float, ObservationTable]]:
    out = []
    for k, w in enumerate(WEARS):
        t = synth_observations(n_cycles=N_TEST, seed=seed + 100 * k, params=set_name, model="paper+wear", wear=w,
                               temperature=(25.0, 50.0), position=(TEST_POSITION, TEST_POSITION), effects=hidden)
        cols = {n: v for n, v in t.columns.items() if n not in ("temperature", "wear")}  # T unknown
        for _, g in ObservationTable(cols, source=t.source).groups("cycle"):
            out.append((w, g))
    return out


def to_joint_side(table: ObservationTable, info: ParameterSet) -> ObservationTable:
    return set_frame_table(table, info) if info.units.joint_side else table


def commission_joint(set_name: str, table: ObservationTable, model: str = "paper") -> tuple[ParameterSet, object]:
    info = load_parameter_set_info(set_name)
    units = info.units if info.units.joint_side else SetUnits()
    res = commission(to_joint_side(table, info), joint=set_name, model=model, units=units, wear_calibration="paper")
    return res.parameter_set(f"commissioned-{set_name}"), res


def estimate(pset: ParameterSet | str, cycles: list[tuple[float, ObservationTable]]) -> list[tuple[float, float, float]]:
    est = JointEstimator(params=pset)
    return [(w, r.wear, r.wear_std) for w, t in cycles for r in [est.estimate(t)]]


def plain_pipeline(set_name: str, base: ObservationTable, cycles: list[tuple[float, ObservationTable]]) -> list[float]:
    """Nominal least_squares from the paper's values (T known), then a (w, T) least_squares per cycle."""
    info = load_parameter_set_info(set_name)
    b = to_joint_side(base, info)
    m, mw = paper_model(), paper_wear_model()
    ref = load_parameter_set_info("ref-2011r").values
    names = m.param_names
    x = {"speed": np.abs(b.speed), "load_torque": np.abs(b["load_torque"]), "temperature": b["temperature"]}

    def res(th: np.ndarray) -> np.ndarray:
        return np.asarray(m.evaluate(dict(zip(names, th)), **x) - b.tau_f)

    fit = least_squares(res, np.array([ref[n] for n in names]), method="lm", max_nfev=20000)
    p = dict(zip(names, fit.x))
    sf, tf = info.units.speed_factor, info.units.torque_factor
    p.update({"Fsw": ref["Fsw"] * tf, "vsw": ref["vsw"] * sf, "Fvw": ref["Fvw"] * tf / sf})
    out = []
    for w_true, t in cycles:
        tj = to_joint_side(t, info)
        v, ld, y = np.abs(tj.speed), np.abs(tj["load_torque"]), tj.tau_f

        def r2(z: np.ndarray, v: np.ndarray = v, ld: np.ndarray = ld, y: np.ndarray = y) -> np.ndarray:
            return np.asarray(mw.evaluate(p, speed=v, load_torque=ld, temperature=z[1], wear=z[0]) - y)

        sol = least_squares(r2, np.array([20.0, 40.0]), bounds=([0.0, 0.0], [100.0, 80.0]))
        out.append(float(sol.x[0]) - w_true)
    return out


def table1() -> None:
    print("== 1. six-joint robot: commissioned vs true vs ref-2011r (joint estimator, T unknown) ==")
    joints = [("joint_1", "arm6-base"), ("joint_2", "arm6-base"), ("joint_3", "cobot-j3"), ("joint_4", "cobot-j3"),
              ("joint_5", "arm6-wrist"), ("joint_6", "arm6-wrist")]
    print(f"{'joint':<8} {'set':<11} {'commission s':>12} | {'wear':>4} {'comm. mean':>10} {'std':>5} {'max|e|/std':>10} "
          f"| {'true mean':>9} {'std':>5} | {'std ratio':>9} | {'ref-2011r mean':>14} {'std':>5}")
    for k, (j, s) in enumerate(joints):
        t0 = time.perf_counter()
        pset, _ = commission_joint(s, baseline(s, 10 + k))
        secs = time.perf_counter() - t0
        cyc = tests(s, 50 + k)
        ec, et, er = estimate(pset, cyc), estimate(s, cyc), estimate("ref-2011r", cyc)
        for w in WEARS:
            c = [(e, sd) for ww, e, sd in ec if ww == w]
            tt = [(e, sd) for ww, e, sd in et if ww == w]
            rr = [(e, sd) for ww, e, sd in er if ww == w]
            z = max(abs(e - w) / sd for e, sd in c)
            ratio = np.mean([sd for _, sd in c]) / np.mean([sd for _, sd in tt])
            print(f"{j:<8} {s:<11} {secs:>12.1f} | {w:>4.0f} {np.mean([e for e, _ in c]):>10.2f} "
                  f"{np.mean([sd for _, sd in c]):>5.2f} {z:>10.2f} | {np.mean([e for e, _ in tt]):>9.2f} "
                  f"{np.mean([sd for _, sd in tt]):>5.2f} | {ratio:>9.2f} | {np.mean([e for e, _ in rr]):>14.2f} "
                  f"{np.mean([sd for _, sd in rr]):>5.2f}")


def table2() -> None:
    print("\n== 2. hidden position ripple (cobot-j3): diagnose, then commission with the suggestion ==")
    s, hidden = "cobot-j3", ("ripple",)
    base = baseline(s, 21, hidden)
    cyc = tests(s, 71, hidden)
    pset0, r0 = commission_joint(s, base)
    print(f"baseline verdict with model paper: {r0.verdict} (suggestion {r0.suggestion}); CV RMSE {r0.cv_rmse:.5f}")
    spec = f"paper + {r0.suggestion}" if r0.suggestion else "paper + ripple(position)"
    pset1, r1 = commission_joint(s, base, model=spec)
    print(f"with model {spec!r}: verdict {r1.verdict}; CV RMSE {r1.cv_rmse:.5f}")
    print(f"{'model':<32} {'wear':>4} {'mean estimate':>13} {'mean error':>10} {'std':>5} {'max|e|/std':>10}")
    for name, ps in (("paper (before)", pset0), (spec + " (after)", pset1)):
        e = estimate(ps, cyc)
        for w in WEARS:
            c = [(x, sd) for ww, x, sd in e if ww == w]
            print(f"{name:<32} {w:>4.0f} {np.mean([x for x, _ in c]):>13.2f} {np.mean([x - w for x, _ in c]):>10.2f} "
                  f"{np.mean([sd for _, sd in c]):>5.2f} {max(abs(x - w) / sd for x, sd in c):>10.2f}")


def table3() -> None:
    print("\n== 3. commission + estimate vs a plain scipy least_squares pipeline (RMS wear error) ==")
    robots = [("R1 normalized", "cobot-j3", ()), ("R2 joint side N·m", "arm6-base", ()),
              ("R3 joint side N·m", "arm6-wrist", ()), ("R4 hidden ripple", "cobot-j3", ("ripple",))]
    print(f"{'robot':<20} {'set':<11} {'ours RMS':>8} {'max|e|/std':>10} {'plain RMS':>9} {'ratio ours/plain':>16}")
    for i, (label, s, hidden) in enumerate(robots):
        base = baseline(s, 31 + i, hidden)
        cyc = tests(s, 81 + i, hidden)
        pset, r = commission_joint(s, base)
        if r.verdict == "found" and r.suggestion:
            pset, r = commission_joint(s, base, model=f"paper + {r.suggestion}")
        e = estimate(pset, cyc)
        ours = math.sqrt(np.mean([(x - w) ** 2 for w, x, _ in e]))
        z = max(abs(x - w) / sd for w, x, sd in e)
        plain = math.sqrt(np.mean(np.square(plain_pipeline(s, base, cyc))))
        print(f"{label:<20} {s:<11} {ours:>8.2f} {z:>10.2f} {plain:>9.2f} {ours / plain:>16.2f}")


if __name__ == "__main__":
    which = sys.argv[1:] or ["1", "2", "3"]
    if "1" in which:
        table1()
    if "2" in which:
        table2()
    if "3" in which:
        table3()
