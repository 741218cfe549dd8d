"""A friction model: a sum of terms, evaluated on named input arrays; and the base of every term.

:class:`Term` (one physical effect) and :class:`Model` (their sum) live together, as lmfit's ``Model``
and its composite do: ``Coulomb() + Viscous()`` is a :class:`Model`. The built-in terms are in
:mod:`.terms`; named models and spec strings (``"paper + ripple(position)"``) in :mod:`.specs`.

>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> m = paper_wear_model()
>>> p = load_parameter_set("ref-2011r")
>>> round(float(m.evaluate(p, speed=47.0, load_torque=0.1, temperature=40.0, wear=35.0)), 5)
0.09072
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from ..errors import ModelError, ParameterError
from .dimensions import REFERENCE_SPEED, Dimension, Relative, decade, largest_abs, scale_factor, unit_dimension
from .parameters import Parameter, Parameters, ParamSpec

__all__ = ["Model", "PreparedModel", "Term"]

Array = npt.NDArray[np.float64]
Inputs = Mapping[str, Array]
Values = Mapping[str, float]

#: 0 K in degC: the model refuses temperatures below it.
ABSOLUTE_ZERO = -273.15

#: Default values of inputs a term may use but the data does not give.
_INPUT_ALIASES = {"v": "speed", "tau_m": "load_torque", "T": "temperature", "w": "wear"}


class Term:
    """Base of every friction term.

    Subclasses set ``name``, ``variables`` (input names used), ``params``
    (a tuple of :class:`ParamSpec`), ``equation`` (readable formula) and
    implement :meth:`value`. Built-in terms also implement
    :meth:`param_gradient` and :meth:`input_gradient` analytically; a user
    term that does not gets central differences from this base class.
    """

    name: ClassVar[str] = "term"
    variables: ClassVar[tuple[str, ...]] = ()
    params: ClassVar[tuple[ParamSpec, ...]] = ()
    equation: ClassVar[str] = ""
    paper_ref: ClassVar[str] = ""
    #: Dimensions of the parameters whose unit does not imply it (see :data:`UNIT_DIMENSIONS`).
    dimensions: ClassVar[Mapping[str, Dimension]] = {}
    # -- workbench hints (as lmfit's Model carries its param hints and ``guess``) ----------
    #: Parameters the term is linear in: a fit solves them by linear least squares given the others
    #: (a candidate starts them at 0).
    linear: ClassVar[tuple[str, ...]] = ()
    #: Starting points of the nonlinear parameters to try, in the numbers the defaults are written in
    #: (the paper's joint); :meth:`guess` moves them to the data's units.
    starts: ClassVar[tuple[Mapping[str, float], ...]] = ()
    #: What the term means physically, in a few words (the diagnosis lists it with the candidate).
    meaning: ClassVar[str] = ""
    #: The diagnosis offers the term as a candidate effect when the data has its inputs and the model lacks it.
    candidate: ClassVar[bool] = False
    #: Start and bounds of each parameter relative to the data's level of its dimension (:class:`Relative`),
    #: for a fit that has no parameter set to start from (commissioning): positive speeds and Coulomb
    #: levels, wide elsewhere.
    relative: ClassVar[Mapping[str, Relative]] = {}

    def start_points(self, x: Inputs) -> list[dict[str, float]]:
        """Starting points of the nonlinear parameters for inputs ``x``, in the numbers of the term's defaults.

        :attr:`starts` by default; a term whose starts depend on the data (a
        column's span) overrides this.
        """
        return [dict(s) for s in self.starts] or [{}]

    def guess(self, x: Inputs) -> list[dict[str, float]]:
        """Starting points of the nonlinear parameters for data ``x``, in the data's own units.

        :meth:`start_points` with each parameter moved by the data's speed scale
        to the power of its :meth:`dimension` (:mod:`jointwear_ros.model.scaling`):
        joint-side data at a few rad/s get Stribeck speeds inside their own range;
        data at the paper's scale keep the numbers as written.

        >>> from jointwear_ros.model.terms import LoadStribeck
        >>> [g["vstm"] for g in LoadStribeck().guess({"speed": np.array([0.01, 2.5])})]
        [0.04, 0.12, 0.3, 0.8]
        """
        grid = self.start_points(x)
        speed = decade(largest_abs(x.get("speed")) / REFERENCE_SPEED)  # DataScales.of(speed=...).speed
        if speed == 1.0:
            return grid
        return [{k: v * scale_factor(self.dimension(k), torque=1.0, speed=speed) for k, v in g.items()}
                for g in grid]

    def describe_effect(self) -> str:
        """What the term means physically: :attr:`meaning`, else the first line of its docstring."""
        if self.meaning:
            return self.meaning
        doc = (type(self).__doc__ or "").strip().splitlines()
        return doc[0] if doc else self.name

    def dimension(self, name: str) -> Dimension:
        """The dimension of parameter ``name``: declared in :attr:`dimensions`, else implied by its unit."""
        if name in self.dimensions:
            return self.dimensions[name]
        return unit_dimension(next((p.unit for p in self.params if p.name == name), ""))

    # -- composition ---------------------------------------------------------
    def __add__(self, other: Term | Model) -> Model:
        return Model([self]) + other

    def __radd__(self, other: object) -> Model:
        if other == 0:  # sum([...]) support
            return Model([self])
        return NotImplemented

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and self.name == getattr(other, "name", None)

    def __hash__(self) -> int:
        return hash((type(self), self.name))

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.params)

    # -- evaluation ----------------------------------------------------------
    def value(self, x: Inputs, p: Values) -> Array:  # pragma: no cover - abstract
        raise NotImplementedError

    def param_gradient(self, x: Inputs, p: Values) -> dict[str, Array]:
        """d value / d parameter, for each of this term's parameters."""
        out: dict[str, Array] = {}
        for spec in self.params:
            h = 1e-6 * max(1.0, abs(p[spec.name]))
            hi = dict(p)
            lo = dict(p)
            hi[spec.name] += h
            lo[spec.name] -= h
            out[spec.name] = (self.value(x, hi) - self.value(x, lo)) / (2 * h)
        return out

    def input_gradient(self, x: Inputs, p: Values, var: str) -> Array:
        """d value / d input variable ``var`` (zero if the term does not use it)."""
        if var not in self.variables:
            return np.zeros(np.broadcast(*[np.asarray(a) for a in x.values()]).shape)
        base = np.asarray(x[var], dtype=float)
        h = 1e-6 * np.maximum(1.0, np.abs(base))
        hi = dict(x)
        lo = dict(x)
        hi[var] = base + h
        lo[var] = base - h
        return (self.value(hi, p) - self.value(lo, p)) / (2 * h)

    @classmethod
    def describe(cls) -> str:
        """One line: name, equation and paper reference."""
        ref = f"  [{cls.paper_ref}]" if cls.paper_ref else ""
        return f"{cls.name}: {cls.equation}{ref}"


class Model:
    """A static friction model: the sum of its terms.

    Build one with ``+`` (``Coulomb() + Viscous()``) or :func:`~.specs.parse_model_spec`.
    Parameter names must be distinct across terms; a clash is an error.
    """

    def __init__(self, terms: Iterable[Term]) -> None:
        self.terms: list[Term] = []
        seen: dict[str, str] = {}
        for t in terms:
            if any(type(t) is type(u) and t.name == u.name for u in self.terms):
                raise ModelError(f"term {t.name!r} appears twice in the model")
            for pn in t.param_names:
                if pn in seen:
                    raise ModelError(
                        f"parameter name clash: {pn!r} is used by both {seen[pn]!r} and {t.name!r}"
                    )
                seen[pn] = t.name
            self.terms.append(t)
        if not self.terms:
            raise ModelError("a model needs at least one term")

    # -- composition ---------------------------------------------------------
    def __add__(self, other: Term | Model) -> Model:
        if isinstance(other, Term):
            return Model([*self.terms, other])
        if isinstance(other, Model):
            return Model([*self.terms, *other.terms])
        return NotImplemented

    def __repr__(self) -> str:
        return f"Model({self.spec})"

    @property
    def spec(self) -> str:
        """The model as a spec string, accepted by :func:`~.specs.parse_model_spec`."""
        return " + ".join(t.name for t in self.terms)

    @property
    def term_names(self) -> list[str]:
        return [t.name for t in self.terms]

    @property
    def param_names(self) -> list[str]:
        return [n for t in self.terms for n in t.param_names]

    @property
    def variables(self) -> list[str]:
        """Input variables the model needs, in order of first use."""
        out: list[str] = []
        for t in self.terms:
            out.extend(v for v in t.variables if v not in out)
        return out

    def equation(self) -> str:
        """The model as a readable equation."""
        return "tau_f = " + " + ".join(t.equation for t in self.terms)

    def make_params(self, values: Mapping[str, float] | Parameters | None = None) -> Parameters:
        """Parameters for this model: each term's defaults, overridden by ``values``.

        ``values`` may hold more names than the model needs (a whole parameter
        set); extra names are ignored. A :class:`~jointwear_ros.model.paramsets.ParameterSet`
        (what ``make_estimator`` hands an estimator) gives its values.
        """
        if values is not None and not isinstance(values, Mapping) and isinstance(getattr(values, "values", None),
                                                                                 Mapping):
            values = values.values  # type: ignore[union-attr]  # a ParameterSet
        src: Mapping[str, Any] = values if values is not None else {}
        out = Parameters()
        for t in self.terms:
            for spec in t.params:
                given = src.get(spec.name) if spec.name in src else None
                if isinstance(given, Parameter):
                    out.add(
                        Parameter(
                            spec.name, given.value, given.min, given.max, given.vary,
                            given.unit or spec.unit, given.description or spec.description,
                        )
                    )
                else:
                    out.add(Parameter.from_spec(spec, None if given is None else float(given)))
        return out

    # -- evaluation ----------------------------------------------------------
    def _inputs(self, inputs: Mapping[str, Any]) -> dict[str, Array]:
        x: dict[str, Array] = {}
        for k, val in inputs.items():
            name = _INPUT_ALIASES.get(k, k)
            x[name] = np.asarray(val, dtype=float)
        missing = [v for v in self.variables if v not in x]
        if missing:
            raise ModelError(
                f"model {self.spec!r} needs input(s) {', '.join(missing)}; got {', '.join(x) or 'none'}"
            )
        try:
            np.broadcast(*x.values())
        except ValueError:
            shapes = {k: np.shape(a) for k, a in x.items()}
            raise ModelError(f"input arrays do not broadcast together: {shapes}") from None
        for name in self.variables:
            a = x[name]
            if not np.isfinite(a).all():
                bad = a[~np.isfinite(a)].flat[0]
                raise ModelError(f"model input {name!r} holds {float(bad)!r}; the model needs finite values")
        if "temperature" in self.variables and (x["temperature"] < ABSOLUTE_ZERO).any():
            low = float(x["temperature"].min())
            raise ModelError(f"model input 'temperature' holds {low:g} degC, below absolute zero ({ABSOLUTE_ZERO} degC)")
        return x

    @staticmethod
    def _values(params: Parameters | Mapping[str, float], needed: Iterable[str]) -> dict[str, float]:
        if isinstance(params, Parameters):
            vals = params.valuesdict()
        else:
            vals = {k: float(v) for k, v in params.items()}
        missing = [n for n in needed if n not in vals]
        if missing:
            raise ParameterError(f"missing parameter value(s): {', '.join(missing)}")
        return vals

    def evaluate(self, params: Parameters | Mapping[str, float], **inputs: Any) -> Array:
        """tau_f on the broadcast input arrays (``speed=``, ``load_torque=``, ...)."""
        x = self._inputs(inputs)
        p = self._values(params, self.param_names)
        total: Array = np.zeros(np.broadcast(*x.values()).shape)
        for t in self.terms:
            total = total + t.value(x, p)
        return total

    __call__ = evaluate

    def components(self, params: Parameters | Mapping[str, float], **inputs: Any) -> dict[str, Array]:
        """Each term's contribution, term name -> array (they sum to :meth:`evaluate`)."""
        x = self._inputs(inputs)
        p = self._values(params, self.param_names)
        shape = np.broadcast(*x.values()).shape
        return {t.name: np.broadcast_to(t.value(x, p), shape).copy() for t in self.terms}

    def param_gradient(
        self, params: Parameters | Mapping[str, float], names: Iterable[str] | None = None, **inputs: Any
    ) -> dict[str, Array]:
        """d tau_f / d parameter for each name (default: all model parameters)."""
        x = self._inputs(inputs)
        p = self._values(params, self.param_names)
        wanted = list(self.param_names if names is None else names)
        shape = np.broadcast(*x.values()).shape
        out: dict[str, Array] = {}
        for t in self.terms:
            if not any(n in wanted for n in t.param_names):
                continue
            g = t.param_gradient(x, p)
            for n in t.param_names:
                if n in wanted:
                    out[n] = np.broadcast_to(g[n], shape).copy()
        unknown = [n for n in wanted if n not in out]
        if unknown:
            raise ParameterError(f"model {self.spec!r} has no parameter(s) {', '.join(unknown)}")
        return {n: out[n] for n in wanted}

    def jacobian(
        self, params: Parameters | Mapping[str, float], names: Iterable[str] | None = None, **inputs: Any
    ) -> Array:
        """Jacobian d tau_f / d theta as an array (n_points, n_params), columns in ``names`` order."""
        g = self.param_gradient(params, names, **inputs)
        cols = [np.ravel(a) for a in g.values()]
        return np.column_stack(cols) if cols else np.zeros((0, 0))

    def prepare(self, **inputs: Any) -> PreparedModel:
        """The model on fixed inputs, checked once: a fit's many evaluations at new parameter values."""
        return PreparedModel(self, inputs)

    def input_gradient(self, var: str, params: Parameters | Mapping[str, float], **inputs: Any) -> Array:
        """d tau_f / d input variable (``wear``/``w``, ``temperature``/``T``, ...)."""
        var = _INPUT_ALIASES.get(var, var)
        x = self._inputs(inputs)
        if var not in x:
            raise ModelError(f"no input named {var!r}")
        p = self._values(params, self.param_names)
        total: Array = np.zeros(np.broadcast(*x.values()).shape)
        for t in self.terms:
            total = total + t.input_gradient(x, p, var)
        return total


class _PreparedInputs(dict):  # type: ignore[type-arg]
    """Checked inputs that carry their broadcast shape (the terms' zeros need not broadcast them again) and a
    ``memo`` where a term keeps what depends on the inputs alone (a spline's basis): they do not change."""

    shape: tuple[int, ...]
    memo: dict[Any, Any]


class PreparedModel:
    """A model on inputs checked once (:meth:`Model.prepare`): :meth:`evaluate` and :meth:`jacobian` at many
    parameter values, each the same numbers as :meth:`Model.evaluate` and :meth:`Model.jacobian` on those inputs
    (the same operations in the same order), without checking the inputs again at every call.

    The terms in the model when it was prepared are the ones evaluated; ``values`` must hold every parameter
    of the model (name -> float).

    >>> from jointwear_ros.model import Coulomb, Viscous
    >>> m = Coulomb() + Viscous()
    >>> pm = m.prepare(speed=np.array([0.0, 10.0]))
    >>> v = {"Fc0": 0.04, "Fv": 4e-4}
    >>> bool(np.array_equal(pm.evaluate(v), m.evaluate(v, speed=[0.0, 10.0])))
    True
    >>> pm.jacobian(v, ["Fv"]).tolist()
    [[0.0], [10.0]]
    """

    def __init__(self, model: Model, inputs: Mapping[str, Any]) -> None:
        self.model = model
        self.x = _PreparedInputs(model._inputs(inputs))
        self.shape = self.x.shape = np.broadcast(*self.x.values()).shape
        self.x.memo = {}
        self.terms = tuple(model.terms)
        self.param_names = tuple(n for t in self.terms for n in t.param_names)
        self._plans: dict[tuple[str, ...], list[tuple[Term, list[tuple[str, int]]]]] = {}

    def evaluate(self, values: Values) -> Array:
        """tau_f at parameter values ``values`` (as :meth:`Model.evaluate`)."""
        x = self.x
        total: Array = np.zeros(self.shape)
        for t in self.terms:
            total = total + t.value(x, values)
        return total

    def _plan(self, names: tuple[str, ...]) -> list[tuple[Term, list[tuple[str, int]]]]:
        plan = self._plans.get(names)
        if plan is None:
            col = {n: j for j, n in enumerate(names)}
            plan = [(t, [(n, col[n]) for n in t.param_names if n in col]) for t in self.terms
                    if any(n in col for n in t.param_names)]
            unknown = [n for n in names if n not in self.param_names]
            if unknown:
                raise ParameterError(f"model {self.model.spec!r} has no parameter(s) {', '.join(unknown)}")
            self._plans[names] = plan
        return plan

    def jacobian(self, values: Values, names: Iterable[str]) -> Array:
        """d tau_f / d theta, (n_points, len(names)), columns in ``names`` order (as :meth:`Model.jacobian`);
        only the terms holding one of ``names`` are differentiated."""
        key = tuple(names)
        plan = self._plan(key)
        if not key:
            return np.zeros((0, 0))
        out = np.empty((int(np.prod(self.shape)), len(key)))
        view = out.reshape(*self.shape, len(key))
        x = self.x
        for t, cols in plan:
            g = t.param_gradient(x, values)
            for n, j in cols:
                view[..., j] = g[n]
        return out
