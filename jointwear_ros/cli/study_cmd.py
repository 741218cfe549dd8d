"""``jointwear study``: the Section 5.1 simulation study, robustness, and the Section 6 case study.

``jointwear study [--method M] ...`` runs the paper's study (Eq. 12 data, per
speed: bias, variance, the Cramér-Rao bound, quantiles; Figs. 9-11 with
``--plot DIR``). ``jointwear study robustness`` runs several estimators when the
true temperature distribution differs from the assumed one.
``jointwear study case`` runs the synthetic case study in the spirit of
Section 6. Thin adapters over :mod:`jointwear_ros.estimation.study` and
:mod:`jointwear_ros.estimation.case_study`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..estimation.names import ESTIMATOR_NAMES
from . import UsageError
from .common import (
    check_output_dir,
    check_temperature_prior,
    format_table,
    parse_float,
    parse_float_list,
    parse_int,
    print_json,
)

if TYPE_CHECKING:
    from ..estimation.priors import TemperaturePrior

__all__ = ["register"]

DEFAULT_SPEEDS = "0:280:56"
DEFAULT_ROBUST_SPEEDS = "10,40,80,120"
DEFAULT_TRUE_T = "normal:40:3"
ACTIONS = ("run", "robustness", "case")
#: Most runs per speed (100x the paper's 10,000) and temperature samples of the paper's estimator.
MAX_RUNS = 1_000_000
MAX_N_SAMPLES = 100_000
#: Most speeds of a study (every 0.05 rad/s over 0-280).
MAX_SPEEDS = 5_600
#: Share of the available memory a study may plan to use.
MEMORY_SHARE = 0.5


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "study",
        help="the paper's Section 5.1 simulation study, robustness, and a Section 6 style case study",
        description=(
            "ACTION run (default): simulate Eq. (12) at each speed and report the estimator's bias, variance, "
            "bound and quantiles. robustness: several estimators under true temperature distributions other "
            "than the assumed one. case: a wear profile rising past 35 at k = 80 observed through a second, "
            "slightly different joint."
        ),
    )
    p.add_argument("action", nargs="?", default="run", choices=ACTIONS, help="run (default), robustness or case")
    p.add_argument("--method", default="paper", type=_method_name,
                   help=f"estimator of the study: {', '.join(ESTIMATOR_NAMES)} (default paper)")
    p.add_argument("--methods", default=None,
                   help="robustness/case: comma list of estimators (default paper,bayes,joint / paper,bayes)")
    p.add_argument("--runs", default=None, help="runs per speed (default 10000; robustness 2000)")
    p.add_argument("--speeds", default=None,
                   help=f"comma list or START:STOP:COUNT, rad/s (default {DEFAULT_SPEEDS}; robustness {DEFAULT_ROBUST_SPEEDS})")
    p.add_argument("--true-wear", default="35", help="w0 of the simulated joint (default 35)")
    p.add_argument("--true-temperature", default=DEFAULT_TRUE_T,
                   help="distribution of the true T: normal:MEAN:STD, uniform:LO:HI or LO:HI (default normal:40:3)")
    p.add_argument("--assumed-temperature", default=None,
                   help="what the estimator assumes (paper: LO:HI of its uniform, default 30:50; "
                        "bayes/joint: a prior spec, default the true distribution; robustness: U(25,55))")
    p.add_argument("--n-samples", default="200", help="paper: N temperature samples per observation (default 200)")
    p.add_argument("--point", default=None, choices=("mode", "mean", "map"),
                   help="bayes: mode (default) or mean; joint: mean (default) or map")
    p.add_argument("--load", default="0.1", help="load torque tau_m, normalized (default 0.1)")
    p.add_argument("--noise-std", default="0.0015", help="sigma_e (default 0.0015)")
    p.add_argument("--params", default="ref-2011r", help="parameter set name or YAML path (default ref-2011r)")
    p.add_argument("--seed", default="0", help="random seed (default 0)")
    p.add_argument("--tolerance", default="1.0", help="robustness: |bias| counted as unbiased (default 1.0)")
    p.add_argument("--mismatch", default="0.03", help="case: relative spread of the second joint's parameters (default 0.03)")
    p.add_argument("--hcr", action="store_true",
                   help="run: add the Hammersley-Chapman-Robbins bound per speed (where the CRB cannot be reached)")
    p.add_argument("--histogram", action="store_true", help="run: include the histogram of estimates in the JSON")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.add_argument("--plot", metavar="DIR", help="write the figures (PNG) into DIR")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_study)


# -- argument helpers -------------------------------------------------------------
def _method_name(text: str) -> str:
    """An estimator name of the registry (argparse ``type``: an unknown one is a usage error, exit 2)."""
    from ..estimation import ESTIMATORS

    key = text.strip().lower()
    if key not in ESTIMATORS:
        raise argparse.ArgumentTypeError(f"unknown method {text!r}; choose one of {', '.join(ESTIMATORS)}")
    return key


class _Bar:
    """A progress bar on stderr."""

    def __init__(self, label: str, quiet: bool) -> None:
        self.label, self.quiet = label, quiet

    def __call__(self, done: int, total: int) -> None:
        if self.quiet:
            return
        width = 30
        k = int(width * done / max(total, 1))
        sys.stderr.write(f"\r{self.label} [{'#' * k}{'.' * (width - k)}] {done}/{total}")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()


def _prior(text: str, what: str, info: Any = None) -> TemperaturePrior:
    """A temperature distribution from the command line, checked against ``info``'s valid temperatures."""
    from ..estimation.priors import parse_temperature_prior

    spec = text.strip()
    parts = spec.split(":")
    if len(parts) == 2 and _is_number(parts[0]):  # LO:HI
        spec = "uniform:" + spec
    try:
        prior = parse_temperature_prior(spec)
    except Exception as exc:  # InputDataError: name the option
        raise UsageError(f"{what}: {exc}") from None
    if info is not None:
        check_temperature_prior(prior, what, info.valid.get("temperature"), info.name)
    return prior


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _int(text: str, what: str, lo: int, hi: int | None = None) -> int:
    return parse_int(text, what, lo, hi, handler="a study")


