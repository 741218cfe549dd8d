"""Fits in the data's units: the data's scales, start values and bounds from them, bound hits.

No fit may assume the paper's normalized joint (motor side speeds of tens to hundreds of
rad/s, friction of about 0.1): a real joint's data are often joint side, in N·m, speeds a
hundred times smaller and torques a hundred times larger. :class:`DataScales` measures a
data set once (its largest and median friction, its largest speed and load torque, its
temperature mean and span), and every parameter's magnitude follows from its *dimension*,
which the term declares (:meth:`~jointwear_ros.model.terms.Term.dimension`: a viscous
coefficient is a torque per speed, ``Fctm`` a torque per load torque, ``Tv0`` a temperature).
Two ways to a fit's starts and bounds use it:

- :func:`data_parameters` (commissioning, which has no parameter set to start from): each
  built-in parameter's start and bounds are multiples (declared on its term,
  :attr:`~jointwear_ros.model.terms.Term.relative`, gathered in :data:`RELATIVE`) of the
  data's level of its dimension (:meth:`DataScales.level`).
- :func:`scale_parameters` (the workbench, which starts from given values or the terms'
  own numbers, written for the paper's joint): those numbers times the data's scale in
  powers of ten of the paper's (:meth:`DataScales.factor`); data within half a decade of the
  paper's keep them exactly. :func:`scale_grid` does the same for a term's start grid.

:func:`on_bound` names every free parameter a fit left on a bound (:class:`BoundHit`); such
a fit is not called converged.

>>> s = DataScales.of(speed=[0.01, 0.5], tau_f=[12.0, 20.0], load_torque=[0, 40.0], temperature=[20, 45])
>>> s.torque_top, s.speed_level, s.load_level, s.temperature_span
(20.0, 0.5, 40.0, 25.0)
>>> p = data_parameters(["Fc0", "vs0", "Tv0"], s)
>>> p["Fc0"].value, p["vs0"].min, p["Tv0"].max
(10.0, 0.0005, 1000.0)
>>> s = DataScales.of(speed=[0.01, 0.5, 1.3], tau_f=[12.0, 10.5, 14.0])
>>> s.speed, s.torque, s.factor("s/rad")
(0.01, 100.0, 10000.0)
>>> DataScales.of(speed=[2.0, 47.0, 250.0], tau_f=[0.07, 0.08, 0.16]).factor("rad/s")
1.0
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from .dimensions import (
    REFERENCE_SPEED,
    REFERENCE_TORQUE,
    Dimension,
    Relative,
    decade,
    finite_abs,
    largest_abs,
    scale_factor,
)
from .model import Model, Term
from .parameters import Parameter, Parameters
from .terms import TERMS, param_dimension

__all__ = [
    "REFERENCE_SPEED",
    "REFERENCE_TORQUE",
    "RELATIVE",
    "BoundHit",
    "DataScales",
    "Relative",
    "data_parameters",
    "on_bound",
    "scale_grid",
    "scale_parameters",
    "speed_starts",
]

#: Start and bounds of each built-in parameter, in units of the data's level of its dimension, gathered
#: from the terms (:attr:`~jointwear_ros.model.terms.Term.relative`, where each term declares them).
RELATIVE: dict[str, Relative] = {n: r for cls in TERMS.values() for n, r in cls.relative.items()}

_SPEED = Dimension(speed=1)


def _or(x: float, default: float) -> float:
    return x if math.isfinite(x) else default


@dataclass(frozen=True)
class DataScales:
    """The magnitudes of one data set, measured once; NaN where not measured.

    ``speed_level`` is the largest |speed|, ``torque_level`` the median and ``torque_top``
    the largest |tau_f|, ``load_level`` the largest |load_torque|; ``temperature`` and
    ``temperature_span`` the mean and span of the temperatures (40 and 20 degC when not
    measured, a span at least 1). :attr:`speed` and :attr:`torque` are the data's scales
    in powers of ten of the paper's (1 for data at the paper's scale).
    """

    speed_level: float = math.nan
    torque_level: float = math.nan
    torque_top: float = math.nan
    load_level: float = math.nan
    temperature: float = 40.0
    temperature_span: float = 20.0
    wear: float = 100.0

    @classmethod
    def of(cls, *, speed: npt.ArrayLike | None = None, tau_f: npt.ArrayLike | None = None,
           load_torque: npt.ArrayLike | None = None, temperature: npt.ArrayLike | None = None) -> DataScales:
        """Scales of arrays (any may be missing)."""
        t = np.asarray([] if temperature is None else temperature, dtype=float).reshape(-1)
        t = t[np.isfinite(t)]
        f = finite_abs(tau_f)
        f = f[f > 0]
        return cls(
            speed_level=largest_abs(speed),
            torque_level=float(np.median(f)) if f.size else math.nan,
            torque_top=largest_abs(tau_f),
            load_level=largest_abs(load_torque),
            temperature=float(np.mean(t)) if t.size else 40.0,
            temperature_span=max(float(np.ptp(t)), 1.0) if t.size else 20.0,
        )

    @classmethod
    def from_table(cls, table: Any) -> DataScales:
        """Scales of an :class:`~jointwear_ros.types.ObservationTable` (the columns it has)."""
        return cls.of(**{c: table[c] for c in ("speed", "tau_f", "load_torque", "temperature") if c in table})

    @property
    def speed(self) -> float:
        """The largest speed in powers of ten of the paper's (:data:`REFERENCE_SPEED`)."""
        return decade(self.speed_level / REFERENCE_SPEED)

    @property
    def torque(self) -> float:
        """The median friction in powers of ten of the paper's (:data:`REFERENCE_TORQUE`)."""
        return decade(self.torque_level / REFERENCE_TORQUE)

    @property
    def identity(self) -> bool:
        return self.speed == 1.0 and self.torque == 1.0

    def factor(self, dimension: Dimension | str, name: str = "") -> float:
        """How much a parameter of this dimension (or unit, of parameter ``name``) moves from the paper's
        numbers: torque (and load torque, in the same unit) and speed by their powers of ten; a
        temperature and the wear do not scale."""
        d = dimension if isinstance(dimension, Dimension) else param_dimension(name, dimension)
        return scale_factor(d, torque=self.torque, speed=self.speed)

    def level(self, dimension: Dimension) -> float:
        """The data's own magnitude of a dimension: the largest friction, speed and load torque, the
        temperature span, wear 100 (a scale not measured counts as 1)."""
        d = dimension
        return float(_or(self.torque_top, 1.0) ** d.torque * _or(self.speed_level, 1.0) ** d.speed
                     * _or(self.load_level, 1.0) ** d.load * self.temperature_span**d.temperature
                     * self.wear**d.wear)

    def to_dict(self) -> dict[str, float]:
        return {"speed_factor": self.speed, "torque_factor": self.torque,
                "speed_level": self.speed_level, "torque_level": self.torque_level}


