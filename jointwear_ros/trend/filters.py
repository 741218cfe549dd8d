"""The fits of the bank's members to a segment's estimates (numpy, the Kalman filters on plain floats).

*Adaptive members*: 2- and 3-state Kalman filters with irregular steps and per-estimate variance
(hand-written on plain floats: a few lines, and the fleet backtest runs at hundreds of joint-nights per second;
statsmodels' ``UnobservedComponents`` assumes equal steps and fits the observation variance)::

    L(t + dt) = L(t) + S(t) dt + eta_L,    S(t + dt) = S(t) + eta_S
    Q(dt) = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]  (+ q_L dt on the level)
    y_k = L(t_k) + e_k,   e_k ~ N(0, wear_std_k^2)

*Steady members*: the regression ``w = c0 + c1 u(t)`` with a Gaussian prior, in closed form from prefix
sums of its sufficient statistics; its evidence sums over "no step" and a step before every estimate (a
product-partition model with at most one change), its prediction uses the line after the step in
proportion to that step's posterior.

Each fit gives the member's marginal log-likelihood (evidence) of the estimates, comparable across members
because all start from the same level and rate priors (:mod:`jointwear_ros.trend.members`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .config import Array, TrendConfig
from .members import RatePrior, steady_basis

__all__ = ["FilterOutput", "SteadyRows", "filter_bank", "kalman_llt", "logsumexp", "rts_smooth", "steady_at", "steady_nights",
           "steady_rows"]


@dataclass(frozen=True)
class FilterOutput:
    """Filtered (or smoothed) states of one adaptive member: ``t_days`` (n,), ``mean`` (n, d), ``cov`` (n, d, d),
    ``loglik`` (n,) the cumulative log-likelihood (marginal, with the level and rate priors) up to each estimate."""

    t_days: Array
    mean: Array
    cov: Array
    loglik: Array
    q: float
    order: int = 2


# ---------------------------------------------------------------------------- adaptive members (Kalman)


def _transition(dt: float, order: int, q: float, ql: float) -> tuple[Array, Array]:
    """F and Q over ``dt`` days: order 2 = integrated random walk of the rate (white acceleration of
    density q); order 3 = an acceleration state with a random walk (white jerk of density q)."""
    if order == 2:
        F = np.array([[1.0, dt], [0.0, 1.0]])
        Q = q * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    else:
        F = np.array([[1.0, dt, dt * dt / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        Q = q * np.array([[dt ** 5 / 20, dt ** 4 / 8, dt ** 3 / 6],
                          [dt ** 4 / 8, dt ** 3 / 3, dt ** 2 / 2],
                          [dt ** 3 / 6, dt ** 2 / 2, dt]])
    Q[0, 0] += ql * dt
    return F, Q


def kalman_llt(t_days: Array, y: Array, r: Array, cfg: TrendConfig, q: float | None = None,
               order: int = 2, prior: RatePrior | None = None) -> FilterOutput:
    """Filtered states at each estimate (times in days, ascending) for one ``q``.

    ``order`` 2: the local linear trend (level, rate); 3: local quadratic (level, rate, acceleration
    with prior std ``cfg.accel_prior_std``), for wear that keeps accelerating. The level starts from
    ``N(level_prior_mean, level_prior_std^2)``, the rate from the prior's ``N(mean, std^2)``; ``loglik``
    is the marginal log-likelihood of the estimates so far (comparable with the steady members').
    """
    q = float(cfg.accel_noise[0] if q is None else q)
    pr = prior or RatePrior(std=cfg.slope_prior_std)
    t = np.asarray(t_days, float)
    tl = t.tolist()
    yl = np.asarray(y, float).tolist()
    var = (np.asarray(r, float) ** 2).tolist()
    ql = float(cfg.level_noise)
    # the states and covariances in plain floats (numpy's per-call cost on 2 x 2 and 3 x 3 is most of a step):
    # order 2: m = (L, S), P = [[a, b], [b, c]]; order 3 adds the acceleration A and P's third row (d, e, f)
    m0, m1, m2 = float(cfg.level_prior_mean), float(pr.mean), 0.0
    pa, pb, pc = float(cfg.level_prior_std) ** 2, 0.0, float(pr.std) ** 2
    pd, pe, pf = 0.0, 0.0, float(cfg.accel_prior_std) ** 2
    means: list[tuple[float, ...]] = []
    covs: list[tuple[float, ...]] = []
    lls: list[float] = []
    total = 0.0
    for k in range(len(tl)):
        if k > 0:
            dt = tl[k] - tl[k - 1]
            dt = dt if dt > 0.0 else 0.0
            d2, d3 = dt * dt, dt * dt * dt
            if order == 2:  # F = [[1, dt], [0, 1]]; F P F^T + Q (Q of _transition)
                m0 = m0 + dt * m1
                pa, pb, pc = (pa + 2.0 * dt * pb + d2 * pc + q * d3 / 3 + ql * dt, pb + dt * pc + q * d2 / 2,
                              pc + q * dt)
            else:  # F = [[1, dt, dt^2/2], [0, 1, dt], [0, 0, 1]]
                h = d2 / 2
                m0, m1 = m0 + dt * m1 + h * m2, m1 + dt * m2
                r0 = (pa + dt * pb + h * pd, pb + dt * pc + h * pe, pd + dt * pe + h * pf)  # (F P) row 0
                r1 = (pb + dt * pd, pc + dt * pe, pe + dt * pf)  # row 1
                pa, pb, pd = (r0[0] + dt * r0[1] + h * r0[2] + q * d3 * d2 / 20 + ql * dt,
                              r0[1] + dt * r0[2] + q * d2 * d2 / 8, r0[2] + q * d3 / 6)
                pc, pe = r1[1] + dt * r1[2] + q * d3 / 3, r1[2] + q * d2 / 2
                pf = pf + q * dt
        s_ = pa + var[k]
        v = yl[k] - m0
        total += -0.5 * (math.log(2 * math.pi * s_) + v * v / s_)
        ka, kb, kc = pa / s_, pb / s_, pd / s_  # K = P[:, 0] / s
        m0, m1, m2 = m0 + ka * v, m1 + kb * v, m2 + kc * v
        # P - K P[0, :], symmetric by construction (K_i P_0j = P_i0 P_0j / s)
        pa, pb, pc, pd, pe, pf = (pa - ka * pa, pb - ka * pb, pc - kb * pb, pd - ka * pd, pe - kb * pd, pf - kc * pd)
        if order == 2:
            means.append((m0, m1))
            covs.append((pa, pb, pb, pc))
        else:
            means.append((m0, m1, m2))
            covs.append((pa, pb, pd, pb, pc, pe, pd, pe, pf))
        lls.append(total)
    n = len(tl)
    mean = np.array(means, dtype=float).reshape(n, order)
    cov = np.array(covs, dtype=float).reshape(n, order, order)
    return FilterOutput(t, mean, cov, np.array(lls, dtype=float), q, order)


def filter_bank(t_days: Array, y: Array, r: Array, cfg: TrendConfig,
                prior: RatePrior | None = None) -> list[FilterOutput]:
    """The adaptive members: each ``q`` of ``cfg.accel_noise`` (order 2), each of ``cfg.jerk_noise`` (order 3)."""
    return ([kalman_llt(t_days, y, r, cfg, q, 2, prior) for q in cfg.accel_noise]
            + [kalman_llt(t_days, y, r, cfg, q, 3, prior) for q in cfg.jerk_noise])


def rts_smooth(f: FilterOutput, cfg: TrendConfig) -> FilterOutput:
    """Rauch-Tung-Striebel smoothed states (for the plotted trend band)."""
    n = len(f.t_days)
    ms, Ps = f.mean.copy(), f.cov.copy()
    for k in range(n - 2, -1, -1):
        F, Q = _transition(max(f.t_days[k + 1] - f.t_days[k], 0.0), f.order, f.q, cfg.level_noise)
        Pp = F @ f.cov[k] @ F.T + Q
        C = f.cov[k] @ F.T @ np.linalg.pinv(Pp)
        ms[k] = f.mean[k] + C @ (ms[k + 1] - F @ f.mean[k])
        Ps[k] = f.cov[k] + C @ (Ps[k + 1] - Pp) @ C.T
    return FilterOutput(f.t_days, ms, Ps, f.loglik, f.q, f.order)


# ---------------------------------------------------------------------------- steady members (closed form)


def logsumexp(x: Array) -> float:
    """log(sum(exp(x))) of a 1-D array (-inf when empty or all -inf); scipy's is 10x slower on short arrays."""
    m = float(np.max(x)) if len(x) else -math.inf
    if not math.isfinite(m):
        return m
    return m + math.log(float(np.exp(x - m).sum()))


def _regression_evidence(S: Array, ua: Array, upa: Array, cfg: TrendConfig, pr: RatePrior
                         ) -> tuple[Array, Array, Array, Array, Array, Array, Array]:
    """Log evidence of ``w = c0 + c1 u(t)`` on segments with sufficient statistics ``S`` (7, .) = sums of w,
    w u, w u², w y, w u y, w y², log(2 pi r²), w = 1/r², the prior ``N`` on (level, rate) at each segment's
    first estimate, where u = ``ua`` and u' = ``upa``; with the posterior mean ``(c0, c1)`` (the level and rate
    at the night: u = 0, u' = 1 there) and the terms of its covariance, ``[[a22, -a12], [-a12, a11]] / det``
    (:func:`_regression_moments` builds mean and covariance where they are needed)."""
    sw, su, suu, sy, suy, syy, sc = S
    pl, ps = 1.0 / cfg.level_prior_std ** 2, 1.0 / pr.std ** 2
    ml, ms = cfg.level_prior_mean, pr.mean
    a11 = sw + pl
    a12 = su + pl * ua
    a22 = suu + pl * ua * ua + ps * upa * upa
    b1 = sy + pl * ml
    b2 = suy + ua * pl * ml + upa * ps * ms
    det = a11 * a22 - a12 * a12
    c0 = (a22 * b1 - a12 * b2) / det
    c1 = (a11 * b2 - a12 * b1) / det
    quad = b1 * c0 + b2 * c1
    logdet_v = math.log(cfg.level_prior_std ** 2) + math.log(pr.std ** 2) - 2.0 * np.log(upa)
    ev = -0.5 * (sc + syy + pl * ml * ml + ps * ms * ms - quad + logdet_v + np.log(det))
    return ev, c0, c1, a11, a12, a22, det


def _regression_moments(c0: Array, c1: Array, a11: Array, a12: Array, a22: Array, det: Array
                        ) -> tuple[Array, Array]:
    """Posterior mean (., 2) and covariance (., 2, 2) from :func:`_regression_evidence`'s terms."""
    mean = np.empty((*c0.shape, 2))
    mean[..., 0], mean[..., 1] = c0, c1
    cov = np.empty((*c0.shape, 2, 2))
    cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 0], cov[..., 1, 1] = a22 / det, -a12 / det, -a12 / det, a11 / det
    return mean, cov