def _speeds(text: str, info: Any = None) -> list[float]:
    v = parse_float_list(text, "--speeds", max_count=MAX_SPEEDS)
    for s in v:
        if s < 0:
            raise UsageError(f"--speeds: {s:g} is negative; give motor-side speed magnitudes >= 0 rad/s")
        if info is not None:
            try:
                info.check_range("speed", s)
            except Exception as exc:
                raise UsageError(f"--speeds: {exc}") from None
    return v


def _available_memory() -> float:
    """Bytes of memory available now (physical pages; inf where the system does not say)."""
    import os

    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return float("inf")


def _check_memory(runs: int, n_speeds: int, n_samples: int, method: str) -> None:
    """Refuse a study whose arrays would not fit: runs x speeds observations, plus a sampling
    estimator's (the paper's) runs x N temperature samples at one speed."""
    from ..estimation import ESTIMATORS

    need = 8.0 * runs * n_speeds * 8  # observations, estimates and their sorted copies, float64
    sampling = ESTIMATORS.capabilities(method).temperature_samples
    if sampling:
        need += 8.0 * runs * n_samples * 3
    avail = _available_memory()
    if need > MEMORY_SHARE * avail:
        raise UsageError(
            f"--runs {runs:,} x {n_speeds} speeds"
            + (f" x --n-samples {n_samples:,}" if sampling else "")
            + f" needs about {need / 1e9:.3g} GB of memory, {avail / 1e9:.3g} GB are available; "
            "lower --runs, --n-samples or the number of speeds"
        )


