"""Histories a maintenance planner meets, with known true wear: the trend's calibration benchmark.

Seven families (:data:`FAMILIES`), each a joint with estimates over ``days`` days and its true wear law:

``linear``
    ``w0 + r t``, r = 0.06-0.25 wear/day, a nightly estimate.
``accelerating``
    half the paper's accelerated wear (``w0 + a tau (exp(t / tau) - 1)``, e-fold every 80-160 days,
    the shape of the accelerated wear test, Sections 3 and 6), half a power law ``w0 + c t^p``
    (p = 1.5-2.5) that no member of the trend's model bank has.
``flat``
    ``w0 + r t`` with r <= 0.02 wear/day: far from the alarm for years.
``step``
    linear until the reducer is replaced on day 35-65 % of the span *without a maintenance event
    in the history*: the wear drops to 1-5 and grows again at a new rate.
``gap``
    linear or accelerating, with 3-6 weeks without estimates (the cell was down) in the middle.
``irregular``
    linear or accelerating, estimates at random times: gaps exponential with a mean of 2 days,
    sometimes two the same night.
``varying_std``
    linear or accelerating, the estimate's std varies by night (log-uniform 0.4-2.5), reported
    exactly (each estimate is drawn with its own reported std).

The estimate noise is Gaussian with the reported std (0.85 unless ``varying_std``), the planner trial's
setting. :meth:`CalibrationJoint.segment_crossing` is the true day of the alarm under the wear law
of the segment holding the night (a trend cannot foresee a replacement to come).

Pure numpy.

>>> js = make_family("step", 3, days=120, seed=1)
>>> [j.profile for j in js], all(len(j.times) > 100 for j in js)
(['step', 'step', 'step'], True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

__all__ = ["EPOCH0", "FAMILIES", "CalibrationJoint", "make_calibration_set", "make_family", "make_trial_set"]

Array = NDArray[np.float64]
DAY = 86400.0
EPOCH0 = 1.7e9
FAMILIES = ("linear", "accelerating", "flat", "step", "gap", "irregular", "varying_std")


@dataclass
class CalibrationJoint:
    """One joint of a family: its estimates and its true wear law (days since :data:`EPOCH0`)."""

    robot: str
    joint: str
    profile: str
    shape: str  # "linear", "exp" or "power"
    w0: float
    rate: float
    tau: float = math.inf  # e-folding time (exp) or the power (power)
    step_day: float = math.nan  # the unrecorded replacement
    w_after: float = 0.0
    rate_after: float = 0.0
    times: Array = field(default_factory=lambda: np.zeros(0))
    wear: Array = field(default_factory=lambda: np.zeros(0))
    wear_std: Array = field(default_factory=lambda: np.zeros(0))
    cycle_ids: NDArray[np.int_] = field(default_factory=lambda: np.zeros(0, int))

    @property
    def maintenance_times(self) -> list[float]:
        return []  # a step is *not* recorded: the trend has to see it in the data

    def _law(self, d: Array) -> Array:
        if self.shape == "exp":
            return np.asarray(self.w0 + self.rate * self.tau * np.expm1(d / self.tau), float)
        if self.shape == "power":
            return np.asarray(self.w0 + self.rate * np.maximum(d, 0.0) ** self.tau, float)
        return np.asarray(self.w0 + self.rate * d, float)

    def true_wear(self, day: Array | float) -> Array:
        d = np.asarray(day, float)
        if math.isfinite(self.step_day):
            after = self.w_after + self.rate_after * (d - self.step_day)
            return np.asarray(np.where(d < self.step_day, self._law(d), after), float)
        return self._law(d)

    def segment_crossing(self, day: float, alarm: float = 35.0, max_days: float = 20000.0) -> float:
        """The day the wear law of ``day``'s segment reaches ``alarm`` (``day`` when there already; inf never)."""
        before = math.isfinite(self.step_day) and day < self.step_day

        def law(d: Array) -> Array:
            return self._law(d) if before else self.true_wear(d)

        if float(law(np.array(day))) >= alarm:
            return day
        lo, hi = day, day + max_days
        if float(law(np.array(hi))) < alarm:
            return math.inf
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if float(law(np.array(mid))) < alarm else (lo, mid)
        return hi

    def segment_crossings(self, days: Array, alarm: float = 35.0, max_days: float = 20000.0) -> Array:
        """:meth:`segment_crossing` at each of ``days``, the same numbers: one bisection for all of them (a power
        law's one at a time: numpy raises an array to a power with other last bits than a number)."""
        d = np.asarray(days, float)
        if self.shape == "power":
            return np.array([self.segment_crossing(float(x), alarm, max_days) for x in d], float)
        before = (d < self.step_day) if math.isfinite(self.step_day) else np.zeros(d.shape, bool)

        def below(x: Array) -> NDArray[np.bool_]:
            return np.asarray(np.where(before, self._law(x), self.true_wear(x)) < alarm)

        lo, hi = d.copy(), d + max_days
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            up = below(mid)
            lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
        return np.where(~below(d), d, np.where(below(d + max_days), math.inf, hi))


