"""Wear estimators, the Cramér-Rao bound, test-cycle design and the Section 5.1 study.

Every estimator follows :class:`~jointwear_ros.types.WearEstimator`: a ``name``
and ``estimate(ObservationTable) -> WearResult``, and declares what it can do in
``capabilities`` (:class:`Capabilities`). :data:`ESTIMATORS` is the one registry of
them by name (:mod:`.registry`); build one by name with :func:`make_estimator`.

Pure numpy/scipy; no ROS import. Importing the package (or its light module :mod:`.names`) imports
none of its modules, not even numpy: each name loads its module on first use (PEP 562), so a command
line's ``--help`` stays quick. ``wear_scale`` stays the function (its module is
``jointwear_ros.estimation.wear_scale``), as it was when the package imported everything.

>>> list(ESTIMATORS)
['paper', 'paper-grid', 'bayes', 'joint']
>>> ESTIMATORS.capabilities("joint").cycle, ESTIMATORS.capabilities("paper").temperature_assumption
(True, 'range')
"""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING, Any

from ..errors import InputDataError  # noqa: F401 - the registry's error, as the package gave it before
from ..lazy import lazy_names
from .names import ESTIMATOR_NAMES, PAPER_SECONDS_PER_SPEED

if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and readers
    from ._common import Capabilities, capabilities_of, resolve_model, set_frame_table
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
    from .wear_scale import WearScale, WearScaledEstimator, wear_scale

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
    **dict.fromkeys(("Capabilities", "capabilities_of", "resolve_model", "set_frame_table"), "_common"),
    **dict.fromkeys(("WearScale", "WearScaledEstimator", "wear_scale"), "wear_scale"),
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


__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())


class _Package(types.ModuleType):
    """This package, whose names of :data:`_LAZY` a submodule of the same name does not cover."""

    def __setattr__(self, name: str, value: Any) -> None:
        # the import system binds a loaded submodule on its package: not over a name the package gives
        # (``wear_scale`` the function, not ``wear_scale`` the module)
        if name in _LAZY and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
