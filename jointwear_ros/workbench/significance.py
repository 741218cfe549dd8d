"""The significance tests the workbench shares: nested least squares, permutations, Holm.

Each is written once and named; the model-free ranking (:mod:`.dependence`) and the
candidate ranking (:mod:`.diagnose`) call them.

* :func:`nested_test` — does a larger least-squares design explain significantly more than
  the design it contains? With a noise floor ``sigma`` (a measured standard deviation):
  the chi-square (likelihood-ratio) test, ``gain / max(sigma^2, s^2)`` on ``k`` degrees of
  freedom, where ``s^2`` is the larger design's residual variance (so a noise floor that is
  too optimistic cannot invent effects). Without one: the F test,
  ``(gain / k) / s^2`` on ``(k, dof)``. Assumptions: independent Gaussian errors of equal
  variance (the chi-square form: of the given standard deviation or larger); the designs
  nested, fitted by least squares.
* :func:`permutation_p` — the p-value of a statistic against its permutation distribution,
  ``(1 + #{null >= obs}) / (R + 1)``; beyond the permutations' range a Gumbel tail fitted to
  them (the statistics are maxima). Assumption: exchangeable rows (or groups) under the null.
* :func:`guarded` — the parametric p-value, unless the permutation test disagrees beyond
  :data:`PERM_GUARD` (residuals correlated within cycles make the F test optimistic).
* :func:`holm` — Holm's step-down adjustment (family-wise error for any dependence).

>>> t = nested_test(gain=0.09, sse=0.30, k=3, dof=100)
>>> t.method, round(t.statistic, 2), round(t.p_value, 4)
('F', 10.0, 0.0)
>>> t = nested_test(gain=9e-4, sse=0.0225, k=3, dof=100, noise=0.015)
>>> t.method, round(t.statistic, 2), round(t.p_value, 4)
('chi-square', 4.0, 0.2615)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy import stats

__all__ = ["PERM_GUARD", "NestedTest", "guarded", "holm", "nested_test", "permutation_p"]

Array = npt.NDArray[np.float64]

#: The parametric test counts only when the permutation test agrees at least this far.
PERM_GUARD = 0.05


class NestedTest(NamedTuple):
    """Outcome of :func:`nested_test`: the statistic, its p-value, and which test (``chi-square`` or ``F``)."""

    statistic: float
    p_value: float
    method: str


def nested_test(gain: float, sse: float, k: int, dof: int, noise: float | None = None) -> NestedTest:
    """Chi-square (given a noise floor) or F test of a gain in fit of ``k`` added directions.

    ``gain`` is the fall of the residual sum of squares from the smaller design to the larger,
    ``sse`` the larger design's residual sum of squares on ``dof`` residual degrees of freedom,
    ``noise`` the noise floor's standard deviation when known (finite and positive).
    """
    k, dof = max(int(k), 1), max(int(dof), 1)
    gain = max(float(gain), 0.0)
    s2 = float(sse) / dof
    if noise is not None and math.isfinite(noise) and noise > 0:
        stat = gain / max(noise**2, s2)
        return NestedTest(stat, float(stats.chi2.sf(stat, k)), "chi-square")
    stat = gain / k / max(s2, 1e-300)
    return NestedTest(stat, float(stats.f.sf(stat, k, dof)), "F")


def permutation_p(obs: float, null: Array) -> float:
    """Permutation p-value of ``obs`` against ``null``; beyond the permutations' range, a Gumbel tail fitted to them."""
    r = null.size
    ge = int(np.sum(null >= obs))
    if ge > 0:
        return (1 + ge) / (r + 1)
    sd = float(np.std(null, ddof=1))
    if not sd > 0:
        return 1.0 / (r + 1)
    scale = sd * math.sqrt(6.0) / math.pi
    loc = float(np.mean(null)) - 0.5772156649 * scale
    return float(min(1.0 / (r + 1), stats.gumbel_r.sf(obs, loc, scale)))


def guarded(p_parametric: float, p_permutation: float) -> float:
    """The parametric p-value, or the larger of the two when the permutation test does not back it
    (:data:`PERM_GUARD`)."""
    return max(p_parametric, p_permutation) if p_permutation > PERM_GUARD else p_parametric


def holm(p: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (family-wise error control for any dependence).

    >>> [round(x, 3) for x in holm([0.01, 0.04, 0.03, 0.5])]
    [0.04, 0.09, 0.09, 0.5]
    """
    m = len(p)
    order = np.argsort(p, kind="stable")
    adj = np.empty(m)
    run = 0.0
    for i, j in enumerate(order):
        run = max(run, min(1.0, (m - i) * float(p[j])))
        adj[j] = run
    return [float(a) for a in adj]