def steady_at(t: Array, y: Array, r: Array, n: int, efold: float, cfg: TrendConfig, pr: RatePrior,
              keep: int = 3) -> tuple[float, list[tuple[float, Array, Array, int]]]:
    """One steady member at night ``n`` (estimates 0..n): its log evidence (summed over no step / a step
    before each estimate) and its components (posterior weight within the member, mean, cov, step index)."""
    return steady_nights(t, y, r, np.array([n]), efold, cfg, pr, keep)[0]


#: nights x estimates of one block of :func:`steady_nights` (its arrays: about 40 of this many floats)
_BLOCK = 40_000


@dataclass(frozen=True)
class SteadyRows:
    """One steady member at B nights as arrays (what :func:`steady_nights` lists): ``lev`` (B,) its log
    evidence; per night up to K components (slot 0: no step, then the likeliest steps), ``ok`` (B, K) where a
    slot holds one, its ``weight`` within the member, ``mean`` (B, K, 2), ``cov`` (B, K, 2, 2) and ``step``
    (B, K) the index of the first estimate after the step (-1: none)."""

    lev: Array
    ok: NDArray[np.bool_]
    weight: Array
    mean: Array
    cov: Array
    step: NDArray[np.int_]


def steady_nights(t: Array, y: Array, r: Array, nights: NDArray[np.int_] | Sequence[int], efold: float, cfg: TrendConfig, pr: RatePrior,
                  keep: int = 3) -> list[tuple[float, list[tuple[float, Array, Array, int]]]]:
    """:func:`steady_at` at each of ``nights``, the same numbers (:func:`steady_rows` as lists)."""
    sr = steady_rows(t, y, r, nights, efold, cfg, pr, keep)
    return [(float(sr.lev[b]), [(float(sr.weight[b, k]), sr.mean[b, k].copy(), sr.cov[b, k].copy(),
                                 int(sr.step[b, k])) for k in np.flatnonzero(sr.ok[b])])
            for b in range(len(sr.lev))]


