"""Wear estimators, the Cramér-Rao bound, test-cycle design and the Section 5.1 study.

Every estimator follows :class:`~jointwear_ros.types.WearEstimator`: a ``name``
and ``estimate(ObservationTable) -> WearResult``, and declares what it can do in
``capabilities`` (:class:`Capabilities`). :data:`ESTIMATORS` is the one registry of
them by name (:mod:`.registry`); build one by name with :func:`make_estimator`.

Pure numpy/scipy; no ROS import. Importing the package (or its light modules :mod:`.names`,
``_common``, ``wear_scale``) imports no scipy: the estimators, the bound and the design load on first
use of their names (PEP 562), so a command line's ``--help`` stays quick.

>>> list(ESTIMATORS)
['paper', 'paper-grid', 'bayes', 'joint']
>>> ESTIMATORS.capabilities("joint").cycle, ESTIMATORS.capabilities("paper").temperature_assumption
(True, 'range')
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._common import Capabilities, capabilities_of, resolve_model, set_frame_table
from .names import ESTIMATOR_NAMES, PAPER_SECONDS_PER_SPEED
from .wear_scale import WearScale, WearScaledEstimator, wear_scale

if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and readers
    from .bayes import BayesEstimator
    from .crb import (
        CRB_METHODS,
        FisherResult,
        crb_known_temperature,
        crb_multi_speed,
        crb_per_speed,
        fisher_information,
    )
    from .design import CycleDesign, design_cycle
    from .inverse import TemperatureTable, WearInverse
    from .joint import JointEstimator, JointPosterior
    from .paper import PAPER_N_SAMPLES, PAPER_TEMPERATURE_RANGE, PaperEstimator, PaperGridEstimator
    from .priors import TemperaturePrior, normal_prior, parse_temperature_prior, uniform_prior
    from .registry import ENTRY_POINT_GROUP, ESTIMATORS, EstimatorRegistry, make_estimator, register_estimator

__all__ = [
    "CRB_METHODS",
    "ENTRY_POINT_GROUP",
    "ESTIMATORS",
    "ESTIMATOR_NAMES",
    "PAPER_N_SAMPLES",
    "PAPER_SECONDS_PER_SPEED",
    "PAPER_TEMPERATURE_RANGE",
    "BayesEstimator",
    "Capabilities",
    "CycleDesign",
    "EstimatorRegistry",
    "FisherResult",
    "JointEstimator",
    "JointPosterior",
    "PaperEstimator",
    "PaperGridEstimator",
    "TemperaturePrior",
    "TemperatureTable",
    "WearInverse",
    "WearScale",
    "WearScaledEstimator",
    "capabilities_of",
    "crb_known_temperature",
    "crb_multi_speed",
    "crb_per_speed",
    "design_cycle",
    "fisher_information",
    "make_estimator",
    "normal_prior",
    "parse_temperature_prior",
    "register_estimator",
    "resolve_model",
    "set_frame_table",
    "uniform_prior",
    "wear_scale",
]

#: The names this package loads on first use, and the module of each (the ones that import scipy).
_LAZY: dict[str, str] = {
    **dict.fromkeys(("BayesEstimator",), "bayes"),
    **dict.fromkeys(("CRB_METHODS", "FisherResult", "crb_known_temperature", "crb_multi_speed", "crb_per_speed",
                     "fisher_information"), "crb"),
    **dict.fromkeys(("CycleDesign", "design_cycle"), "design"),
    **dict.fromkeys(("TemperatureTable", "WearInverse"), "inverse"),
    **dict.fromkeys(("JointEstimator", "JointPosterior"), "joint"),
    **dict.fromkeys(("PAPER_N_SAMPLES", "PAPER_TEMPERATURE_RANGE", "PaperEstimator", "PaperGridEstimator"), "paper"),
    **dict.fromkeys(("TemperaturePrior", "normal_prior", "parse_temperature_prior", "uniform_prior"), "priors"),
    **dict.fromkeys(("ENTRY_POINT_GROUP", "ESTIMATORS", "EstimatorRegistry", "make_estimator",
                     "register_estimator"), "registry"),
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
