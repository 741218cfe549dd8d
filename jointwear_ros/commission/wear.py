"""Wear parameters for a joint without wear experiments: paper, relative, or calibrated from data.

The paper's wear parameters (Eq. 8: ``Fsw``, ``vsw``, ``Fvw``) come from accelerated
wear tests on one robot, in its normalized motor-side units. A commissioned joint
gets one of:

``paper`` (the default)
    Eq. (8) converted to the set's units (speed and torque factors of its frame):
    the same absolute friction increase per unit wear as the paper's joint.
``relative``
    Eq. (8) scaled by the joint's own nominal friction level over the paper
    joint's at the same conditions (v = 0, the baseline's median temperature
    and load): wear w raises the friction by the same *relative* amount as on
    the paper's joint, so the alarm level w = 35 means the same relative
    friction increase. On a joint identical to ``ref-2011r`` it is ``paper``.
FILE
    a YAML file with ``Fsw``, ``vsw``, ``Fvw`` in the set's units (and a
    ``source``), or an observation table with a ``wear`` column of known wear
    levels (a history across a reducer replacement, a run-to-failure series):
    the three are fitted with the nominal model held fixed.

Without wear data on the joint, ``paper`` and ``relative`` are priors: every estimate with
such a set carries the wear scale's own uncertainty in its std
(:mod:`jointwear_ros.estimation.wear_scale`); a FILE calibrates it. The default is chosen by
measurement (``bench/bench_wear_calibration.py``, docs/commissioning.md): ``paper``.

>>> from jointwear_ros.model import SetUnits
>>> w = paper_wear_values(SetUnits("joint", 100.0, 200.0))
>>> round(w["Fsw"], 4), round(w["vsw"], 4), round(w["Fvw"], 7)
(0.182, 0.022, -0.0106)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import InputDataError
from ..model import Model, Parameters, SetUnits, load_parameter_set_info
from ..types import ObservationTable
from .names import DEFAULT_WEAR_CALIBRATION, WEAR_CALIBRATIONS

__all__ = [
    "DEFAULT_WEAR_CALIBRATION",
    "REFERENCE_SET",
    "WEAR_CALIBRATIONS",
    "WEAR_PARAMS",
    "WearCalibration",
    "midpoint_wear_values",
    "paper_wear_values",
    "relative_wear_values",
    "wear_from_file",
]

#: The set that holds the paper's wear parameters (Eq. 8) and its joint's nominal model.
REFERENCE_SET = "ref-2011r"
#: The wear parameters of Eq. (7).
WEAR_PARAMS = ("Fsw", "vsw", "Fvw")


class WearCalibration(dict):  # type: ignore[type-arg]
    """Wear parameter values (set units) with ``label`` (what every estimate names) and ``source``."""

    def __init__(self, values: Mapping[str, float], label: str, source: str, level_ratio: float | None = None
                 ) -> None:
        super().__init__(values)
        self.label = label
        self.source = source
        #: the joint's nominal friction over ref-2011r's (relative, midpoint), recorded in the set
        self.level_ratio = level_ratio


def paper_wear_values(units: SetUnits) -> dict[str, float]:
    """Eq. (8) in a set's units: Fsw x torque factor, vsw x speed factor, Fvw x torque / speed factor."""
    ref = load_parameter_set_info(REFERENCE_SET).values
    sf, tf = units.speed_factor, units.torque_factor
    return {"Fsw": ref["Fsw"] * tf, "vsw": ref["vsw"] * sf, "Fvw": ref["Fvw"] * tf / sf}


def relative_wear_values(model: Model, params: Parameters, units: SetUnits, temperature: float,
                         load: float, speed: float = 0.0) -> tuple[dict[str, float], float]:
    """Eq. (8) scaled to the joint's nominal level over ref-2011r's at ``speed`` (set units; the baseline's lowest
    measured speed, so the ratio is not an extrapolation of the fit below the data); the values and the ratio."""
    from ..estimation.wear_scale import level_ratio

    ratio = level_ratio(model, params, units, temperature, load, speed=speed)
    if not (math.isfinite(ratio) and ratio > 0):
        raise InputDataError(f"the joint's nominal friction at {speed:g} {units.speed_unit} is not positive; the "
                             "relative and midpoint wear calibrations need a positive level: use --wear-calibration "
                             "paper or FILE")
    base = paper_wear_values(units)
    return {"Fsw": base["Fsw"] * ratio, "vsw": base["vsw"], "Fvw": base["Fvw"] * ratio}, ratio