def _estimator(method: str, args: argparse.Namespace, true_t: TemperaturePrior, params: Any,
               default_assumed: str | None) -> Any:
    """An estimator configured from the command line."""
    from ..estimation import ESTIMATORS, make_estimator, resolve_model
    from ..model import load_parameter_set_info

    opts: dict[str, Any] = {"noise_std": parse_float(args.noise_std, "--noise-std")}
    assumed_text = args.assumed_temperature or default_assumed
    info = load_parameter_set_info(args.params)
    caps = ESTIMATORS.capabilities(method)
    if caps.temperature_samples:
        opts["n_samples"] = _int(args.n_samples, "--n-samples", 1, MAX_N_SAMPLES)
    if caps.temperature_assumption == "range":
        if assumed_text is not None:
            pr = _prior(assumed_text, "--assumed-temperature", info)
            if pr.kind != "uniform":
                raise UsageError(f"--assumed-temperature {assumed_text!r}: the paper's estimator assumes a "
                                 "uniform range; give LO:HI")
            opts["temperature_range"] = pr.args
    elif caps.temperature_assumption == "prior":
        opts["prior"] = _prior(assumed_text, "--assumed-temperature", info) if assumed_text else true_t
    if args.point is not None and caps.point(args.point) is not None:
        opts["point"] = caps.point(args.point)
    model, _ = resolve_model(None, info)  # the set's own model (its core terms)
    return make_estimator(method, model, params, **opts)


def _common(args: argparse.Namespace) -> tuple[Any, Any, TemperaturePrior, int, float, float, float]:
    from ..estimation import resolve_model
    from ..model import load_parameter_set_info

    info = load_parameter_set_info(args.params)
    _, params = resolve_model(None, info)
    true_t = _prior(args.true_temperature, "--true-temperature", info)
    seed = _int(args.seed, "--seed", 0)
    wear = parse_float(args.true_wear, "--true-wear")
    if not 0 <= wear <= 100:
        raise UsageError(f"--true-wear: {wear:g} must be within [0, 100]")
    load = parse_float(args.load, "--load")
    if load < 0:
        raise UsageError(f"--load: {load:g} must be >= 0")
    try:
        info.check_range("load_torque", load)
    except Exception as exc:
        raise UsageError(f"--load: {exc}") from None
    noise = parse_float(args.noise_std, "--noise-std")
    if not 0 < noise <= 1:
        raise UsageError(f"--noise-std: {noise:g} must be positive and at most 1 (normalized torque; "
                         "the paper's is 0.0015)")
    check_output_dir(args.plot, "--plot")
    return info, params, true_t, seed, wear, load, noise


def _methods(text: str | None, default: str) -> list[str]:
    from ..estimation import ESTIMATORS

    names = [m.strip().lower() for m in (text or default).split(",") if m.strip()]
    bad = [m for m in names if m not in ESTIMATORS]
    if bad or not names:
        raise UsageError(f"--methods: {', '.join(bad) or 'empty'} not known; choose from {', '.join(ESTIMATORS)}")
    return names


# -- actions ---------------------------------------------------------------------
def cmd_study(args: argparse.Namespace) -> int:
    if args.action == "robustness":
        return _cmd_robustness(args)
    if args.action == "case":
        return _cmd_case(args)
    return _cmd_run(args)


def _cmd_run(args: argparse.Namespace) -> int:
    from ..estimation import ESTIMATORS, resolve_model
    from ..estimation.study import StudySetup, run_study

    info, params, true_t, seed, wear, load, noise = _common(args)
    runs = _int(args.runs or "10000", "--runs", 2, MAX_RUNS)
    speeds = _speeds(args.speeds or DEFAULT_SPEEDS, info)
    est = _estimator(args.method, args, true_t, params, None)
    _check_memory(runs, len(speeds), int(getattr(est, "n_samples", 1)), args.method)
    setup = StudySetup(speeds=speeds, runs=runs, true_wear=wear, load=load, noise_std=noise,
                       true_temperature=true_t, seed=seed)
    cycle = ESTIMATORS.capabilities(args.method).cycle
    unit = "cycles" if cycle else "speeds"
    if args.hcr and cycle:
        raise UsageError("--hcr: the HCR bound is per speed; a joint study has one multi-speed bound (crb)")
    res = run_study(est, setup, model=resolve_model(None, info)[0], params=params, hcr=bool(args.hcr),
                    progress=_Bar(f"study {args.method} ({unit})", args.quiet))
    if args.plot:
        _plot_study(res, Path(args.plot))
    if args.json:
        print_json(res.to_dict(histogram=args.histogram))
        return 0
    print(f"method {res.method} ({res.mode}), {res.runs} runs, {res.seconds:.2f} s; true w = {res.true_wear:g}, "
          f"true T ~ {res.true_temperature}, assumed {res.assumed_temperature}")
    if res.mode == "cycle":
        print("each run is one test cycle over all speeds at one shared unknown T; one estimate per cycle")
    q = res.quantiles
    rows = [[lab, float(b), float(v), float(c), float(m), float(q[0.025][i]), float(q[0.5][i]), float(q[0.975][i])]
            for i, (lab, b, v, c, m) in enumerate(zip(res.rows, res.bias, res.variance, res.crb, res.mse))]
    headers = ["speed", "bias", "variance", "crb", "mse", "q2.5", "median", "q97.5"]
    if res.hcr is not None and res.twin_wear is not None:
        headers[4:4] = ["hcr", "twin w"]
        for r, h, tw in zip(rows, res.hcr, res.twin_wear):
            r[4:4] = [float(h), float(tw)]
    print(format_table(headers, rows, ".3f"))
    if res.hcr is not None:
        print("hcr: Hammersley-Chapman-Robbins bound; where it is far above crb the CRB cannot be reached "
              "(another wear gives nearly the same friction); inf: 'twin w' gives exactly the same friction")
    for k, val in res.extra.items():
        print(f"{k}: {val:.4g}" if isinstance(val, float) else f"{k}: {val}")
    return 0


