"""Commissioning: a joint's nominal friction model from its own baseline cycles.

:func:`commission` fits the nominal model (w = 0, "as installed") of one joint on
baseline friction observations: a warm-up from cold covers the temperature range,
the cycles' windows cover the loads. Every start value, bound and start of the fit
comes from the data's own scales (:mod:`jointwear_ros.model.scaling`), in the
data's units (normalized motor side, or joint side N·m). It reports

- the parameters with standard errors from the fit's covariance, and every
  parameter that ended on a bound (such a fit is not called converged);
- the cross-validated RMSE (folds by cycle), overall and per speed band;
- the covered ranges (speed, load, temperature): the set's ``valid``;
- the noise-floor test and the workbench's verdict on the baseline
  (``found`` / ``unexplained`` / ``nothing_missing``, with its suggestion);
- the wear parameters and the calibration they come from (:mod:`.wear`).

Data that cannot identify the model are refused (:class:`CommissionError`, one
line saying what to record): too few speeds or cycles, a temperature span too
narrow for the temperature terms, a load span too narrow for the load terms.

>>> from jointwear_ros.data import synth_observations
>>> t = synth_observations(n_cycles=16, seed=4, params="ref-2011r")
>>> r = commission(t, joint="joint_1", diagnose_baseline=False)
>>> r.converged, round(r.cv_rmse / 0.0015, 1) < 1.3, r.wear.label
(True, True, 'relative')
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
from ..errors import InputDataError
from ..model import Model, Parameters, ParameterSet, SetUnits, split_model_spec
from ..model.scaling import BoundHit, DataScales, data_parameters, speed_starts
from ..types import ObservationTable
from .wear import DEFAULT_WEAR_CALIBRATION, WearCalibration, paper_wear_values, relative_wear_values, wear_from_file

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
                         f"CV RMSE {self.cv_rmse:.4g} {self.units.torque_unit}, verdict {self.verdict}"),
            values=values, valid=dict(self.valid), spec=self.set_spec, units=self.units,
            stderr={n: float(p.stderr) for n, p in self.params.items() if p.stderr is not None},
            covariance=self.covariance, noise_std=self.noise_std, temperature_prior=prior,
            wear={"calibration": self.wear.label, "source": self.wear.source, "parameters": list(self.wear)},
            provenance={"robot": self.robot, "joint": self.joint, "data": list(self.sources),
                        "date": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
                        "software": f"jointwear {__version__}", "observations": self.n, "cycles": self.n_cycles,
                        "converged": self.converged, "verdict": self.verdict},
        )

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


def _check_identifiable(model: Model, table: ObservationTable, where: str) -> list[str]:
    warnings: list[str] = []
    speeds = np.unique(np.round(np.abs(table.speed), 9))
    if speeds.size < MIN_SPEEDS:
        raise CommissionError(f"{where}: {speeds.size} distinct speed(s); commissioning needs at least {MIN_SPEEDS} "
                              "speeds from the lowest to the highest the joint runs at: record test cycles over the "
                              "joint's speed range")
    cycles = np.unique(table["cycle"]) if "cycle" in table else np.array([0.0])
    if cycles.size < MIN_CYCLES:
        raise CommissionError(f"{where}: {cycles.size} test cycle(s); commissioning needs at least {MIN_CYCLES} "
                              "baseline cycles (held-out cycles validate the model): record more cycles")
    if "temperature" in model.variables:
        t = np.asarray(table.get("temperature"), dtype=float)
        t = t[np.isfinite(t)]
        if t.size < len(table):
            raise CommissionError(f"{where}: {len(table) - t.size} observation(s) without a temperature; model "
                                  f"{model.spec!r} has temperature terms: record the joint temperature "
                                  "(/joint_temperature) with every cycle, or commission with a model without them "
                                  "(--model standard)")
        span = float(np.ptp(t))
        if span < MIN_TEMPERATURE_SPAN:
            raise CommissionError(
                f"{where}: temperature span {span:.1f} degC ({t.min():.1f}-{t.max():.1f}) is too narrow to identify "
                f"the temperature terms (needs {MIN_TEMPERATURE_SPAN:g} degC): record baseline cycles while the "
                "joint warms up from cold, or commission with --model standard")
    if "load_torque" in model.variables:
        ld = np.abs(np.asarray(table.get("load_torque"), dtype=float))
        if not np.isfinite(ld).all():
            raise CommissionError(f"{where}: observations without a load torque; model {model.spec!r} has load terms: "
                                  "give load_torque with every observation")
        if ld.max() <= 0 or np.ptp(ld) < MIN_LOAD_SPAN * ld.max():
            raise CommissionError(
                f"{where}: load torque spans {ld.min():.4g}-{ld.max():.4g}, too narrow to identify the load terms "
                f"(needs {MIN_LOAD_SPAN:.0%} of the largest): record cycles at windows of different gravity load "
                "(other positions), or commission with a model without load terms")
    return warnings


def _bands(speed: np.ndarray, resid: np.ndarray | None, vmax: float) -> list[dict[str, Any]]:
    if resid is None:
        return []
    v = np.abs(speed)
    out = []
    edges = [s * vmax for s in BAND_SHARES]
    for lo, hi in itertools.pairwise(edges):
        m = (v >= lo) & (v < hi)
        if m.any():
            out.append({"lo": float(lo), "hi": float(hi), "n": int(m.sum()),
                        "cv_rmse": float(np.sqrt(np.mean(resid[m] ** 2)))})
    return out


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
) -> CommissionResult:
    """Fit a joint's nominal model on baseline observations; see the module docstring.

    ``table`` is in the set's units (``units``: the paper's normalized motor side by
    default, or the joint frame). ``model`` is the nominal spec (wear terms are
    dropped: the baseline is at w = 0; they come from ``wear_calibration``:
    ``paper``, ``relative`` or a FILE path, with ``wear_table`` its table when the
    FILE is one).
    """
    from ..workbench import diagnose, fit_model, noise_test, parse_spec

    t0 = time.perf_counter()
    units = units or SetUnits()
    where = table.source or "baseline"
    spec = nominal_spec(model)
    m = parse_spec(spec)
    warnings = _check_identifiable(m, table, where)
    if "wear" in table:
        w = np.asarray(table["wear"], dtype=float)
        if np.nanmax(np.abs(w)) > 0:
            warnings.append(f"{where}: the baseline holds wear levels up to {np.nanmax(w):g}; commissioning treats "
                            "it as w = 0 (as installed)")
    scales = DataScales.from_table(table)
    given = m.make_params()
    p0 = data_parameters(m.param_names, scales, given)

    starts: list[dict[str, float]] = speed_starts(m.param_names, scales)
    for term in m.terms:
        if term.name in ("coulomb", "load_coulomb", "load_stribeck", "temp_stribeck", "temp_viscous", "stribeck",
                         "viscous"):
            continue
        grid = term.guess(dict(table.model_inputs()))
        starts = [dict(s, **g) for s in starts for g in grid][:24]
    fit = fit_model(m, table, p0, starts=starts, cv_folds=cv_folds)
    bound = fit.at_bound
    converged = bool(fit.success and not bound and all(math.isfinite(fit.stderr(n)) for n in fit.free))
    for h in bound:
        warnings.append(f"parameter {h.name} = {h.value:.6g} ended on its {h.side} bound {h.bound:.6g}: the data do "
                        "not pin it down; the fit is not converged")
    bad_se = [n for n in fit.free if not math.isfinite(fit.stderr(n))]
    if bad_se:
        warnings.append(f"no standard error for {', '.join(bad_se)} (singular covariance): the data do not "
                        "identify them separately")
    nf = noise_test(table, fit.residuals, fit.n_free)
    verdict, suggestion, summary = "not run", None, "workbench diagnosis not run"
    if diagnose_baseline:
        d = diagnose(table, fit, cv_folds=cv_folds)
        verdict, suggestion, summary = d.verdict, d.suggestion, d.summary()
        if verdict == "found":
            warnings.append(f"the workbench finds an effect the model misses on the baseline: {suggestion}; "
                            f"commission with --model '{spec} + {suggestion}' to carry it into the wear estimate")
        elif verdict == "unexplained":
            warnings.append("the baseline is not explained to its noise floor and no candidate explains it: "
                            "estimates with this set may be biased")
    std = np.array([fit.stderr(n) for n in fit.free])
    cov = fit.correlations * np.outer(std, std) if fit.free else np.zeros((0, 0))
    covariance = (tuple(fit.free), tuple(tuple(float(x) for x in row) for row in cov))
    valid = _covered(table, m)
    # wear parameters
    if wear_calibration == "paper":
        wear = WearCalibration(paper_wear_values(units), "paper",
                               "Eq. (8) of Bittencourt et al. (2011) in the set's units")
    elif wear_calibration == "relative":
        t_med = float(np.nanmedian(table.get("temperature"))) if "temperature" in table else scales.temperature
        l_med = float(np.nanmedian(np.abs(table.get("load_torque")))) if "load_torque" in table else 0.0
        vals, ratio = relative_wear_values(m, fit.params, units, t_med, l_med)
        wear = WearCalibration(vals, "relative",
                               f"Eq. (8) scaled by the joint's nominal level at v = 0 over ref-2011r's "
                               f"(x{ratio:.4g} at T = {t_med:.3g} degC, load {l_med:.4g})")
    else:
        path = Path(wear_calibration)
        if not path.is_file():
            raise InputDataError(f"--wear-calibration {wear_calibration!r}: not paper, relative or an existing file")
        wear = wear_from_file(path, model=m, params=fit.params, table=wear_table, units=units)
    noise_std = nf.value if math.isfinite(nf.value) and nf.value > 0 else fit.rmse
    if noise_std < fit.rmse and not nf.consistent:
        noise_std = fit.cv_rmse if math.isfinite(fit.cv_rmse) else fit.rmse  # a model error counts as noise
    n_cycles = int(np.unique(table["cycle"]).size) if "cycle" in table else 1
    return CommissionResult(
        joint=joint, robot=robot, spec=m.spec, units=units, params=fit.params, covariance=covariance, valid=valid,
        rmse=fit.rmse, cv_rmse=fit.cv_rmse, bands=_bands(table.speed, fit.cv_residuals, scales.speed_level),
        noise_floor=nf.value, noise_method=nf.method, noise_consistent=bool(nf.consistent), verdict=verdict,
        suggestion=suggestion, summary=summary, wear=wear, on_bound=bound, converged=converged,
        message=fit.message, n=len(table), n_cycles=n_cycles, noise_std=float(noise_std), warnings=warnings,
        seconds=time.perf_counter() - t0, sources=list(sources),
    )


def _covered(table: ObservationTable, model: Model) -> dict[str, tuple[float, float]]:
    out: dict[str, tuple[float, float]] = {}
    v = np.abs(table.speed)
    out["speed"] = (float(v.min()), float(v.max()))
    for name in ("load_torque", "temperature"):
        if name in table:
            x = np.asarray(table[name], dtype=float)
            x = np.abs(x) if name == "load_torque" else x
            x = x[np.isfinite(x)]
            if x.size:
                out[name] = (float(x.min()), float(x.max()))
    for var in model.variables:
        if var not in out and var in table and var not in ("wear",):
            x = np.asarray(table[var], dtype=float)
            x = x[np.isfinite(x)]
            if x.size:
                out[var] = (float(x.min()), float(x.max()))
    out["wear"] = (0.0, 100.0)
    return out
