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

Around that ranking, the diagnosis is honest about what it cannot
explain:

1. the current model's residual is tested against the noise floor
   (:func:`~jointwear_ros.workbench.compare.noise_test`);
2. every numeric column (and pairs) is ranked by how much of the residual it
   explains without assuming a shape
   (:func:`~jointwear_ros.workbench.dependence.residual_dependence`);
3. for the columns that do explain something, shapes beyond the fixed library
   are fitted (:mod:`.shapes`: a ripple started at the periodogram's peak, a
   step at the changepoint, B-splines with the knot count chosen by
   cross-validation, the model's own terms scaled by the column);
4. the verdict: ``nothing_missing`` (residual consistent with the noise and
   no column explains it, no candidate significant), ``found`` (a candidate
   brings the CV RMSE within :data:`FOUND_RATIO` of the noise floor and leaves
   no significant dependence, and terms of its columns win at least
   :data:`STABLE_SUPPORT` of the bootstrap resamples by cycle against every
   other explanation), else ``unexplained`` (what remains, where, how far
   above the floor the best shape stays, and the alternatives the data does
   not rule out); ``undetermined`` when there is no noise estimate to judge the residual by (no
   ``tau_f_std``, no repeated observations, no cycles to compare at equal speed).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import stats

from ..errors import ModelError
from ..model import TERMS, Model, Parameters, Term, parse_spec
from ..model.shapes import HarmonicRipple, Interaction, Scale, Spline, Step, is_angle
from ..types import ObservationTable
from .candidates import candidate_library
from .compare import NoiseFloor, noise_test, speed_region, sweep_scatter
from .dependence import VariableDependence, one_blas_thread, residual_dependence
from .fit import FitResult, fit_model, group_folds, model_inputs
from .significance import nested_test

__all__ = ["FOUND_RATIO", "STABLE_SUPPORT", "VERDICTS", "CandidateResult", "Diagnosis", "adaptive_candidates", "diagnose",
           "fit_candidate"]

#: A candidate "found" the missing effect when its CV RMSE is within this many noise floors.
FOUND_RATIO = 1.3
#: The answers of a diagnosis (``undetermined``: no noise estimate to judge the residual by).
VERDICTS = ("nothing_missing", "found", "unexplained", "undetermined")
#: Bootstrap resamples (by cycle) of the choice among the best candidates.
N_BOOTSTRAP = 200
#: "found" needs candidates of the best one's column(s) to win at least this share of the resamples.
STABLE_SUPPORT = 0.8

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
    #: The columns the candidate depends on besides the speed (see :func:`_same`).
    key: tuple[str, ...] = ()
    #: The columns the candidate brings in (a scaled term: its factor).
    factors: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The data (no sentence: the JSON with the region's words is
        :func:`~jointwear_ros.workbench.render.candidate_dict`)."""
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
            "speed_region": {"lo": self.speed_region[0], "hi": self.speed_region[1]},
            "expected_cv_rmse": self.cv_rmse,
        }


@dataclass
class Diagnosis:
    """The current model's errors, the noise test, the model-free ranking, every candidate, and the verdict.

    Data only: the verdict in sentences is :func:`~jointwear_ros.workbench.render.diagnosis_summary`.
    """

    model: str
    n: int
    rmse: float
    cv_rmse: float
    noise: NoiseFloor
    alpha: float
    candidates: list[CandidateResult]
    base: FitResult = field(repr=False)
    variables: list[VariableDependence] = field(default_factory=list)
    verdict: str = "unexplained"
    suggestion: str | None = None
    after_noise: NoiseFloor | None = None
    after_variables: list[VariableDependence] = field(default_factory=list)
    stability: dict[str, float] = field(default_factory=dict)
    agrees: bool = True
    #: Share of the bootstrap resamples won by a candidate of the suggestion's column(s) (1 without a bootstrap).
    support: float = 1.0
    #: Candidates of other columns that win some resamples: explanations the data does not rule out.
    alternatives: list[str] = field(default_factory=list)
    #: Rows whose residual is far outside the robust noise floor (:func:`find_outliers`), found before any shape
    #: is fitted: a shape that only isolates them is not a missing effect.
    outliers: list[Outlier] = field(default_factory=list)
    #: The suggestion owes most of its gain to the outlying rows (it isolates them): not ``found``.
    isolates_outliers: bool = False

    @property
    def noise_floor(self) -> float:
        return self.noise.value

    @property
    def noise_source(self) -> str:
        return self.noise.method

    @property
    def missing_effect_found(self) -> bool:
        return any(c.significant for c in self.candidates)

    @property
    def stable(self) -> bool:
        """Do the best candidate's columns win at least :data:`STABLE_SUPPORT` of the bootstrap resamples?"""
        return self.support >= STABLE_SUPPORT

    @property
    def best(self) -> CandidateResult | None:
        return self.candidates[0] if self.candidates and self.candidates[0].significant else None

    def to_dict(self) -> dict[str, Any]:
        """The data (no sentence: the JSON with the verdict's summary, the shape hints and the region labels is
        :func:`~jointwear_ros.workbench.render.diagnosis_dict`)."""
        return {
            "model": self.model,
            "n": self.n,
            "rmse": self.rmse,
            "cv_rmse": self.cv_rmse,
            "verdict": self.verdict,
            "noise_floor": self.noise.to_dict(),
            "noise_source": self.noise.method,
            "variables": [v.to_dict() for v in self.variables],
            "suggestion": self.suggestion,
            "missing_effect_found": self.missing_effect_found,
            "alpha": self.alpha,
            "after_suggestion": None if self.after_noise is None else {
                "noise_floor": self.after_noise.to_dict(),
                "cv_rmse": self.best.cv_rmse if self.best else None,
                "ratio_to_floor": self.noise.ratio(self.best.cv_rmse) if self.best else None,
                "variables": [v.to_dict() for v in self.after_variables],
            },
            "stability": dict(self.stability),
            "support": self.support,
            "alternatives": list(self.alternatives),
            "candidates": [c.to_dict() for c in self.candidates],
            "outliers": [o.to_dict() for o in self.outliers],
        }


@dataclass(frozen=True)
class Outlier:
    """One observation far outside the robust noise floor: its row (0-based, table order), cycle, speed, residual
    and standardised residual."""

    row: int
    cycle: float
    speed: float
    residual: float
    z: float

    def to_dict(self) -> dict[str, float]:
        return {"row": self.row, "cycle": self.cycle, "speed": self.speed, "residual": self.residual, "z": self.z}


#: At most this share of the rows (and at least 2) are reported as outliers; more is structure, not outliers.
OUTLIER_MAX_SHARE = 0.02
#: A candidate that owes at least this share of its gain (residual sum of squares) to the outlying rows only
#: isolates them: never ``found``.
OUTLIER_GAIN_SHARE = 0.5


def _gain_on(outliers: Sequence[Outlier], before: Array, after: Array) -> float:
    """Share of the fall in the residual sum of squares from ``before`` to ``after`` made on the outlying rows."""
    if not outliers:
        return 0.0
    b, a = np.asarray(before, dtype=float), np.asarray(after, dtype=float)
    gain = float(np.sum(b**2) - np.sum(a**2))
    if not gain > 0:
        return 0.0
    rows = [o.row for o in outliers]
    return float(np.sum(b[rows] ** 2 - a[rows] ** 2)) / gain


def find_outliers(table: ObservationTable, residuals: Array, alpha: float = 0.01) -> list[Outlier]:
    """Rows whose residual is beyond the robust noise floor (a Bonferroni bound at ``alpha`` over the rows).

    Each residual is standardised by its ``tau_f_std`` when the table has it; the scale is then re-estimated
    robustly (1.4826 x the median absolute deviation), so a few gross rows cannot inflate it. Returns the
    outlying rows, worst first; none when there are more than ``OUTLIER_MAX_SHARE`` of the rows (that is
    structure a shape may explain, not outliers).

    >>> import numpy as np
    >>> from jointwear_ros.data.synth import synth_observations
    >>> t = synth_observations(n_cycles=10, seed=1)
    >>> r = np.random.default_rng(0).normal(0.0, 0.0015, len(t)); r[[7, 30]] += 0.02
    >>> sorted(o.row for o in find_outliers(t, r))
    [7, 30]
    """
    r = np.asarray(residuals, dtype=float)
    n = r.size
    if n < 8:
        return []
    z = r.copy()
    if "tau_f_std" in table:
        sd = np.asarray(table["tau_f_std"], dtype=float)
        ok = np.isfinite(sd) & (sd > 0)
        if ok.all():
            z = r / sd
    med = float(np.median(z))
    scale = 1.4826 * float(np.median(np.abs(z - med)))
    if not math.isfinite(scale) or scale <= 0:
        return []
    u = (z - med) / scale
    bound = float(stats.norm.isf(alpha / (2 * n)))
    rows = np.flatnonzero(np.abs(u) > bound)
    if rows.size == 0 or rows.size > max(2, int(OUTLIER_MAX_SHARE * n)):
        return []
    cyc = np.asarray(table["cycle"], dtype=float) if "cycle" in table else np.full(n, np.nan)
    spd = np.asarray(table.speed, dtype=float)
    out = [Outlier(int(i), float(cyc[i]), float(spd[i]), float(r[i]), float(u[i])) for i in rows]
    return sorted(out, key=lambda o: -abs(o.z))


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
    lin = set(term.linear)
    starts = []
    for g in term.guess(x):
        s = {n: 0.0 for n in term.param_names if n in lin}
        s.update(g)
        starts.append(s)
    if isinstance(term, Scale):  # the scaled term's shape starts where the model's own copy is
        own = {new: base.params[old].value for old, new in term.inner_names().items()
               if old in base.params and new not in lin}
        if own:
            starts.insert(0, {**{n: 0.0 for n in term.param_names if n in lin}, **own})
    return fit_model(model, table, params, starts=starts, folds=folds, cv_folds=cv_folds, max_nfev=max_nfev)


def adaptive_candidates(
    table: ObservationTable, model: Model, variables: Sequence[VariableDependence], *, top: int = 3,
    spline_sizes: Sequence[int] = (4, 6, 8),
    explore: bool = False,
) -> list[Term]:
    """Shapes fitted to what the model-free ranking found, for its ``top`` significant columns.

    A ripple started at the periodogram's peak (one and two harmonics) for a
    periodic column; a step at the changepoint; B-splines over the column's
    range with ``spline_sizes`` basis functions (the cross-validated error
    picks among them); for the strongest column (and any column explaining
    at least half its share), each term of the model scaled by it; for a
    significant pair, their product. With ``explore``
    and no significant column, the two strongest columns are used.
    """
    have = set(model.term_names)
    usable = set(table.names)
    out: list[Term] = []

    def add(t: Term) -> None:
        if t.name not in have and t.name not in {u.name for u in out}:
            out.append(t)

    singles = [v for v in variables if v.significant and "," not in v.name][:top]
    if not singles and explore:
        singles = [v for v in variables if "," not in v.name][:2]
    for rank, v in enumerate(singles):
        col = table[v.name]
        if v.peak_frequency is not None:
            add(HarmonicRipple(v.name, w0=float(f"{v.peak_frequency:.4g}")))
            add(HarmonicRipple(v.name, w0=float(f"{v.peak_frequency:.4g}"), k=2))
        elif is_angle(v.name):
            add(HarmonicRipple(v.name))
        lo, hi = float(np.min(col)), float(np.max(col))
        # the spec prints the range: enough digits that it stays a range (a time stamp in seconds since 1970
        # spans a few thousand in 1.8e9)
        digits = next((d for d in (6, 9, 12, 15) if float(f"{lo:.{d}g}") < float(f"{hi:.{d}g}")), None)
        if v.changepoint is not None and v.changepoint_width is not None:
            add(Step(v.name, at=float(f"{v.changepoint:.{max(digits or 6, 6)}g}"),
                     width=float(f"{v.changepoint_width:.3g}")))
        if hi > lo and digits is not None:
            for k in spline_sizes if rank == 0 else spline_sizes[1:2]:
                add(Spline(v.name, lo=float(f"{lo:.{digits}g}"), hi=float(f"{hi:.{digits}g}"), n=k))
        if rank == 0 or v.explained_share >= 0.5 * singles[0].explained_share:
            # each term of the model scaled by the column: for the strongest column and every column the
            # ranking barely separates from it (so that the bootstrap compares them on equal shapes)
            for term in model.terms:
                if type(term).__name__ == TERMS.get(term.name, type(None)).__name__ and term.name in TERMS \
                        and set(term.variables) <= usable and term.name != "coulomb":
                    add(Scale(term.name, v.name))
    for v in variables:
        if v.significant and "," in v.name:
            a, b = v.name.split(",")
            add(Interaction(a, b))
            for term in model.terms:  # a term of one column of the pair, scaled by the other
                if term.name in TERMS and set(term.variables) <= usable:
                    if a in term.variables and b not in term.variables:
                        add(Scale(term.name, b))
                    if b in term.variables and a not in term.variables:
                        add(Scale(term.name, a))
    return out


def _significance(base: FitResult, fit: FitResult, nf: float, n: int, alpha: float, m: int) -> tuple[float, int, float, bool]:
    """The candidate's likelihood-ratio (chi-square with the noise floor, else F) test on top of the base fit,
    at ``alpha / m``, and whether it also lowers the CV RMSE and the BIC."""
    dof = max(fit.n_free - base.n_free, 1)
    stat, p, _ = nested_test(base.ssr - fit.ssr, fit.ssr, dof, n - fit.n_free, nf)
    sig = bool(p < alpha / m and fit.cv_rmse < base.cv_rmse and fit.bic - base.bic < 0)
    return stat, dof, p, sig


def _bootstrap_choice(
    table: ObservationTable, base: FitResult, results: Sequence[CandidateResult], n_boot: int, seed: int
) -> dict[str, float]:
    """How often each of the best candidates wins when whole cycles are resampled with replacement.

    The winner of a resample is the candidate with the largest drop of the
    held-out (cross-validated) squared error on the resampled rows; the fits
    themselves are not repeated, so this measures how clearly the data
    separates the candidates, not the variability of their parameters.
    """
    if not results or base.cv_residuals is None:
        return {}
    cyc = table["cycle"] if "cycle" in table else np.arange(len(table), dtype=float)
    _, inv = np.unique(cyc, return_inverse=True)
    inv = inv.reshape(-1)
    g = inv.max() + 1
    gains = []
    for c in results:
        cr = c.fit.cv_residuals if c.fit.cv_residuals is not None else c.fit.residuals
        gains.append(np.bincount(inv, weights=base.cv_residuals**2 - cr**2, minlength=g))
    gm = np.array(gains)  # (candidates, cycles)
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, g, size=(n_boot, g))
    counts = np.zeros((n_boot, g))
    for i in range(n_boot):
        counts[i] = np.bincount(draws[i], minlength=g)
    totals = gm @ counts.T  # (candidates, boots)
    winners = np.argmax(totals, axis=0)
    freq = np.bincount(winners, minlength=len(results)) / n_boot
    return {c.term: float(f) for c, f in zip(results, freq) if f > 0}


