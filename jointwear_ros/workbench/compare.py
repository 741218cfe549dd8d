"""Compare a fitted model with the data: noise floor, error per speed band, residual structure.

>>> import numpy as np
>>> from jointwear_ros.types import ObservationTable
>>> t = ObservationTable.from_arrays(speed=[5.0, 20.0, 50.0, 120.0], tau_f=[0.08, 0.07, 0.07, 0.09],
...                                  tau_f_std=0.0015)
>>> noise_floor(t)
(0.0015, 'tau_f_std')
>>> [(b.label, b.n, round(b.rmse, 3)) for b in band_rmse(t.speed, np.array([0.01, -0.01, 0.002, 0.0]))]
[('0-10', 1, 0.01), ('10-30', 1, 0.01), ('30-60', 1, 0.002), ('100-150', 1, 0.0)]
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ..types import ObservationTable

__all__ = [
    "SPEED_BAND_EDGES",
    "BandError",
    "ResidualStructure",
    "band_label",
    "band_rmse",
    "noise_floor",
    "residual_structure",
]

Array = npt.NDArray[np.float64]

#: Edges of the speed bands, motor side, rad/s (the last band is open).
SPEED_BAND_EDGES: tuple[float, ...] = (0.0, 10.0, 30.0, 60.0, 100.0, 150.0, 200.0, math.inf)


def band_label(lo: float, hi: float) -> str:
    return f"{lo:g}+" if not math.isfinite(hi) else f"{lo:g}-{hi:g}"


@dataclass(frozen=True)
class BandError:
    """RMSE of the residuals in one speed band [lo, hi)."""

    lo: float
    hi: float
    n: int
    rmse: float

    @property
    def label(self) -> str:
        return band_label(self.lo, self.hi)


def band_rmse(speed: Array, residuals: Array, edges: Sequence[float] = SPEED_BAND_EDGES) -> list[BandError]:
    """RMSE per speed band (bands without observations are left out)."""
    v = np.abs(np.asarray(speed, dtype=float))
    r = np.asarray(residuals, dtype=float)
    out = []
    for lo, hi in itertools.pairwise(edges):
        m = (v >= lo) & (v < hi)
        if m.any():
            out.append(BandError(float(lo), float(hi), int(m.sum()), float(np.sqrt(np.mean(r[m] ** 2)))))
    return out


def noise_floor(table: ObservationTable) -> tuple[float, str]:
    """The RMSE a perfect model would reach, and where the figure comes from.

    From ``tau_f_std`` (root mean square of the per-observation standard
    errors) when present and finite; else from repeated observations (rows of
    one cycle at the same speed, or with identical inputs): the pooled
    standard deviation. ``(nan, "unknown")`` when neither is available.
    """
    if "tau_f_std" in table:
        s = table["tau_f_std"]
        ok = np.isfinite(s) & (s > 0)
        if ok.sum() >= max(1, len(table) // 2):
            return float(np.sqrt(np.mean(s[ok] ** 2))), "tau_f_std"
    keys = [c for c in ("cycle", "speed", "load_torque", "temperature", "position") if c in table]
    if keys:
        mat = np.column_stack([np.round(table[c], 9) for c in keys])
        _, inv, counts = np.unique(mat, axis=0, return_inverse=True, return_counts=True)
        inv = inv.reshape(-1)
        y = table.tau_f
        ss = 0.0
        dof = 0
        for g in np.flatnonzero(counts >= 2):
            yy = y[inv == g]
            ss += float(np.sum((yy - yy.mean()) ** 2))
            dof += yy.size - 1
        if dof >= 3:
            return math.sqrt(ss / dof), "repeated observations"
    return math.nan, "unknown"


@dataclass(frozen=True)
class ResidualStructure:
    """How much of the residual one column explains.

    ``r2_binned``: share of the residual variance explained by the residual's
    mean in quantile bins of the column (0: no structure); ``corr``: linear
    correlation.
    """

    column: str
    corr: float
    r2_binned: float


def residual_structure(table: ObservationTable, residuals: Array, bins: int = 6) -> list[ResidualStructure]:
    """Residual structure against every numeric column (but tau_f and its parts), strongest first."""
    r = np.asarray(residuals, dtype=float)
    out = []
    tot = float(np.sum((r - r.mean()) ** 2)) if r.size else 0.0
    for name, col in table.columns.items():
        if name in ("tau_f", "tau_f_std", "tau_plus", "tau_minus") or not np.all(np.isfinite(col)):
            continue
        if col.size < 3 or float(np.ptp(col)) == 0.0 or tot == 0.0:
            continue
        corr = float(np.corrcoef(col, r)[0, 1])
        q = np.unique(np.quantile(col, np.linspace(0, 1, bins + 1)))
        idx = np.clip(np.searchsorted(q, col, side="right") - 1, 0, max(q.size - 2, 0))
        expl = 0.0
        for b in np.unique(idx):
            m = idx == b
            expl += m.sum() * (r[m].mean() - r.mean()) ** 2
        out.append(ResidualStructure(name, corr, float(expl / tot)))
    out.sort(key=lambda s: -s.r2_binned)
    return out
