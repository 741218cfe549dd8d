"""Every joint at once on a real arm, against one joint after another: cell time, estimate std, coupling.

The pure closed loop of the cell, no ROS: the arm (``ArmSim``, Pinocchio forward dynamics of the UR5 or
the Panda, every joint with the reference friction set, its own wear, temperature unknown to the
estimator) at 1 kHz physics sampled at 500 Hz; the test cycle at 100 Hz, either the line cycle
(``LineCycleRunner``, every joint at once) or the robot cycle (``RobotCycleRunner``, one joint after
another, the others held); one ``FrictionObserverCore`` and one ``WearMonitor`` (the ``joint`` method, as
config/wear_estimator.yaml) per joint, fed as the nodes feed them. The cycle settings per joint are the
demo's (``jointwear demo --joints N``: the arm's test pose, limits and drive sizing).

Prints, per arm:

1. cell time: planned and simulated, one after another vs at once, and their ratio;
2. each joint's wear estimate and its std for both cycles (mean over seeds) and the std ratio
   (at once / one after another; the issue asks for <= 1.2), and how many estimates lie within 3 std;
3. the coupling residual (noise off): each joint's observed tau_f against the model's truth (the
   simulator's friction at that speed and the load of the arm's configuration and velocities where the joint
   crossed its window centre, per-sweep offset off), worst over the speeds, in % of tau_f, for both cycles;
4. a payload change (0 -> 3 kg on the UR5, 1 kg on the Panda) between two cycles at once: each joint's wear
   shift against its std, noise off, and with noise as the mean over the seeds with its standard error.

Measures; asserts nothing. ``--quick``: the UR5 only, one seed. Figures of a run on this machine are in
docs/arm.md.

``--cost``: only what one cycle costs: one ``run_cycle`` of every joint at once (default speeds, noise on, seed 1)
on the UR5 (6 joints) and the Panda (7), each run ``--repeat`` times (default 3), the median wall
(``time.perf_counter``) and CPU (``time.process_time``) seconds, the arm's build included. Measured here (2 cores
shared with two other agents' work, 2026-11-27; one such cycle, base and changed code alternately, five times
each), before and after the arm's step was made cheaper (issue 29, item 6; the same floats):

    arm      CPU s before (median, min)  after (median, min)
    ur5                    2.76, 2.20           2.68, 2.05
    panda                  2.81, 2.51           2.63, 2.23

The arm's own step (``ArmSim.step``) is about a quarter cheaper; the rest of a cycle is mostly the wear monitor's
estimates, the observers and the cycle runner. On a loaded machine single runs scatter by 20 %.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jointwear_ros.sim.arm import ArmSim, arm_configs  # noqa: E402
from jointwear_ros.sim.arms import arm_spec  # noqa: E402
from jointwear_ros.simcell import cycle_settings, run_cycle  # noqa: E402

WEARS = (12.0, 20.0, 26.0, 31.0, 39.0, 46.0, 15.0)
#: the payload change of item 4, kg (the Panda's rated payload is 3 kg, but at its test pose 2 kg take joint 6 over
#: test_cycle's effort limit, 95 % of its 12 N·m)
PAYLOAD = {"ur5": 3.0, "panda": 1.0}
TEMPERATURES = (40.0, 38.0, 44.0, 36.0, 42.0, 41.0, 39.0)


def run(arm: str, n: int, together: bool, seed: int, noise: bool = True, payload: float = 0.0) -> dict[str, Any]:
    """One cycle on the arm (``jointwear_ros.simcell.run_cycle``) and each observation's truth."""
    spec = arm_spec(arm)
    names = [f"joint_{i}" for i in range(1, n + 1)]
    cycles, observers = cycle_settings(arm, names)
    quiet = {} if noise else {"noise_std": 0.0, "effort_noise_std": 0.0}
    sims = [replace(c, wear=WEARS[i], temperature=TEMPERATURES[i], **quiet)
            for i, c in enumerate(arm_configs(spec, names))]
    sim = ArmSim(spec, names, sims, seeds=[seed * 100 + i for i in range(n)], payload=payload)
    r = run_cycle(sim, cycles, observers, together=together, seed=seed)
    truth = {j: [sim.true_friction(j, abs(r.crossing(j, o.speed)[1][i]), *r.crossing(j, o.speed))
                 / observers[j].torque_scale for o in r.observations[j]] for i, j in enumerate(names)}
    return {"state": r.state.name, "message": r.message, "planned": r.planned, "cell": r.cell_seconds,
            "obs": r.observations, "truth": truth, "estimates": r.estimates, "names": names}


