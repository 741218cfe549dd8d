"""Model-free residual dependence: which columns explain what the model leaves, without assuming a shape.

For every numeric column ``x`` (and pairs of the strongest columns), the
residual of the fitted model is regressed on a smooth function of ``x`` and
scored by its **cross-validated** share of the residual variance (folds
grouped by test cycle, as in :func:`~jointwear_ros.workbench.fit.group_folds`).

Given the fitted model's Jacobian (``tangent``), every test is made on top of
it: a column is credited with what a refit of the model could not absorb (the
score, or Lagrange multiplier, test of an omitted effect in nonlinear least
squares). The nuisance part (speed shapes and tangent space) is partialled out
on all rows; only a column's own coefficients are fitted per fold.

* *smoother*: cubic B-splines (:func:`scipy.interpolate.BSpline.design_matrix`)
  of the rank of ``x``, alone and times two speed shapes (low speeds
  ``exp(-|v/15|^1.3)``, high speeds ``v/v_max``), on top of those speed shapes
  alone (so a speed-only misfit is credited to no column). The statistic is
  the larger of the two shares; the reported share is at least that of a
  straight line in ``x`` (a spline of a column that grows with the cycle is
  extrapolated into each held-out cycle, a line is not);
* *modulation*, given the model's terms (``components``): ``x`` as a factor
  of each of them, ``x * term_k``: a column that reshapes a term of the model
  (the Stribeck amplitude with the temperature);
* *periodogram*, for angle-like columns (``position``, ``*angle*``): the peak
  of the normalised Lomb-Scargle periodogram (:func:`scipy.signal.lombscargle`)
  over angular frequencies from half a cycle over the column's span up to
  :data:`~.residual_tests.W_MAX` per unit;
* *changepoint*, for time-like columns (``time``, ``*_time``, ``stamp``): the
  standardised CUSUM of the per-cycle mean residual in time order (a single
  level shift); when a step beats a trend, the column's share is the step's
  own cross-validated share (a spline of a column that grows with the cycle is
  extrapolated into every held-out cycle);
* *pairs*: the strongest columns and the model's inputs pairwise (a tensor
  product of splines and the bilinear interaction, the smaller p-value
  counted twice), and a screen of every column for what it adds to each
  model input (the best one tested as a pair with it, its p-value times the
  number screened).

Each test is one named object in :mod:`.residual_tests` (:class:`~.residual_tests.SmootherTest`,
:class:`~.residual_tests.ModulationTest`, :class:`~.residual_tests.PeriodogramTest`,
:class:`~.residual_tests.ChangepointTest`, :class:`~.residual_tests.PairTest`,
:class:`~.residual_tests.ScreenTest`: its statistic, its p-value and its assumptions in its
docstring) on one :class:`~.residual_tests.ResidualSpace`, which holds what they share (the
residual, the folds, the nuisance space, the cycles, the permutations). The
nested chi-square / F test, the permutation p-value, the guard and Holm's
method are :mod:`.significance`'s.

Each statistic gets a **permutation p-value**: the column is permuted (by whole
cycles when it is constant within cycles, so the test respects the data's
grouping), the statistic recomputed; beyond the permutations' range the tail
is extrapolated (Gumbel fitted to the permutation maxima; for the periodogram,
the effective number of independent frequencies fitted to them). A column's
p-value is the smallest of its tests times their number (Bonferroni), and the
p-values of all columns and pairs are adjusted by Holm's method, so a dozen
irrelevant columns raise no false alarm.

>>> from jointwear_ros.data import synth_observations
>>> from jointwear_ros.workbench import fit_model, parse_spec
>>> t = synth_observations(n_cycles=20, effects=["ripple"], seed=2)
>>> fit = fit_model(parse_spec("paper"), t, cv_folds=0)
>>> dep = residual_dependence(t, fit.residuals)
>>> dep[0].name, dep[0].significant, dep[0].shape
('position', True, 'periodic')
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ParamSpec, TypeVar

import numpy as np
import numpy.typing as npt
from threadpoolctl import threadpool_limits

from ..model.shapes import is_angle
from ..types import ObservationTable
from .candidates import candidate_variables
from .compare import speed_region
from .residual_tests import (
    ChangepointTest,
    ModulationTest,
    PairTest,
    PeriodogramTest,
    ResidualSpace,
    ScreenTest,
    SmootherTest,
)
from .significance import holm

__all__ = [
    "VariableDependence",
    "is_time",
    "residual_dependence",
]

Array = npt.NDArray[np.float64]

#: Permutations per test.
N_PERM = 199
#: Columns always tried in pairs (with the strongest singles): the model's own inputs.
PHYSICAL_INPUTS = ("load_torque", "temperature")
#: Columns of the strongest singles tried in pairs.
PAIR_TOP = 3


@dataclass
class VariableDependence:
    """How much of the residual one column (or pair ``"a,b"``) explains, with a multiplicity-adjusted p-value.

    The shape the evidence points to is data: ``shape`` (``smooth``, ``scales``, ``periodic``,
    ``step``; a pair: ``interaction`` or ``adds``) with ``monotone`` (a smooth column's
    ``increasing``, ``decreasing`` or ``non-monotone``), ``scaled_term`` (the model's term a
    column scales), ``peak_frequency``, ``changepoint`` and the speed region; the renderer says it in
    words (:func:`~jointwear_ros.workbench.render.shape_hint`), and its JSON with those words is
    :func:`~jointwear_ros.workbench.render.variable_dict`.
    """

    name: str
    p_value: float
    p_raw: float
    explained_share: float
    test: str
    significant: bool
    shape: str = "smooth"
    monotone: str = ""
    scaled_term: str = ""
    speed_region: tuple[float, float] = (0.0, math.inf)
    peak_frequency: float | None = None
    changepoint: float | None = None
    changepoint_width: float | None = None
    speed_dependent: bool = False
    tests: dict[str, float] = field(default_factory=dict)

    @property
    def columns(self) -> list[str]:
        return self.name.split(",")

    def to_dict(self) -> dict[str, Any]:
        """The data (no sentence: see :func:`~jointwear_ros.workbench.render.variable_dict`)."""
        return {
            "name": self.name,
            "p_value": self.p_value,
            "explained_share": self.explained_share,
            "shape": self.shape,
            "test": self.test,
            "significant": self.significant,
            "p_raw": self.p_raw,
            "tests": dict(self.tests),
            "speed_region": {"lo": self.speed_region[0], "hi": self.speed_region[1]},
            "peak_frequency": self.peak_frequency,
            "changepoint": self.changepoint,
        }


_P = ParamSpec("_P")
_R = TypeVar("_R")


def one_blas_thread(fn: Callable[_P, _R]) -> Callable[_P, _R]:
    """Run ``fn`` with one BLAS thread: the arrays are small, so BLAS threads only compete with each other."""

    @functools.wraps(fn)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with threadpool_limits(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return wrapper


def is_time(name: str) -> bool:
    """Columns the changepoint test is run on: times."""
    return name in ("time", "stamp", "date") or name.endswith("_time") or name.startswith("time")


def _monotone(x: Array, contribution: Array) -> str:
    """``increasing``, ``decreasing`` or ``non-monotone``: the explained part's course along x (6 quantile bins)."""
    order = np.argsort(x)
    xs, cs = x[order], contribution[order]
    q = np.quantile(xs, np.linspace(0, 1, 7))
    means = [float(np.mean(cs[(xs >= a) & (xs <= b)])) for a, b in itertools.pairwise(q)]
    d = np.diff(means)
    if np.all(d >= -0.1 * np.ptp(means)):
        return "increasing"
    if np.all(d <= 0.1 * np.ptp(means)):
        return "decreasing"
    return "non-monotone"


