"""Commissioning: a joint's nominal friction model from its own baseline cycles.

:func:`commission` fits the nominal model (w = 0, "as installed") of one joint on
baseline friction observations: a warm-up from cold covers the temperature range,
the cycles' windows cover the loads. Every start value, bound and start of the fit
comes from the data's own scales (:mod:`jointwear_ros.model.scaling`), in the
data's units (normalized motor side, or joint side N·m). It reports

- the parameters with standard errors from the fit's covariance, and every
  parameter that ended on a bound (such a fit is not called converged);
- the cross-validated RMSE (folds by cycle), overall and per speed band;
- the covered ranges (speed, load, temperature): the set's ``valid``, the speeds widened by the speed-level
  match either side and the loads by a tenth of their span (a later cycle's measured speed and load scatter
  about the planned ones: :data:`SPEED_MARGIN`, :data:`LOAD_MARGIN`);
- the noise-floor test (``tau_f_std``, or the scatter between sweeps when that is
  larger: a bag's ``tau_f_std`` is a sweep's own error) and the workbench's verdict
  on the baseline (``found`` / ``unexplained`` / ``nothing_missing`` /
  ``undetermined``, with its suggestion);
- a ``found`` suggestion that lowers the error on held-out cycles, carried into the
  model by default (``carried``, ``cv_rmse_before``/``cv_rmse_after``,
  ``verdict_after``), unless the model was given explicitly (``model_explicit``);
- the wear parameters and the calibration they come from (:mod:`.wear`).

Real data rarely vary everything. Terms of a variable that was not measured are
replaced (temperature: ``stribeck + viscous``) or dropped (load); the sensitivities
to a variable held nearly constant (one temperature, a load that changes only with
the speed) are fixed at 0, a stated prior (``fixed``, ``priors``), and ``valid`` is
what was measured. Fewer than :data:`MIN_CYCLES` cycles (one sweep) are validated
on held-out speeds (``validation``). Fewer than :data:`MIN_SPEEDS` speeds are
refused (:class:`CommissionError`, one line saying what to record).

>>> from jointwear_ros.data import synth_observations
>>> t = synth_observations(n_cycles=16, seed=4, params="ref-2011r")
>>> r = commission(t, joint="joint_1", diagnose_baseline=False)
>>> r.converged, round(r.cv_rmse / 0.0015, 1) < 1.3, r.wear.label
(True, True, 'midpoint')
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..condition import SPEED_LEVEL_MATCH
from ..errors import InputDataError
from ..model import Model, Parameters, ParameterSet, SetUnits, split_model_spec
from ..model.scaling import BoundHit, DataScales, data_parameters, speed_starts
from ..types import ObservationTable
from .wear import (
    DEFAULT_WEAR_CALIBRATION,
    WearCalibration,
    midpoint_wear_values,
    paper_wear_values,
    relative_wear_values,
    wear_from_file,
)

__all__ = ["MIN_CYCLES", "MIN_LOAD_SPAN", "MIN_SPEEDS", "MIN_TEMPERATURE_SPAN", "CommissionError", "CommissionResult",
           "commission", "nominal_spec"]

#: Smallest temperature span (degC) that identifies the temperature terms of Eq. (6b), (6c).
MIN_TEMPERATURE_SPAN = 10.0
#: Smallest load span, as a share of the largest load, that identifies the load terms of Eq. (6a).
MIN_LOAD_SPAN = 0.25
#: Fewest distinct speeds and test cycles of a baseline.
MIN_SPEEDS = 5
MIN_CYCLES = 4
#: Speed band edges of the validation, as shares of the top speed.
BAND_SHARES = (0.0, 0.02, 0.08, 0.2, 0.45, 1.0001)


class CommissionError(InputDataError):
    """The baseline cannot identify the model (what to record is in the message)."""


@dataclass
class CommissionResult:
    """Everything commissioning found: the set to write and why it can be trusted (or not)."""

    joint: str
    robot: str
    spec: str
    units: SetUnits
    params: Parameters
    covariance: tuple[tuple[str, ...], tuple[tuple[float, ...], ...]]
    valid: dict[str, tuple[float, float]]
    rmse: float
    cv_rmse: float
    bands: list[dict[str, Any]]
    noise_floor: float
    noise_method: str
    noise_consistent: bool
    verdict: str
    suggestion: str | None
    summary: str
    wear: WearCalibration
    on_bound: list[BoundHit]
    converged: bool
    message: str
    n: int
    n_cycles: int
    noise_std: float
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0
    sources: list[str] = field(default_factory=list)
    #: The suggestion of a ``found`` verdict carried into the model (None: nothing carried).
    carried: str | None = None
    #: CV RMSE of the nominal model before and after carrying the suggestion (nan when nothing was tried).
    cv_rmse_before: float = math.nan
    cv_rmse_after: float = math.nan
    #: The workbench's verdict on the carried model (``not run`` when nothing was carried).
    verdict_after: str = "not run"
    #: The model was given explicitly (``--model``): a found effect is then reported, not carried.
    model_explicit: bool = False
    #: Parameters the data cannot identify, held at a stated prior: name -> value.
    fixed: dict[str, float] = field(default_factory=dict)
    #: Why each group of terms was fixed or replaced (one sentence each).
    priors: list[str] = field(default_factory=list)
    #: What validates the model: ``held-out cycles`` or ``held-out speeds`` (a single sweep).
    validation: str = "held-out cycles"

    @property
    def set_spec(self) -> str:
        """The set's model: the nominal spec plus the wear terms of Eq. (7)."""
        return self.spec + " + wear_stribeck + wear_viscous"

    def parameter_set(self, name: str) -> ParameterSet:
        values = {n: float(p.value) for n, p in self.params.items()}
        values.update({k: float(v) for k, v in self.wear.items()})
        lo, hi = self.valid.get("temperature", (math.nan, math.nan))
        prior = f"uniform:{lo:.6g}:{hi:.6g}" if math.isfinite(lo) and hi > lo else None
        return ParameterSet(
            name=name,
            description=(f"commissioned {self.robot + ' ' if self.robot else ''}{self.joint}: model {self.spec}, "
                         f"CV RMSE {self.cv_rmse:.4g} {self.units.torque_unit}, {self.verdict_text}"),
            values=values, valid=dict(self.valid), spec=self.set_spec, units=self.units,
            stderr={n: float(p.stderr) for n, p in self.params.items() if p.stderr is not None},
            covariance=self.covariance, noise_std=self.noise_std, temperature_prior=prior,
            wear={"calibration": self.wear.label, "source": self.wear.source, "parameters": list(self.wear),
                  **({"level_ratio": float(self.wear.level_ratio)} if self.wear.level_ratio is not None else {})},
            provenance={"robot": self.robot, "joint": self.joint, "data": list(self.sources),
                        "date": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
                        "software": f"jointwear {__version__}", "observations": self.n, "cycles": self.n_cycles,
                        "converged": self.converged, "verdict": self.verdict, "verdict_note": self.verdict_text,
                        "carried": self.carried, "verdict_after": self.verdict_after,
                        "fixed": dict(self.fixed), "validation": self.validation},
        )

    @property
    def verdict_text(self) -> str:
        """The baseline's verdict in words, as the set's description and provenance record it."""
        if self.carried:
            return (f"verdict found on the baseline: {self.carried} carried into the model (CV RMSE "
                    f"{self.cv_rmse_before:.4g} -> {self.cv_rmse_after:.4g}; verdict after: {self.verdict_after})")
        if self.verdict == "found":
            return (f"verdict found on the baseline: {self.suggestion} NOT in the model; estimates with this set "
                    "may be biased")
        if self.verdict == "unexplained":
            return "verdict unexplained on the baseline: estimates with this set may be biased"
        return f"verdict {self.verdict}"

    def to_dict(self, out: str | None = None) -> dict[str, Any]:
        return {
            "joint": self.joint,
            "robot": self.robot,
            "model": self.set_spec,
            "nominal_model": self.spec,
            "units": self.units.to_dict(),
            "parameters": {n: {"value": p.value, "stderr": p.stderr, "vary": p.vary} for n, p in self.params.items()}
            | {k: {"value": v, "stderr": None, "vary": False} for k, v in self.wear.items()},
            "on_bound": [h.to_dict() for h in self.on_bound],
            "converged": self.converged,
            "message": self.message,
            "valid": {k: list(v) for k, v in self.valid.items()},
            "rmse": self.rmse,
            "cv_rmse": self.cv_rmse,
            "cv_rmse_bands": self.bands,
            "noise_floor": self.noise_floor,
            "noise_method": self.noise_method,
            "noise_consistent": self.noise_consistent,
            "verdict": self.verdict,
            "suggestion": self.suggestion,
            "carried": self.carried,
            "model_explicit": self.model_explicit,
            "cv_rmse_before": _num(self.cv_rmse_before),
            "cv_rmse_after": _num(self.cv_rmse_after),
            "verdict_after": self.verdict_after,
            "verdict_note": self.verdict_text,
            "fixed": dict(self.fixed),
            "priors": list(self.priors),
            "validation": self.validation,
            "summary": self.summary,
            "wear_calibration": self.wear.label,
            "wear_source": self.wear.source,
            "n": self.n,
            "cycles": self.n_cycles,
            "seconds": self.seconds,
            "warnings": list(self.warnings),
            "out": out,
        }


