"""The friction and wear model core: terms, parameters, models, parameter sets.

Pure numpy; no ROS import.
"""

from __future__ import annotations

from .model import MODEL_SPECS, Model, paper_model, paper_wear_model, parse_model_spec, standard_model
from .parameters import Parameter, Parameters, ParamSpec
from .paramsets import ParameterSet, available_parameter_sets, load_parameter_set, load_parameter_set_info
from .terms import (
    STRIBECK_EXPONENT,
    TERMS,
    Coulomb,
    LoadCoulomb,
    LoadStribeck,
    Stribeck,
    TempStribeck,
    TempViscous,
    Term,
    Viscous,
    WearStribeck,
    WearViscous,
    stribeck_shape,
    term_by_name,
)

__all__ = [
    "MODEL_SPECS",
    "Model",
    "paper_model",
    "paper_wear_model",
    "parse_model_spec",
    "standard_model",
    "Parameter",
    "Parameters",
    "ParamSpec",
    "ParameterSet",
    "available_parameter_sets",
    "load_parameter_set",
    "load_parameter_set_info",
    "STRIBECK_EXPONENT",
    "TERMS",
    "Term",
    "Coulomb",
    "LoadCoulomb",
    "LoadStribeck",
    "Stribeck",
    "TempStribeck",
    "TempViscous",
    "Viscous",
    "WearStribeck",
    "WearViscous",
    "stribeck_shape",
    "term_by_name",
]
