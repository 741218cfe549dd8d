"""A friction model: a sum of terms, evaluated on named input arrays.

>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> m = paper_wear_model()
>>> p = load_parameter_set("ref-2011r")
>>> round(float(m.evaluate(p, speed=47.0, load_torque=0.1, temperature=40.0, wear=35.0)), 5)
0.09072
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ModelError, ParameterError
from .parameters import Parameter, Parameters
from .terms import Term, term_by_name

__all__ = ["MODEL_SPECS", "Model", "paper_model", "paper_wear_model", "parse_model_spec", "split_model_spec",
           "standard_model"]

Array = npt.NDArray[np.float64]

#: Named model specifications.
MODEL_SPECS: dict[str, tuple[str, ...]] = {
    "standard": ("coulomb", "stribeck", "viscous"),
    "paper": ("coulomb", "load_coulomb", "load_stribeck", "temp_stribeck", "temp_viscous"),
    "paper+wear": (
        "coulomb",
        "load_coulomb",
        "load_stribeck",
        "temp_stribeck",
        "temp_viscous",
        "wear_stribeck",
        "wear_viscous",
    ),
}

#: 0 K in degC: the model refuses temperatures below it.
ABSOLUTE_ZERO = -273.15

#: Default values of inputs a term may use but the data does not give.
_INPUT_ALIASES = {"v": "speed", "tau_m": "load_torque", "T": "temperature", "w": "wear"}


class Model:
    """A static friction model: the sum of its terms.

    Build one with ``+`` (``Coulomb() + Viscous()``) or :func:`parse_model_spec`.
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
        """The model as a spec string, accepted by :func:`parse_model_spec`."""
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


def parse_model_spec(spec: str, resolver: Any = None) -> Model:
    """Build a model from a spec string.

    ``spec`` is a named spec (``standard``, ``paper``, ``paper+wear``) or a sum
    ``A + B + ...`` of named specs and term names. ``resolver`` (optional) is a
    callable ``name -> Term | None`` consulted for names that are not built-in
    (candidate effects, user terms by dotted path); the first one to return a
    term wins.
    """
    text = spec.strip()
    if not text:
        raise ModelError("empty model spec; use e.g. 'paper', 'standard' or 'coulomb + viscous'")
    if text in MODEL_SPECS:
        return Model(term_by_name(n) for n in MODEL_SPECS[text])
    parts = _split_top_level(text)
    terms: list[Term] = []
    for part in parts:
        if part in MODEL_SPECS:
            terms.extend(term_by_name(n) for n in MODEL_SPECS[part])
            continue
        term = resolver(part) if resolver is not None else None
        if term is None:
            term = term_by_name(part)
        terms.append(term)
    return Model(terms)


def split_model_spec(text: str) -> list[str]:
    """The parts of a spec: split on '+' outside parentheses; the named spec 'paper+wear' stays one name.

    >>> split_model_spec("paper+wear + ripple(position, w0=3)")
    ['paper+wear', 'ripple(position, w0=3)']
    """
    return _split_top_level(text)


def _split_top_level(text: str) -> list[str]:
    """Split on '+' outside parentheses; the named spec 'paper+wear' stays one name."""
    raw: list[str] = []
    depth = 0
    cur = ""
    for c in text:
        if c == "(":
            depth += 1
        elif c == ")":
            depth -= 1
        if c == "+" and depth == 0:
            raw.append(cur.strip())
            cur = ""
        else:
            cur += c
    raw.append(cur.strip())
    if depth != 0 or any(not p for p in raw):
        raise ModelError(f"malformed model spec {text!r}: unbalanced parentheses or an empty term")
    out: list[str] = []
    for part in raw:
        if part == "wear" and out and out[-1] == "paper":
            out[-1] = "paper+wear"
        else:
            out.append(part)
    return out


def standard_model() -> Model:
    """Coulomb + Stribeck + viscous: the standard static model, no load or temperature."""
    return parse_model_spec("standard")


def paper_model() -> Model:
    """Eq. (6): load and temperature effects, no wear."""
    return parse_model_spec("paper")


def paper_wear_model() -> Model:
    """Eq. (9): Eq. (6) plus the wear terms of Eq. (7)."""
    return parse_model_spec("paper+wear")
