"""The wear monitor: a test cycle's friction observations → wear estimate → diagnostic level.

Pure; no ROS import. The wear_estimator node and the offline replay share it.
"""

from __future__ import annotations

from .core import (
    ERROR,
    LEVEL_NAMES,
    OK,
    WARN,
    CycleResult,
    MonitorConfig,
    WearMonitor,
    cycle_seed,
    diagnostic_level,
    observations_table,
)
from .validation import PLAUSIBLE_TEMPERATURE, screen_observation

__all__ = [
    "ERROR",
    "LEVEL_NAMES",
    "OK",
    "PLAUSIBLE_TEMPERATURE",
    "WARN",
    "CycleResult",
    "MonitorConfig",
    "WearMonitor",
    "cycle_seed",
    "diagnostic_level",
    "observations_table",
    "screen_observation",
]
