"""The Cramér-Rao bound on the wear estimate, Eq. (13)-(14), with T unknown.

One observation at speed ``v`` is ``y = f(v, tau_m, T, w) + e`` with
``e ~ N(0, sigma^2)`` and the temperature ``T`` drawn from a prior ``p(T)``
(the paper's Eq. 12). T is a nuisance: the likelihood of w is the marginal

    p(y | w) = integral phi_sigma(y - f(v, tau_m, T, w)) p(T) dT          (13)

and the bound on the variance of any unbiased estimate of w is ``1 / M`` with
the Fisher information of that marginal

    M(w) = E_y[(d/dw log p(y | w))^2],  y ~ p(. | w)                      (14)

The paper evaluates (13)-(14) by Monte Carlo integration and a central
difference in w (h = 0.1). Here the score is exact given the T integral,

    d/dw log p(y | w) = E[(y - f(T)) f_w(T) | y, w] / sigma^2,

(the posterior mean over T of the known-T score; ``f_w`` is the model's
analytic wear derivative), the T integral inside uses the prior's quadrature
(:meth:`TemperaturePrior.quadrature`, Gauss-Legendre in probability space; the
node count adapts to how far the friction moves over the prior's range in
units of sigma, so the Gaussian bumps of width sigma / |df/dT| are resolved),
and the outer expectation over (T, e) is

- ``method="quadrature"`` (default): for one speed, the prior's quadrature
  over T times Gauss-Hermite over e, deterministic; halving the node counts
  moves the result by < 0.1 % on ``ref-2011r`` (see ``docs/estimation-joint.md``).
  For several speeds sharing one T (:func:`crb_multi_speed`) the expectation
  is over K + 1 dimensions (T and K noises); it uses randomized quasi-Monte
  Carlo (scrambled Sobol points, fixed seed, so the result is deterministic)
  with its standard error estimated from independent scrambles; with the
  default 2^14 points it is about 0.2-0.5 % of the information.
- ``method="monte-carlo"``: plain Monte Carlo over (T, e) (as the paper),
  ``n_samples`` draws; the relative standard error of the information is
  ``std(score^2) / (sqrt(n) * mean(score^2))``, reported by :func:`fisher_information`
  (about 1-3 % at the default 20,000 draws for one speed).

A single speed with the paper's data distribution is the quantity the paper
plots in Fig. 11 (Section 5.1 uses T ~ N(40, 3^2); pass ``normal_prior(40, 3)``).

>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> from jointwear_ros.estimation.priors import normal_prior
>>> m, p = paper_wear_model(), load_parameter_set("ref-2011r")
>>> b = crb_per_speed(m, p, [40.0], 35.0, prior=normal_prior(40, 3))
>>> bool(1.0 < b[0] < 4.0)
True
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from ..model import Model, Parameters
from ._common import DEFAULT_NOISE_STD, check_noise_std, resolve_model
from .priors import TemperaturePrior, parse_temperature_prior

__all__ = [
    "CRB_METHODS",
    "DEFAULT_CRB_PRIOR",
    "FisherResult",
    "check_crb_inputs",
    "crb_known_temperature",
    "crb_multi_speed",
    "crb_per_speed",
    "fisher_information",
    "friction_and_wear_slope",
    "log_quadrature_weights",
    "temperature_nodes",
]

Array = npt.NDArray[np.float64]

#: Methods accepted by the bound functions.
CRB_METHODS = ("quadrature", "monte-carlo")
#: The default temperature prior of the bound (the joint estimator's default): U(25, 55) degC, as its spec
#: (parsed on use: a frozen scipy.stats law built at import would load scipy.stats with this module).
DEFAULT_CRB_PRIOR = "uniform:25:55"

_MAX_NODES = 1536
_MIN_NODES = 48
_CHUNK = 1 << 21


@dataclass(frozen=True)
class FisherResult:
    """Fisher information of the marginal likelihood of w and the bound it gives.

    ``information`` has one value per speed (per-speed bound) or a single value
    (one observation at each speed, shared T). ``stderr`` is the standard error
    of ``information`` for the (quasi-)Monte Carlo parts, 0 where the result is
    deterministic quadrature.
    """

    speeds: tuple[float, ...]
    information: Array
    stderr: Array
    method: str
    n_temperature: tuple[int, ...]

    @property
    def bound(self) -> Array:
        """CRB on var(w_hat): 1 / information."""
        with np.errstate(divide="ignore"):
            return np.asarray(1.0 / self.information, dtype=float)

    @property
    def bound_std(self) -> Array:
        """sqrt of the bound: the smallest achievable std of w_hat."""
        return np.sqrt(self.bound)

    @property
    def rel_error(self) -> Array:
        """Relative standard error of the information (= of the bound, to first order)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.stderr / self.information, dtype=float)


