"""Friction observer signal processing: test-cycle windows → static friction observations, Eq. (5).

:class:`FrictionObserverCore` is fed plain values by the live node and the
offline replay; :func:`observe_arrays` runs it on whole arrays.
:func:`measure_segment` holds the segmentation rules. Pure numpy; no ROS import.
"""

from __future__ import annotations

from .core import FrictionObserverCore, SampleBuffer, observe_arrays
from .segmentation import batch_means_se, measure_segment
from .types import (
    CYCLE_STATES,
    STATE_ABORTED,
    STATE_DONE,
    STATE_FAILED,
    STATE_IDLE,
    STATE_RUNNING,
    FrictionObservationData,
    ObserverConfig,
    ObserverOutput,
    Rejection,
    SpeedSegment,
)

__all__ = [
    "CYCLE_STATES",
    "STATE_ABORTED",
    "STATE_DONE",
    "STATE_FAILED",
    "STATE_IDLE",
    "STATE_RUNNING",
    "FrictionObservationData",
    "FrictionObserverCore",
    "ObserverConfig",
    "ObserverOutput",
    "Rejection",
    "SampleBuffer",
    "SpeedSegment",
    "batch_means_se",
    "measure_segment",
    "observe_arrays",
]
