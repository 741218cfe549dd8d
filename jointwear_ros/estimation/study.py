"""The Section 5.1 simulation study and the robustness study (pure numpy).

Observations follow the paper's Eq. (12)::

    tau_f = tau_f(v, tau_m, T, w0) + e,   e ~ N(0, sigma_e^2),   T ~ p_true(T)

with ``w0 = 35``, ``sigma_e = 0.0015``, ``tau_m = 0.1`` and ``T ~ N(40, 3^2)``
by default. Each run draws ONE temperature shared by all speeds (a test cycle)
and an independent noise per speed. A per-speed estimator (``paper``,
``paper-grid``, ``bayes``) estimates w from each (run, speed) observation on
its own, exactly as the paper's study does; the marginal statistics per speed
do not depend on the temperature being shared. A cycle estimator
(``capabilities.cycle``: ``joint``) estimates w from all speeds of a run at once
(one cycle, one shared T): its study has one row, the cycle.

Per speed (or per cycle): bias, variance and mean-squared error of the
estimates, the Cramér-Rao bound under the TRUE temperature distribution
(:func:`~jointwear_ros.estimation.crb.crb_per_speed`, or
:func:`~jointwear_ros.estimation.crb.crb_multi_speed` for a cycle), quantiles
and a histogram of the estimates on [0, 100] (the density of Fig. 9).

>>> from jointwear_ros.estimation import make_estimator
>>> setup = StudySetup(speeds=(40.0,), runs=200, seed=1)
>>> r = run_study(make_estimator("paper", n_samples=50), setup, crb=False)
>>> bool(abs(r.bias[0]) < 1.0 and 1.0 < r.variance[0] < 6.0)
True
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from ..model import Model, Parameters
from ..types import ObservationTable
from ._common import DEFAULT_NOISE_STD, WEAR_RANGE, Progress, capabilities_of, make_rng, resolve_model
from .priors import TemperaturePrior, normal_prior, parse_temperature_prior

__all__ = [
    "DEFAULT_ROBUSTNESS_SCENARIOS",
    "PAPER_STUDY_TEMPERATURE",
    "QUANTILE_LEVELS",
    "RobustnessRow",
    "StudyResult",
    "StudySetup",
    "robustness_study",
    "run_study",
    "simulate_cycles",
]

Array = npt.NDArray[np.float64]

#: The data distribution of T in Section 5.1, degC.
PAPER_STUDY_TEMPERATURE = normal_prior(40.0, 3.0)
#: Quantile levels reported per speed.
QUANTILE_LEVELS: tuple[float, ...] = (0.025, 0.25, 0.5, 0.75, 0.975)
#: Histogram bins of the estimates over the wear range (Fig. 9 density).
HIST_BINS = 200

#: Robustness scenarios: label -> true temperature distribution.
DEFAULT_ROBUSTNESS_SCENARIOS: dict[str, str] = {
    "nominal N(40,3)": "normal:40:3",
    "uniform U(30,50)": "uniform:30:50",
    "wide N(40,8)": "normal:40:8",
    "hot N(55,2)": "normal:55:2",
    "cold N(25,2)": "normal:25:2",
}


@dataclass(frozen=True)
class StudySetup:
    """What the simulated observations look like (Eq. 12)."""

    speeds: Sequence[float]
    runs: int = 10_000
    true_wear: float = 35.0
    load: float = 0.1
    noise_std: float = DEFAULT_NOISE_STD
    true_temperature: TemperaturePrior | str = PAPER_STUDY_TEMPERATURE
    seed: int | None = 0

    def checked(self) -> StudySetup:
        """This setup with its values checked (raises :class:`InputDataError`)."""
        v = np.asarray(self.speeds, dtype=float).reshape(-1)
        if v.size == 0:
            raise InputDataError("the study needs at least one speed")
        if not np.all(np.isfinite(v)) or np.any(v < 0):
            raise InputDataError(f"speeds {v.tolist()!r}: every speed must be finite and >= 0 (rad/s, motor side)")
        if int(self.runs) < 2:
            raise InputDataError(f"runs = {self.runs!r}: a study needs at least 2 runs per speed")
        lo, hi = WEAR_RANGE
        if not (math.isfinite(self.true_wear) and lo <= self.true_wear <= hi):
            raise InputDataError(f"true wear {self.true_wear!r} must be within [{lo:g}, {hi:g}]")
        if not (math.isfinite(self.noise_std) and self.noise_std > 0):
            raise InputDataError(f"noise_std = {self.noise_std!r} must be positive (normalized torque)")
        if not (math.isfinite(self.load) and self.load >= 0):
            raise InputDataError(f"load = {self.load!r} must be finite and >= 0 (normalized torque)")
        prior = parse_temperature_prior(self.true_temperature)
        return StudySetup(tuple(float(s) for s in v), int(self.runs), float(self.true_wear), float(self.load),
                          float(self.noise_std), prior, self.seed)

    @property
    def temperature_prior(self) -> TemperaturePrior:
        return parse_temperature_prior(self.true_temperature)


def simulate_cycles(model: Model, params: Parameters, setup: StudySetup, rng: np.random.Generator,
                    runs: int | None = None) -> tuple[Array, Array]:
    """Observations of ``runs`` cycles, Eq. (12): ``(tau_f (runs, K), T (runs,))``.

    One temperature per run (shared by its K speeds), one noise per (run, speed).
    """
    n = setup.runs if runs is None else int(runs)
    v = np.asarray(setup.speeds, dtype=float)
    temps = setup.temperature_prior.sample(rng, n)
    clean = model.evaluate(params, speed=v[None, :], load_torque=setup.load, temperature=temps[:, None],
                           wear=setup.true_wear)
    tau = clean + setup.noise_std * rng.standard_normal((n, v.size))
    return np.asarray(tau, dtype=float), temps


@dataclass
class StudyResult:
    """Statistics of a study, one entry per row (a speed, or the one cycle of ``joint``)."""

    method: str
    mode: str  # "per-speed" or "cycle"
    runs: int
    seconds: float
    speeds: list[float]
    true_wear: float
    true_temperature: str
    assumed_temperature: str
    bias: Array
    variance: Array
    mse: Array
    crb: Array
    quantiles: dict[float, Array]
    hist_edges: Array
    hist_counts: npt.NDArray[np.int64]
    extra: dict[str, Any] = field(default_factory=dict)
    #: the Hammersley-Chapman-Robbins bound per speed (``hcr=True``; inf where w0 has a twin wear)
    hcr: Array | None = None
    #: per speed, the wear giving exactly the friction of the true wear (NaN where none)
    twin_wear: Array | None = None

    @property
    def rows(self) -> list[str]:
        """Row labels: the speeds, or ``cycle`` for a joint study."""
        if self.mode == "cycle":
            return [f"cycle of {len(self.speeds)} speeds"]
        return [f"{v:g}" for v in self.speeds]

    def to_dict(self, histogram: bool = False) -> dict[str, Any]:
        """The JSON contract: ``method, runs, seconds, speeds, bias, variance, crb`` and more."""
        out: dict[str, Any] = {
            "method": self.method,
            "mode": self.mode,
            "meaning": (
                "one row per speed: each (run, speed) observation is estimated on its own, as in the paper"
                if self.mode == "per-speed" else
                "one row: each run is ONE test cycle over all the speeds at one shared unknown T; "
                "bias/variance/crb are of the cycle's single estimate (crb = multi-speed bound)"
            ),
            "runs": self.runs,
            "seconds": self.seconds,
            "speeds": self.speeds,
            "true_wear": self.true_wear,
            "true_temperature": self.true_temperature,
            "assumed_temperature": self.assumed_temperature,
            "bias": self.bias,
            "variance": self.variance,
            "mse": self.mse,
            "crb": self.crb,
            "quantiles": {f"{q:g}": a for q, a in self.quantiles.items()},
        }
        if self.hcr is not None:
            out["hcr"] = self.hcr  # JSON null = infinite (see twin_wear)
            out["twin_wear"] = self.twin_wear
            out["hcr_meaning"] = ("Hammersley-Chapman-Robbins bound on the variance of an unbiased estimate: "
                                  "equal to crb where the CRB is reachable, far above it where another wear "
                                  "gives nearly the same friction, null (infinite) where one (twin_wear) "
                                  "gives exactly the same")
        out.update(self.extra)
        if histogram:
            out["histogram"] = {"edges": self.hist_edges, "counts": self.hist_counts}
        return out


def _assumed_label(estimator: Any) -> str:
    prior = getattr(estimator, "prior", None)
    if isinstance(prior, TemperaturePrior):
        return prior.label
    rng = getattr(estimator, "temperature_range", None)
    if rng is not None:
        return f"uniform:{rng[0]:g}:{rng[1]:g}"
    return "unknown"


def _per_speed(estimator: Any, setup: StudySetup, tau: Array, rng: np.random.Generator,
               progress: Progress | None) -> Array:
    v = np.asarray(setup.speeds)
    est = np.empty(tau.shape)
    rows_fn = getattr(estimator, "estimate_rows", None)
    for k in range(v.size):
        if rows_fn is not None:
            w, _ = rows_fn(np.full(tau.shape[0], v[k]), setup.load, tau[:, k], None, rng=rng)
            est[:, k] = w
        else:  # any WearEstimator: one table per observation
            for i in range(tau.shape[0]):
                obs = ObservationTable.from_arrays(speed=[v[k]], tau_f=[tau[i, k]], load_torque=[setup.load])
                est[i, k] = estimator.estimate(obs).wear
        if progress is not None:
            progress(k + 1, v.size)
    return est


def _per_cycle(estimator: Any, setup: StudySetup, tau: Array, progress: Progress | None) -> tuple[Array, Array]:
    v = np.asarray(setup.speeds)
    n = tau.shape[0]
    wear, temp = np.empty(n), np.empty(n)
    arrays_fn = getattr(estimator, "estimate_arrays", None)
    chunk = max(1, min(500, n // 20 or 1))
    for s in range(0, n, chunk):
        sl = slice(s, min(n, s + chunk))
        if arrays_fn is not None:
            out = arrays_fn(v, setup.load, tau[sl])
            wear[sl], temp[sl] = out["wear"], out["temperature"]
        else:
            for i in range(sl.start, sl.stop):
                r = estimator.estimate(ObservationTable.from_arrays(speed=v, tau_f=tau[i], load_torque=setup.load))
                wear[i], temp[i] = r.wear, r.temperature
        if progress is not None:
            progress(sl.stop, n)
    return wear[:, None], temp


def run_study(
    estimator: Any,
    setup: StudySetup,
    *,
    model: Model | None = None,
    params: Parameters | Mapping[str, float] | str | None = None,
    crb: bool = True,
    hcr: bool = False,
    progress: Progress | None = None,
    rng: np.random.Generator | None = None,
) -> StudyResult:
    """Run the Section 5.1 study for one estimator.

    Parameters
    ----------
    estimator
        A per-speed estimator (``estimate_rows`` used when present) or a cycle
        estimator (``capabilities.cycle``, as ``joint``: one estimate per cycle).
    setup
        Speeds, runs, true wear, load, noise and the TRUE temperature distribution.
    model, params
        The model generating the data (default Eq. 9 with ``ref-2011r``).
    crb
        Compute the bound column (under the true temperature distribution).
    hcr
        Also compute the Hammersley-Chapman-Robbins bound per speed
        (:func:`~jointwear_ros.estimation.hcr.hcr_per_speed`), which shows
        where the CRB cannot be reached; per-speed studies only.
    progress
        Called as ``progress(done, total)`` after each speed (or cycle chunk).
    rng
        Generator of the data and of the estimator's samples (default from ``setup.seed``).
    """
    setup = setup.checked()
    m, p = resolve_model(model, params)
    gen = make_rng(rng, setup.seed)
    t0 = time.perf_counter()
    tau, temps = simulate_cycles(m, p, setup, gen)
    cycle = capabilities_of(estimator).cycle
    extra: dict[str, Any] = {}
    if cycle:
        est, t_hat = _per_cycle(estimator, setup, tau, progress)
        err_t = t_hat - temps
        extra["temperature_bias"] = float(np.mean(err_t))
        extra["temperature_std"] = float(np.std(err_t, ddof=1))
    else:
        est = _per_speed(estimator, setup, tau, gen, progress)
    seconds = time.perf_counter() - t0
    err = est - setup.true_wear
    bias = err.mean(axis=0)
    var = est.var(axis=0, ddof=1)
    mse = np.mean(err * err, axis=0)
    qs = {q: np.quantile(est, q, axis=0) for q in QUANTILE_LEVELS}
    lo, hi = WEAR_RANGE
    edges = np.linspace(lo, hi, HIST_BINS + 1)
    counts = np.stack([np.histogram(np.clip(est[:, k], lo, hi), bins=edges)[0] for k in range(est.shape[1])])
    prior = setup.temperature_prior
    if crb:
        from .crb import crb_multi_speed, crb_per_speed

        if cycle:
            bound = np.array([crb_multi_speed(m, p, setup.speeds, setup.true_wear, load=setup.load,
                                              noise_std=setup.noise_std, prior=prior)])
            single = crb_per_speed(m, p, setup.speeds, setup.true_wear, load=setup.load,
                                   noise_std=setup.noise_std, prior=prior)
            extra["best_single_speed_crb"] = float(np.min(single))
            extra["best_single_speed"] = float(setup.speeds[int(np.argmin(single))])
        else:
            bound = crb_per_speed(m, p, setup.speeds, setup.true_wear, load=setup.load,
                                  noise_std=setup.noise_std, prior=prior)
    else:
        bound = np.full(est.shape[1], math.nan)
    hcr_arr = twin = None
    if hcr:
        if cycle:
            raise InputDataError("the HCR bound is per speed; it is not computed for a joint (cycle) study")
        from .hcr import hcr_per_speed

        # the CRB column is the HCR's d -> 0 limit with the same inputs: hand it over, not computed twice
        h = hcr_per_speed(m, p, setup.speeds, setup.true_wear, load=setup.load, noise_std=setup.noise_std,
                          prior=prior, crb=bound if crb else None)
        hcr_arr, twin = h.bound, h.twin_wear
    return StudyResult(
        method=str(getattr(estimator, "name", type(estimator).__name__)),
        mode="cycle" if cycle else "per-speed",
        runs=setup.runs,
        seconds=seconds,
        speeds=list(setup.speeds),
        true_wear=setup.true_wear,
        true_temperature=prior.label,
        assumed_temperature=_assumed_label(estimator),
        bias=bias, variance=var, mse=mse, crb=np.asarray(bound, dtype=float),
        quantiles=qs, hist_edges=edges, hist_counts=counts, extra=extra, hcr=hcr_arr, twin_wear=twin,
    )


# -- robustness: T outside the assumed range -------------------------------------------
@dataclass(frozen=True)
class RobustnessRow:
    """One (scenario, method, speed) cell of the robustness study."""

    scenario: str
    true_temperature: str
    method: str
    assumed_temperature: str
    speed: str  # a speed, or "cycle"
    bias: float
    std: float
    rmse: float
    bias_se: float
    unbiased: bool

    def to_dict(self) -> dict[str, Any]:
        return dict(self.__dict__)


def robustness_study(
    estimators: Mapping[str, Any],
    scenarios: Mapping[str, TemperaturePrior | str],
    setup: StudySetup,
    *,
    model: Model | None = None,
    params: Parameters | Mapping[str, float] | str | None = None,
    tolerance: float = 1.0,
    progress: Progress | None = None,
) -> list[RobustnessRow]:
    """Bias of each estimator when the true T distribution differs from the assumed one.

    Every scenario replaces ``setup.true_temperature``; all estimators see the
    same simulated data within a scenario. An estimator "stays unbiased" in a
    cell when ``|bias| <= tolerance`` (wear units; default 1.0, about 3 % of
    the alarm level). ``bias_se`` is the Monte Carlo standard error of the
    bias (``std / sqrt(runs)``), so a reader can judge the tolerance.
    """
    m, p = resolve_model(model, params)
    out: list[RobustnessRow] = []
    total = len(scenarios) * len(estimators)
    done = 0
    for si, (label, spec) in enumerate(scenarios.items()):
        prior = parse_temperature_prior(spec)
        base = StudySetup(setup.speeds, setup.runs, setup.true_wear, setup.load, setup.noise_std, prior,
                          None if setup.seed is None else setup.seed + si).checked()
        for name, est in estimators.items():
            # the same data for every estimator of a scenario: the same seed
            res = run_study(est, base, model=m, params=p, crb=False)
            sd = np.sqrt(res.variance)
            for i, row in enumerate(res.rows):
                b = float(res.bias[i])
                out.append(RobustnessRow(
                    scenario=label, true_temperature=prior.label, method=name,
                    assumed_temperature=res.assumed_temperature,
                    speed="cycle" if res.mode == "cycle" else row,
                    bias=b, std=float(sd[i]), rmse=float(math.sqrt(res.mse[i])),
                    bias_se=float(sd[i] / math.sqrt(base.runs)), unbiased=abs(b) <= tolerance,
                ))
            done += 1
            if progress is not None:
                progress(done, total)
    return out