# -- input checks ----------------------------------------------------------------
def check_crb_inputs(
    speeds: npt.ArrayLike, wear: float, load: float, noise_std: float, prior: TemperaturePrior | str, method: str
) -> tuple[Array, float, float, float, TemperaturePrior, str]:
    """Validated ``(speeds, wear, load, noise_std, prior, method)`` of a bound computation, or InputDataError."""
    v = np.atleast_1d(np.asarray(speeds, dtype=float)).ravel()
    if v.size == 0:
        raise InputDataError("speeds: empty; the bound needs at least one speed (rad/s, motor side)")
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        bad = v[~(np.isfinite(v) & (v >= 0))][0]
        raise InputDataError(f"speed {bad!r} must be a finite non-negative motor-side speed in rad/s")
    w = float(wear)
    if not math.isfinite(w):
        raise InputDataError(f"wear = {wear!r} must be finite (0-100)")
    tm = float(load)
    if not math.isfinite(tm):
        raise InputDataError(f"load = {load!r} must be a finite load torque (normalized)")
    sig = check_noise_std(noise_std)
    pr = parse_temperature_prior(prior)
    key = str(method).strip().lower().replace("_", "-")
    if key in ("mc", "montecarlo"):
        key = "monte-carlo"
    if key not in CRB_METHODS:
        raise InputDataError(f"bound method {method!r}: choose one of {', '.join(CRB_METHODS)}")
    return v, w, abs(tm), sig, pr, key


def friction_and_wear_slope(model: Model, params: Parameters, speed: Array, load: float, temps: Array, wear: float
            ) -> tuple[Array, Array]:
    """f and df/dw on the (speed, T) grid: arrays of shape (K, n)."""
    v = speed[:, None]
    t = temps[None, :]
    f = np.asarray(model.evaluate(params, speed=v, load_torque=load, temperature=t, wear=wear), dtype=float)
    a = np.asarray(model.input_gradient("wear", params, speed=v, load_torque=load, temperature=t, wear=wear),
                   dtype=float)
    shape = (speed.size, temps.size)
    return np.broadcast_to(f, shape).copy(), np.broadcast_to(a, shape).copy()


def temperature_nodes(model: Model, params: Parameters, speeds: npt.ArrayLike, wear: float, *,
                      load: float = 0.1, noise_std: float = DEFAULT_NOISE_STD,
                      prior: TemperaturePrior | str = DEFAULT_CRB_PRIOR, density: float = 4.0) -> int:
    """Quadrature nodes over T that resolve the likelihood at these speeds.

    The marginal (13) is a sum of Gaussian bumps of width sigma; over the
    prior's range the friction moves by ``spread``; the rule takes ``density``
    nodes per sigma of that spread (48 at least, 1536 at most), the spread
    being the root-sum-square over the speeds sharing T (the joint
    likelihood's bump in T is narrower). About one node per sigma already
    gives ~1e-4 relative accuracy for a uniform prior; 4 (the default) leaves
    margin for priors whose nodes spread into long tails.
    """
    v = np.atleast_1d(np.asarray(speeds, dtype=float)).ravel()
    pr = parse_temperature_prior(prior)
    lo, hi = pr.support(1.0 - 1e-6)
    t = np.linspace(lo, hi, 129)
    f, _ = friction_and_wear_slope(model, params, v, abs(float(load)), t, float(wear))
    spread = float(np.sqrt(np.sum((f.max(axis=1) - f.min(axis=1)) ** 2)))
    if not math.isfinite(spread) or spread / float(noise_std) + _MIN_NODES > _MAX_NODES:
        # beyond one node per sigma the likelihood is not resolved: the bound would come out
        # wrong (far too small, "bound std 0.000"), so refuse rather than report it
        raise InputDataError(
            f"over the temperature distribution {pr.label} the friction at these speeds moves by "
            f"{spread / float(noise_std):.3g} noise std (sigma_e = {float(noise_std):g}); the bound's quadrature "
            f"resolves at most {_MAX_NODES - _MIN_NODES}: narrow the temperature range to where the parameter set "
            "is valid, or raise sigma_e"
        )
    n = math.ceil(float(density) * spread / float(noise_std)) + _MIN_NODES
    n = 16 * math.ceil(n / 16)  # a multiple of 16: the prior's cached Gauss-Legendre rules get reused
    return int(min(max(n, _MIN_NODES), _MAX_NODES))


