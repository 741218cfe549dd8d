"""The workbench's reports: every sentence, text table and terminal or Markdown report, made from its results.

The core (:mod:`.fit`, :mod:`.compare`, :mod:`.dependence`, :mod:`.diagnose`, ...) returns data (numbers,
names, dataclasses; ``to_dict`` holds no sentence); this module imports it and renders it (never the other
way): the terminal reports of ``jointwear model fit|diagnose|compare|add`` (:func:`fit_text`,
:func:`diagnosis_text`, :func:`compare_text`, :func:`add_text`), a diagnosis as Markdown
(:func:`diagnosis_markdown`), and a result's JSON with its sentences (:func:`diagnosis_dict`,
:func:`variable_dict`, :func:`candidate_dict`: the data's keys plus the shape hint, the region labels and the
verdict's summary). The sentences themselves (the shape hint, the region labels, the goodness-of-fit line,
the verdict) are made in :mod:`.phrases` and re-exported here, so the JSON, the terminal and the HTML report
(:mod:`.report`) say the same.

>>> from jointwear_ros.workbench.dependence import VariableDependence
>>> v = VariableDependence("position", 1e-9, 1e-9, 0.68, "periodogram", True, shape="periodic",
...                        peak_frequency=17.07)
>>> shape_hint(v)
'periodic in position, w = 17.07 per unit (period 0.3681)'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..fmt import format_table
from ..types import ObservationTable
from .compare import band_rmse, noise_floor, noise_test, residual_structure
from .dependence import VariableDependence
from .diagnose import CandidateResult, Diagnosis
from .fit import FitResult
from .phrases import (
    NOISE_UNKNOWN,
    candidate_region_label,
    cv_rmse_text,
    diagnosis_summary,
    floor_text,
    goodness_of_fit,
    noise_line,
    shape_hint,
    speed_region_label,
)

__all__ = [
    "NOISE_UNKNOWN",
    "add_text",
    "candidate_dict",
    "candidate_region_label",
    "compare_text",
    "diagnosis_dict",
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
    "variable_dict",
]


def stability_text(d: Diagnosis) -> str:
    """``ripple(position, w0=17.07) 70 %, ...``: how often each candidate wins the bootstrap, most first."""
    return ", ".join(f"{t} {100 * f:.0f} %" for t, f in sorted(d.stability.items(), key=lambda kv: -kv[1]))


# -- a result's JSON: its data and its sentences ----------------------------------------------
def _insert_after(doc: dict[str, Any], after: str, key: str, value: Any) -> dict[str, Any]:
    """``doc`` with ``key: value`` placed right after ``after`` (the JSON's key order is the reader's)."""
    out: dict[str, Any] = {}
    for k, v in doc.items():
        out[k] = v
        if k == after:
            out[key] = value
    return out


def variable_dict(v: VariableDependence) -> dict[str, Any]:
    """A column's (or pair's) JSON: its data (``to_dict``) with the shape hint and the speed region's label.

    >>> v = VariableDependence("position", 1e-9, 1e-9, 0.68, "periodogram", True, shape="periodic",
    ...                        peak_frequency=17.07)
    >>> doc = variable_dict(v)
    >>> doc["shape_hint"], doc["speed_region"]["label"], list(doc)[2:5]
    ('periodic in position, w = 17.07 per unit (period 0.3681)', 'all speeds', ['explained_share', 'shape_hint', 'shape'])
    """
    doc = _insert_after(v.to_dict(), "explained_share", "shape_hint", shape_hint(v))
    doc["speed_region"] = {**doc["speed_region"], "label": speed_region_label(v.speed_region)}
    return doc


def candidate_dict(c: CandidateResult) -> dict[str, Any]:
    """A candidate's JSON: its data (``to_dict``) with the speed region's label (``low speeds 0-30 rad/s``)."""
    doc = c.to_dict()
    doc["speed_region"] = {**doc["speed_region"], "label": candidate_region_label(c.speed_region)}
    return doc


def diagnosis_dict(d: Diagnosis) -> dict[str, Any]:
    """``jointwear model diagnose --json``: the diagnosis's data (``to_dict``) with its sentences: the verdict's
    ``summary``, each column's ``shape_hint`` and each speed region's ``label``."""
    doc = _insert_after(d.to_dict(), "alpha", "summary", diagnosis_summary(d))
    doc["variables"] = [variable_dict(v) for v in d.variables]
    if doc["after_suggestion"] is not None:
        doc["after_suggestion"] = {**doc["after_suggestion"],
                                   "variables": [variable_dict(v) for v in d.after_variables]}
    doc["candidates"] = [candidate_dict(c) for c in d.candidates]
    return doc


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
    out += [f"# outside its physical bounds (not converged): {n} = {fit.params[n].value:.6g} outside [{lo:g}, {hi:g}]"
            "; a widened bound let it past, a set in the paper's frame cannot hold it" for n, (lo, hi) in fit.outside_physical.items()]
    out.append("")
    hits = {h.name: h for h in fit.at_bound}
    rows = [[n, f"{p.value:.6g}", "fixed" if not p.vary else f"{p.stderr:.3g}" if p.stderr is not None else "-", p.unit,
             f"{hits[n].side} {hits[n].bound:.6g}" if n in hits else
             "outside [{:g}, {:g}]".format(*fit.outside_physical[n]) if n in fit.outside_physical else ""]
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
                  "yes" if v.significant else "no", v.test, shape_hint(v)] for i, v in enumerate(d.variables[:max(top, 0)])]
    nf = d.noise
    floor = nf.value if np.isfinite(nf.value) and nf.value > 0 else float("nan")
    candidates = [[i + 1, c.term, ",".join(c.variables), c.cv_rmse,
                   f"{c.cv_rmse / floor:.2f}x" if math.isfinite(c.cv_rmse / floor) else "-", f"{c.delta_bic:.1f}",
                   f"{c.p_value:.2g}", "yes" if c.significant else "no",
                   candidate_region_label(c.speed_region)]
                  for i, c in enumerate(d.candidates[: max(top, 0)])]
    return variables, candidates


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
    out = [f"# model: {d.model}", f"# data: {source}, n = {d.n}; RMSE {d.rmse:.5f}, {cv_rmse_text(d.cv_rmse)}",
           "# " + noise_line(d.noise, cv), "", f"# {_RANKING}", format_table(_VARIABLE_HEADERS, variables), "",
           format_table(_CANDIDATE_HEADERS, candidates) if candidates else f"# {_NO_CANDIDATE}"]
    out += [f"# {line}" for line in _level_lines(d)]
    if d.stability:
        out.append("# chosen in bootstrap resamples by cycle: " + stability_text(d))
    out += ["", f"verdict: {d.verdict}", diagnosis_summary(d)]
    out += [f"# {line}" for line in _bound_lines(at_bound)]
    return "\n".join(out)


def diagnosis_markdown(d: Diagnosis, source: str, top: int, at_bound: Sequence[Any] = ()) -> str:
    """The same report as :func:`diagnosis_text`, as a Markdown document (for an issue, a wiki page, a log book)."""
    variables, candidates = _diagnosis_rows(d, top)
    out = [f"## Diagnosis of `{d.model}`", "",
           f"Data: `{source}`, n = {d.n}; RMSE {d.rmse:.5f}, {cv_rmse_text(d.cv_rmse)}; "
           f"{noise_line(d.noise, d.cv_rmse if math.isfinite(d.cv_rmse) else None)}.",
           "", f"**verdict: {d.verdict}**", "", diagnosis_summary(d), ""]
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
