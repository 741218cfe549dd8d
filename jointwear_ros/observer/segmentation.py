"""One speed's windows → one friction observation, Eq. (5), vectorised over numpy arrays.

Given the joint-state samples (joint side: position rad, velocity rad/s,
effort N·m) and the stamps [t_start, t_end) of one speed of a test cycle:

1. window: samples with ``t_start <= t < t_end`` and
   ``|position - centre| <= half_width * (1 - edge_trim)``;
2. direction d = +1 (forward), -1 (reverse): window samples with ``d * v > 0``,
   cut into passes (runs in stamp order without a gap over ``pass_gap``);
   passes whose median ``|v_motor|`` is within ``tol`` of ``v_cmd`` and at
   least ``min_constant_fraction`` of whose samples are too are the sweeps of
   this speed (an approach move crossing the window at another speed, or
   accelerating through this one, is left out; when no pass is constant, the
   passes at this speed on median are checked below and fail "speed not
   constant"), ``tol = max(speed_tolerance * v_cmd, speed_tolerance_min)``;
3. at speed: samples of those passes with ``|v_motor - d * v_cmd| <= tol``;
4. checks, each failing with a reason: a pass at this speed ("speed not
   reached"); at least ``min_samples`` at speed ("too few samples"); at least
   ``min_constant_fraction`` of the pass samples at speed, and their speed
   std at most ``max(max_speed_std * v_cmd, max_speed_std_min)`` ("speed not
   constant"); ``u+ > u-`` ("wrong direction");
5. ``u± = mean(effort) / torque_scale`` over the at-speed samples,
   ``tau_f = (u+ - u-) / 2`` (Eq. 5), ``tau_m = |(u+ + u-) / 2|``.

The standard error of each mean is a batch-means estimate: the at-speed
samples in stamp order, less their straight line over position (the torque
both directions share along the window: gravity, the arm's coupling; it
cancels in the difference), are cut into ``n_batches`` contiguous batches and
``se = std(batch means, ddof=1) / sqrt(n_batches)``; what the shared slope
adds when the two directions' samples centre apart is added in quadrature. Torque noise in a
closed velocity loop is autocorrelated, so the naive ``std / sqrt(n)``
would understate it; batch means stay valid as long as a batch is longer
than the correlation time. ``tau_f_std = sqrt(se+^2 + se-^2) / 2``.

Pure numpy; no ROS import.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt

from .types import FrictionObservationData, ObserverConfig, Rejection, SpeedSegment

__all__ = ["batch_means_se", "measure_segment"]

Array = npt.NDArray[np.float64]

_DIRECTION_NAMES = {1: "forward", -1: "reverse"}


def batch_means_se(values: Array, n_batches: int) -> float:
    """Standard error of ``mean(values)`` by non-overlapping batch means.

    ``values`` in time order; the last ``len % n_batches`` samples are left
    out of the batches (not of the mean). Fewer than two samples per batch
    falls back to fewer batches; fewer than 4 values gives NaN.

    >>> round(batch_means_se(np.array([0.0, 1.0] * 50), 10), 6)
    0.0
    """
    n = int(values.size)
    nb = min(int(n_batches), n // 2)
    if nb < 2:
        return math.nan
    m = n // nb
    means = values[: nb * m].reshape(nb, m).mean(axis=1)
    return float(means.std(ddof=1) / math.sqrt(nb))


def _detrend(x: Array, u: Array) -> tuple[float, Array]:
    """The slope of ``u`` over position ``x`` (least squares) and ``u`` without that straight line.

    Inside a window the torque also changes with position by what both directions share (gravity, and on
    an arm the velocity-quadratic coupling along the line): it cancels in ``(u+ - u-)/2`` over the same
    positions, so it is no scatter of the mean; left in, batch means cut along the window would read it as
    noise (on an arm's shoulder 50 times the torque noise)."""
    span = float(np.ptp(x)) if x.size else 0.0
    if x.size < 3 or not span > 0:
        return 0.0, u
    xc = x - x.mean()
    slope = float(np.dot(xc, u - u.mean()) / np.dot(xc, xc))
    return slope, u - slope * xc


def _coverage_bias(slopes: dict[int, float], centres: dict[int, float]) -> float:
    """What the shared slope adds to ``u+ - u-`` when the two directions' samples centre on different
    positions (their means then see the slope at different places): ``|mean slope| * |x+ - x-|``."""
    return abs(0.5 * (slopes[1] + slopes[-1])) * abs(centres[1] - centres[-1])


def measure_segment(
    stamps: Array,
    position: Array,
    velocity: Array,
    effort: Array,
    segment: SpeedSegment,
    config: ObserverConfig,
    temperature_stamps: Array | None = None,
    temperature_values: Array | None = None,
) -> FrictionObservationData | Rejection:
    """The friction observation of one speed, or the reason there is none.

    Parameters
    ----------
    stamps, position, velocity, effort : joint-state samples, joint side, any order.
    segment : the speed (commanded motor speed, window, stamps) from the status stream.
    config : segmentation settings.
    temperature_stamps, temperature_values : temperature samples (degC); their mean over
        [t_start, t_end) is the observation's temperature (NaN when there are none).
    """
    cfg = config
    v_cmd = float(segment.speed)

    def reject(reason: str) -> Rejection:
        return Rejection(stamp=_end_stamp(stamps, segment), joint_name=cfg.joint_name, cycle_id=segment.cycle_id,
                         speed_index=segment.speed_index, speed=v_cmd, reason=reason)

    if not (math.isfinite(v_cmd) and v_cmd > 0):
        return reject(f"commanded speed {v_cmd!r} rad/s is not a positive number; no constant-speed window")
    half = float(segment.window_half_width) * (1.0 - cfg.edge_trim)
    centre = float(segment.window_center)
    if not (math.isfinite(half) and half > 0 and math.isfinite(centre)):
        return reject(f"window {centre!r} ± {segment.window_half_width!r} rad is not a valid window")

    in_time = (stamps >= segment.t_start) & (stamps < segment.t_end)
    in_window = in_time & (np.abs(position - centre) <= half)
    if not in_window.any():
        if in_time.any():
            p = position[in_time]
            return reject(
                f"no samples inside the window {centre:g} ± {half:g} rad: the joint was at "
                f"[{float(p.min()):.3f}, {float(p.max()):.3f}] rad during this speed"
            )
        if stamps.size:
            lo, hi = float(stamps.min()), float(stamps.max())
            return reject(
                f"no joint-state samples during this speed [{segment.t_start:.3f}, {segment.t_end:.3f}) s; the "
                f"buffered samples are stamped [{lo:.3f}, {hi:.3f}] s: are /joint_states and the status stamped "
                "by the same clock (use_sim_time)?"
            )
        return reject("no joint-state samples during this speed (is /joint_states arriving, with the right joint name?)")

    v_motor = velocity * cfg.gear_ratio
    tol = max(cfg.speed_tolerance * v_cmd, cfg.speed_tolerance_min)
    std_limit = max(cfg.max_speed_std * v_cmd, cfg.max_speed_std_min)
    means: dict[int, float] = {}
    ses: dict[int, float] = {}
    counts: dict[int, int] = {}
    speeds: dict[int, float] = {}
    slopes: dict[int, float] = {}
    centres: dict[int, float] = {}
    last_stamp = -math.inf
    for d in (1, -1):
        name = _DIRECTION_NAMES[d]
        mov = np.flatnonzero(in_window & (d * velocity > 0))
        if mov.size == 0:
            return reject(f"too few samples in {name} window: none moving {name} inside it; need {cfg.min_samples}")
        mov = mov[np.argsort(stamps[mov], kind="stable")]
        vm = np.abs(v_motor[mov])
        # passes through the window: runs of samples without a gap longer than pass_gap
        breaks = np.flatnonzero(np.diff(stamps[mov]) > cfg.pass_gap) + 1
        bounds = np.concatenate(([0], breaks, [mov.size]))
        keep = np.zeros(mov.size, dtype=bool)
        near = np.zeros(mov.size, dtype=bool)  # passes at this speed on median, not constant
        others: list[tuple[float, int]] = []
        for a, b in itertools.pairwise(bounds.tolist()):
            med = float(np.median(vm[a:b]))
            if abs(med - v_cmd) <= tol:
                at_speed = np.abs(vm[a:b] - v_cmd) <= tol
                if np.count_nonzero(at_speed) >= cfg.min_constant_fraction * (b - a):
                    keep[a:b] = True
                else:
                    near[a:b] = True
            else:
                others.append((med, int(b - a)))
        if not keep.any() and not near.any():
            seen = ", ".join(f"{m:.3g} rad/s ({n} samples)" for m, n in others[:4])
            return reject(f"speed not reached in {name} window: no pass at {v_cmd:g} ± {tol:.3g} rad/s; "
                          f"passes at median {seen}")
        if not keep.any():  # the sweep crossed the window at this speed, not constantly: the checks below say so
            keep = near
        cand = mov[keep]
        n_moving = int(cand.size)
        idx = cand[np.abs(v_motor[cand] - d * v_cmd) <= tol]
        n_at = int(idx.size)
        if n_at < cfg.min_samples:
            return reject(f"too few samples in {name} window: {n_at} of {n_moving} samples of its pass(es) within "
                          f"±{tol:.3g} rad/s of {v_cmd:g} rad/s; need {cfg.min_samples}")
        if n_at < cfg.min_constant_fraction * n_moving:
            return reject(
                f"speed not constant in {name} window: std {float(np.abs(v_motor[cand]).std()):.3g} rad/s; only "
                f"{100.0 * n_at / n_moving:.0f}% of {n_moving} samples within ±{tol:.3g} rad/s of {v_cmd:g} rad/s "
                f"(need {100.0 * cfg.min_constant_fraction:.0f}%)"
            )
        vs = v_motor[idx]
        v_std = float(vs.std())
        if v_std > std_limit:
            return reject(f"speed not constant in {name} window: std {v_std:.3g} rad/s > {std_limit:.3g} rad/s")
        u = effort[idx] / cfg.torque_scale  # in stamp order
        means[d] = float(u.mean())
        x = position[idx]
        slopes[d], resid = _detrend(x, u)
        centres[d] = float(x.mean())
        ses[d] = batch_means_se(resid, cfg.n_batches)
        counts[d] = n_at
        speeds[d] = float(np.abs(vs).mean())
        last_stamp = max(last_stamp, float(stamps[idx[-1]]))

    u_plus, u_minus = means[1], means[-1]
    tau_f = 0.5 * (u_plus - u_minus)
    if not tau_f > 0:
        return reject(
            f"wrong direction: u+ = {u_plus:.5g} <= u- = {u_minus:.5g}, friction does not oppose the motion; "
            "check the sign conventions of velocity and effort in /joint_states"
        )
    temperature = math.nan
    if temperature_stamps is not None and temperature_values is not None and temperature_stamps.size:
        sel = (temperature_stamps >= segment.t_start) & (temperature_stamps < segment.t_end)
        sel &= np.isfinite(temperature_values)
        if sel.any():
            temperature = float(temperature_values[sel].mean())
    return FrictionObservationData(
        stamp=last_stamp,
        joint_name=cfg.joint_name,
        cycle_id=int(segment.cycle_id),
        speed=0.5 * (speeds[1] + speeds[-1]),
        tau_f=tau_f,
        tau_f_std=0.5 * math.hypot(ses[1], ses[-1], _coverage_bias(slopes, centres)),
        tau_plus=u_plus,
        tau_minus=u_minus,
        load_torque=abs(0.5 * (u_plus + u_minus)),
        temperature=temperature,
        position=centre,
        samples_plus=counts[1],
        samples_minus=counts[-1],
    )


def _end_stamp(stamps: Array, segment: SpeedSegment) -> float:
    if math.isfinite(segment.t_end):
        return float(segment.t_end)
    return float(stamps.max()) if stamps.size else float(segment.t_start)