@one_blas_thread
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
    adaptive: bool = True,
    mode: str = "guided",
    n_bootstrap: int = N_BOOTSTRAP,
    seed: int = 0,
) -> Diagnosis:
    """Test the model against the noise, rank the columns model-free, fit candidate effects, give a verdict.

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
        Family-wise significance level: of the candidates (Bonferroni); the
        noise test and the model-free ranking (Holm) each use ``alpha / 2``.
    params
        Starting values of the model (when ``model`` is not a fit).
    progress
        Called as ``progress(i, m, term)`` before each candidate.
    adaptive
        Also fit the shapes of :func:`adaptive_candidates` for the columns the
        model-free ranking finds.
    mode
        ``"guided"`` (default): the generic shapes of the fixed library only
        for the columns the model-free ranking finds significant (the paper's
        terms and user terms always); ``"full"``: for every column.
    n_bootstrap
        Resamples of whole cycles for the stability of the choice (0: none).
    seed
        Seed of the permutations and the bootstrap (the result is deterministic).

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
    noise = noise_test(table, base.residuals, base.n_free, alpha=alpha / 2)
    nf = noise.value
    outliers = find_outliers(table, base.residuals, alpha=alpha)  # before any shape is fitted
    tangent, components = _tangent(base, table), _components(base, table)
    memo: dict[Any, Any] = {}  # the ranking against the scatter between sweeps below redoes only the nested tests
    variables = residual_dependence(table, base.residuals, folds=folds, alpha=alpha / 2, seed=seed, noise=nf,
                                    tangent=tangent, components=components, memo=memo)
    if not noise.consistent:
        # a scatter between sweeps that tau_f_std cannot see is noise, when no column explains the residual
        # against that larger floor either (a missing effect of a column stays significant against it)
        between = sweep_scatter(table, base.residuals, base.n_free, noise, alpha=alpha / 2)
        if between is not None:
            again = variables
            if any(v.significant for v in variables):
                again = residual_dependence(table, base.residuals, folds=folds, alpha=alpha / 2, seed=seed,
                                            noise=between.value, tangent=tangent, components=components, memo=memo)
            if not any(v.significant for v in again):
                noise, nf, variables = between, between.value, again
    if mode not in ("guided", "full"):
        raise ValueError(f"mode must be 'guided' or 'full', got {mode!r}")
    if library is not None:
        lib = list(library)
    else:
        flagged = [c for v in variables if v.significant for c in v.columns]
        if not flagged and not noise.consistent:
            # above the floor but no column significant: explore the two strongest anyway
            flagged = [c for v in variables[:2] for c in v.columns]
        lib = candidate_library(table, base.model, extra=extra_terms,
                                generic=None if mode == "full" else flagged)
    if adaptive:
        names = {t.name for t in lib}
        adapt = adaptive_candidates(table, base.model, variables, explore=not noise.consistent)
        started = {t.columns[0] for t in adapt if isinstance(t, HarmonicRipple) and t.w0 is not None}
        # a ripple started at the periodogram's peak makes the grid-started one redundant
        lib = [t for t in lib if not (isinstance(t, HarmonicRipple) and t.w0 is None and t.columns[0] in started)]
        lib += [t for t in adapt if t.name not in names]
    n = len(table)
    mcount = max(len(lib), 1)
    results: list[CandidateResult] = []
    for i, term in enumerate(lib):
        if progress is not None:
            progress(i, len(lib), term.name)
        try:
            fit = fit_candidate(base, term, table, folds=folds)
        except ModelError:  # e.g. a parameter name clash with a term of the model
            continue
        stat, dof, p, sig = _significance(base, fit, nf, n, alpha, mcount)
        results.append(
            CandidateResult(
                term=term.name,
                variables=[v for v in term.variables if v != "speed"] or ["speed"],
                description=term.describe_effect(),
                cv_rmse=fit.cv_rmse,
                rmse=fit.rmse,
                delta_bic=fit.bic - base.bic,
                delta_cv_rmse=fit.cv_rmse - base.cv_rmse,
                statistic=stat,
                dof=dof,
                p_value=p,
                significant=sig,
                speed_region=speed_region(table.speed, base.residuals**2 - fit.residuals**2),
                fit=fit,
                key=_key(term),
                factors=_factors(term),
            )
        )
    results.sort(key=lambda c: (not c.significant, _nan_last(c.cv_rmse), _nan_last(c.delta_bic)))
    results = _prefer_simple(results)
    diag = Diagnosis(
        model=base.spec, n=n, rmse=base.rmse, cv_rmse=base.cv_rmse, noise=noise, alpha=alpha,
        candidates=results, base=base, variables=variables, outliers=outliers,
    )
    sig_vars = [v for v in variables if v.significant]
    best = diag.best
    if not math.isfinite(nf):
        # no noise estimate: nothing to compare the residual with; the verdict cannot be given
        diag.verdict = "undetermined"
        diag.suggestion = best.term if best is not None else None
        return diag
    if best is None:
        diag.verdict = "nothing_missing" if noise.consistent and not sig_vars else "unexplained"
        return diag
    diag.suggestion = best.term
    diag.after_noise = noise_test(table, best.fit.residuals, best.fit.n_free, alpha=alpha / 2)
    diag.after_variables = residual_dependence(
        table, best.fit.residuals, folds=folds, alpha=alpha / 2, seed=seed + 1, pairs=0, noise=nf,
        tangent=_tangent(best.fit, table), components=_components(best.fit, table))
    at_floor = (best.cv_rmse <= FOUND_RATIO * nf) if math.isfinite(nf) and nf > 0 else diag.after_noise.consistent
    left = any(v.significant for v in diag.after_variables)
    # the parametric and the model-free evidence must agree on the variable: a flexible term of another
    # column can soak up part of a residual it does not explain
    sig_cols = {c for v in sig_vars for c in v.columns}
    diag.agrees = bool(set(best.variables) & sig_cols)
    if n_bootstrap > 0:
        sig_cands = [c for c in results if c.significant]
        top = sig_cands[:6]
        for c in sig_cands[6:]:  # and the best candidate of every other explanation (column) there is
            if not any(_same(c, t) for t in top):
                top.append(c)
        diag.stability = _bootstrap_choice(table, base, top, n_bootstrap, seed)
        same = [c for c in top if _same(c, best)]
        diag.support = float(sum(diag.stability.get(c.term, 0.0) for c in same))
        diag.alternatives = [c.term for c in top if c not in same and diag.stability.get(c.term, 0.0) > 0]
    # a wrong "found" is worse than "unexplained": the data must pick the best term's column(s) clearly
    # over every other explanation, cycle resample after cycle resample
    stable = diag.stable
    # outlying rows first: a shape whose gain comes mostly from a few gross rows (a narrow step isolating them)
    # is not a missing effect
    diag.isolates_outliers = _gain_on(outliers, base.residuals, best.fit.residuals) >= OUTLIER_GAIN_SHARE
    diag.verdict = ("found" if at_floor and not left and diag.agrees and stable and not diag.isolates_outliers
                    else "unexplained")
    return diag


#: Significant candidates within this factor of the best CV RMSE count as equally good; the one with
#: the fewest parameters is put first (a one-standard-error rule).
SIMPLER_WITHIN = 1.01


def _prefer_simple(results: list[CandidateResult]) -> list[CandidateResult]:
    """Among the significant candidates as good as the best (CV RMSE within SIMPLER_WITHIN), fewest parameters first."""
    if not results or not results[0].significant:
        return results
    best = results[0].cv_rmse
    tied = [c for c in results if c.significant and c.cv_rmse <= SIMPLER_WITHIN * best]
    tied.sort(key=lambda c: (c.dof, _nan_last(c.cv_rmse)))
    ids = {id(c) for c in tied}
    rest = [c for c in results if id(c) not in ids]
    return tied + rest


def _key(term: Term) -> tuple[str, ...]:
    """The columns a candidate depends on besides the speed (a scaled term: its own and the factor's)."""
    return tuple(v for v in term.variables if v != "speed") or ("speed",)


def _factors(term: Term) -> tuple[str, ...]:
    """The columns a candidate brings in: a shape's columns (a scaled term's factor), else its inputs."""
    cols = getattr(term, "columns", None)
    return tuple(cols) if cols else _key(term)


def _same(a: CandidateResult, b: CandidateResult) -> bool:
    """Two candidates give the same explanation: the columns of one are among the other's, or they share a factor.

    ``scale(load_stribeck, temperature)``, ``scale(temp_stribeck, load_torque)`` (both load times
    temperature) and ``x_stribeck(temperature)`` are one explanation, and so are
    ``scale(load_coulomb, motor_temperature)`` and ``scale(temp_stribeck, motor_temperature)``;
    ``scale(load_stribeck, motor_temperature)`` is another than the first three.
    """
    ka, kb = set(a.key), set(b.key)
    return ka <= kb or kb <= ka or bool(set(a.factors) & set(b.factors))


def _tangent(fit: FitResult, table: ObservationTable) -> Array:
    """The fit's Jacobian in its free parameters: the directions a refit of the model can move in."""
    return fit.model.jacobian(fit.params, fit.free, **model_inputs(fit.model, table))


def _components(fit: FitResult, table: ObservationTable) -> dict[str, Array]:
    """The fit's terms, name -> contribution per row (what a column may scale)."""
    return fit.model.components(fit.params, **model_inputs(fit.model, table))


def _nan_last(x: float) -> float:
    return x if math.isfinite(x) else math.inf