def nominal_spec(spec: str) -> str:
    """``spec`` without its wear terms (a baseline is at w = 0): ``paper+wear`` -> ``paper``."""
    parts = ["paper" if p == "paper+wear" else p for p in split_model_spec(spec)]
    keep = [p for p in parts if p not in ("wear", "wear_stribeck", "wear_viscous")]
    if not keep:
        raise CommissionError(f"model {spec!r} has only wear terms; a baseline needs the nominal terms (e.g. paper)")
    return " + ".join(keep)


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


#: Terms of the temperature (Eq. 6b, 6c) and their speed-only counterparts for data without a temperature.
_TEMP_TERMS = {"temp_stribeck": "stribeck", "temp_viscous": "viscous"}
_LOAD_TERMS = ("load_coulomb", "load_stribeck")
#: The temperature sensitivities a one-temperature sweep cannot identify, and their prior (none).
_TEMP_SENSITIVITY = {"FsT": 0.0, "vsT": 0.0, "FvT": 0.0}
#: The load sensitivities a one-load sweep cannot identify, and their prior (none).
_LOAD_SENSITIVITY = {"Fctm": 0.0, "Fstm": 0.0}


def _finite(table: ObservationTable, name: str) -> np.ndarray | None:
    if name not in table:
        return None
    x = np.asarray(table[name], dtype=float)
    return x if np.isfinite(x).any() else None


