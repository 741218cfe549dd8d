"""A synthetic case study in the spirit of the paper's Section 6.

The paper's case study combines two real data sets, Eq. (15)::

    tau_f*(k) = tau~_f(k) + tau_f^0(T)

a wear profile ``tau~_f(k)`` (friction increase of one robot during an
accelerated wear test, over a test index k, alarm at k = 80) and friction
curves ``tau_f^0(T)`` of *another* robot of the same type, without wear, at
known temperatures T drawn to follow N(40, 3^2). Wear is estimated at every
speed separately and compared with the reference ``w*(k)`` of Eq. (16): the w
that best fits the wear profile alone with the model's wear term, using all
speeds.

The real data are not available; this module builds the same experiment from
the model, with a deliberate **model mismatch** so that the estimators do not
see data from their own model:

- the true wear rises as ``w(k) = w_alarm * (k / k_alarm) ** exponent``
  (default 35 at k = 80, k = 0..119);
- the wear profile comes from joint A, whose wear parameters (Fsw, vsw, Fvw)
  differ from Eq. (8) by up to ``mismatch`` (relative, uniform, seeded);
- the temperature curves come from joint B, whose load/temperature parameters
  (Table 1) differ from the model's by up to ``mismatch`` the same way;
- each index k has one temperature ``T_k`` (from the stated distribution, one
  test cycle) shared by all speeds; each of the two data sets carries its own
  measurement noise of std ``noise_std / sqrt(2)``, so ``tau_f*`` has noise
  ``noise_std``.

Per speed and estimator: ``dw = w_hat - w*``; its mean, worst case ``max|dw|``
and standard deviation over k (the paper's Fig. 14), the best speed (smallest
root-mean-square dw), and a detection with a threshold on ``w_hat`` (default
35): the first k with an alarm, the first k of ``confirm`` consecutive alarms,
false alarms before the true crossing and misses after it.

Pure numpy/scipy; no ROS import.

>>> from jointwear_ros.estimation import make_estimator
>>> setup = CaseSetup(speeds=(40.0,), seed=0)
>>> res = run_case_study({"paper": make_estimator("paper", n_samples=50)}, setup)
>>> res.crossing_index
80
>>> bool(abs(res.methods["paper"]["mean"][0]) < 3.0)
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.optimize import minimize_scalar

from ..errors import InputDataError
from ..fmt import format_table
from ..model import Model, Parameters
from ..types import ObservationTable
from ._common import DEFAULT_NOISE_STD, WEAR_RANGE, Progress, capabilities_of, make_rng, resolve_model
from .priors import TemperaturePrior, normal_prior, parse_temperature_prior

__all__ = [
    "WEAR_PARAMS",
    "CaseSetup",
    "CaseStudyResult",
    "detect",
    "mismatched_params",
    "reference_wear",
    "run_case_study",
    "wear_profile",
]

Array = npt.NDArray[np.float64]

#: The wear parameters of Eq. (8); the rest of the model are Table 1's.
WEAR_PARAMS: tuple[str, ...] = ("Fsw", "vsw", "Fvw")


@dataclass(frozen=True)
class CaseSetup:
    """The synthetic Section 6 experiment.

    Parameters
    ----------
    speeds
        Speeds of every test cycle, rad/s (motor side).
    n_indices
        Test indices k = 0 .. n_indices - 1.
    alarm_index, alarm_wear
        The true wear crosses ``alarm_wear`` at ``alarm_index`` (the paper: 35 at k = 80).
    exponent
        Shape of the wear profile ``w(k) = alarm_wear * (k / alarm_index) ** exponent``
        (> 1: wear accelerates), clipped to the wear range.
    load, noise_std
        tau_m of the observations and the total noise std of ``tau_f*``.
    temperature
        Distribution of the cycle temperatures T_k (the paper's reference N(40, 3^2)).
    mismatch
        Largest relative difference between the data's parameters and the model's.
    threshold, confirm
        Detection threshold on ``w_hat`` and the run of consecutive alarms that confirms one.
    seed
        Seeds the mismatch, the temperatures, the noise and the estimators' samples.
    """

    speeds: Sequence[float] = tuple(float(v) for v in np.linspace(0.0, 280.0, 56))
    n_indices: int = 120
    alarm_index: int = 80
    alarm_wear: float = 35.0
    exponent: float = 1.5
    load: float = 0.1
    noise_std: float = DEFAULT_NOISE_STD
    temperature: TemperaturePrior | str = field(default_factory=lambda: normal_prior(40.0, 3.0))
    mismatch: float = 0.03
    threshold: float = 35.0
    confirm: int = 3
    seed: int | None = 0

    def checked(self) -> CaseSetup:
        """This setup with its values checked (raises :class:`InputDataError`)."""
        v = np.asarray(self.speeds, dtype=float).reshape(-1)
        if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v < 0):
            raise InputDataError(f"case study speeds {v.tolist()!r}: give at least one finite speed >= 0 rad/s")
        if not 2 <= int(self.alarm_index) < int(self.n_indices):
            raise InputDataError(f"alarm_index = {self.alarm_index!r} must be within [2, n_indices = {self.n_indices})")
        lo, hi = WEAR_RANGE
        if not lo < self.alarm_wear < hi:
            raise InputDataError(f"alarm_wear = {self.alarm_wear!r} must be inside ({lo:g}, {hi:g})")
        if not (math.isfinite(self.exponent) and self.exponent > 0):
            raise InputDataError(f"exponent = {self.exponent!r} must be positive")
        if not (math.isfinite(self.noise_std) and self.noise_std > 0):
            raise InputDataError(f"noise_std = {self.noise_std!r} must be positive (normalized torque)")
        if not (math.isfinite(self.load) and self.load >= 0):
            raise InputDataError(f"load = {self.load!r} must be finite and >= 0")
        if not (math.isfinite(self.mismatch) and 0 <= self.mismatch < 0.5):
            raise InputDataError(f"mismatch = {self.mismatch!r} must be within [0, 0.5)")
        if int(self.confirm) < 1:
            raise InputDataError(f"confirm = {self.confirm!r} must be at least 1")
        return CaseSetup(tuple(float(s) for s in v), int(self.n_indices), int(self.alarm_index),
                         float(self.alarm_wear), float(self.exponent), float(self.load), float(self.noise_std),
                         parse_temperature_prior(self.temperature), float(self.mismatch), float(self.threshold),
                         int(self.confirm), self.seed)


def wear_profile(setup: CaseSetup) -> Array:
    """The true wear ``w(k)``, k = 0 .. n_indices - 1."""
    k = np.arange(setup.n_indices, dtype=float)
    w = setup.alarm_wear * (k / setup.alarm_index) ** setup.exponent
    return np.clip(w, *WEAR_RANGE)


def mismatched_params(params: Parameters, names: Sequence[str], mismatch: float,
                      rng: np.random.Generator) -> tuple[Parameters, dict[str, float]]:
    """``params`` with each of ``names`` scaled by ``1 + mismatch * u``, ``u ~ U(-1, 1)``.

    Returns the new parameters and the relative change of each.
    """
    u = rng.uniform(-1.0, 1.0, len(names))
    rel = {n: float(mismatch * x) for n, x in zip(names, u)}
    values = params.valuesdict()
    return params.with_values({n: values[n] * (1.0 + r) for n, r in rel.items()}), rel


def _wear_term(model: Model, params: Parameters, speeds: Array, load: float, wear: Array) -> Array:
    """``g_v(w)``: the friction added by wear, shape ``wear.shape + speeds.shape``."""
    w = np.asarray(wear, dtype=float)[..., None]
    full = model.evaluate(params, speed=speeds, load_torque=load, temperature=40.0, wear=w)
    base = model.evaluate(params, speed=speeds, load_torque=load, temperature=40.0, wear=0.0)
    return np.asarray(full - base, dtype=float)


def reference_wear(model: Model, params: Parameters, speeds: npt.ArrayLike, load: float,
                   profile: npt.ArrayLike, step: float = 0.05) -> Array:
    """Eq. (16): per row of ``profile`` (k, speeds), the w fitting it best with the model's wear term.

    A grid over the wear range (``step``), then a bounded scalar polish around
    the best grid point.
    """
    v = np.asarray(speeds, dtype=float)
    prof = np.atleast_2d(np.asarray(profile, dtype=float))
    lo, hi = WEAR_RANGE
    grid = np.linspace(lo, hi, round((hi - lo) / step) + 1)
    g = _wear_term(model, params, v, load, grid)  # (grid, speeds)
    sse = (prof * prof).sum(axis=1)[:, None] - 2.0 * prof @ g.T + (g * g).sum(axis=1)[None, :]
    best = np.argmin(sse, axis=1)
    out = np.empty(prof.shape[0])
    for i, j in enumerate(best):
        a, b = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
        if b <= a:
            out[i] = grid[j]
            continue

        def cost(w: float, row: Array = prof[i]) -> float:
            r = row - _wear_term(model, params, v, load, np.array(w))
            return float(r @ r)

        r = minimize_scalar(cost, bounds=(a, b), method="bounded", options={"xatol": 1e-6})
        out[i] = float(r.x) if cost(float(r.x)) <= cost(float(grid[j])) else float(grid[j])
    return out


def detect(estimates: npt.ArrayLike, threshold: float, crossing: int, confirm: int = 3) -> dict[str, int | None]:
    """Threshold detection on a series ``w_hat(k)``.

    ``first_alarm``: first k with ``w_hat >= threshold``; ``first_confirmed``:
    first k that starts ``confirm`` consecutive alarms; ``false_alarms``:
    alarms at k < ``crossing`` (the true wear is below the threshold there);
    ``misses``: no alarm at k >= ``crossing``; ``delay``: ``first_confirmed - crossing``.
    """
    w = np.asarray(estimates, dtype=float)
    alarm = w >= threshold
    idx = np.flatnonzero(alarm)
    first = int(idx[0]) if idx.size else None
    confirmed = None
    if w.size >= confirm:
        runs = np.convolve(alarm.astype(int), np.ones(confirm, dtype=int), mode="valid")
        hit = np.flatnonzero(runs == confirm)
        confirmed = int(hit[0]) if hit.size else None
    return {
        "first_alarm": first,
        "first_confirmed": confirmed,
        "delay": None if confirmed is None else confirmed - crossing,
        "false_alarms": int(alarm[:crossing].sum()),
        "misses": int((~alarm[crossing:]).sum()),
    }


@dataclass
class CaseStudyResult:
    """The outcome of :func:`run_case_study`."""

    setup: CaseSetup
    k: npt.NDArray[np.int64]
    w_true: Array
    w_ref: Array
    temperatures: Array
    speeds: list[float]
    crossing_index: int
    joint_a_relative: dict[str, float]
    joint_b_relative: dict[str, float]
    methods: dict[str, dict[str, Any]]
    seconds: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: per method and speed the mean, worst and std of dw, the best speed, detection."""
        methods: dict[str, Any] = {}
        for name, d in self.methods.items():
            methods[name] = {
                "mean": d["mean"], "worst": d["worst"], "std": d["std"],
                "best_speed": d["best_speed"], "best": d["best"], "detection": d["detection"],
                "estimates_at_best_speed": d["estimates"][:, d["best_index"]],
            }
        s = self.setup
        return {
            "speeds": self.speeds,
            "k": self.k,
            "w_true": self.w_true,
            "w_ref": self.w_ref,
            "temperatures": self.temperatures,
            "crossing_index": self.crossing_index,
            "threshold": s.threshold,
            "confirm": s.confirm,
            "mismatch": s.mismatch,
            "temperature": parse_temperature_prior(s.temperature).label,
            "load": s.load,
            "noise_std": s.noise_std,
            "joint_a_wear_relative_change": self.joint_a_relative,
            "joint_b_relative_change": self.joint_b_relative,
            "seconds": self.seconds,
            "methods": methods,
        }

    def summary_text(self, every: int = 1) -> str:
        """A readable report: per method a per-speed table and the best speed with its detection."""
        s = self.setup
        lines = [
            f"case study: {s.n_indices} indices, w crosses {s.alarm_wear:g} at k = {self.crossing_index}; "
            f"T_k ~ {parse_temperature_prior(s.temperature).label}; model mismatch up to {100 * s.mismatch:g} %",
            "dw = w_hat - w* (w* = Eq. 16 fit of the wear profile over all speeds)",
        ]
        for name, d in self.methods.items():
            rows = [[f"{v:.1f}", float(d["mean"][i]), float(d["worst"][i]), float(d["std"][i])]
                    for i, v in enumerate(self.speeds) if i % every == 0 or i == d["best_index"]]
            lines.append("")
            lines.append(f"{name}:")
            lines.append(format_table(["speed", "mean dw", "worst |dw|", "std dw"], rows, ".2f"))
            b, det = d["best"], d["detection"]
            lines.append(
                f"{name}: best at {d['best_speed']:.1f} rad/s: bias {b['mean']:+.2f}, worst {b['worst']:.2f}, "
                f"std {b['std']:.2f}; threshold {s.threshold:g}: first alarm k = {det['first_alarm']}, "
                f"confirmed ({s.confirm} in a row) k = {det['first_confirmed']}, "
                f"false alarms before k = {self.crossing_index}: {det['false_alarms']}, misses after: {det['misses']}"
            )
        return "\n".join(lines)


def _estimate_column(estimator: Any, speed: float, load: float, tau: Array, rng: np.random.Generator) -> Array:
    rows_fn = getattr(estimator, "estimate_rows", None)
    if rows_fn is not None:
        w, _ = rows_fn(np.full(tau.size, speed), load, tau, None, rng=rng)
        return np.asarray(w, dtype=float)
    out = np.empty(tau.size)
    for i, t in enumerate(tau):
        obs = ObservationTable.from_arrays(speed=[speed], tau_f=[t], load_torque=[load])
        out[i] = estimator.estimate(obs).wear
    return out


def run_case_study(
    estimators: Mapping[str, Any],
    setup: CaseSetup | None = None,
    *,
    model: Model | None = None,
    params: Parameters | Mapping[str, float] | str | None = None,
    progress: Progress | None = None,
) -> CaseStudyResult:
    """Run the synthetic Section 6 case study for per-speed estimators.

    Parameters
    ----------
    estimators
        name -> per-speed estimator (``paper``, ``paper-grid``, ``bayes``, or
        any :class:`~jointwear_ros.types.WearEstimator` used one observation at a time).
        A cycle estimator (``capabilities.cycle``: ``joint``) is not a per-speed estimator and is refused.
    setup
        The experiment (default :class:`CaseSetup`).
    model, params
        The MODEL the estimators assume (default Eq. 9 with ``ref-2011r``); the
        data come from mismatched copies of ``params``.
    progress
        Called as ``progress(done, total)`` after each estimator.
    """
    import time

    from . import ESTIMATORS

    s = (setup or CaseSetup()).checked()
    m, p = resolve_model(model, params)
    for name, est in estimators.items():
        if capabilities_of(est).cycle:
            raise InputDataError(f"case study: estimator {name!r} is a cycle estimator (one estimate from all "
                                 "speeds of a cycle); the case study estimates at every speed separately "
                                 f"({', '.join(n for n, c in ESTIMATORS.items() if not capabilities_of(c).cycle)})")
    if not estimators:
        raise InputDataError("case study: give at least one estimator")
    t0 = time.perf_counter()
    gen = make_rng(None, s.seed)
    v = np.asarray(s.speeds, dtype=float)
    table1 = [n for n in m.param_names if n not in WEAR_PARAMS]
    p_a, rel_a = mismatched_params(p, WEAR_PARAMS, s.mismatch, gen)
    p_b, rel_b = mismatched_params(p, table1, s.mismatch, gen)
    w_true = wear_profile(s)
    temps = parse_temperature_prior(s.temperature).sample(gen, s.n_indices)
    half = s.noise_std / math.sqrt(2.0)
    # Eq. (15): the wear profile of joint A plus the temperature curves of joint B
    profile = _wear_term(m, p_a, v, s.load, w_true) + half * gen.standard_normal((s.n_indices, v.size))
    tau0 = np.asarray(m.evaluate(p_b, speed=v[None, :], load_torque=s.load, temperature=temps[:, None], wear=0.0))
    tau_star = profile + tau0 + half * gen.standard_normal((s.n_indices, v.size))
    w_ref = reference_wear(m, p, v, s.load, profile)
    crossing = int(s.alarm_index)
    methods: dict[str, dict[str, Any]] = {}
    for n_done, (name, est) in enumerate(estimators.items(), start=1):
        est_rng = make_rng(None, None if s.seed is None else s.seed + 1)
        w_hat = np.stack([_estimate_column(est, float(v[j]), s.load, tau_star[:, j], est_rng)
                          for j in range(v.size)], axis=1)
        dw = w_hat - w_ref[:, None]
        mean = dw.mean(axis=0)
        std = dw.std(axis=0, ddof=1)
        worst = np.abs(dw).max(axis=0)
        rms = np.sqrt(np.mean(dw * dw, axis=0))
        best = int(np.argmin(rms))
        methods[name] = {
            "estimates": w_hat, "mean": mean, "worst": worst, "std": std, "rms": rms,
            "best_index": best, "best_speed": float(v[best]),
            "best": {"mean": float(mean[best]), "worst": float(worst[best]), "std": float(std[best]),
                     "rms": float(rms[best])},
            "detection": detect(w_hat[:, best], s.threshold, crossing, s.confirm),
        }
        if progress is not None:
            progress(n_done, len(estimators))
    return CaseStudyResult(
        setup=s, k=np.arange(s.n_indices), w_true=w_true, w_ref=w_ref, temperatures=temps,
        speeds=[float(x) for x in v], crossing_index=crossing, joint_a_relative=rel_a, joint_b_relative=rel_b,
        methods=methods, seconds=time.perf_counter() - t0,
    )