def _cmd_robustness(args: argparse.Namespace) -> int:
    from ..estimation import ESTIMATORS, resolve_model
    from ..estimation.study import DEFAULT_ROBUSTNESS_SCENARIOS, StudySetup, robustness_study

    info, params, true_t, seed, wear, load, noise = _common(args)
    runs = _int(args.runs or "2000", "--runs", 2, MAX_RUNS)
    speeds = _speeds(args.speeds or DEFAULT_ROBUST_SPEEDS, info)
    tol = parse_float(args.tolerance, "--tolerance")
    if tol <= 0:
        raise UsageError(f"--tolerance: {tol:g} must be positive")
    methods = _methods(args.methods, "paper,bayes,joint")
    ests = {m: _estimator(m, args, true_t, params,
                          "uniform:25:55" if ESTIMATORS.capabilities(m).temperature_assumption == "prior" else None)
            for m in methods}
    for m, e in ests.items():
        _check_memory(runs, len(speeds), int(getattr(e, "n_samples", 1)), m)
    scenarios: dict[str, Any] = dict(DEFAULT_ROBUSTNESS_SCENARIOS)
    if args.true_temperature != DEFAULT_TRUE_T:
        scenarios = {f"given {true_t.label}": true_t}
    setup = StudySetup(speeds=speeds, runs=runs, true_wear=wear, load=load, noise_std=noise, seed=seed)
    rows = robustness_study(ests, scenarios, setup, model=resolve_model(None, info)[0], params=params, tolerance=tol,
                            progress=_Bar("robustness (scenario x method)", args.quiet))
    summary = {m: all(r.unbiased for r in rows if r.method == m) for m in methods}
    if args.json:
        print_json({"runs": runs, "speeds": speeds, "true_wear": wear, "tolerance": tol,
                    "rows": [r.to_dict() for r in rows], "unbiased_in_every_scenario": summary})
        return 0
    print(f"robustness: {runs} runs per cell, true w = {wear:g}; 'yes' = |bias| <= {tol:g}")
    table = [[r.scenario, r.method, r.assumed_temperature, r.speed, r.bias, r.std, r.rmse,
              "yes" if r.unbiased else "NO"] for r in rows]
    print(format_table(["true T", "method", "assumed", "speed", "bias", "std", "rmse", "unbiased"], table, ".2f"))
    for m, ok in summary.items():
        print(f"{m}: {'unbiased in every scenario' if ok else 'biased in some scenario'}")
    return 0


