"""Shared plumbing of the estimators: model resolution, input checks, combining rows.

Pure numpy; no ROS import.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from ..model import Model, Parameters, load_parameter_set, paper_wear_model
from ..types import ObservationTable, WearResult

__all__ = [
    "ABSOLUTE_ZERO",
    "DEFAULT_NOISE_STD",
    "DEFAULT_PARAMS",
    "WEAR_RANGE",
    "Rows",
    "check_estimator_options",
    "check_observation_values",
    "combine_rows",
    "make_rng",
    "prepare_rows",
    "resolve_model",
]

Array = npt.NDArray[np.float64]

#: Noise level of a static friction observation, Section 5.1 of the paper.
DEFAULT_NOISE_STD = 0.0015
#: Parameter set used when none is given.
DEFAULT_PARAMS = "ref-2011r"
#: Absolute zero, degC: a temperature below it is a sensor fault, never a joint's temperature.
ABSOLUTE_ZERO = -273.15
#: The wear scale of the paper: 0 (new) to 100 (failure).
WEAR_RANGE = (0.0, 100.0)
#: Largest motor-side speed an observation may have, rad/s (no robot motor turns 95,000 rpm).
MAX_SPEED = 1.0e4
#: Largest |friction| or |load torque| an observation may have, normalized (10x the maximum torque).
MAX_TORQUE = 10.0
#: Smallest standard error of a friction observation the estimators use (smaller ones are raised to it), normalized.
MIN_TAU_F_STD = 1e-6
#: Temperatures an observation may have, degC: above absolute zero, below where any joint survives.
TEMPERATURE_LIMITS = (-273.15, 1000.0)


def check_estimator_options(options: Mapping[str, Any]) -> None:
    """Refuse estimator options no estimator can work with (the options :func:`make_estimator` passes on).

    ``noise_std`` finite in (0, 1]; ``default_load`` None or finite with
    magnitude at most :data:`MAX_TORQUE`; ``n_samples`` a whole number in
    [1, 1e6]; ``temperature_range`` two finite numbers low < high, low above
    absolute zero; ``seed`` None or a whole number >= 0. Other options are
    left to the estimator.

    >>> check_estimator_options({"noise_std": 0.0015, "n_samples": 200})
    >>> check_estimator_options({"noise_std": -1.0})
    Traceback (most recent call last):
    ...
    jointwear_ros.errors.InputDataError: estimator option noise_std = -1.0: must be a finite number in (0, 1] (normalized torque)
    """

    def number(name: str, v: Any) -> float:
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise InputDataError(f"estimator option {name} = {v!r}: not a number")
        return float(v)

    def whole(name: str, v: Any, lo: int, hi: float) -> None:
        x = number(name, v)
        if not (math.isfinite(x) and x == int(x) and lo <= x <= hi):
            raise InputDataError(f"estimator option {name} = {v!r}: must be a whole number in [{lo}, {hi:g}]")

    if "noise_std" in options:
        x = number("noise_std", options["noise_std"])
        if not (math.isfinite(x) and 0 < x <= 1):
            raise InputDataError(f"estimator option noise_std = {options['noise_std']!r}: must be a finite number "
                                 "in (0, 1] (normalized torque)")
    if options.get("default_load") is not None:
        x = number("default_load", options["default_load"])
        if not (math.isfinite(x) and abs(x) <= MAX_TORQUE):
            raise InputDataError(f"estimator option default_load = {options['default_load']!r}: must be a finite "
                                 f"normalized torque within +-{MAX_TORQUE:g}")
    if "n_samples" in options:
        whole("n_samples", options["n_samples"], 1, 1e6)
    if options.get("seed") is not None:
        whole("seed", options["seed"], 0, 2.0**63)
    if "temperature_range" in options:
        rng = options["temperature_range"]
        try:
            lo, hi = (number("temperature_range", x) for x in rng)
        except (TypeError, ValueError):
            raise InputDataError(f"estimator option temperature_range = {rng!r}: expected (low, high) in degC") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and TEMPERATURE_LIMITS[0] <= lo < hi):
            raise InputDataError(f"estimator option temperature_range = {rng!r}: needs finite low < high, "
                                 f"low above absolute zero ({TEMPERATURE_LIMITS[0]} degC)")


def check_observation_values(table: ObservationTable, *, temperature: bool = True) -> None:
    """Refuse values no measurement of a joint can have, naming the row and the value.

    The estimators' own input check (before :func:`prepare_rows` reshapes the
    rows): speeds finite, >= 0 and at most :data:`MAX_SPEED`; ``tau_f`` and
    ``load_torque`` finite with magnitude at most :data:`MAX_TORQUE`;
    ``temperature`` NaN (unknown) or within :data:`TEMPERATURE_LIMITS`;
    ``tau_f_std`` NaN (unknown) or finite and >= 0. Raises
    :class:`~jointwear_ros.errors.InputDataError`. ``temperature=False``
    leaves the temperature column alone (an estimator that does not use it).

    >>> t = ObservationTable.from_arrays(speed=[40.0, 47.0], tau_f=[0.09, 0.09], load_torque=0.1,
    ...                                  temperature=[40.0, -300.0])
    >>> check_observation_values(t)
    Traceback (most recent call last):
    ...
    jointwear_ros.errors.InputDataError: observations: row 1 (speed 47 rad/s): temperature -300 degC is outside [-273.15, 1000] degC
    """
    where = table.source or "observations"
    speed = np.asarray(table.speed, dtype=float)

    def at(i: int) -> str:
        s = speed[i]
        return f"{where}: row {i} (speed {s:g} rad/s)" if math.isfinite(s) and s >= 0 else f"{where}: row {i}"

    bad = np.flatnonzero(~np.isfinite(speed) | (speed < 0) | (speed > MAX_SPEED))
    if bad.size:
        i = int(bad[0])
        raise InputDataError(f"{where}: row {i}: speed {float(speed[i])!r} is not a speed magnitude in "
                             f"[0, {MAX_SPEED:g}] rad/s (motor side)")
    for name in ("tau_f", "load_torque"):
        if name not in table:
            continue
        col = np.asarray(table[name], dtype=float)
        bad = np.flatnonzero(~np.isfinite(col) | (np.abs(np.nan_to_num(col)) > MAX_TORQUE))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{at(i)}: {name} {float(col[i])!r} is not a finite normalized torque within "
                                 f"+-{MAX_TORQUE:g}")
    if temperature and "temperature" in table:
        col = np.asarray(table["temperature"], dtype=float)
        lo, hi = TEMPERATURE_LIMITS
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~np.isnan(col) & ~((col >= lo) & (col <= hi)))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{at(i)}: temperature {float(col[i]):g} degC is outside [{lo:g}, {hi:g}] degC")
    if "tau_f_std" in table:
        col = np.asarray(table["tau_f_std"], dtype=float)
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(~np.isnan(col) & ~(np.isfinite(col) & (col >= 0)))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{at(i)}: tau_f_std {float(col[i])!r} is not a standard error (finite, >= 0; "
                                 "NaN for unknown)")


def resolve_model(
    model: Model | None, params: Parameters | Mapping[str, float] | str | None
) -> tuple[Model, Parameters]:
    """The model (default Eq. 9) and its parameters (default ``ref-2011r``; a name loads a set)."""
    m = model if model is not None else paper_wear_model()
    if params is None:
        params = DEFAULT_PARAMS
    if isinstance(params, str):
        params = load_parameter_set(params)
    return m, m.make_params(params)


def make_rng(rng: np.random.Generator | None = None, seed: int | None = None) -> np.random.Generator:
    """A generator passed in, or a new one from ``seed`` (never numpy's global state)."""
    if rng is not None:
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        return rng
    return np.random.default_rng(seed)


@dataclass(frozen=True)
class Rows:
    """Checked observation rows, as plain arrays of equal length."""

    speed: Array
    tau_f: Array
    load: Array
    temperature: Array  # NaN = unknown
    noise_std: Array
    source: str

    def __len__(self) -> int:
        return int(self.speed.size)

    @property
    def known_temperature(self) -> npt.NDArray[np.bool_]:
        return np.isfinite(self.temperature)


def prepare_rows(
    table: ObservationTable,
    *,
    noise_std: float = DEFAULT_NOISE_STD,
    default_load: float | None = None,
    use_temperature: bool = True,
) -> Rows:
    """Check one cycle's observations and return them as arrays.

    Raises :class:`~jointwear_ros.errors.InputDataError` naming the row and the
    value when the table is empty, a speed is negative or not finite, a
    friction value is not finite, a load torque is missing, a temperature is
    infinite or below absolute zero, or a ``tau_f_std`` is negative.
    (The wear monitor screens live observations before this, dropping or
    correcting them one by one: :mod:`jointwear_ros.monitor.validation`.)
    """
    if not isinstance(table, ObservationTable):
        raise InputDataError(
            f"estimators take an ObservationTable, got {type(table).__name__}; "
            "build one with ObservationTable.from_arrays(speed=..., tau_f=..., load_torque=...)"
        )
    where = table.source or "observations"
    n = len(table)
    if n == 0:
        raise InputDataError(f"{where}: the table is empty; a wear estimate needs at least one friction observation")
    speed = np.asarray(table.speed, dtype=float)
    tau = np.asarray(table.tau_f, dtype=float)
    bad = np.flatnonzero(~np.isfinite(speed))
    if bad.size:
        i = int(bad[0])
        raise InputDataError(f"{where}: row {i}: speed {float(speed[i])!r} is not finite; give the motor-side speed in rad/s")
    bad = np.flatnonzero(speed < 0)
    if bad.size:
        i = int(bad[0])
        raise InputDataError(
            f"{where}: row {i}: speed {speed[i]:g} is negative; the friction model is for |v|: "
            "give the speed magnitude (motor side, rad/s)"
        )
    bad = np.flatnonzero(~np.isfinite(tau))
    if bad.size:
        i = int(bad[0])
        raise InputDataError(
            f"{where}: row {i} (speed {speed[i]:g} rad/s): tau_f {float(tau[i])!r} is not finite; "
            "drop the observation or repeat that speed"
        )
    if "load_torque" in table:
        load = np.abs(np.asarray(table["load_torque"], dtype=float))
        bad = np.flatnonzero(~np.isfinite(load))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{where}: row {i} (speed {speed[i]:g} rad/s): load_torque {float(load[i])!r} is not finite")
    elif default_load is not None:
        load = np.full(n, abs(float(default_load)))
    else:
        raise InputDataError(
            f"{where}: column 'load_torque' is missing; give the manipulated load torque tau_m "
            "per observation or pass default_load= to the estimator"
        )
    if use_temperature and "temperature" in table:
        temp = np.asarray(table["temperature"], dtype=float).copy()
        bad = np.flatnonzero(np.isinf(temp))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{where}: row {i}: temperature {float(temp[i])!r} is infinite; use NaN for unknown")
        bad = np.flatnonzero(temp < ABSOLUTE_ZERO)
        if bad.size:
            i = int(bad[0])
            raise InputDataError(
                f"{where}: row {i}: temperature {float(temp[i]):g} degC is below absolute zero; "
                "a sensor fault: use NaN for unknown"
            )
    else:
        temp = np.full(n, math.nan)
    check_observation_values(table, temperature=use_temperature)  # the bounds the checks above do not cover
    if not (math.isfinite(noise_std) and noise_std > 0):
        raise InputDataError(f"noise_std = {noise_std!r} must be a positive number (normalized torque)")
    sig = np.full(n, float(noise_std))
    if "tau_f_std" in table:
        given = np.asarray(table["tau_f_std"], dtype=float)  # NaN or >= 0: check_observation_values above
        ok = np.isfinite(given) & (given > 0)
        # no friction observation is known better than MIN_TAU_F_STD: keeps the weights 1/std^2 finite
        sig[ok] = np.maximum(given[ok], MIN_TAU_F_STD)
    return Rows(speed=speed.copy(), tau_f=tau.copy(), load=load, temperature=temp, noise_std=sig, source=where)


def combine_rows(
    rows: Rows,
    wear: Array,
    wear_std: Array,
    *,
    method: str,
    info: Mapping[str, Any] | None = None,
    temperature: float = math.nan,
    temperature_std: float = math.nan,
) -> WearResult:
    """One result from per-row estimates of a per-speed estimator.

    The cycle estimate is the inverse-variance weighted mean of the rows. Rows of
    one cycle share one temperature, so their errors are correlated; the reported
    std is the weighted mean of the row stds (the fully-correlated case, an upper
    bound) and the interval is estimate +- 2 std, clipped to [0, 100].
    """
    var = np.maximum(np.asarray(wear_std, dtype=float) ** 2, 1e-12)
    wts = 1.0 / var
    wts = wts / wts.sum()
    est = float(np.sum(wts * wear))
    std = float(np.sum(wts * np.sqrt(var)))
    lo, hi = WEAR_RANGE
    return WearResult(
        wear=est,
        wear_std=std,
        wear_low=max(lo, est - 2.0 * std),
        wear_high=min(hi, est + 2.0 * std),
        method=method,
        temperature=temperature,
        temperature_std=temperature_std,
        speeds=tuple(float(s) for s in rows.speed),
        per_speed_wear=tuple(float(w) for w in wear),
        info=dict(info or {}, per_speed_std=[float(s) for s in np.sqrt(var)], interval="estimate +- 2 std"),
    )
