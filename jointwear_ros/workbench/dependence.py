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
  :data:`W_MAX` per unit;
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
>>> dep[0].name, dep[0].significant, dep[0].shape_hint.split(",")[0]
('position', True, 'periodic in position')
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
from scipy import stats
from scipy.interpolate import BSpline
from scipy.signal import lombscargle
from threadpoolctl import threadpool_limits

from ..types import ObservationTable
from .candidates import candidate_variables
from .compare import SPEED_BAND_EDGES, band_label
from .fit import group_folds

__all__ = ["W_MAX", "VariableDependence", "holm", "is_angle", "is_time", "residual_dependence"]

Array = npt.NDArray[np.float64]

#: Largest angular frequency of the periodogram, per unit of the column (rad^-1 for an angle).
W_MAX = 100.0
#: Basis functions of the smoother per column (cubic B-splines of the rank).
N_BASIS = 6
#: Permutations per test.
N_PERM = 199
#: Permutations of the periodogram (each costs a full periodogram).
N_PERM_PERIODOGRAM = 39
#: The parametric test counts only when the permutation test agrees at least this far.
PERM_GUARD = 0.05
#: Columns always tried in pairs (with the strongest singles): the model's own inputs.
PHYSICAL_INPUTS = ("load_torque", "temperature")
#: Columns of the strongest singles tried in pairs.
PAIR_TOP = 3


@dataclass
class VariableDependence:
    """How much of the residual one column (or pair ``"a,b"``) explains, with a multiplicity-adjusted p-value."""

    name: str
    p_value: float
    p_raw: float
    explained_share: float
    shape_hint: str
    test: str
    significant: bool
    speed_region: tuple[float, float] = (0.0, math.inf)
    peak_frequency: float | None = None
    changepoint: float | None = None
    changepoint_width: float | None = None
    speed_dependent: bool = False
    tests: dict[str, float] = field(default_factory=dict)

    @property
    def columns(self) -> list[str]:
        return self.name.split(",")

    @property
    def speed_region_label(self) -> str:
        lo, hi = self.speed_region
        if lo <= SPEED_BAND_EDGES[0] and not math.isfinite(hi):
            return "all speeds"
        return f"{band_label(lo, hi)} rad/s"

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "p_value": self.p_value,
            "explained_share": self.explained_share,
            "shape_hint": self.shape_hint,
            "test": self.test,
            "significant": self.significant,
            "p_raw": self.p_raw,
            "tests": dict(self.tests),
            "speed_region": {"lo": self.speed_region[0], "hi": self.speed_region[1],
                             "label": self.speed_region_label},
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


def is_angle(name: str) -> bool:
    """Columns the periodogram is run on: joint angles."""
    return name == "position" or "angle" in name or name.startswith("position")


def is_time(name: str) -> bool:
    """Columns the changepoint test is run on: times."""
    return name in ("time", "stamp", "date") or name.endswith("_time") or name.startswith("time")


