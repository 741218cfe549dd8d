"""The model workbench: fit, compare, diagnose the missing effect, add it, keep a history.

Pure numpy/scipy (plus matplotlib for plots in :mod:`.report`); no ROS import.
"""

from __future__ import annotations

from ..model.scaling import BoundHit, DataScales, on_bound, scale_parameters
from ..model.shapes import SHAPES, CandidateTerm, HarmonicRipple, Scale, Spline, Step, register_shape
from ..model.specs import ENTRY_POINT_GROUP, parse_spec, resolve_term
from .candidates import candidate_library, candidate_variables
from .compare import (
    SPEED_BAND_EDGES,
    BandError,
    NoiseFloor,
    band_rmse,
    noise_floor,
    noise_test,
    residual_structure,
    sweep_scatter,
)
from .dependence import VariableDependence, residual_dependence
from .diagnose import VERDICTS, CandidateResult, Diagnosis, diagnose
from .fit import FitResult, fit_model, group_folds

__all__ = [
    "ENTRY_POINT_GROUP",
    "SHAPES",
    "SPEED_BAND_EDGES",
    "VERDICTS",
    "BandError",
    "BoundHit",
    "CandidateResult",
    "CandidateTerm",
    "DataScales",
    "Diagnosis",
    "FitResult",
    "HarmonicRipple",
    "NoiseFloor",
    "Scale",
    "Spline",
    "Step",
    "VariableDependence",
    "band_rmse",
    "candidate_library",
    "candidate_variables",
    "diagnose",
    "fit_model",
    "group_folds",
    "noise_floor",
    "noise_test",
    "on_bound",
    "parse_spec",
    "register_shape",
    "residual_dependence",
    "residual_structure",
    "resolve_term",
    "scale_parameters",
    "sweep_scatter",
]
