"""Data types shared between concerns (model workbench, estimators, observer, nodes, IO).

Kept in one place so that the subpackages do not import each other sideways.
Pure numpy; no ROS import.

>>> t = ObservationTable.from_arrays(speed=[10.0, 47.0, 10.0], tau_f=[0.075, 0.073, 0.076],
...                                  load_torque=0.1, cycle=[1, 1, 2], source="demo")
>>> len(t), t.names, float(t["load_torque"][2])
(3, ['speed', 'tau_f', 'load_torque', 'cycle'], 0.1)
>>> [(c, len(g)) for c, g in t.groups("cycle")]
[(1.0, 2), (2.0, 1)]
>>> t["temperature"]
Traceback (most recent call last):
...
jointwear_ros.errors.InputDataError: demo: no column 'temperature'; columns: speed, tau_f, load_torque, cycle
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from .errors import InputDataError

__all__ = ["OBSERVATION_COLUMNS", "ObservationTable", "WearEstimator", "WearResult"]

Array = npt.NDArray[np.float64]

#: Standard columns of an observation table (FrictionObservation fields).
#: ``speed`` and ``tau_f`` are required; any other numeric column is allowed.
OBSERVATION_COLUMNS: tuple[str, ...] = (
    "speed",          # motor side, rad/s
    "tau_f",          # static friction (u+ - u-)/2, normalized
    "tau_f_std",      # its standard error
    "load_torque",    # tau_m, normalized
    "temperature",    # degC, NaN when unknown
    "position",       # window centre, joint side, rad
    "time",           # s (any epoch)
    "cycle",          # test-cycle id
    "tau_plus",       # u+, normalized
    "tau_minus",      # u-, normalized (signed)
)


@dataclass(frozen=True)
class ObservationTable:
    """Friction observations as named float columns of equal length.

    One row per observation (one speed of one test cycle). ``speed`` and
    ``tau_f`` are required; the standard optional columns are listed in
    :data:`OBSERVATION_COLUMNS`; any other numeric column (hours since
    lubrication, ambient temperature, ...) is kept too.
    """

    columns: Mapping[str, Array]
    source: str = ""
    #: the units the columns are in (:class:`jointwear_ros.units.TableUnits`): declared by the file, or None
    #: (assumed: the suite's units unless the command's flags say otherwise)
    units: Any = field(default=None, compare=False)

    def __post_init__(self) -> None:
        cols: dict[str, Array] = {}
        n: int | None = None
        for name, values in self.columns.items():
            arr = np.asarray(values, dtype=float).reshape(-1)
            if n is None:
                n = arr.size
            elif arr.size != n:
                raise InputDataError(
                    f"{self.source or 'observations'}: column {name!r} has {arr.size} rows, expected {n}"
                )
            cols[str(name)] = arr
        for req in ("speed", "tau_f"):
            if req not in cols:
                raise InputDataError(
                    f"{self.source or 'observations'}: required column {req!r} is missing; "
                    f"columns present: {', '.join(cols) or 'none'}"
                )
        object.__setattr__(self, "columns", cols)

    @classmethod
    def from_arrays(cls, source: str = "", **columns: Any) -> ObservationTable:
        return cls(columns={k: np.broadcast_to(np.asarray(v, dtype=float), np.shape(columns["speed"]))
                            for k, v in columns.items()}, source=source)

    def __len__(self) -> int:
        return int(self.columns["speed"].size)

    def __contains__(self, name: object) -> bool:
        return name in self.columns

    def __getitem__(self, name: str) -> Array:
        try:
            return self.columns[name]
        except KeyError:
            raise InputDataError(
                f"{self.source or 'observations'}: no column {name!r}; columns: {', '.join(self.columns)}"
            ) from None

    @property
    def names(self) -> list[str]:
        return list(self.columns)

    def get(self, name: str, default: float = math.nan) -> Array:
        """Column ``name``, or a column filled with ``default`` when absent."""
        if name in self.columns:
            return self.columns[name]
        return np.full(len(self), default, dtype=float)

    @property
    def speed(self) -> Array:
        return self.columns["speed"]

    @property
    def tau_f(self) -> Array:
        return self.columns["tau_f"]

    def select(self, mask: npt.ArrayLike) -> ObservationTable:
        """Rows where ``mask`` is true (or an index array)."""
        idx = np.asarray(mask)
        return ObservationTable({k: v[idx] for k, v in self.columns.items()}, source=self.source, units=self.units)

    def with_column(self, name: str, values: npt.ArrayLike) -> ObservationTable:
        cols = dict(self.columns)
        cols[name] = np.broadcast_to(np.asarray(values, dtype=float), (len(self),)).copy()
        return ObservationTable(cols, source=self.source, units=self.units)

    def groups(self, column: str = "cycle") -> Iterator[tuple[float, ObservationTable]]:
        """Sub-tables by value of ``column`` (all rows in one group if it is absent)."""
        if column not in self.columns:
            yield math.nan, self
            return
        for value in np.unique(self.columns[column]):
            yield float(value), self.select(self.columns[column] == value)

    def model_inputs(self) -> dict[str, Array]:
        """Every column but ``tau_f``, for :meth:`Model.evaluate` (``speed=``, ``load_torque=``, ...)."""
        return {k: v for k, v in self.columns.items() if k != "tau_f"}


@dataclass(frozen=True)
class WearResult:
    """A wear estimate with its uncertainty, from any estimator.

    ``wear_low``/``wear_high`` bound an interval (the estimator documents which:
    a credible interval, or mean +- 2 std). ``temperature`` is the temperature
    estimate (degC) or NaN when the estimator does not estimate it.
    ``per_speed_wear`` holds single-speed estimates aligned with ``speeds``.
    ``wear_std_model`` is the part of ``wear_std`` that the parameter set's own
    uncertainty adds (its covariance; 0 when the estimator does not carry it).
    """

    wear: float
    wear_std: float
    wear_low: float
    wear_high: float
    method: str
    temperature: float = math.nan
    temperature_std: float = math.nan
    speeds: tuple[float, ...] = ()
    per_speed_wear: tuple[float, ...] = ()
    info: Mapping[str, Any] = field(default_factory=dict)
    #: the part of ``wear_std`` from the parameter set's own uncertainty (its covariance; 0 when not carried)
    wear_std_model: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "estimate": self.wear,
            "std": self.wear_std,
            "low": self.wear_low,
            "high": self.wear_high,
            "method": self.method,
            "temperature": self.temperature,
            "temperature_std": self.temperature_std,
            "speeds": list(self.speeds),
            "per_speed_wear": list(self.per_speed_wear),
            "std_model": self.wear_std_model,
        }


@runtime_checkable
class WearEstimator(Protocol):
    """What the wear-estimator node and replay need of an estimator.

    ``estimate`` takes the observations of one test cycle (columns ``speed``,
    ``tau_f``, ``load_torque``, optional ``temperature`` with NaN = unknown,
    optional ``tau_f_std``) and returns a :class:`WearResult`. It must not
    raise on ordinary data; bad input raises
    :class:`~jointwear_ros.errors.InputDataError`.
    """

    name: str

    def estimate(self, observations: ObservationTable) -> WearResult: ...
