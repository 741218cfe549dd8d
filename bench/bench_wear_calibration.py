"""How sure is the wear scale of a joint without wear data? ``relative`` and ``paper`` measured.

A commissioned joint has its own nominal model (fitted on its baseline at w = 0) but no
wear data: its wear parameters are a prior, ``paper`` (Eq. 8 in the set's units: the
paper's absolute friction increase per unit wear) or ``relative`` (Eq. 8 scaled by the
joint's nominal friction level over ``ref-2011r``'s). Which one is right depends on how the
real joint wears, which no baseline tells. So every joint here is simulated twice, once with
each kind of true wear signature:

- ``abs``: the paper's absolute signature in the joint's units (what the shipped sets carry);
- ``lvl``: the signature scaled to the joint's own friction level (``relative_wear_values``
  of the true nominal model at the baseline's median conditions).

Joints: the shipped ``cobot-j3`` (normalized), ``arm6-base`` and ``arm6-wrist`` (joint side,
N·m), and generated ones (lower and higher friction levels, other temperature sensitivities,
a joint-side set with another gear ratio and torque scale). Each joint: 16 baseline cycles at
w = 0 over 18-52 degC (``jointwear data synth --cycles 16 --temperature 18:52``), commissioned
with ``relative`` and with ``paper`` (joint-side joints from joint-side tables, as
``jointwear commission --gear-ratio G --torque-scale S``), then test cycles at wear 0, 10, 20,
30, 40 (temperature unknown, one window position) estimated with the joint estimator through
:func:`jointwear_ros.estimation.make_estimator` (what ``jointwear estimate`` uses).

Prints, per joint and calibration (both truths pooled), before (the estimator's std:
noise and temperature only, ``info['wear_std_noise']``) and after (the total std with the
wear scale's own uncertainty): max |z|, the fraction of estimates beyond 3 std, the mean std,
and the level errors (true wear >= 40 read below 30; true wear <= 10 read at or over 35).

Run: ``python bench/bench_wear_calibration.py [--quick]`` (a few minutes on one core).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from jointwear_ros.commission import commission, paper_wear_values, relative_wear_values
from jointwear_ros.data import synth_observations
from jointwear_ros.estimation import make_estimator, set_frame_table
from jointwear_ros.model import (
    ParameterSet,
    SetUnits,
    load_parameter_set_info,
    paper_model,
    parameter_set_document,
)
from jointwear_ros.types import ObservationTable

WEARS = (0.0, 10.0, 20.0, 30.0, 40.0)
CALIBRATIONS = ("relative", "paper", "midpoint")  # midpoint: half-way (log) between the two, the default
TRUTHS = ("abs", "lvl")
#: the baseline's conditions (data synth defaults: load uniform 0.02-0.5; --temperature 18:52)
BASE_T, BASE_LOAD = 35.0, 0.26

#: torque-level parameters (scaled by a friction factor), speed parameters, temperature-sensitivity ones
LEVEL = ("Fc0", "Fctm", "Fstm", "Fs0", "FsT", "Fv0", "FvT")


@dataclass(frozen=True)
class JointSpec:
    name: str
    base: str  # a shipped set, or a variation of ref-2011r
    friction: float = 1.0  # factor on LEVEL
    changes: tuple[tuple[str, float], ...] = ()  # normalized values replaced
    gear_ratio: float | None = None  # joint side when given
    torque_scale: float | None = None


JOINTS = (
    JointSpec("cobot-j3", "cobot-j3"),
    JointSpec("arm6-base", "arm6-base"),
    JointSpec("arm6-wrist", "arm6-wrist"),
    JointSpec("low-n", "ref-2011r", 0.6, (("vsT", 0.35), ("Tv0", 20.0))),
    JointSpec("high-n", "ref-2011r", 1.7, (("vsT", 0.15), ("Tv0", 35.0))),
    JointSpec("hot-n", "ref-2011r", 1.15, (("FsT", 1.8e-3), ("Fs0", -0.027), ("vsT", 0.5))),
    JointSpec("mid-j", "ref-2011r", 1.25, (("vsT", 0.2), ("Tv0", 30.0)), gear_ratio=100.0, torque_scale=60.0),
    JointSpec("small-j", "ref-2011r", 0.75, (("FsT", 1.5e-3), ("Fs0", -0.022)), gear_ratio=50.0, torque_scale=2.0),
)


def to_frame(values: dict[str, float], units: SetUnits) -> dict[str, float]:
    """Normalized motor-side values of Eq. (9) in a set's units."""
    sf, tf = units.speed_factor, units.torque_factor
    f = {"Fc0": tf, "Fs0": tf, "FsT": tf, "Fsw": tf, "Fv0": tf / sf, "FvT": tf / sf, "Fvw": tf / sf,
         "vstm": sf, "vs0": sf, "vsT": sf, "vsw": sf}
    return {k: v * f.get(k, 1.0) for k, v in values.items()}


