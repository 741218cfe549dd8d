"""A simulated year of production: nightly test cycles against production estimates and the cycle on demand (pure).

:func:`simulate_year` draws, for every joint, a wear estimate per production shift, ``N(w_true(t) + bias,
std_prod)`` (``std_prod`` per joint, the production estimate's std measured on the arm; a shift in which the
joint did not move at an informative speed gives none: "cannot tell"), and a dedicated test cycle's estimate
per night, ``N(w_true(t), std_cycle)``. Two schemes run on the same draws (common random numbers):

- ``nightly``: the dedicated cycle every night, its estimates alone;
- ``production``: every shift's production estimate, and the dedicated cycle only on the nights
  :class:`~jointwear_ros.trend.ondemand.OnDemandPolicy` asks for it (one cycle tests every joint; its
  estimates enter the same joint histories).

Both put each joint's estimates through the live monitor's rule: :func:`~jointwear_ros.condition.standing`
(the level rule and the confirmation of an estimate far from the standing one) over the joint's last
``confirm_memory`` estimates (the wear monitor's ``CONFIRM_MEMORY``, 8). The policy's forecast is the trend's
crossing forecast (:func:`~jointwear_ros.trend.alarm.crossing_cdf`, :func:`~jointwear_ros.condition.forecast_of`)
of the bank's slow adaptive member (``accel_noise[0]``) over the joint's production estimates so far: the
full bank is the wear_trend node's and costs a second per joint-year; the production estimates come every
shift whatever the policy does, so the forecast does not depend on its asks.

Each scheme says, per joint, the first night its level was ERROR, the nights a joint whose true wear stays
below the warning level showed ERROR (false ERRORs), and the nights a dedicated cycle ran. Everything is drawn
from one seed; a year of six joints runs in a fraction of a second.

>>> r = simulate_year(seed=1)
>>> r.nightly.cycles, r.production.cycles <= 0.1 * r.nights
(365, True)
>>> [r.production.first_error[j] <= r.nightly.first_error[j] + 3 for j in r.growing]
[True, True]
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.special import ndtr

from ..condition import Forecast, forecast_of, standing
from ..contract import DiagnosticLevel
from ..errors import InputDataError
from .alarm import crossing_cdf, crossing_quantiles, tau_grid
from .config import DAY, Array, TrendConfig
from .filters import kalman_llt
from .ondemand import OnDemandPolicy

__all__ = ["DEFAULT_JOINTS", "STD_CYCLE", "Scheme", "WearPath", "YearResult", "production_forecasts",
           "simulate_year"]

#: the dedicated cycle's wear std (the ``joint`` estimator at wear 20, docs/nodes-bag-demo.md: 19.32 ± 0.85)
STD_CYCLE = 0.85


@dataclass(frozen=True)
class WearPath:
    """A joint's true wear over the year: ``start + rate_per_day * t`` (``efold_days`` None), or accelerating,
    ``start + rate_per_day * efold_days * (exp(t / efold_days) - 1)`` (the rate at day 0 is ``rate_per_day``)."""

    joint: str
    start: float
    rate_per_day: float = 0.0
    efold_days: float | None = None

    def wear(self, t_days: Array | Sequence[float]) -> Array:
        t = np.asarray(t_days, dtype=np.float64)
        if self.efold_days is None:
            return self.start + self.rate_per_day * t
        e = float(self.efold_days)
        return self.start + self.rate_per_day * e * np.expm1(t / e)


#: six joints (a UR5): joint_2 grows linearly and joint_3 accelerates, both crossing 35 in the second half of the
#: year; the others stay below the warning level (27 the highest, 3 production std below the alarm at ratio 2)
DEFAULT_JOINTS: tuple[WearPath, ...] = (
    WearPath("joint_1", 8.0, 0.005),
    WearPath("joint_2", 10.0, 25.0 / 180.0),
    WearPath("joint_3", 5.0, 0.03, 90.0),
    WearPath("joint_4", 18.0, 0.01),
    WearPath("joint_5", 24.0, 0.005),
    WearPath("joint_6", 14.0, 0.0),
)


@dataclass
class Scheme:
    """One scheme's year: per joint the first night at ERROR (None: never), the nights at ERROR of the joints
    whose truth stays below the warning level, and the nights a dedicated cycle ran (with the reasons asked)."""

    name: str
    first_error: dict[str, int | None]
    false_error_nights: dict[str, int]
    cycles: int
    cycle_nights: tuple[int, ...] = ()
    #: (night, joint, kind, reason) of each ask that made a cycle run (the first per joint and night)
    asks: tuple[tuple[int, str, str, str], ...] = ()
    #: the highest level of each joint on each night (nights, joints), -1 none
    levels: NDArray[np.int_] = field(default_factory=lambda: np.zeros((0, 0), int))

    @property
    def false_errors(self) -> int:
        return sum(self.false_error_nights.values())

    def asked_by_kind(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for _, _, k, _ in self.asks:
            out[k] = out.get(k, 0) + 1
        return out


@dataclass
class YearResult:
    """The two schemes over the same year (:func:`simulate_year`)."""

    nights: int
    shifts_per_day: int
    joints: tuple[str, ...]
    growing: tuple[str, ...]
    flat: tuple[str, ...]
    std_cycle: float
    std_prod: tuple[float, ...]
    nightly: Scheme
    production: Scheme
    #: the night each joint's truth reaches the alarm (None: not within the year)
    true_crossing: dict[str, int | None]

    def delays(self) -> dict[str, int | None]:
        """Production's first ERROR minus the nightly cycle's, nights, per growing joint (None: one of them never)."""
        out: dict[str, int | None] = {}
        for j in self.growing:
            a, b = self.production.first_error[j], self.nightly.first_error[j]
            out[j] = None if a is None or b is None else a - b
        return out

    @property
    def asked_fraction(self) -> float:
        return self.production.cycles / self.nights if self.nights else 0.0


def production_forecasts(t_days: Array, wear: Array, wear_std: Array, cfg: TrendConfig) -> list[Forecast]:
    """The trend's forecast after each estimate (times in days, ascending): the crossing forecast of the bank's
    slow adaptive member (``cfg.accel_noise[0]``; the local linear trend), growth when ``P(rate > 0)`` reaches
    ``cfg.growth_probability``, a trend from ``cfg.min_estimates`` estimates on."""
    t = np.asarray(t_days, float)
    n = len(t)
    if n == 0:
        return []
    q = float(cfg.accel_noise[0]) if cfg.accel_noise else 0.0
    f = kalman_llt(t, np.asarray(wear, float), np.asarray(wear_std, float), cfg, q, 2)
    tau = tau_grid(float(cfg.max_horizon_days))
    pg = ndtr(f.mean[:, 1] / np.sqrt(np.maximum(f.cov[:, 1, 1], 1e-18)))
    # the crossing only where it can matter (growth, or the alarm within reach now): the rest say no growth
    now = ndtr((f.mean[:, 0] - cfg.alarm) / np.sqrt(np.maximum(f.cov[:, 0, 0], 1e-18)))
    rows = np.flatnonzero((pg >= cfg.growth_probability) | (now >= 0.05))
    qs = np.full((n, 3), np.inf)
    if len(rows):
        qs[rows] = crossing_quantiles(crossing_cdf(f.mean[rows], f.cov[rows], q, cfg, tau), tau)
    out = []
    for k in range(n):
        lo, med, hi = (float(x) for x in qs[k])
        out.append(forecast_of(_fin(med), _fin(lo), _fin(hi), bool(pg[k] >= cfg.growth_probability),
                               k + 1 >= cfg.min_estimates, cfg.horizon_days))
    return out


def _fin(x: float) -> float | None:
    return x if math.isfinite(x) else None


class _History:
    """A joint's recent estimates and its level by the live monitor's rule (:func:`condition.standing`)."""

    def __init__(self, memory: int, warn: float, alarm: float) -> None:
        self.rows: deque[tuple[float, float, float]] = deque(maxlen=memory)
        self.warn, self.alarm = warn, alarm

    def add(self, t_days: float, w: float, s: float) -> int:
        self.rows.append((t_days, w, s))
        st = standing([r[1] for r in self.rows], [r[2] for r in self.rows], [r[0] for r in self.rows],
                      None, self.warn, self.alarm)
        return -1 if st.level is None else int(st.level)


def _per_joint(name: str, value: float | Sequence[float], n: int) -> tuple[float, ...]:
    vals = (float(value),) * n if isinstance(value, (int, float)) else tuple(float(v) for v in value)
    if len(vals) != n or not all(math.isfinite(v) and v > 0 for v in vals):
        raise InputDataError(f"{name} = {value!r}: one finite std > 0 (or one per joint, {n}) is needed")
    return vals


def simulate_year(joints: Sequence[WearPath] = DEFAULT_JOINTS, *, nights: int = 365, shifts_per_day: int = 3,
                  std_cycle: float = STD_CYCLE, std_prod: float | Sequence[float] | None = None,
                  p_quiet: float = 0.1, quiet_spells: Sequence[tuple[str, int, int]] = (("joint_6", 120, 5),),
                  bias_prod: float = 0.0, policy: OnDemandPolicy | None = None, trend: TrendConfig | None = None,
                  confirm_memory: int = 8, seed: int = 0) -> YearResult:
    """Simulate a year (module docstring) and return both schemes.

    Parameters
    ----------
    joints : the joints' true wear paths.
    nights, shifts_per_day : length of the year and production shifts per day (one estimate per shift).
    std_cycle : the dedicated cycle's wear std; ``std_prod``: the production estimate's (one, or one per joint;
        default twice ``std_cycle``, the most the issue allows).
    p_quiet : probability that a shift has no informative motion of a joint (independent per shift and joint).
    quiet_spells : ``(joint, first night, nights)``: the program does not move the joint informatively (a
        changeover).
    bias_prod : a bias of every production estimate (the temperature the joint reaches in production, say).
    policy : the on-demand policy (default settings and the trend's thresholds).
    trend : the trend's settings (its ``warn`` and ``alarm`` are the levels' thresholds).
    confirm_memory : estimates the confirmation looks back over (the wear monitor's).
    seed : the one seed of every draw.
    """
    trend = trend or TrendConfig()
    policy = policy or OnDemandPolicy(warn=trend.warn, alarm=trend.alarm)
    names = tuple(p.joint for p in joints)
    nj = len(names)
    if nj == 0 or len(set(names)) != nj:
        raise InputDataError(f"joints {names!r}: at least one, each named once")
    if not (isinstance(nights, int) and nights >= 1 and isinstance(shifts_per_day, int) and 1 <= shifts_per_day <= 24):
        raise InputDataError(f"nights = {nights!r}, shifts_per_day = {shifts_per_day!r}: need >= 1 and 1-24")
    if not (math.isfinite(std_cycle) and std_cycle > 0):
        raise InputDataError(f"std_cycle = {std_cycle!r}: a finite std > 0 is needed")
    sp = _per_joint("std_prod", 2.0 * std_cycle if std_prod is None else std_prod, nj)
    if not 0.0 <= p_quiet <= 1.0 or not math.isfinite(bias_prod):
        raise InputDataError(f"p_quiet = {p_quiet!r} must be in [0, 1] and bias_prod = {bias_prod!r} finite")
    S = shifts_per_day
    rng = np.random.default_rng(seed)
    # times in days: shift k of day d ends at d + (k + 1) / (S + 1), the night's cycle at d + (S + 0.5) / (S + 1)
    t_shift: Array = (np.arange(nights, dtype=np.float64)[:, None]
                      + (np.arange(S, dtype=np.float64)[None, :] + 1.0) / (S + 1.0)).ravel()
    t_night: Array = np.arange(nights, dtype=np.float64) + (S + 0.5) / (S + 1.0)
    truth_s = np.array([p.wear(t_shift) for p in joints])  # (nj, nights * S)
    truth_n = np.array([p.wear(t_night) for p in joints])  # (nj, nights)
    prod = truth_s + bias_prod + rng.standard_normal(truth_s.shape) * np.array(sp)[:, None]
    quiet = rng.random(truth_s.shape) < p_quiet
    for j_name, first, length in quiet_spells:
        if j_name not in names:
            raise InputDataError(f"quiet spell of {j_name!r}: not one of the joints {names!r}")
        quiet[names.index(j_name), int(first) * S:(int(first) + int(length)) * S] = True
    cyc = truth_n + rng.standard_normal(truth_n.shape) * std_cycle
    growing = tuple(n for n, row in zip(names, truth_n) if row.max() >= trend.alarm)
    flat = tuple(n for n, row in zip(names, truth_n) if row.max() < trend.warn)
    crossing = {n: (int(np.argmax(row >= trend.alarm)) if row.max() >= trend.alarm else None)
                for n, row in zip(names, truth_n)}

    # the nightly cycle
    lv_n = np.full((nights, nj), -1, int)
    for j in range(nj):
        h = _History(confirm_memory, trend.warn, trend.alarm)
        for d in range(nights):
            lv_n[d, j] = h.add(float(t_night[d]), float(cyc[j, d]), std_cycle)
    nightly = _scheme("nightly", lv_n, names, flat, tuple(range(nights)), ())

    # production and the cycle on demand
    fcs: list[list[Forecast | None]] = []
    for j in range(nj):
        use = np.flatnonzero(~quiet[j])
        fc = production_forecasts(t_shift[use], prod[j, use], np.full(len(use), sp[j]), trend)
        row: list[Forecast | None] = [None] * (nights * S)
        last: Forecast | None = None
        it = iter(zip(use.tolist(), fc))
        nxt = next(it, None)
        for i in range(nights * S):
            if nxt is not None and nxt[0] == i:
                last = nxt[1]
                nxt = next(it, None)
            row[i] = last
        fcs.append(row)
    hist = [_History(confirm_memory, trend.warn, trend.alarm) for _ in range(nj)]
    lv_p = np.full((nights, nj), -1, int)
    quiet_count = [0] * nj
    last_cycle: float | None = None
    last_cycle_est: list[tuple[float, float] | None] = [None] * nj
    cycle_nights: list[int] = []
    asks: list[tuple[int, str, str, str]] = []
    for d in range(nights):
        asked: dict[str, tuple[str, str]] = {}
        for k in range(S):
            i = d * S + k
            now = float(t_shift[i]) * DAY
            for j in range(nj):
                est: tuple[float, float] | None = None
                if quiet[j, i]:
                    quiet_count[j] += 1
                else:
                    quiet_count[j] = 0
                    est = (float(prod[j, i]), sp[j])
                    lv_p[d, j] = max(lv_p[d, j], hist[j].add(float(t_shift[i]), est[0], est[1]))
                if names[j] in asked:
                    continue
                dec = policy.decide(names[j], est, fcs[j][i], quiet_shifts=quiet_count[j],
                                    last_cycle_time=None if last_cycle is None else last_cycle * DAY, now=now,
                                    last_cycle_estimate=last_cycle_est[j])
                if dec.ask:
                    asked[names[j]] = (dec.kind, dec.reason)
        if asked:
            cycle_nights.append(d)
            last_cycle = float(t_night[d])
            for j in range(nj):
                w = float(cyc[j, d])
                lv_p[d, j] = max(lv_p[d, j], hist[j].add(last_cycle, w, std_cycle))
                last_cycle_est[j] = (w, std_cycle)
                quiet_count[j] = 0
            asks += [(d, n, kind, why) for n, (kind, why) in asked.items()]
    production = _scheme("production", lv_p, names, flat, tuple(cycle_nights), tuple(asks))
    return YearResult(nights, S, names, growing, flat, float(std_cycle), sp, nightly, production, crossing)


def _scheme(name: str, levels: NDArray[np.int_], names: tuple[str, ...], flat: tuple[str, ...],
            cycle_nights: tuple[int, ...], asks: tuple[tuple[int, str, str, str], ...]) -> Scheme:
    err = levels == int(DiagnosticLevel.ERROR)
    first = {n: (int(np.argmax(err[:, j])) if err[:, j].any() else None) for j, n in enumerate(names)}
    false = {n: int(err[:, names.index(n)].sum()) for n in flat}
    return Scheme(name, first, false, len(cycle_nights), cycle_nights, asks, levels)
