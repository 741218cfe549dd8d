"""Diagnose which physical effect the model is missing.

Every candidate of the library (:mod:`.candidates`) is fitted on top of the
current model (all parameters free, warm-started at the current fit, the
candidate's nonlinear parameters started on a grid and its linear ones solved
for) and scored by its cross-validated RMSE (folds grouped by test cycle) and
BIC. A candidate is *significant* when

* its likelihood-ratio statistic ``(SSR_model - SSR_candidate) / s^2`` exceeds
  the chi-square quantile with as many degrees of freedom as it adds
  parameters, at level ``alpha / m`` (Bonferroni over the ``m`` candidates),
  with ``s^2 = max(noise_floor^2, SSR_candidate / (n - k))`` (so a noise floor
  that is too optimistic cannot invent effects; with no noise floor this is
  an F test);
* it lowers the cross-validated RMSE; and
* it lowers the BIC.

When no candidate is significant the diagnosis says so.
"""

from __future__ import annotations

import itertools
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import stats

from ..model import Model, Parameters, Term
from ..types import ObservationTable
from .candidates import candidate_library, describe_term, linear_params, parse_spec, start_grid
from .compare import SPEED_BAND_EDGES, band_label, noise_floor
from .fit import FitResult, fit_model, group_folds, model_inputs

__all__ = ["CandidateResult", "Diagnosis", "diagnose", "fit_candidate"]

Array = npt.NDArray[np.float64]


@dataclass
class CandidateResult:
    """One candidate effect fitted on top of the current model."""

    term: str
    variables: list[str]
    description: str
    cv_rmse: float
    rmse: float
    delta_bic: float
    delta_cv_rmse: float
    statistic: float
    dof: int
    p_value: float
    significant: bool
    speed_region: tuple[float, float]
    fit: FitResult = field(repr=False)

    @property
    def speed_region_label(self) -> str:
        lo, hi = self.speed_region
        if lo <= SPEED_BAND_EDGES[0] and not math.isfinite(hi):
            return "all speeds"
        where = "low speeds" if hi <= 60 else "high speeds" if lo >= 100 else "mid speeds" if lo >= 10 and hi <= 150 else "speeds"
        return f"{where} {band_label(lo, hi)} rad/s"

    def to_dict(self) -> dict[str, Any]:
        return {
            "term": self.term,
            "variables": self.variables,
            "description": self.description,
            "cv_rmse": self.cv_rmse,
            "rmse": self.rmse,
            "delta_bic": self.delta_bic,
            "delta_cv_rmse": self.delta_cv_rmse,
            "statistic": self.statistic,
            "dof": self.dof,
            "p_value": self.p_value,
            "significant": self.significant,
            "speed_region": {"lo": self.speed_region[0], "hi": self.speed_region[1],
                             "label": self.speed_region_label},
            "expected_cv_rmse": self.cv_rmse,
        }


@dataclass
class Diagnosis:
    """The current model's errors and every candidate's, best first."""

    model: str
    n: int
    rmse: float
    cv_rmse: float
    noise_floor: float
    noise_source: str
    alpha: float
    candidates: list[CandidateResult]
    base: FitResult = field(repr=False)

    @property
    def missing_effect_found(self) -> bool:
        return any(c.significant for c in self.candidates)

    @property
    def best(self) -> CandidateResult | None:
        return self.candidates[0] if self.candidates and self.candidates[0].significant else None

    def summary(self) -> str:
        """One or two sentences: the missing effect, or that nothing significant is missing."""
        nf = f"noise floor {self.noise_floor:.5f} ({self.noise_source})" if math.isfinite(self.noise_floor) \
            else "noise floor unknown"
        b = self.best
        if b is None:
            top = self.candidates[0] if self.candidates else None
            extra = (f"; the best candidate, {top.term}, would change the CV RMSE to {top.cv_rmse:.5f} "
                     f"(p = {top.p_value:.2g}, not significant)") if top else ""
            return (f"No significant missing effect: model {self.model!r} has CV RMSE {self.cv_rmse:.5f}, "
                    f"{nf}{extra}.")
        return (f"Missing effect: {b.term} — {b.description}, structured at {b.speed_region_label}. "
                f"Adding it should bring the CV RMSE from {self.cv_rmse:.5f} to about {b.cv_rmse:.5f} ({nf}). "
                f"Try: --model \"{self.model} + {b.term}\"")

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "n": self.n,
            "rmse": self.rmse,
            "cv_rmse": self.cv_rmse,
            "noise_floor": self.noise_floor,
            "noise_source": self.noise_source,
            "missing_effect_found": self.missing_effect_found,
            "alpha": self.alpha,
            "summary": self.summary(),
            "candidates": [c.to_dict() for c in self.candidates],
        }


#: Evaluation budget of each start of a candidate fit. Candidates that are nearly
#: redundant with a term already in the model (exp_viscous(temperature) on top of
#: temp_viscous) crawl along a flat valley for thousands of evaluations without
#: changing the SSR in any digit that matters for ranking.
CANDIDATE_MAX_NFEV = 100