def _cmd_case(args: argparse.Namespace) -> int:
    from ..estimation import resolve_model
    from ..estimation.case_study import CaseSetup, run_case_study

    info, params, true_t, seed, _, load, noise = _common(args)
    speeds = _speeds(args.speeds or DEFAULT_SPEEDS, info)
    methods = _methods(args.methods, "paper,bayes")
    mismatch = parse_float(args.mismatch, "--mismatch")
    if not 0 <= mismatch < 0.5:
        raise UsageError(f"--mismatch: {mismatch:g} must be within [0, 0.5)")
    ests = {m: _estimator(m, args, true_t, params, None) for m in methods}
    setup = CaseSetup(speeds=tuple(speeds), load=load, noise_std=noise, temperature=true_t, mismatch=mismatch,
                      seed=seed)
    res = run_case_study(ests, setup, model=resolve_model(None, info)[0], params=params,
                         progress=_Bar("case study (methods)", args.quiet))
    if args.plot:
        _plot_case(res, Path(args.plot))
    if args.json:
        print_json(res.to_dict())
        return 0
    print(res.summary_text())
    return 0


# -- figures -----------------------------------------------------------------------
def _plot_study(res: Any, out: Path) -> None:
    import numpy as np

    from ..plots import WEAR_LABEL, legend_outside, new_figure, save_figure

    v = np.asarray(res.speeds)
    if res.mode == "per-speed":
        fig, axes = new_figure()
        ax = axes[0][0]
        edges = res.hist_edges
        centres = 0.5 * (edges[1:] + edges[:-1])
        dens = res.hist_counts / (res.runs * np.diff(edges)[None, :])
        if v.size > 1:
            cs = ax.contourf(v, centres, dens.T, levels=12, cmap="viridis")
            fig.colorbar(cs, ax=ax, label="density of w_hat")
        mean = res.true_wear + res.bias
        import matplotlib.patheffects as pe

        ax.plot(v, mean, color="white", lw=1.8, label="mean of w_hat",  # outlined: seen on the plot and the legend
                path_effects=[pe.Stroke(linewidth=3.2, foreground="black"), pe.Normal()])
        ax.axhline(res.true_wear, color="red", ls="--", lw=1.0, label=f"true w = {res.true_wear:g}")
        ax.set_xlabel("speed v, motor side [rad/s]")
        ax.set_ylabel("w_hat, " + WEAR_LABEL)
        ax.set_title(f"Fig. 9: density of w_hat over speed ({res.method}, {res.runs} runs)")
        legend_outside(ax, "below", fontsize=8, ncol=2)
        save_figure(fig, out / f"study_{res.method}_density.png")

        fig, axes = new_figure()
        ax = axes[0][0]
        ax.plot(v, res.bias, "o-", ms=3)
        ax.axhline(0.0, color="grey", lw=0.6)
        ax.set_xlabel("speed v, motor side [rad/s]")
        ax.set_ylabel("bias of w_hat, " + WEAR_LABEL)
        ax.set_title(f"Fig. 10: bias ({res.method})")
        ax.grid(alpha=0.3)
        save_figure(fig, out / f"study_{res.method}_bias.png")

    fig, axes = new_figure()
    ax = axes[0][0]
    if res.mode == "per-speed":
        ax.semilogy(v, res.variance, "o-", ms=3, label="variance of w_hat")
        ax.semilogy(v, res.mse, "s-", ms=2, lw=0.8, label="mean-squared error")
        if np.isfinite(res.crb).any():
            ax.semilogy(v, res.crb, "k--", label="Cramer-Rao bound")
        if res.hcr is not None:
            finite = np.isfinite(res.hcr)
            ax.semilogy(v[finite], res.hcr[finite], ":", color="tab:red", lw=1.5,
                        label="Hammersley-Chapman-Robbins bound")
            if (~finite).any():
                ax.axvspan(float(v[~finite].min()), float(v[~finite].max()), color="tab:red", alpha=0.08,
                           label="a twin wear gives the same friction")
        ax.set_xlabel("speed v, motor side [rad/s]")
    else:
        ax.bar(["variance", "mse", "multi-speed CRB"], [res.variance[0], res.mse[0], res.crb[0]])
        ax.set_yscale("log")
    ax.set_ylabel("variance of w_hat [(% of failure state)²]")
    ax.set_title(f"Fig. 11: variance and the bound ({res.method})")
    ax.grid(alpha=0.3, which="both")
    legend_outside(ax, "right", fontsize=8) if res.mode == "per-speed" else None
    save_figure(fig, out / f"study_{res.method}_variance.png")


