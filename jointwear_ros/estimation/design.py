"""Test-cycle design: the speeds that minimise the bound on w for a given cycle time.

A test cycle measures ``n = floor(budget / seconds_per_speed)`` speeds (the
paper: about 14 s per speed), all at one unknown temperature. The bound on
var(w_hat) of the whole cycle is :func:`~jointwear_ros.estimation.crb.crb_multi_speed`
of the chosen speeds; the design picks the multiset of n speeds (a speed may
repeat) from a candidate list that minimises it:

1. start from the candidate with the smallest single-speed bound (the paper's
   choice of speed region, by the bound instead of by simulation);
2. greedy forward selection: add the candidate that lowers the bound most,
   until n speeds;
3. exchange passes: replace one chosen speed by any candidate while that
   lowers the bound (at most ``max_passes`` passes).

During the search the bound is evaluated with common random numbers (one set
of scrambled Sobol points, fixed seed, 1024 of them, single precision; about one T node per
sigma of spread), so that designs are compared on the same points; the winner
and the paper's best single speed repeated n times are then re-evaluated with
the accurate default settings. The result is never worse than that repeated
single speed (if the search did not beat it, it is returned).

>>> d = design_cycle(budget=42.0, candidates=[0.0, 40.0, 120.0, 220.0])
>>> d.n_speeds, d.bound_std <= d.repeated_best_bound_std
(3, True)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.stats import norm, qmc

from ..errors import InputDataError
from ..model import Model, Parameters
from ._common import DEFAULT_NOISE_STD, resolve_model
from .crb import (
    DEFAULT_CRB_PRIOR,
    crb_known_temperature,
    crb_per_speed,
    fisher_information,
    friction_and_wear_slope,
    log_quadrature_weights,
    temperature_nodes,
)
from .names import PAPER_SECONDS_PER_SPEED
from .priors import TemperaturePrior, parse_temperature_prior

__all__ = ["PAPER_SECONDS_PER_SPEED", "CycleDesign", "design_cycle"]

Array = npt.NDArray[np.float64]
Work = npt.NDArray[Any]  # single-precision search arrays

_SEARCH_POINTS = 1024
#: A swap must lower the search bound by this fraction to count (the search points' noise is ~1 %).
_MIN_GAIN = 3e-3


@dataclass(frozen=True)
class CycleDesign:
    """A chosen set of speeds and the bound it gives, beside the paper's single-speed choice."""

    speeds: tuple[float, ...]
    bound: float
    bound_std: float
    bound_rel_error: float
    n_speeds: int
    seconds: float
    budget: float
    seconds_per_speed: float
    best_single_speed: float
    best_single_bound_std: float
    repeated_best_bound_std: float
    known_temperature_bound_std: float
    per_speed_bound_std: tuple[float, ...]
    candidates: tuple[float, ...]
    settings: Mapping[str, Any] = field(default_factory=dict)

    @property
    def gain(self) -> float:
        """How many times smaller the std bound is than the best single speed repeated n times."""
        return self.repeated_best_bound_std / self.bound_std

    def to_dict(self) -> dict[str, Any]:
        return {
            "speeds": list(self.speeds),
            "bound_std": self.bound_std,
            "bound": self.bound,
            "bound_rel_error": self.bound_rel_error,
            "n_speeds": self.n_speeds,
            "seconds": self.seconds,
            "budget": self.budget,
            "seconds_per_speed": self.seconds_per_speed,
            "per_speed_bound_std": list(self.per_speed_bound_std),
            "best_single_speed": self.best_single_speed,
            "best_single_bound_std": self.best_single_bound_std,
            "repeated_best_bound_std": self.repeated_best_bound_std,
            "gain_over_repeated_best": self.gain,
            "known_temperature_bound_std": self.known_temperature_bound_std,
            **dict(self.settings),
        }


