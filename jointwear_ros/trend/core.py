"""Wear trend of one joint: current wear and rate, time to the alarm with a 90 % interval, a level.

The model is a **local linear trend** (level ``L``, rate ``S`` in wear per
day) whose rate follows an integrated random walk, observed through each
estimate's own standard deviation::

    L(t + dt) = L(t) + S(t) dt + eta_L,    S(t + dt) = S(t) + eta_S
    Q(dt) = q [[dt^3/3, dt^2/2], [dt^2/2, dt]]  (+ q_L dt on the level)
    y_k = L(t_k) + e_k,   e_k ~ N(0, wear_std_k^2)

with ``q`` (:attr:`TrendConfig.accel_noise`, wear² per day³) the spectral
density of the rate's random walk, i.e. how fast the wear may accelerate.
Next to it, a **local quadratic trend** (a third state, the acceleration, with
a random walk of density :attr:`TrendConfig.jerk_noise`) for wear that keeps
accelerating (the paper's accelerated wear test, Sections 3 and 6). A *bank*
of these filters (several ``q``, one quadratic) runs on the estimates, and
their results are averaged with weights from each one's predictive
likelihood of the estimates (equal prior weights): a steady joint keeps the
weight on a small ``q``; an accelerating one moves it to a large ``q`` and
the quadratic model as the data show the acceleration.

Each is a 2- or 3-state Kalman filter with irregular time steps and
per-observation noise (and an RTS smoother for the plotted band),
hand-written in numpy: a few lines, it takes each estimate's own variance
and uneven gaps directly, and it runs the fleet backtest at thousands of
joint-nights per second; a general state-space library (statsmodels
``UnobservedComponents``: equal steps, a fitted, not a given, observation
variance) does not give that as simply.

**Time to alarm.** From each filter's state ``(L, S[, A]) ~ N(m, P)`` at the
last estimate, the wear ``tau`` days ahead is Gaussian with mean ``L + S tau
(+ A tau^2/2)`` and variance ``h P h' + q tau^3/3`` (quadratic: ``+ q
tau^5/20``), ``h = [1, tau(, tau^2/2)]``. The probability
that the alarm ``a`` has been crossed by ``tau`` is taken as the running
maximum over ``tau' <= tau`` of ``P(wear(tau') >= a)`` (exact for a straight
line with uncertain level and rate; for the random-walk part it ignores
paths that cross and come back, which wear does not do). These curves are
averaged with the filters' weights; the 5 %, 50 % and 95 % points are the
90 % interval and the median (a point not reached within
``max_horizon_days`` is infinite: unbounded). When the rate is not
credibly positive (``P(S > 0) < growth_probability``) there is no time to
alarm: *no growth detected*.

**Level** (``diagnostic_msgs/DiagnosticStatus`` bytes): ERROR when the
current wear estimate (filtered level) is at or above the alarm, the
wear_estimator's convention (``w_hat >= 35``); WARN when growth is detected
and the 90 % interval's lower bound is within ``horizon_days``; else OK.
Fewer than ``min_estimates`` estimates in the current segment give no trend
(OK or ERROR only).

**Segments.** A maintenance event (regrease, reducer replaced) starts a new
segment: the trend uses the estimates after the joint's last event.
**Revisions.** A wear_estimator may re-estimate a cycle (same cycle id, later
stamp); estimates of the same cycle id within ``revision_window_s`` are one
cycle and the newest is kept.

Pure numpy/scipy: no ROS, no database.

>>> import numpy as np
>>> t = 1.7e9 + 86400.0 * np.arange(60)
>>> w = 10.0 + 0.3 * np.arange(60)
>>> r = analyze_joint(t, w, np.full(60, 0.85))
>>> round(r.rate_per_day, 2), r.level_name, round(r.time_to_alarm.median)
(0.3, 'WARN', 24)
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

from ..contract import DiagnosticLevel
from ..errors import InputDataError

__all__ = [
    "DAY",
    "ERROR",
    "LEVEL_NAMES",
    "OK",
    "WARN",
    "FilterOutput",
    "TimeToAlarm",
    "TrendConfig",
    "TrendResult",
    "TrendStates",
    "analyze_joint",
    "bank_weights",
    "collapse_revisions",
    "crossing_cdf",
    "crossing_quantiles",
    "filter_bank",
    "kalman_llt",
    "last_segment",
    "rts_smooth",
    "trend_states",
]

DAY = 86400.0
#: the trend's levels are ``DiagnosticStatus`` levels: aliases of :class:`jointwear_ros.contract.DiagnosticLevel`.
OK, WARN, ERROR = DiagnosticLevel.OK, DiagnosticLevel.WARN, DiagnosticLevel.ERROR
LEVEL_NAMES = {int(lv): lv.name for lv in (OK, WARN, ERROR)}

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TrendConfig:
    """Settings of the trend model and of the levels.

    Attributes
    ----------
    alarm : wear at which the alarm is raised (35, the paper's).
    horizon_days : WARN when the 90 % interval's lower bound of the time to alarm is within it.
    accel_noise : candidate values of ``q``, spectral density of the rate's random walk, wear² / day³ (how
        fast wear may accelerate); the trend averages over them, weighted by how well each explains the
        joint's estimates (equal prior weights). One value: a plain Kalman filter.
    level_noise : ``q_L``, random walk of the level, wear² / day (0: wear has no jumps between maintenance).
    slope_prior_std : prior standard deviation of the rate at a segment's start, wear / day.
    min_estimates : estimates a segment needs before it has a trend.
    growth_probability : ``P(rate > 0)`` needed to call it growth.
    max_horizon_days : times to alarm beyond it are reported as infinite.
    revision_window_s : estimates with the same cycle id within this many seconds are one cycle (revisions).
    """

    alarm: float = 35.0
    horizon_days: float = 30.0
    accel_noise: tuple[float, ...] = (1e-5, 1e-4, 1e-3)
    jerk_noise: tuple[float, ...] = (1e-8,)
    accel_prior_std: float = 0.003
    level_noise: float = 0.0
    slope_prior_std: float = 0.2
    min_estimates: int = 5
    growth_probability: float = 0.95
    max_horizon_days: float = 3650.0
    revision_window_s: float = 3600.0

    def __post_init__(self) -> None:
        q = self.accel_noise
        qs = (q,) if isinstance(q, (int, float)) else tuple(q)
        if not qs or not all(math.isfinite(float(x)) and float(x) >= 0 for x in qs):
            raise InputDataError(f"trend setting accel_noise = {q!r} must be one or more finite numbers >= 0")
        object.__setattr__(self, "accel_noise", tuple(float(x) for x in qs))
        jq = self.jerk_noise
        jqs = (jq,) if isinstance(jq, (int, float)) else tuple(jq)
        if not all(math.isfinite(float(x)) and float(x) >= 0 for x in jqs):
            raise InputDataError(f"trend setting jerk_noise = {jq!r} must be finite numbers >= 0")
        object.__setattr__(self, "jerk_noise", tuple(float(x) for x in jqs))
        for name in ("alarm", "horizon_days", "level_noise", "slope_prior_std", "accel_prior_std",
                     "max_horizon_days", "revision_window_s"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise InputDataError(f"trend setting {name} = {v!r} must be a finite number >= 0")
        if self.slope_prior_std <= 0 or self.max_horizon_days <= 0:
            raise InputDataError("trend settings slope_prior_std and max_horizon_days must be > 0")
        if not 0.5 <= self.growth_probability < 1:
            raise InputDataError(f"growth_probability = {self.growth_probability!r} must be in [0.5, 1)")
        if int(self.min_estimates) < 2:
            raise InputDataError(f"min_estimates = {self.min_estimates!r} must be at least 2")

    @classmethod
    def from_mapping(cls, values: dict[str, Any]) -> TrendConfig:
        names = set(cls.__dataclass_fields__)
        return cls(**{k: v for k, v in values.items() if k in names})


@dataclass(frozen=True)
class TimeToAlarm:
    """Days from the last estimate until the trend crosses the alarm: median and 90 % interval (inf: beyond)."""

    median: float
    lo90: float
    hi90: float

    def as_dict(self) -> dict[str, float]:
        return {"median": self.median, "lo90": self.lo90, "hi90": self.hi90}


@dataclass(frozen=True)
class FilterOutput:
    """Filtered (or smoothed) states for one ``q``: ``t_days`` (n,), ``mean`` (n, 2), ``cov`` (n, 2, 2),
    ``loglik`` (n,) the cumulative log-likelihood of the estimates up to each one (predictive, after the first)."""

    t_days: Array
    mean: Array
    cov: Array
    loglik: Array
    q: float
    order: int = 2


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

    @property
    def level_name(self) -> str:
        return LEVEL_NAMES[self.level]

    def as_dict(self) -> dict[str, Any]:
        """The issue's JSON contract (plus a few extra keys)."""
        return {
            "robot": self.robot, "joint": self.joint, "estimates": self.estimates,
            "wear": self.wear, "wear_std": self.wear_std, "rate_per_day": self.rate_per_day,
            "time_to_alarm_days": None if self.time_to_alarm is None else self.time_to_alarm.as_dict(),
            "level": self.level_name,
            "rate_std_per_day": self.rate_std, "growth_detected": self.growth_detected,
            "estimates_total": self.estimates_total, "segments": self.segments,
            "last_time": self.last_time, "segment_start": self.segment_start, "message": self.message,
        }