def true_sets(spec: JointSpec, where: Path) -> dict[str, str]:
    """The joint's true sets (``abs`` and ``lvl`` signatures) as YAML files in ``where``; name -> path."""
    if spec.gear_ratio is None and spec.base != "ref-2011r":
        info = load_parameter_set_info(spec.base)
    else:
        ref = load_parameter_set_info(spec.base)
        vals = {k: v * (spec.friction if k in LEVEL else 1.0) for k, v in ref.values.items()}
        vals.update(dict(spec.changes))
        units = SetUnits("joint", spec.gear_ratio, spec.torque_scale) if spec.gear_ratio else SetUnits()
        vals = to_frame(vals, units)
        sf, tf = units.speed_factor, units.torque_factor
        valid = {"speed": (0.0, 280.0 * sf), "load_torque": (0.0, 1.0 * tf), "temperature": (10.0, 60.0),
                 "wear": (0.0, 100.0)}
        info = ParameterSet(spec.name, f"bench joint {spec.name}", vals, valid, units=units,
                            wear={"calibration": "paper", "source": "Eq. (8) in the set's units"})
    units = info.units
    nominal = paper_model()
    out = {}
    for truth in TRUTHS:
        vals = dict(info.values)
        vals.update(paper_wear_values(units))
        if truth == "lvl":
            p = nominal.make_params(info.parameters())
            w, _ = relative_wear_values(nominal, p, units, BASE_T, BASE_LOAD * units.torque_factor)
            vals.update(w)
        s = replace(info, name=f"{spec.name}-{truth}", values=vals, path=None)
        path = where / f"{spec.name}-{truth}.yaml"
        path.write_text(yaml.safe_dump(parameter_set_document(s), sort_keys=False), encoding="utf-8")
        out[truth] = str(path)
    return out


def level_ratio(paths: dict[str, str]) -> float:
    a, b = (load_parameter_set_info(paths[t]).values["Fsw"] for t in TRUTHS)
    return b / a


def test_cycles(path: str, seed: int, n: int) -> list[tuple[float, ObservationTable]]:
    out = []
    for k, w in enumerate(WEARS):
        t = synth_observations(n_cycles=n, seed=seed + 101 * k, params=path, model="paper+wear", wear=w,
                               temperature=(25.0, 50.0), position=(0.3, 0.3))
        cols = {c: v for c, v in t.columns.items() if c not in ("temperature", "wear")}  # T unknown
        out += [(w, g) for _, g in ObservationTable(cols, source=t.source).groups("cycle")]
    return out


@dataclass
class Row:
    joint: str
    calibration: str
    truth: str
    wear: float
    estimate: float
    std_noise: float
    std_total: float


