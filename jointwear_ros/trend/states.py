"""The model-averaged trend after each estimate of a segment: what the levels are made of (pure numpy/scipy).

The bank's members (:mod:`jointwear_ros.trend.members`) are averaged with weights from the evidence of the
joint's own estimates (Bayesian model averaging: a documented prior weight times each member's marginal
likelihood of the segment's estimates, each observed through its own standard deviation; the log evidences
tempered by :attr:`TrendConfig.evidence_temperature`). With the default priors a steady joint puts its
weight on the line and its interval approaches the straight-line limit; an accelerating one moves it to an
accelerated shape or an adaptive member as the data show the acceleration; a jump moves it to the step.
When the rate is not credibly positive (``P(S > 0) < growth_probability``) there is no growth.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from ..contract import DiagnosticLevel
from .alarm import crossing_curves, crossing_quantiles, forecast_basis, tau_grid
from .config import Array, TrendConfig
from .filters import filter_bank, steady_rows
from .members import Component, Member, RatePrior, bank_members

__all__ = ["TrendStates", "trend_states", "unbounded_reason"]

#: components per array operation of :func:`trend_states`' crossing curves (each a row of the tau grid): a chunk
#: in blocks of about ``_BLOCK`` components that each hold whole rows (2048 at once are 11 MB an array, out of the
#: cache: three times slower); a row's sum splits only where a chunk ends
_CHUNK = 2048
_BLOCK = 256


@dataclass(frozen=True)
class TrendStates:
    """The trend after each estimate of a segment (or ``rows``; arrays of that length): what the levels are
    made of. ``weights`` (M, n): each member's posterior weight; ``reach`` (n, M): each member's probability
    of the alarm within ``max_horizon_days``; ``mixtures``: the components at each row (``keep=True``)."""

    wear: Array
    wear_std: Array
    rate: Array
    rate_std: Array
    p_growth: Array
    growth: NDArray[np.bool_]
    quantiles: Array  # (n, 3): lo90, median, hi90 in days
    #: the *forecast's* signal, what the backtest scores (not the condition level, docs/levels.md): WARN = the alarm
    #: expected within the horizon (growth and the 90 % lower bound within it), ERROR = the trend's wear at the alarm
    level: NDArray[np.int_]
    weights: Array  # (M, n)
    step_probability: Array
    reach: Array
    p_growth_steady: Array
    mixtures: list[list[Component]] = field(default_factory=list)


def trend_states(t_days: Array, y: Array, r: Array, cfg: TrendConfig, rows: Array | None = None,
                 prior: RatePrior | None = None, keep: bool = False) -> TrendStates:
    """The model-averaged trend after each estimate of a segment (times in days, ascending), or at ``rows``."""
    pr = prior or RatePrior(std=cfg.slope_prior_std)
    t = np.asarray(t_days, float)
    y = np.asarray(y, float)
    r = np.asarray(r, float)
    n_all = len(t)
    idx = np.arange(n_all) if rows is None else np.asarray(rows, int)
    members = bank_members(cfg)
    sources = pr.sources(cfg)  # (prior, probability): one, or the fleet's and the default (a contaminated prior)
    logprior = np.array([np.log(np.maximum(p.member_weights(cfg) * ps, 1e-300)) for p, ps in sources])
    tau = tau_grid(float(cfg.max_horizon_days))
    bases = [forecast_basis(m, tau, cfg) for m in members]
    M, N = len(members), len(idx)
    # every member's components at every row, as slots: the (source, member) blocks in that order, a steady
    # member's slots its no-step and step components (_Slots), an adaptive member's its filtered state
    lev = np.full((N, len(sources), M), -np.inf)
    blocks: list[_Slots] = []
    for si, (p, _) in enumerate(sources):
        bank = iter(filter_bank(t, y, r, cfg, p))
        for i, m in enumerate(members):
            if m.kind == "steady":
                if logprior[si, i] > -600:
                    sr = steady_rows(t, y, r, idx, m.efold, cfg, p)
                    lev[:, si, i] = sr.lev
                    blocks.append(_Slots(si, i, sr.ok, sr.weight, sr.mean, sr.cov, sr.step))
            else:
                f = next(bank)
                lev[:, si, i] = f.loglik[idx]
                blocks.append(_Slots(si, i, np.ones((N, 1), bool), np.ones((N, 1)), f.mean[idx][:, None],
                                     f.cov[idx][:, None], np.full((N, 1), -1)))
    lw = logprior + lev / cfg.evidence_temperature
    ws = np.exp(lw - _row_logsumexp(lw.reshape(N, -1))[:, None, None])
    W = ws.sum(axis=1).T.copy()
    # the components of each row in order (source, member, slot), those of members with weight > 1e-9
    on = [b.ok & (ws[:, b.source, b.member] > 1e-9)[:, None] for b in blocks]
    cw = [ws[:, b.source, b.member][:, None] * b.weight for b in blocks]
    comp_on = np.concatenate(on, axis=1) if blocks else np.zeros((N, 0), bool)
    comp_w = np.concatenate(cw, axis=1) if blocks else np.zeros((N, 0))
    m0, m1 = (np.concatenate([b.mean[..., d] for b in blocks], axis=1) if blocks else np.zeros((N, 0))
              for d in (0, 1))
    c00, c11 = (np.concatenate([b.cov[..., d, d] for b in blocks], axis=1) if blocks else np.zeros((N, 0))
                for d in (0, 1))
    is_steady = np.concatenate([np.full(b.ok.shape[1], members[b.member].kind == "steady") for b in blocks]
                               ) if blocks else np.zeros(0, bool)
    is_step = np.concatenate([b.step >= 0 for b in blocks], axis=1) if blocks else np.zeros((N, 0), bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        pg_c = comp_w * ndtr(m1 / np.sqrt(np.maximum(c11, 1e-18)))
    # the mixture's moments, each a sum over the row's components one after the other (as they are listed)
    wear = _row_sum(comp_w * m0, comp_on)
    rate = _row_sum(comp_w * m1, comp_on)
    out = {"wear": wear, "rate": rate,
           "wvar": _row_sum(comp_w * (c00 + _pow2(m0 - wear[:, None], comp_on)), comp_on),
           "rvar": _row_sum(comp_w * (c11 + _pow2(m1 - rate[:, None], comp_on)), comp_on),
           "pg": _row_sum(pg_c, comp_on), "step": _row_sum(comp_w, comp_on & is_step)}
    w_steady = _row_sum(comp_w, comp_on & is_steady)
    with np.errstate(divide="ignore", invalid="ignore"):
        out["pgs"] = np.where(w_steady > 0, _row_sum(pg_c, comp_on & is_steady) / w_steady, math.nan)
    mixtures: list[list[Component]] = []
    if keep:
        slot = [(b, k) for b in blocks for k in range(b.ok.shape[1])]
        for j in range(N):
            mixtures.append([Component(b.member, float(comp_w[j, s]), b.mean[j, k], b.cov[j, k], int(b.step[j, k]))
                             for s, (b, k) in enumerate(slot) if comp_on[j, s]])
    # the mixture's crossing CDF per row: each member's components of every row in one array operation
    F = np.zeros((N, len(tau)))
    reach = np.zeros((N, M))
    cw_member = np.zeros((N, M))
    for i in range(M):
        mine = [(b, on[n], cw[n]) for n, b in enumerate(blocks) if b.member == i]
        if not mine:
            continue
        # (row, source, slot) order: rows ascending, within a row the sources' components one after the other
        sel = np.concatenate([o for _, o, _ in mine], axis=1)
        row = np.nonzero(sel)[0]
        wts = np.concatenate([c for _, _, c in mine], axis=1)[sel]
        mus = np.concatenate([b.mean for b, _, _ in mine], axis=1)[sel]
        covs = np.concatenate([b.cov for b, _, _ in mine], axis=1)[sel]
        for c0 in range(0, len(row), _CHUNK):
            rc = row[c0:c0 + _CHUNK]
            starts = np.flatnonzero(np.concatenate([[True], rc[1:] != rc[:-1]]))
            # a chunk in blocks of about _BLOCK components that end where a row does (the arrays of a block
            # stay in the cache; each row's sum is the same)
            mu = mus[c0:c0 + _CHUNK] @ bases[i][0]  # for the chunk at once: the same last bits
            ends = np.append(starts, len(rc))
            cuts = np.unique(np.append(ends[np.searchsorted(ends, np.arange(0, len(rc), _BLOCK))], len(rc)))
            for b0, b1 in pairwise(cuts.tolist()):
                a, b = c0 + b0, c0 + b1
                Fi = crossing_curves(mus[a:b], covs[a:b], *bases[i], cfg.alarm, mu=mu[b0:b1])
                first = starts[(starts >= b0) & (starts < b1)] - b0
                Fm = _segment_sums(wts[a:b, None] * Fi, first)
                F[row[a:b][first]] += Fm
                reach[row[a:b][first], i] += Fm[:, -1]
        np.add.at(cw_member[:, i], row, wts)
    with np.errstate(invalid="ignore", divide="ignore"):
        reach = np.where(cw_member > 0, reach / np.where(cw_member > 0, cw_member, 1.0), 0.0)
    qs = crossing_quantiles(F, tau) if N else np.zeros((0, 3))
    growth = (out["pg"] >= cfg.growth_probability) & (idx + 1 >= cfg.min_estimates)
    level = np.full(N, DiagnosticLevel.OK)
    level[growth & (qs[:, 0] <= cfg.horizon_days)] = DiagnosticLevel.WARN
    level[out["wear"] >= cfg.alarm] = DiagnosticLevel.ERROR
    return TrendStates(out["wear"], np.sqrt(out["wvar"]), out["rate"], np.sqrt(out["rvar"]), out["pg"], growth, qs,
                       level, W, out["step"], reach, out["pgs"], mixtures)


@dataclass(frozen=True)
class _Slots:
    """One (source, member)'s components at every row: ``ok`` (N, K), weight within the member (N, K), mean
    (N, K, d), cov (N, K, d, d), step (N, K)."""

    source: int
    member: int
    ok: NDArray[np.bool_]
    weight: Array
    mean: Array
    cov: Array
    step: NDArray[np.int_]


def _row_sum(x: Array, on: NDArray[np.bool_]) -> Array:
    """Per row, the sum of ``x``'s entries where ``on``, added left to right (the order the components are
    listed in, so each row's sum is the one a loop over its components gives: a running sum; + 0.0 for the
    loop's start from 0, which turns a sum of -0.0 into 0.0)."""
    if x.shape[1] == 0:
        return np.zeros(x.shape[0])
    return np.asarray(np.cumsum(np.where(on, x, 0.0), axis=1)[:, -1] + 0.0)


