"""Where the Cramér-Rao bound cannot be reached: the Hammersley-Chapman-Robbins bound.

The CRB (:mod:`.crb`) is a *local* bound: it sees only the slope of the
likelihood at the true wear. At some speeds the wear term of Eq. (9) is not
monotone in w (at 110-150 rad/s on ``ref-2011r`` the friction at w = 0 and at
w = 35 is almost the same, and over the unknown T the two observation
densities overlap), so an observation that is compatible with w = 35 is as
compatible with a far-away wear. No unbiased estimator can then get near the
CRB. The Hammersley-Chapman-Robbins bound (HCR) makes that visible: for any
estimator unbiased at ``w0`` and at ``w0 + d``,

    var(w_hat) >= d^2 / chi2(p(. | w0 + d) || p(. | w0)),
    chi2 = integral p(y | w0 + d)^2 / p(y | w0) dy - 1,

for every test offset ``d`` with ``w0 + d`` in the wear range [0, 100]; the
bound is the supremum over ``d``. As ``d -> 0`` it tends to the CRB, so
``HCR >= CRB``; where the two agree the CRB is the relevant yardstick, where
the HCR is far above it the CRB is unattainable and an estimator's error
there should be compared with the HCR (a constrained or biased estimator,
such as the posterior mode on [0, 100], can sit below the HCR too).

``p(y | w)`` is the paper's marginal (13) over T ~ prior. With the model
additive in wear (Eq. 9, checked), ``tau_f = b(v, tau_m, T) + g_v(w)``, it is
a shift family: ``p(y | w) = h_v(y - g_v(w))`` with ``h_v`` the density of
``b + e`` (a mixture of Gaussians of width sigma on the prior's quadrature
nodes, the same nodes as the CRB). The divergence therefore depends on the
shift ``g_v(w0 + d) - g_v(w0)`` only, and:

- if another wear ``w'`` in the range has exactly ``g_v(w') = g_v(w0)`` (a
  *twin*: the wear term of Eq. 9 is not monotone in w; on ``ref-2011r``
  w = 35 has a twin above ~150 rad/s), the two wears give the same
  observation distribution and the bound is infinite: one observation at
  that speed cannot tell them apart, whatever the estimator (reported in
  ``twin_wear``); a near-twin (at 110-150 rad/s w = 0 gives almost the
  friction of w = 35) makes the bound finite but far above the CRB;
- else the bound is the largest ``d^2 / chi2`` over the test offsets: a
  geometric set from 1e-3 of the way to each end of the wear range to the end
  itself (``n_test`` in all), every near-twin (a local minimum of
  ``|g_v(w) - g_v(w0)|`` on a dense w grid), and the CRB as the ``d -> 0``
  limit.

The chi-square integral is evaluated on a uniform y grid with step sigma / 3
spanning both densities and the peak of ``p1^2 / p0`` (which lies beyond
``p1``, at ``2 f1 - f0``), in the log domain; the trapezoid rule on Gaussian
integrands at that step is exact to far below the float64 resolution.

Pure numpy; no ROS import.

>>> from jointwear_ros.model import paper_wear_model, load_parameter_set
>>> from jointwear_ros.estimation.priors import normal_prior
>>> m, p = paper_wear_model(), load_parameter_set("ref-2011r")
>>> r = hcr_per_speed(m, p, [40.0, 110.0, 130.0, 200.0], 35.0, prior=normal_prior(40, 3))
>>> [round(float(x), 2) for x in r.ratio]    # HCR / CRB
[1.0, 1.04, 30.82, inf]
>>> [round(float(x), 1) for x in r.test_point]   # the confusable offset: w = 0 at 110 and 130 rad/s
[0.0, -35.0, -35.0, -7.2]
>>> round(float(r.twin_wear[3]), 1)          # at 200 rad/s w = 27.8 gives exactly the friction of w = 35
27.8
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from ..model import Model, Parameters
from ._common import DEFAULT_NOISE_STD, WEAR_RANGE, log_sum_exp, resolve_model
from .crb import DEFAULT_CRB_PRIOR, check_crb_inputs, crb_per_speed, temperature_nodes
from .inverse import WearInverse
from .priors import TemperaturePrior

__all__ = ["HCRResult", "hcr_per_speed"]

Array = npt.NDArray[np.float64]

_GRID_STEP = 1.0 / 3.0  # y grid step, in units of sigma
_MARGIN = 10.0  # sigma beyond the outermost Gaussian bump


@dataclass(frozen=True)
class HCRResult:
    """The HCR bound per speed, the test offset attaining it, and the CRB for reference.

    ``bound[k]`` is in wear^2 (like the CRB); ``test_point[k]`` is the offset
    ``d`` of the maximising test wear ``w0 + d`` (0 where the supremum is the
    ``d -> 0`` limit, i.e. the CRB itself).
    """

    speeds: tuple[float, ...]
    wear: float
    bound: Array
    test_point: Array
    crb: Array
    twin_wear: Array  # the wear with the same friction as ``wear`` (NaN where there is none)

    @property
    def ratio(self) -> Array:
        """HCR / CRB: 1 where the CRB is the relevant bound, >> 1 where it cannot be reached."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.asarray(self.bound / self.crb, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        return {"speeds": list(self.speeds), "wear": self.wear, "hcr": self.bound.tolist(),
                "test_point": self.test_point.tolist(), "crb": self.crb.tolist(),
                "twin_wear": self.twin_wear.tolist()}


