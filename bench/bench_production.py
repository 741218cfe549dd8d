"""Wear per joint from the simulated UR5's pick-and-place, against the truth and the dedicated cycle.

Public tools only: the simulated production (``jointwear_ros.sim.production``: the UR5's pick-and-place, a
2 kg payload one way, self-heating from 40 degC), the production observer (``observe_production`` with the
arm's gravity at no payload, the payload's rigid-body torque per kg and the part's mass) and ``estimate_shift`` (one
``WearMonitor`` per joint, the ``joint`` estimator, as the live wear_estimator), per shift; the dedicated
simultaneous cycle (``jointwear_ros.simcell.run_cycle``) on the same arm at the same wear.

Prints per joint: the truth, the production estimate per shift in std units (temperature measured; and
without the sensor), its std, the ratio std_production / std_dedicated, and the pass counts (paired, of
which corrected for the payload, rejected). Target (issue 31): within 3 std, ratio <= 2. ``--json``: the
same as JSON. Figures of a run on this machine are in docs/production.md.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from jointwear_ros.monitor import MonitorConfig, estimate_shift  # noqa: E402
from jointwear_ros.observer import ProductionConfig, ProductionObserver  # noqa: E402
from jointwear_ros.sim.arm import ArmModel, ArmSim, arm_configs  # noqa: E402
from jointwear_ros.sim.arms import arm_spec  # noqa: E402
from jointwear_ros.sim.production import pick_and_place, run_production  # noqa: E402
from jointwear_ros.simcell import cycle_settings, run_cycle  # noqa: E402

WEAR = (5.0, 12.0, 20.0, 30.0, 45.0, 0.0)
PAYLOAD = 2.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shifts", type=int, default=2)
    ap.add_argument("--cycles", type=int, default=4, help="pick-and-place cycles per shift (15.2 s each)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--override", type=float, nargs="+", default=[1.0],
                    help="the program's speed override cycle by cycle (e.g. 1 0.8 1.25: a product mix)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    arm = "ur5"
    t0 = time.process_time()
    run = run_production(arm, pick_and_place(arm, payload=PAYLOAD), shifts=args.shifts, cycles=args.cycles,
                         wear=list(WEAR), temperature=40.0, seed=args.seed,
                         speed_override=args.override)
    names = list(run.names)
    cfg = [ProductionConfig(gear_ratio=g, torque_scale=s) for g, s in zip(run.gear_ratio, run.torque_scale, strict=True)]
    obs = ProductionObserver(names, cfg, **ArmModel(arm, names).observer_models(payload_mass=PAYLOAD))
    shifts = run.observe(obs)
    t_prod = time.process_time() - t0
    # the dedicated simultaneous cycle on the same arm at the same wear and start temperature
    spec = arm_spec(arm)
    cycles, observers = cycle_settings(arm, names)
    sim = ArmSim(spec, names, [replace(c, wear=w, temperature=40.0) for c, w in zip(arm_configs(spec, names), WEAR,
                                                                                   strict=True)],
                 seeds=[args.seed * 100 + i for i in range(len(names))])
    ded = run_cycle(sim, cycles, observers, together=True, seed=args.seed)
    rows: list[dict[str, Any]] = []
    for s, sh in enumerate(shifts):
        with_t = estimate_shift(sh, MonitorConfig(method="joint", use_measured_temperature=True), pooled=True)
        without = estimate_shift(sh, MonitorConfig(method="joint", use_measured_temperature=False), pooled=True)
        pp = estimate_shift(sh, MonitorConfig(method="joint"))
        pp0 = estimate_shift(sh, MonitorConfig(method="joint", use_measured_temperature=False))
        for i, n in enumerate(names):
            e, e0, p, p0 = with_t[n], without[n], pp[n], pp0[n]
            w_true = run.wear[s][i]
            d_std = ded.estimates[n][1]
            c = sh.joints[n]
            rows.append({
                "shift": s + 1, "joint": n, "true_wear": w_true,
                "estimate": e.wear if e.told else None, "std": e.wear_std if e.told else None,
                "z": (e.wear - w_true) / e.wear_std if e.told else None,
                "ratio": e.wear_std / d_std if e.told and math.isfinite(d_std) else None,
                "dedicated_estimate": ded.estimates[n][0], "dedicated_std": d_std,
                "no_sensor_estimate": e0.wear if e0.told else None, "no_sensor_std": e0.wear_std if e0.told else None,
                "no_sensor_z": (e0.wear - w_true) / e0.wear_std if e0.told else None,
                "no_sensor_ratio": e0.wear_std / d_std if e0.told and math.isfinite(d_std) else None,
                "per_pass_z": (p.wear - w_true) / p.wear_std if p.told else None,
                "per_pass_std": p.wear_std if p.told else None,
                "per_pass_ratio": p.wear_std / d_std if p.told and math.isfinite(d_std) else None,
                "per_pass_no_sensor_z": (p0.wear - w_true) / p0.wear_std if p0.told else None,
                "per_pass_no_sensor_ratio": p0.wear_std / d_std if p0.told and math.isfinite(d_std) else None,
                "passes": c.passes, "paired": c.paired, "payload_corrected": len(c.payload_kg),
                "rejected": dict(c.rejected), "reason": e.reason, "no_sensor_reason": e0.reason})
    out = {"arm": arm, "shifts": args.shifts, "cycles": args.cycles, "payload": PAYLOAD, "rows": rows,
           "speed_override": args.override,
           "cpu_seconds_production": round(t_prod, 1), "dedicated_state": ded.state.name}
    if args.json:
        print(json.dumps(out, indent=1))
        return

    def f(x: Any, fmt: str) -> str:
        return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, fmt)

    print(f"UR5 pick-and-place, {args.shifts} shift(s) x {args.cycles} cycles, {PAYLOAD:g} kg one way, speed "
          f"override {' '.join(f'{x:g}' for x in args.override)} cycle by cycle; "
          f"production {t_prod:.0f} CPU s; dedicated cycle {ded.state.name}")
    print("levels: one observation per speed level; per pass: one per pair (estimate_shift's default); "
          "noT: the temperature not given to the estimator (as the dedicated cycle's)")
    print(f"{'':20} {'':>6} {'levels, T measured':>19} {'levels noT':>13} {'per pass, T':>19} {'per pass noT':>13}")
    print(f"{'shift':>5} {'joint':8} {'true':>5} {'ded std':>7} {'est':>6} {'std':>5} {'z':>6} {'ratio':>5} "
          f"{'z':>6} {'ratio':>5} {'std':>5} {'z':>6} {'ratio':>5} {'z':>6} {'ratio':>5} "
          f"{'pass':>4} {'pair':>4} {'+pl':>3} {'rej':>3}  cannot tell (levels, T)")
    for r in rows:
        print(f"{r['shift']:>5} {r['joint']:8} {r['true_wear']:5.1f} {f(r['dedicated_std'], '7.2f'):>7} "
              f"{f(r['estimate'], '6.1f'):>6} {f(r['std'], '5.2f'):>5} {f(r['z'], '+6.2f'):>6} {f(r['ratio'], '5.2f'):>5} "
              f"{f(r['no_sensor_z'], '+6.2f'):>6} {f(r['no_sensor_ratio'], '5.2f'):>5} "
              f"{f(r['per_pass_std'], '5.2f'):>5} {f(r['per_pass_z'], '+6.2f'):>6} {f(r['per_pass_ratio'], '5.2f'):>5} "
              f"{f(r['per_pass_no_sensor_z'], '+6.2f'):>6} {f(r['per_pass_no_sensor_ratio'], '5.2f'):>5} "
              f"{r['passes']:4d} {r['paired']:4d} "
              f"{r['payload_corrected']:3d} {sum(v for k, v in r['rejected'].items() if k != 'held still'):3d}  "
              f"{r['reason'][:60]}")


if __name__ == "__main__":
    main()