def _segment_sums(x: Array, starts: NDArray[np.int_]) -> Array:
    """``np.add.reduceat(x, starts, axis=0)`` for ascending ``starts`` (from 0) without its cost on wide rows
    (a segment here is a row's few components), the same numbers: reduceat adds to a segment's first row the
    sum of the others, and sums fewer than 8 one after the other (numpy's pairwise sum); longer segments are
    left to it."""
    n = np.diff(np.append(starts, len(x)))
    if len(n) == 0 or n.max() > 8:
        return np.asarray(np.add.reduceat(x, starts, axis=0))
    acc = x[starts]
    if n.max() == 1:
        return acc
    two = n > 1
    rest = x[starts[two] + 1]
    for o in range(2, int(n.max())):
        more = n[two] > o
        rest[more] += x[starts[two][more] + o]
    acc[two] += rest
    return acc


def _pow2(x: Array, on: NDArray[np.bool_]) -> Array:
    """``x ** 2`` where ``on`` (else 0) as C's ``pow`` gives it, the square of a scalar (numpy squares an array
    as ``x * x``, now and then one unit in the last place away from it): the variances stay the ones a loop
    over the components gives."""
    out = np.zeros(x.shape)
    out[on] = [math.pow(v, 2.0) for v in x[on].tolist()]
    return out


