"""The models of the trend's bank and the prior they start from (pure numpy).

The trend is a **bank of models** (:func:`bank_members`), averaged with weights from the evidence of the
joint's own estimates (:mod:`jointwear_ros.trend.states`):

*Steady members* (sharp when the data are steady), each a 2-parameter regression with a Gaussian
prior, solved in closed form (:mod:`jointwear_ros.trend.filters`):

- ``line``: ``w(t) = L + S t`` (a local linear trend with ``q = 0``);
- ``accelerated <e> d``: the paper's accelerated wear (Sections 3 and 6: the friction change grows
  with use), ``w(t) = L + S e (exp(t / e) - 1)``, the rate growing e-fold every ``e`` days, for each
  ``e`` of :attr:`TrendConfig.efold_days` (considered over at most :attr:`TrendConfig.max_efolds`
  e-foldings of the segment).

Each steady member also allows **one unrecorded step** (a reducer replaced without a maintenance
event, a jump): a change of level and rate at an estimate ``k``, with a prior rate
:attr:`TrendConfig.step_rate_per_day` of such steps.

*Adaptive members* (robust to acceleration of any shape): local linear trends whose rate follows a
random walk of spectral density ``q`` (wear² / day³; :attr:`TrendConfig.accel_noise`) and a local
quadratic trend (acceleration with a random walk, :attr:`TrendConfig.jerk_noise`), Kalman filters
(:mod:`jointwear_ros.trend.filters`).

**Priors** (documented in docs/history-trend.md): at a segment's start (and after a step) the level is
``N(level_prior_mean, level_prior_std^2)`` = N(50, 30²) (wear lies in 0-100) and the rate
``N(0, slope_prior_std^2)`` = N(0, 0.2²) wear/day, the same for every member so that their evidences
compare; a fleet prior (:class:`RatePrior`, estimated by :func:`jointwear_ros.trend.prior.fleet_prior`)
replaces the rate prior and the member weights by what the joint's siblings show. Prior member weights:
``prior_line`` for the line, ``prior_accelerated`` shared by the accelerated shapes, the rest shared by
the adaptive members.

>>> [m.name for m in bank_members(TrendConfig(efold_days=(90.0,), jerk_noise=()))]
['line', 'accelerated 90 d', 'random-walk rate q=0.0001', 'random-walk rate q=0.001']
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .config import Array, TrendConfig

__all__ = ["Component", "Member", "RatePrior", "bank_members", "default_weights", "steady_basis"]


@dataclass(frozen=True)
class Member:
    """One model of the bank: ``kind`` "steady" (``efold`` inf: the line) or "adaptive" (``q``, ``order``)."""

    name: str
    kind: str
    efold: float = math.inf
    q: float = 0.0
    order: int = 2


def bank_members(cfg: TrendConfig) -> list[Member]:
    """The models of the bank, steady first: line, accelerated shapes, random-walk rates, quadratic."""
    out = [Member("line", "steady")]
    out += [Member(f"accelerated {e:g} d", "steady", efold=e) for e in cfg.efold_days]
    out += [Member(f"random-walk rate q={q:g}", "adaptive", q=q, order=2) for q in cfg.accel_noise]
    out += [Member(f"quadratic jerk={q:g}", "adaptive", q=q, order=3) for q in cfg.jerk_noise]
    return out


def default_weights(cfg: TrendConfig) -> Array:
    """The members' prior weights of ``cfg`` (in :func:`bank_members`' order), summing to 1."""
    n_acc, n_ad = len(cfg.efold_days), len(cfg.accel_noise) + len(cfg.jerk_noise)
    w = [cfg.prior_line] + ([cfg.prior_accelerated / n_acc] * n_acc if n_acc else [])
    rest = max(1.0 - sum(w), 0.0)
    w += [rest / n_ad] * n_ad if n_ad else []
    a = np.asarray(w, float)
    return np.asarray(a / a.sum(), float)


@dataclass(frozen=True)
class RatePrior:
    """The prior a joint's trend starts from: the rate ``N(mean, std^2)`` wear/day at a segment's start and
    the members' prior weights (None: the config's). :func:`fleet_prior` estimates one from siblings."""

    mean: float = 0.0
    std: float = 0.2
    weights: tuple[float, ...] | None = None
    source: str = "default"
    joints: int = 0
    #: prior probability that the joint is *unlike* its siblings: the trend then also weighs every member under
    #: the default prior (a contaminated prior), so that the evidence of a joint that does not wear like its
    #: fleet moves it back to the default prior's answer
    unlike: float = 0.0

    def sources(self, cfg: TrendConfig) -> list[tuple[RatePrior, float]]:
        """The priors a trend weighs with their probabilities: this one, and the default with ``unlike``."""
        if self.unlike <= 0.0 or self.source == "default":
            return [(self, 1.0)]
        return [(self, 1.0 - self.unlike), (RatePrior(std=cfg.slope_prior_std), self.unlike)]

    def member_weights(self, cfg: TrendConfig) -> Array:
        if self.weights is None:
            return default_weights(cfg)
        w = np.asarray(self.weights, float)
        return np.asarray(w / w.sum(), float)

    def as_dict(self) -> dict[str, Any]:
        return {"rate_mean": self.mean, "rate_std": self.std, "source": self.source, "joints": self.joints,
                "member_weights": None if self.weights is None else list(self.weights), "unlike": self.unlike}


@dataclass(frozen=True)
class Component:
    """One Gaussian of the mixture at a night: member index, weight, state mean and covariance (level, rate[, acc])
    at that night, and for a steady member after a step the index of the first estimate after it (else -1)."""

    member: int
    weight: float
    mean: Array
    cov: Array
    step_at: int = -1


def steady_basis(dt: Array, efold: float) -> tuple[Array, Array]:
    """u(dt), u'(dt) of a steady member, ``dt`` days relative to the night (<= 0): the line or
    ``e (exp(dt / e) - 1)``."""
    if math.isinf(efold):
        return dt, np.ones_like(dt)
    x = dt / efold
    return efold * np.expm1(x), np.exp(x)
