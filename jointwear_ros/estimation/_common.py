"""Shared plumbing of the estimators: model resolution, input checks, combining rows.

Pure numpy; no ROS import.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError, ModelError
from ..model import Model, Parameters, ParameterSet, load_parameter_set_info, paper_wear_model
from ..types import ObservationTable, WearResult

__all__ = [
    "ABSOLUTE_ZERO",
    "DEFAULT_NOISE_STD",
    "DEFAULT_PARAMS",
    "WEAR_RANGE",
    "Capabilities",
    "Progress",
    "Rows",
    "SetModel",
    "SetModelBase",
    "capabilities_of",
    "check_estimator_options",
    "check_noise_std",
    "check_observation_values",
    "check_wear_range",
    "combine_rows",
    "log_sum_exp",
    "make_rng",
    "prepare_rows",
    "resolve_model",
    "resolve_set",
    "set_frame_table",
    "setup_model",
    "split_extra",
    "with_set_info",
]

#: Inputs every estimator supplies itself (the grid variables and the standard columns).
STANDARD_INPUTS = ("speed", "load_torque", "temperature", "wear")

Array = npt.NDArray[np.float64]
#: A study's progress callback: ``progress(done, total)``.
Progress = Callable[[int, int], None]

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


@dataclass(frozen=True)
class Capabilities:
    """What an estimator can do, declared on its class (``capabilities = Capabilities(...)``).

    Whoever must treat estimators differently (the study, the case study, the CLI's options, the
    memory check) asks these flags, never the estimator's name; :data:`~jointwear_ros.estimation.ESTIMATORS`
    lists them per name (``jointwear_ros.estimation.ESTIMATORS.table()``). An estimator without the
    attribute gets the defaults: a per-observation estimator that assumes nothing about T.

    Attributes
    ----------
    summary : one line for the method list.
    cycle : estimates w from all speeds of a cycle at once, at one shared unknown temperature (one
        estimate per cycle); else each observation on its own and the rows combined.
    temperature_assumption : how an unknown temperature enters: ``"range"`` a uniform range
        (option ``temperature_range``), ``"prior"`` a stated distribution (option ``prior``),
        ``"fixed"`` a value of its own, ``"none"`` not said.
    uses_temperature : a measured temperature (finite ``temperature`` column) replaces the assumption.
    needs_seed : draws random numbers: ``seed``/``rng`` make it reproducible (else deterministic; it
        still accepts ``seed`` as every estimator does).
    temperature_samples : draws ``n_samples`` temperatures per observation (memory grows with rows x samples).
    gives_posterior : ``wear_std`` and the interval are a posterior's (std, credible interval).
    search : how w is found: ``"table"`` (a tabulated inverse), ``"grid"`` (a scan), ``"posterior grid"``,
        ``"optimizer"``.
    points : the point estimates it reports, as ``(name, its point= value)`` pairs; a name given for
        another estimator's point (``map`` for ``mode``) maps to the nearest one here.
    joint_frame : takes a joint-side parameter set (speeds and torques in the set's units).
    """

    summary: str = ""
    cycle: bool = False
    temperature_assumption: str = "none"
    uses_temperature: bool = True
    needs_seed: bool = False
    temperature_samples: bool = False
    gives_posterior: bool = False
    search: str = ""
    points: tuple[tuple[str, str], ...] = ()
    joint_frame: bool = True

    def point(self, name: str) -> str | None:
        """This estimator's ``point=`` value for a point name (``mode``, ``mean``, ``map``); None: no such option.

        >>> Capabilities(points=(("mode", "mode"), ("map", "mode"), ("mean", "mean"))).point("map")
        'mode'
        """
        return dict(self.points).get(name)


def capabilities_of(estimator: Any) -> Capabilities:
    """The capabilities an estimator (a class or an instance) declares; the defaults when it declares none."""
    caps = getattr(estimator, "capabilities", None)
    return caps if isinstance(caps, Capabilities) else Capabilities()


def check_estimator_options(options: Mapping[str, Any], torque_factor: float = 1.0) -> None:
    """Refuse estimator options no estimator can work with (the options :func:`make_estimator` passes on).

    ``noise_std`` finite in (0, 1] (x ``torque_factor``: a joint-side set's torque unit per normalized
    unit; its noise is in N·m); ``default_load`` None or finite with
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
        if not (math.isfinite(x) and 0 < x <= torque_factor):
            unit = "normalized torque" if torque_factor == 1.0 else "the parameter set's torque unit"
            raise InputDataError(f"estimator option noise_std = {options['noise_std']!r}: must be a finite number "
                                 f"in (0, {torque_factor:g}] ({unit})")
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


def resolve_set(
    model: Model | None, params: Parameters | Mapping[str, float] | str | ParameterSet | None
) -> tuple[Model, Parameters, ParameterSet | None]:
    """The model, its parameters and the parameter set they came from (None for values passed in).

    ``params`` a name or a YAML path loads a set (default ``ref-2011r``); the model is
    then the set's own (its ``model`` spec, Eq. 9 when it names none) unless ``model`` is given.
    """
    pset: ParameterSet | None = None
    if params is None:
        params = DEFAULT_PARAMS
    if isinstance(params, str):
        params = load_parameter_set_info(params)
    if isinstance(params, ParameterSet):
        pset = params
        m = model if model is not None else pset.model()
        return m, m.make_params(pset.parameters()), pset
    m = model if model is not None else paper_wear_model()
    return m, m.make_params(params), None


def resolve_model(
    model: Model | None, params: Parameters | Mapping[str, float] | str | ParameterSet | None
) -> tuple[Model, Parameters]:
    """The model (default: the set's, else Eq. 9) and its parameters (default ``ref-2011r``; a name loads a set).

    A set whose model has terms of other inputs (``ripple(position)``) gives its core terms
    (:func:`split_extra`): the bound, the cycle design and the study evaluate at speed, load,
    temperature and wear, where a term of another input is a known offset that carries no
    information about w, so the bound stays exact.
    """
    m, p, _ = resolve_set(model, params)
    return split_extra(m)[0], p


def split_extra(model: Model) -> tuple[Model, Model | None]:
    """``(core, extra)``: the terms of the standard inputs, and those needing other inputs (or None).

    A term of another input (``ripple(position)``, a column the set names) enters a
    wear estimate as a known per-observation offset: its value is computed from the
    observation's own input and taken off ``tau_f``, which is exact as long as the
    term depends on neither temperature nor wear (checked here; :class:`ModelError`).

    >>> from jointwear_ros.model import parse_model_spec
    >>> core, extra = split_extra(parse_model_spec("paper+wear"))
    >>> core.spec == "coulomb + load_coulomb + load_stribeck + temp_stribeck + temp_viscous + wear_stribeck + wear_viscous", extra
    (True, None)
    """
    core = [t for t in model.terms if all(v in STANDARD_INPUTS for v in t.variables)]
    extra = [t for t in model.terms if t not in core]
    for t in extra:
        shared = [v for v in t.variables if v in ("temperature", "wear")]
        if shared:
            raise ModelError(f"term {t.name!r} of model {model.spec!r} needs {', '.join(v for v in t.variables if v not in STANDARD_INPUTS)} "
                             f"and {' and '.join(shared)}; the wear estimators take a term of another input as a "
                             "known offset, which needs it to depend on neither temperature nor wear")
    if not core:
        raise ModelError(f"model {model.spec!r} has no term of speed, load or temperature")
    return Model(core), (Model(extra) if extra else None)


def set_frame_table(table: ObservationTable, pset: ParameterSet | None) -> ObservationTable:
    """The suite's observations (motor side, normalized) in a joint-frame set's units (identity otherwise)."""
    if pset is None:
        return table
    from ..units import to_set_frame

    return to_set_frame(table, pset.units)  # type: ignore[no-any-return]


def extra_offset(table: ObservationTable, extra: Model | None, params: Parameters) -> Array:
    """The known offset of the extra terms per row (0 without them); a missing input is refused with the reason."""
    n = len(table)
    if extra is None:
        return np.zeros(n)
    where = table.source or "observations"
    inputs: dict[str, Array] = {}
    for var in extra.variables:
        if var not in table:
            terms = ", ".join(t.name for t in extra.terms if var in t.variables)
            raise InputDataError(f"{where}: column {var!r} is missing; the parameter set's model needs it for "
                                 f"{terms}: give {var!r} with each observation")
        col = np.asarray(table[var], dtype=float)
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{where}: row {i}: {var} {float(col[i])!r} is not finite; the parameter set's "
                                 f"model needs {var!r} for every observation")
        inputs[var] = col
    return np.asarray(np.broadcast_to(extra.evaluate(params, **inputs), (n,)), dtype=float)


