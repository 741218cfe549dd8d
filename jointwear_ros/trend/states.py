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

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from ..contract import DiagnosticLevel
from .alarm import crossing_curves, crossing_quantiles, forecast_basis, tau_grid
from .config import Array, TrendConfig
from .filters import filter_bank, logsumexp, steady_nights
from .members import Component, Member, RatePrior, bank_members

__all__ = ["TrendStates", "trend_states", "unbounded_reason"]

#: components per array operation of :func:`trend_states`' crossing curves (each a row of the tau grid)
_CHUNK = 2048


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
    banks = [filter_bank(t, y, r, cfg, p) for p, _ in sources]
    adaptive = [i for i, m in enumerate(members) if m.kind == "adaptive"]
    tau = tau_grid(float(cfg.max_horizon_days))
    bases = [forecast_basis(m, tau, cfg) for m in members]
    M, N = len(members), len(idx)
    W = np.zeros((M, N))
    out = {k: np.zeros(N) for k in ("wear", "wvar", "rate", "rvar", "pg", "pgs", "step")}
    reach = np.zeros((N, M))
    mixtures: list[list[Component]] = []
    steady = {(si, i): steady_nights(t, y, r, idx, m.efold, cfg, p) for si, (p, _) in enumerate(sources)
              for i, m in enumerate(members) if m.kind == "steady" and logprior[si, i] > -600}
    by_member: list[list[tuple[int, Component]]] = [[] for _ in members]  # (row, component), rows ascending
    for j, n in enumerate(idx):
        lev = np.full((len(sources), M), -np.inf)
        # (source, member) -> [(weight, mean, cov, step)]
        comps_by: list[list[list[tuple[float, Array, Array, int]]]] = [[[] for _ in members] for _ in sources]
        for si, bank in enumerate(banks):
            for i, m in enumerate(members):
                if m.kind == "steady":
                    if (si, i) in steady:
                        lev[si, i], comps_by[si][i] = steady[si, i][j]
                else:
                    f = bank[adaptive.index(i)]
                    lev[si, i] = f.loglik[n]
                    comps_by[si][i] = [(1.0, f.mean[n], f.cov[n], -1)]
        lw = logprior + lev / cfg.evidence_temperature
        ws = np.exp(lw - logsumexp(lw.ravel()))
        w = ws.sum(axis=0)
        W[:, j] = w
        comps = [Component(i, float(ws[si, i] * cw), mu, P, k) for si in range(len(sources)) for i in range(M)
                 if ws[si, i] > 1e-9 for (cw, mu, P, k) in comps_by[si][i]]
        wear = sum(c.weight * c.mean[0] for c in comps)
        rate = sum(c.weight * c.mean[1] for c in comps)
        out["wear"][j], out["rate"][j] = wear, rate
        out["wvar"][j] = sum(c.weight * (c.cov[0, 0] + (c.mean[0] - wear) ** 2) for c in comps)
        out["rvar"][j] = sum(c.weight * (c.cov[1, 1] + (c.mean[1] - rate) ** 2) for c in comps)
        pg = [c.weight * float(ndtr(c.mean[1] / math.sqrt(max(c.cov[1, 1], 1e-18)))) for c in comps]
        out["pg"][j] = sum(pg)
        w_steady = sum(c.weight for c in comps if members[c.member].kind == "steady")
        out["pgs"][j] = (sum(p for p, c in zip(pg, comps) if members[c.member].kind == "steady") / w_steady
                         if w_steady > 0 else math.nan)
        out["step"][j] = sum(c.weight for c in comps if c.step_at >= 0)
        for c in comps:
            by_member[c.member].append((j, c))
        if keep:
            mixtures.append(comps)
    # the mixture's crossing CDF per row: each member's components of every row in one array operation
    F = np.zeros((N, len(tau)))
    for i, mine in enumerate(by_member):
        for c0 in range(0, len(mine), _CHUNK):
            part = mine[c0:c0 + _CHUNK]
            row = np.array([j for j, _ in part])
            cw = np.array([c.weight for _, c in part])
            Fi = crossing_curves(np.array([c.mean for _, c in part]), np.array([c.cov for _, c in part]), *bases[i],
                                 cfg.alarm)
            starts = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])
            Fm = np.add.reduceat(cw[:, None] * Fi, starts, axis=0)
            F[row[starts]] += Fm
            reach[row[starts], i] += Fm[:, -1]
    cw_member = np.zeros((N, M))
    for i, mine in enumerate(by_member):
        np.add.at(cw_member[:, i], [j for j, _ in mine], [c.weight for _, c in mine])
    with np.errstate(invalid="ignore", divide="ignore"):
        reach = np.where(cw_member > 0, reach / np.where(cw_member > 0, cw_member, 1.0), 0.0)
    qs = crossing_quantiles(F, tau) if N else np.zeros((0, 3))
    growth = (out["pg"] >= cfg.growth_probability) & (idx + 1 >= cfg.min_estimates)
    level = np.full(N, DiagnosticLevel.OK)
    level[growth & (qs[:, 0] <= cfg.horizon_days)] = DiagnosticLevel.WARN
    level[out["wear"] >= cfg.alarm] = DiagnosticLevel.ERROR
    return TrendStates(out["wear"], np.sqrt(out["wvar"]), out["rate"], np.sqrt(out["rvar"]), out["pg"], growth, qs,
                       level, W, out["step"], reach, out["pgs"], mixtures)


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