# ---------------------------------------------------------------------------- filter


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
               order: int = 2) -> FilterOutput:
    """Filtered states at each estimate (times in days, ascending) for one ``q``.

    ``order`` 2: the local linear trend (level, rate); 3: local quadratic (level, rate, acceleration
    with prior std ``cfg.accel_prior_std``), for wear that keeps accelerating.
    """
    q = float(cfg.accel_noise[0] if q is None else q)
    t = np.asarray(t_days, float)
    y = np.asarray(y, float)
    var = np.asarray(r, float) ** 2
    n = len(t)
    mean = np.zeros((n, order))
    cov = np.zeros((n, order, order))
    ll = np.zeros(n)
    m = np.zeros(order)
    m[0] = y[0] if n else 0.0
    P = np.diag([1e6, cfg.slope_prior_std ** 2, cfg.accel_prior_std ** 2][:order])
    total = 0.0
    for k in range(n):
        if k > 0:
            F, Q = _transition(max(t[k] - t[k - 1], 0.0), order, q, cfg.level_noise)
            m = F @ m
            P = F @ P @ F.T + Q
        s_ = P[0, 0] + var[k]
        v = y[k] - m[0]
        if k > 0:
            total += -0.5 * (math.log(2 * math.pi * s_) + v * v / s_)
        K = P[:, 0] / s_
        m = m + K * v
        P = P - np.outer(K, P[0, :])
        P = 0.5 * (P + P.T)
        mean[k], cov[k], ll[k] = m, P, total
    return FilterOutput(t, mean, cov, ll, q, order)


