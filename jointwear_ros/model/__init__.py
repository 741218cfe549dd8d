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
    "STRIBECK_EXPONENT",
    "TERMS",
    "Coulomb",
    "LoadCoulomb",
    "LoadStribeck",
    "Model",
    "ParamSpec",
    "Parameter",
    "ParameterSet",
    "Parameters",
    "Stribeck",
    "TempStribeck",
    "TempViscous",
    "Term",
    "Viscous",
    "WearStribeck",
    "WearViscous",
    "available_parameter_sets",
    "load_parameter_set",
    "load_parameter_set_info",
    "paper_model",
    "paper_wear_model",
    "parse_model_spec",
    "standard_model",
    "stribeck_shape",
    "term_by_name",
]
