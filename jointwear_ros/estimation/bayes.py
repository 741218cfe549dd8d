"""A per-speed marginal-likelihood (Bayesian) wear estimator.

With the model additive in wear (Eq. 9), ``tau_f = b(v, tau_m, T) + g_v(w) + e``.
With T unknown and distributed as a stated prior ``p(T)``, the likelihood of w
is the paper's marginal Eq. (13)::

    p(tau_f | w) = integral N(tau_f - b(T) - g_v(w); 0, sigma_e^2) p(T) dT
                 = h_v(tau_f - g_v(w)),

where ``h_v`` is the density of ``b(v, tau_m, T) + e``: a function of one
variable that depends on (v, tau_m, prior, sigma_e) only. It is computed once
per (speed, load) by quadrature over T (equal cells over the prior's support weighted by their
exact probability mass, with enough cells that ``b`` moves less than
sigma_e / 4 across one) and tabulated as ``log h`` on a fine grid.
The posterior on a w grid over [0, 100] (flat prior on w by default) is then
one table lookup per grid point, for every observation at once; its mean is
one estimate; its maximiser (the marginal maximum-likelihood estimate, the
MAP under the flat prior on w) is the other and the default, with the
posterior std and an equal-tailed 95 % credible interval.

Why the mode by default: for v > 0 the wear term first dips below zero and is
nearly flat on w in [0, ~25] at 90-130 rad/s; a low observation then spreads
the posterior over that flat stretch and the mean lands far from a true
w = 35, so its mean-squared error is 2-3 times the Cramér-Rao bound there,
while the mode stays within about 1.2x up to 100 rad/s (see
``docs/estimation-study.md``).

For studies with thousands of observations at the same (speed, load), the
posterior summaries are functions of the scalar ``tau_f`` alone, so
:meth:`BayesEstimator.estimate_rows` tabulates them once over a fine tau grid
and interpolates: 10,000 runs cost a few milliseconds per speed.

A measured temperature (finite ``temperature`` column) replaces the prior by
that value: the likelihood is then ``N(tau_f - b(T) - g_v(w); 0, sigma_e^2)``.

>>> from jointwear_ros.types import ObservationTable
>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> m, p = paper_wear_model(), load_parameter_set("ref-2011r")
>>> tau = m.evaluate(p, speed=40.0, load_torque=0.1, temperature=40.0, wear=35.0)
>>> obs = ObservationTable.from_arrays(speed=[40.0], tau_f=[tau], load_torque=[0.1], temperature=[40.0])
>>> res = BayesEstimator(noise_std=1e-5).estimate(obs)
>>> round(res.wear, 2)
35.0
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError, ModelError
from ..model import Model, Parameters, ParameterSet
from ..types import ObservationTable, WearResult
from ._common import (
    WEAR_RANGE,
    Capabilities,
    SetModelBase,
    check_noise_std,
    check_wear_range,
    combine_rows,
    log_sum_exp,
    prepare_rows,
    set_temperature_prior,
    with_set_info,
)
from .inverse import base_friction
from .priors import TemperaturePrior, parse_temperature_prior, uniform_prior

__all__ = ["DEFAULT_BAYES_PRIOR", "BayesEstimator", "PosteriorSummary", "SpeedPosterior"]

Array = npt.NDArray[np.float64]

#: The default temperature prior of the Bayesian estimator: a wide uniform, degC.
DEFAULT_BAYES_PRIOR = (25.0, 55.0)
#: Credible level of the reported interval.
CREDIBLE_LEVEL = 0.95
_LOG_2PI = math.log(2.0 * math.pi)
_CHUNK = 1 << 20  # elements of one (rows x w-grid) block


@dataclass(frozen=True)
class PosteriorSummary:
    """Posterior summaries of many observations, arrays of equal length."""

    mean: Array
    std: Array
    low: Array
    high: Array
    mode: Array

    def point(self, which: str) -> Array:
        """The point estimate ``"mode"`` (marginal maximum likelihood / MAP) or ``"mean"``."""
        return self.mode if which == "mode" else self.mean


class SpeedPosterior:
    """The posterior of w for observations at one speed and load, under one prior.

    Parameters
    ----------
    model, params
        A model additive in wear (Eq. 9) and its parameters.
    speed, load
        v (rad/s, motor side) and tau_m (normalized).
    prior
        Temperature prior; ``None`` builds no marginal table (known-T use only).
    noise_std
        sigma_e of the observation.
    w_grid
        The w grid the posterior lives on.
    log_w_prior
        Log prior density of w on ``w_grid`` (unnormalized; flat by default).
    """

    def __init__(
        self,
        model: Model,
        params: Parameters,
        speed: float,
        load: float,
        prior: TemperaturePrior | None,
        noise_std: float,
        w_grid: Array,
        log_w_prior: Array,
        *,
        y_step: float = 0.1,
        max_nodes: int = 4000,
        max_table: int = 40000,
    ) -> None:
        self.model, self.params = model, params
        self.speed, self.load = float(speed), float(load)
        self.sigma = float(noise_std)
        self.w = w_grid
        ref_t = 40.0
        g = model.evaluate(params, speed=self.speed, load_torque=self.load, temperature=ref_t, wear=w_grid)
        g = np.asarray(g - model.evaluate(params, speed=self.speed, load_torque=self.load, temperature=ref_t, wear=0.0),
                       dtype=float)
        self.g = g
        # log prior plus trapezoid weights of the w grid: integrals over w become sums
        trap = np.gradient(w_grid)
        self.log_base = log_w_prior + np.log(trap)
        self.prior = prior
        self._y_step, self._max_nodes, self._max_table = y_step, max_nodes, max_table
        self._logh: Array | None = None

    def _marginal(self) -> Array:
        """The log h table, built on first use (rows with a measured T never need it)."""
        if self._logh is None:
            if self.prior is None:
                raise InputDataError("no temperature prior: the marginal likelihood needs one")
            self._build_marginal(self.prior, self._y_step, self._max_nodes)
        assert self._logh is not None
        return self._logh

    # -- the marginal density h(y) of b(T) + e ------------------------------
    def _nodes(self, prior: TemperaturePrior, max_nodes: int) -> tuple[Array, Array]:
        """Cells of equal width over the prior's support, each with its exact probability mass.

        The cell count makes b move by at most sigma_e / 4 across a cell, so the
        sum over cells of ``mass * N(y - b(T_mid))`` is the convolution integral
        to well below the noise scale (a midpoint rule in T).
        """
        lo, hi = prior.support()
        probe = np.linspace(lo, hi, 257)
        bp = base_friction(self.model, self.params, self.speed, self.load, probe)
        spread = float(np.max(np.abs(np.diff(bp)), initial=0.0)) * 256
        n = int(min(max_nodes, max(64, math.ceil(spread / (0.25 * self.sigma)))))
        edges = np.linspace(lo, hi, n + 1)
        mass = np.diff(np.asarray(prior.dist.cdf(edges), dtype=float))
        mass = mass / mass.sum()
        mid = 0.5 * (edges[1:] + edges[:-1])
        b = base_friction(self.model, self.params, self.speed, self.load, mid)
        return np.asarray(b, dtype=float), mass

    def _build_marginal(self, prior: TemperaturePrior, y_step: float, max_nodes: int) -> None:
        b, wt = self._nodes(prior, max_nodes)
        keep = wt > 0
        self.b_nodes, self.log_b_w = b[keep], np.log(wt[keep])
        s = self.sigma
        self.b_min, self.b_max = float(self.b_nodes.min()), float(self.b_nodes.max())
        # y = tau - g(w) for every tau within 12 sigma of a possible observation and every w
        g_span = float(self.g.max() - self.g.min())
        lo = self.b_min - g_span - 16.0 * s
        hi = self.b_max + g_span + 16.0 * s
        dy = max(y_step * s, (hi - lo) / (self._max_table - 1))
        n = math.ceil((hi - lo) / dy) + 1
        self._y0, self._dy = lo, dy
        y = lo + dy * np.arange(n)
        self._logh = self.log_marginal_exact(y)

    def log_marginal_exact(self, y: npt.ArrayLike) -> Array:
        """log h(y) by the quadrature sum (no table)."""
        y = np.asarray(y, dtype=float)
        flat = y.reshape(-1)
        out = np.empty(flat.size)
        step = max(1, (1 << 20) // self.b_nodes.size)
        for i in range(0, flat.size, step):
            r = (flat[i:i + step, None] - self.b_nodes[None, :]) / self.sigma
            # every term is finite (the log masses of the kept cells); summed in place
            out[i:i + step] = log_sum_exp(self.log_b_w[None, :] - 0.5 * r * r, axis=1, overwrite=True)
        return (out - 0.5 * _LOG_2PI - math.log(self.sigma)).reshape(y.shape)

    def log_marginal(self, y: Array) -> Array:
        """log h(y): table lookup with linear interpolation.

        Beyond the table (more than 16 sigma_e from every b(T)), h is continued
        by the Gaussian tail of the nearest edge of b's range.
        """
        logh = self._marginal()
        t = (y - self._y0) / self._dy
        n = logh.size
        k = np.clip(t, 0, n - 1 - 1e-9).astype(np.intp)
        f = np.clip(t, 0, n - 1) - k
        out = logh[k] * (1.0 - f) + logh[k + 1] * f
        below, above = t < 0, t > n - 1
        if below.any() or above.any():
            s2 = 2.0 * self.sigma * self.sigma
            y_lo, y_hi = self._y0, self._y0 + self._dy * (n - 1)
            yb, ya = y[below], y[above]
            out[below] = logh[0] - ((yb - self.b_min) ** 2 - (y_lo - self.b_min) ** 2) / s2
            out[above] = logh[-1] - ((ya - self.b_max) ** 2 - (y_hi - self.b_max) ** 2) / s2
        return out

    # -- posterior -------------------------------------------------------------
    def log_posterior(self, tau: Array, temperature: Array | None = None) -> Array:
        """Unnormalized log posterior on the w grid, shape (len(tau), len(w))."""
        y = tau[:, None] - self.g[None, :]
        if temperature is None:
            ll = self.log_marginal(y)
        else:
            b = base_friction(self.model, self.params, self.speed, self.load, temperature)
            r = (y - np.asarray(b, dtype=float)[:, None]) / self.sigma
            ll = -0.5 * r * r
        return ll + self.log_base[None, :]

    def summarize(self, tau: npt.ArrayLike, temperature: npt.ArrayLike | None = None,
                  level: float = CREDIBLE_LEVEL, *, interval: bool = True) -> PosteriorSummary:
        """Posterior mean, std and equal-tailed credible interval for each observation.

        ``interval=False`` leaves ``low`` and ``high`` NaN: the posterior CDF and its quantiles are a fair
        share of the work on a large block, and a point estimate with its std does not need them.
        """
        tau = np.atleast_1d(np.asarray(tau, dtype=float))
        temp = None if temperature is None else np.broadcast_to(np.asarray(temperature, dtype=float), tau.shape)
        mean, std, mode = np.empty(tau.size), np.empty(tau.size), np.empty(tau.size)
        low, high = np.full(tau.size, math.nan), np.full(tau.size, math.nan)
        a = 0.5 * (1.0 - level)
        step = max(1, _CHUNK // self.w.size)
        for s in range(0, tau.size, step):
            sl = slice(s, s + step)
            lp = self.log_posterior(tau[sl], None if temp is None else temp[sl])
            mode[sl] = _refined_argmax(lp, self.w)
            lp -= lp.max(axis=1, keepdims=True)
            p = np.exp(lp, out=lp)  # in place: lp is not needed after this, and the block is large
            p /= p.sum(axis=1, keepdims=True)
            m = p @ self.w
            mean[sl] = m
            std[sl] = np.sqrt(np.maximum(p @ (self.w * self.w) - m * m, 0.0))
            if not interval:
                continue
            cdf = np.cumsum(p, axis=1)
            low[sl] = _quantile_rows(cdf, self.w, a)
            high[sl] = _quantile_rows(cdf, self.w, 1.0 - a)
        return PosteriorSummary(mean, std, low, high, mode)

    def tau_range(self) -> tuple[float, float]:
        """Observations beyond this range are out by more than 12 sigma_e for every w and T."""
        self._marginal()
        return (float(self.b_nodes.min() + self.g.min() - 12.0 * self.sigma),
                float(self.b_nodes.max() + self.g.max() + 12.0 * self.sigma))


def _refined_argmax(lp: Array, w: Array) -> Array:
    """Each row's maximiser on grid w, refined by a parabola through the three points around it."""
    k = np.argmax(lp, axis=1)
    rows = np.arange(lp.shape[0])
    inner = (k > 0) & (k < w.size - 1)
    kc = np.clip(k, 1, w.size - 2)
    l0, l1, l2 = lp[rows, kc - 1], lp[rows, kc], lp[rows, kc + 1]
    den = l0 - 2.0 * l1 + l2
    shift = np.where(inner & (den < 0), 0.5 * (l0 - l2) / np.where(den < 0, den, -1.0), 0.0)
    step = w[1] - w[0]
    return np.asarray(w[k] + np.clip(shift, -0.5, 0.5) * step, dtype=float)


