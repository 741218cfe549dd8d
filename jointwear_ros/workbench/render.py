"""The workbench's words: every sentence and text table the workbench shows, made from its results.

The core (:mod:`.fit`, :mod:`.compare`, :mod:`.dependence`, :mod:`.diagnose`) returns data;
this module is the one place that turns it into text: the shape a column's evidence points
to (:func:`shape_hint`), the goodness-of-fit line (:func:`goodness_of_fit`), a diagnosis's
verdict in sentences (:func:`diagnosis_summary`), and the terminal reports of ``jointwear
model fit|diagnose|compare|add`` (:func:`fit_text`, :func:`diagnosis_text`,
:func:`compare_text`, :func:`add_text`), and a diagnosis as Markdown (:func:`diagnosis_markdown`). The JSON (``to_dict``) and the HTML report
(:mod:`.report`) take their sentences from here, so the three say the same.

>>> from jointwear_ros.workbench.dependence import VariableDependence
>>> v = VariableDependence("position", 1e-9, 1e-9, 0.68, "periodogram", True, shape="periodic",
...                        peak_frequency=17.07)
>>> shape_hint(v)
'periodic in position, w = 17.07 per unit (period 0.3681)'
>>> shape_hint(VariableDependence("temperature", 0.2, 0.1, 0.02, "smoother", False, monotone="increasing",
...                               speed_dependent=True, speed_region=(0.0, 30.0)))
'smooth in temperature, increasing, mostly at 0-30 rad/s'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..fmt import format_table
from .compare import SPEED_BAND_EDGES, NoiseFloor, band_label, band_rmse, noise_floor, noise_test, residual_structure

if TYPE_CHECKING:
    from ..types import ObservationTable
    from .dependence import VariableDependence
    from .diagnose import Diagnosis
    from .fit import FitResult

__all__ = [
    "NOISE_UNKNOWN",
    "add_text",
    "candidate_region_label",
    "compare_text",
    "diagnosis_markdown",
    "diagnosis_summary",
    "diagnosis_text",
    "fit_text",
    "floor_text",
    "goodness_of_fit",
    "markdown_table",
    "noise_line",
    "shape_hint",
    "speed_region_label",
    "stability_text",
]

#: What a report says when the data give no noise floor.
NOISE_UNKNOWN = "noise floor unknown (no tau_f_std, replicates or repeated speeds across cycles)"


# -- labels ------------------------------------------------------------------------------
def speed_region_label(region: tuple[float, float]) -> str:
    """``all speeds`` or ``10-30 rad/s``."""
    lo, hi = region
    if lo <= SPEED_BAND_EDGES[0] and not math.isfinite(hi):
        return "all speeds"
    return f"{band_label(lo, hi)} rad/s"


def candidate_region_label(region: tuple[float, float]) -> str:
    """``all speeds`` or ``low speeds 0-30 rad/s`` (low, mid, high speeds by the paper's motor-side bands)."""
    lo, hi = region
    if lo <= SPEED_BAND_EDGES[0] and not math.isfinite(hi):
        return "all speeds"
    where = ("low speeds" if hi <= 60 else "high speeds" if lo >= 100
             else "mid speeds" if lo >= 10 and hi <= 150 else "speeds")
    return f"{where} {band_label(lo, hi)} rad/s"


def shape_hint(v: VariableDependence) -> str:
    """The shape a column's (or a pair's) evidence points to, in words."""
    c = v.name
    if v.shape == "interaction":
        a, b = v.columns
        return f"interaction of {a} and {b}"
    if v.shape == "adds":
        a, b = v.columns
        return f"{b} adds to {a}"
    if v.shape == "periodic" and v.peak_frequency is not None:
        w = v.peak_frequency
        hint = f"periodic in {c}, w = {w:.4g} per unit (period {2 * math.pi / w:.4g})"
    elif v.shape == "step" and v.changepoint is not None:
        hint = f"step in {c} at {v.changepoint:.6g}"
    elif v.shape == "scales":
        hint = f"scales the model's {v.scaled_term} with {c}"
    else:
        hint = f"smooth in {c}, {v.monotone}"
    if v.speed_dependent:
        hint += f", mostly at {band_label(*v.speed_region)} rad/s"
    return hint


# -- the noise floor ---------------------------------------------------------------------
def _consistent(nf: NoiseFloor) -> str:
    return "consistent" if nf.consistent else "NOT consistent"


def goodness_of_fit(nf: NoiseFloor, cv_rmse: float) -> str:
    """``goodness of fit: chi-square with tau_f_std, p = 0.57: the residual is consistent with the noise
    (CV RMSE 1.02x the floor)``."""
    if not math.isfinite(nf.value):
        return f"goodness of fit: {NOISE_UNKNOWN}"
    return (f"goodness of fit: {nf.method}, p = {nf.p_value:.2g}: the residual is {_consistent(nf)} with the noise "
            f"(CV RMSE {cv_rmse / nf.value:.2f}x the floor)")


def noise_line(nf: NoiseFloor, cv_rmse: float | None = None) -> str:
    """``noise floor 0.00150 (method): [CV RMSE = 1.00x the floor; ]p = 0.7, consistent with the noise``."""
    if not math.isfinite(nf.value):
        return NOISE_UNKNOWN
    ratio = f"CV RMSE = {cv_rmse / nf.value:.2f}x the floor; " if cv_rmse is not None else ""
    return f"noise floor {nf.value:.5f} ({nf.method}): {ratio}p = {nf.p_value:.2g}, {_consistent(nf)} with the noise"


def floor_text(nf: NoiseFloor) -> str:
    """``noise floor 0.00150 (method: p = 0.7, consistent with the noise)``, as the summary says it."""
    if not math.isfinite(nf.value):
        return NOISE_UNKNOWN
    return f"noise floor {nf.value:.5f} ({nf.method}: p = {nf.p_value:.2g}, {_consistent(nf)} with the noise)"


# -- a diagnosis in sentences --------------------------------------------------------------
def _ratio(nf: NoiseFloor, rmse: float) -> str:
    r = nf.ratio(rmse)
    return f"{r:.2f}x the noise floor" if math.isfinite(r) else "noise floor unknown"


def _outlier_text(d: Diagnosis) -> str:
    if not d.outliers:
        return ""
    rows = ", ".join(f"row {o.row} (cycle {o.cycle:g}, speed {o.speed:g}, {o.z:+.1f} std)" for o in d.outliers[:5])
    more = f" and {len(d.outliers) - 5} more" if len(d.outliers) > 5 else ""
    iso = (f" The best shape, {d.suggestion}, owes most of its gain to them: it isolates them, it is not a "
           "missing effect." if d.isolates_outliers else "")
    return (f" {len(d.outliers)} outlying observation(s): {rows}{more}; check them (a bad sample, a "
            f"disturbed cycle) before trusting any shape.{iso}")


def diagnosis_summary(d: Diagnosis) -> str:
    """The verdict in a few sentences: what is missing, or that nothing is, or what stays unexplained."""
    from .diagnose import STABLE_SUPPORT

    b = d.best
    nf = d.noise
    if d.verdict == "undetermined":
        cv = (f"CV RMSE {d.cv_rmse:.5f}" if math.isfinite(d.cv_rmse) else
              "no CV RMSE (a single group: nothing to hold out)")
        sug = f" The best candidate would be {b.term} (p = {b.p_value:.2g})." if b is not None else ""
        return (f"Undetermined: model {d.model!r} has RMSE {d.rmse:.5f}, {cv}, but there is no noise estimate to "
                "judge it by (no tau_f_std column, no repeated observations, no cycles to compare at equal speed), "
                f"so whether an effect is missing cannot be said.{sug} Give tau_f_std or record repeated cycles."
                + _outlier_text(d))
    if d.verdict == "nothing_missing":
        top = d.variables[0] if d.variables else None
        dep = (f"; no column explains its residual (strongest: {top.name}, adjusted p = {top.p_value:.2g}, "
               f"significant below {d.alpha / 2:g})" if top else "; no column to test")
        cand = (f"; the best candidate, {d.candidates[0].term}, is not significant "
                f"(p = {d.candidates[0].p_value:.2g}; significant below {d.alpha / max(len(d.candidates), 1):.2g} "
                "with a lower CV RMSE and BIC)") if d.candidates else ""
        text = (f"Nothing missing: model {d.model!r} has {_cv_text(d.cv_rmse)} "
                f"({_ratio(nf, d.cv_rmse)}); {floor_text(nf)}{dep}{cand}.")
    elif d.verdict == "found" and b is not None:
        stab = d.stability.get(b.term)
        stab_txt = (f" It is chosen in {100 * stab:.0f} % of bootstrap resamples by cycle (terms of "
                    f"{', '.join(b.key)}: {100 * d.support:.0f} %)." if stab is not None else "")
        text = (f"Missing effect found: {b.term} — {b.description}, structured at {b.speed_region_label}. "
                f"Adding it brings the CV RMSE from {d.cv_rmse:.5f} to {b.cv_rmse:.5f} "
                f"({_ratio(nf, b.cv_rmse)}) and leaves no significant dependence on any column.{stab_txt} "
                f"Try: --model \"{d.model} + {b.term}\"")
    else:
        sig = [v for v in d.variables if v.significant]
        parts = [f"Unexplained structure remains: model {d.model!r} has {_cv_text(d.cv_rmse)} "
                 f"({_ratio(nf, d.cv_rmse)}; {floor_text(nf)})."]
        if sig:
            parts.append("The residual depends on " + "; ".join(
                f"{v.name} ({v.shape_hint}; explains {100 * v.explained_share:.0f} %, adjusted p = {v.p_value:.2g})"
                for v in sig[:3]) + ".")
        else:
            parts.append("No column of the table explains it (a variable that is not recorded, or a noise "
                         "estimate that is too optimistic).")
        tried = d.candidates[:3]
        if tried:
            parts.append("Best shapes tried: " + ", ".join(
                f"{c.term} ({_ratio(nf, c.cv_rmse)}{'' if c.significant else ', not significant'})"
                for c in tried) + ".")
        if b is not None:
            rest = [v.name for v in d.after_variables if v.significant]
            left = f"; the residual still depends on {', '.join(rest)}" if rest else ""
            odd = ("" if d.agrees else
                   "; its variables are not among those the model-free ranking found, so it can only be a "
                   "partial fit")
            if d.support < STABLE_SUPPORT and d.alternatives:
                odd += (f"; the data does not tell it from {', '.join(d.alternatives[:3])} (terms of its "
                        f"column(s) win only {100 * d.support:.0f} % of bootstrap resamples by cycle)")
            parts.append(f"The best, {b.term}, leaves the CV RMSE at {_ratio(nf, b.cv_rmse)} "
                         f"(at {b.speed_region_label}){left}{odd}. "
                         f"Try next: --model \"{d.model} + {b.term}\", then diagnose again.")
        text = " ".join(parts)
    return text + _outlier_text(d)


def stability_text(d: Diagnosis) -> str:
    """``ripple(position, w0=17.07) 70 %, ...``: how often each candidate wins the bootstrap, most first."""
    return ", ".join(f"{t} {100 * f:.0f} %" for t, f in sorted(d.stability.items(), key=lambda kv: -kv[1]))


# -- the terminal reports ------------------------------------------------------------------
def fit_text(table: ObservationTable, fit: FitResult) -> str:
    """``jointwear model fit``: the model, the data and noise floor, the errors, the parameters, the bands."""
    nf, src = noise_floor(table)
    out = [f"# model: {fit.spec}", f"# {fit.model.equation()}",
           f"# data: {table.source}, n = {fit.n}; noise floor {nf:.5f} ({src})",
           "# " + goodness_of_fit(noise_test(table, fit.residuals, fit.n_free), fit.cv_rmse),
           format_table(["RMSE", "CV RMSE", "AIC", "BIC", "free", "converged"],
                        [[fit.rmse, fit.cv_rmse, f"{fit.aic:.1f}", f"{fit.bic:.1f}", fit.n_free, fit.success]])]
    if not fit.success:
        out.append(f"# solver: {fit.message}")
    out += [f"# on a bound (not converged): {h}; its stderr means nothing, the data may not identify it"
            for h in fit.at_bound]
    out.append("")
    hits = {h.name: h for h in fit.at_bound}
    rows = [[n, f"{p.value:.6g}", "fixed" if not p.vary else f"{p.stderr:.3g}" if p.stderr is not None else "-", p.unit,
             f"{hits[n].side} {hits[n].bound:.6g}" if n in hits else ""]
            for n, p in fit.params.items()]
    out.append(format_table(["parameter", "value", "stderr", "unit", "on bound"], rows))
    strong = [(a, b, fit.correlation(a, b)) for i, a in enumerate(fit.free) for b in fit.free[i + 1:]]
    strong = [s for s in strong if np.isfinite(s[2]) and abs(s[2]) > 0.95]
    if strong:
        out.append("# strongly correlated: " + ", ".join(f"{a}~{b} ({r:+.3f})" for a, b, r in strong[:6]))
    out.append("")
    out.append(format_table(["speed band", "n", "RMSE"],
                            [[b.label, b.n, b.rmse] for b in band_rmse(table.speed, fit.residuals)]))
    return "\n".join(out)


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], floatfmt: str = ".5f") -> str:
    """A Markdown (pipe) table, cells as :func:`~jointwear_ros.fmt.format_table` writes them.

    >>> print(markdown_table(["term", "CV RMSE"], [["ripple(position, w0=17.07)", 0.0015], ["a|b", float("nan")]]))
    | term | CV RMSE |
    |---:|---:|
    | ripple(position, w0=17.07) | 0.00150 |
    | a\\|b | nan |
    """
    def cell(v: Any) -> str:
        return format_table([""], [[v]], floatfmt).splitlines()[-1].strip().replace("|", "\\|")

    lines = ["| " + " | ".join(headers) + " |", "|" + "---:|" * len(headers)]
    lines += ["| " + " | ".join(cell(v) for v in r) + " |" for r in rows]
    return "\n".join(lines)