def _moves(d: Dimension) -> bool:
    """Does a parameter of this dimension move with the data's powers of ten (:meth:`DataScales.factor`)?"""
    return (d.torque + d.load, d.speed) != (0, 0)


def data_parameters(names: Iterable[str], scales: DataScales,
                    given: Mapping[str, Parameter] | None = None) -> Parameters:
    """Start values and bounds of the named built-in parameters from the data's levels (:data:`RELATIVE`).

    A name that is not a built-in parameter is taken from ``given`` (its own
    start and bounds) or left out.
    """
    out = Parameters()
    for n in names:
        if n in RELATIVE:
            r = RELATIVE[n]
            s = scales.level(param_dimension(n))
            lo, hi = (r.lo, r.hi) if r.absolute else (r.lo * s, r.hi * s)
            out.add(Parameter(n, float(min(max(r.start * s, lo), hi)), float(lo), float(hi)))
        elif given is not None and n in given:
            g = given[n]
            out.add(Parameter(n, g.value, g.min, g.max, g.vary, g.unit, g.description))
    return out


def speed_starts(names: Sequence[str], scales: DataScales, fractions: Sequence[float] = (0.03, 0.1, 0.3)
                 ) -> list[dict[str, float]]:
    """Starts of the built-in Stribeck speeds among ``names``: each at a few fractions of the data's top speed."""
    speeds = [n for n in names if n in RELATIVE and param_dimension(n) == _SPEED]
    out: list[dict[str, float]] = [{}]
    for n in speeds:
        out = [dict(o, **{n: f * _or(scales.speed_level, 1.0)}) for o in out for f in fractions]
    return out