def _identifiable_model(model: Model, table: ObservationTable, where: str
                        ) -> tuple[Model, dict[str, float], list[str], list[str]]:
    """The model the data identify: terms of a variable that was not measured are replaced or dropped, and the
    sensitivities to a variable held constant are fixed at a stated prior.

    Returns the model, the fixed parameters (name -> value), one sentence per change (the priors) and the
    warnings. Data that identify nothing (too few speeds, a temperature on some rows only) are refused.
    """
    from ..workbench import parse_spec

    speeds = np.unique(np.round(np.abs(table.speed), 9))
    if speeds.size < MIN_SPEEDS:
        raise CommissionError(f"{where}: {speeds.size} distinct speed(s); commissioning needs at least {MIN_SPEEDS} "
                              "speeds from the lowest to the highest the joint runs at: record test cycles over the "
                              "joint's speed range")
    names = list(model.term_names)
    fixed: dict[str, float] = {}
    priors: list[str] = []
    warnings: list[str] = []
    temps = [n for n in names if n in _TEMP_TERMS]
    if temps:
        t = _finite(table, "temperature")
        if t is None:
            swap = [_TEMP_TERMS[n] for n in temps if _TEMP_TERMS[n] not in names]
            names = [n for n in names if n not in _TEMP_TERMS] + swap
            priors.append(f"no temperature was measured: {', '.join(temps)} replaced by {', '.join(swap) or 'nothing'}"
                          " (speed only; the set holds for the temperature the data were taken at, which is unknown)")
        else:
            if not np.isfinite(t).all():
                raise CommissionError(
                    f"{where}: {int((~np.isfinite(t)).sum())} observation(s) without a temperature; model "
                    f"{model.spec!r} has temperature terms: record the joint temperature (/joint_temperature) with "
                    "every cycle, or commission with a model without them (--model standard)")
            span = float(np.ptp(t))
            if span < MIN_TEMPERATURE_SPAN:
                held = {k: v for k, v in _TEMP_SENSITIVITY.items()}
                fixed.update(held)
                priors.append(f"temperature span {span:.1f} degC ({t.min():.1f}-{t.max():.1f}) is under "
                              f"{MIN_TEMPERATURE_SPAN:g} degC: the temperature sensitivities {', '.join(held)} are "
                              "fixed at 0 (prior: no temperature dependence) and valid temperatures narrowed to "
                              "the measured ones; record a warm-up from cold to identify them")
    loads = [n for n in names if n in _LOAD_TERMS]
    if loads:
        ld = _finite(table, "load_torque")
        if ld is None:
            names = [n for n in names if n not in _LOAD_TERMS]
            priors.append(f"no load torque was measured: {', '.join(loads)} dropped (the set holds for the load the "
                          "data were taken at)")
        else:
            if not np.isfinite(ld).all():
                raise CommissionError(f"{where}: observations without a load torque; model {model.spec!r} has load "
                                      "terms: give load_torque with every observation")
            ld = np.abs(ld)
            if ld.max() > 0 and np.ptp(ld) >= MIN_LOAD_SPAN * ld.max() and \
                    _span_at_equal_speed(table.speed, ld) < MIN_LOAD_SPAN * ld.max():
                held = {k: v for k, v in _LOAD_SENSITIVITY.items() if any(k in parse_spec(n).param_names
                                                                          for n in loads)}
                fixed.update(held)
                priors.append(f"the load torque ({ld.min():.4g}-{ld.max():.4g}) changes only with the speed (not "
                              f"between cycles at equal speed), so its terms cannot be told from the speed terms: "
                              f"{', '.join(held)} "
                              "fixed at 0 (prior: no load dependence); record cycles at windows of different "
                              "gravity load to identify them")
            elif ld.max() <= 0 or np.ptp(ld) < MIN_LOAD_SPAN * ld.max():
                held = {k: v for k, v in _LOAD_SENSITIVITY.items() if any(k in parse_spec(n).param_names
                                                                          for n in loads)}
                fixed.update(held)
                priors.append(f"load torque spans {ld.min():.4g}-{ld.max():.4g} (under {MIN_LOAD_SPAN:.0%} of the "
                              f"largest): the load sensitivities {', '.join(held)} are fixed at 0 (prior: no load "
                              "dependence) and valid loads narrowed to about the measured ones; record cycles at windows "
                              "of different gravity load to identify them")
    if names != list(model.term_names):
        if not names:
            raise CommissionError(f"{where}: model {model.spec!r} has no term the data can identify")
        model = parse_spec(" + ".join(names))
    fixed = {k: v for k, v in fixed.items() if k in model.param_names}
    if "vstm" in model.param_names and "Fstm" in fixed:
        fixed["vstm"] = math.nan  # its start: no load Stribeck amplitude, so no speed of it
    if "Tv0" in model.param_names and "FvT" in fixed:
        fixed["Tv0"] = 25.0  # ref-2011r's; without FvT it does nothing
    return model, fixed, priors, warnings