def midpoint_wear_values(model: Model, params: Parameters, units: SetUnits, temperature: float,
                         load: float, speed: float = 0.0) -> tuple[dict[str, float], float]:
    """Half-way in log between ``paper`` and ``relative``: Eq. (8) scaled by sqrt(ratio); the values and the ratio.

    Measured best of the three on joints unlike the paper's (docs/commissioning.md): the default.
    """
    _, ratio = relative_wear_values(model, params, units, temperature, load, speed)
    k = math.sqrt(ratio)
    base = paper_wear_values(units)
    return {"Fsw": base["Fsw"] * k, "vsw": base["vsw"], "Fvw": base["Fvw"] * k}, ratio


def wear_from_file(path: str | Path, *, model: Model, params: Parameters, table: ObservationTable | None,
                   units: SetUnits) -> WearCalibration:
    """A calibration FILE: a YAML of the three values, or a table with a ``wear`` column (fitted)."""
    import yaml

    p = Path(path)
    if p.suffix in (".yaml", ".yml"):
        try:
            doc = yaml.safe_load(p.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
            raise InputDataError(f"{p}: cannot read the wear calibration ({' '.join(str(exc).split())[:120]})") from None
        if not isinstance(doc, dict):
            raise InputDataError(f"{p}: a wear calibration YAML maps Fsw, vsw, Fvw to numbers (set units)")
        vals = doc.get("parameters", doc)
        out: dict[str, float] = {}
        for k in WEAR_PARAMS:
            try:
                out[k] = float(vals[k])
            except (KeyError, TypeError, ValueError):
                raise InputDataError(f"{p}: wear calibration needs a number for {k} (in the set's units)") from None
            if not math.isfinite(out[k]):
                raise InputDataError(f"{p}: wear calibration {k} = {vals[k]!r} is not finite")
        if out["vsw"] <= 0:
            raise InputDataError(f"{p}: wear calibration vsw = {out['vsw']:g} must be > 0")
        return WearCalibration(out, f"file:{p.name}", str(doc.get("source", p.name)))
    if table is None:
        raise InputDataError(f"{p}: give a wear calibration as YAML (Fsw, vsw, Fvw) or an observation table with "
                             "a 'wear' column")
    return fit_wear(table, model=model, params=params, units=units, label=f"file:{p.name}")


def fit_wear(table: ObservationTable, *, model: Model, params: Parameters, units: SetUnits,
             label: str) -> WearCalibration:
    """Fit Fsw, vsw, Fvw on observations of known wear (column ``wear``), the nominal model held fixed."""
    from ..model import term_by_name
    from ..workbench import fit_model

    where = table.source or "wear calibration table"
    if "wear" not in table:
        raise InputDataError(f"{where}: a wear calibration table needs a 'wear' column (the known wear level per row)")
    w = np.asarray(table["wear"], dtype=float)
    if not np.isfinite(w).all() or np.ptp(w) < 5.0:
        raise InputDataError(f"{where}: the wear column spans {np.nanmin(w):g}-{np.nanmax(w):g}; calibrating the "
                             "wear parameters needs known wear levels at least 5 apart (before and after a change)")
    full = model + term_by_name("wear_stribeck") + term_by_name("wear_viscous")
    start = dict(paper_wear_values(units))
    p0 = full.make_params(params)
    from ..model.parameters import Parameter

    p = Parameters()
    for n, q in p0.items():
        if n in WEAR_PARAMS:
            lo = 1e-6 * start["vsw"] if n == "vsw" else -math.inf
            p.add(Parameter(n, start[n], lo, math.inf))
        else:
            p.add(Parameter(n, q.value, vary=False))
    fit = fit_model(full, table, p, cv_folds=0)
    vals = {n: fit.params[n].value for n in WEAR_PARAMS}
    if not all(math.isfinite(v) for v in vals.values()):
        raise InputDataError(f"{where}: the wear parameters could not be fitted ({fit.message})")
    return WearCalibration(vals, label, f"fitted on {len(table)} observations of known wear ({where})")