_VARIABLE_HEADERS = ["#", "variable", "explains", "p (adj.)", "signif.", "test", "shape"]
_CANDIDATE_HEADERS = ["#", "term", "variables", "CV RMSE", "x floor", "dBIC", "p", "signif.", "speed region"]
_RANKING = "which columns explain the residual (model-free; p adjusted for every column and pair tried)"
_NO_CANDIDATE = "no candidate term to fit (no column explains the residual; the paper's terms are in the model)"


def _diagnosis_rows(d: Diagnosis, top: int) -> tuple[list[list[Any]], list[list[Any]]]:
    """The rows of the model-free ranking and of the candidates (``top`` each)."""
    variables = [[i + 1, v.name, f"{100 * v.explained_share:.0f} %", f"{v.p_value:.2g}",
                  "yes" if v.significant else "no", v.test, v.shape_hint] for i, v in enumerate(d.variables[:max(top, 0)])]
    nf = d.noise
    floor = nf.value if np.isfinite(nf.value) and nf.value > 0 else float("nan")
    candidates = [[i + 1, c.term, ",".join(c.variables), c.cv_rmse,
                   f"{c.cv_rmse / floor:.2f}x" if math.isfinite(c.cv_rmse / floor) else "-", f"{c.delta_bic:.1f}",
                   f"{c.p_value:.2g}", "yes" if c.significant else "no", c.speed_region_label]
                  for i, c in enumerate(d.candidates[: max(top, 0)])]
    return variables, candidates