def run_joint(spec: JointSpec, k: int, where: Path, n: int, method: str = "joint") -> list[Row]:
    paths = true_sets(spec, where)
    info = load_parameter_set_info(paths["abs"])
    base = synth_observations(n_cycles=16, seed=10 + k, params=paths["abs"], temperature=(18.0, 52.0))
    units = info.units if info.units.joint_side else SetUnits()
    table = set_frame_table(base, info)  # a joint-side joint is recorded and commissioned joint side
    rows = []
    cycles = {t: test_cycles(paths[t], 50 + 7 * k + (1000 if t == "lvl" else 0), n) for t in TRUTHS}
    made: dict[str, ParameterSet] = {}
    for cal in CALIBRATIONS:
        res = commission(table, joint=spec.name, units=units, wear_calibration=cal, diagnose_baseline=False)
        pset = res.parameter_set(f"{spec.name}-{cal}")
        made[cal] = pset
        est = make_estimator(method, params=pset, seed=0)
        for truth in TRUTHS:
            for w, t in cycles[truth]:
                r = est.estimate(t)
                sn = float(r.info.get("wear_std_noise", r.wear_std))
                rows.append(Row(spec.name, cal, truth, w, r.wear, sn, r.wear_std))
    return rows


def summary(rows: list[Row]) -> dict[str, float]:
    e = np.array([r.estimate - r.wear for r in rows])
    sn = np.array([r.std_noise for r in rows])
    st = np.array([r.std_total for r in rows])
    zn, zt = e / sn, e / st
    miss = sum(1 for r in rows if r.wear >= 40 and r.estimate < 30)
    false = sum(1 for r in rows if r.wear <= 10 and r.estimate >= 35)
    return {"n": len(rows), "zn": float(np.max(np.abs(zn))), "fn": float(np.mean(np.abs(zn) > 3)),
            "sn": float(np.mean(sn)), "zt": float(np.max(np.abs(zt))), "ft": float(np.mean(np.abs(zt) > 3)),
            "st": float(np.mean(st)), "miss": miss, "false": false}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="1 test cycle per wear level (else 2)")
    ap.add_argument("--joints", default="", help="comma-separated joint names (default: all)")
    ap.add_argument("--worst", type=int, default=0, help="also list the N estimates of largest |z| (after)")
    args = ap.parse_args(argv)
    n = 1 if args.quick else 2
    chosen = [j for j in JOINTS if not args.joints or j.name in args.joints.split(",")]
    all_rows: list[Row] = []
    with tempfile.TemporaryDirectory() as tmp:
        print("| joint | level ratio | calibration | n | before: max\\|z\\| | beyond 3 std | mean std "
              "| after: max\\|z\\| | beyond 3 std | mean std | w>=40 read <30 | w<=10 read >=35 |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for k, spec in enumerate(chosen):
            rows = run_joint(spec, k, Path(tmp), n)
            ratio = level_ratio(true_sets(spec, Path(tmp)))
            all_rows += rows
            for cal in CALIBRATIONS:
                s = summary([r for r in rows if r.calibration == cal])
                print(f"| {spec.name} | {ratio:.3f} | {cal} | {s['n']} | {s['zn']:.2f} | {s['fn']:.0%} | {s['sn']:.2f} "
                      f"| {s['zt']:.2f} | {s['ft']:.0%} | {s['st']:.2f} | {s['miss']} | {s['false']} |", flush=True)
        print()
        print("| calibration | truth | n | before: max\\|z\\| | beyond 3 std | after: max\\|z\\| | beyond 3 std "
              "| mean std after | w>=40 read <30 | w<=10 read >=35 |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        for cal in CALIBRATIONS:
            for truth in (*TRUTHS, "both"):
                sel = [r for r in all_rows if r.calibration == cal and truth in (r.truth, "both")]
                s = summary(sel)
                print(f"| {cal} | {truth} | {s['n']} | {s['zn']:.2f} | {s['fn']:.0%} | {s['zt']:.2f} | {s['ft']:.0%} "
                      f"| {s['st']:.2f} | {s['miss']} | {s['false']} |")
    if args.worst:
        print()
        for r in sorted(all_rows, key=lambda r: -abs(r.estimate - r.wear) / r.std_total)[: args.worst]:
            print(f"{r.joint} {r.calibration} {r.truth} w={r.wear:g} est={r.estimate:.2f} std_noise={r.std_noise:.2f} "
                  f"std={r.std_total:.2f} z={(r.estimate - r.wear) / r.std_total:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
