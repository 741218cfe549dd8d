"""Wear trend and time to alarm per joint (pure numpy/scipy; no ROS, no database)."""

from __future__ import annotations

from .core import (
    DAY,
    ERROR,
    LEVEL_NAMES,
    OK,
    WARN,
    FilterOutput,
    TimeToAlarm,
    TrendConfig,
    TrendResult,
    TrendStates,
    analyze_joint,
    collapse_revisions,
    crossing_quantiles,
    filter_bank,
    kalman_llt,
    last_segment,
    rts_smooth,
    trend_states,
)

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
    "collapse_revisions",
    "crossing_quantiles",
    "filter_bank",
    "kalman_llt",
    "last_segment",
    "rts_smooth",
    "trend_states",
]
