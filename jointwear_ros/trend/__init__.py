"""Wear trend and time to alarm per joint (pure numpy/scipy; no ROS, no database).

Modules by role, each importing only those before it in this list: ``config`` (:class:`TrendConfig`, the
settings), ``members`` (the bank's models and the prior they start from), ``filters`` (their fits: Kalman
filters, closed-form regressions), ``alarm`` (time to alarm, forecast band), ``states`` (the model-averaged
trend after each estimate, the forecast's levels), ``prior`` (the fleet as a prior), ``segments`` (segments
and revisions), ``analysis`` (:func:`analyze_joint`: one joint's trend); above them ``backtest``, ``families``
and ``report``; ``ondemand`` (:class:`OnDemandPolicy`: the test cycle on demand) and ``year`` (:func:`simulate_year`:
a simulated year of production estimates against a nightly cycle).
"""

from __future__ import annotations

from .alarm import TimeToAlarm, crossing_cdf, crossing_quantiles, forecast_band
from .analysis import TrendResult, analyze_joint
from .config import DAY, TrendConfig
from .filters import FilterOutput, filter_bank, kalman_llt, rts_smooth
from .members import Component, Member, RatePrior, bank_members
from .ondemand import Decision, OnDemandConfig, OnDemandLedger, OnDemandPolicy
from .prior import SiblingFit, fleet_prior, pool_prior, sibling_fit, type2_weights
from .segments import collapse_revisions, current_segment, last_segment
from .states import TrendStates, trend_states
from .year import WearPath, YearResult, simulate_year

__all__ = [
    "DAY",
    "Component",
    "Decision",
    "FilterOutput",
    "Member",
    "OnDemandConfig",
    "OnDemandLedger",
    "OnDemandPolicy",
    "RatePrior",
    "SiblingFit",
    "TimeToAlarm",
    "TrendConfig",
    "TrendResult",
    "TrendStates",
    "WearPath",
    "YearResult",
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
    "simulate_year",
    "trend_states",
    "type2_weights",
]
