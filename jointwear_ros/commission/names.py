"""Commissioning's names and constants that need none of its code: what ``jointwear commission``,
``estimate`` and ``demo --help`` show (the wear calibrations, the fewest baseline cycles), without numpy.

>>> WEAR_CALIBRATIONS, DEFAULT_WEAR_CALIBRATION, MIN_BASELINE_CYCLES
(('midpoint', 'paper', 'relative'), 'midpoint', 4)
"""

from __future__ import annotations

__all__ = ["DEFAULT_WEAR_CALIBRATION", "MIN_BASELINE_CYCLES", "WEAR_CALIBRATIONS"]

#: The wear calibration a commissioned set gets unless told otherwise (measured: docs/commissioning.md).
DEFAULT_WEAR_CALIBRATION = "midpoint"
#: The wear calibrations by name (the priors); a FILE calibrates.
WEAR_CALIBRATIONS = ("midpoint", "paper", "relative")
#: Fewest baseline cycles the demo runs (commissioning needs 4; the overloaded one does not count).
MIN_BASELINE_CYCLES = 4