def holm(p: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (family-wise error control for any dependence).

    >>> [round(x, 3) for x in holm([0.01, 0.04, 0.03, 0.5])]
    [0.04, 0.09, 0.09, 0.5]
    """
    m = len(p)
    order = np.argsort(p, kind="stable")
    adj = np.empty(m)
    run = 0.0
    for i, j in enumerate(order):
        run = max(run, min(1.0, (m - i) * float(p[j])))
        adj[j] = run
    return [float(a) for a in adj]


def _tail_p(obs: float, null: Array) -> float:
    """Permutation p-value; beyond the permutations' range, a Gumbel tail fitted to them."""
    r = null.size
    ge = int(np.sum(null >= obs))
    if ge > 0:
        return (1 + ge) / (r + 1)
    sd = float(np.std(null, ddof=1))
    if not sd > 0:
        return 1.0 / (r + 1)
    scale = sd * math.sqrt(6.0) / math.pi
    loc = float(np.mean(null)) - 0.5772156649 * scale
    return float(min(1.0 / (r + 1), stats.gumbel_r.sf(obs, loc, scale)))


class _Context:
    """What every test of one residual vector shares: folds, speed shapes, cycles, permutation source."""

    def __init__(self, table: ObservationTable, residuals: Array, folds: Array | None, seed: int,
                 tangent: Array | None = None) -> None:
        n = len(table)
        self.n = n
        # what the model misses, data minus model (FitResult.residuals are model minus data)
        self.r = float(np.mean(residuals)) - np.asarray(residuals, dtype=float)
        self.total = float(np.sum(self.r**2))
        self.folds = folds if folds is not None else group_folds(table, 5)
        self.fold_ids = np.unique(self.folds)
        v = np.abs(table.speed)
        vmax = float(np.max(v)) if v.size and np.max(v) > 0 else 1.0
        self.speed = v
        self.low = np.exp(-((v / 15.0) ** 1.3))
        self.high = v / vmax
        z = np.column_stack([np.ones(n), self.low, self.high])
        if tangent is not None and tangent.size:
            # the model's own tangent space (its Jacobian at the fit): what a refit of the model could absorb.
            # Testing a column on top of it is the score (Lagrange multiplier) test of an omitted effect in
            # nonlinear least squares: the first-order gain of refitting the model with the effect added
            tg = np.asarray(tangent, dtype=float).reshape(n, -1)
            tg = tg[:, np.all(np.isfinite(tg), axis=0)]  # a parameter at a singular point gives no direction
            sd = np.std(tg, axis=0)
            z = np.column_stack([z, (tg[:, sd > 0] - tg[:, sd > 0].mean(axis=0)) / sd[sd > 0]])
        u, sv, _ = np.linalg.svd(z, full_matrices=False)
        keep = sv > sv[0] * 1e-7
        # an orthonormal basis of the nuisance space (scaled to the columns' size), the intercept first in span
        self.z0 = u[:, keep] * math.sqrt(n)
        self.q = int(self.z0.shape[1])
        self.r_perp = self.r - self.z0 @ (self.z0.T @ self.r) / n
        self.cycle = table["cycle"] if "cycle" in table else np.arange(n, dtype=float)
        self.ucyc, self.cinv = np.unique(self.cycle, return_inverse=True)
        self.cinv = self.cinv.reshape(-1)
        self.rng = np.random.default_rng(seed)
        self.sse0 = float(self._cv_sse(self.z0[None, :, :])[0])
        self.sse0_in = float(self._in_sse(self.z0[None, :, :])[0])

    # -- permutations ------------------------------------------------------------------
    def cycle_level(self, x: Array) -> bool:
        if self.ucyc.size == self.n or self.ucyc.size < 2:
            return False
        means = np.bincount(self.cinv, weights=x) / np.bincount(self.cinv)
        within = float(np.sum((x - means[self.cinv]) ** 2))
        total = float(np.sum((x - x.mean()) ** 2))
        return total > 0 and within <= 1e-4 * total

    def permuted(self, x: Array, r: int) -> Array:
        """``r`` permutations of ``x`` (row 0 the data itself): by whole cycles when x is per cycle."""
        out = np.empty((r + 1, self.n))
        out[0] = x
        if self.cycle_level(x):
            counts = np.bincount(self.cinv)
            means = np.bincount(self.cinv, weights=x) / counts
            dev = x - means[self.cinv]
            for i in range(1, r + 1):
                out[i] = means[self.rng.permutation(means.size)][self.cinv] + dev
        else:
            for i in range(1, r + 1):
                out[i] = x[self.rng.permutation(self.n)]
        return out

    # -- smoother ----------------------------------------------------------------------
    @staticmethod
    def rank_basis(xs: Array, nb: int = N_BASIS) -> Array:
        """Cubic B-splines of the rank of each row of ``xs`` (shape (R, n) -> (R, n, nb - 1))."""
        rr, n = xs.shape
        u = stats.rankdata(xs, axis=1) / n
        knots = np.concatenate([[0.0] * 3, np.linspace(0.0, 1.0, nb - 2), [1.0] * 3])
        dm = BSpline.design_matrix(np.clip(u.ravel(), 0.0, 1.0), knots, 3).toarray()
        return dm.reshape(rr, n, nb)[:, :, 1:]  # type: ignore[no-any-return]

    def _cv_sse(self, d: Array, return_pred: bool = False) -> Array:
        """Cross-validated SSE of the residual on each design ``d[k]`` (shape (R, n, p), ``z0`` first).

        The nuisance part (the first ``q`` columns: the speed shapes and the
        model's tangent space) is partialled out of the residual and of the
        other columns on all rows (Frisch-Waugh), as a refit of the model on
        all cycles would; only the column's own coefficients are fitted per
        fold and judged on the held-out cycles. (Refitting a dozen nuisance
        directions per fold on a few cycles would charge the column with
        their extrapolation error.) The SSE of the nuisance alone is the
        partialled residual's sum of squares.
        """
        rr = d.shape[0]
        extra = d[:, :, self.q:]
        extra = extra - np.matmul(self.z0, np.matmul(self.z0.T, extra)) / self.n
        r = self.r_perp
        p = extra.shape[2]
        pred = np.zeros((rr, self.n)) if return_pred else None
        if p == 0:
            sse = np.full(rr, float(np.sum(r**2)))
            return (sse, pred) if return_pred else sse  # type: ignore[return-value]
        sse = np.zeros(rr)
        ridge = 1e-8 * self.n * np.eye(p)
        for f in self.fold_ids:
            te = self.folds == f
            tr = ~te
            dtr = extra[:, tr, :]
            g = np.matmul(dtr.transpose(0, 2, 1), dtr) + ridge
            b = np.matmul(dtr.transpose(0, 2, 1), r[tr])
            coef = np.linalg.solve(g, b[..., None])[..., 0]
            pr = np.matmul(extra[:, te, :], coef[..., None])[..., 0]
            sse += np.sum((r[te] - pr) ** 2, axis=1)
            if pred is not None:
                pred[:, te] = pr
        return (sse, pred) if return_pred else sse  # type: ignore[return-value]

    def _in_sse(self, d: Array) -> Array:
        """In-sample SSE of the residual on each design ``d[k]`` (shape (R, n, p))."""
        p = d.shape[2]
        dt = d.transpose(0, 2, 1)
        g = np.matmul(dt, d) + 1e-8 * self.n * np.eye(p)
        coef = np.linalg.solve(g, np.matmul(dt, self.r)[..., None])[..., 0]
        pr = np.matmul(d, coef[..., None])[..., 0]
        return np.sum((self.r - pr) ** 2, axis=1)  # type: ignore[no-any-return]

    def designs(self, b: Array) -> tuple[Array, Array]:
        rr = b.shape[0]
        z0 = np.broadcast_to(self.z0, (rr, self.n, self.q))
        lvl = np.concatenate([z0, b], axis=2)
        spd = np.concatenate([lvl, b * self.low[None, :, None], b * self.high[None, :, None]], axis=2)
        return lvl, spd

    def basis_size(self, x: Array) -> int:
        """Basis functions for a column: fewer when it has few distinct values (a per-cycle column, few cycles)."""
        distinct = np.unique(x).size
        return int(np.clip(distinct // 4 + 1, 4, N_BASIS))  # a cubic B-spline basis needs 4 or more

    def f_test(self, d: Array, noise: float | None) -> float:
        """Nested F (or chi-square, with a noise floor) test of design ``d[0]`` against the speed shapes alone."""
        sse = float(self._in_sse(d[:1])[0])
        k = d.shape[2] - self.q
        dof = max(self.n - d.shape[2], 1)
        gain = max(self.sse0_in - sse, 0.0)
        s2 = sse / dof
        if noise is not None and math.isfinite(noise) and noise > 0:
            return float(stats.chi2.sf(gain / max(noise**2, s2), k))
        return float(stats.f.sf(gain / k / max(s2, 1e-300), k, dof))

    def smoother(self, xs: Array) -> tuple[Array, float, float]:
        """Test statistic of each permuted column (row 0: the data), and the data's CV shares (level, speed).

        The statistic is the larger of the in-sample shares of the two designs
        (level; level times speed shapes) beyond the speed shapes alone, each
        standardised by its permutation distribution; the reported share is
        cross-validated.
        """
        lvl, spd = self.designs(self.rank_basis(xs, self.basis_size(xs[0])))
        self.last = (lvl[:1], spd[:1])
        zs = []
        for d in (lvl, spd):
            share = (self.sse0_in - self._in_sse(d)) / self.total
            null = share[1:]
            sd = float(np.std(null, ddof=1)) if null.size > 1 else 1.0
            zs.append((share - float(np.mean(null)) if null.size else share) / (sd if sd > 0 else 1.0))
        stat = np.maximum(zs[0], zs[1])
        cv_lvl = float((self.sse0 - self._cv_sse(lvl[:1])[0]) / self.total)
        cv_spd = float((self.sse0 - self._cv_sse(spd[:1])[0]) / self.total)
        return stat, cv_lvl, cv_spd

    def prediction(self, x: Array, with_speed: bool) -> Array:
        b = self.rank_basis(x[None, :])
        d = np.concatenate([self.z0[None], b], axis=2)
        if with_speed:
            d = np.concatenate([d, b * self.low[None, :, None], b * self.high[None, :, None]], axis=2)
        _, pred = self._cv_sse(d, return_pred=True)  # type: ignore[misc]
        base = self._cv_sse(self.z0[None], return_pred=True)[1]  # type: ignore[index]
        return pred[0] - base[0]  # type: ignore[no-any-return]

    # -- modulation of the model's terms -----------------------------------------------
    def set_components(self, components: dict[str, Array] | None) -> None:
        """The model's terms (name -> contribution per row) a column may scale; constant ones are kept."""
        self.comp_names: list[str] = []
        self.comp_varies: list[bool] = []
        cols = []
        for name, v in (components or {}).items():
            v = np.asarray(v, dtype=float).reshape(-1)
            rms = float(np.sqrt(np.mean(v**2)))
            if v.size == self.n and rms > 0 and np.all(np.isfinite(v)):
                self.comp_names.append(name)
                self.comp_varies.append(bool(np.std(v) > 1e-9 * rms))
                cols.append(v / rms)
        self.comp = np.column_stack(cols) if cols else np.zeros((self.n, 0))

    def modulation(self, xs: Array, noise: float | None) -> tuple[float, float, str]:
        """Does the column scale the model's own terms? (p-value, CV share, the term it scales most).

        The term is "" when it is a constant one: the Coulomb level scaled by x
        is a level that changes with x, what the smoother already says.

        The design is ``x * term_k`` for every term ``k`` of the model (x centred and
        standardised), on the nuisance space (speed shapes and the model's tangent
        space): the score test of ``x`` as a factor of each term. An effect that
        reshapes a term of the model with a column (the Stribeck amplitude with the
        temperature, every term with the motor's temperature) is one direction of it.
        """
        k = self.comp.shape[1]
        if k == 0:
            return 1.0, 0.0, ""
        sd = float(np.std(xs[0]))
        if not sd > 0:
            return 1.0, 0.0, ""
        z = (xs - xs.mean(axis=1, keepdims=True)) / sd
        rr = xs.shape[0]
        d = np.concatenate([np.broadcast_to(self.z0, (rr, self.n, self.q)), z[:, :, None] * self.comp[None]], axis=2)
        share_in = (self.sse0_in - self._in_sse(d)) / self.total
        p_perm = _tail_p(float(share_in[0]), share_in[1:])
        p_f = self.f_test(d[:1], noise)
        p = max(p_f, p_perm) if p_perm > PERM_GUARD else p_f
        share = float((self.sse0 - self._cv_sse(d[:1])[0]) / self.total)
        # the term it scales: the one whose product alone explains most (coefficients of collinear terms
        # do not say it)
        one = np.stack([np.concatenate([self.z0, (z[0] * self.comp[:, j])[:, None]], axis=1) for j in range(k)])
        j = int(np.argmin(self._in_sse(one)))
        return p, share, self.comp_names[j] if self.comp_varies[j] else ""

    # -- periodogram ------------------------------------------------------------------
    def periodogram(self, x: Array) -> tuple[float, float, float]:
        """Peak angular frequency, its normalised power, and its p-value (permutations + effective M)."""
        span = float(np.ptp(x))
        w_lo = max(math.pi / span, 1e-3)
        step = 2.0 * math.pi / span / 3.0
        w = np.arange(w_lo, W_MAX, step)
        if w.size < 2:
            return math.nan, 0.0, 1.0

        def peak(y: Array) -> tuple[float, float]:
            pw = lombscargle(x, y, w, normalize=True, floating_mean=True)
            i = int(np.argmax(pw))
            return float(w[i]), float(pw[i])

        w_best, z = peak(self.r)
        null = np.array([peak(self.r[self.rng.permutation(self.n)])[1] for _ in range(N_PERM_PERIODOGRAM)])
        # single frequency: P(power > z) = (1 - z)^((n - 3)/2); max over M_eff frequencies, M_eff fitted
        # to the median of the permutation maxima
        e = (self.n - 3) / 2.0

        def single(zz: float) -> float:
            return float((1.0 - min(max(zz, 0.0), 1.0)) ** e)

        med = float(np.median(null))
        q = single(med)
        m_eff = math.log(0.5) / math.log1p(-q) if 0 < q < 1 else float(w.size)
        fap = -math.expm1(m_eff * math.log1p(-single(z))) if single(z) < 1 else 1.0
        ge = int(np.sum(null >= z))
        p = (1 + ge) / (null.size + 1) if ge > 0 else min(1.0 / (null.size + 1), fap)
        return w_best, z, float(p)

    def step_beats_trend(self, x: Array, at: float) -> bool:
        """Does a single step at ``at`` explain the residual better than a straight trend in x?"""
        if not math.isfinite(at):
            return False
        step = (x > at).astype(float)
        a = np.column_stack([np.ones(self.n), step])
        b = np.column_stack([np.ones(self.n), x - x.mean()])
        fs = a @ np.linalg.lstsq(a, self.r, rcond=None)[0]
        ft = b @ np.linalg.lstsq(b, self.r, rcond=None)[0]
        return _r2(self.r, fs) > _r2(self.r, ft)

    def linear_share(self, x: Array) -> float:
        """Cross-validated share explained by x linearly (and times the speed shapes), on the speed shapes.

        A spline of the rank is extrapolated into the held-out cycles of a column that grows with the
        cycle (time, days, hours since a service); a straight line is not, so the share of a trend is
        the larger of the two.
        """
        sd = float(np.std(x))
        if not sd > 0:
            return 0.0
        xs = (x - x.mean()) / sd
        d = np.concatenate([self.z0, np.column_stack([xs, xs * self.low, xs * self.high])], axis=1)[None]
        return float(min(1.0, (self.sse0 - self._cv_sse(d)[0]) / self.total))

    def step_share(self, x: Array, at: float) -> float:
        """Cross-validated share of the residual explained by one level step at ``at`` (on the speed shapes)."""
        if not math.isfinite(at):
            return 0.0
        d = np.concatenate([self.z0, (x > at).astype(float)[:, None]], axis=1)[None]
        return float(min(1.0, (self.sse0 - self._cv_sse(d)[0]) / self.total))

    def partial_p(self, a: Array, x: Array, noise: float | None) -> float:
        """Screen: does ``x`` (linear, and times the speed shapes) add to a smooth function of ``a``?"""
        da = np.concatenate([self.z0, self.rank_basis(a[None, :], 4)[0]], axis=1)
        xs = (x - x.mean()) / (float(np.std(x)) or 1.0)
        dx = np.concatenate([da, np.column_stack([xs, xs * self.low, xs * self.high])], axis=1)
        sse_a = float(self._in_sse(da[None])[0])
        sse_x = float(self._in_sse(dx[None])[0])
        k, dof = 3, max(self.n - dx.shape[1], 1)
        gain, s2 = max(sse_a - sse_x, 0.0), sse_x / dof
        if noise is not None and math.isfinite(noise) and noise > 0:
            return float(stats.chi2.sf(gain / max(noise**2, s2), k))
        return float(stats.f.sf(gain / k / max(s2, 1e-300), k, dof))

    # -- changepoint ------------------------------------------------------------------
    def changepoint(self, x: Array, r: int) -> tuple[float, float, float, float]:
        """Standardised CUSUM of the per-group mean residual ordered by x: (statistic, p, at, width)."""
        if self.cycle_level(x):
            cnt = np.bincount(self.cinv)
            gx = np.bincount(self.cinv, weights=x) / cnt
            gr = np.bincount(self.cinv, weights=self.r) / cnt
        else:
            gx, gr = x, self.r
        order = np.argsort(gx, kind="stable")
        gx, gr = gx[order], gr[order]
        g = gr.size
        if g < 4 or not np.std(gr) > 0:
            return 0.0, 1.0, math.nan, math.nan

        def cusum(m: Array) -> tuple[Array, Array]:
            c = np.cumsum(m - m.mean(axis=-1, keepdims=True), axis=-1)[..., :-1]
            k = np.arange(1, g)
            s = c / np.sqrt(k * (g - k) / g)  # the standardised (likelihood-ratio) form of a mean shift
            return np.max(np.abs(s), axis=-1) / m.std(axis=-1), np.argmax(np.abs(s), axis=-1)

        perm = np.stack([gr] + [gr[self.rng.permutation(g)] for _ in range(r)])
        stat, arg = cusum(perm)
        p = _tail_p(float(stat[0]), stat[1:]) if r > 0 else 1.0
        k = int(arg[0])
        at = 0.5 * (gx[k] + gx[k + 1])
        width = max(float(gx[k + 1] - gx[k]) / 8.0, 1e-9 * max(abs(at), 1.0))
        return float(stat[0]), p, float(at), width


def _r2(y: Array, yhat: Array) -> float:
    tot = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum((y - yhat) ** 2)) / tot if tot > 0 else 0.0


def _speed_region(speed: Array, contribution: Array) -> tuple[float, float]:
    """Speed bands where the explained part is largest (>= 15 % of the largest band's mean square)."""
    edges = SPEED_BAND_EDGES
    ms = []
    for lo, hi in itertools.pairwise(edges):
        m = (speed >= lo) & (speed < hi)
        ms.append(float(np.mean(contribution[m] ** 2)) if m.any() else math.nan)
    g = np.asarray(ms)
    present = np.isfinite(g)
    if not present.any() or not np.nanmax(g) > 0:
        return float(edges[0]), float(edges[-1])
    on = np.flatnonzero(present & (g >= 0.15 * np.nanmax(g)))
    pres = np.flatnonzero(present)
    lo_i, hi_i = int(on.min()), int(on.max())
    if lo_i == pres.min() and hi_i == pres.max():
        return float(edges[0]), float(edges[-1])
    return float(edges[lo_i]), float(edges[hi_i + 1])


def _monotone_hint(x: Array, contribution: Array) -> str:
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

    Returns
    -------
    list of VariableDependence
        Significant ones first, then by explained share.
    """
    cols = list(columns) if columns is not None else candidate_variables(table)
    ctx = _Context(table, residuals, folds, seed, tangent)
    ctx.set_components(dict(components) if components is not None else None)
    if ctx.total <= 0 or not cols:
        return []
    out: list[VariableDependence] = []
    for c in cols:
        x = np.asarray(table[c], dtype=float)
        xs = ctx.permuted(x, n_perm)
        stat, s_lvl, s_spd = ctx.smoother(xs)
        p_perm = _tail_p(float(stat[0]), stat[1:])
        # the parametric test uses the noise level (powerful with few cycles); the permutation test
        # guards it against structure the F test would misread (residuals correlated within cycles)
        p_f = min(1.0, 2.0 * min(ctx.f_test(ctx.last[0], noise), ctx.f_test(ctx.last[1], noise)))
        tests = {"smoother": max(p_f, p_perm) if p_perm > PERM_GUARD else p_f}
        share = max(s_lvl, s_spd, ctx.linear_share(x), 0.0)
        speed_dep = bool(s_spd > s_lvl + 0.02)
        contrib = ctx.prediction(x, speed_dep)
        hint = f"smooth in {c}, {_monotone_hint(x, contrib)}"
        if ctx.comp.shape[1]:
            p_mod, s_mod, scaled = ctx.modulation(xs, noise)
            tests["modulation"] = p_mod
            share = max(share, s_mod)
            if p_mod < tests["smoother"] and scaled:
                hint = f"scales the model's {scaled} with {c}"
        peak = None
        if is_angle(c):
            w, power, p_ls = ctx.periodogram(x)
            tests["periodogram"] = p_ls
            if p_ls < tests["smoother"]:
                peak = w
                share = max(share, power)
                hint = f"periodic in {c}, w = {w:.4g} per unit (period {2 * math.pi / w:.4g})"
                speed_dep = False
        _, p_cp, at, width = ctx.changepoint(x, n_perm if is_time(c) else 0)
        if is_time(c):
            tests["changepoint"] = p_cp
            if min(p_cp, tests["smoother"]) < alpha and ctx.step_beats_trend(x, at):
                hint = f"step in {c} at {at:.6g}"
                # a spline of a column that grows with the cycle is extrapolated into every held-out
                # cycle (folds are whole cycles), so its cross-validated share understates a step
                share = max(share, ctx.step_share(x, at))
                speed_dep = False
        best_test = min(tests, key=lambda k: tests[k])
        p_raw = min(1.0, tests[best_test] * len(tests))
        region = _speed_region(ctx.speed, contrib) if speed_dep else (0.0, math.inf)
        if speed_dep:
            hint += f", mostly at {band_label(*region)} rad/s"
        d = VariableDependence(
            name=c, p_value=math.nan, p_raw=p_raw, explained_share=share, shape_hint=hint, test=best_test,
            significant=False, speed_region=region, peak_frequency=peak,
            changepoint=at if math.isfinite(at) else None, changepoint_width=width if math.isfinite(width) else None,
            speed_dependent=speed_dep, tests=tests,
        )
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
        done = {frozenset(t[:2]) for t in todo}
        for a in PHYSICAL_INPUTS:
            others = [c for c in cols if c != a]
            if a not in cols or not others:
                continue
            xa = np.asarray(table[a], dtype=float)
            best = min(others, key=lambda c: ctx.partial_p(xa, np.asarray(table[c], dtype=float), noise))
            if frozenset((a, best)) not in done:
                todo.append((a, best, len(others)))
                done.add(frozenset((a, best)))
    pair_out: list[VariableDependence] = []

    def pair_test(d_pair: Array, d_a: Array) -> tuple[float, float]:
        """(p-value, CV share) of the designs ``d_pair`` (row 0 the data, then permutations) nested on ``d_a``."""
        in_pair = (ctx.sse0_in - ctx._in_sse(d_pair)) / ctx.total
        p_perm = _tail_p(float(in_pair[0]), in_pair[1:])
        # nested test: does b (with the interaction) add to a alone?
        sse_a = float(ctx._in_sse(d_a)[0])
        sse_p = float(ctx._in_sse(d_pair[:1])[0])
        k = d_pair.shape[2] - d_a.shape[2]
        dof = max(ctx.n - d_pair.shape[2], 1)
        s2 = sse_p / dof
        gain = max(sse_a - sse_p, 0.0)
        if noise is not None and math.isfinite(noise) and noise > 0:
            p_f = float(stats.chi2.sf(gain / max(noise**2, s2), k))
        else:
            p_f = float(stats.f.sf(gain / k / max(s2, 1e-300), k, dof))
        share = float((ctx.sse0 - ctx._cv_sse(d_pair[:1])[0]) / ctx.total)
        return (max(p_f, p_perm) if p_perm > PERM_GUARD else p_f), share

    for a, b, screened in todo:
        xa = np.asarray(table[a], dtype=float)
        xb = ctx.permuted(np.asarray(table[b], dtype=float), n_perm)
        ba = ctx.rank_basis(xa[None, :], 4)
        bb = ctx.rank_basis(xb, 4)
        rr = bb.shape[0]
        z0 = np.broadcast_to(ctx.z0, (rr, ctx.n, ctx.q))
        d_a = np.concatenate([ctx.z0[None], ba], axis=2)
        xs = (xb - xb.mean(axis=1, keepdims=True)) / (float(np.std(xb[0])) or 1.0)
        if screened > 1:  # the screened column enters as the screen had it: linear, times the speed shapes
            lin = np.stack([xs, xs * ctx.low[None, :], xs * ctx.high[None, :]], axis=2)
            p, share = pair_test(np.concatenate([z0, np.broadcast_to(ba, (rr, ctx.n, ba.shape[2])), lin], axis=2),
                                 d_a)
            p = min(1.0, p * screened)
        else:
            # two designs, the smaller p-value counted twice (Bonferroni): a tensor product of cubic splines
            # (any smooth interaction, many parameters), and the bilinear one (b and a*b, each times the speed
            # shapes: the first-order interaction, few parameters, so it keeps its power with few cycles)
            inter = (np.broadcast_to(ba, bb.shape)[:, :, :, None] * bb[:, :, None, :]).reshape(rr, ctx.n, -1)
            d_full = np.concatenate([z0, np.broadcast_to(ba, bb.shape), bb,
                                     inter, inter * ctx.low[None, :, None], inter * ctx.high[None, :, None]], axis=2)
            sa = (xa - xa.mean()) / (float(np.std(xa)) or 1.0)
            lean = np.stack([xs, xs * sa[None, :]], axis=2)
            d_lean = np.concatenate([z0, np.broadcast_to(ba, bb.shape), lean, lean * ctx.low[None, :, None],
                                     lean * ctx.high[None, :, None]], axis=2)
            p_full, share_full = pair_test(d_full, d_a)
            p_lean, share_lean = pair_test(d_lean, d_a)
            p, share = min(1.0, 2.0 * min(p_full, p_lean)), max(share_full, share_lean)
        best_single = max(d.explained_share for d in out if d.name in (a, b))
        pair_out.append(VariableDependence(
            name=f"{a},{b}", p_value=math.nan, p_raw=p, explained_share=max(share, 0.0),
            shape_hint=f"interaction of {a} and {b}" if share > best_single + 0.05
            else f"{b} adds to {a}", test="smoother (pair)", significant=False,
            tests={"smoother (pair)": p},
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