def _quantile_rows(cdf: Array, w: Array, q: float) -> Array:
    """The q-quantile of each row's discrete CDF on grid w (linear between grid points)."""
    idx = np.sum(cdf < q, axis=1)
    idx = np.clip(idx, 1, w.size - 1)
    rows = np.arange(cdf.shape[0])
    c0, c1 = cdf[rows, idx - 1], cdf[rows, idx]
    frac = np.clip((q - c0) / np.where(c1 > c0, c1 - c0, 1.0), 0.0, 1.0)
    out = w[idx - 1] + frac * (w[idx] - w[idx - 1])
    return np.where(cdf[:, 0] >= q, w[0], out)


class BayesEstimator(SetModelBase):
    """Posterior mean of w per observation with T marginalised under a stated prior.

    Parameters
    ----------
    model, params
        Friction model (default Eq. 9, must be additive in wear) and parameters
        (default ``ref-2011r``).
    prior
        Temperature prior: a :class:`TemperaturePrior`, a spec such as
        ``"normal:40:3"`` or ``"uniform:25:55"`` (default U(25, 55) degC).
    noise_std
        sigma_e of an observation (rows with ``tau_f_std`` use their own).
    wear_range
        Support of w (the paper's [0, 100]); the prior on w is flat there.
    point
        The point estimate reported as ``wear``: ``"mode"`` (default; the
        maximiser of the marginal likelihood Eq. 13, which under the flat
        prior on w is the MAP) or ``"mean"`` (the posterior mean). Both, the
        posterior std and the interval are always computed.
    grid_step
        Step of the w grid of the posterior (default 0.1; the mode is refined
        between grid points).
    default_load
        tau_m for tables without a ``load_torque`` column.
    use_temperature
        Use measured temperatures (finite ``temperature``) instead of the prior.
    tabulate_above
        Groups of more than this many rows at one (speed, load) are solved
        through a tau table (see :meth:`estimate_rows`).
    n_tau
        Most points of that tau table (its step is sigma_e / 10 where that fits).
    """

    name = "bayes"
    capabilities = Capabilities(
        summary="per observation, the posterior of w with T marginalised under a stated prior",
        temperature_assumption="prior", gives_posterior=True, search="posterior grid",
        points=(("mode", "mode"), ("map", "mode"), ("mean", "mean")))

    def __init__(
        self,
        model: Model | None = None,
        params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
        *,
        prior: TemperaturePrior | str | object | None = None,
        noise_std: float | None = None,
        wear_range: tuple[float, float] = WEAR_RANGE,
        point: str = "mode",
        grid_step: float = 0.1,
        default_load: float | None = None,
        use_temperature: bool = True,
        tabulate_above: int = 2000,
        n_tau: int = 4096,
        seed: int | None = None,
        rng: np.random.Generator | None = None,
    ) -> None:
        # seed/rng are accepted for a uniform factory interface; the estimator is deterministic
        del seed, rng
        noise_std = self.attach_set_model(model, params, noise_std)
        if prior is None:
            prior = set_temperature_prior(self.param_set, None)
        self.prior = uniform_prior(*DEFAULT_BAYES_PRIOR) if prior is None else parse_temperature_prior(prior)
        self.noise_std = check_noise_std(noise_std)
        lo, hi = check_wear_range(wear_range)
        if not (math.isfinite(grid_step) and 0 < grid_step <= (hi - lo) / 10):
            raise InputDataError(f"grid_step = {grid_step!r}: needs 0 < step <= {(hi - lo) / 10:g}")
        self.wear_range = (lo, hi)
        if point not in ("mode", "mean"):
            raise InputDataError(f"point = {point!r}: choose 'mode' (marginal maximum likelihood) or 'mean'")
        self.point = point
        n = round((hi - lo) / grid_step) + 1
        self.w_grid = np.linspace(lo, hi, n)
        self.log_w_prior = np.zeros(n)
        self.default_load = default_load
        self.use_temperature = use_temperature
        self.tabulate_above = int(tabulate_above)
        self.n_tau = int(n_tau)
        self._check_additive()
        self._posteriors: dict[tuple[float, float, float], SpeedPosterior] = {}

    def _check_additive(self) -> None:
        w = np.array([0.0, 20.0, 35.0, 70.0])
        for v in (0.0, 40.0, 150.0):
            d1 = self.model.evaluate(self.params, speed=v, load_torque=0.0, temperature=30.0, wear=w)
            d2 = self.model.evaluate(self.params, speed=v, load_torque=0.5, temperature=50.0, wear=w)
            if not np.allclose(d1 - d1[0], d2 - d2[0], rtol=1e-9, atol=1e-12):
                raise ModelError(
                    f"model {self.model.spec!r}: the wear effect depends on load or temperature; the Bayesian "
                    "estimator needs a model additive in wear (Eq. 9)"
                )

    def posterior(self, speed: float, load: float, noise_std: float | None = None) -> SpeedPosterior:
        """The (cached) posterior machinery at one (speed, load, sigma_e)."""
        sig = self.noise_std if noise_std is None else float(noise_std)
        key = (float(speed), float(load), sig)
        post = self._posteriors.get(key)
        if post is None:
            post = SpeedPosterior(self.model, self.params, key[0], key[1], self.prior, sig,
                                  self.w_grid, self.log_w_prior)
            if len(self._posteriors) > 512:
                self._posteriors.clear()
            self._posteriors[key] = post
        return post

    # -- vectorised API --------------------------------------------------------
    def estimate_rows(
        self,
        speed: npt.ArrayLike,
        load: npt.ArrayLike,
        tau_f: npt.ArrayLike,
        temperature: npt.ArrayLike | None = None,
        *,
        noise_std: npt.ArrayLike | None = None,
        rng: np.random.Generator | None = None,
    ) -> tuple[Array, Array]:
        """Single-observation estimates of many rows: ``(point estimate, posterior std)``.

        ``rng`` is accepted for the common study interface and unused (the
        estimator is deterministic). See :meth:`summarize_rows` for intervals
        (not computed here: nothing returned needs them).
        """
        del rng
        s = self.summarize_rows(speed, load, tau_f, temperature, noise_std=noise_std, interval=False)
        return s.point(self.point), s.std

    def summarize_rows(
        self,
        speed: npt.ArrayLike,
        load: npt.ArrayLike,
        tau_f: npt.ArrayLike,
        temperature: npt.ArrayLike | None = None,
        *,
        noise_std: npt.ArrayLike | None = None,
        interval: bool = True,
    ) -> PosteriorSummary:
        """Posterior mean, std and 95 % interval of many rows at once.

        Rows are grouped by (speed, load, sigma_e). A group of rows with
        unknown temperature larger than ``tabulate_above`` is solved through
        a table of the summaries over ``n_tau`` values of tau_f (they depend
        on tau_f alone), interpolated linearly; smaller groups are solved
        directly. ``interval=False`` skips the interval (``low``, ``high`` NaN).
        """
        speed = np.atleast_1d(np.asarray(speed, dtype=float))
        shape = speed.shape
        tau = np.broadcast_to(np.asarray(tau_f, dtype=float), shape)
        ld = np.broadcast_to(np.asarray(load, dtype=float), shape)
        temp = (np.full(shape, math.nan) if temperature is None
                else np.broadcast_to(np.asarray(temperature, dtype=float), shape))
        sig = (np.full(shape, self.noise_std) if noise_std is None
               else np.broadcast_to(np.asarray(noise_std, dtype=float), shape))
        out = [np.empty(shape) for _ in range(5)]
        keys = np.stack([speed, ld, sig], axis=1)
        # one group (a study's column): skip np.unique's sort of the rows, slow on 10^4 of them
        if keys.shape[0] and (keys == keys[0]).all():
            uniq, inv = keys[:1], np.zeros(keys.shape[0], dtype=np.intp)
        else:
            uniq, inv = np.unique(keys, axis=0, return_inverse=True)
        inv = np.asarray(inv).reshape(-1)
        for gi, (v, tm, sg) in enumerate(uniq):
            idx = np.flatnonzero(inv == gi)
            post = self.posterior(float(v), float(tm), float(sg))
            known = np.isfinite(temp[idx]) if self.use_temperature else np.zeros(idx.size, dtype=bool)
            if known.any():
                k = idx[known]
                _store(out, k, post.summarize(tau[k], temp[k], interval=interval))
            u = idx[~known]
            if u.size > self.tabulate_above:
                _store(out, u, self._tabulated(post, tau[u], interval))
            elif u.size:
                _store(out, u, post.summarize(tau[u], interval=interval))
        return PosteriorSummary(*out)

    def _tabulated(self, post: SpeedPosterior, tau: Array, interval: bool = True) -> PosteriorSummary:
        lo, hi = post.tau_range()
        n = int(min(self.n_tau, max(256, math.ceil((hi - lo) / (0.1 * post.sigma)) + 1)))
        grid = np.linspace(lo, hi, n)
        tab = post.summarize(grid, interval=interval)
        fields = ("mean", "std", "low", "high", "mode")
        res = PosteriorSummary(*(np.interp(tau, grid, getattr(tab, f)) if interval or f not in ("low", "high")
                                 else np.full(tau.shape, math.nan) for f in fields))
        out_of = (tau < lo) | (tau > hi)
        if out_of.any():
            ex = post.summarize(tau[out_of], interval=interval)
            for f in fields:
                getattr(res, f)[out_of] = getattr(ex, f)
        return res

    def estimate(self, observations: ObservationTable) -> WearResult:
        """Posterior mean per observation (speed); the cycle estimate combines them (see ``combine_rows``)."""
        rows = prepare_rows(observations, noise_std=self.noise_std, default_load=self.default_load,
                            use_temperature=self.use_temperature, pset=self.param_set, extra=self.extra,
                            params=self.params)
        s = self.summarize_rows(rows.speed, rows.load, rows.tau_f, rows.temperature, noise_std=rows.noise_std)
        res = combine_rows(
            rows, s.point(self.point), np.maximum(s.std, 1e-6), method=self.name,
            info={
                "prior": self.prior.label,
                "point": self.point,
                "per_speed_posterior_mean": [float(x) for x in s.mean],
                "per_speed_mode": [float(x) for x in s.mode],
                "known_temperature": [bool(k) for k in rows.known_temperature],
                "per_speed_low": [float(x) for x in s.low],
                "per_speed_high": [float(x) for x in s.high],
                "credible_level": CREDIBLE_LEVEL,
            },
        )
        if len(rows) == 1:  # one observation: report its own credible interval
            res = WearResult(
                wear=res.wear, wear_std=res.wear_std, wear_low=float(s.low[0]), wear_high=float(s.high[0]),
                method=res.method, speeds=res.speeds, per_speed_wear=res.per_speed_wear,
                info=dict(res.info, interval=f"equal-tailed {CREDIBLE_LEVEL:.0%} credible interval"),
            )
        return with_set_info(res, self.param_set)


def _store(out: list[Array], idx: Array, s: PosteriorSummary) -> None:
    for o, a in zip(out, (s.mean, s.std, s.low, s.high, s.mode)):
        o[idx] = a