def _cv_text(cv_rmse: float) -> str:
    """``CV RMSE 0.00150``, or why there is none (never ``nan``)."""
    return (f"CV RMSE {cv_rmse:.5f}" if math.isfinite(cv_rmse) else
            "CV RMSE not computed (a single cycle and no other groups: nothing to hold out)")


def _level_lines(d: Diagnosis) -> list[str]:
    """What ``signif.`` means in each table (the levels the p-values are compared with), and how the
    suggestion relates to the model-free ranking, so that the tables and the verdict read alike."""
    m = max(len(d.candidates), 1)
    cand = (f"; a candidate when its p is below {d.alpha / m:.2g} (alpha / {m} candidates) and it lowers the CV RMSE "
            "and the BIC") if d.candidates else ""
    out = [f"significant: a column when its adjusted p is below {d.alpha / 2:g} (alpha {d.alpha:g}, half of it for "
           f"the ranking){cand}"]
    b = d.best
    if b is not None and d.variables:
        first = d.variables[0].name
        cols = set(b.variables)
        if first not in cols and not (set(d.variables[0].columns) & cols):
            rank = next((i + 1 for i, v in enumerate(d.variables) if set(v.columns) & cols), None)
            where = f"rank {rank} in the model-free ranking" if rank else "not in the model-free ranking"
            out.append(f"the suggestion {b.term} uses {', '.join(b.variables)} ({where}); {first} ranks first but "
                       "no candidate of it is better on held-out cycles")
    return out


