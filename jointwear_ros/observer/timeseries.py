"""A joint's recorded time series → friction observations, for data this suite did not record.

Input: one joint's samples (time s, position rad, velocity rad/s or none,
applied torque/effort, and any other measured variable), in the units they were
recorded in. Output: one observation per speed and direction pair, Eq. (5):
``tau_f = (u+ - u-) / 2``, ``load_torque = |(u+ + u-) / 2|`` (or the mean of a
measured load column), with the other measured variables averaged over the
samples used. Speeds are ``|velocity| * gear_ratio``, torques
``effort / torque_scale`` (both 1 by default: the data's own units).

Two ways to find the samples, tried in this order (``mode="auto"``):

1. **Plateaus** (a test like the paper's, forward and reverse sweeps at
   constant speeds): the speed levels are found from the histogram of |v|
   (each level held by at least ``min_samples`` samples in each direction);
   a plateau is a run of samples at a level in one direction; each forward
   plateau is paired with the neighbouring reverse plateau of the same level
   whose position range overlaps it most, and that pair is measured by the
   suite's own observer rule (:func:`~jointwear_ros.observer.measure_segment`,
   the window being the overlap of the two position ranges, so gravity is the
   same both ways). The k-th pair of a level is cycle k.
2. **Steady-speed bins** (continuous or sinusoidal motion, no plateaus): the
   samples whose |acceleration| is small (at most ``max_accel``, default the
   ``accel_quantile`` quantile of the moving samples' |acceleration|) are
   binned by speed (``n_bins`` geometric bins); within a speed bin, forward
   and reverse samples are compared at the same positions (``position_bins``
   bins of the positions both directions cover, so the gravity load cancels
   to within a bin's width); each bin with ``min_samples`` matched samples in
   both directions gives an observation with its sample counts and position
   spread. The two directions' accelerations still differ, and positions match
   only to a bin width, so gravity and inertia cancel only approximately; the
   result says so in its warnings.

Without velocity, velocity is the derivative of position (``numpy.gradient``
over time). Standard errors are batch means (:func:`~jointwear_ros.observer.batch_means_se`)
of the half difference ``(u+ - u-)/2``, the batches being position bins of the window (so a load
that varies over the window cancels in each batch, as it does in the mean; the observer's batches
of each direction alone would count that variation as noise).

Pure numpy/scipy; no ROS import.

>>> import numpy as np
>>> t = np.arange(0, 40, 0.002)
>>> # forward at 0.2 rad/s for 10 s, reverse 10 s, then again at 0.5 rad/s
>>> v = np.select([t < 10, t < 20, t < 30], [0.2, -0.2, 0.5], -0.5)
>>> q = np.concatenate(([0.0], np.cumsum(v[:-1]) * 0.002))
>>> u = np.sign(v) * (1.0 + 2.0 * np.abs(v)) + 3.0   # friction 1 + 2|v| N·m, gravity 3 N·m
>>> r = timeseries_observations(t, q, v, u)
>>> r.method, len(r.rows), [round(x["tau_f"], 3) for x in r.rows], [round(x["load_torque"], 3) for x in r.rows]
('plateaus', 2, [1.4, 2.0], [3.0, 3.0])
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from .segmentation import batch_means_se, measure_segment
from .types import FrictionObservationData, ObserverConfig, SpeedSegment

__all__ = ["MODES", "SPLITS", "TimeseriesConfig", "TimeseriesResult", "timeseries_observations", "velocity_from_position"]

Array = npt.NDArray[np.float64]

MODES = ("auto", "plateaus", "bins")
SPLITS = ("auto", "gaps", "reversals", "none")
#: Accelerations quantiles and bin counts tried, in order, when the steady-speed mode picks its own bins.
AUTO_BINS = ((0.3, 12), (0.3, 8), (0.5, 8), (0.5, 6), (0.7, 6), (0.9, 6), (0.9, 5))
#: The steady-speed mode picks its bins until it has this many speeds (commissioning needs 5).
MIN_BIN_SPEEDS = 5


@dataclass(frozen=True)
class TimeseriesConfig:
    """Settings of :func:`timeseries_observations` (speeds relative, times in seconds).

    Attributes
    ----------
    joint_name : written into every observation.
    gear_ratio, torque_scale : output speed = |velocity| x gear_ratio, torque = effort / torque_scale.
    mode : ``auto`` (plateaus, else bins), ``plateaus`` or ``bins``.
    speed_tolerance : a sample is at a speed level when within this fraction of it.
    max_speed_std : a plateau's speed standard deviation at most this fraction of its level.
    min_constant_fraction : the observer's check: this fraction of a pass's samples at the level.
    min_samples : samples needed in each direction (plateau pair or bin).
    rest_fraction : |v| below this fraction of the largest |v| is standing still.
    n_batches : batches of the batch-means standard error.
    n_bins : speed bins of the steady-speed mode.
    max_accel : steady-speed samples have |acceleration| at most this (rad/s², joint side);
        None: the ``accel_quantile`` quantile of the moving samples' |acceleration|.
    accel_quantile : see ``max_accel``.
    smooth_seconds : the velocity is smoothed over this long before it is differentiated.
    position_bins : in the steady-speed mode, forward and reverse samples are compared within this many
        bins of the positions both cover (0: not matched by position).
    min_plateau_fraction : a plateau covers at least this fraction of its motion in one direction
        (from standstill or reversal to the next); the speed peaks of a sinusoid do not.
    window_half_width : plateau pairs are measured over the centre of their position overlap
        ± this (rad, joint side); None: the whole overlap. A narrower window keeps the load
        (gravity) nearly constant, so the standard error is not inflated by its variation.
    min_friction_share : observations at the lowest speeds whose friction is under this share of
        the median friction (friction not developed: pre-sliding, creep, a velocity offset) are
        dropped and reported (0: keep every one).
    split : how a long recording is cut into cycles: ``auto`` (a ``cycle_column`` when given or
        present as ``cycle``, else gaps in time over 10 median intervals and 1 s), ``gaps``,
        ``reversals`` (every ``split_reversals`` direction reversals), ``none``.
    cycle_column : the measured variable that numbers the cycles (``split=auto``).
    """

    joint_name: str = ""
    gear_ratio: float = 1.0
    torque_scale: float = 1.0
    mode: str = "auto"
    speed_tolerance: float = 0.05
    max_speed_std: float = 0.05
    min_constant_fraction: float = 0.6
    min_samples: int = 20
    rest_fraction: float = 1e-3
    n_batches: int = 10
    n_bins: int = 12
    max_accel: float | None = None
    accel_quantile: float = 0.3
    smooth_seconds: float = 0.05
    window_half_width: float | None = None
    min_plateau_fraction: float = 0.3
    position_bins: int = 10
    min_friction_share: float = 0.2
    split: str = "auto"
    split_reversals: int = 4
    cycle_column: str | None = None
    auto_bins: bool = True

    def __post_init__(self) -> None:
        for name in ("gear_ratio", "torque_scale", "speed_tolerance", "max_speed_std", "smooth_seconds"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise InputDataError(f"time-series setting {name} = {v!r} must be a positive number")
        if self.mode not in MODES:
            raise InputDataError(f"time-series setting mode = {self.mode!r}: give one of {', '.join(MODES)}")
        if int(self.min_samples) < 4:
            raise InputDataError(f"time-series setting min_samples = {self.min_samples!r} must be at least 4")
        if int(self.n_bins) < 1:
            raise InputDataError(f"time-series setting n_bins = {self.n_bins!r} must be at least 1")
        if not 0 < self.accel_quantile <= 1:
            raise InputDataError(f"time-series setting accel_quantile = {self.accel_quantile!r} must be in (0, 1]")
        if self.window_half_width is not None and not (math.isfinite(self.window_half_width)
                                                       and self.window_half_width > 0):
            raise InputDataError(f"time-series setting window_half_width = {self.window_half_width!r} must be a "
                                 "positive number (rad)")
        if self.max_accel is not None and not (math.isfinite(self.max_accel) and self.max_accel > 0):
            raise InputDataError(f"time-series setting max_accel = {self.max_accel!r} must be a positive number")
        if int(self.position_bins) < 0:
            raise InputDataError(f"time-series setting position_bins = {self.position_bins!r} must be >= 0")
        if not 0 <= self.min_plateau_fraction <= 1:
            raise InputDataError(f"time-series setting min_plateau_fraction = {self.min_plateau_fraction!r} must be "
                                 "in [0, 1]")
        if not 0 <= self.min_friction_share < 1:
            raise InputDataError(f"time-series setting min_friction_share = {self.min_friction_share!r} must be in "
                                 "[0, 1)")
        if self.split not in SPLITS:
            raise InputDataError(f"time-series setting split = {self.split!r}: give one of {', '.join(SPLITS)}")
        if int(self.split_reversals) < 2:
            raise InputDataError(f"time-series setting split_reversals = {self.split_reversals!r} must be at least 2")
        if not 0 <= self.rest_fraction < 1:
            raise InputDataError(f"time-series setting rest_fraction = {self.rest_fraction!r} must be in [0, 1)")


@dataclass
class TimeseriesResult:
    """Observations (one dict per row, standard columns first), how they were found, and warnings."""

    rows: list[dict[str, float]]
    method: str
    warnings: list[str] = field(default_factory=list)
    rejected: list[str] = field(default_factory=list)
    samples: int = 0
    dropped: int = 0

    def columns(self) -> dict[str, Array]:
        """The rows as columns (every column present in every row; a missing value is NaN)."""
        names: list[str] = []
        for r in self.rows:
            names.extend(k for k in r if k not in names)
        return {n: np.array([r.get(n, math.nan) for r in self.rows], dtype=float) for n in names}

    def to_dict(self) -> dict[str, Any]:
        return {"method": self.method, "observations": len(self.rows), "samples": self.samples,
                "dropped_samples": self.dropped, "warnings": list(self.warnings), "rejected": list(self.rejected)}


def velocity_from_position(t: Array, q: Array) -> Array:
    """dq/dt by central differences (``numpy.gradient`` over the stamps).

    >>> velocity_from_position(np.array([0.0, 1.0, 2.0, 4.0]), np.array([0.0, 2.0, 4.0, 8.0])).tolist()
    [2.0, 2.0, 2.0, 2.0]
    """
    if t.size < 2:
        return np.zeros_like(q)
    return np.asarray(np.gradient(q, t), dtype=float)


def _smooth(t: Array, v: Array, seconds: float) -> Array:
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    k = round(seconds / dt) if dt > 0 else 1
    if k < 3:
        return v
    k = min(k, v.size)
    kernel = np.ones(k) / k
    pad = k // 2
    padded = np.concatenate((np.full(pad, v[0]), v, np.full(k - 1 - pad, v[-1])))
    return np.convolve(padded, kernel, mode="valid")


def timeseries_observations(
    time: npt.ArrayLike,
    position: npt.ArrayLike,
    velocity: npt.ArrayLike | None,
    effort: npt.ArrayLike,
    extra: Mapping[str, npt.ArrayLike] | None = None,
    config: TimeseriesConfig | None = None,
    *,
    temperature: str | None = None,
    load: str | None = None,
) -> TimeseriesResult:
    """Friction observations of one joint's samples (see the module docstring).

    Parameters
    ----------
    time, position, velocity, effort
        Samples of the joint (``velocity`` None: from the position).
    extra
        Other measured variables, one value per sample; each becomes a column
        (its mean over the samples of an observation).
    temperature, load
        Names in ``extra`` of the temperature (degC) and the load torque
        (same unit as ``effort``); the load replaces ``|(u+ + u-)/2|``.
    """
    cfg = config if config is not None else TimeseriesConfig()
    t = np.asarray(time, dtype=float).reshape(-1)
    q = np.asarray(position, dtype=float).reshape(-1)
    e = np.asarray(effort, dtype=float).reshape(-1)
    derived = velocity is None
    v = np.full(t.size, math.nan) if velocity is None else np.asarray(velocity, dtype=float).reshape(-1)
    ex = {str(k): np.asarray(a, dtype=float).reshape(-1) for k, a in (extra or {}).items()}
    for name, arr in (("position", q), ("velocity", v), ("effort", e), *ex.items()):
        if arr.size != t.size:
            raise InputDataError(f"column {name!r} has {arr.size} samples, time has {t.size}")
    for role in (temperature, load):
        if role is not None and role not in ex:
            raise InputDataError(f"column {role!r} is not among the measured variables ({', '.join(ex) or 'none'})")
    # drop samples without time, position or effort; order by time; one sample per stamp
    ok = np.isfinite(t) & np.isfinite(q) & np.isfinite(e) & (derived | np.isfinite(v))
    n_in = int(t.size)
    order = np.argsort(t[ok], kind="stable")
    idx = np.flatnonzero(ok)[order]
    t, q, e, v = t[idx], q[idx], e[idx], v[idx]
    ex = {k: a[idx] for k, a in ex.items()}
    if t.size > 1:
        keep = np.concatenate(([True], np.diff(t) > 0))
        t, q, e, v = t[keep], q[keep], e[keep], v[keep]
        ex = {k: a[keep] for k, a in ex.items()}
    dropped = n_in - int(t.size)
    warnings: list[str] = []
    if dropped:
        warnings.append(f"{dropped} of {n_in} samples dropped (a missing/non-finite value or a repeated time stamp)")
    if t.size < 2 * cfg.min_samples:
        raise InputDataError(f"{t.size} usable samples; need at least {2 * cfg.min_samples} "
                             f"({cfg.min_samples} in each direction)")
    if derived:
        v = velocity_from_position(t, q)
    parts, how = _split(t, v, ex, cfg)
    result = TimeseriesResult([], "")
    methods: list[str] = []
    cycle0 = 0
    for a, b in parts:
        sub = {k: arr[a:b] for k, arr in ex.items()}
        if b - a < 2 * cfg.min_samples:
            result.rejected.append(f"part {t[a]:.6g}-{t[b - 1]:.6g} s: {b - a} samples (need {2 * cfg.min_samples})")
            continue
        part = _observe(t[a:b], q[a:b], v[a:b], e[a:b], sub, cfg, temperature, load)
        if len(parts) > 1:
            for r in part.rows:
                r["cycle"] = float(cycle0 + 1)
            if part.rows:
                cycle0 += 1
            part.rejected = [f"cycle {cycle0 if part.rows else '-'} ({t[a]:.6g}-{t[b - 1]:.6g} s): {x}"
                             for x in part.rejected]
        result.rows.extend(part.rows)
        result.warnings.extend(w for w in part.warnings if w not in result.warnings)
        result.rejected.extend(part.rejected)
        methods.append(part.method)
    result.method = max(set(methods), key=methods.count) if methods else ("bins" if cfg.mode == "bins" else "plateaus")
    if len(parts) > 1:
        warnings.append(f"the recording is split into {len(parts)} parts ({how}); {cycle0} of them gave "
                        "observations, numbered as cycles")
    _drop_undeveloped(result, cfg)
    result.warnings[:0] = warnings
    result.samples = n_in
    result.dropped = dropped
    if derived:
        result.warnings.append("velocity derived from position (numpy.gradient over time)")
    result.rows.sort(key=lambda r: (r["cycle"], r["speed"]))
    return result


def _observe(t: Array, q: Array, v: Array, e: Array, ex: Mapping[str, Array], cfg: TimeseriesConfig,
             temperature: str | None, load: str | None) -> TimeseriesResult:
    """Plateaus, else (auto) steady-speed bins, of one part of the recording."""
    warnings: list[str] = []
    result: TimeseriesResult | None = None
    rejected: list[str] = []
    if cfg.mode in ("auto", "plateaus"):
        result = _plateaus(t, q, v, e, ex, cfg, temperature, load)
        if not result.rows and cfg.mode == "auto":
            why = "; ".join(result.rejected[:3]) or "no speed held in both directions"
            warnings.append(f"no constant-speed plateaus in both directions ({why}); using steady-speed bins")
            rejected = [f"plateaus: {x}" for x in result.rejected[:3]]
            if len(result.rejected) > 3:
                rejected.append(f"plateaus: {len(result.rejected) - 3} more speed level(s) without a plateau pair")
            result = None
    if result is None:
        result = _bins(t, q, v, e, ex, cfg, temperature, load)
        result.rejected[:0] = rejected
    result.warnings[:0] = warnings
    return result


def _split(t: Array, v: Array, ex: Mapping[str, Array], cfg: TimeseriesConfig) -> tuple[list[tuple[int, int]], str]:
    """[start, stop) of the parts of a long recording (each becomes a cycle), and how they were found."""
    n = t.size
    col = cfg.cycle_column if cfg.cycle_column is not None else ("cycle" if "cycle" in ex else None)
    if cfg.split == "none" or n < 2:
        return [(0, n)], "not split"
    if cfg.split == "auto" and col is not None:
        if col not in ex:
            raise InputDataError(f"cycle column {col!r} is not among the measured variables ({', '.join(ex) or 'none'})")
        c = ex[col]
        cuts = np.flatnonzero(np.diff(c) != 0) + 1
        bounds = [0, *cuts.tolist(), n]
        return list(itertools.pairwise(bounds)), f"by the column {col!r}"
    if cfg.split in ("auto", "gaps"):
        dt = np.diff(t)
        gap = max(10.0 * float(np.median(dt)), 1.0)
        cuts = np.flatnonzero(dt > gap) + 1
        if cuts.size or cfg.split == "gaps":
            return list(itertools.pairwise([0, *cuts.tolist(), n])), f"at {cuts.size} gap(s) in time over {gap:.3g} s"
        return [(0, n)], "not split"
    # reversals: every split_reversals changes of direction of the moving samples
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    mov = np.flatnonzero(np.abs(v) > max(cfg.rest_fraction, 1e-6) * vmax)
    sg = np.sign(v[mov])
    rev = mov[1:][np.diff(sg) != 0]
    cuts = rev[cfg.split_reversals::cfg.split_reversals]
    return list(itertools.pairwise([0, *cuts.tolist(), n])), (f"every {cfg.split_reversals} of {rev.size} direction "
                                                               "reversals")


def _drop_undeveloped(result: TimeseriesResult, cfg: TimeseriesConfig) -> None:
    """Drop the lowest-speed observations whose friction is not developed (under ``min_friction_share`` of the
    median), each reported with its reason."""
    if cfg.min_friction_share <= 0 or len(result.rows) < 3:
        return
    tau = np.array([r["tau_f"] for r in result.rows])
    med = float(np.median(tau))
    if not med > 0:
        return
    limit = cfg.min_friction_share * med
    ok = tau >= limit
    if ok.all() or not ok.any():
        return
    v_dev = min(r["speed"] for r, g in zip(result.rows, ok) if g)
    keep = []
    for r, g in zip(result.rows, ok):
        if not g and r["speed"] < v_dev:
            result.rejected.append(
                f"{r['speed']:.4g} rad/s (cycle {r['cycle']:g}): tau_f {r['tau_f']:.4g} is under "
                f"{100 * cfg.min_friction_share:g} % of the median friction {med:.4g}: friction not developed "
                "(pre-sliding, creep or a velocity offset); dropped (--min-friction-share 0 keeps it)")
        else:
            keep.append(r)
    n = len(result.rows) - len(keep)
    if n:
        result.warnings.append(f"{n} observation(s) below {v_dev:.4g} rad/s dropped: friction not developed there "
                               f"(tau_f under {100 * cfg.min_friction_share:g} % of the median)")
    result.rows = keep


# --------------------------------------------------------------------------- plateaus


def _levels(speed: Array, direction: Array, cfg: TimeseriesConfig, rejected: list[str] | None = None) -> list[float]:
    """Speed levels held by at least ``min_samples`` samples in each direction, largest count first."""
    tol = cfg.speed_tolerance
    pool = np.ones(speed.size, dtype=bool)
    levels: list[float] = []
    logv = np.log(speed)
    width = math.log1p(tol)
    for _ in range(64):
        if pool.sum() < 2 * cfg.min_samples:
            break
        lv = logv[pool]
        edges = np.arange(lv.min(), lv.max() + width, width)
        if edges.size < 2:
            edges = np.array([lv.min() - width, lv.max() + width])
        counts, _ = np.histogram(lv, edges)
        b = int(np.argmax(counts))
        centre = math.exp(0.5 * (edges[b] + edges[b + 1]))
        near = pool & (np.abs(speed - centre) <= tol * centre)
        if near.sum() < cfg.min_samples:
            break
        level = float(np.median(speed[near]))
        at = pool & (np.abs(speed - level) <= tol * level)
        pool &= ~(np.abs(speed - level) <= 2 * tol * level)
        nf, nr = int((at & (direction > 0)).sum()), int((at & (direction < 0)).sum())
        if nf >= cfg.min_samples and nr >= cfg.min_samples:
            levels.append(level)
        elif rejected is not None:
            rejected.append(f"{level * cfg.gear_ratio:.4g} rad/s: {nf} forward and {nr} reverse samples within "
                            f"{100 * cfg.speed_tolerance:g} % of it; need {cfg.min_samples} each (--speed-tolerance, "
                            "--min-samples)")
    return sorted(levels)


def _runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[start, stop) of the runs of True in ``mask``."""
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def _close(mask: npt.NDArray[np.bool_], same: npt.NDArray[np.bool_], gap: int) -> npt.NDArray[np.bool_]:
    """``mask`` with its gaps of at most ``gap`` samples filled where ``same`` holds throughout (the direction)."""
    out = mask.copy()
    runs = _runs(mask)
    for (_, b), (a2, _) in itertools.pairwise(runs):
        if a2 - b <= gap and same[b:a2].all():
            out[b:a2] = True
    return out