def scale_parameters(model: Model, params: Parameters, scales: DataScales) -> tuple[Parameters, set[str]]:
    """A copy of ``params`` with the terms' own starts and bounds scaled to the data (:meth:`DataScales.factor`).

    Only parameters whose bounds are still their term's (a caller's bounds are
    kept) are scaled; a value still at the term's default scales with them.
    Returns the copy and the names of the parameters whose bounds came from
    the scaling (a torque or speed dimension; a fit may widen those when it ends
    on one). Parameters of a dimension that does not scale keep their terms' numbers.
    """
    out = params.copy()
    auto: set[str] = set()
    specs = {s.name: (t, s) for t in model.terms for s in t.params}
    for name, (term, spec) in specs.items():
        if name not in out:
            continue
        p = out[name]
        d = term.dimension(name)
        if (p.min, p.max) != (spec.min, spec.max) or not _moves(d):
            continue
        auto.add(name)
        f = scales.factor(d)
        if f == 1.0:
            continue
        p.min, p.max = spec.min * f, spec.max * f
        if p.value == spec.default:
            p.value = spec.default * f
        p.value = float(min(max(p.value, p.min), p.max))
    return out, auto


def scale_grid(term: Term, grid: Sequence[Mapping[str, float]], scales: DataScales) -> list[dict[str, float]]:
    """Start points ``grid`` of ``term`` (written for the paper's joint) scaled to the data by each
    parameter's dimension."""
    return [{k: v * scales.factor(term.dimension(k)) for k, v in g.items()} for g in grid]


class BoundHit(tuple[str, float, float]):
    """A parameter a fit left on a bound: the triple ``(name, value, bound)``, and ``side``.

    It unpacks and compares as the triple; ``side`` (``"lower"`` or ``"upper"``)
    says which of the parameter's bounds it is.
    """

    side: str

    def __new__(cls, name: str, value: float, bound: float, side: str) -> BoundHit:
        hit = super().__new__(cls, (name, float(value), float(bound)))
        hit.side = side
        return hit

    def __getnewargs__(self) -> tuple[str, float, float, str]:  # type: ignore[override]
        return (self.name, self.value, self.bound, self.side)

    @property
    def name(self) -> str:
        return self[0]

    @property
    def value(self) -> float:
        return self[1]

    @property
    def bound(self) -> float:
        return self[2]

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "value": self.value, "bound": self.bound, "side": self.side}

    def __repr__(self) -> str:
        return f"BoundHit({self.name!r}, {self.value!r}, {self.bound!r}, {self.side!r})"

    def __str__(self) -> str:
        return f"{self.name} = {self.value:.6g} on its {self.side} bound {self.bound:.6g}"


def on_bound(params: Parameters, names: Iterable[str] | None = None, rtol: float = 1e-6) -> list[BoundHit]:
    """The parameters of ``names`` (default: the free ones) whose value is on a finite bound: within
    ``rtol`` of it, relative (a bound at 0: within ``rtol * 1e-3`` of the bounded range).

    >>> on_bound(Parameters([Parameter("a", 0.0, 0.0, 1.0), Parameter("b", 2.0, 0.0, 2.0)]))
    [BoundHit('a', 0.0, 0.0, 'lower'), BoundHit('b', 2.0, 2.0, 'upper')]
    """
    out = []
    for n in params.free() if names is None else names:
        p = params[n]
        span = p.max - p.min
        for side, b in (("lower", p.min), ("upper", p.max)):
            if not math.isfinite(b):
                continue
            tol = rtol * abs(b) if b != 0 else rtol * 1e-3 * (span if math.isfinite(span) else 1.0)
            if abs(p.value - b) <= tol:
                out.append(BoundHit(n, float(p.value), float(b), side))
                break
    return out
