"""The wear scale's own uncertainty: how sure a parameter set is of what one unit of wear does to friction.

A wear estimate reads friction through the set's wear parameters (Eq. 7: ``Fsw``,
``vsw``, ``Fvw``). Where those were measured on the joint itself (a calibration FILE:
observations of known wear, or values fitted elsewhere) or come with the set that defines
the joint (``ref-2011r`` and ``paper-printed``: the paper's own joint, Eq. 8 from its
accelerated wear tests; a designed simulated set), the scale is **calibrated** and the
estimate's std is the estimator's (noise and temperature). On a commissioned joint without
wear data the wear parameters are a **prior** (``paper``: the paper's absolute increase per
unit wear; ``relative``: the paper's increase scaled to the joint's friction level; any other
label that is not a FILE calibration): how the joint really wears is unknown, and a wrong
scale multiplies the estimate (a joint that wears like ``relative`` reads about ``r^0.8``
times its wear with ``paper``, ``r`` its friction level over ``ref-2011r``'s).

:func:`wear_scale` tells which (:class:`WearScale`), and :meth:`WearScale.apply` folds the
scale's uncertainty into a result: ``wear_std`` becomes the total
``sqrt(std_noise^2 + (rel_std * max(w, 5))^2)``, the interval widens by the same part, and ``info``
says ``calibrated``, ``wear_std_noise`` (the estimator's std), ``wear_scale_std`` and
``wear_scale_rel_std``. The relative spread of a prior is
``sqrt(SCALE_FLOOR^2 + (SCALE_PER_LOG_RATIO * ln r)^2)``: it covers both hypotheses (the
joint wears like the paper's in absolute terms, or relative to its level), measured on joints
unlike the paper's (``bench/bench_wear_calibration.py``, docs/commissioning.md).
:class:`WearScaledEstimator` wraps an estimator so that every result carries it
(:func:`~jointwear_ros.estimation.make_estimator` does this for every estimator it builds).

Pure numpy; no ROS import.

>>> from jointwear_ros.model import load_parameter_set_info
>>> s = wear_scale(load_parameter_set_info("ref-2011r"))
>>> s.calibrated, s.rel_std
(True, 0.0)
>>> prior = WearScale(False, "relative", 1.35, 0.18, "a prior")
>>> round(prior.std(40.0), 2), round(prior.std(0.0), 2)
(7.2, 0.9)
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..model import Model, Parameters, ParameterSet, SetUnits, load_parameter_set_info, paper_model
from ..types import ObservationTable, WearEstimator, WearResult
from ._common import WEAR_RANGE, capabilities_of

__all__ = ["PRIOR_LABELS", "REFERENCE_SET", "SCALE_FLOOR", "SCALE_MIN_WEAR", "SCALE_PER_LOG_RATIO", "WearScale",
           "WearScaledEstimator", "level_ratio", "wear_scale", "wear_scale_of"]

#: The set whose wear parameters are the paper's (Eq. 8) and whose nominal level ``r`` is measured against.
REFERENCE_SET = "ref-2011r"
#: Wear calibrations that are priors when the set was commissioned (no wear data on the joint).
PRIOR_LABELS = ("midpoint", "paper", "relative")
#: Relative std of a prior wear scale on a joint at the paper's friction level (``r = 1``, where ``paper``
#: and ``relative`` agree): the paper's Eq. (8) comes from one robot's accelerated wear tests.
SCALE_FLOOR = 0.10
#: Relative std per unit of ``|ln r|`` (measured: the estimates of the two hypotheses differ by about
#: ``r^0.8`` at wear 20-40 and more at wear 10, where the Stribeck width ``vsw w`` bends the relation).
SCALE_PER_LOG_RATIO = 0.6
#: The scale part is ``rel_std x max(w, SCALE_MIN_WEAR)``: near w = 0 a wrong scale still moves the estimate
#: by a few units (a low-friction joint at true wear 10 read 2.7 with the other hypothesis).
SCALE_MIN_WEAR = 5.0
#: Two-sided 95 % of a normal: the interval's half-width of the scale part.
_Z95 = 1.959963984540054


@dataclass(frozen=True)
class WearScale:
    """Whether a set's wear scale is calibrated, and the relative std of the scale when it is not.

    ``label``: the set's ``wear.calibration`` (``given parameters`` without a set);
    ``level_ratio``: the joint's nominal friction at v = 0 over ``ref-2011r``'s (NaN when not needed);
    ``rel_std``: relative std of the wear scale (0 when calibrated); ``reason``: one line why.
    """

    calibrated: bool
    label: str
    level_ratio: float
    rel_std: float
    reason: str

    def std(self, wear: float) -> float:
        """The scale's part of the std at an estimate ``wear``: ``rel_std x wear``, the wear clipped to
        [:data:`SCALE_MIN_WEAR`, 100]."""
        if not math.isfinite(wear):
            return math.nan
        return float(self.rel_std * min(max(wear, SCALE_MIN_WEAR), WEAR_RANGE[1]))

    def apply(self, result: WearResult) -> WearResult:
        """``result`` with the scale's uncertainty folded into ``wear_std`` and the interval, named in ``info``."""
        info = dict(result.info)
        noise = float(result.wear_std)
        part = self.std(result.wear) if not self.calibrated else 0.0
        info.update(calibrated=self.calibrated, wear_std_noise=noise, wear_scale_std=part,
                    wear_scale_rel_std=self.rel_std)
        if math.isfinite(self.level_ratio):
            info["wear_level_ratio"] = self.level_ratio
        if not (part > 0 and math.isfinite(noise)):
            return replace(result, info=info)
        est, lo_b, hi_b = float(result.wear), WEAR_RANGE[0], WEAR_RANGE[1]
        add = _Z95 * part
        low = est - math.hypot(max(est - result.wear_low, 0.0), add)
        high = est + math.hypot(max(result.wear_high - est, 0.0), add)
        info["interval"] = f"{info.get('interval', 'interval')} widened by the wear scale (+-1.96 x wear_scale_std)"
        return replace(result, wear_std=math.hypot(noise, part), wear_low=max(lo_b, min(low, result.wear_low)),
                       wear_high=min(hi_b, max(high, result.wear_high)), info=info)


