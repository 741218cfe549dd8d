"""Screening of friction observations before they reach an estimator (pure).

A ``FrictionObservation`` comes from outside (the observer node, a bag, a
hand-made publisher), so every field is checked before the wear monitor uses
it. :func:`screen_observation` returns the observation to use (or ``None``)
and the reason for any change:

- **dropped** (``None``): speed not finite or ``<= 0`` (a test cycle sweeps
  at a positive motor speed; the model is for ``|v|``) or outside the
  parameter set's valid speed range; ``tau_f`` not finite or negative
  (friction opposes motion: ``(u+ - u-)/2 < 0`` is a sign or wiring fault);
  ``tau_f_std`` negative or infinite (NaN means "not given" and is kept: the
  estimator then uses the configured noise level); ``load_torque`` not finite
  or ``|load_torque|`` outside the valid load range.
- **temperature made unknown** (kept, temperature NaN): a temperature that
  is infinite, below absolute zero or outside the plausible range of a robot
  joint (:data:`PLAUSIBLE_TEMPERATURE`) is a sensor fault, and one inside
  that range but outside the parameter set's valid range would extrapolate
  the model. The friction measurement itself is still valid, so the
  observation is kept and the estimator treats its temperature as unknown
  (Eq. 11), which widens the reported std instead of biasing the estimate.
  Dropping it instead would lose a good measurement; using it gave, in the
  reported example, an estimate near 7 with std near 0 for a joint at wear
  40 (one -300 °C reading hid the alarm).

Pure Python; no ROS import.

>>> from jointwear_ros.observer import FrictionObservationData
>>> o = FrictionObservationData(stamp=1.0, joint_name="joint_1", cycle_id=1, speed=40.0, tau_f=0.09,
...     tau_f_std=3e-4, tau_plus=0.19, tau_minus=0.01, load_torque=0.1, temperature=-300.0, position=0.0,
...     samples_plus=500, samples_minus=500)
>>> kept, why = screen_observation(o, {"temperature": (20.0, 60.0)})
>>> kept.temperature, why
(nan, 'temperature -300 degC is below absolute zero (plausible -50 to 200 degC); used as unknown')
>>> screen_observation(replace(o, speed=-40.0))
(None, 'speed -40 rad/s must be finite and > 0 (motor side); dropped')
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

from ..observer.types import PLAUSIBLE_TEMPERATURE, FrictionObservationData

__all__ = ["ABSOLUTE_ZERO", "PLAUSIBLE_TEMPERATURE", "screen_observation"]

#: degC
ABSOLUTE_ZERO = -273.15


def screen_observation(
    o: FrictionObservationData,
    valid: Mapping[str, tuple[float, float]] | None = None,
    *,
    use_temperature: bool = True,
) -> tuple[FrictionObservationData | None, str]:
    """The observation to estimate with (``None`` = dropped) and the reason of a drop or change ("" if none).

    ``valid`` is the parameter set's valid ranges (``speed``, ``load_torque``,
    ``temperature``; see :class:`~jointwear_ros.model.paramsets.ParameterSet`).
    With ``use_temperature`` false the temperature is not looked at (the
    monitor ignores it anyway).
    """
    rng = dict(valid or {})
    v = o.speed
    if not (math.isfinite(v) and v > 0.0):
        return None, f"speed {v:g} rad/s must be finite and > 0 (motor side); dropped"
    if "speed" in rng:
        lo, hi = rng["speed"]
        if not lo <= v <= hi:
            return None, f"speed {v:g} rad/s is outside the parameter set's valid range [{lo:g}, {hi:g}]; dropped"
    if not math.isfinite(o.tau_f):
        return None, f"tau_f {o.tau_f!r} at {v:g} rad/s is not finite; dropped"
    if o.tau_f < 0.0:
        return None, (f"tau_f {o.tau_f:g} at {v:g} rad/s is negative (friction opposes motion: a sign or "
                      "wiring fault); dropped")
    s = o.tau_f_std
    if not math.isnan(s) and not (math.isfinite(s) and s >= 0.0):
        return None, f"tau_f_std {s!r} at {v:g} rad/s must be >= 0 (NaN = not given); dropped"
    load = o.load_torque
    if not math.isfinite(load):
        return None, f"load_torque {load!r} at {v:g} rad/s is not finite; dropped"
    if "load_torque" in rng:
        lo, hi = rng["load_torque"]
        if not lo <= abs(load) <= hi:
            return None, (f"|load_torque| {abs(load):g} at {v:g} rad/s is outside the parameter set's valid range "
                          f"[{lo:g}, {hi:g}]; dropped")
    t = o.temperature
    if not use_temperature or math.isnan(t):
        return o, ""
    plo, phi = PLAUSIBLE_TEMPERATURE
    if not (math.isfinite(t) and plo <= t <= phi):
        what = "below absolute zero" if t < ABSOLUTE_ZERO else "physically impossible for a robot joint"
        return replace(o, temperature=math.nan), (
            f"temperature {t:g} degC is {what} (plausible {plo:g} to {phi:g} degC); used as unknown")
    if "temperature" in rng:
        lo, hi = rng["temperature"]
        if not lo <= t <= hi:
            return replace(o, temperature=math.nan), (
                f"temperature {t:g} degC is outside the parameter set's valid range [{lo:g}, {hi:g}] degC; "
                "used as unknown")
    return o, ""
