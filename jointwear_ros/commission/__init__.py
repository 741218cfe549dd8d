"""Commissioning: a real joint's own model from its baseline cycles, and its wear calibration.

Pure numpy/scipy (the fit and the verdict through :mod:`jointwear_ros.workbench`);
no ROS import. The CLI (``jointwear commission``, ``jointwear estimate``) wraps it.
Importing the package imports none of its modules: each name loads its module on first use
(PEP 562), so a parser reads the constants of :mod:`.names` (the wear calibrations, the demo's
``MIN_BASELINE_CYCLES``) without numpy or the fit's scipy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names

if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and readers
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

#: The module of each name of :data:`__all__`.
_LAZY: dict[str, str] = {
    **dict.fromkeys(("MIN_CYCLES", "MIN_LOAD_SPAN", "MIN_SPEEDS", "MIN_TEMPERATURE_SPAN", "CommissionError",
                     "CommissionResult", "commission", "nominal_spec"), "core"),
    **dict.fromkeys(("CycleEstimate", "estimate_cycles"), "estimate"),
    **dict.fromkeys(("DEFAULT_WEAR_CALIBRATION", "WearCalibration", "paper_wear_values", "relative_wear_values",
                     "wear_from_file"), "wear"),
}


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())