def _commissioned(pset: ParameterSet) -> bool:
    """Written by commissioning (a nominal model fitted on baseline data, at w = 0)."""
    prov = pset.provenance or {}
    return any(k in prov for k in ("cycles", "observations")) or pset.description.startswith("commissioned")


def level_ratio(model: Model, params: Parameters | Mapping[str, float], units: SetUnits, temperature: float,
                load: float, speed: float = 0.0) -> float:
    """A joint's nominal friction at ``speed`` (set units, wear 0, other inputs at 0) over ``ref-2011r``'s there.

    ``temperature`` (degC), ``load`` and ``speed`` (set units) are where both are compared; the reference's
    temperature is clipped to its valid range. NaN when either level is not positive.
    """
    ref = load_parameter_set_info(REFERENCE_SET)
    pm = paper_model()
    t_lo, t_hi = ref.valid.get("temperature", (-math.inf, math.inf))
    f_ref = float(pm.evaluate(pm.make_params(ref.parameters()), speed=speed / units.speed_factor,
                              load_torque=load / units.torque_factor,
                              temperature=min(max(temperature, t_lo), t_hi))) * units.torque_factor
    inputs: dict[str, Any] = {"speed": speed, "load_torque": load, "temperature": temperature, "wear": 0.0}
    inputs = {k: v for k, v in inputs.items() if k in model.variables}
    for var in model.variables:  # inputs of other terms: at 0 (a ripple's mean is 0 only on average; a level)
        inputs.setdefault(var, 0.0)
    p = params if isinstance(params, Parameters) else model.make_params(dict(params))
    f0 = float(np.mean(model.evaluate(p, **inputs)))
    if not (math.isfinite(f0) and f0 > 0 and f_ref > 0):
        return math.nan
    return f0 / f_ref


def _set_level_ratio(pset: ParameterSet) -> float:
    """``r`` of a set: exact from a ``relative`` set's Fsw; else its nominal level at the middle of its ranges."""
    ref = load_parameter_set_info(REFERENCE_SET).values
    tf = pset.units.torque_factor
    recorded = pset.wear.get("level_ratio")
    if isinstance(recorded, (int, float)) and math.isfinite(recorded) and recorded > 0:
        return float(recorded)  # what commissioning measured, at the baseline's lowest speed
    if pset.wear_calibration == "relative" and "Fsw" in pset.values and ref.get("Fsw"):
        return float(pset.values["Fsw"] / (ref["Fsw"] * tf))
    if pset.wear_calibration == "midpoint" and "Fsw" in pset.values and ref.get("Fsw"):
        return float((pset.values["Fsw"] / (ref["Fsw"] * tf)) ** 2)
    t_lo, t_hi = pset.valid.get("temperature", (40.0, 40.0))
    l_lo, l_hi = pset.valid.get("load_torque", (0.1 * tf, 0.1 * tf))
    try:
        model = pset.model()
        return level_ratio(model, model.make_params(pset.parameters()), pset.units, 0.5 * (t_lo + t_hi),
                           0.5 * (l_lo + l_hi))
    except Exception:  # a model that cannot be evaluated at v = 0: the spread takes the largest measured ratio
        return math.nan


