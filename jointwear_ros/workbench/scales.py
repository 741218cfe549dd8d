"""Fits in the data's units: start values and bounds scaled to the data, bound hits reported.

The terms declare each parameter's start value and bounds (:class:`~jointwear_ros.model.ParamSpec`)
for the paper's joint: motor side speeds of tens to hundreds of rad/s and friction of about 0.1 in
normalized torque. A real joint's data are often joint side, in N·m: speeds a hundred times smaller,
torques a hundred times larger. A fit started and bounded in the paper's numbers then stops on a
bound far from the data's optimum.

:class:`DataScales` measures the data's own scales (the largest speed, the median friction) and
expresses them as powers of ten of the paper's (:data:`REFERENCE_SPEED`, :data:`REFERENCE_TORQUE`):
data within half a decade of the paper's keep the terms' numbers exactly; joint-side data in N·m
(gear 120, 150 N·m per normalized unit) get speed factor 0.01 and torque factor 100. Each parameter
is scaled by its unit's dimension (:func:`unit_dimension`: a torque ``-`` scales with the torque
factor, a speed ``rad/s`` with the speed factor, a viscous coefficient ``s/rad`` with their ratio;
degrees Celsius and the candidate terms' per-column units do not scale). :func:`scale_parameters`
applies it to every parameter whose bounds are still its term's own (a bound the caller set is
kept), and :func:`bound_hits` names the parameters a fit left on a bound.

>>> s = DataScales.from_arrays(speed=[0.01, 0.5, 1.3], tau_f=[12.0, 10.5, 14.0])
>>> s.speed, s.torque, s.factor("s/rad")
(0.01, 100.0, 10000.0)
>>> DataScales.from_arrays(speed=[2.0, 47.0, 250.0], tau_f=[0.07, 0.08, 0.16]).factor("rad/s")
1.0
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ..model import Model, Parameters

__all__ = [
    "REFERENCE_SPEED",
    "REFERENCE_TORQUE",
    "BoundHit",
    "DataScales",
    "bound_hits",
    "scale_grid",
    "scale_parameters",
    "unit_dimension",
]

Array = npt.NDArray[np.float64]

#: The largest speed of the paper's test cycles is of this order (motor side, rad/s).
REFERENCE_SPEED = 100.0
#: The paper's friction is of this order (normalized torque).
REFERENCE_TORQUE = 0.1

#: Dimension of a unit as (torque exponent, speed exponent). Anything else does not scale.
_UNIT_DIMENSIONS: dict[str, tuple[int, int]] = {
    "-": (1, 0), "1/degC": (1, 0), "1/w": (1, 0), "-/x": (1, 0), "-/(x*y)": (1, 0),
    "rad/s": (0, 1), "rad/s/degC": (0, 1), "rad/s/w": (0, 1),
    "s/rad": (1, -1), "s/rad/w": (1, -1), "s/rad/x": (1, -1),
}
#: Parameters written "-" that are a ratio of two torques (friction per unit load torque).
_TORQUE_RATIOS = frozenset({"Fctm", "Fstm"})


def unit_dimension(unit: str, name: str = "") -> tuple[int, int]:
    """(torque, speed) exponents of a parameter's unit; ``(0, 0)`` for units that do not scale.

    >>> unit_dimension("s/rad"), unit_dimension("degC"), unit_dimension("-", "Fctm")
    ((1, -1), (0, 0), (0, 0))
    """
    if name in _TORQUE_RATIOS or name.rsplit("_", 1)[-1] in _TORQUE_RATIOS:
        return (0, 0)
    return _UNIT_DIMENSIONS.get(unit.strip(), (0, 0))


def _decade(x: float) -> float:
    """``x`` rounded to the nearest power of ten (1 for a non-positive or non-finite x)."""
    if not (math.isfinite(x) and x > 0):
        return 1.0
    return float(10.0 ** round(math.log10(x)))


@dataclass(frozen=True)
class DataScales:
    """The data's speed and torque scales relative to the paper's, as powers of ten.

    ``speed_level`` is the largest |speed| of the data, ``torque_level`` the
    median |tau_f| (NaN when not measured); ``speed`` and ``torque`` are the
    factors applied to the terms' numbers.
    """

    speed: float = 1.0
    torque: float = 1.0
    speed_level: float = math.nan
    torque_level: float = math.nan

    @classmethod
    def from_arrays(cls, speed: Any = None, tau_f: Any = None) -> DataScales:
        v = np.abs(np.asarray([] if speed is None else speed, dtype=float).reshape(-1))
        v = v[np.isfinite(v) & (v > 0)]
        t = np.abs(np.asarray([] if tau_f is None else tau_f, dtype=float).reshape(-1))
        t = t[np.isfinite(t) & (t > 0)]
        vl = float(v.max()) if v.size else math.nan
        tl = float(np.median(t)) if t.size else math.nan
        return cls(speed=_decade(vl / REFERENCE_SPEED), torque=_decade(tl / REFERENCE_TORQUE),
                   speed_level=vl, torque_level=tl)

    @classmethod
    def from_table(cls, table: Any) -> DataScales:
        """Scales of an :class:`~jointwear_ros.types.ObservationTable` (its ``speed`` and ``tau_f``)."""
        return cls.from_arrays(table["speed"] if "speed" in table else None,
                               table["tau_f"] if "tau_f" in table else None)

    @property
    def identity(self) -> bool:
        return self.speed == 1.0 and self.torque == 1.0

    def factor(self, unit: str, name: str = "") -> float:
        """How much a parameter of this unit scales with the data."""
        a, b = unit_dimension(unit, name)
        return float(self.torque**a * self.speed**b)

    def to_dict(self) -> dict[str, float]:
        return {"speed_factor": self.speed, "torque_factor": self.torque,
                "speed_level": self.speed_level, "torque_level": self.torque_level}


def _specs(model: Model) -> dict[str, Any]:
    return {s.name: s for t in model.terms for s in t.params}


def scale_parameters(model: Model, params: Parameters, scales: DataScales) -> tuple[Parameters, set[str]]:
    """A copy of ``params`` with the terms' own starts and bounds scaled to the data.

    Only parameters whose bounds are still their term's (a caller's bounds are
    kept) are scaled; a value still at the term's default scales with them.
    Returns the copy and the names of the parameters whose bounds came from
    the scaling (a torque or speed unit; a fit may widen those when it ends on
    one). Parameters of units that do not scale keep their terms' numbers.
    """
    out = params.copy()
    auto: set[str] = set()
    for name, spec in _specs(model).items():
        if name not in out:
            continue
        p = out[name]
        if (p.min, p.max) != (spec.min, spec.max) or unit_dimension(spec.unit, name) == (0, 0):
            continue
        auto.add(name)
        f = scales.factor(spec.unit, name)
        if f == 1.0:
            continue
        p.min, p.max = spec.min * f, spec.max * f
        if p.value == spec.default:
            p.value = spec.default * f
        p.value = float(min(max(p.value, p.min), p.max))
    return out, auto


def scale_grid(model_or_params: Iterable[Any], grid: Sequence[Mapping[str, float]],
               scales: DataScales) -> list[dict[str, float]]:
    """Start points ``grid`` (written for the paper's joint) scaled to the data by each parameter's unit.

    ``model_or_params`` are the term's :class:`~jointwear_ros.model.ParamSpec` (``term.params``).
    """
    units = {s.name: s.unit for s in model_or_params}
    return [{k: v * scales.factor(units.get(k, ""), k) for k, v in g.items()} for g in grid]


@dataclass(frozen=True)
class BoundHit:
    """A parameter the fit left on one of its bounds."""

    name: str
    value: float
    bound: float
    side: str  # "lower" or "upper"

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "value": self.value, "bound": self.bound, "side": self.side}

    def __str__(self) -> str:
        return f"{self.name} = {self.value:.6g} on its {self.side} bound {self.bound:.6g}"


def bound_hits(params: Parameters, names: Iterable[str], rtol: float = 1e-6) -> list[BoundHit]:
    """The parameters of ``names`` whose value is on a finite bound (within ``rtol`` of it, relative;
    a bound at 0 within ``rtol * 1e-3`` of the bounded range)."""
    out = []
    for n in names:
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