def cost(repeat: int) -> None:
    """``--cost``: the median wall and CPU seconds of one cycle at once on each arm."""
    print(f"one run_cycle, every joint at once, default speeds, noise on (median of {repeat}):")
    print(f"   {'arm':6} {'joints':>6} {'wall s':>7} {'CPU s':>6} {'sim s':>6}")
    for arm, n in (("ur5", 6), ("panda", 7)):
        walls, cpus = [], []
        simulated = math.nan
        for _ in range(repeat):
            w0, c0 = time.perf_counter(), time.process_time()
            r = run(arm, n, True, 1)
            walls.append(time.perf_counter() - w0)
            cpus.append(time.process_time() - c0)
            simulated = r["cell"]
        print(f"   {arm:6} {n:6d} {float(np.median(walls)):7.2f} {float(np.median(cpus)):6.2f} {simulated:6.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the UR5 only, one seed")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--cost", action="store_true", help="only the wall and CPU seconds of one cycle on each arm")
    ap.add_argument("--repeat", type=int, default=3, help="--cost: runs per arm (the median is printed)")
    args = ap.parse_args()
    if args.cost:
        cost(max(1, args.repeat))
        return
    arms = [("ur5", 6)] if args.quick else [("ur5", 6), ("panda", 7)]
    seeds = range(1, 2 if args.quick else args.seeds + 1)
    for arm, n in arms:
        spec = arm_spec(arm)
        print(f"== {spec.title}: {n} joints, default speeds, temperature unknown to the estimator ==")
        t_wall = time.perf_counter()
        runs: dict[bool, list[dict[str, Any]]] = {True: [], False: []}
        for together in (False, True):
            for s in seeds:
                runs[together].append(run(arm, n, together, s))
        seq, line = runs[False][0], runs[True][0]
        print(f"1. cell time: one after another {seq['planned']:.1f} s planned, {seq['cell']:.1f} s simulated; "
              f"at once {line['planned']:.1f} s planned, {line['cell']:.1f} s simulated; ratio of the plans "
              f"{line['planned'] / seq['planned']:.2f}")
        for together in (False, True):
            for r in runs[together]:
                if r["state"] != "DONE":
                    print(f"   {'at once' if together else 'one after another'}: {r['state']}: {r['message']}")
        names = line["names"]
        print("2. wear estimates (mean over seeds):")
        print(f"   {'joint':8} {'true':>5} {'one after another':>20} {'at once':>20} {'std ratio':>9}")
        within = {False: 0, True: 0}
        total = 0
        for i, j in enumerate(names):
            row = []
            stds = {}
            for together in (False, True):
                e = np.array([r["estimates"][j] for r in runs[together]])
                stds[together] = float(np.nanmean(e[:, 1]))
                row.append(f"{np.nanmean(e[:, 0]):6.2f} ± {stds[together]:5.2f}")
                within[together] += int(np.sum(np.abs(e[:, 0] - WEARS[i]) <= 3 * e[:, 1]))
            total += len(seeds)
            print(f"   {j:8} {WEARS[i]:5.1f} {row[0]:>20} {row[1]:>20} {stds[True] / stds[False]:9.2f}")
        print(f"   within 3 std: one after another {within[False]}/{total}, at once {within[True]}/{total}")
        print("3. coupling residual, noise off: |observed - model truth| / tau_f, worst over the speeds:")
        quiet = {together: run(arm, n, together, 1, noise=False) for together in (False, True)}
        print(f"   {'joint':8} {'one after another':>18} {'at once':>10} {'the two cycles apart (other poses)':>36}")
        for j in names:
            worst = {}
            for together in (False, True):
                q = quiet[together]
                worst[together] = max((abs(o.tau_f - t) / t for o, t in zip(q["obs"][j], q["truth"][j], strict=True)),
                                      default=math.nan)
            pair = [abs(a.tau_f - b.tau_f) / b.tau_f
                    for a, b in zip(quiet[True]["obs"][j], quiet[False]["obs"][j], strict=False)]
            print(f"   {j:8} {100 * worst[False]:17.2f}% {100 * worst[True]:9.2f}% {100 * max(pair, default=math.nan):35.2f}%")
        kg = PAYLOAD[arm]
        print(f"4. payload 0 -> {kg:g} kg between two cycles at once: each joint's wear shift against its std, noise off "
              "(the payload's own effect) and with noise over the seeds (mean shift ± its standard error: a bias "
              "would stand out of it; two noisy cycles also differ by their noise):")
        quiet_loaded = run(arm, n, True, 1, noise=False, payload=kg)
        noisy = [run(arm, n, True, s, payload=kg) for s in seeds]
        for r in [quiet_loaded, *noisy]:
            if r["state"] != "DONE":
                print(f"   {r['state']}: {r['message']}")
        print(f"   {'joint':8} {'noise off':>18} {'with noise, mean over seeds':>30}")
        for j in names:
            (w0, s0), (w3, s3) = quiet[True]["estimates"][j], quiet_loaded["estimates"][j]
            d = np.array([b["estimates"][j][0] - a["estimates"][j][0] for a, b in zip(runs[True], noisy, strict=True)])
            sd = np.array([max(a["estimates"][j][1], b["estimates"][j][1])
                           for a, b in zip(runs[True], noisy, strict=True)])
            se = float(d.std(ddof=1) / np.sqrt(d.size)) if d.size > 1 else math.nan
            print(f"   {j:8} {w3 - w0:+7.2f} ({(w3 - w0) / max(s0, s3):+.2f} std) "
                  f"{float(d.mean()):+12.2f} ± {se:.2f} ({float(d.mean()) / float(sd.mean()):+.2f} std)")
        print(f"   ({time.perf_counter() - t_wall:.0f} s wall)\n")


if __name__ == "__main__":
    main()
