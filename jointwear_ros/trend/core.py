"""Wear trend of one joint: current wear and rate, time to the alarm with a 90 % interval, a level.

The trend is a **bank of models**, averaged with weights from the evidence of the joint's own
estimates (Bayesian model averaging: a documented prior weight times each model's marginal
likelihood of the segment's estimates, each observed through its own standard deviation):

*Steady members* (sharp when the data are steady), each a 2-parameter regression with a Gaussian
prior, solved in closed form:

- ``line``: ``w(t) = L + S t`` (a local linear trend with ``q = 0``);
- ``accelerated <e> d``: the paper's accelerated wear (Sections 3 and 6: the friction change grows
  with use), ``w(t) = L + S e (exp(t / e) - 1)``, the rate growing e-fold every ``e`` days, for each
  ``e`` of :attr:`TrendConfig.efold_days` (considered over at most :attr:`TrendConfig.max_efolds`
  e-foldings of the segment).

Each steady member also allows **one unrecorded step** (a reducer replaced without a maintenance
event, a jump): a change of level and rate at an estimate ``k``, with a prior rate
:attr:`TrendConfig.step_rate_per_day` of such steps; the member's evidence sums over "no step" and
every ``k`` (a product-partition model with at most one change), its prediction uses the line after
the step in proportion to that step's posterior.

*Adaptive members* (robust to acceleration of any shape): local linear trends whose rate follows a
random walk of spectral density ``q`` (wear² / day³; :attr:`TrendConfig.accel_noise`) and a local
quadratic trend (acceleration with a random walk, :attr:`TrendConfig.jerk_noise`), 2- and 3-state
Kalman filters with irregular steps and per-estimate variance (hand-written in numpy: a few lines,
and the fleet backtest runs at hundreds of joint-nights per second; statsmodels'
``UnobservedComponents`` assumes equal steps and fits the observation variance)::

    L(t + dt) = L(t) + S(t) dt + eta_L,    S(t + dt) = S(t) + eta_S
    Q(dt) = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]  (+ q_L dt on the level)
    y_k = L(t_k) + e_k,   e_k ~ N(0, wear_std_k^2)

**Priors** (documented in docs/history-trend.md): at a segment's start (and after a step) the level is
``N(level_prior_mean, level_prior_std^2)`` = N(50, 30²) (wear lies in 0-100) and the rate
``N(0, slope_prior_std^2)`` = N(0, 0.2²) wear/day, the same for every member so that their evidences
compare; the fleet prior (:class:`RatePrior`, :func:`fleet_prior`) replaces the rate prior and the
member weights by what the joint's siblings show. Prior member weights: ``prior_line`` for the line,
``prior_accelerated`` shared by the accelerated shapes, the rest shared by the adaptive members.
With these, a steady joint puts its weight on the line and its interval approaches the straight-line
limit; an accelerating one moves it to an accelerated shape or an adaptive member as the data show
the acceleration; a jump moves it to the step.

**Time to alarm.** From each member's state at the last estimate, the wear ``tau`` days ahead is
Gaussian, ``h(tau) m`` with variance ``h P h' (+ process noise for the adaptive members: q tau^3/3,
quadratic q tau^5/20)``, ``h = [1, tau]`` (line, random walk), ``[1, e (exp(tau / e) - 1)]``
(accelerated), ``[1, tau, tau^2/2]`` (quadratic). The probability that the alarm ``a`` has been
crossed by ``tau`` is the running maximum over ``tau' <= tau`` of ``P(wear(tau') >= a)`` (exact for a
monotone curve with uncertain parameters; for the random-walk part it ignores paths that cross and
come back, which wear does not do). These curves are averaged with the members' weights; the 5 %,
50 % and 95 % points are the 90 % interval and the median (a point not reached within
``max_horizon_days`` is infinite: unbounded, and :attr:`TimeToAlarm.unbounded_reason` says why). When
the rate is not credibly positive (``P(S > 0) < growth_probability``) there is no time to alarm:
*no growth detected*.

**Condition level and forecast** (two quantities, :mod:`jointwear_ros.condition`): the *condition
level* (``diagnostic_msgs/DiagnosticStatus`` bytes) is the one rule of the suite applied to the joint's
standing estimate (the newest confirmed one of the segment: an estimate far from it is held
``unconfirmed`` and left out of the trend until the next one confirms it as a step or refutes it as an
outlier; estimates from too few speeds carry no level), exactly what the wear_estimator publishes for
the same sequence; STALE when the segment has no estimate. The *forecast* is the time to alarm: *alarm
expected within* ``horizon_days`` when growth is detected and the 90 % interval's lower bound is within
it. The forecast never changes the condition level. Fewer than ``min_estimates`` estimates in the
current segment give no trend.

**Segments.** A maintenance event (regrease, reducer replaced) starts a new segment: the trend
uses the estimates after the joint's last event. **Revisions.** A wear_estimator may re-estimate a
cycle (same cycle id, later stamp); estimates of the same cycle id within ``revision_window_s`` are
one cycle and the newest is kept.

Pure numpy/scipy: no ROS, no database.

>>> import numpy as np
>>> t = 1.7e9 + 86400.0 * np.arange(60)
>>> w = 10.0 + 0.3 * np.arange(60)
>>> r = analyze_joint(t, w, np.full(60, 0.85))
>>> round(r.rate_per_day, 2), r.level_name, round(r.time_to_alarm.median), r.forecast.text
(0.3, 'OK', 24, 'alarm expected within 30 days')
>>> max(r.time_to_alarm.model_weights, key=r.time_to_alarm.model_weights.get)
'line'
>>> analyze_joint(t, np.full(60, 12.0), np.full(60, 0.85)).time_to_alarm is None
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from ..condition import INSUFFICIENT, Forecast, forecast_of, standing
from ..contract import DiagnosticLevel, level_name
from ..errors import InputDataError

__all__ = [
    "DAY",
    "Component",
    "FilterOutput",
    "Member",
    "RatePrior",
    "SiblingFit",
    "TimeToAlarm",
    "TrendConfig",
    "TrendResult",
    "TrendStates",
    "analyze_joint",
    "bank_members",
    "collapse_revisions",
    "crossing_cdf",
    "crossing_quantiles",
    "current_segment",
    "filter_bank",
    "fleet_prior",
    "forecast_band",
    "kalman_llt",
    "last_segment",
    "pool_prior",
    "rts_smooth",
    "sibling_fit",
    "tau_grid",
    "trend_states",
    "type2_weights",
    "unbounded_reason",
]

DAY = 86400.0

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TrendConfig:
    """Settings of the trend model and of the levels.

    Attributes
    ----------
    alarm : wear at which the alarm is raised (35, the paper's).
    horizon_days : the forecast says "alarm expected within" when the 90 % interval's lower bound of the time
        to alarm is within it (the forecast; it does not change the condition level).
    warn : wear of the warning level (the condition level's WARN band starts there).
    accel_noise : ``q`` of the adaptive local-linear members, spectral density of the rate's random walk,
        wear² / day³ (how fast wear may accelerate).
    jerk_noise : jerk density of the local-quadratic member(s).
    efold_days : e-folding times of the accelerated-wear members, days.
    prior_line, prior_accelerated : prior weight of the line and of all accelerated shapes together; the
        rest (``1 - prior_line - prior_accelerated``) is shared by the adaptive members.
    step_rate_per_day : prior rate of an unrecorded step (reducer replaced, jump), per day.
    level_prior_mean, level_prior_std : prior of the wear at a segment's start (and after a step).
    slope_prior_std : prior standard deviation of the rate at a segment's start, wear / day (mean 0).
    accel_prior_std : prior std of the quadratic member's acceleration, wear / day².
    max_efolds : an accelerated shape is considered over at most this many e-folding times of a segment.
    level_noise : ``q_L``, random walk of the adaptive members' level, wear² / day.
    min_estimates : estimates a segment needs before it has a trend.
    growth_probability : ``P(rate > 0)`` needed to call it growth.
    max_horizon_days : times to alarm beyond it are reported as infinite.
    revision_window_s : estimates with the same cycle id within this many seconds are one cycle (revisions).
    """

    alarm: float = 35.0
    horizon_days: float = 30.0
    warn: float = 30.0
    accel_noise: tuple[float, ...] = (1e-4, 1e-3)
    jerk_noise: tuple[float, ...] = (1e-8,)
    efold_days: tuple[float, ...] = (160.0, 120.0, 90.0, 60.0, 45.0)
    prior_line: float = 0.6
    prior_accelerated: float = 0.3
    step_rate_per_day: float = 1.0 / 730.0
    level_prior_mean: float = 50.0
    level_prior_std: float = 30.0
    accel_prior_std: float = 0.003
    level_noise: float = 0.0
    slope_prior_std: float = 0.2
    max_efolds: float = 10.0
    evidence_temperature: float = 1.25
    min_estimates: int = 5
    growth_probability: float = 0.95
    max_horizon_days: float = 3650.0
    revision_window_s: float = 3600.0

    def __post_init__(self) -> None:
        for name, allow_empty in (("accel_noise", True), ("jerk_noise", True), ("efold_days", True)):
            q = getattr(self, name)
            qs = (q,) if isinstance(q, (int, float)) else tuple(q)
            if (not qs and not allow_empty) or not all(math.isfinite(float(x)) and float(x) >= 0 for x in qs):
                raise InputDataError(f"trend setting {name} = {q!r} must be finite numbers >= 0")
            object.__setattr__(self, name, tuple(float(x) for x in qs))
        if any(e <= 0 for e in self.efold_days):
            raise InputDataError(f"trend setting efold_days = {self.efold_days!r} must be > 0 days")
        for name in ("alarm", "warn", "horizon_days", "level_noise", "slope_prior_std", "accel_prior_std",
                     "max_horizon_days", "revision_window_s", "prior_line", "prior_accelerated",
                     "step_rate_per_day", "level_prior_std", "max_efolds", "evidence_temperature"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise InputDataError(f"trend setting {name} = {v!r} must be a finite number >= 0")
        if not math.isfinite(float(self.level_prior_mean)):
            raise InputDataError(f"trend setting level_prior_mean = {self.level_prior_mean!r} must be finite")
        if min(self.slope_prior_std, self.max_horizon_days, self.level_prior_std, self.evidence_temperature) <= 0:
            raise InputDataError("trend settings slope_prior_std, level_prior_std, evidence_temperature and "
                                 "max_horizon_days must be > 0")
        n_adapt = len(self.accel_noise) + len(self.jerk_noise)
        rest = 1.0 - self.prior_line - (self.prior_accelerated if self.efold_days else 0.0)
        if rest < -1e-12 or (n_adapt == 0 and rest > 1e-12) or (self.prior_line <= 0 and n_adapt == 0
                                                                  and not self.efold_days):
            raise InputDataError(f"trend prior weights: line {self.prior_line:g} + accelerated "
                                 f"{self.prior_accelerated:g} must be <= 1 (the rest goes to the {n_adapt} "
                                 "adaptive member(s); with none they must sum to 1)")
        if not 0.5 <= self.growth_probability < 1:
            raise InputDataError(f"growth_probability = {self.growth_probability!r} must be in [0.5, 1)")
        if int(self.min_estimates) < 2:
            raise InputDataError(f"min_estimates = {self.min_estimates!r} must be at least 2")

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> TrendConfig:
        names = set(cls.__dataclass_fields__)
        return cls(**{k: v for k, v in values.items() if k in names})


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


def _default_weights(cfg: TrendConfig) -> Array:
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
            return _default_weights(cfg)
        w = np.asarray(self.weights, float)
        return np.asarray(w / w.sum(), float)

    def as_dict(self) -> dict[str, Any]:
        return {"rate_mean": self.mean, "rate_std": self.std, "source": self.source, "joints": self.joints,
                "member_weights": None if self.weights is None else list(self.weights), "unlike": self.unlike}


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


@dataclass(frozen=True)
class Component:
    """One Gaussian of the mixture at a night: member index, weight, state mean and covariance (level, rate[, acc])
    at that night, and for a steady member after a step the index of the first estimate after it (else -1)."""

    member: int
    weight: float
    mean: Array
    cov: Array
    step_at: int = -1


@dataclass
class TrendResult:
    """The trend of one joint (its current segment)."""

    robot: str
    joint: str
    estimates: int
    estimates_total: int
    wear: float
    wear_std: float
    rate_per_day: float
    rate_std: float
    time_to_alarm: TimeToAlarm | None
    level: int
    message: str
    growth_detected: bool
    last_time: float
    segment_start: float
    segments: int
    filtered: FilterOutput | None = None
    smoothed: FilterOutput | None = None
    times: Array = field(default_factory=lambda: np.zeros(0))
    wears: Array = field(default_factory=lambda: np.zeros(0))
    wear_stds: Array = field(default_factory=lambda: np.zeros(0))
    model_weights: dict[str, float] = field(default_factory=dict)
    step_probability: float = 0.0
    step_time: float = math.nan
    components: list[Component] = field(default_factory=list)
    members: list[Member] = field(default_factory=list)
    prior: RatePrior | None = None
    #: the forecast (time to alarm, alarm expected within the horizon); its own quantity, not the level
    forecast: Forecast | None = None
    #: the estimate the condition level stands on, its evidence, and the newest estimate's confirmation
    level_wear: float = math.nan
    level_wear_std: float = math.nan
    evidence: str = ""
    confirmation: str = ""
    #: estimates of the segment left out of the trend: held (unconfirmed) or refuted (outlier): times, wear, std
    held: tuple[tuple[float, float, float, str], ...] = ()

    @property
    def level_name(self) -> str:
        return level_name(self.level)

    @property
    def alarm_expected(self) -> bool:
        return bool(self.forecast is not None and self.forecast.expected_within_horizon)

    def as_dict(self) -> dict[str, Any]:
        """The ``trend --json`` contract (plus a few extra keys)."""
        return {
            "robot": self.robot, "joint": self.joint, "estimates": self.estimates,
            "wear": self.wear, "wear_std": self.wear_std, "rate_per_day": self.rate_per_day,
            "time_to_alarm_days": None if self.time_to_alarm is None else self.time_to_alarm.as_dict(),
            "level": self.level_name,
            "rate_std_per_day": self.rate_std, "growth_detected": self.growth_detected,
            "estimates_total": self.estimates_total, "segments": self.segments,
            "last_time": self.last_time, "segment_start": self.segment_start, "message": self.message,
            "step_probability": self.step_probability,
            "condition": {"level": self.level_name, "wear": _num(self.level_wear),
                          "wear_std": _num(self.level_wear_std), "evidence": self.evidence or None,
                          "newest_estimate": self.confirmation or None,
                          "held": [{"time": h[0], "wear": h[1], "wear_std": h[2], "status": h[3]} for h in self.held]},
            "forecast": None if self.forecast is None else self.forecast.as_dict(),
            "alarm_expected": self.alarm_expected,
            "fleet_prior": None if self.prior is None or self.prior.source == "default" else self.prior.as_dict(),
        }


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


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
    y = np.asarray(y, float)
    var = np.asarray(r, float) ** 2
    n = len(t)
    mean = np.zeros((n, order))
    cov = np.zeros((n, order, order))
    ll = np.zeros(n)
    m = np.zeros(order)
    m[0], m[1] = cfg.level_prior_mean, pr.mean
    P = np.diag([cfg.level_prior_std ** 2, pr.std ** 2, cfg.accel_prior_std ** 2][:order])
    total = 0.0
    for k in range(n):
        if k > 0:
            F, Q = _transition(max(t[k] - t[k - 1], 0.0), order, q, cfg.level_noise)
            m = F @ m
            P = F @ P @ F.T + Q
        s_ = P[0, 0] + var[k]
        v = y[k] - m[0]
        total += -0.5 * (math.log(2 * math.pi * s_) + v * v / s_)
        K = P[:, 0] / s_
        m = m + K * v
        P = P - np.outer(K, P[0, :])
        P = 0.5 * (P + P.T)
        mean[k], cov[k], ll[k] = m, P, total
    return FilterOutput(t, mean, cov, ll, q, order)


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

_LOG2PI = math.log(2 * math.pi)


def logsumexp(x: Array) -> float:
    """log(sum(exp(x))) of a 1-D array (-inf when empty or all -inf); scipy's is 10x slower on short arrays."""
    m = float(np.max(x)) if len(x) else -math.inf
    if not math.isfinite(m):
        return m
    return m + math.log(float(np.exp(x - m).sum()))


def _basis(dt: Array, efold: float) -> tuple[Array, Array]:
    """u(dt), u'(dt) of a steady member, ``dt`` days relative to the night (<= 0): the line or
    ``e (exp(dt / e) - 1)``."""
    if math.isinf(efold):
        return dt, np.ones_like(dt)
    x = dt / efold
    return efold * np.expm1(x), np.exp(x)


def _regression_evidence(S: Array, ua: Array, upa: Array, cfg: TrendConfig, pr: RatePrior
                         ) -> tuple[Array, Array, Array]:
    """Log evidence, posterior mean (., 2) and covariance (., 2, 2) of ``w = c0 + c1 u(t)`` on segments with
    sufficient statistics ``S`` (7, .) = sums of w, w u, w u², w y, w u y, w y², log(2 pi r²), w = 1/r², the
    prior ``N`` on (level, rate) at each segment's first estimate, where u = ``ua`` and u' = ``upa``.
    ``(c0, c1)`` are the level and rate at the night (u = 0, u' = 1 there)."""
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
    mean = np.empty((*c0.shape, 2))
    mean[..., 0], mean[..., 1] = c0, c1
    cov = np.empty((*c0.shape, 2, 2))
    cov[..., 0, 0], cov[..., 0, 1], cov[..., 1, 0], cov[..., 1, 1] = a22 / det, -a12 / det, -a12 / det, a11 / det
    return ev, mean, cov


def _steady_at(t: Array, y: Array, r: Array, n: int, efold: float, cfg: TrendConfig, pr: RatePrior,
               keep: int = 3) -> tuple[float, list[tuple[float, Array, Array, int]]]:
    """One steady member at night ``n`` (estimates 0..n): its log evidence (summed over no step / a step
    before each estimate) and its components (posterior weight within the member, mean, cov, step index)."""
    tt, yy, rr = t[: n + 1], y[: n + 1], r[: n + 1]
    dt = tt - tt[-1]
    u, up = _basis(dt, efold)
    w = 1.0 / rr ** 2
    P = np.zeros((7, n + 2))  # prefix sums of the sufficient statistics
    wu, wy = w * u, w * yy
    for row, v in enumerate((w, wu, wu * u, wy, wu * yy, wy * yy, np.log(2 * math.pi * rr * rr))):
        np.cumsum(v, out=P[row, 1:])
    valid = -dt <= cfg.max_efolds * efold  # segment starts an accelerated shape may use
    ks = np.arange(n + 1)
    after = P[:, [n + 1]] - P[:, ks]
    ev_a, mean_a, cov_a = _regression_evidence(after, u[ks], up[ks], cfg, pr)
    ev_a = np.where(valid[ks], ev_a, -np.inf)
    span = float(tt[-1] - tt[0])
    h = cfg.step_rate_per_day
    logp = np.full(n + 1, -np.inf)
    logp[0] = -h * span
    if n >= 1 and span > 0 and h > 0:
        ev_b, _, _ = _regression_evidence(P[:, ks[1:]], np.full(n, u[0]), np.full(n, up[0]), cfg, pr)
        ev_b = np.where(valid[0], ev_b, -np.inf)
        gaps = np.diff(tt) / span
        with np.errstate(divide="ignore"):
            logp[1:] = math.log(-math.expm1(-h * span)) + np.log(gaps) + ev_b
    total = logp + ev_a
    if not np.isfinite(total).any():
        return -math.inf, []
    lev = float(logsumexp(total))
    post = np.exp(total - lev)
    order = [0] + [int(k) for k in np.argsort(-post[1:])[:keep] + 1 if post[k] > 1e-4] if n >= 1 else [0]
    order = [k for k in order if post[k] > 0]
    tot = float(sum(post[k] for k in order))
    return lev, [(float(post[k] / tot), mean_a[k], cov_a[k], k if k > 0 else -1) for k in order]


# ---------------------------------------------------------------------------- time to alarm

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
        u, _ = _basis(tau, m.efold)
        return np.stack([np.ones_like(tau), u]), np.zeros_like(tau)
    H = np.stack([np.ones_like(tau), tau, tau * tau / 2][: m.order])
    noise = m.q * tau ** 3 / 3 if m.order == 2 else m.q * tau ** 5 / 20
    return H, noise + cfg.level_noise * tau


def _crossing(mean: Array, cov: Array, H: Array, extra: Array, alarm: float) -> Array:
    m = np.atleast_2d(mean)
    d = m.shape[1]
    P = cov.reshape(-1, d, d)
    mu = m @ H
    v = np.einsum("ig,nij,jg->ng", H, P, H) + extra[None, :]
    z = (mu - alarm) / np.sqrt(np.maximum(v, 1e-12))
    return np.asarray(np.maximum.accumulate(ndtr(z), axis=1))


def crossing_cdf(mean: Array, cov: Array, q: float, cfg: TrendConfig, tau: Array) -> Array:
    """P(alarm crossed by tau) for adaptive states (N, d), (N, d, d) -> (N, len(tau)), running max over tau
    (``q = 0``, d = 2: a straight line with uncertain level and rate)."""
    d = np.atleast_2d(mean).shape[1]
    H, extra = forecast_basis(Member("", "adaptive", q=q, order=d), tau, cfg)
    return _crossing(mean, cov, H, extra, cfg.alarm)


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
    qs = np.zeros((N, 3))
    reach = np.zeros((N, M))
    mixtures: list[list[Component]] = []
    for j, n in enumerate(idx):
        lev = np.full((len(sources), M), -np.inf)
        comps_by = [[[] for _ in members] for _ in sources]  # (source, member) -> [(weight, mean, cov, step)]
        for si, ((p, _), bank) in enumerate(zip(sources, banks)):
            for i, m in enumerate(members):
                if m.kind == "steady":
                    if logprior[si, i] > -600:
                        lev[si, i], comps_by[si][i] = _steady_at(t, y, r, int(n), m.efold, cfg, p)
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
        F = np.zeros(len(tau))
        wear = sum(c.weight * c.mean[0] for c in comps)
        rate = sum(c.weight * c.mean[1] for c in comps)
        out["wear"][j], out["rate"][j] = wear, rate
        out["wvar"][j] = sum(c.weight * (c.cov[0, 0] + (c.mean[0] - wear) ** 2) for c in comps)
        out["rvar"][j] = sum(c.weight * (c.cov[1, 1] + (c.mean[1] - rate) ** 2) for c in comps)
        pg = [c.weight * float(ndtr(c.mean[1] / math.sqrt(max(c.cov[1, 1], 1e-18)))) for c in comps]
        out["pg"][j] = sum(pg)
        ws = sum(c.weight for c in comps if members[c.member].kind == "steady")
        out["pgs"][j] = (sum(p for p, c in zip(pg, comps) if members[c.member].kind == "steady") / ws
                         if ws > 0 else math.nan)
        out["step"][j] = sum(c.weight for c in comps if c.step_at >= 0)
        for i in range(M):
            mine = [c for c in comps if c.member == i]
            if not mine:
                continue
            Fi = _crossing(np.array([c.mean for c in mine]), np.array([c.cov for c in mine]), *bases[i], cfg.alarm)
            cw = np.array([c.weight for c in mine])
            Fm = cw @ Fi
            F += Fm
            reach[j, i] = Fm[-1] / cw.sum()
        qs[j] = crossing_quantiles(F[None, :], tau)[0]
        if keep:
            mixtures.append(comps)
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


# ---------------------------------------------------------------------------- segments and revisions


def collapse_revisions(times: Array, cycle_ids: Array, window_s: float) -> Array:
    """Indices to keep (time order): of estimates with one cycle id within ``window_s``, the newest.

    >>> collapse_revisions(np.array([0.0, 5.0, 100.0, 90000.0]), np.array([1, 1, 2, 1]), 3600.0).tolist()
    [1, 2, 3]
    """
    t = np.asarray(times, float)
    c = np.asarray(cycle_ids)
    order = np.argsort(t, kind="stable")
    keep: list[int] = []
    last_of_cycle: dict[Any, int] = {}  # cycle id -> position in keep
    for i in order:
        key = c[i].item() if hasattr(c[i], "item") else c[i]
        pos = last_of_cycle.get(key)
        if pos is not None and t[i] - t[keep[pos]] <= window_s and key != 0:
            keep[pos] = int(i)  # a revision replaces the earlier result of its cycle
            continue
        last_of_cycle[key] = len(keep)
        keep.append(int(i))
    return np.array(sorted(keep, key=lambda j: t[j]), dtype=int)


def last_segment(times: Array, maintenance_times: Sequence[float]) -> tuple[int, float, int]:
    """(first index of the current segment, its start time, number of segments) for times ascending.

    The current segment starts at the last maintenance event; an event after the last estimate gives
    an empty current segment (the old trend no longer applies).

    >>> last_segment(np.arange(10.0), [4.5]), last_segment(np.arange(10.0), [20.0])
    ((5, 4.5, 2), (10, 20.0, 2))
    """
    t = np.asarray(times, float)
    ev = sorted(float(x) for x in maintenance_times)
    if not ev:
        return 0, float(t[0]) if len(t) else math.nan, 1
    segs = 1 + len(ev)
    start = ev[-1]
    return int(np.searchsorted(t, start, side="left")), start, segs


# ---------------------------------------------------------------------------- one joint


def current_segment(times: Any, wear: Any, wear_std: Any, cycle_ids: Any, maintenance_times: Sequence[float],
           cfg: TrendConfig, where: str) -> tuple[Array, Array, Array, int, float, int]:
    """Checked, revision-collapsed estimates of the current segment: (t, w, s, total, segment start, segments)."""
    t = np.asarray(times, float)
    w = np.asarray(wear, float)
    s = np.asarray(wear_std, float)
    if not (t.shape == w.shape == s.shape) or t.ndim != 1:
        raise InputDataError(f"{where}: times, wear and wear_std must be 1-D of one length "
                             f"(got {t.shape}, {w.shape}, {s.shape})")
    bad = ~(np.isfinite(t) & np.isfinite(w) & np.isfinite(s) & (s > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputDataError(f"{where}: estimate {i} is not usable (time {t[i]!r}, wear {w[i]!r}, "
                             f"std {s[i]!r}): need finite values and std > 0")
    total = len(t)
    cid = np.zeros(total, int) if cycle_ids is None else np.asarray(cycle_ids)
    keep = collapse_revisions(t, cid, cfg.revision_window_s) if total else np.zeros(0, int)
    t, w, s = t[keep], w[keep], s[keep]
    first, seg_start, segs = last_segment(t, maintenance_times)
    return t[first:], w[first:], s[first:], total, seg_start, segs


def analyze_joint(
    times: Array | Sequence[float],
    wear: Array | Sequence[float],
    wear_std: Array | Sequence[float],
    *,
    cycle_ids: Array | Sequence[int] | None = None,
    maintenance_times: Sequence[float] = (),
    cfg: TrendConfig | None = None,
    robot: str = "",
    joint: str = "",
    smooth: bool = False,
    prior: RatePrior | None = None,
    evidence: Sequence[str] | None = None,
) -> TrendResult:
    """The trend of one joint from its estimates (times in seconds since the epoch); ``prior``: a fleet prior;
    ``evidence``: each estimate's (``complete``, ``partial``, ``insufficient``; default complete)."""
    cfg = cfg or TrendConfig()
    t, w, s, total, seg_start, segs = current_segment(times, wear, wear_std, cycle_ids, maintenance_times, cfg,
                                             f"{robot}/{joint}")
    ev = _segment_evidence(times, cycle_ids, maintenance_times, evidence, cfg)
    n_all = len(t)
    if n_all == 0:
        return TrendResult(robot, joint, 0, total, math.nan, math.nan, math.nan, math.nan, None,
                           DiagnosticLevel.STALE, "no estimates since the last maintenance event", False, math.nan,
                           seg_start, segs, prior=prior, forecast=forecast_of(None, None, None, False, False,
                                                                              cfg.horizon_days))
    days = (t - t[0]) / DAY
    cond = standing(w.tolist(), s.tolist(), days.tolist(), ev, cfg.warn, cfg.alarm)
    out = {i: st_i for i, st_i in enumerate(cond.statuses) if st_i in ("unconfirmed", "outlier", INSUFFICIENT)}
    held = tuple((float(t[i]), float(w[i]), float(s[i]), out[i]) for i in sorted(out))
    fit = np.array([i for i in range(n_all) if i not in out], dtype=int)
    last_time = float(t[-1])
    t, w, s = t[fit], w[fit], s[fit]
    n = len(t)
    level = int(DiagnosticLevel.STALE if cond.level is None else cond.level)
    lv_ev = "" if cond.index is None else ev[cond.index]
    if n == 0:
        return TrendResult(robot, joint, 0, total, math.nan, math.nan, math.nan, math.nan, None, level,
                           cond.reason, False, last_time, seg_start, segs, prior=prior,
                           forecast=forecast_of(None, None, None, False, False, cfg.horizon_days),
                           level_wear=cond.wear, level_wear_std=cond.wear_std, evidence=lv_ev,
                           confirmation=cond.newest_status, held=held)
    members = bank_members(cfg)
    st = trend_states((t - t[0]) / DAY, w, s, cfg, rows=np.array([n - 1]), prior=prior, keep=True)
    qs = st.quantiles
    growth = bool(st.growth[0])
    wear_now, wear_sd = float(st.wear[0]), float(st.wear_std[0])
    rate, rate_sd = float(st.rate[0]), float(st.rate_std[0])
    weights = {m.name: round(float(x), 4) for m, x in zip(members, st.weights[:, 0])}
    comps = st.mixtures[0]
    step_p = float(st.step_probability[0])
    step_time = math.nan
    if step_p >= 0.5:
        by_k: dict[int, float] = {}
        for c in comps:
            if c.step_at >= 0:
                by_k[c.step_at] = by_k.get(c.step_at, 0.0) + c.weight
        step_time = float(t[max(by_k, key=lambda k: by_k[k])])
    adaptive = [i for i, m in enumerate(members) if m.kind == "adaptive"]
    f = None
    if adaptive:
        best = max(adaptive, key=lambda i: st.weights[i, 0])
        m = members[best]
        f = kalman_llt((t - t[0]) / DAY, w, s, cfg, m.q, m.order, prior)
    tta: TimeToAlarm | None
    if wear_now >= cfg.alarm:
        tta = TimeToAlarm(0.0, 0.0, 0.0, weights)
        fmsg = f"the trend's wear {wear_now:.1f} ± {wear_sd:.1f} is at or above the alarm {cfg.alarm:g}"
    elif n < cfg.min_estimates:
        tta = None
        fmsg = f"{n} estimate(s) in this segment: a trend needs {cfg.min_estimates}"
    elif not growth:
        tta = None
        fmsg = f"no growth detected (rate {rate:+.3f} ± {rate_sd:.3f} /day); trend wear {wear_now:.1f} ± {wear_sd:.1f}"
    else:
        reason = unbounded_reason(st, 0, members, cfg)
        tta = TimeToAlarm(float(qs[0, 1]), float(qs[0, 0]), float(qs[0, 2]), weights, reason)
        fmsg = (f"alarm {cfg.alarm:g} in {_days(tta.median)} (90 %: {_days(tta.lo90)} to {_days(tta.hi90)}); "
                f"trend wear {wear_now:.1f} ± {wear_sd:.1f}, rate {rate:+.3f} /day")
        if reason:
            fmsg += f"; no upper bound: {reason}"
    fc = forecast_of(None if tta is None else tta.median, None if tta is None else tta.lo90,
                     None if tta is None else tta.hi90, growth, n >= cfg.min_estimates, cfg.horizon_days)
    if fc.expected_within_horizon and fc.state == "within_horizon":
        fmsg = f"alarm expected within {cfg.horizon_days:g} days: " + fmsg
    msg = f"{cond.reason}; forecast: {fmsg}"
    if step_p >= 0.5:
        from datetime import UTC, datetime

        msg += (f"; a step in the estimates at {datetime.fromtimestamp(step_time, UTC):%Y-%m-%d} without a "
                f"maintenance event (P = {step_p:.2f}): the trend follows the estimates after it")
    return TrendResult(
        robot=robot, joint=joint, estimates=n, estimates_total=total, wear=wear_now, wear_std=wear_sd,
        rate_per_day=rate, rate_std=rate_sd, time_to_alarm=tta, level=level, message=msg,
        growth_detected=growth, last_time=last_time, segment_start=float(seg_start), segments=segs,
        filtered=f, smoothed=rts_smooth(f, cfg) if (smooth and f is not None) else None, times=t, wears=w,
        wear_stds=s, model_weights=weights, step_probability=step_p, step_time=step_time, components=comps,
        members=members, prior=prior, forecast=fc, level_wear=cond.wear, level_wear_std=cond.wear_std,
        evidence=lv_ev, confirmation=cond.newest_status, held=held,
    )


def _segment_evidence(times: Any, cycle_ids: Any, maintenance_times: Sequence[float],
                      evidence: Sequence[str] | None, cfg: TrendConfig) -> list[str]:
    """The evidence of the estimates :func:`current_segment` keeps, in its order."""
    t = np.asarray(times, float)
    if evidence is None:
        ev = np.array(["complete"] * len(t), dtype=object)
    else:
        ev = np.array([str(x) or "complete" for x in evidence], dtype=object)
        if len(ev) != len(t):
            raise InputDataError(f"evidence has {len(ev)} entries for {len(t)} estimates")
    if not len(t):
        return []
    cid = np.zeros(len(t), int) if cycle_ids is None else np.asarray(cycle_ids)
    keep = collapse_revisions(t, cid, cfg.revision_window_s)
    first, _, _ = last_segment(t[keep], maintenance_times)
    return [str(x) for x in ev[keep][first:]]


def _days(x: float) -> str:
    return "unbounded" if not math.isfinite(x) else f"{x:.0f} d"


# ---------------------------------------------------------------------------- the fleet as a prior


@dataclass(frozen=True)
class SiblingFit:
    """What one sibling joint contributes to a fleet prior: its current rate, the rate's posterior variance and
    its members' posterior weights (under the default prior)."""

    rate: float
    rate_var: float
    weights: Array


def sibling_fit(t_days: Array, y: Array, r: Array, cfg: TrendConfig | None = None) -> SiblingFit | None:
    """Fit one sibling's current segment (times in days) with the default prior; None below ``min_estimates``."""
    cfg = cfg or TrendConfig()
    t = np.asarray(t_days, float)
    if len(t) < cfg.min_estimates:
        return None
    st = trend_states(t - t[0], y, r, cfg, rows=np.array([len(t) - 1]))
    return SiblingFit(float(st.rate[0]), float(st.rate_std[0]) ** 2, st.weights[:, 0].copy())


def type2_weights(posterior: Array, prior: Array, *, iterations: int = 1000, tol: float = 1e-10) -> Array:
    """Member weights that maximize the marginal likelihood of a set of histories (type-II maximum likelihood,
    empirical Bayes): ``pi = argmax sum_j log sum_m pi_m L_jm``, by EM from each history's posterior weights
    ``posterior`` (J, M) under ``prior`` (M,) (so ``L_jm`` is proportional to ``posterior_jm / prior_m``; the
    tempered evidence when the weights came from :func:`trend_states`).

    >>> post = np.array([[0.9, 0.1], [0.9, 0.1], [0.2, 0.8]])
    >>> np.round(type2_weights(post, np.array([0.5, 0.5])), 2).tolist()
    [0.85, 0.15]
    """
    pr = np.asarray(prior, float)
    lik = np.asarray(posterior, float) / np.where(pr > 0, pr, 1.0)
    lik = lik / lik.max(axis=1, keepdims=True)
    pi = np.full(lik.shape[1], 1.0 / lik.shape[1])
    for _ in range(iterations):
        r = lik * pi
        r /= r.sum(axis=1, keepdims=True)
        new = r.mean(axis=0)
        if float(np.abs(new - pi).max()) < tol:
            return np.asarray(new, float)
        pi = new
    return np.asarray(pi, float)


def pool_prior(fits: Sequence[SiblingFit | None], cfg: TrendConfig | None = None, *, min_joints: int = 5,
               source: str = "fleet", weights: str = "mean", floor: float = 0.2,
               unlike: float = 0.0) -> RatePrior | None:
    """Empirical-Bayes prior from sibling fits: the rates' distribution and the members' weights.

    The fleet's rate distribution ``N(mu, s^2)`` by the method of moments (the spread of the siblings' rates
    less their mean posterior variance, DerSimonian-Laird), ``s`` clipped to [0.01, ``slope_prior_std``]. The
    member weights (``weights``):

    - ``"mean"`` (what ``--fleet-prior`` uses): the siblings' mean posterior weights mixed 4:1 with the default
      prior weights, so that no member is ruled out by the fleet;
    - ``"type2"``: the weights that maximize the siblings' marginal likelihood (:func:`type2_weights`), each at
      least ``floor`` times its default prior weight. Sharper where the siblings agree, and for that reason
      not the default: an accelerating joint among linear siblings loses coverage (``bench_trend_calibration.py
      --trial``: 62 % with floor 0.2 against 81 % with ``"mean"`` and 88 % with the default prior).

    ``unlike``: the prior probability that a joint is unlike its siblings (:attr:`RatePrior.unlike`, a
    contaminated prior: every member is also weighed under the default prior). 0 (``--fleet-prior``'s) trusts the
    fleet; 0.4 gives an accelerating joint among linear siblings its coverage back (18 of 20 against 5 of 20) but
    widens a young joint's interval (8-20 estimates: 2.2x the true time against 0.78x). None with fewer than
    ``min_joints`` (>= 2) siblings.
    """
    cfg = cfg or TrendConfig()
    ok = [f for f in fits if f is not None]
    if len(ok) < max(int(min_joints), 2):
        return None
    if weights not in ("mean", "type2") or not 0.0 < float(floor) <= 1.0 or not 0.0 <= float(unlike) < 1.0:
        raise InputDataError(f"pool_prior: weights {weights!r} must be 'mean' or 'type2', floor {floor!r} in (0, 1] "
                             f"and unlike {unlike!r} in [0, 1)")
    ra, rv = np.array([f.rate for f in ok]), np.array([f.rate_var for f in ok])
    mu = float(ra.mean())
    tau2 = float(ra.var(ddof=1) - rv.mean())
    sd = float(np.clip(math.sqrt(max(tau2, 0.0)), 0.01, cfg.slope_prior_std))
    d = _default_weights(cfg)
    if weights == "mean":
        w = 0.8 * np.mean([f.weights for f in ok], axis=0) + 0.2 * d
    else:
        w = np.maximum(type2_weights(np.array([f.weights for f in ok]), d), float(floor) * d)
    return RatePrior(mean=mu, std=sd, weights=tuple(float(x) for x in w / w.sum()), source=source,
                     joints=len(ok), unlike=float(unlike))


def fleet_prior(segments: Sequence[tuple[Array, Array, Array]], cfg: TrendConfig | None = None, *,
                min_joints: int = 5, source: str = "fleet", **pooling: Any) -> RatePrior | None:
    """The prior a joint gets from its siblings' current segments ``(times in days, wear, wear std)``:
    :func:`sibling_fit` of each, :func:`pool_prior` of them (``pooling``: its ``weights``, ``floor``, ``unlike``).

    >>> import numpy as np
    >>> t = np.arange(40.0)
    >>> sibs = [(t, 5 + r * t, np.full(40, 0.5)) for r in (0.10, 0.12, 0.14, 0.16, 0.18)]
    >>> p = fleet_prior(sibs)
    >>> round(p.mean, 2), p.joints
    (0.14, 5)
    """
    cfg = cfg or TrendConfig()
    return pool_prior([sibling_fit(t, y, r, cfg) for t, y, r in segments], cfg, min_joints=min_joints,
                      source=source, **pooling)