# -- the score -------------------------------------------------------------------
def _scores(y: Array, f: Array, a: Array, logpi: Array, sig: float) -> Array:
    """d/dw log p(y | w) for observation vectors ``y`` (Q, K); f, a: (K, n) on nodes with log weights logpi (n,)."""
    q, k = y.shape
    n = f.shape[1]
    out = np.empty(q)
    step = max(1, _CHUNK // max(1, n * k))
    inv2 = 0.5 / (sig * sig)
    for s in range(0, q, step):
        r = y[s:s + step, :, None] - f[None, :, :]  # (q, K, n)
        if k == 1:
            ll = logpi[None, :] - inv2 * r[:, 0, :] ** 2
            num = r[:, 0, :] * a[0][None, :]
        else:
            ll = logpi[None, :] - inv2 * np.einsum("qkn,qkn->qn", r, r)
            num = np.einsum("qkn,kn->qn", r, a)
        ll -= ll.max(axis=1, keepdims=True)
        np.exp(ll, out=ll)
        out[s:s + step] = np.einsum("qn,qn->q", ll, num) / (ll.sum(axis=1) * sig * sig)
    return out


@lru_cache(maxsize=8)
def _gauss_hermite(n: int) -> tuple[Array, Array]:
    """Nodes and weights (summing to 1) of E[h(x)], x ~ N(0, 1)."""
    x, g = np.polynomial.hermite_e.hermegauss(n)
    return x, g / g.sum()


def log_quadrature_weights(wts: Array) -> Array:
    """log of quadrature weights, -inf where a weight is zero (no warning)."""
    with np.errstate(divide="ignore"):
        return np.log(np.maximum(wts, 0.0))


# -- per speed ---------------------------------------------------------------------
def _per_speed_quadrature(f: Array, a: Array, wts: Array, sig: float, n_noise: int) -> float:
    """E over T (prior nodes) and e (Gauss-Hermite) of the squared score; f, a, wts: (n,)."""
    x, g = _gauss_hermite(int(n_noise))
    e = sig * x
    y = (f[:, None] + e[None, :]).reshape(-1, 1)
    s = _scores(y, f[None, :], a[None, :], log_quadrature_weights(wts), sig).reshape(f.size, e.size)
    return float(np.sum(wts[:, None] * g[None, :] * s * s))


def fisher_information(
    model: Model | None,
    params: Parameters | Mapping[str, float] | str | None,
    speeds: npt.ArrayLike,
    wear: float,
    *,
    load: float = 0.1,
    noise_std: float = DEFAULT_NOISE_STD,
    prior: TemperaturePrior | str = DEFAULT_CRB_PRIOR,
    method: str = "quadrature",
    shared_temperature: bool = False,
    n_temperature: int | None = None,
    n_noise: int | None = None,
    n_samples: int | None = None,
    seed: int = 0,
) -> FisherResult:
    """Fisher information of the T-marginal likelihood of w, per speed or for speeds sharing T.

    Parameters
    ----------
    model, params
        Friction model (default Eq. 9) and parameters (default ``ref-2011r``).
    speeds
        Motor-side speeds, rad/s.
    wear
        The true wear w at which the information is evaluated.
    load
        tau_m of the observations (normalized).
    noise_std
        sigma_e of one observation (normalized torque).
    prior
        The temperature distribution (any :class:`TemperaturePrior`, or a spec
        such as ``"normal:40:3"``).
    method
        ``"quadrature"`` or ``"monte-carlo"`` (see the module docstring).
    shared_temperature
        False: one value per speed, each a single observation. True: one value
        for one observation at every speed, all at the same unknown T.
    n_temperature
        Quadrature nodes of the inner T integral (default: :func:`temperature_nodes`).
    n_noise
        Gauss-Hermite nodes over e (single speed, default 32), or the number of
        quasi-Monte Carlo points (several speeds sharing T, default 2^14).
    n_samples
        Monte Carlo draws of (T, e) for ``method="monte-carlo"`` (default 20,000).
    seed
        Seed of the (quasi-)random points; the result is a pure function of the inputs.
    """
    m, p = resolve_model(model, params)
    v, w, tm, sig, pr, key = check_crb_inputs(speeds, wear, load, noise_std, prior, method)
    for name, val in (("n_temperature", n_temperature), ("n_noise", n_noise), ("n_samples", n_samples)):
        if val is not None and int(val) < 2:
            raise InputDataError(f"{name} = {val!r} must be at least 2")
    rng = np.random.default_rng(seed)
    groups = [v] if shared_temperature else [v[i:i + 1] for i in range(v.size)]
    info = np.empty(len(groups))
    err = np.zeros(len(groups))
    nodes: list[int] = []
    for gi, vs in enumerate(groups):
        n = int(n_temperature) if n_temperature is not None else temperature_nodes(
            m, p, vs, w, load=tm, noise_std=sig, prior=pr)
        nodes.append(n)
        tq, wq = pr.quadrature(n)
        f, a = friction_and_wear_slope(m, p, vs, tm, tq, w)
        logpi = log_quadrature_weights(wq)
        if key == "monte-carlo":
            ns = int(n_samples) if n_samples is not None else 20_000
            t_out = pr.sample(rng, ns)
            f_out, _ = friction_and_wear_slope(m, p, vs, tm, t_out, w)
            y = f_out.T + sig * rng.standard_normal((ns, vs.size))
            s2 = _scores(y, f, a, logpi, sig) ** 2
            info[gi] = float(s2.mean())
            err[gi] = float(s2.std(ddof=1) / math.sqrt(ns))
        elif vs.size == 1:
            info[gi] = _per_speed_quadrature(f[0], a[0], wq, sig, int(n_noise) if n_noise is not None else 32)
        else:
            info[gi], err[gi] = _shared_qmc(m, p, vs, tm, w, sig, pr, f, a, logpi,
                                            int(n_noise) if n_noise is not None else 1 << 14, seed)
    return FisherResult(speeds=tuple(float(x) for x in v), information=info, stderr=err, method=key,
                        n_temperature=tuple(nodes))


def _shared_qmc(m: Model, p: Parameters, vs: Array, tm: float, w: float, sig: float, pr: TemperaturePrior,
                f: Array, a: Array, logpi: Array, n_points: int, seed: int, n_scrambles: int = 8
                ) -> tuple[float, float]:
    """E[score^2] over (T, e_1..e_K) by scrambled Sobol points; stderr from independent scrambles."""
    from scipy.stats import norm, qmc  # on use: scipy.stats is most of a node's start-up

    k = vs.size
    per = max(16, int(2 ** math.ceil(math.log2(max(16, n_points // n_scrambles)))))
    means = np.empty(n_scrambles)
    for r in range(n_scrambles):
        u = qmc.Sobol(d=k + 1, scramble=True, seed=np.random.default_rng([seed, r])).random(per)
        u = np.clip(u, 1e-12, 1.0 - 1e-12)
        t_out = np.asarray(pr.dist.ppf(u[:, 0]), dtype=float)
        f_out, _ = friction_and_wear_slope(m, p, vs, tm, t_out, w)
        y = f_out.T + sig * norm.ppf(u[:, 1:])
        means[r] = float(np.mean(_scores(y, f, a, logpi, sig) ** 2))
    return float(means.mean()), float(means.std(ddof=1) / math.sqrt(n_scrambles))


# -- the public bound functions -------------------------------------------------------
def crb_per_speed(
    model: Model | None,
    params: Parameters | Mapping[str, float] | str | None,
    speeds: npt.ArrayLike,
    wear: float,
    *,
    load: float = 0.1,
    noise_std: float = DEFAULT_NOISE_STD,
    prior: TemperaturePrior | str = DEFAULT_CRB_PRIOR,
    method: str = "quadrature",
    n_temperature: int | None = None,
    n_noise: int | None = None,
    n_samples: int | None = None,
    seed: int = 0,
) -> Array:
    """The paper's bound, Eq. (13)-(14): CRB on var(w_hat) from ONE observation at each speed, T ~ prior.

    Returns an array with one bound per speed (variance units, wear^2). See
    :func:`fisher_information` for the arguments and the accuracy of each
    method (quadrature: deterministic, < 0.1 % node-count sensitivity;
    monte-carlo: 1-3 % relative standard error at 20,000 draws).
    """
    res = fisher_information(model, params, speeds, wear, load=load, noise_std=noise_std, prior=prior,
                             method=method, shared_temperature=False, n_temperature=n_temperature,
                             n_noise=n_noise, n_samples=n_samples, seed=seed)
    return res.bound


def crb_multi_speed(
    model: Model | None,
    params: Parameters | Mapping[str, float] | str | None,
    speeds: npt.ArrayLike,
    wear: float,
    *,
    load: float = 0.1,
    noise_std: float = DEFAULT_NOISE_STD,
    prior: TemperaturePrior | str = DEFAULT_CRB_PRIOR,
    method: str = "quadrature",
    n_temperature: int | None = None,
    n_noise: int | None = None,
    n_samples: int | None = None,
    seed: int = 0,
) -> float:
    """CRB on var(w_hat) from one observation at each of ``speeds``, all at ONE unknown T ~ prior.

    The likelihood is the marginal over the shared T of the joint likelihood,
    ``p(y | w) = int prod_k phi(y_k - f(v_k, T, w)) p(T) dT``; a speed may
    repeat (two observations at that speed). With one speed this is
    :func:`crb_per_speed`. The expectation over (T, e) for several speeds is
    randomized quasi-Monte Carlo (relative standard error about 0.2-0.5 % at
    the default 2^14 points) or Monte Carlo (``method="monte-carlo"``).
    """
    res = fisher_information(model, params, speeds, wear, load=load, noise_std=noise_std, prior=prior,
                             method=method, shared_temperature=True, n_temperature=n_temperature,
                             n_noise=n_noise, n_samples=n_samples, seed=seed)
    return float(res.bound[0])


def crb_known_temperature(
    model: Model | None,
    params: Parameters | Mapping[str, float] | str | None,
    speeds: npt.ArrayLike,
    wear: float,
    *,
    load: float = 0.1,
    noise_std: float = DEFAULT_NOISE_STD,
    temperature: float = 40.0,
    shared: bool = False,
) -> Array | float:
    """The reference bound with T known: ``sigma^2 / (df/dw)^2`` per speed (plain Gaussian Fisher information).

    With ``shared=True`` the bound for one observation at every speed,
    ``sigma^2 / sum_k (df/dw)_k^2`` (a float).
    """
    m, p = resolve_model(model, params)
    v, w, tm, sig, _, _ = check_crb_inputs(speeds, wear, load, noise_std, DEFAULT_CRB_PRIOR, "quadrature")
    if not math.isfinite(float(temperature)):
        raise InputDataError(f"temperature = {temperature!r} must be finite (degC)")
    _, a = friction_and_wear_slope(m, p, v, tm, np.array([float(temperature)]), w)
    info = a[:, 0] ** 2 / sig**2
    with np.errstate(divide="ignore"):
        if shared:
            return float(1.0 / info.sum())
        return np.asarray(1.0 / info, dtype=float)

