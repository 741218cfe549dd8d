"""Temperature distributions: the paper's U(T_lo, T_hi), N(mu, sigma), or any scipy.stats law.

The uniform and the normal are :class:`UniformLaw` and :class:`NormalLaw`: the part of a frozen scipy.stats law
the estimators use (mean, std, ppf, cdf, logpdf, pdf), from scipy.special's normal integral and its inverse, which
scipy.stats itself uses. Importing scipy.stats costs about 0.9 s of CPU on a 2-core EPYC, more than the rest of a
wear_estimator's numerics; a node or a command that estimates no longer pays it.

A :class:`TemperaturePrior` draws samples (with a generator passed in) and gives
quadrature nodes for integrals over T: Gauss-Legendre nodes in probability
space mapped through the quantile function, so one rule serves every
continuous distribution.

>>> p = parse_temperature_prior("normal:40:3")
>>> t, wts = p.quadrature(64)
>>> round(float((t * wts).sum()), 6)
40.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.special import ndtr, ndtri, roots_legendre

from ..errors import InputDataError

__all__ = ["ABSOLUTE_ZERO", "MIN_STD", "NormalLaw", "TemperaturePrior", "UniformLaw", "normal_prior",
           "parse_temperature_prior", "uniform_prior"]

Array = npt.NDArray[np.float64]

#: 0 K in degC: no temperature distribution may reach below it.
ABSOLUTE_ZERO = -273.15
#: Smallest std of a normal temperature distribution (``fixed:T`` uses it), degC.
MIN_STD = 1e-6
#: A normal's mass below this many std under the mean may not cross absolute zero.
_NORMAL_REACH = 6.0


@lru_cache(maxsize=64)
def _gauss_legendre_01(n: int) -> tuple[Array, Array]:
    # scipy's rule: same nodes and weights as numpy's leggauss (to 1e-13), but O(n^2) instead of
    # a dense eigenvalue problem, which costs seconds for the few hundred nodes the bounds use
    x, w = roots_legendre(n)
    return 0.5 * (np.asarray(x) + 1.0), 0.5 * np.asarray(w)


#: log(sqrt(2 pi)), as scipy.stats.norm computes it
_NORM_PDF_LOGC = float(np.log(np.sqrt(2 * np.pi)))


@dataclass(frozen=True)
class NormalLaw:
    """N(loc, scale^2): the methods of ``scipy.stats.norm(loc, scale)`` the estimators use, computed as scipy.stats
    computes them (``ndtri``/``ndtr`` of the standardized value), without importing scipy.stats.

    >>> law = NormalLaw(40.0, 3.0)
    >>> float(law.ppf(0.5)), float(law.cdf(43.0)) > 0.84, law.std()
    (40.0, True, 3.0)
    """

    loc: float
    scale: float
    name = "norm"

    def mean(self) -> float:
        return float(self.loc)

    def std(self) -> float:
        return float(self.scale)

    def ppf(self, q: npt.ArrayLike) -> Any:
        return ndtri(np.asarray(q, dtype=float)) * self.scale + self.loc

    def cdf(self, x: npt.ArrayLike) -> Any:
        return ndtr((np.asarray(x, dtype=float) - self.loc) / self.scale)

    def logpdf(self, x: npt.ArrayLike) -> Any:
        z = (np.asarray(x, dtype=float) - self.loc) / self.scale
        return -z**2 / 2.0 - _NORM_PDF_LOGC - np.log(self.scale)

    def pdf(self, x: npt.ArrayLike) -> Any:
        return np.exp(self.logpdf(x))


@dataclass(frozen=True)
class UniformLaw:
    """U(loc, loc + scale): the methods of ``scipy.stats.uniform(loc, scale)`` the estimators use, without importing
    scipy.stats (outside the support: cdf 0 or 1, logpdf -inf; a probability outside [0, 1]: ppf nan).

    >>> law = UniformLaw(30.0, 20.0)
    >>> float(law.ppf(0.25)), float(law.cdf(60.0)), float(law.logpdf(20.0))
    (35.0, 1.0, -inf)
    """

    loc: float
    scale: float
    name = "uniform"

    def mean(self) -> float:
        return float(0.5 * self.scale + self.loc)

    def std(self) -> float:
        return float(np.sqrt(1.0 / 12.0 * self.scale * self.scale))

    def ppf(self, q: npt.ArrayLike) -> Any:
        q = np.asarray(q, dtype=float)
        return np.where((q >= 0.0) & (q <= 1.0), q * self.scale + self.loc, np.nan)[()]

    def cdf(self, x: npt.ArrayLike) -> Any:
        z = (np.asarray(x, dtype=float) - self.loc) / self.scale
        return np.where(np.isnan(z), np.nan, np.clip(z, 0.0, 1.0))[()]

    def logpdf(self, x: npt.ArrayLike) -> Any:
        z = (np.asarray(x, dtype=float) - self.loc) / self.scale
        inside = (z >= 0.0) & (z <= 1.0)
        return np.where(np.isnan(z), np.nan, np.where(inside, -np.log(self.scale), -np.inf))[()]

    def pdf(self, x: npt.ArrayLike) -> Any:
        return np.exp(self.logpdf(x))


@dataclass(frozen=True)
class TemperaturePrior:
    """A distribution of the joint temperature T (degC).

    ``dist`` is a :class:`UniformLaw`, a :class:`NormalLaw` or a frozen scipy.stats continuous distribution
    (anything with ``mean``, ``std``, ``ppf``, ``cdf`` and ``logpdf``); ``label`` is how it is written
    (``uniform:30:50``, ``normal:40:3``).
    """

    dist: Any
    label: str
    kind: str = "custom"
    args: tuple[float, ...] = field(default=())

    @property
    def mean(self) -> float:
        return float(self.dist.mean())

    @property
    def std(self) -> float:
        return float(self.dist.std())

    def support(self, coverage: float = 1.0 - 1e-9) -> tuple[float, float]:
        """The interval holding ``coverage`` of the probability (the whole support if bounded)."""
        a = (1.0 - coverage) / 2.0
        return float(self.dist.ppf(a)), float(self.dist.ppf(1.0 - a))

    def sample(self, rng: np.random.Generator, size: int | tuple[int, ...]) -> Array:
        """Samples through the quantile function of uniforms from ``rng``."""
        if self.kind == "uniform":
            lo, hi = self.args
            return lo + (hi - lo) * rng.random(size)
        if self.kind == "normal":
            mu, sd = self.args
            return mu + sd * rng.standard_normal(size)
        return np.asarray(self.dist.ppf(rng.random(size)), dtype=float)

    def quadrature(self, n: int) -> tuple[Array, Array]:
        """Nodes and weights (summing to 1) for E[f(T)] = sum w_j f(T_j).

        Gauss-Legendre in probability space u in (0, 1), mapped T = F^-1(u):
        exact for a uniform prior on polynomials of degree 2n-1, and for any
        prior accurate for smooth f (nodes are dense where the density is).
        """
        u, w = _gauss_legendre_01(int(n))
        if self.kind == "uniform":
            lo, hi = self.args
            return lo + (hi - lo) * u, w.copy()
        return np.asarray(self.dist.ppf(u), dtype=float), w.copy()

    def logpdf(self, t: npt.ArrayLike) -> Array:
        return np.asarray(self.dist.logpdf(t), dtype=float)


def uniform_prior(lo: float, hi: float) -> TemperaturePrior:
    """U(lo, hi) degC, the paper's assumption in Eq. (11).

    >>> uniform_prior(30, 50).mean
    40.0
    >>> uniform_prior(-400, -300)
    Traceback (most recent call last):
    ...
    jointwear_ros.errors.InputDataError: uniform temperature range [-400, -300] reaches below absolute zero (-273.15 degC)
    """
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo and math.isfinite(hi - lo)):
        raise InputDataError(f"uniform temperature range [{lo!r}, {hi!r}] must be finite with high > low")
    if lo < ABSOLUTE_ZERO:
        raise InputDataError(f"uniform temperature range [{lo:g}, {hi:g}] reaches below absolute zero ({ABSOLUTE_ZERO} degC)")
    return TemperaturePrior(UniformLaw(lo, hi - lo), f"uniform:{lo:g}:{hi:g}", "uniform", (lo, hi))


def normal_prior(mean: float, std: float) -> TemperaturePrior:
    """N(mean, std^2) degC, the paper's data distribution of Section 5.1 (40, 3).

    Its std is at least :data:`MIN_STD`, and mean - 6 std stays above absolute zero.
    """
    if not (math.isfinite(mean) and math.isfinite(std) and std > 0):
        raise InputDataError(f"normal temperature N({mean!r}, {std!r}^2) needs a finite mean and a positive std")
    if std < MIN_STD:
        raise InputDataError(f"normal temperature N({mean:g}, {std:g}^2): std below {MIN_STD:g} degC; "
                             "use fixed:T for a known temperature")
    if mean - _NORMAL_REACH * std < ABSOLUTE_ZERO:
        raise InputDataError(f"normal temperature N({mean:g}, {std:g}^2) reaches below absolute zero "
                             f"({ABSOLUTE_ZERO} degC)")
    return TemperaturePrior(NormalLaw(mean, std), f"normal:{mean:g}:{std:g}", "normal", (mean, std))


def parse_temperature_prior(spec: str | TemperaturePrior | Any) -> TemperaturePrior:
    """``uniform:LO:HI``, ``normal:MEAN:STD``, ``fixed:T`` (a narrow normal), a prior, or a frozen scipy distribution."""
    if isinstance(spec, TemperaturePrior):
        return spec
    if not isinstance(spec, str):
        if hasattr(spec, "ppf") and hasattr(spec, "rvs"):
            return TemperaturePrior(spec, f"scipy:{getattr(getattr(spec, 'dist', None), 'name', 'custom')}")
        raise InputDataError(f"temperature distribution {spec!r}: expected 'uniform:LO:HI' or 'normal:MEAN:STD'")
    parts = spec.strip().split(":")
    try:
        nums = [float(p) for p in parts[1:]]
    except ValueError:
        raise InputDataError(f"temperature distribution {spec!r}: the numbers after the kind must be numbers") from None
    kind = parts[0].lower()
    if kind in ("uniform", "u") and len(nums) == 2:
        return uniform_prior(nums[0], nums[1])
    if kind in ("normal", "n", "gauss") and len(nums) == 2:
        return normal_prior(nums[0], nums[1])
    if kind == "fixed" and len(nums) == 1:
        return normal_prior(nums[0], MIN_STD)
    raise InputDataError(
        f"temperature distribution {spec!r}: expected 'uniform:LO:HI', 'normal:MEAN:STD' or 'fixed:T'"
    )
