"""The wear monitor: a test cycle's (or a production shift's) friction observations → wear estimate → diagnostic level.

Pure; no ROS import. :class:`RobotMonitor` holds one :class:`WearMonitor` per joint and routes the
observations and statuses to them; the wear_estimator node and the offline replay share it.
"""

from __future__ import annotations

from .core import (
    CycleKey,
    CycleResult,
    EstimatorFactory,
    MonitorConfig,
    WearMonitor,
    cycle_label,
    cycle_seed,
    diagnostic_level,
    observations_table,
)
from .production import ShiftEstimate, estimate_shift
from .robot import RobotMonitor
from .validation import PLAUSIBLE_TEMPERATURE, screen_observation

__all__ = [
    "PLAUSIBLE_TEMPERATURE",
    "CycleKey",
    "CycleResult",
    "EstimatorFactory",
    "MonitorConfig",
    "RobotMonitor",
    "ShiftEstimate",
    "WearMonitor",
    "cycle_label",
    "cycle_seed",
    "diagnostic_level",
    "estimate_shift",
    "observations_table",
    "screen_observation",
]
