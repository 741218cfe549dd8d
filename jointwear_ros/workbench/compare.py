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
from scipy import stats

from ..model.scaling import DataScales
from ..types import ObservationTable

__all__ = [
    "SPEED_BAND_EDGES",
    "BandError",
    "NoiseFloor",
    "ResidualStructure",
    "band_label",
    "band_rmse",
    "noise_floor",
    "noise_test",
    "residual_structure",
    "speed_band_edges",
    "speed_region",
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


def speed_band_edges(speed: Array) -> tuple[float, ...]:
    """:data:`SPEED_BAND_EDGES` scaled by the data's speed scale (unchanged for motor-side data).

    >>> speed_band_edges(np.array([0.01, 1.3]))[:3]
    (0.0, 0.1, 0.3)
    """
    f = DataScales.of(speed=speed).speed
    return SPEED_BAND_EDGES if f == 1.0 else tuple(e * f for e in SPEED_BAND_EDGES)


def speed_region(speed: Array, gain: Array, edges: Sequence[float] | None = None) -> tuple[float, float]:
    """The speed bands where ``gain`` (per row: an explained part squared, a fall of the squared residual)
    is largest: from the lowest to the highest band whose mean gain is at least 15 % of the largest band's.

    ``edges`` default: :func:`speed_band_edges` of the data. All speeds (the first edge to the last) when
    the region covers every band with data, or nothing gains.

    >>> v = np.array([2.0, 5.0, 20.0, 40.0, 120.0, 250.0])
    >>> speed_region(v, np.array([1.0, 1.0, 0.5, 0.0, 0.0, 0.0]))
    (0.0, 30.0)
    >>> speed_region(v, np.ones(6))
    (0.0, inf)
    """
    v = np.abs(np.asarray(speed, dtype=float))
    g_row = np.asarray(gain, dtype=float)
    edges = speed_band_edges(v) if edges is None else tuple(edges)
    g = np.array([float(np.mean(g_row[m])) if (m := (v >= lo) & (v < hi)).any() else math.nan
                  for lo, hi in itertools.pairwise(edges)])
    present = np.isfinite(g)
    if not present.any() or not np.nanmax(g) > 0:
        return float(edges[0]), float(edges[-1])
    on = np.flatnonzero(present & (g >= 0.15 * np.nanmax(g)))
    pres = np.flatnonzero(present)
    lo_i, hi_i = int(on.min()), int(on.max())
    if lo_i == pres.min() and hi_i == pres.max():  # every band with data: all speeds
        return float(edges[0]), float(edges[-1])
    return float(edges[lo_i]), float(edges[hi_i + 1])


def band_rmse(speed: Array, residuals: Array, edges: Sequence[float] | None = None) -> list[BandError]:
    """RMSE per speed band (bands without observations are left out).

    ``edges`` default: :data:`SPEED_BAND_EDGES` (motor side rad/s) scaled by
    the data's speed scale (:class:`~jointwear_ros.model.scaling.DataScales`),
    so joint-side speeds of a few rad/s get bands of their own.
    """
    if edges is None:
        edges = speed_band_edges(speed)
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
    ss, dof = _replicate_groups(table)
    if dof >= 3:
        return math.sqrt(ss / dof), "repeated observations"
    return math.nan, "unknown"


#: Method names of the noise floor (JSON ``noise_floor.method``).
METHOD_STD = "chi-square with tau_f_std"
METHOD_REPLICATES = "lack-of-fit F test against replicates"
METHOD_CYCLE_DIFF = "F test against cycle-to-cycle differences at equal speed"
METHOD_SWEEP = ("F test against the scatter between sweeps (cycle-to-cycle differences at equal speed; "
                "tau_f_std is the within-sweep error only)")


@dataclass(frozen=True)
class NoiseFloor:
    """The RMSE a perfect model would reach, and whether a fit's residual is consistent with it.

    ``method`` names the source and the test: a chi-square test of
    ``sum((r_i / tau_f_std_i)^2)`` on ``n - k`` degrees of freedom; a
    lack-of-fit F test against the pure error of replicated observations; or
    an F test of the residual variance against half the mean squared
    difference of the residual between consecutive cycles at the same speed
    (an upper bound of the noise when the missing effect changes from cycle to
    cycle, so it errs towards "consistent"). ``consistent`` is
    ``p_value >= alpha``.
    """

    value: float
    method: str
    consistent: bool
    p_value: float
    statistic: float = math.nan
    dof: tuple[int, int] = (0, 0)
    alpha: float = 0.01

    def ratio(self, rmse: float) -> float:
        """``rmse`` in noise floors (nan when the floor is unknown)."""
        return rmse / self.value if math.isfinite(self.value) and self.value > 0 else math.nan

    def to_dict(self) -> dict[str, object]:
        return {"value": self.value if math.isfinite(self.value) else None, "method": self.method,
                "consistent": self.consistent, "p_value": self.p_value if math.isfinite(self.p_value) else None,
                "statistic": self.statistic if math.isfinite(self.statistic) else None,
                "dof": list(self.dof), "alpha": self.alpha}


def _replicate_groups(table: ObservationTable) -> tuple[float, int]:
    keys = [c for c in ("cycle", "speed", "load_torque", "temperature", "position") if c in table]
    if not keys:
        return 0.0, 0
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
    return ss, dof


def _cycle_differences(table: ObservationTable, residuals: Array) -> tuple[float, int]:
    """Sum of squared residual differences between consecutive cycles at equal speed, and their count."""
    if "cycle" not in table:
        return 0.0, 0
    order_key = table["time"] if "time" in table else table["cycle"]
    r = np.asarray(residuals, dtype=float)
    ss, cnt = 0.0, 0
    # equal speed within 0.5 %: a measured speed (a bag's) differs from cycle to cycle in its last digits
    a = np.abs(np.asarray(table.speed, dtype=float))
    v = np.where(a > 0, np.round(np.log(np.where(a > 0, a, 1.0)) / 0.01), -1e9)
    for sp in np.unique(v):
        idx = np.flatnonzero(v == sp)
        if idx.size < 2:
            continue
        idx = idx[np.argsort(order_key[idx], kind="stable")]
        d = np.diff(r[idx])
        ss += float(np.sum(d**2))
        cnt += d.size
    return ss, cnt


def noise_test(
    table: ObservationTable, residuals: Array, n_free: int, *, alpha: float = 0.01
) -> NoiseFloor:
    """Is the residual of a fit with ``n_free`` parameters consistent with the measurement noise?

    Uses ``tau_f_std`` when present (chi-square), else replicated
    observations (lack-of-fit F), else cycle-to-cycle differences at equal
    speed (F); ``method`` says which. With none of them the floor is unknown
    (``consistent`` False, p nan).

    >>> from jointwear_ros.data import synth_observations
    >>> from jointwear_ros.workbench import fit_model, parse_spec
    >>> t = synth_observations(n_cycles=20, seed=3)
    >>> fit = fit_model(parse_spec("paper"), t, cv_folds=0)
    >>> nf = noise_test(t, fit.residuals, fit.n_free)
    >>> nf.method, nf.consistent, round(nf.value, 4)
    ('chi-square with tau_f_std', True, 0.0015)
    """
    r = np.asarray(residuals, dtype=float)
    n = r.size
    dof_res = max(n - int(n_free), 1)
    ssr = float(np.sum(r**2))
    if "tau_f_std" in table:
        s = table["tau_f_std"]
        ok = np.isfinite(s) & (s > 0)
        if ok.sum() >= max(1, n // 2):
            # rows without a usable std get the RMS of the others
            rms = float(np.sqrt(np.mean(s[ok] ** 2)))
            sd = np.where(ok, s, rms)
            chi = float(np.sum((r / sd) ** 2))
            p = float(stats.chi2.sf(chi, dof_res))
            return NoiseFloor(rms, METHOD_STD, bool(p >= alpha), p, chi, (dof_res, 0), alpha)
    ss_pe, dof_pe = _replicate_groups(table)
    if dof_pe >= 3 and ss_pe > 0:
        floor = math.sqrt(ss_pe / dof_pe)
        dof_lof = dof_res - dof_pe
        if dof_lof >= 1:
            f = ((ssr - ss_pe) / dof_lof) / (ss_pe / dof_pe)
            p = float(stats.f.sf(f, dof_lof, dof_pe))
            return NoiseFloor(floor, METHOD_REPLICATES, bool(p >= alpha), p, f, (dof_lof, dof_pe), alpha)
    ss_d, cnt = _cycle_differences(table, r)
    if cnt >= 3 and ss_d > 0:
        var = ss_d / (2.0 * cnt)
        f = (ssr / dof_res) / var
        p = float(stats.f.sf(f, dof_res, cnt))
        return NoiseFloor(math.sqrt(var), METHOD_CYCLE_DIFF, bool(p >= alpha), p, f, (dof_res, cnt), alpha)
    return NoiseFloor(math.nan, "unknown", False, math.nan, math.nan, (0, 0), alpha)


def sweep_scatter(
    table: ObservationTable, residuals: Array, n_free: int, within: NoiseFloor, *, alpha: float = 0.01
) -> NoiseFloor | None:
    """The noise floor from the scatter between sweeps, when it is significantly above ``within``.

    ``tau_f_std`` is a sweep's own standard error (batch means over its samples): it cannot see an error
    that is constant over one sweep and changes from sweep to sweep (an offset per pass, a drift, a
    temperature read once per cycle). Half the mean squared difference of the residual between consecutive
    cycles at equal speed estimates the whole per-sweep variance; when it exceeds ``within.value ** 2``
    (chi-square on the number of differences, at ``alpha``), it is the floor, and the fit's residual is
    F-tested against it. ``None`` when there is no such evidence (or no cycles to compare).

    It is an upper bound when a missing effect changes from cycle to cycle: the caller uses it only when no
    column explains the residual (:func:`~jointwear_ros.workbench.diagnose.diagnose`).

    >>> import numpy as np
    >>> from jointwear_ros.types import ObservationTable
    >>> rng = np.random.default_rng(0)
    >>> cyc = np.repeat(np.arange(12.0), 8); v = np.tile(np.arange(1.0, 9.0), 12)
    >>> r = rng.normal(0, 0.0015, cyc.size)
    >>> t = ObservationTable({"cycle": cyc, "speed": v, "tau_f": r, "tau_f_std": np.full(cyc.size, 1.7e-4)})
    >>> w = noise_test(t, r, 0)
    >>> w.consistent, round(w.value, 5)
    (False, 0.00017)
    >>> s = sweep_scatter(t, r, 0, w)
    >>> s.consistent, round(s.value / 0.0015, 1)
    (True, 1.0)
    """
    if not (math.isfinite(within.value) and within.value > 0):
        return None
    r = np.asarray(residuals, dtype=float)
    ss_d, cnt = _cycle_differences(table, r)
    if cnt < 3 or not ss_d > 0:
        return None
    var = ss_d / (2.0 * cnt)
    larger = float(stats.chi2.sf(ss_d / (2.0 * within.value**2), cnt))
    if larger >= alpha or var <= within.value**2:
        return None
    n = r.size
    dof_res = max(n - int(n_free), 1)
    f = (float(np.sum(r**2)) / dof_res) / var
    p = float(stats.f.sf(f, dof_res, cnt))
    return NoiseFloor(math.sqrt(var), METHOD_SWEEP, bool(p >= alpha), p, f, (dof_res, cnt), alpha)


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