def _overlap(a: tuple[float, float], b: tuple[float, float]) -> float:
    return min(a[1], b[1]) - max(a[0], b[0])


def _plateaus(t: Array, q: Array, v: Array, e: Array, ex: Mapping[str, Array], cfg: TimeseriesConfig,
              temperature: str | None, load: str | None) -> TimeseriesResult:
    # a noisy velocity column breaks a plateau into runs shorter than min_samples: detect and measure on the
    # velocity smoothed over smooth_seconds (the samples' own time base)
    v = _smooth(t, v, cfg.smooth_seconds)
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    moving = np.abs(v) > cfg.rest_fraction * vmax
    dt = float(np.median(np.diff(t)))
    out = TimeseriesResult([], "plateaus")
    if not moving.any():
        out.rejected.append("the joint never moves")
        return out
    speed = np.where(moving, np.abs(v), np.nan)
    sgn = np.sign(v)
    levels = _levels(speed[moving], sgn[moving], cfg, out.rejected)
    if not levels:
        out.rejected.append(f"no speed held by {cfg.min_samples} samples in each direction "
                            f"(within {100 * cfg.speed_tolerance:g} %)")
        return out
    obs_cfg = ObserverConfig(
        joint_name=cfg.joint_name or "joint", gear_ratio=cfg.gear_ratio, torque_scale=cfg.torque_scale,
        speed_tolerance=cfg.speed_tolerance, speed_tolerance_min=0.0, max_speed_std=cfg.max_speed_std,
        max_speed_std_min=0.0, min_constant_fraction=cfg.min_constant_fraction, min_samples=cfg.min_samples,
        pass_gap=max(0.05, 3.0 * dt), n_batches=cfg.n_batches,
    )
    tt = ex[temperature] if temperature is not None else None
    # motions: runs in one direction, from standstill or reversal to the next
    motion_len = np.zeros(t.size)
    for d in (1, -1):
        for a, b in _runs(moving & (sgn == d)):
            motion_len[a:b] = t[b - 1] - t[a] + dt
    short = 0
    for level in levels:
        at = moving & (np.abs(np.abs(v) - level) <= cfg.speed_tolerance * level)
        plats: list[tuple[int, int, int]] = []  # (start, stop, direction)
        for d in (1, -1):
            # a noisy velocity leaves the tolerance for a few samples now and then: short gaps do not end a plateau
            for a, b in _runs(_close(at & (sgn == d), sgn == d, max(3, cfg.min_samples // 2))):
                if b - a < cfg.min_samples:
                    continue
                if t[b - 1] - t[a] + dt < cfg.min_plateau_fraction * motion_len[a]:
                    short += 1
                    continue
                plats.append((a, b, d))
        plats.sort()
        used: set[int] = set()
        k = 0
        n_rows = len(out.rows)
        for i, (a, b, d) in enumerate(plats):
            if d != 1 or i in used:
                continue
            rng_f = (float(q[a:b].min()), float(q[a:b].max()))
            best, best_ov = -1, 0.0
            for j in (i - 1, i + 1):
                if 0 <= j < len(plats) and plats[j][2] == -1 and j not in used:
                    a2, b2, _ = plats[j]
                    ov = _overlap(rng_f, (float(q[a2:b2].min()), float(q[a2:b2].max())))
                    if ov > best_ov or (ov == best_ov and ov > 0 and j > i):
                        best, best_ov = j, ov
            if best < 0:
                continue
            used.update((i, best))
            a2, b2, _ = plats[best]
            rng_r = (float(q[a2:b2].min()), float(q[a2:b2].max()))
            lo, hi = max(rng_f[0], rng_r[0]), min(rng_f[1], rng_r[1])
            if cfg.window_half_width is not None and hi - lo > 2 * cfg.window_half_width:
                mid = 0.5 * (lo + hi)
                lo, hi = mid - cfg.window_half_width, mid + cfg.window_half_width
            first, last = min(a, a2), max(b, b2)
            seg = SpeedSegment(cycle_id=k + 1, speed_index=levels.index(level), speed=level * cfg.gear_ratio,
                               window_center=0.5 * (lo + hi), window_half_width=0.5 * (hi - lo),
                               t_start=float(t[first]), t_end=float(t[last - 1]) + 0.5 * dt, speeds_total=len(levels))
            r = measure_segment(t, q, v, e, seg, obs_cfg, t if tt is not None else None, tt)
            if not isinstance(r, FrictionObservationData):
                out.rejected.append(f"{level * cfg.gear_ratio:.4g} rad/s pair {k + 1}: {r.reason}")
                continue
            k += 1
            sel = (t >= seg.t_start) & (t < seg.t_end) & (np.abs(q - seg.window_center) <= seg.window_half_width) \
                & (np.abs(np.abs(v) - level) <= cfg.speed_tolerance * level)
            # the standard error of (u+ - u-)/2 from position-matched batches: a load that varies over the
            # window (gravity) cancels in the difference, but would inflate each direction's own batch means
            m = _match_positions(q, e / cfg.torque_scale, sel & (v > 0), sel & (v < 0), cfg, bins=cfg.n_batches)
            if not isinstance(m, str) and math.isfinite(m[2]):
                r = replace(r, tau_f_std=m[2])
            out.rows.append(_row(r, ex, sel, cfg, load, extra_fields={
                "samples_plus": r.samples_plus, "samples_minus": r.samples_minus,
                "position_spread": float(np.std(q[sel])) if sel.any() else math.nan}))
        if len(out.rows) == n_rows:
            dirs = {d for _, _, d in plats}
            why = ("no run of " + str(cfg.min_samples) + " samples at it in " +
                   ("either direction" if not dirs else "the " + ("reverse" if 1 in dirs else "forward") + " direction")
                   if dirs != {1, -1} else "no forward run next to a reverse run over the same positions")
            out.rejected.append(f"{level * cfg.gear_ratio:.4g} rad/s: no plateau pair ({why}; --speed-tolerance, "
                                "--min-samples)")
    if short and not out.rows:
        out.rejected.append(f"{short} run(s) at a steady speed too short to be plateaus (under "
                            f"{100 * cfg.min_plateau_fraction:g} % of their motion: speed peaks, not plateaus)")
    out.rows.sort(key=lambda r: (r["cycle"], r["speed"]))
    return out


def _row(r: FrictionObservationData, ex: Mapping[str, Array], sel: npt.NDArray[np.bool_], cfg: TimeseriesConfig,
         load: str | None, extra_fields: Mapping[str, float]) -> dict[str, float]:
    row = {"speed": r.speed, "tau_f": r.tau_f, "tau_f_std": r.tau_f_std, "load_torque": r.load_torque,
           "temperature": r.temperature, "position": r.position, "time": r.stamp, "cycle": float(r.cycle_id),
           "tau_plus": r.tau_plus, "tau_minus": r.tau_minus, **{k: float(v) for k, v in extra_fields.items()}}
    for name, arr in ex.items():
        if name in row:
            continue
        vals = arr[sel]
        vals = vals[np.isfinite(vals)]
        row[name] = float(vals.mean()) if vals.size else math.nan
    if load is not None:
        row["load_torque"] = abs(row[load]) / cfg.torque_scale
    return row


# --------------------------------------------------------------------------- bins


def _match_positions(
    q: Array, u: Array, fw: npt.NDArray[np.bool_], rv: npt.NDArray[np.bool_], cfg: TimeseriesConfig,
    bins: int | None = None,
) -> tuple[float, float, float, npt.NDArray[np.bool_], npt.NDArray[np.bool_]] | str:
    """Forward and reverse samples compared at the same positions (so the load, e.g. gravity, cancels).

    The positions both directions cover are cut into ``position_bins`` bins;
    in each bin with at least 2 samples of each direction, ``d = (mean u+ - mean u-)/2``.
    Returns u+ and u- (weighted means over the matched bins, weights
    ``2 n+ n- / (n+ + n-)``), the standard error of their half difference
    (from the bins' scatter; batch means with one bin) and the samples used,
    or why there are none.
    """
    nbins = cfg.position_bins if bins is None else bins
    if not (fw.any() and rv.any()):
        return "no samples in one direction"
    qf, qr = q[fw], q[rv]
    lo, hi = max(float(qf.min()), float(qr.min())), min(float(qf.max()), float(qr.max()))
    if nbins == 0:
        edges = np.array([-np.inf, np.inf])
    elif not hi > lo:
        return (f"forward samples at [{float(qf.min()):.3g}, {float(qf.max()):.3g}] rad, reverse at "
                f"[{float(qr.min()):.3g}, {float(qr.max()):.3g}] rad: never at the same positions")
    else:
        edges = np.linspace(lo, hi, nbins + 1)
        edges[-1] = np.nextafter(hi, np.inf)
    used_f = np.zeros_like(fw)
    used_r = np.zeros_like(rv)
    dp, dm, w = [], [], []
    for a, b in itertools.pairwise(edges.tolist()):
        f = fw & (q >= a) & (q < b)
        r = rv & (q >= a) & (q < b)
        nf, nr = int(f.sum()), int(r.sum())
        if nf < 2 or nr < 2:
            continue
        dp.append(float(u[f].mean()))
        dm.append(float(u[r].mean()))
        w.append(2.0 * nf * nr / (nf + nr))
        used_f |= f
        used_r |= r
    nf, nr = int(used_f.sum()), int(used_r.sum())
    if nf < cfg.min_samples or nr < cfg.min_samples:
        return (f"{nf} forward and {nr} reverse steady samples at common positions; need {cfg.min_samples} each")
    ww = np.asarray(w)
    up, um = float(np.dot(ww, dp) / ww.sum()), float(np.dot(ww, dm) / ww.sum())
    d = 0.5 * (np.asarray(dp) - np.asarray(dm))
    if d.size >= 2:
        tau = 0.5 * (up - um)
        se = float(math.sqrt(d.size / (d.size - 1) * float(np.sum(ww**2 * (d - tau) ** 2))) / ww.sum())
    else:
        se = 0.5 * math.hypot(batch_means_se(u[used_f], cfg.n_batches), batch_means_se(u[used_r], cfg.n_batches))
    return up, um, se, used_f, used_r



def _bins(t: Array, q: Array, v: Array, e: Array, ex: Mapping[str, Array], cfg: TimeseriesConfig,
          temperature: str | None, load: str | None) -> TimeseriesResult:
    if not cfg.auto_bins or cfg.max_accel is not None:
        return _bins_at(t, q, v, e, ex, cfg, temperature, load)
    # bins picked by the data: the strictest steadiness and the finest bins that give MIN_BIN_SPEEDS speeds,
    # over the speeds from the 5 % quantile (at least 1 % of the top speed) up
    best: TimeseriesResult | None = None
    for quant, nb in AUTO_BINS:
        r = _bins_at(t, q, v, e, ex, replace(cfg, accel_quantile=quant, n_bins=nb), temperature, load)
        r.warnings.append(f"bins picked from the data: {nb} speed bins, |acceleration| up to its {100 * quant:g} % "
                          "quantile (--bins, --max-accel choose them)")
        if best is None or len(r.rows) > len(best.rows):
            best = r
        if len(r.rows) >= MIN_BIN_SPEEDS:
            return r
    assert best is not None
    return best


def _bins_at(t: Array, q: Array, v: Array, e: Array, ex: Mapping[str, Array], cfg: TimeseriesConfig,
             temperature: str | None, load: str | None) -> TimeseriesResult:
    out = TimeseriesResult([], "bins")
    vmax = float(np.max(np.abs(v))) if v.size else 0.0
    moving = np.abs(v) > max(cfg.rest_fraction, 1e-6) * vmax
    if moving.sum() < 2 * cfg.min_samples:
        out.rejected.append(f"only {int(moving.sum())} moving samples")
        return out
    vs = _smooth(t, v, cfg.smooth_seconds)
    acc = np.abs(np.gradient(vs, t))
    limit = cfg.max_accel if cfg.max_accel is not None else float(np.quantile(acc[moving], cfg.accel_quantile))
    steady = moving & (acc <= limit)
    speed = np.abs(v)
    if not steady.any():
        out.rejected.append(f"no sample with |acceleration| <= {limit:.3g}")
        return out
    lo, hi = float(speed[steady].min()), float(speed[steady].max())
    if cfg.auto_bins and cfg.max_accel is None:  # bins picked from the data: from the 5 % quantile of the speeds
        lo = max(lo, float(np.quantile(speed[steady], 0.05)), 0.01 * hi)
    edges = np.geomspace(lo, hi * (1 + 1e-9), cfg.n_bins + 1) if hi > lo else np.array([lo, hi * (1 + 1e-9) + 1e-12])
    sgn = np.sign(v)
    k = 0
    spread_max = 0.0
    for b in range(edges.size - 1):
        inbin = steady & (speed >= edges[b]) & (speed < edges[b + 1])
        fw, rv = inbin & (sgn > 0), inbin & (sgn < 0)
        nf, nr = int(fw.sum()), int(rv.sum())
        if nf < cfg.min_samples or nr < cfg.min_samples:
            if inbin.any():
                out.rejected.append(f"speed bin [{edges[b] * cfg.gear_ratio:.4g}, {edges[b + 1] * cfg.gear_ratio:.4g}) "
                                    f"rad/s: {nf} forward, {nr} reverse steady samples; need {cfg.min_samples} each")
            continue
        m = _match_positions(q, e / cfg.torque_scale, fw, rv, cfg)
        if isinstance(m, str):
            out.rejected.append(f"speed bin [{edges[b] * cfg.gear_ratio:.4g}, {edges[b + 1] * cfg.gear_ratio:.4g}) "
                                f"rad/s: {m}")
            continue
        mp, mm, se, fw, rv = m
        nf, nr = int(fw.sum()), int(rv.sum())
        inbin = fw | rv
        k += 1
        spread = float(np.std(q[inbin]))
        spread_max = max(spread_max, spread)
        temp = math.nan
        if temperature is not None:
            tv = ex[temperature][inbin]
            tv = tv[np.isfinite(tv)]
            temp = float(tv.mean()) if tv.size else math.nan
        r = FrictionObservationData(
            stamp=float(t[inbin].mean()), joint_name=cfg.joint_name, cycle_id=1,
            speed=0.5 * (float(speed[fw].mean()) + float(speed[rv].mean())) * cfg.gear_ratio,
            tau_f=0.5 * (mp - mm), tau_f_std=se, tau_plus=mp, tau_minus=mm,
            load_torque=abs(0.5 * (mp + mm)), temperature=temp, position=float(q[inbin].mean()),
            samples_plus=nf, samples_minus=nr,
        )
        out.rows.append(_row(r, ex, inbin, cfg, load, extra_fields={
            "samples_plus": nf, "samples_minus": nr, "position_spread": spread,
            "position_gap": abs(float(q[fw].mean()) - float(q[rv].mean())),
            "accel_max": float(acc[inbin].max())}))
    if out.rows:
        out.warnings.append(
            f"{len(out.rows)} observations from steady-speed samples (|acceleration| <= {limit:.3g} rad/s^2) "
            "binned by speed and matched by position (forward and reverse compared within the same position "
            f"bins; spread up to {spread_max:.3g} rad): their accelerations differ and the positions match only "
            "to a bin width, so gravity and inertia cancel only approximately")
    bad = [r for r in out.rows if not r["tau_f"] > 0]
    if bad:
        out.warnings.append(f"{len(bad)} bin(s) have tau_f <= 0 (u+ <= u-): gravity or inertia dominates there, "
                            "or velocity and effort have opposite sign conventions")
    return out