class _SearchBound:
    """The shared-T bound of any multiset of candidates, on one fixed set of points."""

    def __init__(self, model: Model, params: Parameters, candidates: Array, n: int, wear: float, load: float,
                 sigma: float, prior: TemperaturePrior, seed: int) -> None:
        # about one node per sigma of the largest spread n observations of one candidate can have
        spread_nodes = max(temperature_nodes(model, params, np.full(n, c), wear, load=load, noise_std=sigma,
                                             prior=prior, density=1.0) for c in candidates)
        temps, wq = prior.quadrature(spread_nodes)
        f, a = friction_and_wear_slope(model, params, candidates, load, temps, wear)
        self.f, self.a = f.astype(np.float32), a.astype(np.float32)
        self.logpi = log_quadrature_weights(wq).astype(np.float32)
        u = qmc.Sobol(d=n + 1, scramble=True, seed=np.random.default_rng(seed)).random(_SEARCH_POINTS)
        u = np.clip(u, 1e-12, 1.0 - 1e-12)
        t_out = np.asarray(prior.dist.ppf(u[:, 0]), dtype=float)
        f_out, _ = friction_and_wear_slope(model, params, candidates, load, t_out, wear)
        self.f_out = f_out.astype(np.float32)
        self.z = (sigma * norm.ppf(u[:, 1:])).astype(np.float32)
        self.sigma = sigma
        self.n_nodes = spread_nodes

    def partial(self, idx: Sequence[int], skip: int = -1) -> tuple[Work, Work]:
        """Log posterior weights over T nodes and the summed known-T score, (Q, n) each, of the
        design ``idx`` without position ``skip``; position k uses noise column k."""
        q, n = self.z.shape[0], self.logpi.size
        ll = np.broadcast_to(self.logpi, (q, n)).copy()
        num = np.zeros((q, n), dtype=np.float32)
        for k, c in enumerate(idx):
            if k != skip:
                self._add(ll, num, int(c), k)
        return ll, num

    def _add(self, ll: Work, num: Work, c: int, pos: int) -> None:
        r = (self.f_out[c] + self.z[:, pos])[:, None] - self.f[c][None, :]
        ll -= (0.5 / self.sigma**2) * r * r
        num += r * (self.a[c] / self.sigma**2)[None, :]

    def with_each(self, ll: Work, num: Work, pos: int, cands: Sequence[int]) -> Array:
        """The bound for the partial design plus each candidate at position ``pos``."""
        out = np.empty(len(cands))
        for j, c in enumerate(cands):
            l2, n2 = ll.copy(), num.copy()
            self._add(l2, n2, int(c), pos)
            l2 -= l2.max(axis=1, keepdims=True)
            np.exp(l2, out=l2)
            s = np.einsum("qn,qn->q", l2, n2) / l2.sum(axis=1)
            info = float(np.mean(s.astype(float) ** 2))
            out[j] = 1.0 / info if info > 0 else math.inf
        return out

    def __call__(self, idx: Sequence[int]) -> float:
        ll, num = self.partial(idx[:-1])
        return float(self.with_each(ll, num, len(idx) - 1, [idx[-1]])[0])