def filter_bank(t_days: Array, y: Array, r: Array, cfg: TrendConfig) -> list[FilterOutput]:
    """One filter per candidate: each ``q`` of ``cfg.accel_noise`` (order 2), each of ``cfg.jerk_noise`` (order 3)."""
    return ([kalman_llt(t_days, y, r, cfg, q, 2) for q in cfg.accel_noise]
            + [kalman_llt(t_days, y, r, cfg, q, 3) for q in cfg.jerk_noise])


def bank_weights(bank: Sequence[FilterOutput]) -> Array:
    """Posterior weight of each ``q`` after each estimate (K, n): equal priors times the likelihood."""
    ll = np.stack([f.loglik for f in bank])
    ll = ll - ll.max(axis=0, keepdims=True)
    w = np.exp(ll)
    return np.asarray(w / w.sum(axis=0, keepdims=True), float)


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


# ---------------------------------------------------------------------------- time to alarm

_GRID_CACHE: dict[float, Array] = {}


def _tau_grid(max_days: float) -> Array:
    g = _GRID_CACHE.get(max_days)
    if g is None:
        g = np.concatenate([[0.0], np.geomspace(0.01, max_days, 700)])
        _GRID_CACHE[max_days] = g
    return g


def crossing_cdf(mean: Array, cov: Array, q: float, cfg: TrendConfig, tau: Array) -> Array:
    """P(alarm crossed by tau) for states (N, d), (N, d, d) -> (N, len(tau)), running max over tau."""
    m = np.atleast_2d(mean)
    d = m.shape[1]
    P = cov.reshape(-1, d, d)
    tau = np.asarray(tau, float)
    H = np.stack([np.ones_like(tau), tau, tau * tau / 2][:d])  # (d, G)
    mu = m @ H
    v = np.einsum("ig,nij,jg->ng", H, P, H)
    v = v + (q * tau ** 3 / 3 if d == 2 else q * tau ** 5 / 20)[None, :] + cfg.level_noise * tau[None, :]
    z = (mu - cfg.alarm) / np.sqrt(np.maximum(v, 1e-12))
    return np.asarray(np.maximum.accumulate(ndtr(z), axis=1))


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


@dataclass(frozen=True)
class TrendStates:
    """The trend after each estimate of a segment (arrays of length n): what the levels are made of."""

    wear: Array
    wear_std: Array
    rate: Array
    rate_std: Array
    p_growth: Array
    growth: NDArray[np.bool_]
    quantiles: Array  # (n, 3): lo90, median, hi90 in days
    level: NDArray[np.int_]
    weights: Array  # (K, n) weight of each q