def steady_rows(t: Array, y: Array, r: Array, nights: NDArray[np.int_] | Sequence[int], efold: float, cfg: TrendConfig,
                pr: RatePrior, keep: int = 3) -> SteadyRows:
    """One steady member at each of ``nights``: the sufficient statistics of every (night, segment start)
    pair of a block of nights in one array (row b: night ``nights[b]``, column k: estimate k, relative to that
    night; zero beyond it), so a whole history costs a few array operations per block."""
    t, y, r = np.asarray(t, float), np.asarray(y, float), np.asarray(r, float)
    ns_all = np.asarray(nights, int)
    rows = max(1, _BLOCK // max(1, int(ns_all.max(initial=0)) + 1))
    blocks = [_steady_block(t, y, r, ns_all[b0:b0 + rows], efold, cfg, pr, keep)
              for b0 in range(0, len(ns_all), rows)]
    if len(blocks) == 1:
        return blocks[0]
    K = max([b.ok.shape[1] for b in blocks], default=1)

    def cat(name: str, fill: float | int | bool) -> Any:
        parts = []
        for b in blocks:
            a = getattr(b, name)
            pad = np.full((a.shape[0], K - a.shape[1], *a.shape[2:]), fill, dtype=a.dtype)
            parts.append(np.concatenate([a, pad], axis=1))
        return np.concatenate(parts) if parts else np.zeros((0, K))

    return SteadyRows(np.concatenate([b.lev for b in blocks]) if blocks else np.zeros(0), cat("ok", False),
                      cat("weight", 0.0), cat("mean", 0.0), cat("cov", 0.0), cat("step", -1))


def _steady_block(t: Array, y: Array, r: Array, ns: NDArray[np.int_], efold: float, cfg: TrendConfig, pr: RatePrior,
                  keep: int) -> SteadyRows:
    L = int(ns.max()) + 1
    tt, yy, rr = t[:L], y[:L], r[:L]
    ks = np.arange(L)
    mine = ks[None, :] <= ns[:, None]  # (B, L): estimate k is in night b's history
    dt = np.where(mine, tt[None, :] - tt[ns][:, None], 0.0)
    u, up = steady_basis(dt, efold)
    w = np.where(mine, 1.0 / rr ** 2, 0.0)
    P = np.zeros((7, len(ns), L + 1))  # per night, prefix sums of the sufficient statistics
    wu, wy = w * u, w * yy
    logc = np.where(mine, np.log(2 * math.pi * rr * rr), 0.0)
    for row, v in enumerate((w, wu, wu * u, wy, wu * yy, wy * yy, logc)):
        np.cumsum(v, axis=1, out=P[row, :, 1:])
    valid = (-dt <= cfg.max_efolds * efold) & mine  # segment starts an accelerated shape may use
    B = np.arange(len(ns))
    after = P[:, B, ns + 1][:, :, None] - P[:, :, :L]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ev_a, *terms_a = _regression_evidence(after, u, up, cfg, pr)
        ev_b = _regression_evidence(P[:, :, 1:L], u[:, :1], up[:, :1], cfg, pr)[0]
    ev_a = np.where(valid, ev_a, -np.inf)
    # the prior probability of no step (column 0) and of a step just before estimate k (column k), per night
    h = cfg.step_rate_per_day
    span = tt[ns] - tt[0]
    logp = np.full((len(ns), L), -np.inf)
    logp[:, 0] = -h * span
    stepped = (ns >= 1) & (span > 0) & (h > 0)
    if L > 1 and stepped.any():
        with np.errstate(divide="ignore", invalid="ignore"):
            gaps = np.diff(tt)[None, :] / np.where(stepped, span, 1.0)[:, None]
            lp = np.log(-np.expm1(-h * np.where(stepped, span, 1.0)))[:, None] + np.log(gaps)
        lp = lp + np.where(valid[:, :1], ev_b, -np.inf)
        logp[:, 1:] = np.where(mine[:, 1:] & stepped[:, None], lp, -np.inf)
    total = np.where(mine, logp + ev_a, -np.inf)
    top = np.max(total, axis=1)
    some = np.isfinite(top)
    with np.errstate(invalid="ignore"):
        lev = top + np.log(np.exp(total - np.where(some, top, 0.0)[:, None]).sum(axis=1))
        post = np.exp(total - np.where(some, lev, 0.0)[:, None])
    rank = np.argsort(-post[:, 1:], axis=1)[:, :keep] + 1 if L > 1 else np.zeros((len(ns), 0), int)
    # the components of each night: no step (when its posterior is > 0), then the likeliest steps above 1e-4
    cand = np.concatenate([np.zeros((len(ns), 1), int), rank], axis=1)
    at = (B[:, None], cand)  # each night's candidates
    pc = post[at]
    ok = (pc > 0) & some[:, None]
    ok[:, 1:] &= pc[:, 1:] > 1e-4
    tot = np.zeros(len(ns))
    for k in range(cand.shape[1]):  # summed one slot after the other, as the components are listed
        tot = np.where(ok[:, k], tot + pc[:, k], tot)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = np.where(ok, pc / np.where(ok, tot[:, None], 1.0), 0.0)
    mean, cov = _regression_moments(*(a[at] for a in terms_a))
    return SteadyRows(np.where(some, lev, -math.inf), ok, weight, mean, cov, np.where(cand > 0, cand, -1))