def fit_candidate(
    base: FitResult, term: Term, table: ObservationTable, *, folds: Array | None = None, cv_folds: int = 5,
    max_nfev: int | None = CANDIDATE_MAX_NFEV,
) -> FitResult:
    """Fit ``base.model + term``, warm-started at the base fit, ``term`` started on its grid."""
    model = Model([*base.model.terms, term])
    params: Parameters = model.make_params(base.params)
    x = model_inputs(model, table)
    lin = set(linear_params(term))
    starts = []
    for g in start_grid(term, x):
        s = {n: 0.0 for n in term.param_names if n in lin}
        s.update(g)
        starts.append(s)
    return fit_model(model, table, params, starts=starts, folds=folds, cv_folds=cv_folds, max_nfev=max_nfev)


def _speed_region(speed: Array, r0: Array, r1: Array) -> tuple[float, float]:
    v = np.abs(speed)
    edges = SPEED_BAND_EDGES
    gains = []
    for lo, hi in itertools.pairwise(edges):
        m = (v >= lo) & (v < hi)
        gains.append(float(np.sum(r0[m] ** 2 - r1[m] ** 2)) / max(int(m.sum()), 1) if m.any() else math.nan)
    g = np.asarray(gains)
    present = np.isfinite(g)
    if not present.any() or np.nanmax(g) <= 0:
        return float(edges[0]), float(edges[-1])
    on = present & (g >= 0.15 * np.nanmax(g))
    idx = np.flatnonzero(on)
    lo_i, hi_i = int(idx.min()), int(idx.max())
    # bands with data outside the region: if none, it is every speed present
    pres = np.flatnonzero(present)
    if lo_i == pres.min() and hi_i == pres.max():
        return float(edges[0]), float(edges[-1])
    return float(edges[lo_i]), float(edges[hi_i + 1])


def diagnose(
    table: ObservationTable,
    model: Model | str | FitResult,
    *,
    library: Sequence[Term] | None = None,
    extra_terms: Sequence[Term] = (),
    cv_folds: int = 5,
    alpha: float = 0.01,
    params: Parameters | None = None,
    progress: Callable[[int, int, str], None] | None = None,
) -> Diagnosis:
    """Rank candidate effects fitted on top of ``model`` and test them against the noise floor.

    Parameters
    ----------
    table
        Observations.
    model
        The current model (a spec string, a :class:`Model`, or an existing fit of it).
    library
        Candidates to try (default: :func:`candidate_library` of the data, plus ``extra_terms``).
    cv_folds
        Cross-validation folds grouped by test cycle.
    alpha
        Family-wise significance level over the whole library.
    params
        Starting values of the model (when ``model`` is not a fit).
    progress
        Called as ``progress(i, m, term)`` before each candidate.

    Returns
    -------
    Diagnosis
    """
    folds = group_folds(table, cv_folds)
    if isinstance(model, FitResult):
        base = model
    else:
        m = parse_spec(model) if isinstance(model, str) else model
        base = fit_model(m, table, params, folds=folds)
    if base.cv_residuals is None:
        base = fit_model(base.model, table, base.params, folds=folds, n_starts=1)
    nf, src = noise_floor(table)
    lib = list(library) if library is not None else candidate_library(table, base.model, extra=extra_terms)
    n = len(table)
    mcount = max(len(lib), 1)
    results: list[CandidateResult] = []
    for i, term in enumerate(lib):
        if progress is not None:
            progress(i, len(lib), term.name)
        fit = fit_candidate(base, term, table, folds=folds)
        dof = max(fit.n_free - base.n_free, 1)
        ssr_gain = max(base.ssr - fit.ssr, 0.0)
        resid_var = fit.ssr / max(n - fit.n_free, 1)
        if math.isfinite(nf) and nf > 0:
            s2 = max(nf**2, resid_var)
            stat = ssr_gain / s2
            p = float(stats.chi2.sf(stat, dof))
        else:
            stat = ssr_gain / dof / max(resid_var, 1e-300)
            p = float(stats.f.sf(stat, dof, max(n - fit.n_free, 1)))
        dbic = fit.bic - base.bic
        sig = bool(p < alpha / mcount and fit.cv_rmse < base.cv_rmse and dbic < 0)
        results.append(
            CandidateResult(
                term=term.name,
                variables=[v for v in term.variables if v != "speed"] or ["speed"],
                description=describe_term(term),
                cv_rmse=fit.cv_rmse,
                rmse=fit.rmse,
                delta_bic=dbic,
                delta_cv_rmse=fit.cv_rmse - base.cv_rmse,
                statistic=stat,
                dof=dof,
                p_value=p,
                significant=sig,
                speed_region=_speed_region(table.speed, base.residuals, fit.residuals),
                fit=fit,
            )
        )
    results.sort(key=lambda c: (not c.significant, _nan_last(c.cv_rmse), _nan_last(c.delta_bic)))
    return Diagnosis(
        model=base.spec, n=n, rmse=base.rmse, cv_rmse=base.cv_rmse, noise_floor=nf, noise_source=src,
        alpha=alpha, candidates=results, base=base,
    )


def _nan_last(x: float) -> float:
    return x if math.isfinite(x) else math.inf


def stderr_progress(i: int, m: int, name: str) -> None:  # pragma: no cover - terminal only
    """A one-line progress indicator on stderr."""
    sys.stderr.write(f"\r  candidate {i + 1}/{m}: {name[:40]:<40}")
    if i + 1 == m:
        sys.stderr.write("\r" + " " * 70 + "\r")
    sys.stderr.flush()