def _log_mixture(y: Array, f: Array, logw: Array, sig: float) -> Array:
    """log sum_j w_j N(y; f_j, sig^2) for every y (chunked over y).

    The terms are always finite here (the log weights of the kept nodes): the
    sum is :func:`~jointwear_ros.estimation._common.log_sum_exp`, in place.
    """
    out = np.empty(y.size)
    step = max(1, (1 << 20) // max(1, f.size))
    c = -math.log(sig * math.sqrt(2.0 * math.pi))
    for s in range(0, y.size, step):
        r = (y[s:s + step, None] - f[None, :]) / sig
        out[s:s + step] = log_sum_exp(logw[None, :] - 0.5 * r * r, axis=1, overwrite=True) + c
    return out


def _chi2(b: Array, logw: Array, shift: float, sig: float) -> float:
    """chi2(h(. - shift) || h) for the mixture h of N(b_j, sig^2) with log weights logw."""
    f1 = b + shift
    lo = min(b.min(), f1.min(), 2.0 * f1.min() - b.max()) - _MARGIN * sig
    hi = max(b.max(), f1.max(), 2.0 * f1.max() - b.min()) + _MARGIN * sig
    n = math.ceil((hi - lo) / (_GRID_STEP * sig)) + 1
    y = np.linspace(lo, hi, n)
    dy = float(y[1] - y[0])
    li = 2.0 * _log_mixture(y, f1, logw, sig) - _log_mixture(y, b, logw, sig)
    li[0] -= math.log(2.0)  # trapezoid end weights
    li[-1] -= math.log(2.0)
    top = float(li.max())
    log_int = math.log(float(np.exp(li - top).sum())) + top + math.log(dy)
    return math.expm1(log_int) if log_int < 700.0 else math.inf


def _twins_and_near_twins(w: Array, delta: Array, w0: float, exclude: float) -> tuple[float, list[float]]:
    """The twin wear nearest to w0 (NaN if none) and the near-twins (local minima of |delta|) away from w0."""
    away = np.abs(w - w0) > exclude
    twin = math.nan
    sgn = np.sign(delta)
    for i in np.flatnonzero((sgn[:-1] * sgn[1:] <= 0) & away[:-1] & away[1:]):
        a, c = delta[i], delta[i + 1]
        root = float(w[i]) if a == c else float(w[i] + (w[i + 1] - w[i]) * a / (a - c))
        if math.isnan(twin) or abs(root - w0) < abs(twin - w0):
            twin = root
    ad = np.abs(delta)
    near = [float(w[i]) for i in range(1, w.size - 1)
            if away[i] and ad[i] <= ad[i - 1] and ad[i] <= ad[i + 1]]
    for end in (0, w.size - 1):  # the ends of the range are candidates too
        if away[end]:
            near.append(float(w[end]))
    return twin, near


def _check_additive(model: Model, params: Parameters, v: Array, wear_range: tuple[float, float]) -> None:
    """Raise :class:`~jointwear_ros.errors.ModelError` unless the model is additive in wear at every speed.

    The test of :class:`~jointwear_ros.estimation.inverse.WearInverse` (the wear effect the same at two
    (load, T) points), made for all speeds in two model calls; building a small ``WearInverse`` per speed
    only for its check cost more than the rest of the bound. A speed that fails is handed to ``WearInverse``,
    which raises its own error.
    """
    w = np.array([0.0, 20.0, 35.0, 70.0])
    d1 = np.asarray(model.evaluate(params, speed=v[:, None], load_torque=0.0, temperature=30.0, wear=w[None, :]),
                    dtype=float)
    d2 = np.asarray(model.evaluate(params, speed=v[:, None], load_torque=0.5, temperature=50.0, wear=w[None, :]),
                    dtype=float)
    d1, d2 = np.broadcast_to(d1, (v.size, w.size)), np.broadcast_to(d2, (v.size, w.size))
    ok = np.isclose(d1 - d1[:, :1], d2 - d2[:, :1], rtol=1e-9, atol=1e-12).all(axis=1)
    for speed in v[~ok]:
        WearInverse(model, params, float(speed), wear_range=wear_range, n_dense=64, n_table=16)


def hcr_per_speed(
    model: Model | None,
    params: Parameters | Mapping[str, float] | str | None,
    speeds: npt.ArrayLike,
    wear: float,
    *,
    load: float = 0.1,
    noise_std: float = DEFAULT_NOISE_STD,
    prior: TemperaturePrior | str = DEFAULT_CRB_PRIOR,
    wear_range: tuple[float, float] = WEAR_RANGE,
    n_test: int = 48,
    n_dense: int = 4001,
    crb: npt.ArrayLike | None = None,
) -> HCRResult:
    """The HCR bound on var(w_hat) from ONE observation at each speed, T ~ prior (see the module docstring).

    ``crb``: the Cramér-Rao bound per speed when the caller has it already
    (:func:`~jointwear_ros.estimation.crb.crb_per_speed` with the same model,
    speeds, wear, load, noise and prior, as :func:`~jointwear_ros.estimation.study.run_study`
    has); computed here when None.
    """
    m, p = resolve_model(model, params)
    v, w0, tm, sig, pr, _ = check_crb_inputs(speeds, wear, load, noise_std, prior, "quadrature")
    lo, hi = (float(x) for x in wear_range)
    if not lo <= w0 <= hi:
        raise InputDataError(f"wear = {wear!r} must lie in the wear range [{lo:g}, {hi:g}]")
    if int(n_test) < 2:
        raise InputDataError(f"n_test = {n_test!r}: need at least 2 test points")
    if crb is None:
        crb = crb_per_speed(m, p, v, w0, load=tm, noise_std=sig, prior=pr)
    crb = np.array(crb, dtype=float).reshape(-1)
    if crb.size != v.size:
        raise InputDataError(f"crb has {crb.size} values for {v.size} speeds")
    _check_additive(m, p, v, (lo, hi))
    frac = np.geomspace(1e-3, 1.0, max(1, int(n_test) // 2))
    offsets = list(-(w0 - lo) * frac) if w0 > lo else []
    offsets += list((hi - w0) * frac) if w0 < hi else []
    w_dense = np.linspace(lo, hi, int(n_dense))
    exclude = 2.0 * (hi - lo) / (int(n_dense) - 1)
    bound, arg, twins = crb.copy(), np.zeros(v.size), np.full(v.size, math.nan)
    for k, speed in enumerate(v):
        n = temperature_nodes(m, p, [speed], w0, load=tm, noise_std=sig, prior=pr)
        t, wts = pr.quadrature(n)
        keep = wts > 0
        b = np.asarray(m.evaluate(p, speed=speed, load_torque=tm, temperature=t[keep], wear=0.0), dtype=float)
        logw = np.log(wts[keep])
        g_dense = np.asarray(m.evaluate(p, speed=speed, load_torque=0.0, temperature=40.0, wear=w_dense), dtype=float)
        g0 = float(m.evaluate(p, speed=speed, load_torque=0.0, temperature=40.0, wear=w0))
        twin, near = _twins_and_near_twins(w_dense, g_dense - g0, w0, exclude)
        if not math.isnan(twin):
            bound[k], arg[k], twins[k] = math.inf, twin - w0, twin
            continue
        tests = [*offsets, *(x - w0 for x in near)]
        # the wear term at every test wear in one model call (the model is elementwise in wear)
        g1s = np.broadcast_to(np.asarray(m.evaluate(p, speed=speed, load_torque=0.0, temperature=40.0,
                                                    wear=w0 + np.asarray(tests, dtype=float)), dtype=float),
                              (len(tests),))
        for d, g1 in zip(tests, g1s):
            chi2 = _chi2(b, logw, float(g1) - g0, sig)
            if chi2 > 0 and d * d / chi2 > bound[k]:
                bound[k], arg[k] = d * d / chi2, d
    return HCRResult(speeds=tuple(float(x) for x in v), wear=w0, bound=bound, test_point=arg, crb=crb,
                     twin_wear=twins)