def _span_at_equal_speed(speed: np.ndarray, x: np.ndarray) -> float:
    """The median, over the speeds (equal within 0.5 %), of the span of ``x`` among the rows at that speed."""
    a = np.abs(np.asarray(speed, dtype=float))
    key = np.round(np.log(np.where(a > 0, a, 1e-300)) / 0.01)
    spans = [float(np.ptp(x[key == k])) for k in np.unique(key)]
    return float(np.median(spans)) if spans else 0.0


def _folds(table: ObservationTable, cv_folds: int) -> tuple[np.ndarray | None, str, list[str]]:
    """Cross-validation folds: by cycle with enough cycles, else by speed (a single sweep: held-out speeds)."""
    cycles = np.unique(table["cycle"]) if "cycle" in table else np.array([0.0])
    if cycles.size >= MIN_CYCLES:
        return None, "held-out cycles", []
    v = np.round(np.abs(table.speed), 9)
    _, rank = np.unique(v, return_inverse=True)
    k = int(min(max(cv_folds, 2), rank.max() + 1))
    note = (f"{cycles.size} test cycle(s) (held-out cycles need at least {MIN_CYCLES}): the model is validated on "
            "held-out speeds instead (neighbouring speeds in different folds; the CV RMSE leaves out the lowest "
            "and the highest speed, where a held-out fold extrapolates), which checks the curve between speeds but "
            "not its repeatability; record more cycles (or split a long recording into cycles: data "
            "from-timeseries --split)")
    return (rank.reshape(-1) % k).astype(int), "held-out speeds", [note]


