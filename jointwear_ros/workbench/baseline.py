"""The plain pipeline the workbench is measured against: scipy ``least_squares`` of the standard model.

``tau_f = Fc + Fs exp(-|v/vs|^1.3) + Fv v``, no bounds but ``vs > 0``, started
at the data's own numbers (``Fc`` the smallest friction, ``Fs`` the low-speed
excess, ``Fv`` 0) from 13 Stribeck speeds spread geometrically over
``vs_range``; the best of them. What an engineer would write in ten lines, and
what ``model fit --model standard`` has to match in any units
(``bench/bench_units.py``, ``test/test_workbench_units.py``).

>>> import numpy as np
>>> v = np.geomspace(0.01, 1.0, 20)
>>> round(plain_standard_fit(v, 0.3 + 0.2 * np.exp(-(v / 0.1) ** 1.3) + 0.5 * v).rmse, 8)
0.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from ..model import STRIBECK_EXPONENT

__all__ = ["PlainFit", "plain_standard_fit"]


@dataclass(frozen=True)
class PlainFit:
    """Parameters (Fc, Fs, vs, Fv) and RMSE of :func:`plain_standard_fit`."""

    params: tuple[float, float, float, float]
    rmse: float


def plain_standard_fit(speed: npt.ArrayLike, tau_f: npt.ArrayLike,
                       vs_range: tuple[float, float] | None = None, nonnegative: bool = False) -> PlainFit:
    """Least squares of the standard model, best of 13 starts (``vs_range`` default: the data's speeds;
    ``nonnegative``: Fc, Fs and Fv at least 0, the physical signs)."""
    v = np.abs(np.asarray(speed, dtype=float))
    y = np.asarray(tau_f, dtype=float)
    lo, hi = vs_range if vs_range is not None else (float(v[v > 0].min()), float(v.max()))

    def res(p: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        return p[0] + p[1] * np.exp(-np.abs(v / p[2]) ** STRIBECK_EXPONENT) + p[3] * v - y

    best: PlainFit | None = None
    first = float(y[int(np.argmin(v))])
    for vs in np.geomspace(lo, hi, 13):
        low = [0.0 if nonnegative else -np.inf, 0.0 if nonnegative else -np.inf, 1e-12,
               0.0 if nonnegative else -np.inf]
        start = [max(float(y.min()), 0.0) if nonnegative else float(y.min()), max(first - float(y.min()), 0.0) if nonnegative else first - float(y.min()), vs,
                 1e-12 if nonnegative else 0.0]
        s = least_squares(res, start, bounds=(low, np.inf))
        fit = PlainFit(tuple(float(x) for x in s.x), float(math.sqrt(np.mean(s.fun**2))))  # type: ignore[arg-type]
        if best is None or fit.rmse < best.rmse:
            best = fit
    assert best is not None
    return best
