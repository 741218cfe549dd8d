"""Friction observer signal processing: test-cycle windows → static friction observations, Eq. (5).

:class:`RobotObserver` (one :class:`FrictionObserverCore` per joint, and the routing of the
inputs to them) is fed plain values by the live node and the offline replay;
:func:`observe_arrays` runs one core on whole arrays.
:func:`measure_segment` holds the segmentation rules. :class:`ProductionObserver` (and
:func:`observe_production` on recorded arrays) finds friction in the robot's own program instead of a test
cycle (docs/production.md). Pure numpy; no ROS import.
"""

from __future__ import annotations

from .core import FrictionObserverCore, SampleBuffer, observe_arrays
from .production import (
    KINDS,
    REASONS,
    JointShiftCounts,
    ProductionConfig,
    ProductionObserver,
    ProductionShift,
    observe_production,
)
from .robot import JointStateOutcome, RobotObserver, Routed, receipt_stamp
from .segmentation import batch_means_se, measure_segment
from .types import (
    FrictionObservationData,
    ObserverConfig,
    ObserverOutput,
    Rejection,
    SpeedSegment,
)

__all__ = [
    "KINDS",
    "REASONS",
    "FrictionObservationData",
    "FrictionObserverCore",
    "JointShiftCounts",
    "JointStateOutcome",
    "ObserverConfig",
    "ObserverOutput",
    "ProductionConfig",
    "ProductionObserver",
    "ProductionShift",
    "Rejection",
    "RobotObserver",
    "Routed",
    "SampleBuffer",
    "SpeedSegment",
    "batch_means_se",
    "measure_segment",
    "observe_arrays",
    "observe_production",
    "receipt_stamp",
]
