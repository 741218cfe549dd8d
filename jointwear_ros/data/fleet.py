"""A synthetic fleet: joints over months of nightly test cycles, with known true wear.

Each joint has a true wear profile over time (days since the fleet's start):

``linear``
    ``w0 + r t``.
``accelerating``
    ``w0 + a tau (exp(t / tau) - 1)``: the rate ``a exp(t / tau)`` grows
    e-fold every ``tau`` = 80-160 days, slow at first, then faster, as the
    wear of the paper's accelerated wear test (Section 3, Fig. 5-6: the
    friction change grows with use).
``flat``
    ``w0`` plus a slow drift that stays far below the alarm.
``maintained``
    linear growth until a planned maintenance event (regrease / reducer
    replaced) at a wear of 15-28, where the wear resets to a low value and
    grows again.

Every night at a time that varies by up to ±2 h, a cycle runs at the joint
temperature ``T = 40 + seasonal ±8 °C + daily ±3 °C (by the hour) + N(0, 1)``
and the single-cycle estimator returns ``w_hat = w + e``, ``e ~ N(0,
sigma_e(w)^2)``, with its reported std ``sigma_r(w)``. Both come from
:data:`ESTIMATOR_NOISE`, calibrated by running the real joint estimator on
simulated cycle observations at eight wears and three temperatures
(:func:`calibrate_estimator_noise`): about 0.85 at w = 20 (what the demo
shows), 0.7 near the alarm, 1.5-2 at w < 10 where the wear changes the
friction least. The temperature is recorded with each estimate; the joint
estimator estimates it with the wear, so it adds no bias of its own here.
A few nights are skipped (the cell was busy).

The true time at which a joint reaches the alarm is known
(:meth:`JointHistory.segment_crossing`), so a trend's time to alarm can be
scored at every night.

Pure numpy (the calibration imports the estimators).

>>> fleet = make_fleet(n_joints=8, days=120, seed=1)
>>> sorted({j.profile for j in fleet})
['accelerating', 'flat', 'linear', 'maintained']
>>> len(fleet[0].times) > 100, bool(fleet[0].wear_std.min() > 0.5)
(True, True)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["DAY", "EPOCH0", "ESTIMATOR_NOISE", "PROFILES", "EstimatorNoise", "JointHistory",
           "calibrate_estimator_noise", "make_fleet"]

Array = NDArray[np.float64]
DAY = 86400.0
EPOCH0 = 1.7e9  # the fleet's day 0, seconds since the epoch (Nov 2023)
PROFILES = ("linear", "accelerating", "flat", "maintained")


@dataclass(frozen=True)
class EstimatorNoise:
    """Single-cycle estimator noise as a function of the true wear (linear interpolation between knots).

    ``actual``: RMS error of the estimate; ``reported``: the std the estimator reports.
    """

    wears: tuple[float, ...] = (0.85,)
    actual: tuple[float, ...] = (0.85,)
    reported: tuple[float, ...] = (0.85,)

    def _interp(self, wear: Array, values: tuple[float, ...]) -> Array:
        w = np.asarray(wear, float)
        if len(self.wears) == 1:
            return np.full(w.shape, float(values[0]))
        return np.asarray(np.interp(w, self.wears, values), float)

    def std(self, wear: Array) -> Array:
        """The reported std at the true ``wear``."""
        return self._interp(wear, self.reported)

    def error_std(self, wear: Array) -> Array:
        """The actual RMS error at the true ``wear``."""
        return self._interp(wear, self.actual)


#: the joint estimator at the default 8 speeds, load 0.1, T in {32, 40, 48} °C, 40 cycles per point
#: (calibrate_estimator_noise(wears=(2, 5, 10, 15, 20, 27, 35, 45), runs=40); docs/history-trend.md)
ESTIMATOR_NOISE = EstimatorNoise(
    wears=(2.0, 5.0, 10.0, 15.0, 20.0, 27.0, 35.0, 45.0),
    actual=(1.42, 1.66, 1.62, 0.98, 0.85, 0.73, 0.73, 0.72),
    reported=(1.79, 1.97, 1.54, 1.02, 0.86, 0.75, 0.70, 0.66),
)


@dataclass
class JointHistory:
    """One synthetic joint: its profile, nightly estimates, maintenance times and the true wear function."""

    robot: str
    joint: str
    profile: str
    w0: float
    rate: float
    accel: float = 0.0
    accel_tau: float = 1.0
    maintenance_day: float = math.nan
    reset_wear: float = 0.0
    times: Array = field(default_factory=lambda: np.zeros(0))
    wear: Array = field(default_factory=lambda: np.zeros(0))
    wear_std: Array = field(default_factory=lambda: np.zeros(0))
    true: Array = field(default_factory=lambda: np.zeros(0))
    temperature: Array = field(default_factory=lambda: np.zeros(0))
    cycle_ids: NDArray[np.int_] = field(default_factory=lambda: np.zeros(0, int))

    def true_wear(self, day: Array | float) -> Array:
        """True wear at ``day`` (days since the fleet's start)."""
        d = np.asarray(day, float)
        if self.profile == "maintained" and math.isfinite(self.maintenance_day):
            before = self.w0 + self.rate * d
            after = self.reset_wear + self.rate * (d - self.maintenance_day)
            return np.where(d < self.maintenance_day, before, after)
        w = self.w0 + self.rate * d
        if self.accel:
            w = w + self.accel * (np.exp(d / self.accel_tau) - 1.0)
        return np.asarray(w, float)

    @property
    def maintenance_times(self) -> list[float]:
        return [] if not math.isfinite(self.maintenance_day) else [EPOCH0 + self.maintenance_day * DAY]

    def segment_crossing(self, day: float, alarm: float = 35.0, max_days: float = 20000.0) -> float:
        """Day at which the wear law of the segment holding ``day`` reaches ``alarm`` (no later maintenance).

        What a trend can predict at ``day``: it cannot know of maintenance to come.
        ``day`` itself when the wear is already there, inf when never.
        """
        if self.profile == "maintained" and math.isfinite(self.maintenance_day) and day < self.maintenance_day:
            if self.w0 + self.rate * day >= alarm:
                return day
            return day + (alarm - self.w0 - self.rate * day) / self.rate if self.rate > 0 else math.inf
        if float(self.true_wear(day)) >= alarm:
            return day
        lo, hi = day, day + max_days
        if float(self.true_wear(hi)) < alarm:
            return math.inf
        for _ in range(60):  # monotone within a segment
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if float(self.true_wear(mid)) < alarm else (lo, mid)
        return hi


def make_fleet(
    n_joints: int = 120,
    days: int = 240,
    *,
    seed: int = 0,
    mix: Sequence[str] = PROFILES,
    noise: EstimatorNoise = ESTIMATOR_NOISE,
    joints_per_robot: int = 6,
    skip_probability: float = 0.05,
    rng: np.random.Generator | None = None,
) -> list[JointHistory]:
    """``n_joints`` joints (profiles in turn from ``mix``), nightly estimates over ``days`` days."""
    rng = rng if rng is not None else np.random.default_rng(seed)
    out: list[JointHistory] = []
    for i in range(n_joints):
        profile = mix[i % len(mix)]
        robot, joint = f"robot_{i // joints_per_robot + 1:03d}", f"joint_{i % joints_per_robot + 1}"
        w0 = float(rng.uniform(2.0, 15.0))
        if profile == "linear":
            jh = JointHistory(robot, joint, profile, w0, rate=float(rng.uniform(0.06, 0.25)))
        elif profile == "accelerating":
            tau = float(rng.uniform(80.0, 160.0))
            a = float(rng.uniform(0.03, 0.1))  # initial rate, growing as exp(t / tau)
            jh = JointHistory(robot, joint, profile, w0, rate=0.0, accel=a * tau, accel_tau=tau)
        elif profile == "flat":
            jh = JointHistory(robot, joint, profile, w0, rate=float(rng.uniform(0.0, 0.02)))
        elif profile == "maintained":
            md = float(rng.uniform(0.3, 0.6) * days)
            rate = float(rng.uniform(0.08, 0.2))
            # a planned regrease when the wear reached 15-28, before any alarm
            w0 = max(float(rng.uniform(15.0, 28.0)) - rate * md, 1.0)
            jh = JointHistory(robot, joint, profile, w0, rate=rate, maintenance_day=md,
                              reset_wear=float(rng.uniform(1.0, 5.0)))
        else:
            raise ValueError(f"unknown profile {profile!r}; one of {', '.join(PROFILES)}")
        nights = np.arange(days, dtype=float)
        nights = nights[rng.random(days) >= skip_probability]
        hour = 2.0 + rng.uniform(-2.0, 2.0, len(nights))
        day_f = nights + hour / 24.0
        temp = (40.0 + 8.0 * np.sin(2 * np.pi * (day_f + 30.0 * i % 365) / 365.0)
                + 3.0 * np.sin(2 * np.pi * (hour - 9.0) / 24.0) + rng.normal(0.0, 1.0, len(nights)))
        true = jh.true_wear(day_f)
        jh.times = EPOCH0 + day_f * DAY
        jh.true = true
        jh.temperature = temp
        jh.wear_std = noise.std(true)
        jh.wear = true + rng.normal(0.0, 1.0, len(nights)) * noise.error_std(true)
        jh.cycle_ids = np.arange(1, len(nights) + 1)
        out.append(jh)
    return out


def calibrate_estimator_noise(
    wears: Sequence[float] = (5.0, 20.0, 35.0),
    temperatures: Sequence[float] = (32.0, 40.0, 48.0),
    runs: int = 20,
    *,
    method: str = "joint",
    speeds: Sequence[float] = (10, 20, 30, 40, 50, 80, 120, 160),
    noise: float = 0.0015,
    load: float = 0.1,
    seed: int = 0,
) -> dict[str, Any]:
    """Run the real estimator on simulated cycles (Eq. 12 noise); its error and reported std per (wear, T).

    Returns ``{"rows": [{"wear", "temperature", "bias", "std", "reported_std"}], "fit": EstimatorNoise}``
    (per wear: RMS error over the temperatures, mean reported std).
    """
    from ..estimation import make_estimator
    from ..model import load_parameter_set, paper_wear_model
    from ..types import ObservationTable

    rng = np.random.default_rng(seed)
    model, params = paper_wear_model(), load_parameter_set("ref-2011r")
    est = make_estimator(method, params="ref-2011r")
    sp = np.asarray(speeds, float)
    rows = []
    for w in wears:
        for temp in temperatures:
            errs, reps = [], []
            for _ in range(runs):
                tau = np.asarray(model.evaluate(params, speed=sp, load_torque=load, temperature=temp, wear=w))
                obs = ObservationTable({"speed": sp, "tau_f": tau + rng.normal(0.0, noise, len(sp)),
                                        "tau_f_std": np.full(len(sp), noise), "load_torque": np.full(len(sp), load)})
                r = est.estimate(obs)
                errs.append(r.wear - w)
                reps.append(r.wear_std)
            rows.append({"wear": w, "temperature": temp, "bias": float(np.mean(errs)),
                         "std": float(np.std(errs, ddof=1)), "reported_std": float(np.mean(reps))})
    ws = tuple(float(w) for w in wears)
    actual = tuple(float(np.sqrt(np.mean([r["std"] ** 2 + r["bias"] ** 2 for r in rows if r["wear"] == w])))
                   for w in ws)
    reported = tuple(float(np.mean([r["reported_std"] for r in rows if r["wear"] == w])) for w in ws)
    fit = EstimatorNoise(wears=ws, actual=actual, reported=reported)
    return {"rows": rows, "fit": fit}