def _row_logsumexp(x: Array) -> Array:
    """:func:`~jointwear_ros.trend.filters.logsumexp` of each row of ``x`` (N, K)."""
    out = np.full(x.shape[0], -math.inf)
    if x.shape[1] == 0:
        return out
    top = np.max(x, axis=1)
    fin = np.isfinite(top)
    out[~fin] = top[~fin]
    s = np.exp(x[fin] - top[fin, None]).sum(axis=1)
    out[fin] = top[fin] + np.array([math.log(float(v)) for v in s])
    return out


def unbounded_reason(st: TrendStates, j: int, members: Sequence[Member], cfg: TrendConfig) -> str | None:
    """Why the 90 % interval of row ``j`` has no upper bound (None when it has one)."""
    if math.isfinite(float(st.quantiles[j, 2])):
        return None
    w = st.weights[:, j]
    steady = np.array([m.kind == "steady" for m in members])
    ws, wa = float(w[steady].sum()), float(w[~steady].sum())
    reach_s = float((w[steady] * st.reach[j, steady]).sum() / ws) if ws > 0 else 0.0
    if wa > 0 and reach_s >= 0.95:
        return (f"acceleration not identified: {100 * wa:.0f} % of the weight is on models whose rate may wander "
                "(random walk), which do not bound the latest time")
    pgs = float(st.p_growth_steady[j])
    if not math.isfinite(pgs) or pgs < 0.95:
        return (f"rate not distinguishable from zero (P(rate > 0) = {pgs:.2f} under the steady models): the data "
                "bound the earliest time, not the latest")
    return f"at the slowest plausible rate the alarm lies beyond the {cfg.max_horizon_days:g}-day horizon"