def _bands(speed: np.ndarray, resid: np.ndarray | None, vmax: float) -> list[dict[str, Any]]:
    if resid is None:
        return []
    v = np.abs(speed)
    out = []
    edges = [s * vmax for s in BAND_SHARES]
    for lo, hi in itertools.pairwise(edges):
        m = (v >= lo) & (v < hi) & np.isfinite(resid)
        if m.any():
            out.append({"lo": float(lo), "hi": float(hi), "n": int(m.sum()),
                        "cv_rmse": float(np.sqrt(np.mean(resid[m] ** 2)))})
    return out


def _fit(m: Model, table: ObservationTable, scales: DataScales, fixed: dict[str, float], cv_folds: int,
         folds: np.ndarray | None, warm: Parameters | None = None) -> Any:
    from ..workbench import fit_model

    given = m.make_params()
    p0 = data_parameters(m.param_names, scales, given)
    if warm is not None:
        for n, p in warm.items():
            if n in p0:
                p0[n].value = float(min(max(p.value, p0[n].min), p0[n].max))
    hold = []
    for n, v in fixed.items():
        if n in p0:
            if math.isfinite(v):
                p0[n].value = float(v)
                p0[n].min = min(p0[n].min, float(v))
                p0[n].max = max(p0[n].max, float(v))
            hold.append(n)
    starts: list[dict[str, float]] = speed_starts([n for n in m.param_names if n not in hold], scales)
    for term in m.terms:
        if term.name in ("coulomb", "load_coulomb", "load_stribeck", "temp_stribeck", "temp_viscous", "stribeck",
                         "viscous"):
            continue
        grid = term.guess(dict(table.model_inputs()))
        starts = [dict(s, **g) for s in starts for g in grid][:24]
    if warm is not None:
        starts.insert(0, {n: p0[n].value for n in p0 if n not in hold})
    starts = [{k: v for k, v in s.items() if k not in hold} for s in starts]
    return fit_model(m, table, p0, fixed=hold, starts=starts, cv_folds=cv_folds, folds=folds)


def _outside_physical_bounds(m: Model, fit: Any, units: SetUnits) -> dict[str, tuple[float, float]]:
    """The fitted free parameters outside their terms' physical bounds, which the set loader refuses in a frame
    it bounds (not the joint side): name -> (value, the nearest bound)."""
    if units.joint_side:
        return {}
    specs = {sp.name: sp for t in m.terms for sp in t.params}
    out: dict[str, tuple[float, float]] = {}
    for n in fit.free:
        sp = specs.get(n)
        v = float(fit.params[n].value)
        if sp is not None and math.isfinite(v) and not sp.min <= v <= sp.max:
            out[n] = (v, float(min(max(v, sp.min), sp.max)))
    return out