@one_blas_thread
def residual_dependence(
    table: ObservationTable,
    residuals: Array,
    *,
    columns: Sequence[str] | None = None,
    folds: Array | None = None,
    alpha: float = 0.01,
    n_perm: int = N_PERM,
    pairs: int = PAIR_TOP,
    seed: int = 0,
    noise: float | None = None,
    tangent: Array | None = None,
    components: Mapping[str, Array] | None = None,
    memo: dict[Any, Any] | None = None,
) -> list[VariableDependence]:
    """Rank columns (and pairs) by how much of the residual they explain, model-free; best first.

    Parameters
    ----------
    table
        Observations (the columns tried: :func:`candidate_variables` unless ``columns``).
    residuals
        The fitted model's residuals, one per row.
    folds
        Cross-validation folds (default: 5, grouped by cycle).
    alpha
        Family-wise level: a variable is ``significant`` when its Holm-adjusted p-value is below it.
    n_perm
        Permutations per smoother and changepoint test.
    pairs
        Number of the strongest single columns tried in pairs (0: no pairs).
    seed
        Seed of the permutations (the result is deterministic).
    noise
        The noise floor (standard deviation), when known: the parametric test
        then uses ``max(noise^2, residual variance)`` as its error variance.
    tangent
        The fitted model's Jacobian in its free parameters (n rows, one column
        per parameter): every test is then made on top of it, so a column
        counts with what a refit of the model cannot absorb (the score test of
        an omitted effect), not with what the fit already bent its
        parameters towards.
    components
        The fitted model's terms (name -> contribution per row): each column is
        also tested as a factor of them (``x * term``, the *modulation* test).
    memo
        A dict shared by rankings of the same residual (same table, folds, seed, tangent and components)
        against different noise floors: what comes before the noise floor is computed once
        (:class:`~.residual_tests.ResidualSpace`); the result is the same as without it.

    Returns
    -------
    list of VariableDependence
        Significant ones first, then by explained share.
    """
    cols = list(columns) if columns is not None else candidate_variables(table)
    space = ResidualSpace(table, residuals, folds, seed, tangent, memo=memo)
    smoother, modulation = SmootherTest(space), ModulationTest(space, components)
    periodogram, changepoint = PeriodogramTest(space), ChangepointTest(space)
    if space.total <= 0 or not cols:
        return []
    out: list[VariableDependence] = []
    for c in cols:
        x = np.asarray(table[c], dtype=float)
        xs = space.permuted(x, n_perm)
        # the parametric test uses the noise level (powerful with few cycles); the permutation test
        # guards it against structure the F test would misread (residuals correlated within cycles)
        sm, s_lvl, s_spd = smoother.run(xs, noise)
        tests = {sm.name: sm.p_value}
        share = max(s_lvl, s_spd, space.linear_share(x), 0.0)
        speed_dep = bool(s_spd > s_lvl + 0.02)
        contrib = space.prediction(x, speed_dep)
        d = VariableDependence(name=c, p_value=math.nan, p_raw=math.nan, explained_share=0.0, test=sm.name,
                               significant=False, shape="smooth", monotone=_monotone(x, contrib))
        if modulation.applicable:
            mod, scaled = modulation.run(xs, noise)
            tests[mod.name] = mod.p_value
            share = max(share, mod.share)
            if mod.p_value < tests[sm.name] and scaled:
                d.shape, d.scaled_term = "scales", scaled
        if is_angle(c):
            per, w = periodogram.run(x)
            tests[per.name] = per.p_value
            if per.p_value < tests[sm.name]:
                d.shape, d.peak_frequency = "periodic", w
                share = max(share, per.share)
                speed_dep = False
        cp, at, width = changepoint.run(x, n_perm if is_time(c) else 0)
        if is_time(c):
            tests[cp.name] = cp.p_value
            if min(cp.p_value, tests[sm.name]) < alpha and space.step_beats_trend(x, at):
                d.shape = "step"
                # a spline of a column that grows with the cycle is extrapolated into every held-out
                # cycle (folds are whole cycles), so its cross-validated share understates a step
                share = max(share, space.step_share(x, at))
                speed_dep = False
        d.test = min(tests, key=lambda k: tests[k])
        d.p_raw = min(1.0, tests[d.test] * len(tests))
        d.explained_share = share
        d.speed_dependent = speed_dep
        d.speed_region = speed_region(space.speed, contrib**2) if speed_dep else (0.0, math.inf)
        d.changepoint = at if math.isfinite(at) else None
        d.changepoint_width = width if math.isfinite(width) else None
        d.tests = tests
        out.append(d)
    # pairs of the strongest singles: does the second column add to the first (with an interaction)?
    singles = [d.name for d in sorted(out, key=lambda d: d.p_raw)[: max(pairs, 0)]]
    if pairs > 0:  # the model's own inputs interact with everything (a term of the model reshaped by a column)
        singles += [c for c in PHYSICAL_INPUTS if c in cols and c not in singles]
    todo: list[tuple[str, str, int]] = [(a, b, 1) for a, b in itertools.combinations(singles, 2)]
    if pairs > 0:
        # a column correlated with a model input (the motor's temperature with the joint's) shows little
        # on its own: the refitted model has absorbed its shared part through that input. Screen every
        # column for what it adds to each input (a cheap nested test) and test the best one as a pair;
        # its p-value is multiplied by the number of columns screened (the choice is made on this data)
        screen = ScreenTest(space)
        done = {frozenset(t[:2]) for t in todo}
        for a in PHYSICAL_INPUTS:
            others = [c for c in cols if c != a]
            if a not in cols or not others:
                continue
            xa = np.asarray(table[a], dtype=float)
            best = min(others, key=lambda c: screen.run(xa, np.asarray(table[c], dtype=float), noise).p_value)
            if frozenset((a, best)) not in done:
                todo.append((a, best, len(others)))
                done.add(frozenset((a, best)))
    pair_test = PairTest(space)
    pair_out: list[VariableDependence] = []
    for a, b, screened in todo:
        res = pair_test.run(np.asarray(table[a], dtype=float), np.asarray(table[b], dtype=float), screened,
                            n_perm, noise)
        best_single = max(d.explained_share for d in out if d.name in (a, b))
        pair_out.append(VariableDependence(
            name=f"{a},{b}", p_value=math.nan, p_raw=res.p_value, explained_share=max(res.share, 0.0),
            shape="interaction" if res.share > best_single + 0.05 else "adds", test=res.name, significant=False,
            tests={res.name: res.p_value},
        ))
    allv = out + pair_out
    adj = holm([d.p_raw for d in allv])
    for d, pa in zip(allv, adj):
        d.p_value = pa
        d.significant = bool(pa < alpha)
    # a pair is worth listing only when it explains clearly more than its best single column
    keep = [d for d in pair_out if d.significant and d.explained_share > 0.05 + max(
        s.explained_share for s in out if s.name in d.columns)]
    allv = out + keep
    allv.sort(key=lambda d: (not d.significant, -d.explained_share, d.p_value))
    return allv
