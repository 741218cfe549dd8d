"""The sentences the workbench says about its results: region labels, the shape hint, the noise floor, the verdict.

The rendering side's vocabulary. The cores (:mod:`.dependence`, :mod:`.diagnose`, ...) return data and
import neither this module nor :mod:`.render`; the sentences are made here from the plain values and the
results' fields (``v`` a :class:`~.dependence.VariableDependence`, ``d`` a :class:`~.diagnose.Diagnosis`).
:mod:`.render` re-exports them and assembles them into the terminal and Markdown reports and a result's JSON
(:func:`~.render.diagnosis_dict`); the HTML report (:mod:`.report`) takes them from :mod:`.render`, so the
JSON, the terminal and the page say the same.

>>> from jointwear_ros.workbench.dependence import VariableDependence
>>> v = VariableDependence("position", 1e-9, 1e-9, 0.68, "periodogram", True, shape="periodic",
...                        peak_frequency=17.07)
>>> shape_hint(v)
'periodic in position, w = 17.07 per unit (period 0.3681)'
>>> shape_hint(VariableDependence("temperature", 0.2, 0.1, 0.02, "smoother", False, monotone="increasing",
...                               speed_dependent=True, speed_region=(0.0, 30.0)))
'smooth in temperature, increasing, mostly at 0-30 rad/s'
>>> speed_region_label((0.0, 30.0)), candidate_region_label((0.0, 30.0))
('0-30 rad/s', 'low speeds 0-30 rad/s')
"""

from __future__ import annotations

import math
from typing import Any

from .compare import SPEED_BAND_EDGES, NoiseFloor, band_label

__all__ = [
    "NOISE_UNKNOWN",
    "candidate_region_label",
    "cv_rmse_text",
    "diagnosis_summary",
    "floor_text",
    "goodness_of_fit",
    "noise_line",
    "shape_hint",
    "speed_region_label",
]

#: What a report says when the data give no noise floor.
NOISE_UNKNOWN = "noise floor unknown (no tau_f_std, replicates or repeated speeds across cycles)"


# -- labels ------------------------------------------------------------------------------
def speed_region_label(region: tuple[float, float]) -> str:
    """``all speeds`` or ``10-30 rad/s``."""
    lo, hi = region
    if lo <= SPEED_BAND_EDGES[0] and not math.isfinite(hi):
        return "all speeds"
    return f"{band_label(lo, hi)} rad/s"


def candidate_region_label(region: tuple[float, float]) -> str:
    """``all speeds`` or ``low speeds 0-30 rad/s`` (low, mid, high speeds by the paper's motor-side bands)."""
    lo, hi = region
    if lo <= SPEED_BAND_EDGES[0] and not math.isfinite(hi):
        return "all speeds"
    where = ("low speeds" if hi <= 60 else "high speeds" if lo >= 100
             else "mid speeds" if lo >= 10 and hi <= 150 else "speeds")
    return f"{where} {band_label(lo, hi)} rad/s"


def shape_hint(v: Any) -> str:
    """The shape a column's (or a pair's) evidence points to, in words."""
    c = v.name
    if v.shape == "interaction":
        a, b = v.columns
        return f"interaction of {a} and {b}"
    if v.shape == "adds":
        a, b = v.columns
        return f"{b} adds to {a}"
    if v.shape == "periodic" and v.peak_frequency is not None:
        w = v.peak_frequency
        hint = f"periodic in {c}, w = {w:.4g} per unit (period {2 * math.pi / w:.4g})"
    elif v.shape == "step" and v.changepoint is not None:
        hint = f"step in {c} at {v.changepoint:.6g}"
    elif v.shape == "scales":
        hint = f"scales the model's {v.scaled_term} with {c}"
    else:
        hint = f"smooth in {c}, {v.monotone}"
    if v.speed_dependent:
        hint += f", mostly at {band_label(*v.speed_region)} rad/s"
    return hint


# -- the noise floor ---------------------------------------------------------------------
def _consistent(nf: NoiseFloor) -> str:
    return "consistent" if nf.consistent else "NOT consistent"


def goodness_of_fit(nf: NoiseFloor, cv_rmse: float) -> str:
    """``goodness of fit: chi-square with tau_f_std, p = 0.57: the residual is consistent with the noise
    (CV RMSE 1.02x the floor)``."""
    if not math.isfinite(nf.value):
        return f"goodness of fit: {NOISE_UNKNOWN}"
    return (f"goodness of fit: {nf.method}, p = {nf.p_value:.2g}: the residual is {_consistent(nf)} with the noise "
            f"(CV RMSE {cv_rmse / nf.value:.2f}x the floor)")


def noise_line(nf: NoiseFloor, cv_rmse: float | None = None) -> str:
    """``noise floor 0.00150 (method): [CV RMSE = 1.00x the floor; ]p = 0.7, consistent with the noise``."""
    if not math.isfinite(nf.value):
        return NOISE_UNKNOWN
    ratio = f"CV RMSE = {cv_rmse / nf.value:.2f}x the floor; " if cv_rmse is not None else ""
    return f"noise floor {nf.value:.5f} ({nf.method}): {ratio}p = {nf.p_value:.2g}, {_consistent(nf)} with the noise"


def floor_text(nf: NoiseFloor) -> str:
    """``noise floor 0.00150 (method: p = 0.7, consistent with the noise)``, as the summary says it."""
    if not math.isfinite(nf.value):
        return NOISE_UNKNOWN
    return f"noise floor {nf.value:.5f} ({nf.method}: p = {nf.p_value:.2g}, {_consistent(nf)} with the noise)"