def trend_states(bank: Sequence[FilterOutput], cfg: TrendConfig, rows: Array | None = None) -> TrendStates:
    """Mix the filters of a bank (weights by likelihood) into the trend after each estimate (or ``rows``)."""
    W = bank_weights(bank)
    n = len(bank[0].t_days)
    idx = np.arange(n) if rows is None else np.asarray(rows, int)
    W = W[:, idx]
    means = [f.mean[idx] for f in bank]
    covs = [f.cov[idx] for f in bank]
    wear = sum(W[k] * means[k][:, 0] for k in range(len(bank)))
    rate = sum(W[k] * means[k][:, 1] for k in range(len(bank)))
    wear_var = sum(W[k] * (covs[k][:, 0, 0] + (means[k][:, 0] - wear) ** 2) for k in range(len(bank)))
    rate_var = sum(W[k] * (covs[k][:, 1, 1] + (means[k][:, 1] - rate) ** 2) for k in range(len(bank)))
    p_growth = sum(W[k] * ndtr(means[k][:, 1] / np.sqrt(np.maximum(covs[k][:, 1, 1], 1e-18)))
                   for k in range(len(bank)))
    tau = _tau_grid(float(cfg.max_horizon_days))
    F = sum(W[k][:, None] * crossing_cdf(means[k], covs[k], bank[k].q, cfg, tau) for k in range(len(bank)))
    qs = crossing_quantiles(np.asarray(F), tau)
    n_used = idx + 1
    growth = (p_growth >= cfg.growth_probability) & (n_used >= cfg.min_estimates)
    level = np.full(len(idx), OK)
    level[growth & (qs[:, 0] <= cfg.horizon_days)] = WARN
    level[wear >= cfg.alarm] = ERROR
    return TrendStates(wear, np.sqrt(wear_var), rate, np.sqrt(rate_var), p_growth, growth, qs, level, W)


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
) -> TrendResult:
    """The trend of one joint from its estimates (times in seconds since the epoch)."""
    cfg = cfg or TrendConfig()
    t = np.asarray(times, float)
    w = np.asarray(wear, float)
    s = np.asarray(wear_std, float)
    if not (t.shape == w.shape == s.shape) or t.ndim != 1:
        raise InputDataError(f"{robot}/{joint}: times, wear and wear_std must be 1-D of one length "
                             f"(got {t.shape}, {w.shape}, {s.shape})")
    bad = ~(np.isfinite(t) & np.isfinite(w) & np.isfinite(s) & (s > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputDataError(f"{robot}/{joint}: estimate {i} is not usable (time {t[i]!r}, wear {w[i]!r}, "
                             f"std {s[i]!r}): need finite values and std > 0")
    total = len(t)
    cid = np.zeros(total, int) if cycle_ids is None else np.asarray(cycle_ids)
    keep = collapse_revisions(t, cid, cfg.revision_window_s) if total else np.zeros(0, int)
    t, w, s = t[keep], w[keep], s[keep]
    first, seg_start, segs = last_segment(t, maintenance_times)
    t, w, s = t[first:], w[first:], s[first:]
    n = len(t)
    if n == 0:
        return TrendResult(robot, joint, 0, total, math.nan, math.nan, math.nan, math.nan, None, OK,
                           "no estimates since the last maintenance event", False, math.nan, seg_start, segs)
    bank = filter_bank((t - t[0]) / DAY, w, s, cfg)
    st = trend_states(bank, cfg, rows=np.array([n - 1]))
    qs = st.quantiles
    level, growth = int(st.level[0]), bool(st.growth[0])
    wear_now, wear_sd = float(st.wear[0]), float(st.wear_std[0])
    rate, rate_sd = float(st.rate[0]), float(st.rate_std[0])
    best = int(np.argmax(st.weights[:, 0]))
    f = bank[best]
    tta: TimeToAlarm | None
    if wear_now >= cfg.alarm:
        tta = TimeToAlarm(0.0, 0.0, 0.0)
        msg = f"wear {wear_now:.1f} ± {wear_sd:.1f} at or above the alarm {cfg.alarm:g}"
    elif n < cfg.min_estimates:
        tta = None
        msg = f"{n} estimate(s) in this segment: a trend needs {cfg.min_estimates}"
    elif not growth:
        tta = None
        msg = f"no growth detected (rate {rate:+.3f} ± {rate_sd:.3f} /day); wear {wear_now:.1f} ± {wear_sd:.1f}"
    else:
        tta = TimeToAlarm(float(qs[0, 1]), float(qs[0, 0]), float(qs[0, 2]))
        msg = (f"alarm {cfg.alarm:g} in {_days(tta.median)} (90 %: {_days(tta.lo90)} to {_days(tta.hi90)}); "
               f"wear {wear_now:.1f} ± {wear_sd:.1f}, rate {rate:+.3f} /day")
        if level == WARN:
            msg = f"alarm possible within {cfg.horizon_days:g} days: " + msg
    return TrendResult(
        robot=robot, joint=joint, estimates=n, estimates_total=total, wear=wear_now, wear_std=wear_sd,
        rate_per_day=rate, rate_std=rate_sd, time_to_alarm=tta, level=level, message=msg,
        growth_detected=growth, last_time=float(t[-1]), segment_start=float(seg_start), segments=segs,
        filtered=f, smoothed=rts_smooth(f, cfg) if smooth else None, times=t, wears=w, wear_stds=s,
    )


def _days(x: float) -> str:
    return "unbounded" if not math.isfinite(x) else f"{x:.0f} d"