def _times(family: str, days: int, rng: np.random.Generator) -> Array:
    if family == "irregular":
        gaps = rng.exponential(2.0, 4 * days)
        gaps[rng.random(len(gaps)) < 0.1] = rng.uniform(0.01, 0.2)  # two the same night
        t = np.cumsum(gaps)
        return np.asarray(t[t < days], float)
    nights = np.arange(days, dtype=float)
    nights = nights[rng.random(days) >= 0.05]  # a few nights skipped
    if family == "gap":
        g0 = rng.uniform(0.3, 0.6) * days
        nights = nights[(nights < g0) | (nights >= g0 + rng.uniform(21.0, 42.0))]
    return np.asarray(nights + rng.uniform(0.0, 4.0, len(nights)) / 24.0, float)


def make_family(family: str, n: int, *, days: int = 180, seed: int = 0, std: float = 0.85,
                first: int = 0) -> list[CalibrationJoint]:
    """``n`` joints of ``family`` (one of :data:`FAMILIES`), estimates over ``days`` days."""
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}; one of {', '.join(FAMILIES)}")
    rng = np.random.default_rng([seed, FAMILIES.index(family)])
    out = []
    for i in range(n):
        k = first + i
        w0 = float(rng.uniform(2.0, 15.0))
        accel = family == "accelerating" or (family in ("gap", "irregular", "varying_std") and i % 2 == 1)
        j = CalibrationJoint(f"{family}_{k // 6 + 1:03d}", f"joint_{k % 6 + 1}", family, "linear", w0,
                             float(rng.uniform(0.06, 0.25)))
        if accel:
            if i % 4 < 2 or family != "accelerating":
                j.shape, j.tau, j.rate = "exp", float(rng.uniform(80.0, 160.0)), float(rng.uniform(0.03, 0.1))
            else:
                p = float(rng.uniform(1.5, 2.5))
                # the rate at day 100 is 0.1-0.3 wear/day
                j.shape, j.tau, j.rate = "power", p, float(rng.uniform(0.1, 0.3)) / (p * 100.0 ** (p - 1))
        elif family == "flat":
            j.rate = float(rng.uniform(0.0, 0.02))
        elif family == "step":
            j.step_day = float(rng.uniform(0.35, 0.65) * days)
            j.rate = float(rng.uniform(0.08, 0.2))
            j.w0 = max(float(rng.uniform(18.0, 30.0)) - j.rate * j.step_day, 1.0)
            j.w_after, j.rate_after = float(rng.uniform(1.0, 5.0)), float(rng.uniform(0.1, 0.3))
        d = _times(family, days, rng)
        sd = (np.exp(rng.uniform(np.log(0.4), np.log(2.5), len(d))) if family == "varying_std"
              else np.full(len(d), std))
        j.times = EPOCH0 + d * DAY
        j.wear_std = sd
        j.wear = j.true_wear(d) + rng.normal(0.0, 1.0, len(d)) * sd
        j.cycle_ids = np.arange(1, len(d) + 1)
        out.append(j)
    return out


def make_calibration_set(per_family: int = 20, *, days: int = 180, seed: int = 0) -> list[CalibrationJoint]:
    """``per_family`` joints of every family."""
    out: list[CalibrationJoint] = []
    for f in FAMILIES:
        out += make_family(f, per_family, days=days, seed=seed, first=len(out))
    return out


def make_trial_set(seeds: tuple[int, ...] = (100, 101, 102), per_family: int = 10, *,
                   days: int = 175) -> list[CalibrationJoint]:
    """The planner trial (docs/history-trend.md): per seed, ``per_family`` linear, accelerating and flat joints over ``days``
    days (the trial looks at estimates 100-159 of each, 60 nightly estimates about 105 days into the joint's
    wear: :func:`jointwear_ros.trend.backtest.score_trial`; 175 days hold at least 160 estimates)."""
    return [j for s in seeds for f in ("linear", "accelerating", "flat") for j in make_family(f, per_family, days=days,
                                                                                               seed=s)]