# -- a diagnosis in sentences --------------------------------------------------------------
def _ratio(nf: NoiseFloor, rmse: float) -> str:
    r = nf.ratio(rmse)
    return f"{r:.2f}x the noise floor" if math.isfinite(r) else "noise floor unknown"


def _outlier_text(d: Any) -> str:
    if not d.outliers:
        return ""
    rows = ", ".join(f"row {o.row} (cycle {o.cycle:g}, speed {o.speed:g}, {o.z:+.1f} std)" for o in d.outliers[:5])
    more = f" and {len(d.outliers) - 5} more" if len(d.outliers) > 5 else ""
    iso = (f" The best shape, {d.suggestion}, owes most of its gain to them: it isolates them, it is not a "
           "missing effect." if d.isolates_outliers else "")
    return (f" {len(d.outliers)} outlying observation(s): {rows}{more}; check them (a bad sample, a "
            f"disturbed cycle) before trusting any shape.{iso}")


def diagnosis_summary(d: Any) -> str:
    """The verdict in a few sentences: what is missing, or that nothing is, or what stays unexplained."""
    b = d.best
    nf = d.noise
    if d.verdict == "undetermined":
        cv = (f"CV RMSE {d.cv_rmse:.5f}" if math.isfinite(d.cv_rmse) else
              "no CV RMSE (a single group: nothing to hold out)")
        sug = f" The best candidate would be {b.term} (p = {b.p_value:.2g})." if b is not None else ""
        return (f"Undetermined: model {d.model!r} has RMSE {d.rmse:.5f}, {cv}, but there is no noise estimate to "
                "judge it by (no tau_f_std column, no repeated observations, no cycles to compare at equal speed), "
                f"so whether an effect is missing cannot be said.{sug} Give tau_f_std or record repeated cycles."
                + _outlier_text(d))
    if d.verdict == "nothing_missing":
        top = d.variables[0] if d.variables else None
        dep = (f"; no column explains its residual (strongest: {top.name}, adjusted p = {top.p_value:.2g}, "
               f"significant below {d.alpha / 2:g})" if top else "; no column to test")
        cand = (f"; the best candidate, {d.candidates[0].term}, is not significant "
                f"(p = {d.candidates[0].p_value:.2g}; significant below {d.alpha / max(len(d.candidates), 1):.2g} "
                "with a lower CV RMSE and BIC)") if d.candidates else ""
        text = (f"Nothing missing: model {d.model!r} has {cv_rmse_text(d.cv_rmse)} "
                f"({_ratio(nf, d.cv_rmse)}); {floor_text(nf)}{dep}{cand}.")
    elif d.verdict == "found" and b is not None:
        stab = d.stability.get(b.term)
        stab_txt = (f" It is chosen in {100 * stab:.0f} % of bootstrap resamples by cycle (terms of "
                    f"{', '.join(b.key)}: {100 * d.support:.0f} %)." if stab is not None else "")
        text = (f"Missing effect found: {b.term} — {b.description}, structured at {candidate_region_label(b.speed_region)}. "
                f"Adding it brings the CV RMSE from {d.cv_rmse:.5f} to {b.cv_rmse:.5f} "
                f"({_ratio(nf, b.cv_rmse)}) and leaves no significant dependence on any column.{stab_txt} "
                f"Try: --model \"{d.model} + {b.term}\"")
    else:
        sig = [v for v in d.variables if v.significant]
        parts = [f"Unexplained structure remains: model {d.model!r} has {cv_rmse_text(d.cv_rmse)} "
                 f"({_ratio(nf, d.cv_rmse)}; {floor_text(nf)})."]
        if sig:
            parts.append("The residual depends on " + "; ".join(
                f"{v.name} ({shape_hint(v)}; explains {100 * v.explained_share:.0f} %, adjusted p = {v.p_value:.2g})"
                for v in sig[:3]) + ".")
        else:
            parts.append("No column of the table explains it (a variable that is not recorded, or a noise "
                         "estimate that is too optimistic).")
        tried = d.candidates[:3]
        if tried:
            parts.append("Best shapes tried: " + ", ".join(
                f"{c.term} ({_ratio(nf, c.cv_rmse)}{'' if c.significant else ', not significant'})"
                for c in tried) + ".")
        if b is not None:
            rest = [v.name for v in d.after_variables if v.significant]
            left = f"; the residual still depends on {', '.join(rest)}" if rest else ""
            odd = ("" if d.agrees else
                   "; its variables are not among those the model-free ranking found, so it can only be a "
                   "partial fit")
            if not d.stable and d.alternatives:
                odd += (f"; the data does not tell it from {', '.join(d.alternatives[:3])} (terms of its "
                        f"column(s) win only {100 * d.support:.0f} % of bootstrap resamples by cycle)")
            parts.append(f"The best, {b.term}, leaves the CV RMSE at {_ratio(nf, b.cv_rmse)} "
                         f"(at {candidate_region_label(b.speed_region)}){left}{odd}. "
                         f"Try next: --model \"{d.model} + {b.term}\", then diagnose again.")
        text = " ".join(parts)
    return text + _outlier_text(d)


def cv_rmse_text(cv_rmse: float) -> str:
    """``CV RMSE 0.00150``, or why there is none (never ``nan``)."""
    return (f"CV RMSE {cv_rmse:.5f}" if math.isfinite(cv_rmse) else
            "CV RMSE not computed (a single cycle and no other groups: nothing to hold out)")