def _fit_within_physical_bounds(m: Model, table: ObservationTable, scales: DataScales, fixed: dict[str, float],
                                cv_folds: int, folds: np.ndarray | None, units: SetUnits,
                                warm: Parameters | None = None) -> tuple[Any, dict[str, float], list[str]]:
    """:func:`_fit`, then every free parameter past its physical bound (:func:`_outside_physical_bounds`) held at
    that bound and the rest fitted again, until none is: the one way commissioning fits, so no fit it keeps (the
    nominal one, or the refit with a found effect carried) writes a set the loader refuses.

    The data-scaled bounds, widened, can let a parameter the data do not pin down walk past the terms' physical
    one (``Fstm`` 147.7 against [0, 10] on the first fit, seen live; ``vstm`` 555 against [0.1, 500] on the refit
    with a low-speed effect carried). Returns the fit, ``fixed`` with the held parameters added, and one note per
    held parameter (for the warnings).
    """
    fit = _fit(m, table, scales, fixed, cv_folds, folds, warm=warm)
    notes: list[str] = []
    outside = _outside_physical_bounds(m, fit, units)
    while outside:  # each round holds at least one more free parameter: it ends
        for n, (value, bound) in outside.items():
            notes.append(f"parameter {n} = {value:.6g} is outside its physical bounds: held at {bound:g} (the data "
                         "do not pin it down)")
        fixed = {**fixed, **{n: bound for n, (_v, bound) in outside.items()}}
        fit = _fit(m, table, scales, fixed, cv_folds, folds, warm=warm)
        outside = _outside_physical_bounds(m, fit, units)
    return fit, fixed, notes


