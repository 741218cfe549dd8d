"""Cost of the simulated production (``jointwear_ros.sim.production``): seconds of computation per simulated minute.

For the UR5 and the Panda, each shipped program (pick-and-place, machine tending) runs for cycles started
within ``--seconds`` simulated seconds (default 60) at 250 Hz samples and 1 kHz physics, with wear per joint
and self-heating on; the table gives the wall seconds per simulated minute of the run, of recording it to
MCAP (``io.production_bag``) and their sum: CPU seconds of this process (``time.process_time``, one thread,
one run each; the machine's other load does not count). Then each
program's cruise speeds, motor side (joint speed x gear ratio), per move and joint.

Measured here (2 cores shared with four other agents, load about 4, 2026-11-26), --seconds 60:

    arm    program           sim s  samples  run s/min  record s/min  total s/min
    ur5    pick_and_place     65.7    16425        5.4           0.5          5.9
    ur5    machine_tending    64.5    16128        4.9           0.4          5.3
    panda  pick_and_place     68.1    17023        5.5           0.4          5.9
    panda  machine_tending    68.2    17040        5.6           0.4          6.0

About 80-90 µs per physics step: the held tool-flange joint sits in the drive's stick band, which the arm
solves with the inertia matrix at every step (``sim/arm.py``). An 8-hour shift is about 45 CPU minutes; the
tests and the demo run short shifts (a few cycles).

Measures; asserts nothing. ``python bench/bench_production_sim.py [--seconds S]``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jointwear_ros.io.production_bag import record_production  # noqa: E402
from jointwear_ros.sim import arm_spec, machine_tending, pick_and_place, run_production  # noqa: E402

WEAR = {"ur5": [5.0, 12.0, 20.0, 30.0, 45.0, 0.0], "panda": [5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 0.0]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0, help="simulated seconds per program (cycles started within)")
    args = ap.parse_args()
    rows = []
    speeds = []
    tmp = Path(tempfile.mkdtemp(prefix="bench_production_"))
    try:
        for arm in ("ur5", "panda"):
            for make in (pick_and_place, machine_tending):
                program = make(arm)
                t0 = time.process_time()
                run = run_production(arm, program, duration=args.seconds, wear=WEAR[arm], seed=0)
                t1 = time.process_time()
                record_production(run, tmp / f"{arm}_{program.name}")
                t2 = time.process_time()
                per_min = 60.0 / run.duration
                rows.append((arm, program.name, run.duration, len(run.t), (t1 - t0) * per_min, (t2 - t1) * per_min))
                gear = np.asarray(run.gear_ratio)
                seen = set()
                for m in run.moves:
                    if m.move in seen:
                        continue
                    seen.add(m.move)
                    speeds.append((arm, program.name, m.label, np.round(np.abs(np.asarray(m.velocity)) * gear, 1)))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{'arm':6s} {'program':16s} {'sim s':>6s} {'samples':>8s} {'run s/min':>10s} {'record s/min':>13s} "
          f"{'total s/min':>12s}")
    for arm, name, dur, n, run_s, rec_s in rows:
        print(f"{arm:6s} {name:16s} {dur:6.1f} {n:8d} {run_s:10.1f} {rec_s:13.1f} {run_s + rec_s:12.1f}")
    print()
    for arm in ("ur5", "panda"):
        print(f"{arm}: cruise speeds, motor rad/s, joints {', '.join(j.name for j in arm_spec(arm).joints)}")
        for a, name, label, w in speeds:
            if a == arm:
                print(f"  {name:16s} {label:28s} {w.tolist()}")


if __name__ == "__main__":
    main()
