"""The six named tests of residual dependence, on one shared residual space.

Each test is one object (:class:`SmootherTest`, :class:`ModulationTest`, :class:`PeriodogramTest`,
:class:`ChangepointTest`, :class:`PairTest`, :class:`ScreenTest`): its statistic, its p-value and its
assumptions in its docstring, its :meth:`run` returning an :class:`Outcome`. All run on one
:class:`ResidualSpace`, which holds what they share (the residual, the folds, the nuisance space, the cycles,
the permutations). Which columns they are run on and how their p-values are combined and adjusted is
:func:`~jointwear_ros.workbench.dependence.residual_dependence`'s; the nested test, the permutation p-value
and the guard are :mod:`.significance`'s.
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt
from scipy import stats
from scipy.interpolate import BSpline

from ..types import ObservationTable
from .fit import group_folds
from .significance import guarded, nested_test, permutation_p

__all__ = [
    "CHUNK",
    "N_BASIS",
    "N_PERM_PERIODOGRAM",
    "W_MAX",
    "ChangepointTest",
    "ModulationTest",
    "Outcome",
    "PairTest",
    "PeriodogramTest",
    "ResidualSpace",
    "ScreenTest",
    "SmootherTest",
    "lombscargle_many",
]

Array = npt.NDArray[np.float64]
_T = TypeVar("_T")

#: Largest angular frequency of the periodogram, per unit of the column (rad^-1 for an angle).
W_MAX = 100.0
#: Basis functions of the smoother per column (cubic B-splines of the rank).
N_BASIS = 6
#: Permutations of the periodogram (each costs a full periodogram).
N_PERM_PERIODOGRAM = 39
#: Permuted designs built and solved at once (a few MB: they stay in the cache; each is solved on its own,
#: so the numbers do not depend on it).
CHUNK = 16


class Outcome(NamedTuple):
    """What one test says about one column: its statistic, its p-value and the share of the residual it explains
    (cross-validated; 0 when the test does not measure one)."""

    name: str
    statistic: float
    p_value: float
    share: float = 0.0


class ResidualSpace:
    """What every test of one residual vector shares: the residual, folds, speed shapes, nuisance space, cycles.

    The nuisance space holds an intercept, two speed shapes (low speeds ``exp(-|v/15|^1.3)``, high
    speeds ``v/v_max``) and, given the fitted model's Jacobian (``tangent``), the model's own tangent
    space: testing a column on top of it is the score (Lagrange multiplier) test of an omitted effect
    in nonlinear least squares, the first-order gain of refitting the model with the effect added.
    Permutations come from one seeded generator, so a ranking is deterministic.

    ``memo`` (a dict, optional) keeps what the tests compute before the noise floor enters (the permuted
    designs' sums of squares, the cross-validated shares), keyed by this space's residual, nuisance space,
    folds and seed and by the test's inputs: a second ranking of the same residual against another noise
    floor (:func:`~jointwear_ros.workbench.diagnose.diagnose` tries the scatter between sweeps) then only
    redoes the nested tests. The permutations are drawn as before, so the numbers are the same.
    """

    def __init__(self, table: ObservationTable, residuals: Array, folds: Array | None, seed: int,
                 tangent: Array | None = None, memo: dict[Any, Any] | None = None) -> None:
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
        self.sse0 = float(self.cv_sse(self.z0[None, :, :])[0])
        self.sse0_in = float(self.in_sse(self.z0[None, :, :])[0])
        self.memo = memo
        self._digest = b""
        if memo is not None:
            h = hashlib.blake2b(digest_size=20)
            for a in (self.r, self.z0, np.asarray(self.folds, dtype=float), self.cycle):
                h.update(np.ascontiguousarray(a, dtype=float).tobytes())
            h.update(repr(seed).encode())
            self._digest = h.digest()

    def remembered(self, key: tuple[Any, ...], inputs: Sequence[Array], compute: Callable[[], _T]) -> _T:
        """``compute()``, or what it gave before for the same ``key``, ``inputs`` and space (see ``memo``)."""
        if self.memo is None:
            return compute()
        h = hashlib.blake2b(self._digest, digest_size=20)
        for a in inputs:
            a = np.ascontiguousarray(a, dtype=float)
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
        k = (*key, h.digest())
        if k not in self.memo:
            self.memo[k] = compute()
        return self.memo[k]  # type: ignore[no-any-return]

    # -- permutations ------------------------------------------------------------------
    def cycle_level(self, x: Array) -> bool:
        """Is ``x`` constant within cycles (a per-cycle column)?"""
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

    # -- least squares on the nuisance space --------------------------------------------
    @staticmethod
    def rank_basis(xs: Array, nb: int = N_BASIS) -> Array:
        """Cubic B-splines of the rank of each row of ``xs`` (shape (R, n) -> (R, n, nb - 1))."""
        n = xs.shape[1]
        # an average rank is a whole or a half number: the basis is looked up at twice the rank
        return _rank_splines(n, nb)[_twice_ranks(xs)]  # type: ignore[no-any-return]

    def cv_sse(self, d: Array, return_pred: bool = False) -> Array:
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

    def in_sse(self, d: Array) -> Array:
        """In-sample SSE of the residual on each design ``d[k]`` (shape (R, n, p))."""
        p = d.shape[2]
        dt = d.transpose(0, 2, 1)
        g = np.matmul(dt, d) + 1e-8 * self.n * np.eye(p)
        coef = np.linalg.solve(g, np.matmul(dt, self.r)[..., None])[..., 0]
        pr = np.matmul(d, coef[..., None])[..., 0]
        return np.sum((self.r - pr) ** 2, axis=1)  # type: ignore[no-any-return]

    def cv_share(self, d: Array) -> float:
        """Cross-validated share of the residual design ``d`` (one design, z0 first) explains beyond the nuisance."""
        return float((self.sse0 - self.cv_sse(d)[0]) / self.total)

    def nested(self, d_small: Array, d_large: Array, noise: float | None) -> float:
        """p-value of the nested test (:func:`~.significance.nested_test`) of design ``d_large[0]`` on ``d_small``."""
        return self.nested_p(self.nested_sums(d_small, d_large), noise)

    def nested_sums(self, d_small: Array, d_large: Array) -> tuple[float, float, int, int]:
        """What the nested test of ``d_large[0]`` on ``d_small`` takes before the noise floor: the two sums of
        squares and the degrees of freedom (added, left)."""
        sse_small = float(self.in_sse(d_small[:1])[0])
        sse = float(self.in_sse(d_large[:1])[0])
        return sse_small, sse, d_large.shape[2] - d_small.shape[2], self.n - d_large.shape[2]

    def on_nuisance_sums(self, d: Array) -> tuple[float, float, int, int]:
        """:meth:`nested_sums` of design ``d[0]`` against the nuisance space alone."""
        sse = float(self.in_sse(d[:1])[0])
        return self.sse0_in, sse, d.shape[2] - self.q, self.n - d.shape[2]

    @staticmethod
    def nested_p(sums: tuple[float, float, int, int], noise: float | None) -> float:
        """The nested test's p-value from :meth:`nested_sums` and the noise floor."""
        sse_small, sse, k, dof = sums
        return nested_test(sse_small - sse, sse, k, dof, noise).p_value

    def nested_on_nuisance(self, d: Array, noise: float | None) -> float:
        """p-value of the nested test of design ``d[0]`` against the nuisance space alone."""
        return self.nested_p(self.on_nuisance_sums(d), noise)

    def designs(self, b: Array) -> tuple[Array, Array]:
        """The nuisance space plus basis ``b`` (level), and plus ``b`` times the speed shapes too (speed)."""
        rr = b.shape[0]
        z0 = np.broadcast_to(self.z0, (rr, self.n, self.q))
        lvl = np.concatenate([z0, b], axis=2)
        spd = np.concatenate([lvl, b * self.low[None, :, None], b * self.high[None, :, None]], axis=2)
        return lvl, spd

    def basis_size(self, x: Array) -> int:
        """Basis functions for a column: fewer when it has few distinct values (a per-cycle column, few cycles)."""
        distinct = np.unique(x).size
        return int(np.clip(distinct // 4 + 1, 4, N_BASIS))  # a cubic B-spline basis needs 4 or more

    # -- effect sizes --------------------------------------------------------------------
    def prediction(self, x: Array, with_speed: bool) -> Array:
        """The cross-validated part of the residual a smooth function of ``x`` explains (times the speed shapes)."""
        b = self.rank_basis(x[None, :])
        d = np.concatenate([self.z0[None], b], axis=2)
        if with_speed:
            d = np.concatenate([d, b * self.low[None, :, None], b * self.high[None, :, None]], axis=2)
        _, pred = self.cv_sse(d, return_pred=True)  # type: ignore[misc]
        base = self.cv_sse(self.z0[None], return_pred=True)[1]  # type: ignore[index]
        return pred[0] - base[0]  # type: ignore[no-any-return]

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
        return float(min(1.0, self.cv_share(d)))

    def step_share(self, x: Array, at: float) -> float:
        """Cross-validated share of the residual explained by one level step at ``at`` (on the speed shapes)."""
        if not math.isfinite(at):
            return 0.0
        d = np.concatenate([self.z0, (x > at).astype(float)[:, None]], axis=1)[None]
        return float(min(1.0, self.cv_share(d)))

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


class SmootherTest:
    """Does a smooth function of the column explain the residual? (``smoother``)

    Design: cubic B-splines of the column's rank (fewer basis functions for a column with
    few distinct values), alone (level) and also times the two speed shapes (speed), on the
    nuisance space. Statistic: the larger of the two designs' in-sample shares, each
    standardised by its permutation distribution. p-value: the nested test of the better
    design (the smaller p counted twice), guarded by the permutation p-value of the statistic.
    Shares: cross-validated, level and speed. Assumptions: the nested test's (independent
    errors of equal variance, or the noise floor's); rows (or, for a per-cycle column,
    whole cycles) exchangeable under the null.
    """

    name = "smoother"

    def __init__(self, space: ResidualSpace) -> None:
        self.s = space

    def run(self, xs: Array, noise: float | None) -> tuple[Outcome, float, float]:
        """The outcome (share: the larger CV share), and the CV shares of the level and speed designs."""
        s = self.s
        stat, cv_lvl, cv_spd, sums_lvl, sums_spd = s.remembered((self.name,), (xs,), lambda: self._sums(xs))
        p_perm = permutation_p(float(stat[0]), stat[1:])
        p_f = min(1.0, 2.0 * min(s.nested_p(sums_lvl, noise), s.nested_p(sums_spd, noise)))
        return Outcome(self.name, float(stat[0]), guarded(p_f, p_perm), max(cv_lvl, cv_spd)), cv_lvl, cv_spd

    def _sums(self, xs: Array) -> tuple[Array, float, float, tuple[float, float, int, int], tuple[float, float, int, int]]:
        """What :meth:`run` computes before the noise floor enters."""
        s = self.s
        b = s.rank_basis(xs, s.basis_size(xs[0]))
        lvl, spd = s.designs(b[:1])
        sse: tuple[list[Array], list[Array]] = ([], [])
        for i in range(0, b.shape[0], CHUNK):
            for out, d in zip(sse, s.designs(b[i:i + CHUNK])):
                out.append(s.in_sse(d))
        zs = []
        for part in sse:
            share = (s.sse0_in - np.concatenate(part)) / s.total
            null = share[1:]
            sd = float(np.std(null, ddof=1)) if null.size > 1 else 1.0
            zs.append((share - float(np.mean(null)) if null.size else share) / (sd if sd > 0 else 1.0))
        stat = np.maximum(zs[0], zs[1])
        cv_lvl = s.cv_share(lvl[:1])
        cv_spd = s.cv_share(spd[:1])
        return stat, cv_lvl, cv_spd, s.on_nuisance_sums(lvl[:1]), s.on_nuisance_sums(spd[:1])


class ModulationTest:
    """Does the column scale the model's own terms? (``modulation``)

    Design: ``x * term_k`` for every term ``k`` of the fitted model (x centred and standardised,
    each term by its RMS), on the nuisance space: the score test of ``x`` as a factor of each
    term. An effect that reshapes a term of the model with a column (the Stribeck amplitude
    with the temperature, every term with the motor's temperature) is one direction of it.
    Statistic: the in-sample share. p-value: the nested test, guarded by permutations.
    Also names the term the column scales most (the one whose product alone explains most;
    "" for a constant term: the Coulomb level scaled by x is what the smoother already says).
    Assumptions: the smoother's.
    """

    name = "modulation"

    def __init__(self, space: ResidualSpace, components: Mapping[str, Array] | None) -> None:
        self.s = space
        self.names: list[str] = []
        self.varies: list[bool] = []
        cols = []
        for name, v in (components or {}).items():
            v = np.asarray(v, dtype=float).reshape(-1)
            rms = float(np.sqrt(np.mean(v**2)))
            if v.size == space.n and rms > 0 and np.all(np.isfinite(v)):
                self.names.append(name)
                self.varies.append(bool(np.std(v) > 1e-9 * rms))
                cols.append(v / rms)
        self.comp = np.column_stack(cols) if cols else np.zeros((space.n, 0))

    @property
    def applicable(self) -> bool:
        return bool(self.comp.shape[1])

    def run(self, xs: Array, noise: float | None) -> tuple[Outcome, str]:
        """The outcome (share cross-validated) and the model's term the column scales most."""
        s = self.s
        k = self.comp.shape[1]
        sd = float(np.std(xs[0]))
        if k == 0 or not sd > 0:
            return Outcome(self.name, 0.0, 1.0, 0.0), ""
        share_in0, p_perm, sums, share, j = s.remembered((self.name,), (xs, self.comp), lambda: self._sums(xs, sd))
        p = guarded(s.nested_p(sums, noise), p_perm)
        return Outcome(self.name, share_in0, p, share), self.names[j] if self.varies[j] else ""

    def _sums(self, xs: Array, sd: float) -> tuple[float, float, tuple[float, float, int, int], float, int]:
        """What :meth:`run` computes before the noise floor enters."""
        s = self.s
        k = self.comp.shape[1]
        z = (xs - xs.mean(axis=1, keepdims=True)) / sd

        def design(rows: slice) -> Array:
            zr = z[rows]
            return np.concatenate([np.broadcast_to(s.z0, (zr.shape[0], s.n, s.q)), zr[:, :, None] * self.comp[None]],
                                  axis=2)

        d = design(slice(0, 1))
        sse = np.concatenate([s.in_sse(design(slice(i, i + CHUNK))) for i in range(0, xs.shape[0], CHUNK)])
        share_in = (s.sse0_in - sse) / s.total
        p_perm = permutation_p(float(share_in[0]), share_in[1:])
        sums = s.on_nuisance_sums(d[:1])
        share = s.cv_share(d[:1])
        # the term it scales: the one whose product alone explains most (coefficients of collinear terms
        # do not say it)
        one = np.stack([np.concatenate([s.z0, (z[0] * self.comp[:, j])[:, None]], axis=1) for j in range(k)])
        j = int(np.argmin(s.in_sse(one)))
        return float(share_in[0]), p_perm, sums, share, j


class PeriodogramTest:
    """Is the residual periodic in an angle-like column? (``periodogram``)

    Statistic: the peak of the normalised Lomb-Scargle periodogram
    (:func:`scipy.signal.lombscargle`, floating mean; :func:`lombscargle_many`) of the residual over angular frequencies
    from half a period over the column's span up to :data:`W_MAX` per unit. p-value: from
    :data:`N_PERM_PERIODOGRAM` permutations of the residual; beyond their range the false-alarm
    probability ``1 - (1 - (1 - z)^((n - 3)/2))^M`` with the effective number of independent
    frequencies ``M`` fitted to the median of the permutation maxima. The share is the peak's
    normalised power. Assumptions: rows exchangeable under the null; one sinusoid.
    """

    name = "periodogram"

    def __init__(self, space: ResidualSpace) -> None:
        self.s = space

    def run(self, x: Array) -> tuple[Outcome, float]:
        """The outcome (share: the peak's power) and the peak's angular frequency (nan: no frequency to try)."""
        s = self.s
        span = float(np.ptp(x))
        w_lo = max(math.pi / span, 1e-3)
        step = 2.0 * math.pi / span / 3.0
        w = np.arange(w_lo, W_MAX, step)
        if w.size < 2:
            return Outcome(self.name, 0.0, 1.0, 0.0), math.nan

        # the data and its permutations share x, so one periodogram of all of them (the trigonometry once)
        ys = np.stack([s.r] + [s.r[s.rng.permutation(s.n)] for _ in range(N_PERM_PERIODOGRAM)])
        pw = lombscargle_many(x, ys, w)
        i = int(np.argmax(pw[0]))
        w_best, z = float(w[i]), float(pw[0, i])
        null = np.max(pw[1:], axis=1)
        e = (s.n - 3) / 2.0

        def single(zz: float) -> float:
            return float((1.0 - min(max(zz, 0.0), 1.0)) ** e)

        med = float(np.median(null))
        q = single(med)
        m_eff = math.log(0.5) / math.log1p(-q) if 0 < q < 1 else float(w.size)
        fap = -math.expm1(m_eff * math.log1p(-single(z))) if single(z) < 1 else 1.0
        ge = int(np.sum(null >= z))
        p = (1 + ge) / (null.size + 1) if ge > 0 else min(1.0 / (null.size + 1), fap)
        return Outcome(self.name, z, float(p), z), w_best


class ChangepointTest:
    """Does the residual step once along the column? (``changepoint``)

    Statistic: the standardised CUSUM (the likelihood-ratio form of a single mean shift) of the
    per-cycle mean residual (per row for a column that varies within cycles) ordered by the
    column, over its standard deviation. p-value: from ``r`` permutations of the order
    (:func:`~.significance.permutation_p`; 1 without permutations). Also the change's place
    (between two groups) and a width (a sixteenth of the gap there: a step's centre stays within four
    widths of its place, the gap's middle half). Assumptions: groups
    exchangeable under the null; one shift of the mean.
    """

    name = "changepoint"

    def __init__(self, space: ResidualSpace) -> None:
        self.s = space

    def run(self, x: Array, r: int) -> tuple[Outcome, float, float]:
        """The outcome (no share), the change's place and its width (nan when there are too few groups)."""
        s = self.s
        if s.cycle_level(x):
            cnt = np.bincount(s.cinv)
            gx = np.bincount(s.cinv, weights=x) / cnt
            gr = np.bincount(s.cinv, weights=s.r) / cnt
        else:
            gx, gr = x, s.r
        order = np.argsort(gx, kind="stable")
        gx, gr = gx[order], gr[order]
        g = gr.size
        if g < 4 or not np.std(gr) > 0:
            return Outcome(self.name, 0.0, 1.0), math.nan, math.nan

        def cusum(m: Array) -> tuple[Array, Array]:
            c = np.cumsum(m - m.mean(axis=-1, keepdims=True), axis=-1)[..., :-1]
            k = np.arange(1, g)
            st = c / np.sqrt(k * (g - k) / g)  # the standardised (likelihood-ratio) form of a mean shift
            return np.max(np.abs(st), axis=-1) / m.std(axis=-1), np.argmax(np.abs(st), axis=-1)

        perm = np.stack([gr] + [gr[s.rng.permutation(g)] for _ in range(r)])
        stat, arg = cusum(perm)
        p = permutation_p(float(stat[0]), stat[1:]) if r > 0 else 1.0
        k = int(arg[0])
        at = 0.5 * (gx[k] + gx[k + 1])
        width = max(float(gx[k + 1] - gx[k]) / 16.0, 1e-9 * max(abs(at), 1.0))
        return Outcome(self.name, float(stat[0]), p), float(at), width


class PairTest:
    """Does a second column add to a smooth function of the first? (``smoother (pair)``)

    Two designs on the first column's splines (nested on them), the smaller p-value counted
    twice: a tensor product of cubic splines of both (any smooth interaction, also times the
    speed shapes) and the bilinear one (b and a*b, each also times the speed shapes: few
    parameters, so it keeps its power with few cycles). A *screened* second column (chosen by
    :class:`ScreenTest` among ``screened`` columns) enters as the screen had it (linear and
    times the speed shapes), its p-value multiplied by ``screened``. Each p-value: the nested
    test guarded by permutations of the second column (by whole cycles when it is per cycle).
    Assumptions: the smoother's.
    """

    name = "smoother (pair)"

    def __init__(self, space: ResidualSpace) -> None:
        self.s = space

    def _one(self, design: Callable[[slice], Array], rr: int, d_a: Array
             ) -> tuple[float, tuple[float, float, int, int], float]:
        """(permutation p-value, nested sums, CV share) of the designs ``design(rows)`` (row 0 the data, then
        permutations; ``rr`` in all) nested on ``d_a``: all but the noise floor."""
        s = self.s
        sse = np.concatenate([s.in_sse(design(slice(i, i + CHUNK))) for i in range(0, rr, CHUNK)])
        in_pair = (s.sse0_in - sse) / s.total
        p_perm = permutation_p(float(in_pair[0]), in_pair[1:])
        d0 = design(slice(0, 1))
        return p_perm, s.nested_sums(d_a, d0), s.cv_share(d0)

    def run(self, xa: Array, xb: Array, screened: int, n_perm: int, noise: float | None) -> Outcome:
        s = self.s
        xbp = s.permuted(xb, n_perm)
        parts = s.remembered((self.name, screened), (xa, xbp), lambda: self._parts(xa, xbp, screened))
        ps = [guarded(s.nested_p(sums, noise), p_perm) for p_perm, sums, _ in parts]
        if screened > 1:
            return Outcome(self.name, math.nan, min(1.0, ps[0] * screened), parts[0][2])
        return Outcome(self.name, math.nan, min(1.0, 2.0 * min(ps)), max(parts[0][2], parts[1][2]))

    def _parts(self, xa: Array, xbp: Array, screened: int) -> list[tuple[float, tuple[float, float, int, int], float]]:
        """:meth:`_one` of each design :meth:`run` tries (the screened one; else the full and the lean)."""
        s = self.s
        ba = s.rank_basis(xa[None, :], 4)
        bb_all = s.rank_basis(xbp, 4)
        rr = bb_all.shape[0]
        d_a = np.concatenate([s.z0[None], ba], axis=2)
        xs_all = (xbp - xbp.mean(axis=1, keepdims=True)) / (float(np.std(xbp[0])) or 1.0)
        if screened > 1:  # the screened column enters as the screen had it: linear, times the speed shapes
            def screened_design(rows: slice) -> Array:
                xs = xs_all[rows]
                m = xs.shape[0]
                lin = np.stack([xs, xs * s.low[None, :], xs * s.high[None, :]], axis=2)
                return np.concatenate([np.broadcast_to(s.z0, (m, s.n, s.q)),
                                       np.broadcast_to(ba, (m, s.n, ba.shape[2])), lin], axis=2)

            return [self._one(screened_design, rr, d_a)]
        sa = (xa - xa.mean()) / (float(np.std(xa)) or 1.0)

        def full(rows: slice) -> Array:
            bb = bb_all[rows]
            m = bb.shape[0]
            inter = (np.broadcast_to(ba, bb.shape)[:, :, :, None] * bb[:, :, None, :]).reshape(m, s.n, -1)
            return np.concatenate([np.broadcast_to(s.z0, (m, s.n, s.q)), np.broadcast_to(ba, bb.shape), bb,
                                   inter, inter * s.low[None, :, None], inter * s.high[None, :, None]], axis=2)

        def lean(rows: slice) -> Array:
            xs = xs_all[rows]
            m = xs.shape[0]
            ln = np.stack([xs, xs * sa[None, :]], axis=2)
            return np.concatenate([np.broadcast_to(s.z0, (m, s.n, s.q)), np.broadcast_to(ba, (m, s.n, ba.shape[2])),
                                   ln, ln * s.low[None, :, None], ln * s.high[None, :, None]], axis=2)

        return [self._one(full, rr, d_a), self._one(lean, rr, d_a)]


class ScreenTest:
    """Screen: does column ``x`` (linear, and times the speed shapes) add to a smooth function of ``a``?

    A cheap nested test (no permutations) on four cubic B-splines of ``a``'s rank: which column
    a model input hides. The one with the smallest p-value is then tested as a pair
    (:class:`PairTest`), its p-value multiplied by the number screened. Assumptions: the nested
    test's.
    """

    name = "screen"

    def __init__(self, space: ResidualSpace) -> None:
        self.s = space

    def run(self, a: Array, x: Array, noise: float | None) -> Outcome:
        s = self.s
        return Outcome(self.name, math.nan, s.nested_p(s.remembered((self.name,), (a, x), lambda: self._sums(a, x)),
                                                       noise))

    def _sums(self, a: Array, x: Array) -> tuple[float, float, int, int]:
        s = self.s
        da = np.concatenate([s.z0, s.rank_basis(a[None, :], 4)[0]], axis=1)
        xs = (x - x.mean()) / (float(np.std(x)) or 1.0)
        dx = np.concatenate([da, np.column_stack([xs, xs * s.low, xs * s.high])], axis=1)
        return s.nested_sums(da[None], dx[None])


def _twice_ranks(xs: Array) -> npt.NDArray[np.intp]:
    """Twice the average rank of each value in its row of ``xs`` (``rint(2 * scipy.stats.rankdata(xs, axis=1))``,
    the same whole numbers): a group of ties at sorted places s..e (from 0) has twice its rank s + e + 2."""
    if xs.ndim != 2 or not np.all(np.isfinite(xs)):
        return np.rint(2.0 * stats.rankdata(xs, axis=-1)).astype(np.intp)  # type: ignore[no-any-return]
    r, n = xs.shape
    order = np.argsort(xs, axis=1)  # any order within ties: they share their rank
    srt = np.take_along_axis(xs, order, axis=1)
    tw = np.empty((r, n), dtype=np.intp)
    tw[:] = np.arange(2, 2 * n + 2, 2)
    ties = srt[:, 1:] == srt[:, :-1]
    rows = np.flatnonzero(ties.any(axis=1))
    if rows.size:
        idx = np.arange(n)
        first = np.ones((rows.size, n), dtype=bool)
        first[:, 1:] = ~ties[rows]
        last = np.ones((rows.size, n), dtype=bool)
        last[:, :-1] = first[:, 1:]
        start = np.maximum.accumulate(np.where(first, idx, 0), axis=1)
        end = np.minimum.accumulate(np.where(last, idx, n)[:, ::-1], axis=1)[:, ::-1]
        tw[rows] = start + end + 2
    out = np.empty((r, n), dtype=np.intp)
    np.put_along_axis(out, order, tw, axis=1)
    return out


@functools.lru_cache(maxsize=64)
def _rank_splines(n: int, nb: int) -> Array:
    """Cubic B-splines (``nb`` of them, less the first) of u = (j / 2) / n, row j = 0 .. 2n: every rank's basis."""
    u = np.arange(2 * n + 1) * 0.5 / n
    knots = np.concatenate([[0.0] * 3, np.linspace(0.0, 1.0, nb - 2), [1.0] * 3])
    table = BSpline.design_matrix(np.clip(u, 0.0, 1.0), knots, 3).toarray()[:, 1:]
    table.setflags(write=False)
    return table  # type: ignore[no-any-return]


def lombscargle_many(x: Array, ys: Array, w: Array) -> Array:
    """The normalised floating-mean Lomb-Scargle periodogram of each row of ``ys`` (shape (R, n) -> (R, len(w))).

    :func:`scipy.signal.lombscargle` (``normalize=True, floating_mean=True``, equal weights) row by row, with
    what depends only on ``x`` and ``w`` (the sines, cosines and the phase offset tau) computed once for all rows.
    """
    x = np.asarray(x, dtype=float).reshape(-1, 1)
    ys = np.atleast_2d(np.asarray(ys, dtype=float))
    n = x.shape[0]
    wt = w.reshape(1, -1) * x
    cos, sin = np.cos(wt), np.sin(wt)
    c, s_ = cos.mean(axis=0), sin.mean(axis=0)
    cc = np.mean(cos * cos, axis=0) - c * c
    ss = 1.0 - np.mean(cos * cos, axis=0) - s_ * s_
    cs = np.mean(cos * sin, axis=0) - c * s_
    tau = 0.5 * np.arctan2(2.0 * cs, cc - ss)  # Zechmeister and Kuerster (2009), eq. 19
    cos, sin = np.cos(wt - tau), np.sin(wt - tau)
    c, s_ = cos.mean(axis=0), sin.mean(axis=0)
    cc = np.mean(cos * cos, axis=0)
    ss = 1.0 - cc - s_ * s_
    cc = cc - c * c
    eps = np.finfo(float).epsneg
    cc, ss = np.maximum(cc, eps), np.maximum(ss, eps)
    ym = ys.mean(axis=1, keepdims=True)
    yc = ys @ cos / n - ym * c
    ys_ = ys @ sin / n - ym * s_
    yy = np.mean(ys * ys, axis=1, keepdims=True) - ym * ym
    return (yc * yc / cc + ys_ * ys_ / ss) / yy  # type: ignore[no-any-return]


def _r2(y: Array, yhat: Array) -> float:
    tot = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum((y - yhat) ** 2)) / tot if tot > 0 else 0.0