def commission(
    table: ObservationTable,
    *,
    joint: str,
    robot: str = "",
    model: str = "paper",
    units: SetUnits | None = None,
    wear_calibration: str = DEFAULT_WEAR_CALIBRATION,
    wear_table: ObservationTable | None = None,
    diagnose_baseline: bool = True,
    cv_folds: int = 5,
    sources: Sequence[str] = (),
    carry_found: bool = True,
    model_explicit: bool = False,
) -> CommissionResult:
    """Fit a joint's nominal model on baseline observations; see the module docstring.

    ``table`` is in the set's units (``units``: the paper's normalized motor side by
    default, or the joint frame). ``model`` is the nominal spec (wear terms are
    dropped: the baseline is at w = 0; they come from ``wear_calibration``:
    ``paper``, ``relative`` or a FILE path, with ``wear_table`` its table when the
    FILE is one).

    With ``carry_found`` (the default) a ``found`` verdict's suggestion that lowers
    the error on held-out cycles is carried into the model (``spec + suggestion``,
    refitted, before/after CV RMSE in the result), unless ``model_explicit`` (the
    user chose the model: the finding is then reported, not acted on).

    Data that do not vary a variable cannot identify its terms: without a
    temperature (or a load) column those terms are replaced by their speed-only
    counterparts (or dropped); with one temperature (or one load) their
    sensitivities are fixed at 0 and ``valid`` is what was measured. The result's
    ``priors`` say which, ``fixed`` holds the values. Fewer than
    :data:`MIN_CYCLES` cycles are validated on held-out speeds (``validation``).
    """
    from ..workbench import diagnose, noise_test, sweep_scatter

    t0 = time.perf_counter()
    units = units or SetUnits()
    where = table.source or "baseline"
    spec = nominal_spec(model)
    from ..workbench import parse_spec

    m0 = parse_spec(spec)
    m, fixed, priors, warnings = _identifiable_model(m0, table, where)
    warnings.extend(priors)
    folds, validation, notes = _folds(table, cv_folds)
    warnings.extend(notes)
    if "wear" in table:
        w = np.asarray(table["wear"], dtype=float)
        if np.nanmax(np.abs(w)) > 0:
            warnings.append(f"{where}: the baseline holds wear levels up to {np.nanmax(w):g}; commissioning treats "
                            "it as w = 0 (as installed)")
    scales = DataScales.from_table(table)
    fit, fixed, held = _fit_within_physical_bounds(m, table, scales, fixed, cv_folds, folds, units)
    warnings.extend(held)
    verdict, suggestion, summary = "not run", None, "workbench diagnosis not run"
    carried, verdict_after = None, "not run"
    before, after = math.nan, math.nan
    nf = None
    if diagnose_baseline:
        from ..workbench.render import diagnosis_summary

        d = diagnose(table, fit, cv_folds=cv_folds)
        verdict, suggestion, summary = d.verdict, d.suggestion, diagnosis_summary(d)
        nf = d.noise
        if verdict == "found" and d.best is not None:
            before = fit.cv_rmse
            if carry_found and not model_explicit:
                try:
                    m2 = parse_spec(f"{m.spec} + {suggestion}")
                    fit2, fixed2, held2 = _fit_within_physical_bounds(m2, table, scales, fixed, cv_folds, folds,
                                                                      units, warm=d.best.fit.params)
                except InputDataError:
                    fit2 = None
                after = fit2.cv_rmse if fit2 is not None else math.nan
                if fit2 is not None and math.isfinite(after) and after < before:
                    carried, m, fit, fixed = suggestion, m2, fit2, fixed2
                    warnings.extend(held2)
                    d2 = diagnose(table, fit, cv_folds=cv_folds, n_bootstrap=0)
                    verdict_after, nf = d2.verdict, d2.noise
                    warnings.append(f"the workbench finds an effect the nominal model misses on the baseline: "
                                    f"{suggestion}; carried into the model (CV RMSE on held-out "
                                    f"{validation.split()[-1]} {before:.4g} -> {after:.4g}; verdict after: "
                                    f"{verdict_after}); give --model to choose the model yourself")
                else:
                    warnings.append(f"the workbench finds an effect the model misses on the baseline: {suggestion}; "
                                    f"NOT carried: it does not lower the error on held-out {validation.split()[-1]} "
                                    f"(CV RMSE {before:.4g} -> {after:.4g}); estimates with this set may be biased")
            else:
                after = d.best.cv_rmse
                warnings.append(f"the workbench finds an effect the model misses on the baseline: {suggestion} (CV "
                                f"RMSE {before:.4g} -> {after:.4g} with it); the model was given explicitly, so it is "
                                f"not carried: commission with --model '{spec} + {suggestion}' to carry it into the "
                                "wear estimate")
        elif verdict == "unexplained":
            warnings.append("the baseline is not explained to its noise floor and no candidate explains it: "
                            "estimates with this set may be biased")
        elif verdict == "undetermined":
            warnings.append(f"the workbench cannot judge the baseline: {summary}")
    bound = fit.at_bound
    converged = bool(fit.success and not bound and all(math.isfinite(fit.stderr(n)) for n in fit.free))
    for h in bound:
        warnings.append(f"parameter {h.name} = {h.value:.6g} ended on its {h.side} bound {h.bound:.6g}: the data do "
                        "not pin it down; the fit is not converged")
    if not fit.success and not bound:
        warnings.append(f"the fit is not converged: {fit.message}")
    bad_se = [n for n in fit.free if not math.isfinite(fit.stderr(n))]
    if bad_se:
        warnings.append(f"no standard error for {', '.join(bad_se)} (singular covariance): the data do not "
                        "identify them separately")
    if nf is None:
        nf = noise_test(table, fit.residuals, fit.n_free)
        if not nf.consistent:
            nf = sweep_scatter(table, fit.residuals, fit.n_free, nf) or nf
    std = np.array([fit.stderr(n) for n in fit.free])
    cov = fit.correlations * np.outer(std, std) if fit.free else np.zeros((0, 0))
    covariance = (tuple(fit.free), tuple(tuple(float(x) for x in row) for row in cov))
    valid = _covered(table, m)
    # wear parameters
    if wear_calibration == "paper":
        wear = WearCalibration(paper_wear_values(units), "paper",
                               "Eq. (8) of Bittencourt et al. (2011) in the set's units")
    elif wear_calibration in ("relative", "midpoint"):
        t_med = float(np.nanmedian(table.get("temperature"))) if _finite(table, "temperature") is not None \
            else scales.temperature
        l_med = float(np.nanmedian(np.abs(table.get("load_torque")))) if _finite(table, "load_torque") is not None \
            else 0.0
        v_lo = float(np.min(np.abs(table.speed)))  # the lowest measured speed: no extrapolation below the data
        values_of = relative_wear_values if wear_calibration == "relative" else midpoint_wear_values
        vals, ratio = values_of(m, fit.params, units, t_med, l_med, v_lo)
        how = "scaled by" if wear_calibration == "relative" else "scaled by the square root of"
        wear = WearCalibration(vals, wear_calibration,
                               f"Eq. (8) {how} the joint's nominal level over ref-2011r's "
                               f"(x{ratio:.4g} at {v_lo:.3g} {units.speed_unit}, T = {t_med:.3g} degC, load "
                               f"{l_med:.4g})", level_ratio=ratio)
    else:
        path = Path(wear_calibration)
        if not path.is_file():
            raise InputDataError(f"--wear-calibration {wear_calibration!r}: not midpoint, paper, relative or an "
                                 "existing file")
        wear = wear_from_file(path, model=m, params=fit.params, table=wear_table, units=units)
    n_cycles = int(np.unique(table["cycle"]).size) if "cycle" in table else 1
    cv_rmse, cv_res = fit.cv_rmse, fit.cv_residuals
    if validation == "held-out speeds" and cv_res is not None:
        # a held-out end speed is an extrapolation, not a validation: the CV RMSE is over the speeds between
        v = np.abs(np.asarray(table.speed, dtype=float))
        inner = (v > v.min()) & (v < v.max())
        if inner.any():
            cv_rmse = float(np.sqrt(np.mean(cv_res[inner] ** 2)))
            cv_res = np.where(inner, cv_res, np.nan)
            if carried:
                after = cv_rmse
    noise_std = nf.value if math.isfinite(nf.value) and nf.value > 0 else fit.rmse
    if noise_std < fit.rmse and not nf.consistent:
        noise_std = cv_rmse if math.isfinite(cv_rmse) else fit.rmse  # a model error counts as noise
    return CommissionResult(
        joint=joint, robot=robot, spec=m.spec, units=units, params=fit.params, covariance=covariance, valid=valid,
        rmse=fit.rmse, cv_rmse=cv_rmse, bands=_bands(table.speed, cv_res, scales.speed_level),
        noise_floor=nf.value, noise_method=nf.method, noise_consistent=bool(nf.consistent), verdict=verdict,
        suggestion=suggestion, summary=summary, wear=wear, on_bound=bound, converged=converged,
        message=fit.message, n=len(table), n_cycles=n_cycles, noise_std=float(noise_std), warnings=warnings,
        seconds=time.perf_counter() - t0, sources=list(sources), carried=carried, cv_rmse_before=before,
        cv_rmse_after=after, verdict_after=verdict_after, model_explicit=model_explicit,
        fixed={n: float(fit.params[n].value) for n in fixed if n in fit.params}, priors=priors,
        validation=validation,
    )


