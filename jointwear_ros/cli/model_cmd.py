"""``jointwear model ...``: evaluate, fit, compare and diagnose the friction model.

``curve`` evaluates Eq. (9). The workbench actions (``fit``, ``diagnose``,
``compare``, ``add``, ``report``) take an observation table (CSV or a
rosbag2/MCAP bag of FrictionObservation) and a model spec; they are thin
adapters over :mod:`jointwear_ros.workbench`."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from . import UsageError
from .common import (
    check_output_dir,
    check_output_file,
    format_table,
    parse_float,
    parse_float_list,
    print_json,
)

__all__ = ["register"]

DEFAULT_SPEEDS = "0,10,25,47,80,150,280"


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("model", help="evaluate, fit and diagnose the friction model")
    msub = p.add_subparsers(dest="model_command", metavar="ACTION", parser_class=type(p))
    msub.required = True

    c = msub.add_parser(
        "curve",
        help="friction curve of the model (Eq. 9) with each term's contribution",
        description="Evaluate tau_f(v, tau_m, T, w) of Eq. (9) at given speeds, with every term's share.",
    )
    c.add_argument("--params", default="ref-2011r", help="parameter set name or YAML path (default ref-2011r)")
    c.add_argument("--load", default="0.1", help="load torque tau_m, normalized (default 0.1)")
    c.add_argument("--temperature", default="40", help="joint temperature, degC (default 40)")
    c.add_argument("--wear", default="0", help="wear level w, 0-100 (default 0)")
    c.add_argument("--speeds", default=DEFAULT_SPEEDS, help=f"comma list or START:STOP:COUNT, rad/s (default {DEFAULT_SPEEDS})")
    c.add_argument("--json", action="store_true", help="print JSON instead of a table")
    c.add_argument("--plot", metavar="FILE.png", help="draw the curve and its components to a PNG")
    c.set_defaults(func=cmd_curve)

    _register_workbench(msub)


def cmd_curve(args: argparse.Namespace) -> int:
    import numpy as np

    from ..model import load_parameter_set_info, paper_wear_model

    info = load_parameter_set_info(args.params)
    load = parse_float(args.load, "--load")
    temperature = parse_float(args.temperature, "--temperature")
    wear = parse_float(args.wear, "--wear")
    speeds = np.asarray(parse_float_list(args.speeds, "--speeds"))
    info.check_range("load_torque", abs(load))
    info.check_range("temperature", temperature)
    info.check_range("wear", wear)
    for s in speeds:
        if s < 0:
            raise UsageError(f"--speeds: {s:g} is negative; the model is for |v|, give speeds >= 0")
        info.check_range("speed", float(s))
    check_output_file(args.plot, "--plot", suffix=".png")

    model = paper_wear_model()
    params = model.make_params(info.parameters())
    inputs = dict(speed=speeds, load_torque=load, temperature=temperature, wear=wear)
    tau = model.evaluate(params, **inputs)
    comps = model.components(params, **inputs)

    if args.plot:
        from ..plots import plot_curve

        vv = np.linspace(0.0, float(max(speeds.max(), 1.0)), 300)
        dense = dict(inputs, speed=vv)
        plot_curve(
            Path(args.plot),
            vv,
            model.evaluate(params, **dense),
            model.components(params, **dense),
            title=f"{info.name}: tau_m={load:g}, T={temperature:g} degC, w={wear:g}",
            points=(speeds, tau),
        )

    if args.json:
        print_json(
            {
                "params": info.name,
                "load_torque": load,
                "temperature": temperature,
                "wear": wear,
                "speed": speeds,
                "tau_f": tau,
                "components": comps,
            }
        )
    else:
        print(f"# {info.name}: tau_m = {load:g}, T = {temperature:g} degC, w = {wear:g}")
        print(f"# {model.equation()}")
        headers = ["speed", "tau_f", *comps]
        rows = [[f"{s:g}", float(tau[i]), *(float(comps[k][i]) for k in comps)] for i, s in enumerate(speeds)]
        print(format_table(headers, rows))
        if args.plot:
            print(f"# plot written to {args.plot}")
    return 0


# -- the model workbench ---------------------------------------------------------
def _add_data_args(p: argparse.ArgumentParser, model_required: bool = True) -> None:
    p.add_argument("data", metavar="DATA", help="observation table: CSV file, or rosbag2/MCAP bag of FrictionObservation")
    if model_required:
        p.add_argument("--model", required=True, metavar="SPEC",
                       help="model spec: standard, paper, paper+wear, or 'A + B + ...' of term names "
                            "(built-in terms, generic terms such as x_stribeck(lube_hours), pkg.module:Class)")
    p.add_argument("--topic", default=None, help="bag topic to read (default: every FrictionObservation topic)")
    p.add_argument("--params", default=None, help="parameter set name or YAML path for starting values")
    p.add_argument("--fix", action="append", default=[], metavar="NAME[=VALUE]",
                   help="hold a parameter fixed (at VALUE, or its starting value); repeatable")
    p.add_argument("--folds", type=int, default=5, help="cross-validation folds, grouped by cycle (default 5)")
    p.add_argument("--speed-unit", default="rad/s", choices=["rad/s", "rpm", "deg/s"],
                   help="unit of the table's speed column (default rad/s; a table's '# units:' line takes precedence)")
    p.add_argument("--temperature-unit", default="degC", choices=["degC", "K", "degF"],
                   help="unit of the table's temperature column (default degC)")


def _register_workbench(msub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    f = msub.add_parser("fit", help="fit a model spec to observations (RMSE, CV RMSE, AIC/BIC, parameters)",
                        description="Nonlinear least-squares fit of a model to an observation table.")
    _add_data_args(f)
    f.add_argument("--json", action="store_true", help="print JSON (rmse, cv_rmse, aic, bic, params, ...)")
    f.add_argument("--report", metavar="DIR", help="write plots and an HTML report into DIR")
    f.add_argument("--history", metavar="FILE.json", help="append this model version to a JSON history")
    f.set_defaults(func=cmd_fit)

    d = msub.add_parser("diagnose", help="which physical effect is the model missing?",
                        description="Fit every candidate effect on top of the model, rank by CV error and BIC, "
                                    "test against the noise floor.")
    _add_data_args(d)
    out = d.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="print JSON")
    out.add_argument("--markdown", action="store_true",
                     help="print the report as Markdown (for an issue, a wiki page or a log book)")
    d.add_argument("--candidate", action="append", default=[], metavar="TERM",
                   help="also try this term (e.g. a user term pkg.module:Class); repeatable")
    d.add_argument("--alpha", type=float, default=0.01, help="family-wise significance level (default 0.01)")
    d.add_argument("--top", type=int, default=10, help="candidates to list (default 10)")
    d.add_argument("--library", choices=("guided", "full"), default="guided",
                   help="guided (default): the fixed library's generic shapes only for the columns the model-free "
                        "ranking finds; full: for every column")
    d.add_argument("--report", metavar="DIR", help="write plots and an HTML report into DIR")
    d.set_defaults(func=cmd_diagnose)

    c = msub.add_parser("compare", help="compare model specs: errors, errors per speed band, residual structure")
    _add_data_args(c, model_required=False)
    c.add_argument("--model", action="append", required=True, metavar="SPEC", help="a model spec; repeat to compare")
    c.add_argument("--json", action="store_true", help="print JSON")
    c.add_argument("--plot", metavar="DIR", help="write overlaid residual and band-error plots into DIR")
    c.set_defaults(func=cmd_compare)

    a = msub.add_parser("add", help="add a term to the model, refit, show the error fall",
                        description="Fit SPEC and SPEC + TERM; show RMSE per speed band before and after.")
    _add_data_args(a)
    a.add_argument("--term", required=True, metavar="TERM", help="term to add (a candidate's term string, or pkg.module:Class)")
    a.add_argument("--history", metavar="FILE.json", help="append both versions to a JSON history")
    a.add_argument("--plot", metavar="DIR", help="write overlaid before/after plots (and the error-fall chart) into DIR")
    a.add_argument("--json", action="store_true", help="print JSON")
    a.set_defaults(func=cmd_add)

    r = msub.add_parser("report", help="self-contained HTML report: fit, residuals, diagnosis, history")
    _add_data_args(r)
    r.add_argument("--out", required=True, metavar="DIR", help="output directory")
    r.add_argument("--history", metavar="FILE.json", help="model history to chart (read only)")
    r.add_argument("--no-diagnose", action="store_true", help="leave out the diagnosis (faster)")
    r.set_defaults(func=cmd_report)


def _check_out_dir(value: str | None, flag: str) -> None:
    check_output_dir(value, flag)


def _prepare(args: argparse.Namespace, spec: str) -> tuple[Any, Any, Any]:
    """Read the data, parse the model and the starting parameters (everything that can fail on input)."""
    from ..io.tables import read_table
    from ..model import load_parameter_set_info
    from ..workbench import parse_spec

    if args.folds < 0 or args.folds == 1:
        raise UsageError(f"--folds: {args.folds} must be 0 (no cross-validation) or at least 2")
    model = parse_spec(spec)
    table = _in_base_units(read_table(args.data, topic=args.topic), args)
    info = load_parameter_set_info(args.params) if args.params else None
    start = info.parameters() if info is not None else None
    if info is not None:
        _check_table_in_range(table, info)
    params = model.make_params(start)
    for item in args.fix:
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in params:
            raise UsageError(f"--fix: model {model.spec!r} has no parameter {name!r}; it has {', '.join(params)}")
        if value:
            v = parse_float(value, f"--fix {name}")
            p = params[name]
            if not p.min <= v <= p.max:
                raise UsageError(f"--fix {name}: {v:g} is outside the parameter's bounds [{p.min:g}, {p.max:g}]")
            p.value = v
        params[name].vary = False
    from ..workbench.fit import model_inputs

    model_inputs(model, table)  # the columns the model needs: a missing one is named first
    n_free = len(params.free())
    if len(table) <= n_free:
        raise UsageError(
            f"{table.source}: {len(table)} observation(s) cannot fit model {model.spec!r}, which has {n_free} free "
            f"parameters; give more than {n_free} rows, or hold parameters with --fix"
        )
    return table, model, params


def _in_base_units(table: Any, args: argparse.Namespace) -> Any:
    """The table in degC and rad/s (its frame kept: the workbench fits in the data's own units), its temperatures
    checked: kelvin or degF named with the flag that converts them."""
    from ..model import load_parameter_set_info
    from ..units import TableUnits, check_temperature, effective_units, in_base_units

    declared = table.units
    frame = declared.frame if declared is not None else "motor_normalized"
    try:
        assumed = TableUnits(frame, speed_unit=args.speed_unit, temperature_unit=args.temperature_unit)
    except Exception as exc:
        raise UsageError(str(exc)) from None
    explicit = args.speed_unit != "rad/s" or args.temperature_unit != "degC"
    units = effective_units(table, assumed, explicit=explicit)
    out = in_base_units(table, units)
    if getattr(args, "params", None):  # the set's range first: its message names the set
        _check_table_in_range(out, load_parameter_set_info(args.params))
    check_temperature(out, units)
    return out


def _check_table_in_range(table: Any, info: Any) -> None:
    """The table's temperatures inside the parameter set's valid range (as ``model curve`` checks its
    argument): temperatures in kelvin against a set in degC are refused before any fit. (Speeds and loads
    beyond the set's range are left to the fit: the set only gives starting values there.)"""
    import numpy as np

    for var, (lo, hi) in info.valid.items():
        if var != "temperature" or var not in table.columns:
            continue
        col = np.asarray(table.columns[var], dtype=float)
        col = col[np.isfinite(col)]
        if col.size == 0:
            continue
        vmin, vmax = float(col.min()), float(col.max())
        if vmin < lo or vmax > hi:
            hint = ("; in kelvin? the set is in degC (subtract 273.15)" if var == "temperature" and vmin > 200 else "")
            raise UsageError(f"{table.source}: column {var} runs from {vmin:g} to {vmax:g}, outside the valid range "
                             f"[{lo:g}, {hi:g}] of parameter set {info.name!r}{hint}")


def _fit(table: Any, model: Any, params: Any, folds: int) -> Any:
    from ..workbench import fit_model, group_folds

    return fit_model(model, table, params, folds=group_folds(table, folds) if folds >= 2 else None,
                     cv_folds=folds)


def _bands_dict(table: Any, fit: Any) -> list[dict[str, Any]]:
    from ..workbench import band_rmse

    return [{"band": b.label, "lo": b.lo, "hi": b.hi, "n": b.n, "rmse": b.rmse}
            for b in band_rmse(table.speed, fit.residuals)]


def cmd_fit(args: argparse.Namespace) -> int:
    from ..workbench import noise_floor, noise_test
    from ..workbench.history import History

    _check_out_dir(args.report, "--report")
    check_output_file(args.history, "--history")
    table, model, params = _prepare(args, args.model)
    history = History.load(args.history) if args.history else None
    fit = _fit(table, model, params, args.folds)
    if args.report:
        from ..workbench.report import write_report

        write_report(args.report, table, fit, history=history)
    if history is not None:
        history.add(fit, table)
        history.save()
    if args.json:
        nf, src = noise_floor(table)
        print_json({**fit.to_dict(), "data": table.source, "noise_floor": nf, "noise_source": src,
                    "goodness_of_fit": noise_test(table, fit.residuals, fit.n_free).to_dict(),
                    "bands": _bands_dict(table, fit)})
    else:
        from ..workbench.render import fit_text

        print(fit_text(table, fit))
        if args.report:
            print(f"# report written to {Path(args.report) / 'report.html'}")
    return 0


def _stderr_progress(i: int, m: int, name: str) -> None:  # pragma: no cover - terminal only
    """A one-line progress indicator of the candidates on stderr."""
    import sys

    sys.stderr.write(f"\r  candidate {i + 1}/{m}: {name[:40]:<40}")
    if i + 1 == m:
        sys.stderr.write("\r" + " " * 70 + "\r")
    sys.stderr.flush()


def _progress() -> Any:
    import sys

    return _stderr_progress if sys.stderr.isatty() else None


def cmd_diagnose(args: argparse.Namespace) -> int:
    from ..model import parse_spec
    from ..workbench import diagnose, resolve_term

    _check_out_dir(args.report, "--report")
    if not 0 < args.alpha < 1:
        raise UsageError(f"--alpha: {args.alpha} must be between 0 and 1")
    if args.folds < 2:
        raise UsageError(f"--folds: diagnose ranks by cross-validated error; give at least 2, got {args.folds}")
    table, model, params = _prepare(args, args.model)
    extra = []
    for t in args.candidate:
        term = resolve_term(t)
        extra.append(term if term is not None else parse_spec(t).terms[0])
    base = _fit(table, model, params, args.folds)
    diag = diagnose(table, base, extra_terms=extra, cv_folds=args.folds, alpha=args.alpha, progress=_progress(),
                    mode=args.library)
    if args.report:
        from ..workbench.report import write_report

        write_report(args.report, table, base, diagnosis=diag)
    if args.json:
        from ..workbench.render import diagnosis_dict

        print_json({**diagnosis_dict(diag), "converged": base.success,
                    "at_bound": [h.to_dict() for h in base.at_bound]})
        return 0
    from ..workbench.render import diagnosis_markdown, diagnosis_text

    render = diagnosis_markdown if args.markdown else diagnosis_text
    print(render(diag, table.source, args.top, at_bound=base.at_bound))
    if args.report:
        print(f"# report written to {Path(args.report) / 'report.html'}")
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from ..workbench import noise_floor, residual_structure

    _check_out_dir(args.plot, "--plot")
    prepared = [_prepare(args, spec) for spec in args.model]
    table = prepared[0][0]
    fits = [_fit(table, m, p, args.folds) for _, m, p in prepared]
    nf, src = noise_floor(table)
    if args.plot:
        from ..workbench.report import plot_band_errors, plot_residuals

        labelled = [(f"{i + 1}: {f.spec}", f) for i, f in enumerate(fits)]
        plot_residuals(Path(args.plot) / "residuals.png", table, labelled)
        plot_band_errors(Path(args.plot) / "bands.png", table, labelled)
    if args.json:
        print_json({
            "data": table.source, "n": len(table), "noise_floor": nf, "noise_source": src,
            "models": [{**f.to_dict(), "bands": _bands_dict(table, f),
                        "residual_structure": [{"column": s.column, "r2_binned": s.r2_binned, "corr": s.corr}
                                               for s in residual_structure(table, f.residuals)]} for f in fits],
        })
        return 0
    from ..workbench.render import compare_text

    print(compare_text(table, fits))
    if args.plot:
        print(f"# plots written to {args.plot}")
    return 0


def cmd_add(args: argparse.Namespace) -> int:
    from ..workbench import noise_floor, noise_test
    from ..workbench.history import History

    _check_out_dir(args.plot, "--plot")
    check_output_file(args.history, "--history")
    table, model, params = _prepare(args, args.model)
    _, model2, params2 = _prepare(args, f"{args.model} + {args.term}")
    history = History.load(args.history) if args.history else None
    before = _fit(table, model, params, args.folds)
    after = _fit(table, model2, params2, args.folds)
    if history is not None:
        # each (model, data) once: `model add` run again adds no duplicate version (the error-fall chart
        # would go down, up, down)
        def known(spec: str) -> bool:
            return any(v.model == spec and v.data == table.source for v in history.versions)

        if not known(before.spec):
            history.add(before, table)
        if not known(after.spec):
            history.add(after, table, note=f"added {args.term}")
    if args.plot:
        from ..workbench.report import plot_band_errors, plot_error_fall, plot_residuals

        pair = [("before: " + before.spec, before), ("after: " + after.spec, after)]
        plot_residuals(Path(args.plot) / "residuals_before_after.png", table, pair)
        plot_band_errors(Path(args.plot) / "bands_before_after.png", table, pair)
        if history is not None:
            plot_error_fall(Path(args.plot) / "error_fall.png", history)
    if history is not None:
        history.save()
    nf, _ = noise_floor(table)
    if args.json:
        print_json({
            "data": table.source, "noise_floor": nf, "term": args.term,
            "before": {**before.to_dict(), "bands": _bands_dict(table, before)},
            "after": {**after.to_dict(), "bands": _bands_dict(table, after)},
            "cv_rmse_ratio": before.cv_rmse / after.cv_rmse if after.cv_rmse > 0 else None,
            "goodness_of_fit": {"before": noise_test(table, before.residuals, before.n_free).to_dict(),
                                "after": noise_test(table, after.residuals, after.n_free).to_dict()},
        })
        return 0
    from ..workbench.render import add_text

    print(add_text(table, before, after))
    if args.history:
        print(f"# history: {args.history} ({len(history.versions) if history else 0} versions)")
    if args.plot:
        print(f"# plots written to {args.plot}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from ..workbench import diagnose
    from ..workbench.history import History
    from ..workbench.report import write_report

    _check_out_dir(args.out, "--out")
    table, model, params = _prepare(args, args.model)
    history = History.load(args.history) if args.history else None
    fit = _fit(table, model, params, max(args.folds, 2))
    diag = None if args.no_diagnose else diagnose(table, fit, cv_folds=max(args.folds, 2), progress=_progress())
    path = write_report(args.out, table, fit, diagnosis=diag, history=history)
    print(f"# report written to {path}")
    return 0
