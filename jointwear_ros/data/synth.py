"""Synthetic observation tables: the reference model plus optional hidden effects.

Each test cycle has its own temperature ``T``; each observation (one speed of
one cycle) has its own load torque ``tau_m`` and window position. Friction is
the reference model (Eq. 6, or Eq. 9 with a wear level) plus any hidden
effects, plus Gaussian noise ``sigma_e`` (the paper's 0.0015). The hidden
effects are what the model workbench should find:

``load_viscous``
    a load-dependent viscous term ``k * tau_m * v`` (k = 1.5e-4 s/rad).
``ripple``
    a periodic friction ripple in joint position
    ``A * sin(omega * position + phi)`` (A = 0.004, omega = 3 rad^-1).
``lubrication``
    low-speed friction that grows with hours since lubrication (column
    ``lube_hours``): ``k * h * exp(-|v / 15|^1.3)`` (k = 1.0e-5 per hour).
``time_drift``
    a slow drift of the friction level with time (column ``time``, s):
    ``k * time`` (k = 0.012 per 40 days).

The generator also offers effects that the workbench's fixed candidate library cannot
express, as a geared robot joint shows them:

``ripple_fast``
    a gear-mesh ripple at a high angular frequency,
    ``0.003 * sin(17 * position + 0.3)``.
``regreasing``
    friction drops once, by 0.006, when the joint is regreased: at 55 % of
    the time span of the table (a step in ``time``).
``warmup``
    friction falls and saturates over the first hours of running after a
    start: ``-0.006 * (1 - exp(-hours_running / 1.5))`` (column
    ``hours_running``, 0-8 h, one value per cycle).
``stribeck_temperature``
    the load Stribeck hump reshaped by temperature: the term ``Fstm*|tau_m|*S(v; vstm)``
    of Eq. (6a) times ``(1 + 0.025 * (T - 40))``.
``bearing_load``
    the bearing load from the link's own weight, a friction change
    ``0.004 * cos(position)`` at the joint's own period.
``torque_constant``
    the motor's torque constant falls with the magnets' temperature (column
    ``motor_temperature``: the joint temperature plus 0-25 degC of self
    heating per cycle), so the friction computed from the current reads
    ``tau_f * (1 - 0.002 * (T_motor - 50))``.

``irrelevant`` extra columns (``aux_01``, ...) hold random numbers (per
observation or per cycle) that nothing depends on: the workbench must not
raise an alarm on them.

Pure numpy; no file or ROS access (writing is the IO layer's job).

>>> t = synth_observations(n_cycles=3, seed=1)
>>> len(t), sorted(t.names)[:3]
(30, ['cycle', 'hours_running', 'load_torque'])
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from ..model import load_parameter_set_info, parse_model_spec, stribeck_shape
from ..types import ObservationTable
from ..units import SUITE_UNITS

__all__ = ["DEFAULT_SPEEDS", "EFFECT_FAMILIES", "HIDDEN_EFFECTS", "NOISE_STD", "HiddenEffect", "synth_observations"]

Array = npt.NDArray[np.float64]

#: The paper's measurement noise sigma_e (normalized torque).
NOISE_STD = 0.0015

#: Speeds of one synthetic test cycle, motor side, rad/s.
DEFAULT_SPEEDS: tuple[float, ...] = (2.0, 6.0, 12.0, 20.0, 32.0, 47.0, 70.0, 110.0, 170.0, 250.0)


@dataclass(frozen=True)
class HiddenEffect:
    """One effect the generator can hide in the data: what it is and which column drives it."""

    name: str
    description: str
    variables: tuple[str, ...]


#: Every hidden-effect family the generator offers (the four of the paper's neighbourhood and six the fixed library cannot express).
EFFECT_FAMILIES: dict[str, HiddenEffect] = {
    e.name: e
    for e in (
        HiddenEffect("load_viscous", "load-dependent viscous friction 1.5e-4 * tau_m * v", ("load_torque",)),
        HiddenEffect("ripple", "position ripple 0.004 * sin(3 * position + 0.7)", ("position",)),
        HiddenEffect(
            "lubrication", "low-speed friction 1e-5 * lube_hours * exp(-|v/15|^1.3)", ("lube_hours",)
        ),
        HiddenEffect("time_drift", "friction drift 0.012 per 40 days of time", ("time",)),
        HiddenEffect("ripple_fast", "gear-mesh ripple 0.003 * sin(17 * position + 0.3)", ("position",)),
        HiddenEffect("regreasing", "friction level drops by 0.006 at 55 % of the time span (regreasing)",
                     ("time",)),
        HiddenEffect("warmup", "-0.006 * (1 - exp(-hours_running / 1.5)): friction falls over the first hours",
                     ("hours_running",)),
        HiddenEffect("stribeck_temperature", "load Stribeck term times (1 + 0.025 * (T - 40))", ("temperature",)),
        HiddenEffect("bearing_load", "bearing load of the link's weight 0.004 * cos(position)", ("position",)),
        HiddenEffect("torque_constant", "torque constant falls with the motor temperature: "
                     "tau_f * (1 - 0.002 * (motor_temperature - 50))", ("motor_temperature",)),
    )
}


#: The effects the simulated joint (:mod:`jointwear_ros.sim.friction`) reproduces too: the first four.
HIDDEN_EFFECTS: dict[str, HiddenEffect] = {
    k: EFFECT_FAMILIES[k] for k in ("load_viscous", "ripple", "lubrication", "time_drift")
}


def _need(cols: dict[str, Array], name: str, effect: str) -> Array:
    if name not in cols:
        raise InputDataError(f"hidden effect {effect!r} needs the column {name!r}, which is not given")
    return cols[name]


def effect_value(name: str, cols: dict[str, Array]) -> Array:
    v = np.abs(cols["speed"])
    if name == "load_viscous":
        return 1.5e-4 * cols["load_torque"] * v
    if name == "ripple":
        return 0.004 * np.sin(3.0 * cols["position"] + 0.7)
    if name == "lubrication":
        s, _ = stribeck_shape(v, 15.0)
        return 1.0e-5 * cols["lube_hours"] * s
    if name == "time_drift":
        return 0.012 * cols["time"] / (40.0 * 86400.0)
    if name == "ripple_fast":
        return 0.003 * np.sin(17.0 * cols["position"] + 0.3)
    if name == "regreasing":
        t = _need(cols, "time", name)
        at = float(np.min(t)) + 0.55 * float(np.ptp(t)) if t.size else 0.0
        return np.where(t > at, -0.006, 0.0) if np.ptp(t) > 0 else np.zeros_like(t)
    if name == "warmup":
        return -0.006 * (1.0 - np.exp(-_need(cols, "hours_running", name) / 1.5))
    if name == "stribeck_temperature":
        s, _ = stribeck_shape(v, 12.0)
        return 0.08 * np.abs(cols["load_torque"]) * s * 0.025 * (_need(cols, "temperature", name) - 40.0)
    if name == "bearing_load":
        return 0.004 * np.cos(cols["position"])
    if name == "torque_constant":
        return -0.002 * (_need(cols, "motor_temperature", name) - 50.0) * _need(cols, "tau_model", name)
    raise InputDataError(f"unknown hidden effect {name!r}; known: {', '.join(EFFECT_FAMILIES)}")


def synth_observations(
    n_cycles: int = 40,
    speeds: Sequence[float] = DEFAULT_SPEEDS,
    effects: Iterable[str] = (),
    *,
    seed: int | None = 0,
    rng: np.random.Generator | None = None,
    params: str = "ref-2011r",
    model: str = "paper",
    temperature: tuple[float, float] = (25.0, 55.0),
    load: tuple[float, float] = (0.02, 0.5),
    position: tuple[float, float] = (-2.5, 2.5),
    wear: float = 0.0,
    noise: float = NOISE_STD,
    irrelevant: int = 0,
) -> ObservationTable:
    """Observation table from the reference model plus hidden effects and noise.

    Parameters
    ----------
    n_cycles
        Number of test cycles; each gives one observation per speed.
    speeds
        Speeds of a cycle, motor side, rad/s (>= 0).
    effects
        Names of hidden effects (keys of :data:`EFFECT_FAMILIES`).
    seed, rng
        Random generator, or the seed of a new one (``rng`` wins).
    params
        Parameter set of the reference model.
    model
        ``paper`` (Eq. 6) or ``paper+wear`` (Eq. 9, with ``wear``).
    temperature, load, position
        Uniform ranges of the cycle temperature (degC), the load torque per
        observation (normalized) and the window centre per observation (rad).
        Give equal bounds to hold a quantity fixed.
    wear
        Wear level used by ``paper+wear``; a ``wear`` column is written then.
    noise
        Standard deviation of the Gaussian noise on ``tau_f``; also the
        ``tau_f_std`` column.
    irrelevant
        Number of extra columns ``aux_01``, ... of random numbers nothing
        depends on (odd ones per observation, even ones per cycle).

    Returns
    -------
    ObservationTable
        Columns ``cycle``, ``time``, ``speed``, ``tau_f``, ``tau_f_std``,
        ``tau_plus``, ``tau_minus``, ``load_torque``, ``temperature``,
        ``position``, ``lube_hours``, ``hours_running``, ``motor_temperature`` (and ``wear`` for
        ``paper+wear``, ``aux_NN`` for irrelevant columns). The columns of
        the first four effects are drawn exactly as before: a seed gives the same values.
    """
    effects = list(effects)
    for e in effects:
        if e not in EFFECT_FAMILIES:
            raise InputDataError(f"unknown hidden effect {e!r}; known: {', '.join(EFFECT_FAMILIES)}")
    if n_cycles < 1:
        raise InputDataError(f"n_cycles must be at least 1, got {n_cycles}")
    sp = np.asarray(list(speeds), dtype=float)
    if sp.size == 0 or np.any(sp < 0) or not np.all(np.isfinite(sp)):
        raise InputDataError("speeds must be a non-empty list of finite values >= 0")
    if model not in ("paper", "paper+wear"):
        raise InputDataError(f"synthetic data model must be 'paper' or 'paper+wear', got {model!r}")
    for what, (lo, hi) in (("temperature", temperature), ("load", load), ("position", position)):
        if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
            raise InputDataError(f"{what} range [{lo}, {hi}] is not a finite interval lo <= hi")
    if not 0 <= irrelevant <= 99:
        raise InputDataError(f"irrelevant columns must be 0 to 99, got {irrelevant}")
    if not (noise >= 0 and np.isfinite(noise)):
        raise InputDataError(f"noise must be finite and >= 0, got {noise}")
    gen = rng if rng is not None else np.random.default_rng(seed)

    m = parse_model_spec(model)
    info = load_parameter_set_info(params)
    p = m.make_params(info.parameters())
    # a joint-frame set (N·m, joint side) is evaluated in its own units and the table kept in the suite's
    sf, tf = info.units.speed_factor, info.units.torque_factor
    ns = sp.size
    n = n_cycles * ns
    cycle = np.repeat(np.arange(n_cycles, dtype=float), ns)
    # a cycle a day, one speed every 30 s; jitter the start of the day
    day = np.repeat(np.arange(n_cycles) * 86400.0 + gen.uniform(0.0, 3600.0, n_cycles), ns)
    time = day + np.tile(np.arange(ns) * 30.0, n_cycles)
    T = np.repeat(gen.uniform(temperature[0], temperature[1], n_cycles), ns)
    # hours since the last lubrication: each cycle on its own schedule
    hours = np.repeat(gen.uniform(0.0, 2000.0, n_cycles), ns)
    tm = gen.uniform(load[0], load[1], n)
    pos = gen.uniform(position[0], position[1], n)
    v = np.tile(sp, n_cycles)
    cols: dict[str, Array] = {
        "cycle": cycle,
        "time": time,
        "speed": v,
        "load_torque": tm,
        "temperature": T,
        "position": pos,
        "lube_hours": hours,
    }
    inputs = dict(speed=v * sf, load_torque=tm * tf, temperature=T)
    if model == "paper+wear":
        cols["wear"] = np.full(n, float(wear))
        inputs["wear"] = cols["wear"]
    tau = m.evaluate(p, **inputs) / tf
    # columns added after the first four effects come from a separate stream, so the older columns keep their values
    extra = np.random.Generator(cast(Any, gen.bit_generator).jumped())  # PCG64 (default_rng) jumps
    cols["hours_running"] = np.repeat(extra.uniform(0.0, 8.0, n_cycles), ns)
    cols["motor_temperature"] = T + np.repeat(extra.uniform(0.0, 25.0, n_cycles), ns)
    aux: dict[str, Array] = {}
    for i in range(1, irrelevant + 1):
        scale = 10.0 ** extra.uniform(-2.0, 3.0)
        per_cycle = i % 2 == 0
        vals = extra.uniform(0.0, scale, n_cycles if per_cycle else n)
        aux[f"aux_{i:02d}"] = np.repeat(vals, ns) if per_cycle else vals
    effect_cols = {**cols, "tau_model": tau}
    total = tau.copy()
    for e in effects:
        total = total + effect_value(e, effect_cols)
    tau = total + gen.normal(0.0, noise, n) if noise > 0 else total
    # u+ and u- around a gravity torque of +-tau_m (sign from the window position)
    g = tm * np.sign(np.cos(pos) + 1e-12)
    cols["tau_f"] = tau
    cols["tau_f_std"] = np.full(n, float(noise))
    cols["tau_plus"] = g + tau
    cols["tau_minus"] = g - tau
    order = ["cycle", "time", "speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus",
             "load_torque", "temperature", "position", "lube_hours", "hours_running", "motor_temperature", "wear"]
    out = {k: cols[k] for k in order if k in cols}
    out.update(aux)
    return ObservationTable(out, source="synth", units=SUITE_UNITS)
