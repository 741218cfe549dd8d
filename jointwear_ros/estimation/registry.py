"""The one registry of wear estimators by name (:data:`ESTIMATORS`) and :func:`make_estimator`.

Its built-in estimators are :data:`~jointwear_ros.estimation.names.ESTIMATOR_NAMES`, the light list a
command line's ``--help`` names them by (checked here at import, so the two cannot drift).
"""

from __future__ import annotations

import inspect
from collections.abc import Iterator, Mapping
from dataclasses import fields
from typing import Any

from ..errors import InputDataError
from ..model import Model, Parameters, ParameterSet, load_parameter_set_info
from ..types import WearEstimator
from ._common import Capabilities, capabilities_of, check_estimator_options
from .bayes import BayesEstimator
from .joint import JointEstimator
from .names import ESTIMATOR_NAMES
from .paper import PaperEstimator, PaperGridEstimator
from .wear_scale import WearScaledEstimator, wear_scale

__all__ = ["ENTRY_POINT_GROUP", "ESTIMATORS", "EstimatorRegistry", "make_estimator", "register_estimator"]


class EstimatorRegistry(Mapping[str, type]):
    """The wear estimators by name: the one list every part of jointwear asks.

    ``name -> class``, in registration order. Each class has a ``name`` and may declare
    ``capabilities`` (:class:`Capabilities`); :meth:`options` are the keyword options its
    constructor takes. :meth:`register` adds a class (usable as a decorator); a name not
    registered is looked up once in the entry point group ``jointwear.estimators`` (an installed
    package's estimators, without an import), as the workbench's terms are in ``jointwear.terms``.

    >>> list(ESTIMATORS)
    ['paper', 'paper-grid', 'bayes', 'joint']
    >>> ESTIMATORS.capabilities("joint").cycle, ESTIMATORS.capabilities("paper").temperature_assumption
    (True, 'range')
    """

    def __init__(self, *classes: type) -> None:
        self._classes: dict[str, type] = {}
        for cls in classes:
            self.register(cls)

    def register(self, cls: type, *, replace: bool = False) -> type:
        """Add ``cls`` under its ``name`` (lowercase); a name already taken by another class is an error."""
        name = str(getattr(cls, "name", "") or "").strip().lower()
        if not name or not callable(getattr(cls, "estimate", None)):
            raise InputDataError(f"estimator class {cls.__qualname__}: needs a 'name' and an estimate() method "
                                 "(jointwear_ros.types.WearEstimator)")
        old = self._classes.get(name)
        if old is not None and old is not cls and not replace:
            raise InputDataError(f"estimator name {name!r} is taken by {old.__module__}.{old.__qualname__}; "
                                 "choose another name")
        self._classes[name] = cls
        return cls

    def __getitem__(self, name: str) -> type:
        key = str(name).strip().lower()
        cls = self._classes.get(key)
        if cls is None:
            cls = _entry_point_estimator(key)
            if cls is None:
                raise KeyError(name)
            self.register(cls)
        return cls

    def __contains__(self, name: object) -> bool:
        try:
            self[str(name)]
        except (KeyError, InputDataError):
            return False
        return True

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._classes))

    def __len__(self) -> int:
        return len(self._classes)

    def names(self) -> tuple[str, ...]:
        """The registered names, in order (entry points count once they are used)."""
        return tuple(self._classes)

    def get_class(self, method: str) -> type:
        """The class of ``method`` (case and spaces ignored), else :class:`InputDataError` listing the names."""
        try:
            return self[method]
        except KeyError:
            raise InputDataError(f"unknown wear estimation method {method!r}; choose one of "
                                 f"{', '.join(self)}") from None

    def capabilities(self, method: str) -> Capabilities:
        """What ``method`` declares it can do (:class:`Capabilities`)."""
        return capabilities_of(self.get_class(method))

    def options(self, method: str) -> set[str]:
        """The keyword options ``method``'s constructor takes (besides model and params)."""
        return _accepted_options(self.get_class(method))

    def table(self) -> list[dict[str, Any]]:
        """One row per estimator: name, summary, capability flags and options (for docs and ``--json``)."""
        rows = []
        for name, cls in self._classes.items():
            caps = capabilities_of(cls)
            rows.append({"name": name, **{f.name: getattr(caps, f.name) for f in fields(caps)},
                         "options": sorted(_accepted_options(cls))})
        return rows


#: Entry point group of installed packages' estimators (``name = "pkg.module:Class"``).
ENTRY_POINT_GROUP = "jointwear.estimators"


def _entry_point_estimator(name: str) -> type | None:
    from importlib import metadata

    try:
        eps = [ep for ep in metadata.entry_points(group=ENTRY_POINT_GROUP) if ep.name.strip().lower() == name]
    except Exception:
        return None
    if not eps:
        return None
    try:
        cls = eps[0].load()
    except Exception as exc:
        raise InputDataError(f"estimator {name!r} (entry point {eps[0].value!r} of {ENTRY_POINT_GROUP}) "
                             f"cannot be loaded: {exc}") from None
    if not isinstance(cls, type) or str(getattr(cls, "name", "")).strip().lower() != name:
        raise InputDataError(f"entry point {name!r} of {ENTRY_POINT_GROUP} ({eps[0].value!r}) is not an estimator "
                             f"class named {name!r}")
    return cls


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


#: The estimators by name; :func:`make_estimator`, the nodes' ``method``, the CLI and the studies ask it.
ESTIMATORS = EstimatorRegistry(PaperEstimator, PaperGridEstimator, BayesEstimator, JointEstimator)
#: Add an estimator class under its ``name`` (a decorator too): ``ESTIMATORS.register``.
register_estimator = ESTIMATORS.register
if ESTIMATORS.names() != ESTIMATOR_NAMES:  # pragma: no cover - a built-in estimator renamed, added or removed
    raise ImportError(f"estimation.names.ESTIMATOR_NAMES {ESTIMATOR_NAMES} is not the registry's built-in "
                      f"estimators {ESTIMATORS.names()}: update names.py")


def make_estimator(
    method: str,
    model: Model | None = None,
    params: Parameters | Mapping[str, float] | str | ParameterSet | None = None,
    **options: Any,
) -> WearEstimator:
    """An estimator by name: one of :data:`ESTIMATORS` (``paper``, ``paper-grid``, ``bayes``, ``joint``, and
    any registered one).

    ``model`` defaults to Eq. (9), ``params`` to ``ref-2011r`` (a name loads a
    set); ``options`` go to the estimator's constructor (``seed=``, ``rng=``,
    ``n_samples=``, ``temperature_range=``, ``prior=``, ``noise_std=``, ...).

    >>> est = make_estimator("paper", seed=0)
    >>> est.name
    'paper'
    """
    cls: Any = ESTIMATORS.get_class(method)  # a WearEstimator class: it has a name
    key = str(cls.name).strip().lower()
    # an option the estimator does not take is the caller's mistake (exit 2); any other TypeError is a bug
    # inside the estimator and keeps its traceback
    accepted = _accepted_options(cls)
    unknown = sorted(set(options) - accepted)
    if unknown:
        raise InputDataError(f"estimator {key!r} takes no option {', '.join(unknown)}; "
                             f"it takes {', '.join(sorted(accepted))}")
    if isinstance(params, str):
        params = load_parameter_set_info(params)  # a missing set fails here, with its reason
    factor = params.units.torque_factor if isinstance(params, ParameterSet) else 1.0
    check_estimator_options(options, factor)  # values no estimator can work with
    est = cls(model, params, **options)
    return WearScaledEstimator(est, wear_scale(params if isinstance(params, ParameterSet) else None))
