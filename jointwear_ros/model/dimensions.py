"""What a parameter's magnitude is made of, and how much it moves with a data set's powers of ten.

The lowest part of the model package (no import of it): a parameter's :class:`Dimension` (exponents of the
data's torque, speed, load torque, temperature and wear scales), the dimension a unit implies
(:data:`UNIT_DIMENSIONS`), a parameter's start and bounds relative to the data (:class:`Relative`) and the
paper's reference magnitudes. The terms (:mod:`.terms`) declare their parameters' dimensions with these;
:mod:`.scaling` measures a data set and scales a model's parameters to it.

>>> unit_dimension("s/rad"), decade(0.03), scale_factor(Dimension(torque=1, speed=-1), torque=100.0, speed=0.01)
(Dimension(torque=1, speed=-1, load=0, temperature=0, wear=0), 0.01, 10000.0)
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = [
    "REFERENCE_SPEED",
    "REFERENCE_TORQUE",
    "UNIT_DIMENSIONS",
    "Dimension",
    "Relative",
    "decade",
    "finite_abs",
    "largest_abs",
    "scale_factor",
    "unit_dimension",
]

#: The largest speed of the paper's test cycles is of this order (motor side, rad/s).
REFERENCE_SPEED = 100.0
#: The paper's friction is of this order (normalized torque).
REFERENCE_TORQUE = 0.1


class Dimension(NamedTuple):
    """What a parameter's magnitude is made of: exponents of the data's scales.

    ``torque`` (the friction's unit), ``speed``, ``load`` (the load torque's),
    ``temperature`` (degrees C) and ``wear`` (0-100). A viscous coefficient is
    ``Dimension(torque=1, speed=-1)``; a pure number is all zeros.
    """

    torque: int = 0
    speed: int = 0
    load: int = 0
    temperature: int = 0
    wear: int = 0


#: The dimension a parameter's unit implies. The paper's torques are normalized, so ``-`` is a
#: torque; ``w`` is wear; ``x``, ``y`` are a candidate term's columns, of unknown unit (pure numbers
#: here). A unit not listed does not scale.
UNIT_DIMENSIONS: dict[str, Dimension] = {
    "-": Dimension(torque=1),
    "1/degC": Dimension(torque=1, temperature=-1),
    "1/w": Dimension(torque=1, wear=-1),
    "-/x": Dimension(torque=1),
    "-/(x*y)": Dimension(torque=1),
    "rad/s": Dimension(speed=1),
    "rad/s/degC": Dimension(speed=1, temperature=-1),
    "rad/s/w": Dimension(speed=1, wear=-1),
    "s/rad": Dimension(torque=1, speed=-1),
    "s/rad/w": Dimension(torque=1, speed=-1, wear=-1),
    "s/rad/x": Dimension(torque=1, speed=-1),
    "degC": Dimension(temperature=1),
}


class Relative(NamedTuple):
    """A parameter's start and bounds as multiples of the data's level of its dimension
    (:meth:`~jointwear_ros.model.scaling.DataScales.level`): how a fit with no parameter set to start
    from (commissioning) starts in any units.

    ``absolute``: the bounds are in the parameter's own unit (physical limits), not multiples.
    """

    start: float
    lo: float
    hi: float
    absolute: bool = False


def unit_dimension(unit: str) -> Dimension:
    """The dimension a unit implies (:data:`UNIT_DIMENSIONS`; a pure number for a unit not listed)."""
    return UNIT_DIMENSIONS.get(unit.strip(), Dimension())


def decade(x: float) -> float:
    """``x`` rounded to the nearest power of ten (1 for a non-positive or non-finite x)."""
    if not (math.isfinite(x) and x > 0):
        return 1.0
    return float(10.0 ** round(math.log10(x)))


def finite_abs(a: Any) -> npt.NDArray[np.float64]:
    """The finite absolute values of ``a`` (None: none), flat."""
    x = np.abs(np.asarray([] if a is None else a, dtype=float).reshape(-1))
    return x[np.isfinite(x)]


def largest_abs(a: Any) -> float:
    """The largest |value| (NaN when none is positive)."""
    x = finite_abs(a)
    return float(x.max()) if x.size and x.max() > 0 else math.nan


def scale_factor(dimension: Dimension, *, torque: float, speed: float) -> float:
    """How much a parameter of ``dimension`` moves from the paper's numbers on data whose torque and speed
    are ``torque`` and ``speed`` powers of ten of the paper's: torque (and load torque, in the same unit) and
    speed by their powers; a temperature and the wear do not scale."""
    d = dimension
    return float(torque ** (d.torque + d.load) * speed**d.speed)
