"""The trend's settings (:class:`TrendConfig`) and its time unit (pure: no ROS, no io).

The settings the ``wear_trend`` node takes as parameters are declared with
:func:`~jointwear_ros.settings.setting` (description, unit, range, and the parameter's name where it is not
the field's: ``alarm`` and ``warn`` are the node's ``alarm_threshold`` and ``warn_threshold``, the names it
shares with the wear_estimator): :func:`jointwear_ros.settings.declarations` builds the node's declarations
from them and :func:`~jointwear_ros.settings.from_mapping` the config from the node's parameter values, as for
every other config. The bank's other settings are not node parameters.

>>> from jointwear_ros.settings import declarations, from_mapping
>>> [(d.name, d.default, d.min, d.max) for d in declarations(TrendConfig)][:2]
[('alarm_threshold', 35.0, 0.0, 100.0), ('warn_threshold', 30.0, 0.0, 100.0)]
>>> cfg = from_mapping(TrendConfig, {"alarm_threshold": 40, "horizon_days": 10.0, "robot": "robot_1"})
>>> cfg.alarm, cfg.horizon_days, cfg.min_estimates
(40.0, 10.0, 5)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..errors import InputDataError
from ..settings import check_ranges, setting

__all__ = ["DAY", "TrendConfig"]

DAY = 86400.0

Array = NDArray[np.float64]


@dataclass(frozen=True)
class TrendConfig:
    """Settings of the trend model and of the levels.

    ``alarm``, ``warn``, ``horizon_days`` and ``min_estimates`` are also parameters of the
    ``wear_trend`` node (``alarm`` and ``warn`` as ``alarm_threshold`` and ``warn_threshold``); the others are the bank's and not node parameters.

    Attributes
    ----------
    alarm : wear at which the alarm is raised (35, the paper's).
    warn : wear of the warning level (the condition level's WARN band starts there).
    horizon_days : the forecast says "alarm expected within" when the 90 % interval's lower bound of the time
        to alarm is within it (the forecast; it does not change the condition level).
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
    evidence_temperature : the members' log evidences are divided by it before they are weighed (> 1 tempers).
    min_estimates : estimates a segment needs before it has a trend.
    growth_probability : ``P(rate > 0)`` needed to call it growth.
    max_horizon_days : times to alarm beyond it are reported as infinite.
    revision_window_s : estimates with the same cycle id within this many seconds are one cycle (revisions).
    """

    alarm: float = setting(35.0, description="wear at which the condition level is ERROR", range=(0.0, 100.0),
                           param="alarm_threshold")
    warn: float = setting(30.0, description="wear at which the condition level is WARN", range=(0.0, 100.0),
                          param="warn_threshold")
    horizon_days: float = setting(
        30.0, description="WARN when the 90 % interval's lower bound of the time to alarm is within this many days",
        unit="days", range=(0.0, 3650.0))
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
    min_estimates: int = setting(5, description="estimates a segment needs before it has a trend",
                                 range=(2, 100_000))
    growth_probability: float = 0.95
    max_horizon_days: float = 3650.0
    revision_window_s: float = 3600.0

    def __post_init__(self) -> None:
        check_ranges(self, InputDataError, "trend setting")
        for name, allow_empty in (("accel_noise", True), ("jerk_noise", True), ("efold_days", True)):
            q = getattr(self, name)
            qs = (q,) if isinstance(q, (int, float)) else tuple(q)
            if (not qs and not allow_empty) or not all(math.isfinite(float(x)) and float(x) >= 0 for x in qs):
                raise InputDataError(f"trend setting {name} = {q!r} must be finite numbers >= 0")
            object.__setattr__(self, name, tuple(float(x) for x in qs))
        if any(e <= 0 for e in self.efold_days):
            raise InputDataError(f"trend setting efold_days = {self.efold_days!r} must be > 0 days")
        for name in ("level_noise", "slope_prior_std", "accel_prior_std",
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
