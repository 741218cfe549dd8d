"""Model parameters: value, bounds, vary flag and unit, kept outside the terms.

Modelled on lmfit's ``Parameter``/``Parameters``: a term declares which
parameters it needs (:class:`ParamSpec`), a :class:`Parameters` collection holds
their current values, and a fit changes only the ones with ``vary=True``.

>>> ps = Parameters([Parameter("Fc0", 0.04, 0.0, 1.0, unit="-"), Parameter("Fv", 4e-4, vary=False)])
>>> ps.valuesdict(), ps.free()
({'Fc0': 0.04, 'Fv': 0.0004}, ['Fc0'])
>>> ps.with_values({"Fc0": 0.05})["Fc0"].value, ps["Fc0"].value
(0.05, 0.04)
>>> Parameter("vs", float("nan"))
Traceback (most recent call last):
...
jointwear_ros.errors.ParameterError: parameter 'vs': value nan is not finite
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field, replace

from ..errors import ParameterError

__all__ = ["ParamSpec", "Parameter", "Parameters"]


@dataclass(frozen=True)
class ParamSpec:
    """What a term needs of one parameter: its name, unit, bounds and a typical value.

    ``default`` is a physically sensible starting value (used for initial
    guesses when a parameter set does not give one).
    """

    name: str
    unit: str
    default: float
    min: float = -math.inf
    max: float = math.inf
    description: str = ""


@dataclass
class Parameter:
    """One parameter value with bounds, a vary flag and its unit."""

    name: str
    value: float
    min: float = -math.inf
    max: float = math.inf
    vary: bool = True
    unit: str = ""
    description: str = ""
    stderr: float | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if not math.isfinite(self.value):
            raise ParameterError(f"parameter {self.name!r}: value {self.value!r} is not finite")
        if self.min > self.max:
            raise ParameterError(
                f"parameter {self.name!r}: lower bound {self.min} above upper bound {self.max}"
            )

    @classmethod
    def from_spec(cls, spec: ParamSpec, value: float | None = None, vary: bool = True) -> Parameter:
        return cls(
            name=spec.name,
            value=spec.default if value is None else float(value),
            min=spec.min,
            max=spec.max,
            vary=vary,
            unit=spec.unit,
            description=spec.description,
        )

    def in_bounds(self) -> bool:
        return self.min <= self.value <= self.max


class Parameters(Mapping[str, Parameter]):
    """An ordered collection of :class:`Parameter`, indexed by name.

    Behaves as a read-only mapping name -> Parameter; :meth:`valuesdict` gives
    name -> float, which is what terms evaluate with.
    """

    def __init__(self, params: Iterable[Parameter] = ()) -> None:
        self._p: dict[str, Parameter] = {}
        for p in params:
            self.add(p)

    # mapping protocol
    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._p[name]
        except KeyError:
            raise ParameterError(
                f"unknown parameter {name!r}; known: {', '.join(self._p) or '(none)'}"
            ) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._p)

    def __len__(self) -> int:
        return len(self._p)

    def __contains__(self, name: object) -> bool:
        return name in self._p

    def __repr__(self) -> str:
        inner = ", ".join(f"{n}={p.value:.6g}" for n, p in self._p.items())
        return f"Parameters({inner})"

    def add(self, p: Parameter) -> None:
        if p.name in self._p:
            raise ParameterError(f"parameter {p.name!r} defined twice")
        self._p[p.name] = p

    def copy(self) -> Parameters:
        return Parameters(replace(p) for p in self._p.values())

    def valuesdict(self) -> dict[str, float]:
        return {n: p.value for n, p in self._p.items()}

    def free(self) -> list[str]:
        """Names of the parameters a fit may change (``vary=True``), in order."""
        return [n for n, p in self._p.items() if p.vary]

    def with_values(self, values: Mapping[str, float]) -> Parameters:
        """A copy with some values replaced (unknown names are an error)."""
        out = self.copy()
        for n, v in values.items():
            out[n].value = float(v)
        return out

    def set_vary(self, names: Iterable[str], vary: bool) -> None:
        for n in names:
            self[n].vary = vary

    def merged(self, other: Parameters) -> Parameters:
        """Union of two collections; a name present in both takes ``other``'s entry."""
        out = self.copy()
        for n, p in other.items():
            out._p[n] = replace(p)
        return out