def _bound_lines(at_bound: Sequence[Any]) -> list[str]:
    return [f"the model's own fit ended on a bound (not converged): {h}; the verdict is about a fit the data may "
            "not identify" for h in at_bound]


def diagnosis_text(d: Diagnosis, source: str, top: int, at_bound: Sequence[Any] = ()) -> str:
    """``jointwear model diagnose``: noise test, model-free ranking, candidates, verdict (``top`` rows each);
    ``at_bound``: the model's own parameters on a bound."""
    variables, candidates = _diagnosis_rows(d, top)
    cv = d.cv_rmse if math.isfinite(d.cv_rmse) else None
    out = [f"# model: {d.model}", f"# data: {source}, n = {d.n}; RMSE {d.rmse:.5f}, {_cv_text(d.cv_rmse)}",
           "# " + noise_line(d.noise, cv), "", f"# {_RANKING}", format_table(_VARIABLE_HEADERS, variables), "",
           format_table(_CANDIDATE_HEADERS, candidates) if candidates else f"# {_NO_CANDIDATE}"]
    out += [f"# {line}" for line in _level_lines(d)]
    if d.stability:
        out.append("# chosen in bootstrap resamples by cycle: " + stability_text(d))
    out += ["", f"verdict: {d.verdict}", d.summary()]
    out += [f"# {line}" for line in _bound_lines(at_bound)]
    return "\n".join(out)