def log_sum_exp(a: npt.NDArray[np.float64], axis: int, *, overwrite: bool = False) -> npt.NDArray[np.float64]:
    """``log(sum(exp(a)))`` along ``axis``, for arrays whose maximum along it is finite (the log weights of the
    quadrature nodes or kept cells the estimators sum over). Written out (maximum, exp, sum, log) rather than
    :func:`scipy.special.logsumexp`: its general handling of infinities, signs and array namespaces cost several
    times the sum itself on these small blocks (0.53 against 0.14 ms on 24 x 401), summed thousands of times by a
    study. ``overwrite``: ``a`` is scratch, used in place."""
    top = a.max(axis=axis, keepdims=True)
    b = a if overwrite else np.empty_like(a)
    np.subtract(a, top, out=b)
    np.exp(b, out=b)
    out: npt.NDArray[np.float64] = np.log(b.sum(axis=axis)) + np.squeeze(top, axis=axis)
    return out


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
    pset: ParameterSet | None = None,
    extra: Model | None = None,
    params: Parameters | None = None,
) -> Rows:
    """Check one cycle's observations and return them as arrays.

    Raises :class:`~jointwear_ros.errors.InputDataError` naming the row and the
    value when the table is empty, a speed is negative or not finite, a
    friction value is not finite, a load torque is missing, a temperature is
    infinite or below absolute zero, or a ``tau_f_std`` is negative.
    (The wear monitor screens live observations before this, dropping or
    correcting them one by one: :mod:`jointwear_ros.monitor.validation`.)

    With ``pset`` in the joint frame the rows come back in its units (speed
    joint side, torques N·m); with ``extra`` terms (inputs other than speed, load,
    temperature) their value per row is taken off ``tau_f`` (see :func:`split_extra`).
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
    sig = np.full(n, check_noise_std(noise_std))
    if "tau_f_std" in table:
        given = np.asarray(table["tau_f_std"], dtype=float)  # NaN or >= 0: check_observation_values above
        ok = np.isfinite(given) & (given > 0)
        # no friction observation is known better than MIN_TAU_F_STD: keeps the weights 1/std^2 finite
        sig[ok] = np.maximum(given[ok], MIN_TAU_F_STD)
    speed, tau = speed.copy(), tau.copy()
    if pset is not None and pset.units.joint_side:
        sf, tf = pset.units.speed_factor, pset.units.torque_factor
        speed, tau, load = speed * sf, tau * tf, load * tf
        if "tau_f_std" in table:  # the default noise_std is the set's own, already in its unit
            sig = np.where(ok, sig * tf, sig)
    if extra is not None:
        if params is None:
            raise ValueError("prepare_rows: extra terms need params")
        tau = tau - extra_offset(set_frame_table(table, pset), extra, params)
    return Rows(speed=speed, tau_f=tau, load=load, temperature=temp, noise_std=sig, source=where)


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


@dataclass(frozen=True)
class SetModel:
    """What an estimator takes from its model and set: the full model, its core terms, the extra terms
    (inputs other than speed, load, temperature, wear; None without), the parameters, the set, sigma_e."""

    full_model: Model
    model: Model
    extra: Model | None
    params: Parameters
    param_set: ParameterSet | None
    noise_std: float


def setup_model(
    model: Model | None, params: Parameters | Mapping[str, float] | str | ParameterSet | None,
    noise_std: float | None,
) -> SetModel:
    """An estimator's model, parameters and set (:func:`resolve_set`, :func:`split_extra`) and its noise_std.

    ``noise_std`` None takes the set's own ``noise_std`` (in its torque unit), else
    the paper's :data:`DEFAULT_NOISE_STD` converted to the set's torque unit.
    """
    m, p, pset = resolve_set(model, params)
    core, extra = split_extra(m)
    if noise_std is None:
        if pset is not None and pset.noise_std is not None:
            noise_std = pset.noise_std
        else:  # the paper's sigma_e, in the set's torque unit
            noise_std = DEFAULT_NOISE_STD * (pset.units.torque_factor if pset is not None else 1.0)
    return SetModel(m, core, extra, p, pset, float(noise_std))


class SetModelBase:
    """Base of the estimators built on a model and a parameter set: what they take from :func:`setup_model`."""

    full_model: Model
    model: Model
    extra: Model | None
    params: Parameters
    param_set: ParameterSet | None

    def attach_set_model(
        self, model: Model | None, params: Parameters | Mapping[str, float] | str | ParameterSet | None,
        noise_std: float | None,
    ) -> float:
        """Set ``full_model``, ``model``, ``extra``, ``params`` and ``param_set`` from :func:`setup_model`;
        return its noise_std (not yet checked: see :func:`check_noise_std`)."""
        sm = setup_model(model, params, noise_std)
        self.full_model, self.model, self.extra = sm.full_model, sm.model, sm.extra
        self.params, self.param_set = sm.params, sm.param_set
        return sm.noise_std


def check_noise_std(noise_std: float) -> float:
    """sigma_e of an observation as a float, or InputDataError unless a positive finite number."""
    sig = float(noise_std)
    if not (math.isfinite(sig) and sig > 0):
        raise InputDataError(f"noise_std = {noise_std!r} must be a positive number (normalized torque)")
    return sig


def check_wear_range(wear_range: tuple[float, float]) -> tuple[float, float]:
    """An estimator's wear range as ``(low, high)`` floats, or InputDataError unless finite with low < high."""
    lo, hi = float(wear_range[0]), float(wear_range[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise InputDataError(f"wear_range = {wear_range!r}: needs finite low < high")
    return lo, hi


def with_set_info(result: WearResult, pset: ParameterSet | None) -> WearResult:
    """The result with the parameter set, its model, units and wear calibration named in ``info``."""
    from dataclasses import replace

    info = dict(result.info)
    if pset is None:
        info.setdefault("wear_calibration", "given parameters")
    else:
        info["parameter_set"] = pset.name
        info["model"] = pset.spec
        info["units"] = pset.units.frame
        info["wear_calibration"] = pset.wear_calibration
    return replace(result, info=info)


def set_temperature_prior(pset: ParameterSet | None, default: Any) -> Any:
    """The set's ``temperature_prior`` (commissioned sets carry their covered range) or ``default``."""
    if pset is not None and pset.temperature_prior:
        return pset.temperature_prior
    return default