def design_cycle(
    model: Model | None = None,
    params: Parameters | Mapping[str, float] | str | None = None,
    *,
    budget: float = 90.0,
    seconds_per_speed: float = PAPER_SECONDS_PER_SPEED,
    candidates: Sequence[float] | npt.ArrayLike | None = None,
    wear: float = 35.0,
    load: float = 0.1,
    noise_std: float = DEFAULT_NOISE_STD,
    prior: TemperaturePrior | str = DEFAULT_CRB_PRIOR,
    allow_repeats: bool = True,
    max_passes: int = 4,
    seed: int = 0,
    progress: Callable[[int, int], None] | None = None,
) -> CycleDesign:
    """Choose ``floor(budget / seconds_per_speed)`` speeds minimising the shared-T bound on w.

    Parameters
    ----------
    model, params
        Friction model (default Eq. 9) and parameters (default ``ref-2011r``).
    budget, seconds_per_speed
        Cycle time and time per speed, seconds.
    candidates
        Candidate speeds, rad/s (default 0, 5, ..., 280).
    wear, load, noise_std, prior
        Where the bound is evaluated: true w, tau_m, sigma_e, temperature prior.
    allow_repeats
        Allow a speed to be chosen more than once.
    max_passes
        Exchange passes after the greedy selection.
    seed
        Seed of the quasi-random points (the design is a pure function of the inputs).
    progress
        Called as ``progress(done, total)`` after each evaluation round.
    """
    m, p = resolve_model(model, params)
    for name, val in (("budget", budget), ("seconds_per_speed", seconds_per_speed)):
        if not (isinstance(val, (int, float, np.floating, np.integer)) and math.isfinite(val) and val > 0):
            raise InputDataError(f"{name} = {val!r} must be a positive number of seconds")
    n = math.floor(float(budget) / float(seconds_per_speed) + 1e-9)
    if n < 1:
        raise InputDataError(
            f"budget {budget:g} s is shorter than one speed ({seconds_per_speed:g} s); "
            "raise --budget or lower --seconds-per-speed"
        )
    cand = np.linspace(0.0, 280.0, 57) if candidates is None else np.atleast_1d(np.asarray(candidates, dtype=float))
    if cand.size == 0:
        raise InputDataError("candidate speeds: empty; give at least one speed (rad/s)")
    if not np.all(np.isfinite(cand)) or np.any(cand < 0):
        raise InputDataError(f"candidate speeds must be finite and non-negative (rad/s), got {cand.tolist()!r}")
    cand = np.unique(cand)
    if not allow_repeats and cand.size < n:
        raise InputDataError(
            f"{n} distinct speeds needed but only {cand.size} candidates given; allow repeats or give more candidates"
        )
    pr = parse_temperature_prior(prior)
    single = crb_per_speed(m, p, cand, wear, load=load, noise_std=noise_std, prior=pr)
    best = int(np.argmin(single))
    search = _SearchBound(m, p, cand, n, wear, abs(float(load)), float(noise_std), pr, seed)
    total = (n - 1) * cand.size + max_passes * n * cand.size
    done = 0
    chosen = [best]
    while len(chosen) < n:
        ll, num = search.partial(chosen)
        pool = [c for c in range(cand.size) if allow_repeats or c not in chosen]
        b = search.with_each(ll, num, len(chosen), pool)
        chosen.append(pool[int(np.argmin(b))])
        done += cand.size
        if progress is not None:
            progress(done, total)
    current = search(chosen)
    for _ in range(max_passes):
        improved = False
        for i in range(n):
            ll, num = search.partial(chosen, skip=i)
            pool = [c for c in range(cand.size) if c != chosen[i] and (allow_repeats or c not in chosen)]
            if pool:
                b = search.with_each(ll, num, i, pool)
                j = int(np.argmin(b))
                if b[j] < current * (1.0 - _MIN_GAIN):
                    chosen = [*chosen[:i], pool[j], *chosen[i + 1:]]
                    current, improved = float(b[j]), True
            done += cand.size
            if progress is not None:
                progress(done, total)
        if not improved:
            break
    if progress is not None:
        progress(total, total)
    speeds = np.sort(cand[chosen])
    kw: dict[str, Any] = {"load": load, "noise_std": noise_std, "prior": pr, "seed": seed}
    final = fisher_information(m, p, speeds, wear, shared_temperature=True, **kw)
    repeated = np.full(n, cand[best])
    rep = fisher_information(m, p, repeated, wear, shared_temperature=True, **kw)
    bound, rel = float(final.bound[0]), float(final.rel_error[0])
    if float(rep.bound[0]) <= bound:
        speeds, bound, rel = repeated, float(rep.bound[0]), float(rep.rel_error[0])
    known = float(crb_known_temperature(m, p, speeds, wear, load=load, noise_std=noise_std, shared=True))
    per = crb_per_speed(m, p, speeds, wear, load=load, noise_std=noise_std, prior=pr)
    return CycleDesign(
        speeds=tuple(float(s) for s in speeds),
        bound=bound,
        bound_std=math.sqrt(bound),
        bound_rel_error=rel,
        n_speeds=n,
        seconds=n * float(seconds_per_speed),
        budget=float(budget),
        seconds_per_speed=float(seconds_per_speed),
        best_single_speed=float(cand[best]),
        best_single_bound_std=math.sqrt(float(single[best])),
        repeated_best_bound_std=math.sqrt(float(rep.bound[0])),
        known_temperature_bound_std=math.sqrt(known),
        per_speed_bound_std=tuple(float(x) for x in np.sqrt(per)),
        candidates=tuple(float(c) for c in cand),
        settings={"wear": float(wear), "load": float(load), "noise_std": float(noise_std), "prior": pr.label,
                  "search_points": _SEARCH_POINTS, "search_temperature_nodes": search.n_nodes},
    )
