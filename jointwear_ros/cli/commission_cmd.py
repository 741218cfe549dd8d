"""``jointwear commission`` and ``jointwear estimate``: a joint's own model, and wear estimates with it.

``commission DATA... --joint J --out SET.yaml`` fits the joint's nominal model on
baseline cycles (bags of this suite or observation tables) and writes a parameter
set that carries the model (see :mod:`jointwear_ros.commission`).
``estimate DATA... --params SET.yaml`` estimates the wear of every test cycle of
every joint in the data with that set. Both check every input before any work;
bad input is one line and exit 2, and nothing is written.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from ..commission.names import DEFAULT_WEAR_CALIBRATION, WEAR_CALIBRATIONS
from ..estimation.names import ESTIMATOR_NAMES
from . import UsageError
from .common import add_unit_flags, check_output_dir, check_output_file, print_json, units_from_args

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    c = sub.add_parser("commission", help="identify a joint's nominal friction model from its baseline cycles",
                       description="Fit a joint's nominal (w = 0, as installed) friction model on baseline test "
                                   "cycles (bags of this suite or observation tables), validate it on held-out "
                                   "cycles, run the workbench's diagnosis on it, and write a parameter set that "
                                   "carries the model, its covariance, valid ranges, units, wear calibration and "
                                   "provenance.")
    c.add_argument("data", nargs="+", metavar="DATA", help="bag directories and/or observation CSV tables")
    c.add_argument("--joint", required=True, help="the joint to commission")
    c.add_argument("--robot", default="", help="robot name (provenance)")
    c.add_argument("--model", default=None,
                   help="nominal model spec (default paper, and a missing effect the workbench finds and held-out "
                        "cycles confirm is carried into it; a model you give is kept as given)")
    c.add_argument("--gear-ratio", type=float, default=None,
                   help="DATA is joint side (rad/s, N·m): motor speed = joint speed x this (with --torque-scale)")
    c.add_argument("--torque-scale", type=float, default=None, help="N·m (joint side) per normalized torque unit")
    add_unit_flags(c, frame_flags=False)
    c.add_argument("--wear-calibration", default=DEFAULT_WEAR_CALIBRATION,
                   help=f"{' | '.join(WEAR_CALIBRATIONS)} | FILE (default {DEFAULT_WEAR_CALIBRATION}; without wear data "
                        "on the joint each is a prior whose uncertainty every estimate's std includes, "
                        "docs/commissioning.md); FILE: known wear levels, calibrated")
    c.add_argument("--name", default=None, help="name of the set (default: the --out file's stem)")
    c.add_argument("--out", required=True, help="parameter set YAML to write")
    c.add_argument("--report", default=None, metavar="DIR", help="write a fit plot and the JSON report here")
    c.add_argument("--no-diagnose", action="store_true", help="skip the workbench verdict on the baseline")
    c.add_argument("--json", action="store_true", help="print JSON")
    c.set_defaults(func=cmd_commission)

    e = sub.add_parser("estimate", help="wear estimate of every test cycle with a parameter set",
                       description="Estimate the wear of every test cycle of every joint in observation tables "
                                   "or bags with a parameter set (a commissioned one, or a named set).")
    e.add_argument("data", nargs="+", metavar="DATA", help="bag directories and/or observation CSV tables")
    e.add_argument("--params", required=True, metavar="SET", help="parameter set name or YAML path")
    e.add_argument("--method", default="joint",
                   help=f"estimator: {', '.join(ESTIMATOR_NAMES)} (default joint, the cycle's shared temperature)")
    e.add_argument("--joint", default=None, help="only this joint (tables without a joint column: the set's joint)")
    add_unit_flags(e)
    e.add_argument("--alarm", type=float, default=35.0, help="alarm level of wear (default 35)")
    e.add_argument("--warn", type=float, default=30.0, help="warning level of wear (default 30)")
    e.add_argument("--seed", type=int, default=0)
    e.add_argument("--json", action="store_true", help="print JSON")
    e.set_defaults(func=cmd_estimate)


def _read_all(paths: list[str], default_joint: str | None,
              skipped: list[str] | None = None) -> list[tuple[str, str, Any]]:
    """``(path, joint, table)`` of every input; with ``skipped`` a bag that cannot be read (a failed cycle that
    recorded no observation, a foreign bag) is skipped with its reason, as long as another input is read."""
    from ..errors import InputDataError
    from ..io.observations import read_observations

    out = []
    for p in paths:
        try:
            tables = read_observations(p, default_joint)
        except InputDataError as exc:
            if skipped is None or not _is_bag(p):
                raise
            skipped.append(str(exc))
            continue
        for joint, table in tables.items():
            out.append((p, joint, table))
    if not out and skipped:
        raise InputDataError(f"no input could be read: {skipped[0]}"
                             + (f" (and {len(skipped) - 1} more)" if len(skipped) > 1 else ""))
    return out


def _is_bag(path: str) -> bool:
    p = Path(path)
    return p.is_dir() or p.suffix in (".mcap", ".db3")


def cmd_commission(args: argparse.Namespace) -> int:
    import numpy as np

    from ..commission import commission
    from ..errors import InputDataError
    from ..model import parameter_set_document
    from ..types import ObservationTable
    from ..units import SetUnits, TableUnits, prepare_baseline, to_set_frame

    assumed, explicit = units_from_args(args, joint_side=args.gear_ratio is not None)  # flags checked here
    if (args.gear_ratio is None) != (args.torque_scale is None):
        raise UsageError("--gear-ratio and --torque-scale go together (DATA joint side: both say how it maps to "
                         "the motor side and the normalized torque)")
    out = check_output_file(args.out, "--out", ".yaml")
    assert out is not None  # --out is required
    report = check_output_dir(args.report, "--report")
    wc = args.wear_calibration
    if wc not in WEAR_CALIBRATIONS and not Path(wc).is_file():
        raise UsageError(f"--wear-calibration {wc!r}: use {', '.join(WEAR_CALIBRATIONS)} or an existing calibration "
                         "FILE")
    skipped: list[str] = []
    inputs = [(path, table) for path, joint, table in _read_all(args.data, args.joint, skipped)
              if joint in (args.joint, "")]
    if not inputs:
        raise InputDataError(f"no observations of joint {args.joint!r} in {', '.join(args.data)}")
    units = SetUnits("joint", args.gear_ratio, args.torque_scale) if args.gear_ratio else SetUnits()
    if not args.gear_ratio:  # tables that declare one joint-side frame give the set's frame
        declared = {(t.units.gear_ratio, t.units.torque_scale) for _, t in inputs
                    if isinstance(t.units, TableUnits) and t.units.declared and t.units.joint_side}
        if len(declared) == 1 and None not in next(iter(declared)):
            gear, scale = next(iter(declared))
            units = SetUnits("joint", gear, scale)
    parts = []
    for path, table in inputs:
        # every table to the suite's units (checked: kelvin, rpm, N·m read as normalized, ... are named), then
        # into the set's frame (bags hold the suite's units: to joint side with the given gear and scale)
        suite = prepare_baseline(table, assumed, explicit=explicit, where=table.source or path,
                                 fix_frame="--gear-ratio G --torque-scale S")
        parts.append(to_set_frame(suite, units))
    cols: dict[str, list[np.ndarray]] = {}
    names = [n for n in parts[0].names if all(n in t for t in parts)]
    for i, t in enumerate(parts):
        for n in names:
            x = np.asarray(t[n], dtype=float)
            if n == "cycle":
                x = x + 1e6 * i  # cycles of different files stay apart
            cols.setdefault(n, []).append(x)
    table = ObservationTable({n: np.concatenate(v) for n, v in cols.items()}, source=", ".join(args.data))
    wear_table = None
    if wc not in WEAR_CALIBRATIONS and Path(wc).suffix not in (".yaml", ".yml"):
        from ..io.tables import read_table

        wear_table = read_table(wc)
    res = commission(table, joint=args.joint, robot=args.robot, model=args.model or "paper",
                     model_explicit=args.model is not None, units=units,
                     wear_calibration=wc, wear_table=wear_table, diagnose_baseline=not args.no_diagnose,
                     sources=[str(Path(p)) for p in args.data])
    import yaml

    pset = res.parameter_set(args.name or out.stem)
    out.write_text(yaml.safe_dump(parameter_set_document(pset), sort_keys=False, allow_unicode=True), encoding="utf-8")
    doc = res.to_dict(str(out))
    if skipped:
        doc["skipped_inputs"] = skipped
    if report is not None:
        _report(report, table, res, doc)
    if args.json:
        print_json(doc)
        return 0
    print(f"commissioned {args.joint}: model {res.set_spec} ({res.units.frame}), {res.n} observations in "
          f"{res.n_cycles} cycles, {res.seconds:.1f} s")
    print(f"{'parameter':<12} {'value':>13} {'stderr':>11}")
    for n, p in res.params.items():
        se = "-" if p.stderr is None or not math.isfinite(p.stderr) else f"{p.stderr:.3g}"
        print(f"{n:<12} {p.value:>13.6g} {se:>11}")
    for k, v in res.wear.items():
        print(f"{k:<12} {v:>13.6g} {'(' + res.wear.label + ')':>11}")
    print(f"fit: {'converged' if res.converged else 'NOT converged'} ({res.message}); RMSE {res.rmse:.4g}, "
          f"CV RMSE {res.cv_rmse:.4g}, noise floor {res.noise_floor:.4g} ({res.noise_method})")
    print("CV RMSE per speed band: " + ", ".join(f"{b['lo']:.3g}-{b['hi']:.3g}: {b['cv_rmse']:.3g}"
                                                   for b in res.bands))
    print("valid: " + ", ".join(f"{k} [{lo:.4g}, {hi:.4g}]" for k, (lo, hi) in res.valid.items()))
    print(f"workbench verdict on the baseline: {res.verdict}" + (f" (suggests {res.suggestion})" if res.suggestion else ""))
    if res.carried:
        print(f"carried into the model: {res.carried} (CV RMSE {res.cv_rmse_before:.4g} -> {res.cv_rmse_after:.4g} "
              f"on {res.validation}; verdict after: {res.verdict_after})")
    print(f"validated on {res.validation}")
    if res.fixed:
        print("fixed (the data do not identify them): " + ", ".join(f"{k} = {v:.6g}" for k, v in res.fixed.items()))
    print(f"wear calibration: {res.wear.label}: {res.wear.source}")
    for w in res.warnings:
        print(f"warning: {w}")
    for why in skipped:
        print(f"skipped: {why}")
    print(f"wrote {out}")
    return 0


def _report(report: Path, table: Any, res: Any, doc: dict[str, Any]) -> None:
    """``commission.json`` and ``commission.png``: the baseline with the fitted model over it (left; the model
    at each observation and its curve at the median of the other inputs) and the residual (right)."""
    import json

    import numpy as np

    from ..plots import legend_outside, new_figure, save_figure

    report.mkdir(parents=True, exist_ok=True)
    (report / "commission.json").write_text(json.dumps(doc, indent=2, default=str), encoding="utf-8")
    from ..workbench import parse_spec
    from ..workbench.fit import model_inputs

    m = parse_spec(res.spec)
    inputs = model_inputs(m, table)
    fitted = m.evaluate(res.params, **inputs)
    speed = np.abs(np.asarray(table.speed, float))
    fig, axes = new_figure(1, 2, size=(11.5, 4.4))
    ax, axr = axes[0]
    temp = table.get("temperature")
    sc = ax.scatter(speed, table.tau_f, s=6, c=temp, cmap="coolwarm", zorder=3, label="baseline (observed)")
    ax.plot(speed, fitted, "_", ms=7, mew=1.0, color="black", alpha=0.7, zorder=2,
            label="fitted model at each observation")
    grid = np.linspace(float(speed.min()), float(speed.max()), 200)
    sign = -1.0 if float(np.median(np.asarray(table.speed, float))) < 0 else 1.0  # the side most data are on
    at = {k: sign * grid if k == "speed" else np.full(grid.size, float(np.median(v))) for k, v in inputs.items()}
    curve = np.asarray(m.evaluate(res.params, **at), float) * np.ones(grid.size)
    med = ", ".join(f"{k} {float(np.median(v)):.3g}" for k, v in inputs.items() if k != "speed")
    ax.plot(grid, curve, color="black", lw=1.6, zorder=4,
            label="fitted model at the median inputs" + (f" ({med})" if med else ""))
    ax.set_xlabel(f"speed |v| [{res.units.speed_unit}]")
    ax.set_ylabel(f"friction torque tau_f [{res.units.torque_unit}]")
    ax.set_title(f"{res.joint}: baseline and the fitted model", fontsize=10)
    ax.grid(alpha=0.3)
    if temp is not None:
        fig.colorbar(sc, ax=ax, label="temperature [°C]")
    legend_outside(ax, "below", fontsize=7.5)
    axr.scatter(speed, table.tau_f - fitted, s=6)
    axr.axhline(0, color="k", lw=0.5)
    axr.set_xlabel(f"speed |v| [{res.units.speed_unit}]")
    axr.set_ylabel(f"residual tau_f - model [{res.units.torque_unit}]")
    axr.set_title(f"CV RMSE {res.cv_rmse:.3g}, verdict {res.verdict}", fontsize=10)
    axr.grid(alpha=0.3)
    save_figure(fig, report / "commission.png")


def cmd_estimate(args: argparse.Namespace) -> int:
    from ..commission import estimate_cycles
    from ..commission.estimate import conditions
    from ..model import load_parameter_set_info
    from ..units import prepare_for_set

    pset = load_parameter_set_info(args.params)
    set_joint = str(pset.provenance.get("joint", "")) or args.joint or ""
    assumed, explicit = units_from_args(args)
    tau_range = pset.friction_range()
    tables = []
    for path, joint, table in _read_all(args.data, set_joint):
        joint = joint or set_joint
        if args.joint and joint != args.joint:
            continue
        # to the suite's units, checked against the set (a unit slip is one line naming the fix); the estimator
        # maps the suite's units into the set's frame
        tables.append((path, joint, prepare_for_set(table, pset, assumed, explicit=explicit,
                                                    where=table.source or path, tau_range=tau_range)))
    verdict = str(pset.provenance.get("verdict_after") or pset.provenance.get("verdict") or "")
    rows: list[dict[str, Any]] = []
    infos: list[Any] = []
    cycles = estimate_cycles(tables, pset, args.method, args.seed)
    for c, cond in zip(cycles, conditions(cycles, args.warn, args.alarm)):
        r = c.result
        infos.append(r.info)
        rows.append({"source": c.source, "joint": c.joint, "cycle": c.cycle, "cycle_source": c.cycle_source,
                     "estimate": r.wear,
                     "std": r.wear_std, "temperature": r.temperature, "level": cond.level,
                     "evidence": cond.evidence, "confirmation": cond.confirmation,
                     "level_wear": cond.level_wear if math.isfinite(cond.level_wear) else None,
                     "level_reason": cond.reason,
                     "method": r.method, "wear_calibration": r.info.get("wear_calibration"),
                     "calibrated": bool(r.info.get("calibrated", True)),
                     "std_noise": r.info.get("wear_std_noise", r.wear_std),
                     "wear_scale_std": r.info.get("wear_scale_std", 0.0), "low": r.wear_low, "high": r.wear_high,
                     "model_verdict": verdict or None, "parameter_set": pset.name})
    if not rows:
        from ..errors import InputDataError

        raise InputDataError(f"no observations{' of joint ' + args.joint if args.joint else ''} in "
                             f"{', '.join(args.data)}")
    if args.json:
        print_json({"estimates": rows})
        return 0
    print(f"parameter set {pset.name} (model {pset.spec}, {pset.units.frame}, wear calibration "
          f"{pset.wear_calibration}), method {args.method}")
    if verdict in ("found", "unexplained"):
        print(f"note: the set was commissioned against a workbench verdict '{verdict}': its model may miss an effect")
    # a column for where each estimate's observations came from once a production shift is among them
    two = any(row["cycle_source"] == "production" for row in rows)
    print(f"{'joint':<10} {'cycle':>6} " + (f"{'from':<10} " if two else "")
          + f"{'wear':>7} {'std':>6} {'T':>6} {'cal':>3} {'level':<5} note")
    for row in rows:
        t = "-" if not math.isfinite(row["temperature"]) else f"{row['temperature']:.1f}"
        note = {"insufficient": "too few speeds for a level: the level before stands",
                "unconfirmed": "far from the joint's standing estimate: held until the next cycle",
                "step": "a step, confirmed by two cycles", "outlier": "not confirmed by the next cycle"}
        why = note.get(row["evidence"] if row["evidence"] == "insufficient" else row["confirmation"], "")
        src = f"{row['cycle_source']:<10} " if two else ""
        print(f"{row['joint'] or '-':<10} {row['cycle']:>6} {src}{row['estimate']:>7.2f} {row['std']:>6.2f} {t:>6} "
              f"{'yes' if row['calibrated'] else 'no':>3} {row['level']:<5} {why}".rstrip())
    uncal = [r for r in rows if not r["calibrated"]]
    if uncal:
        info = uncal_info[0] if (uncal_info := [i for i in infos if not i.get("calibrated", True)]) else {}
        rel = float(info.get("wear_scale_rel_std", math.nan))
        ratio = float(info.get("wear_level_ratio", math.nan))
        print(f"# wear scale not calibrated ({pset.wear_calibration}: a prior, no wear data on this joint): the std "
              f"includes {100 * rel:.0f} % of the wear (friction level {ratio:.2f}x ref-2011r's); a FILE calibration "
              "(commission --wear-calibration FILE) removes it")
    return 0