#: ``|ln r|`` used when a prior set's level ratio cannot be computed (the largest of the measured joints).
_FALLBACK_LOG_RATIO = math.log(1.8)


def prior_rel_std(ratio: float) -> float:
    """Relative std of a prior wear scale on a joint of level ratio ``ratio`` (:data:`SCALE_FLOOR`,
    :data:`SCALE_PER_LOG_RATIO`).

    >>> round(prior_rel_std(1.0), 3), round(prior_rel_std(1.35), 3), round(prior_rel_std(1 / 1.35), 3)
    (0.1, 0.206, 0.206)
    """
    lr = abs(math.log(ratio)) if math.isfinite(ratio) and ratio > 0 else _FALLBACK_LOG_RATIO
    return math.hypot(SCALE_FLOOR, SCALE_PER_LOG_RATIO * lr)


def wear_scale_of(params: str) -> WearScale | None:
    """:func:`wear_scale` of the set an estimate names (its name or path, as the history stores it); None when
    that set cannot be read here (another machine's path, a set since deleted): unknown, never guessed.

    Cached per set file and its modification time: the plant page asks every refresh, and a set
    commissioned again under the same path is read again.
    """
    if not params:
        return None
    try:
        stamp = Path(params).stat().st_mtime_ns if Path(params).is_file() else 0
    except OSError:
        stamp = 0
    return _wear_scale_of(params, stamp)


@functools.lru_cache(maxsize=256)
def _wear_scale_of(params: str, stamp: int) -> WearScale | None:
    try:
        return wear_scale(load_parameter_set_info(params))
    except Exception:  # any set this machine cannot read: the calibration is unknown here
        return None


def wear_scale(pset: ParameterSet | None) -> WearScale:
    """Whether ``pset``'s wear scale is calibrated, and its spread when it is a prior.

    - no set (plain :class:`~jointwear_ros.model.Parameters`): the caller's values, calibrated;
    - a set without a ``wear`` section (``ref-2011r``, ``paper-printed``): the wear parameters of the
      joint the set describes (the paper's, Eq. 8 from its accelerated wear tests), calibrated;
    - ``wear.calibration`` ``file:...``: known wear levels (fitted) or values given in a file, calibrated;
    - ``relative``: a prior, always (it exists only for a joint without wear data);
    - any other label (``paper``, ...) on a commissioned set (provenance of baseline cycles): a prior;
      on a designed set (the shipped simulated joints ``cobot-j3``, ``arm6-*``) the wear parameters are
      part of the joint's definition: calibrated.
    """
    if pset is None:
        return WearScale(True, "given parameters", math.nan, 0.0, "wear parameters given by the caller")
    if not pset.wear:
        return WearScale(True, pset.wear_calibration, math.nan, 0.0,
                         f"{pset.name}: the wear parameters the set was given with (the paper's joint: Eq. 8)")
    label = pset.wear_calibration
    if label.startswith("file:"):
        return WearScale(True, label, math.nan, 0.0, f"{pset.name}: wear calibrated from {label[5:]}")
    if label != "relative" and not _commissioned(pset):
        return WearScale(True, label, math.nan, 0.0,
                         f"{pset.name}: a designed set; its wear parameters ({label}) define the joint")
    r = _set_level_ratio(pset)
    return WearScale(False, label, r, prior_rel_std(r),
                     f"{pset.name}: wear scale {label!r} is a prior (no wear data on this joint); level ratio "
                     f"{r:.3g} to {REFERENCE_SET}")


class WearScaledEstimator:
    """An estimator whose every result carries its set's wear scale (:meth:`WearScale.apply`).

    Anything else (``name``, ``capabilities``, options, ``posterior``, ...) is the wrapped estimator's.
    """

    name: str

    def __init__(self, estimator: WearEstimator, scale: WearScale) -> None:
        self.__dict__["estimator"] = estimator
        self.__dict__["scale"] = scale
        self.__dict__["name"] = str(estimator.name)

    @property
    def capabilities(self) -> Any:
        return capabilities_of(self.estimator)

    def estimate(self, observations: ObservationTable) -> WearResult:
        return self.scale.apply(self.estimator.estimate(observations))

    def __getattr__(self, name: str) -> Any:
        inner = self.__dict__.get("estimator")
        if inner is None:  # not yet initialised (a copy or unpickling): no forwarding
            raise AttributeError(name)
        return getattr(inner, name)

    def __repr__(self) -> str:
        return f"WearScaledEstimator({self.estimator!r}, calibrated={self.scale.calibrated})"
