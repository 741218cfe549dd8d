"""Wear estimators, the Cramér-Rao bound, test-cycle design and the Section 5.1 study.

Every estimator follows :class:`~jointwear_ros.types.WearEstimator`: a ``name``
and ``estimate(ObservationTable) -> WearResult``. Build one by name with
:func:`make_estimator`.

Pure numpy/scipy; no ROS import.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

from ..errors import InputDataError
from ..model import Model, Parameters, ParameterSet, load_parameter_set_info
from ..types import WearEstimator
from ._common import check_estimator_options, resolve_model, set_frame_table
from .bayes import BayesEstimator
from .crb import (
    CRB_METHODS,
    FisherResult,
    crb_known_temperature,
    crb_multi_speed,
    crb_per_speed,
    fisher_information,
)
from .design import PAPER_SECONDS_PER_SPEED, CycleDesign, design_cycle
from .inverse import TemperatureTable, WearInverse
from .joint import JointEstimator, JointPosterior
from .paper import PAPER_N_SAMPLES, PAPER_TEMPERATURE_RANGE, PaperEstimator, PaperGridEstimator
from .priors import TemperaturePrior, normal_prior, parse_temperature_prior, uniform_prior

__all__ = [
    "CRB_METHODS",
    "ESTIMATOR_METHODS",
    "PAPER_N_SAMPLES",
    "PAPER_SECONDS_PER_SPEED",
    "PAPER_TEMPERATURE_RANGE",
    "BayesEstimator",
    "CycleDesign",
    "FisherResult",
    "JointEstimator",
    "JointPosterior",
    "PaperEstimator",
    "PaperGridEstimator",
    "TemperaturePrior",
    "TemperatureTable",
    "WearInverse",
    "crb_known_temperature",
    "crb_multi_speed",
    "crb_per_speed",
    "design_cycle",
    "fisher_information",
    "make_estimator",
    "normal_prior",
    "parse_temperature_prior",
    "resolve_model",
    "set_frame_table",
    "uniform_prior",
]


_ESTIMATOR_CLASSES: dict[str, type] = {
    "paper": PaperEstimator,
    "paper-grid": PaperGridEstimator,
    "bayes": BayesEstimator,
    "joint": JointEstimator,
}


def _accepted_options(cls: type) -> set[str]:
    """Keyword options of ``cls`` and of the bases its ``**options`` are handed on to."""
    names: set[str] = set()
    for klass in cls.__mro__:
        init = klass.__dict__.get("__init__")
        if init is None:
            continue
        sig = inspect.signature(init)
        names.update(n for n, p in sig.parameters.items()
                     if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD) and n not in ("self", "model", "params"))
        if not any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values()):
            break
    return names


#: Method names accepted by :func:`make_estimator`.
ESTIMATOR_METHODS: tuple[str, ...] = ("paper", "paper-grid", "bayes", "joint")


def make_estimator(
    method: str,
    model: Model | None = None,
    params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
    **options: Any,
) -> WearEstimator:
    """An estimator by name: ``paper``, ``paper-grid``, ``bayes`` or ``joint``.

    ``model`` defaults to Eq. (9), ``params`` to ``ref-2011r`` (a name loads a
    set); ``options`` go to the estimator's constructor (``seed=``, ``rng=``,
    ``n_samples=``, ``temperature_range=``, ``prior=``, ``noise_std=``, ...).

    >>> est = make_estimator("paper", seed=0)
    >>> est.name
    'paper'
    """
    key = str(method).strip().lower()
    if key not in _ESTIMATOR_CLASSES:
        raise InputDataError(f"unknown wear estimation method {method!r}; choose one of {', '.join(ESTIMATOR_METHODS)}")
    cls = _ESTIMATOR_CLASSES[key]
    # an option the estimator does not take is the caller's mistake (exit 2); any other TypeError is a bug
    # inside the estimator and keeps its traceback
    unknown = sorted(set(options) - _accepted_options(cls))
    if unknown:
        raise InputDataError(f"estimator {key!r} takes no option {', '.join(unknown)}; "
                             f"it takes {', '.join(sorted(_accepted_options(cls)))}")
    if isinstance(params, str):
        params = load_parameter_set_info(params)  # a missing set fails here, with its reason
    factor = params.units.torque_factor if isinstance(params, ParameterSet) else 1.0
    check_estimator_options(options, factor)  # values no estimator can work with
    return cls(model, params, **options)  # type: ignore[no-any-return]
