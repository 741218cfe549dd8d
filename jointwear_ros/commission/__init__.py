"""Commissioning: a real joint's own model from its baseline cycles, and its wear calibration.

Pure numpy/scipy (the fit and the verdict through :mod:`jointwear_ros.workbench`);
no ROS import. The CLI (``jointwear commission``, ``jointwear estimate``) wraps it.
"""

from __future__ import annotations

from .core import (
    MIN_CYCLES,
    MIN_LOAD_SPAN,
    MIN_SPEEDS,
    MIN_TEMPERATURE_SPAN,
    CommissionError,
    CommissionResult,
    commission,
    nominal_spec,
)
from .estimate import CycleEstimate, estimate_cycles
from .wear import DEFAULT_WEAR_CALIBRATION, WearCalibration, paper_wear_values, relative_wear_values, wear_from_file

__all__ = [
    "DEFAULT_WEAR_CALIBRATION",
    "MIN_CYCLES",
    "MIN_LOAD_SPAN",
    "MIN_SPEEDS",
    "MIN_TEMPERATURE_SPAN",
    "CommissionError",
    "CommissionResult",
    "CycleEstimate",
    "WearCalibration",
    "commission",
    "estimate_cycles",
    "nominal_spec",
    "paper_wear_values",
    "relative_wear_values",
    "wear_from_file",
]
