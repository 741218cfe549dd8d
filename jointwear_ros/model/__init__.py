"""The friction and wear model core: terms, shapes, parameters, models, specs, parameter sets.

Pure numpy; no ROS import. Terms compose with ``+``; a model evaluates on
named inputs and reports each term's share:

>>> from jointwear_ros.model import Coulomb, Stribeck, Viscous
>>> m = Coulomb() + Stribeck() + Viscous()
>>> m.equation()
'tau_f = Fc0 + Fs*exp(-|v/vs|^1.3) + Fv*v'
>>> p = m.make_params({"Fc0": 0.04, "Fs": 0.03, "vs": 20.0, "Fv": 4e-4})
>>> [round(float(x), 5) for x in m.evaluate(p, speed=[0.0, 20.0, 100.0])]
[0.07, 0.05904, 0.08001]
>>> {k: round(float(v[1]), 5) for k, v in m.components(p, speed=[0.0, 20.0, 100.0]).items()}
{'coulomb': 0.04, 'stribeck': 0.01104, 'viscous': 0.008}
>>> m.evaluate(p, speed=float("nan"))
Traceback (most recent call last):
...
jointwear_ros.errors.ModelError: model input 'speed' holds nan; the model needs finite values
"""

from __future__ import annotations

from .model import Model, Term
from .parameters import Parameter, Parameters, ParamSpec
from .paramsets import (
    ParameterSet,
    SetUnits,
    available_parameter_sets,
    load_parameter_set,
    load_parameter_set_info,
    parameter_set_document,
)
from .shapes import SHAPES, CandidateTerm, register_shape
from .specs import (
    MODEL_SPECS,
    paper_model,
    paper_wear_model,
    parse_model_spec,
    parse_spec,
    resolve_term,
    split_model_spec,
    standard_model,
)
from .terms import (
    STRIBECK_EXPONENT,
    TERMS,
    Coulomb,
    LoadCoulomb,
    LoadStribeck,
    Stribeck,
    TempStribeck,
    TempViscous,
    Viscous,
    WearStribeck,
    WearViscous,
    stribeck_shape,
    term_by_name,
)

__all__ = [
    "MODEL_SPECS",
    "SHAPES",
    "STRIBECK_EXPONENT",
    "TERMS",
    "CandidateTerm",
    "Coulomb",
    "LoadCoulomb",
    "LoadStribeck",
    "Model",
    "ParamSpec",
    "Parameter",
    "ParameterSet",
    "Parameters",
    "SetUnits",
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
    "parameter_set_document",
    "parse_model_spec",
    "parse_spec",
    "register_shape",
    "resolve_term",
    "split_model_spec",
    "standard_model",
    "stribeck_shape",
    "term_by_name",
]