#: A commissioned set's valid speeds reach this share beyond the slowest and the fastest speed measured: the
#: suite's speed-level match (:data:`jointwear_ros.condition.SPEED_LEVEL_MATCH`: a speed within it is the same
#: level). A later cycle's measured speed scatters about its planned one: the live Panda's test cycle swept
#: 80.0416 rad/s where its baseline's fastest sweep was 80.0379, and the estimator dropped it.
SPEED_MARGIN = SPEED_LEVEL_MATCH
#: ... and its valid loads this share of the measured load span beyond either end (never below 0): a pose's load
#: scatters between cycles (the same run's shoulder read |load| 0.0031 at its test pose, its baseline 0.0080-0.1428).
LOAD_MARGIN = 0.1


def _covered(table: ObservationTable, model: Model) -> dict[str, tuple[float, float]]:
    """The set's ``valid``: the ranges measured (module docstring: speeds and loads with their margins)."""
    out: dict[str, tuple[float, float]] = {}
    v = np.abs(table.speed)
    out["speed"] = (float(v.min()) * (1.0 - SPEED_MARGIN), float(v.max()) * (1.0 + SPEED_MARGIN))
    for name in ("load_torque", "temperature"):
        if name in table:
            x = np.asarray(table[name], dtype=float)
            x = np.abs(x) if name == "load_torque" else x
            x = x[np.isfinite(x)]
            if x.size:
                lo, hi = float(x.min()), float(x.max())
                if name == "load_torque":
                    lo, hi = max(0.0, lo - LOAD_MARGIN * (hi - lo)), hi + LOAD_MARGIN * (hi - lo)
                out[name] = (lo, hi)
    for var in model.variables:
        if var not in out and var in table and var not in ("wear",):
            x = np.asarray(table[var], dtype=float)
            x = x[np.isfinite(x)]
            if x.size:
                out[var] = (float(x.min()), float(x.max()))
    out["wear"] = (0.0, 100.0)
    return out
