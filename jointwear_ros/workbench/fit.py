"""Nonlinear least-squares fit of a model to an observation table.

``fit_model`` wraps :func:`scipy.optimize.least_squares` (trust-region
reflective, bounds from the parameters, the terms' analytic Jacobian). It
never raises on non-convergence: it returns a :class:`FitResult` with
``success`` and ``message``, RMSE, cross-validated RMSE (folds grouped by test
cycle), AIC/BIC, parameter values with standard errors and correlations.

Units: the terms' own start values and bounds are written for the paper's
joint (motor side, normalized torque); they are first scaled to the data's
speed and torque scales (:mod:`jointwear_ros.model.scaling`), so a joint
recorded in N·m at a few rad/s is fitted in its own numbers. A parameter that
ends on a bound made by that scaling has the bound widened tenfold and the
fit resumed (twice at most); a parameter still on a bound is named in
``at_bound`` and the fit is then not ``success`` (converged). A bound the
scaling left at its term's own number (data at the paper's scale, a table not
declared joint side) is the term's physical bound, the one a parameter set in
the paper's frame is held to: a parameter the widening let past it keeps the
data's value but is named in ``outside_physical`` (and the message), and the
fit is then not ``success`` either.

Starting values: the given parameters (a parameter set, or each term's
physically sensible default); the parameters the model is linear in are then
solved for by linear least squares (variable projection), and, where the
model is nonlinear in some free parameters, further starts scale those by
0.3 and 3. The best start wins.

The paper's model fitted to data drawn from it reaches the noise floor; the
"standard" textbook model (Coulomb + Stribeck + viscous) stays far above it:

>>> from jointwear_ros.data import synth_observations
>>> from jointwear_ros.model import parse_model_spec
>>> from jointwear_ros.workbench import noise_floor
>>> data = synth_observations(n_cycles=10, seed=0)   # 100 observations, sigma_e = 0.0015
>>> paper, standard = parse_model_spec("paper"), parse_model_spec("standard")
>>> f = fit_model(paper, data, paper.make_params())
>>> f.success, f.n, f.n_free, round(f.rmse / noise_floor(data)[0], 1)
(True, 100, 11, 1.0)
>>> g = fit_model(standard, data, standard.make_params())
>>> g.rmse > 5 * noise_floor(data)[0]
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from ..errors import InputDataError
from ..model import Model, Parameters
from ..model.scaling import BoundHit, DataScales, on_bound, scale_parameters
from ..types import ObservationTable

__all__ = ["FitResult", "fit_model", "group_folds", "information_criteria", "model_inputs", "physical_bound_names"]

Array = npt.NDArray[np.float64]

#: Solver tolerance while comparing several starts (the best is then solved to 1e-10).
SCOUT_TOL = 1e-8


@dataclass
class FitResult:
    """Outcome of one fit: never an exception on non-convergence (see ``success``/``message``)."""

    model: Model
    params: Parameters
    success: bool
    message: str
    n: int
    n_free: int
    ssr: float
    rmse: float
    cv_rmse: float
    aic: float
    bic: float
    free: list[str]
    correlations: Array
    residuals: Array
    fitted: Array
    nfev: int = 0
    cv_residuals: Array | None = field(default=None, repr=False)
    at_bound: list[BoundHit] = field(default_factory=list)
    scales: DataScales | None = field(default=None, repr=False)
    #: Free parameters past their terms' physical bounds (see :func:`fit_model`): name -> (min, max).
    outside_physical: dict[str, tuple[float, float]] = field(default_factory=dict)

    @property
    def spec(self) -> str:
        return self.model.spec

    def stderr(self, name: str) -> float:
        s = self.params[name].stderr
        return math.nan if s is None else float(s)

    def correlation(self, a: str, b: str) -> float:
        i, j = self.free.index(a), self.free.index(b)
        return float(self.correlations[i, j])

    def to_dict(self) -> dict[str, Any]:
        """The CLI's JSON: rmse, cv_rmse, aic, bic, parameters {name: {value, stderr, ...}} and more.

        ``params`` and ``parameters`` are the same table (``parameters`` adds
        each one's bounds and whether it ended on one); ``at_bound`` lists the
        parameters on a bound, ``outside_physical`` those past their terms'
        physical bounds, ``converged`` is ``success``.
        """
        hits = {h.name: h for h in self.at_bound}
        return {
            "model": self.spec,
            "equation": self.model.equation(),
            "n": self.n,
            "n_free": self.n_free,
            "success": self.success,
            "message": self.message,
            "rmse": self.rmse,
            "cv_rmse": self.cv_rmse,
            "aic": self.aic,
            "bic": self.bic,
            "params": {
                n: {
                    "value": p.value,
                    "stderr": p.stderr,
                    "vary": p.vary,
                    "unit": p.unit,
                }
                for n, p in self.params.items()
            },
            "parameters": {
                n: {
                    "value": p.value,
                    "stderr": p.stderr,
                    "vary": p.vary,
                    "unit": p.unit,
                    "min": p.min,
                    "max": p.max,
                    "at_bound": None if n not in hits else hits[n].side,
                }
                for n, p in self.params.items()
            },
            "converged": self.success,
            "at_bound": [h.to_dict() for h in self.at_bound],
            "outside_physical": [{"name": n, "value": float(self.params[n].value), "min": lo, "max": hi}
                                 for n, (lo, hi) in self.outside_physical.items()],
            "scales": None if self.scales is None else self.scales.to_dict(),
            "correlations": {
                a: {b: float(self.correlations[i, j]) for j, b in enumerate(self.free) if j != i}
                for i, a in enumerate(self.free)
            },
        }


#: Parameters that are at least 0 in a physical fit (a Stribeck amplitude, a viscous coefficient).
NONNEGATIVE = ("Fs", "Fv")
#: Terms whose contribution is a friction level that cannot be negative where the joint was measured.
SIGNED_TERMS = ("stribeck", "temp_stribeck", "load_stribeck", "viscous", "temp_viscous")


def _negative_terms(model: Model, params: Parameters, x: Mapping[str, Array]) -> list[str]:
    """The Stribeck and viscous terms whose contribution is negative at the data (beyond rounding)."""
    names = [t.name for t in model.terms if t.name in SIGNED_TERMS]
    if not names:
        return []
    try:
        comps = model.components(params, **x)
    except (KeyError, ValueError, TypeError):
        return []
    total = max(float(np.max(np.abs(sum(np.asarray(c, dtype=float) for c in comps.values())))), 1e-300)
    out = []
    for nm in names:
        c = np.asarray(comps.get(nm, 0.0), dtype=float)
        if c.size and float(np.min(c)) < -1e-3 * total:
            out.append(f"{nm} is negative at the data (down to {float(np.min(c)):.4g})")
    return out


def information_criteria(ssr: float, n: int, k: int) -> tuple[float, float]:
    """Gaussian AIC and BIC with unknown noise variance: n ln(SSR/n) + 2k, n ln(SSR/n) + k ln n."""
    if n <= 0:
        return math.nan, math.nan
    base = n * math.log(max(ssr, 1e-300) / n)
    return base + 2.0 * k, base + k * math.log(n)


def model_inputs(model: Model, table: ObservationTable) -> dict[str, Array]:
    """The columns ``model`` needs, checked: present and finite (else :class:`InputDataError`)."""
    src = table.source or "observations"
    out: dict[str, Array] = {}
    for var in model.variables:
        if var not in table:
            raise InputDataError(
                f"{src}: column {var!r} is missing, needed by model {model.spec!r}; "
                f"columns present: {', '.join(table.names)}"
            )
        col = table[var]
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise InputDataError(
                f"{src}: column {var!r}, row {int(bad[0]) + 1}: value {float(col[bad[0]])!r} is not finite "
                f"({bad.size} such rows); model {model.spec!r} needs it"
            )
        out[var] = col
    y = table.tau_f
    bad = np.flatnonzero(~np.isfinite(y))
    if bad.size:
        raise InputDataError(f"{src}: column 'tau_f', row {int(bad[0]) + 1}: value {float(y[bad[0]])!r} is not finite")
    return out


def group_folds(table: ObservationTable, k: int = 5, seed: int = 0, column: str = "cycle") -> Array:
    """Fold index per row; rows of one test cycle stay in one fold (rows are groups without ``cycle``)."""
    n = len(table)
    groups = table[column] if column in table else np.arange(n, dtype=float)
    uniq, inv = np.unique(groups, return_inverse=True)
    k = int(min(k, uniq.size))
    if k < 2:
        return np.zeros(n, dtype=int)
    order = np.random.default_rng(seed).permutation(uniq.size)
    fold_of_group = np.empty(uniq.size, dtype=int)
    fold_of_group[order] = np.arange(uniq.size) % k
    return fold_of_group[inv].astype(int)


class _Problem:
    """Residuals and Jacobian in the free parameters, on prepared inputs."""

    def __init__(self, model: Model, x: Mapping[str, Array], y: Array, params: Parameters) -> None:
        self.model = model
        self.x = dict(x)
        self.y = y
        self.params = params
        self.free = params.free()
        self.fixed = {n: float(p.value) for n, p in params.items() if not p.vary}
        self.lb = np.array([params[n].min for n in self.free], dtype=float)
        self.ub = np.array([params[n].max for n in self.free], dtype=float)
        # the inputs checked once: every evaluation below is Model.evaluate's and Model.jacobian's numbers
        self.prepared = model.prepare(**self.x)
        self._free = tuple(self.free)

    def values(self, theta: Array) -> dict[str, float]:
        d = dict(self.fixed)
        d.update(zip(self.free, theta.tolist()))
        return d

    def f(self, theta: Array) -> Array:
        return self.prepared.evaluate(self.values(theta)) - self.y

    def jac(self, theta: Array) -> Array:
        return self.prepared.jacobian(self.values(theta), self._free)

    def jac_of(self, theta: Array, name: str) -> Array:
        """The Jacobian's column of free parameter ``name`` alone (only its term is differentiated)."""
        return self.prepared.jacobian(self.values(theta), (name,))[:, 0]

    def clip(self, theta: Array) -> Array:
        with np.errstate(invalid="ignore"):
            lo = np.where(np.isfinite(self.lb), self.lb + 1e-12 * (1 + np.abs(self.lb)), -np.inf)
            hi = np.where(np.isfinite(self.ub), self.ub - 1e-12 * (1 + np.abs(self.ub)), np.inf)
        return np.clip(theta, lo, hi)

    def solve(self, theta0: Array, max_nfev: int | None = None, tol: float = 1e-10) -> Any:
        with np.errstate(all="ignore"):
            return least_squares(
                self.f, self.clip(theta0), jac=self.jac, bounds=(self.lb, self.ub), method="trf",
                x_scale="jac", max_nfev=max_nfev, xtol=tol, ftol=tol, gtol=tol,
            )


def _linear_names(prob: _Problem, theta: Array) -> list[str]:
    """Free parameters the model is linear in: their Jacobian column does not move with them.

    Tested at a point with no zero parameter (an amplitude at 0 would hide
    its shape parameters' nonlinearity).
    """
    theta = prob.clip(np.where(theta == 0.0, 1.0, theta))
    with np.errstate(all="ignore"):
        j0 = prob.jac(theta)
    out = []
    for i, n in enumerate(prob.free):
        t2 = theta.copy()
        t2[i] = theta[i] + max(1.0, abs(theta[i])) * 0.37
        t2 = prob.clip(t2)
        if t2[i] == theta[i]:
            continue
        with np.errstate(all="ignore"):
            j1 = prob.jac_of(t2, n)  # the column of the whole Jacobian (each column is its own term's)
        if np.allclose(j0[:, i], j1, rtol=1e-9, atol=1e-14):
            out.append(n)
    return out


def _project_linear(prob: _Problem, theta: Array, linear: Sequence[str]) -> Array:
    """Solve the linear parameters by least squares given the others (then clip to bounds)."""
    idx = [prob.free.index(n) for n in linear if n in prob.free]
    if not idx:
        return theta
    with np.errstate(all="ignore"):
        r = prob.f(theta)
        jl = prob.jac(theta)[:, idx]
        if not np.all(np.isfinite(jl)) or not np.all(np.isfinite(r)):
            return theta
        # model = jl @ theta_l + rest; want jl @ theta_l_new = y - rest = jl @ theta_l - r
        target = jl @ theta[idx] - r
        sol, *_ = np.linalg.lstsq(jl, target, rcond=None)
    out = theta.copy()
    out[idx] = sol
    return prob.clip(out)


def _covariance(jac: Array, ssr: float, n: int) -> tuple[Array, Array]:
    """Standard errors and correlations; parameters in a non-identifiable direction get inf."""
    k = jac.shape[1]
    if k == 0:
        return np.zeros(0), np.zeros((0, 0))
    dof = max(n - k, 1)
    s2 = ssr / dof
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    tol = sv.max() * max(jac.shape) * np.finfo(float).eps * 1e3 if sv.size else 0.0
    ok = sv > tol
    inv = np.where(ok, 1.0 / np.where(ok, sv, 1.0) ** 2, 0.0)
    cov = (vt.T * inv) @ vt * s2
    var = np.diag(cov).copy()
    null = vt[~ok]
    unident = np.any(np.abs(null) > 1e-6, axis=0) if null.size else np.zeros(k, dtype=bool)
    std = np.sqrt(np.maximum(var, 0.0))
    std[unident] = np.inf
    with np.errstate(all="ignore"):
        d = np.sqrt(np.maximum(var, 0.0))
        corr = cov / np.outer(d, d)
    corr[~np.isfinite(corr)] = 0.0
    corr[unident, :] = np.nan
    corr[:, unident] = np.nan
    np.fill_diagonal(corr, 1.0)
    return std, corr


def fit_model(
    model: Model,
    table: ObservationTable,
    params: Parameters | Mapping[str, float] | None = None,
    *,
    fixed: Sequence[str] = (),
    starts: Sequence[Mapping[str, float]] | None = None,
    n_starts: int = 3,
    cv_folds: int = 5,
    folds: Array | None = None,
    cv_max_nfev: int | None = 60,
    max_nfev: int | None = None,
    scales: DataScales | None = None,
    rescale: bool = True,
    widen: int = 2,
    physical: bool = True,
    _clipped: bool = False,
    _check_only: bool = False,
    _cv: bool = True,
) -> FitResult:
    """Fit ``model`` to ``table`` by nonlinear least squares.

    Parameters
    ----------
    model
        The model to fit.
    table
        Observations; the model's input columns must be present and finite.
    params
        Starting values (a :class:`Parameters` keeps its bounds and vary flags).
    fixed
        Names of parameters held at their starting value.
    starts
        Explicit starting points (each overrides some values); default: the
        automatic multi-start described in the module docstring.
    n_starts
        Number of automatic starts (1: no multi-start).
    cv_folds, folds
        Cross-validation folds grouped by ``cycle`` (``folds`` gives the fold
        of each row directly); ``cv_folds < 2`` skips cross-validation.
    cv_max_nfev
        Evaluation budget of each fold's refit (warm-started at the full fit).
    scales, rescale
        The data's scales (default: measured from ``table``); ``rescale=False``
        keeps the terms' numbers as they are.
    widen
        How many times a bound made by the scaling is widened tenfold when the
        fit ends on it.
    physical
        Physical signs hold (default): the speed-only Stribeck amplitude ``Fs`` and viscous coefficient
        ``Fv`` are at least 0 (a fit that ends below refits with the bound at 0), and a fit whose Stribeck or viscous term (:data:`SIGNED_TERMS`) is negative
        at the data is not called converged (the message names it). And a parameter whose bounds were
        its term's physical ones (:func:`physical_bound_names`) that ends past them (a widened bound) is
        named in ``outside_physical`` and the message, and the fit is not called converged.

    Returns
    -------
    FitResult
    """
    x = model_inputs(model, table)
    y = np.asarray(table.tau_f, dtype=float)
    n = y.size
    p0 = model.make_params(params)
    sc = (scales if scales is not None else DataScales.from_table(table)) if rescale else None
    auto: set[str] = set()
    if sc is not None:
        p0, auto = scale_parameters(model, p0, sc)
    bounded = physical_bound_names(model, p0, auto, table) if physical else frozenset()
    if physical and not _clipped:
        res = fit_model(model, table, params, fixed=fixed, starts=starts, n_starts=n_starts, cv_folds=cv_folds,
                        folds=folds, cv_max_nfev=cv_max_nfev, max_nfev=max_nfev, scales=scales, rescale=rescale,
                        widen=widen, physical=True, _clipped=True, _check_only=True, _cv=False)
        neg = [nm for nm in NONNEGATIVE if nm in res.free and res.params[nm].value < 0]
        if not neg:
            # cross-validated only now: a fit refitted below would have thrown its folds' refits away
            theta = np.array([res.params[nm].value for nm in res.free], dtype=float)  # the fit's own numbers
            res.cv_rmse, res.cv_residuals = _cv_errors(model, table, x, y, res.params, theta, cv_folds, folds,
                                                       cv_max_nfev)
            return res
        _clipped = True  # a negative Stribeck amplitude or viscous coefficient: refit with it at least 0
        if starts is None:  # from the free fit with those at 0, and the speed parameters over the data's speeds
            from ..model.scaling import speed_starts

            at = {nm: (0.0 if nm in neg else float(res.params[nm].value)) for nm in res.free}
            sc0 = scales if scales is not None else DataScales.from_table(table)
            grid = speed_starts(res.free, sc0, (0.001, 0.003, 0.01, 0.03, 0.1, 0.3))
            starts = [at] + [dict(at, **g) for g in grid if g]
    if _clipped and not _check_only:
        for nm in NONNEGATIVE:
            if nm in p0 and p0[nm].min < 0 and nm not in fixed:
                p0[nm].min = 0.0
                p0[nm].value = max(p0[nm].value, 0.0)
    if fixed:
        p0.set_vary(fixed, False)
    prob = _Problem(model, x, y, p0)
    theta_base = np.array([p0[nm].value for nm in prob.free], dtype=float)

    best: Any = None
    message = ""
    if prob.free and n > 0:
        candidates: list[Array] = []
        if starts is not None:
            for s in starts:
                t = theta_base.copy()
                for nm, val in s.items():
                    if nm in prob.free:
                        t[prob.free.index(nm)] = float(val)
                candidates.append(prob.clip(t))
            linear = _linear_names(prob, candidates[0]) if candidates else []
            candidates = [_project_linear(prob, t, linear) for t in candidates]
        else:
            t0 = prob.clip(theta_base)
            linear = _linear_names(prob, t0)
            nonlinear = [i for i, nm in enumerate(prob.free) if nm not in linear]
            candidates.append(t0)
            candidates.append(_project_linear(prob, t0, linear))
            if nonlinear and n_starts > 1:
                for factor in (0.3, 3.0, 0.1, 10.0)[: n_starts - 1]:
                    t = t0.copy()
                    t[nonlinear] = t0[nonlinear] * factor
                    candidates.append(_project_linear(prob, prob.clip(t), linear))
        # pick the most promising starts by initial cost, then solve
        with np.errstate(all="ignore"):
            costs = [float(np.sum(prob.f(t) ** 2)) for t in candidates]
        order = np.argsort(np.where(np.isfinite(costs), costs, np.inf))
        keep = [candidates[i] for i in order[: max(n_starts, 1) if starts is None else 3]]
        # several starts: solve each to a loose tolerance, then polish the best one
        tol = SCOUT_TOL if len(keep) > 1 else 1e-10
        for t in keep:
            try:
                sol = prob.solve(t, max_nfev=max_nfev, tol=tol)
            except (ValueError, np.linalg.LinAlgError) as exc:
                message = f"solver failed from a start: {exc}"
                continue
            if not np.isfinite(sol.cost):
                continue
            if best is None or sol.cost < best.cost:
                best = sol
        if best is not None and tol != 1e-10:
            try:
                polished = prob.solve(best.x, max_nfev=max_nfev)
                if np.isfinite(polished.cost) and polished.cost <= best.cost:
                    polished.nfev += best.nfev
                    best = polished
            except (ValueError, np.linalg.LinAlgError) as exc:
                message = f"solver failed polishing the best start: {exc}"
        if best is not None:
            prob, best = _widen_bounds(model, x, y, p0, prob, best, auto, widen, max_nfev)
        theta = best.x if best is not None else prob.clip(theta_base)
        success = bool(best is not None and best.status > 0)
        message = best.message if best is not None else (message or "no start gave a finite cost")
        nfev = int(best.nfev) if best is not None else 0
    else:
        theta = theta_base
        success = True
        message = "no free parameters" if n > 0 else "no observations"
        nfev = 0

    with np.errstate(all="ignore"):
        resid = prob.f(theta) if n else np.zeros(0)
    ssr = float(np.sum(resid**2))
    k = len(prob.free)
    rmse = math.sqrt(ssr / n) if n else math.nan
    aic, bic = information_criteria(ssr, n, k)
    if k and n and np.all(np.isfinite(resid)):
        std, corr = _covariance(prob.jac(theta), ssr, n)
    else:
        std, corr = np.full(k, np.nan), np.full((k, k), np.nan)
    out_params = p0.copy()
    for i, nm in enumerate(prob.free):
        out_params[nm].value = float(theta[i])
        out_params[nm].stderr = float(std[i])
    hits = on_bound(out_params, prob.free) if n else []
    hits = [h for h in hits if not (physical and h.name in NONNEGATIVE and h.bound == 0.0)]
    if hits:
        success = False
        message = f"{message}; ended on a bound: {'; '.join(str(h) for h in hits)}"
    outside = _outside_physical(model, out_params, prob.free, bounded)
    if outside:
        success = False
        message = (f"{message}; outside its physical bounds (a widened bound let it past; a set in the paper's frame "
                   "cannot hold it): " + "; ".join(f"{nm} = {out_params[nm].value:.6g} outside [{lo:g}, {hi:g}]"
                               for nm, (lo, hi) in outside.items()))
    if physical and n:
        bad = _negative_terms(model, out_params, x)
        if bad:
            success = False
            message = f"{message}; not physical: {'; '.join(bad)}"

    cv_rmse, cv_res = (_cv_errors(model, table, x, y, out_params, theta, cv_folds, folds, cv_max_nfev) if _cv
                       else (math.nan, None))

    return FitResult(
        model=model, params=out_params, success=success, message=str(message), n=n, n_free=k, ssr=ssr,
        rmse=rmse, cv_rmse=cv_rmse, aic=aic, bic=bic, free=list(prob.free), correlations=corr,
        residuals=resid, fitted=resid + y, nfev=nfev, cv_residuals=cv_res, at_bound=hits, scales=sc,
        outside_physical=outside,
    )


def physical_bound_names(model: Model, params: Parameters, auto: set[str], table: ObservationTable
                         ) -> frozenset[str]:
    """The parameters of ``auto`` (bounds from the terms) whose bounds are still their terms' own numbers, in a
    table not declared joint side: the terms' physical bounds, which a set in the paper's frame is held to
    (the set loader refuses a value past them). A fit may still widen them, but names a parameter it leaves
    past them (:attr:`FitResult.outside_physical`) and is then not converged.

    Data off the paper's scale have their bounds scaled to the data's numbers (those may be widened), and a
    joint-side table is not held to the normalized frame's bounds (nor is a set in the joint frame).
    """
    units = getattr(table, "units", None)
    if units is not None and getattr(units, "joint_side", False):
        return frozenset()
    specs = {sp.name: sp for t in model.terms for sp in t.params}
    return frozenset(n for n in auto if n in specs and n in params
                     and (params[n].min, params[n].max) == (specs[n].min, specs[n].max))


def _outside_physical(model: Model, params: Parameters, free: Sequence[str], physical: frozenset[str]
                      ) -> dict[str, tuple[float, float]]:
    """The free parameters of ``physical`` (:func:`physical_bound_names`) past their terms' bounds: name -> (min, max)."""
    specs = {sp.name: sp for t in model.terms for sp in t.params}
    out: dict[str, tuple[float, float]] = {}
    for nm in free:
        if nm in physical and not specs[nm].min <= params[nm].value <= specs[nm].max:
            out[nm] = (float(specs[nm].min), float(specs[nm].max))
    return out


def _widen_bounds(
    model: Model, x: Mapping[str, Array], y: Array, params: Parameters, prob: _Problem, best: Any,
    auto: set[str], rounds: int, max_nfev: int | None,
) -> tuple[_Problem, Any]:
    """Widen tenfold the scaled bounds ``best`` ended on (not a bound at 0: a sign) and resume the fit.

    ``params`` is changed in place (its bounds are the fit's); returns the
    problem of the final bounds and its best solution.
    """
    for _ in range(max(rounds, 0)):
        trial = params.copy()
        for i, nm in enumerate(prob.free):
            trial[nm].value = float(best.x[i])
        hits = [h for h in on_bound(trial, prob.free) if h.name in auto and h.bound != 0.0]
        if not hits:
            break
        for h in hits:
            p = params[h.name]
            if h.side == "lower":
                p.min = p.min / 10.0 if p.min > 0 else p.min * 10.0
            else:
                p.max = p.max * 10.0 if p.max > 0 else p.max / 10.0
        new = _Problem(model, x, y, params)
        try:
            sol = new.solve(new.clip(best.x), max_nfev=max_nfev)
        except (ValueError, np.linalg.LinAlgError):
            break
        prob = new
        if np.isfinite(sol.cost) and sol.cost <= best.cost:
            sol.nfev += best.nfev
            best = sol
    return prob, best


def _cv_errors(
    model: Model, table: ObservationTable, x: Mapping[str, Array], y: Array, params: Parameters, theta: Array,
    cv_folds: int, folds: Array | None, max_nfev: int | None,
) -> tuple[float, Array | None]:
    """The CV RMSE and the held-out residuals of the fit ``theta`` (nan and None without folds)."""
    if y.size and (cv_folds >= 2 or folds is not None):
        fid = folds if folds is not None else group_folds(table, cv_folds)
        if np.unique(fid).size >= 2:
            cv_res = _cross_validate(model, x, y, params, fid, theta, max_nfev)
            return float(np.sqrt(np.mean(cv_res**2))), cv_res
    return math.nan, None


#: Solver tolerance of the cross-validation refits: each fold's held-out
#: prediction is needed to a few significant digits, not to the last bit.
CV_TOL = 1e-6


def _cross_validate(
    model: Model, x: Mapping[str, Array], y: Array, params: Parameters, folds: Array, theta: Array,
    max_nfev: int | None,
) -> Array:
    """Held-out residual of every row, from refits on the other folds (warm-started at ``theta``)."""
    out = np.empty_like(y)
    for f in np.unique(folds):
        test = folds == f
        train = ~test
        xt = {k: v[train] for k, v in x.items()}
        prob = _Problem(model, xt, y[train], params)
        if prob.free and train.sum() > 0:
            try:
                sol = prob.solve(theta, max_nfev=max_nfev, tol=CV_TOL)
                th = sol.x if np.isfinite(sol.cost) else theta
            except (ValueError, np.linalg.LinAlgError):
                th = theta
        else:
            th = theta
        vals = prob.values(th)
        with np.errstate(all="ignore"):
            out[test] = model.evaluate(vals, **{k: v[test] for k, v in x.items()}) - y[test]
    return out