def diagnosis_markdown(d: Diagnosis, source: str, top: int, at_bound: Sequence[Any] = ()) -> str:
    """The same report as :func:`diagnosis_text`, as a Markdown document (for an issue, a wiki page, a log book)."""
    variables, candidates = _diagnosis_rows(d, top)
    out = [f"## Diagnosis of `{d.model}`", "",
           f"Data: `{source}`, n = {d.n}; RMSE {d.rmse:.5f}, {_cv_text(d.cv_rmse)}; "
           f"{noise_line(d.noise, d.cv_rmse if math.isfinite(d.cv_rmse) else None)}.",
           "", f"**verdict: {d.verdict}**", "", d.summary(), ""]
    out += [f"*{line}*" for line in _bound_lines(at_bound)] + ([""] if at_bound else [])
    out += [f"### {_RANKING[0].upper()}{_RANKING[1:]}", "", markdown_table(_VARIABLE_HEADERS, variables), "",
            "### Candidate terms", "", markdown_table(_CANDIDATE_HEADERS, candidates) if candidates else
            _NO_CANDIDATE[0].upper() + _NO_CANDIDATE[1:] + "."]
    out += [""] + [f"*{line[0].upper()}{line[1:]}.*" for line in _level_lines(d)]
    if d.stability:
        out += ["", "Chosen in bootstrap resamples by cycle: " + stability_text(d) + "."]
    return "\n".join(out)


def compare_text(table: ObservationTable, fits: Sequence[FitResult]) -> str:
    """``jointwear model compare``: errors of each model, RMSE per speed band, residual structure."""
    nf, src = noise_floor(table)
    out = [f"# data: {table.source}, n = {len(table)}; noise floor {nf:.5f} ({src})",
           format_table(["#", "model", "RMSE", "CV RMSE", "AIC", "BIC", "free"],
                        [[i + 1, f.spec, f.rmse, f.cv_rmse, f"{f.aic:.1f}", f"{f.bic:.1f}", f.n_free]
                         for i, f in enumerate(fits)]),
           ""]
    bands = [band_rmse(table.speed, f.residuals) for f in fits]
    out.append(format_table(["speed band", "n", *[f"RMSE #{i + 1}" for i in range(len(fits))]],
                            [[b.label, b.n, *[bb[j].rmse for bb in bands]] for j, b in enumerate(bands[0])]))
    for i, f in enumerate(fits):
        out += ["", f"# residual structure of model #{i + 1} (share of residual variance explained by each column)",
                format_table(["column", "binned R2", "corr"],
                             [[s.column, s.r2_binned, s.corr] for s in residual_structure(table, f.residuals)])]
    return "\n".join(out)


def add_text(table: ObservationTable, before: FitResult, after: FitResult) -> str:
    """``jointwear model add``: errors before and after, RMSE per speed band with the ratio, the fall."""
    nf, src = noise_floor(table)
    b0, b1 = band_rmse(table.speed, before.residuals), band_rmse(table.speed, after.residuals)
    out = [f"# before: {before.spec}", f"# after:  {after.spec}",
           f"# data: {table.source}, n = {len(table)}; noise floor {nf:.5f} ({src})",
           format_table(["", "RMSE", "CV RMSE", "BIC"],
                        [["before", before.rmse, before.cv_rmse, f"{before.bic:.1f}"],
                         ["after", after.rmse, after.cv_rmse, f"{after.bic:.1f}"]]),
           "",
           format_table(["speed band", "n", "RMSE before", "RMSE after", "ratio"],
                        [[x.label, x.n, x.rmse, y.rmse, f"{x.rmse / y.rmse:.2f}x" if y.rmse > 0 else "-"]
                         for x, y in zip(b0, b1)])]
    if after.cv_rmse > 0:
        out.append(f"# CV RMSE fell {before.cv_rmse / after.cv_rmse:.2f}x"
                   + (f"; now {after.cv_rmse / nf:.2f}x the noise floor" if np.isfinite(nf) and nf > 0 else ""))
    out.append("# " + goodness_of_fit(noise_test(table, after.residuals, after.n_free), after.cv_rmse))
    return "\n".join(out)
