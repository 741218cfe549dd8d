"""Time to alarm: when the bank's forecast crosses the alarm, and the forecast band (pure numpy/scipy).

From each member's state at the last estimate, the wear ``tau`` days ahead is Gaussian, ``h(tau) m`` with
variance ``h P h' (+ process noise for the adaptive members: q tau^3/3, quadratic q tau^5/20)``,
``h = [1, tau]`` (line, random walk), ``[1, e (exp(tau / e) - 1)]`` (accelerated), ``[1, tau, tau^2/2]``
(quadratic) (:func:`forecast_basis`). The probability that the alarm ``a`` has been crossed by ``tau`` is
the running maximum over ``tau' <= tau`` of ``P(wear(tau') >= a)`` (exact for a monotone curve with
uncertain parameters; for the random-walk part it ignores paths that cross and come back, which wear does
not do). These curves are averaged with the members' weights (:mod:`jointwear_ros.trend.states`); the 5 %,
50 % and 95 % points are the 90 % interval and the median (:func:`crossing_quantiles`; a point not reached
within ``max_horizon_days`` is infinite: unbounded, and :attr:`TimeToAlarm.unbounded_reason` says why).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import ndtr

from .config import Array, TrendConfig
from .members import Component, Member, steady_basis

__all__ = ["TimeToAlarm", "crossing_cdf", "crossing_curves", "crossing_quantiles", "forecast_band", "forecast_basis",
           "tau_grid"]


@dataclass(frozen=True)
class TimeToAlarm:
    """Days from the last estimate until the trend crosses the alarm: median and 90 % interval (inf: beyond),
    the members' weights and, for an infinite bound, why the data cannot bound it."""

    median: float
    lo90: float
    hi90: float
    model_weights: dict[str, float] = field(default_factory=dict)
    unbounded_reason: str | None = None

    def as_dict(self) -> dict[str, Any]:
        return {"median": self.median, "lo90": self.lo90, "hi90": self.hi90,
                "model_weights": dict(self.model_weights), "unbounded_reason": self.unbounded_reason}


_GRID_CACHE: dict[float, Array] = {}


def tau_grid(max_days: float) -> Array:
    """The grid of days ahead on which crossing probabilities are evaluated (0, then 700 log-spaced to the horizon)."""
    g = _GRID_CACHE.get(max_days)
    if g is None:
        g = np.concatenate([[0.0], np.geomspace(0.01, max_days, 700)])
        _GRID_CACHE[max_days] = g
    return g


def forecast_basis(m: Member, tau: Array, cfg: TrendConfig) -> tuple[Array, Array]:
    """``H`` (d, G) and the process-noise variance (G,) of member ``m``'s wear ``tau`` days ahead."""
    tau = np.asarray(tau, float)
    if m.kind == "steady":
        u, _ = steady_basis(tau, m.efold)
        return np.stack([np.ones_like(tau), u]), np.zeros_like(tau)
    H = np.stack([np.ones_like(tau), tau, tau * tau / 2][: m.order])
    noise = m.q * tau ** 3 / 3 if m.order == 2 else m.q * tau ** 5 / 20
    return H, noise + cfg.level_noise * tau


def crossing_curves(mean: Array, cov: Array, H: Array, extra: Array, alarm: float, mu: Array | None = None) -> Array:
    """P(``alarm`` crossed by each day ahead) (N, G) of states ``mean`` (N, d), ``cov`` (N, d, d) forecast with
    :func:`forecast_basis`'s ``H`` (d, G) and process noise ``extra`` (G,): the running maximum over the grid.
    ``mu``: the forecast means ``mean @ H`` when already computed (the matrix product's last bit depends on the
    number of rows it is computed for)."""
    m = np.atleast_2d(mean)
    d = m.shape[1]
    P = cov.reshape(-1, d, d)
    mu = m @ H if mu is None else mu
    v = np.einsum("ig,nij,jg->ng", H, P, H)
    if extra.any():  # the steady members have none
        v += extra[None, :]
    # z = (mu - alarm) / sqrt(max(v, 1e-12)), in place
    np.sqrt(np.maximum(v, 1e-12, out=v), out=v)
    z = np.subtract(mu, alarm)
    z /= v
    return np.asarray(np.maximum.accumulate(ndtr(z), axis=1))


def crossing_cdf(mean: Array, cov: Array, q: float, cfg: TrendConfig, tau: Array) -> Array:
    """P(alarm crossed by tau) for adaptive states (N, d), (N, d, d) -> (N, len(tau)), running max over tau
    (``q = 0``, d = 2: a straight line with uncertain level and rate)."""
    d = np.atleast_2d(mean).shape[1]
    H, extra = forecast_basis(Member("", "adaptive", q=q, order=d), tau, cfg)
    return crossing_curves(mean, cov, H, extra, cfg.alarm)


def crossing_quantiles(F: Array, tau: Array, probs: Sequence[float] = (0.05, 0.5, 0.95)) -> Array:
    """Quantiles (N, len(probs)) of crossing CDFs ``F`` (N, G) on the grid ``tau``; inf where never reached."""
    out = np.full((F.shape[0], len(probs)), np.inf)
    rows = np.arange(F.shape[0])
    for j, p in enumerate(probs):
        hit = F >= p
        anyhit = hit.any(axis=1)
        k = np.argmax(hit, axis=1)
        km1 = np.maximum(k - 1, 0)
        f0, f1 = F[rows, km1], F[rows, k]
        frac = np.where(f1 > f0, (p - f0) / np.where(f1 > f0, f1 - f0, 1.0), 0.0)
        val = np.where(k == 0, 0.0, tau[km1] + frac * (tau[k] - tau[km1]))
        out[anyhit, j] = val[anyhit]
    return out


def forecast_band(comps: Sequence[Component], members: Sequence[Member], cfg: TrendConfig, tau: Array,
                  probs: Sequence[float] = (0.05, 0.5, 0.95)) -> Array:
    """Quantiles (len(tau), len(probs)) of the mixture's wear ``tau`` days ahead (for the plot)."""
    tau = np.asarray(tau, float)
    mus, sds, ws = [], [], []
    for c in comps:
        H, extra = forecast_basis(members[c.member], tau, cfg)
        mus.append(c.mean @ H)
        sds.append(np.sqrt(np.maximum(np.einsum("ig,ij,jg->g", H, c.cov, H) + extra, 1e-12)))
        ws.append(c.weight)
    mu, sd, w = np.array(mus), np.array(sds), np.array(ws)[:, None]
    lo = (mu - 5 * sd).min(axis=0)
    hi = (mu + 5 * sd).max(axis=0)
    out = np.zeros((len(tau), len(probs)))
    for g in range(len(tau)):
        x = np.linspace(lo[g], hi[g], 801)
        F = (w[:, 0][:, None] * ndtr((x[None, :] - mu[:, g][:, None]) / sd[:, g][:, None])).sum(axis=0)
        out[g] = np.interp(probs, F / F[-1], x)
    return out