#: one look per estimator in the case study (colour, line, marker): told apart in colour and in grey
_METHOD_STYLE = (("tab:blue", "-", "o"), ("tab:orange", "--", "s"), ("tab:green", "-.", "^"), ("tab:purple", ":", "D"))


def _plot_case(res: Any, out: Path) -> None:
    import numpy as np

    from ..plots import WEAR_LABEL, legend_outside, new_figure, save_figure

    fig, axes = new_figure(2, 1, size=(9.5, 8.5))
    ax = axes[0][0]
    k = res.k
    ax.plot(k, res.w_true, "-", color="0.2", lw=2.4, alpha=0.5, label="true w", zorder=1)
    ax.plot(k, res.w_ref, ":", color="black", lw=1.2, label="w* (Eq. 16)", zorder=2)
    every = max(1, len(k) // 12)
    for j, (m, d) in enumerate(res.methods.items()):
        i = d["best_index"]
        c, ls, mk = _METHOD_STYLE[j % len(_METHOD_STYLE)]
        ax.plot(k, d["estimates"][:, i], color=c, ls=ls, lw=1.4, marker=mk, ms=5, markevery=(j * every // 2, every),
                mfc="white" if j % 2 else c, zorder=3 + j, label=f"{m} at {res.speeds[i]:.1f} rad/s")
    ax.axhline(35.0, color="red", ls=(0, (1, 3)), label="threshold 35")
    traces = [(m, np.asarray(d["estimates"][:, d["best_index"]], float)) for m, d in res.methods.items()]
    if len(traces) >= 2:  # traces that lie on each other: say by how much they differ
        (m0, a0), (m1, a1) = traces[:2]
        diff = np.abs(a0 - a1)
        diff = diff[np.isfinite(diff)]
        if diff.size:
            ax.text(1.01, 0.0, f"|{m0} - {m1}|:\nmean {float(diff.mean()):.2g},\nlargest {float(diff.max()):.2g}",
                    transform=ax.transAxes, fontsize=8, va="bottom", ha="left")
    ax.set_xlabel("index k (one estimate per step of the case) [-]")
    ax.set_ylabel("w, " + WEAR_LABEL)
    legend_outside(ax, "right", fontsize=8)
    ax.set_title("Fig. 13: estimated wear over k at the best speed")
    ax = axes[1][0]
    for j, (m, d) in enumerate(res.methods.items()):
        c, _, mk = _METHOD_STYLE[j % len(_METHOD_STYLE)]
        ax.plot(res.speeds, d["mean"], color=c, marker=mk, ms=4, label=f"{m}: mean dw")
        ax.plot(res.speeds, d["worst"], color=c, ls="--", label=f"{m}: worst |dw|")
        ax.plot(res.speeds, 3 * d["std"], color=c, ls=":", label=f"{m}: 3 std")
    ax.set_xlabel("speed v, motor side [rad/s]")
    ax.set_ylabel("dw = w_hat - w* [% of failure state]")
    # every curve whole (no cut at a fixed limit); a symmetric log scale when the worst case dwarfs the rest
    vals = np.concatenate([np.asarray(d[key], float).ravel() * f for d in res.methods.values()
                           for key, f in (("mean", 1.0), ("worst", 1.0), ("std", 3.0))])  # what is drawn
    vals = vals[np.isfinite(vals)]
    if vals.size:
        lo, hi = min(float(vals.min()), 0.0), max(float(vals.max()), 1.0)
        if hi - lo > 100.0:
            ax.set_yscale("symlog", linthresh=5.0)
            ax.set_ylabel("dw = w_hat - w* [% of failure state]\n(linear within ±5, logarithmic beyond)")
        pad = 0.05 * (hi - lo)
        ax.set_ylim(lo - pad, hi + pad)
    ax.grid(alpha=0.3)
    legend_outside(ax, "right", fontsize=7.5)
    ax.set_title("Fig. 14: bias, worst case and 3 std of dw over speed")
    save_figure(fig, out / "case_study.png")
