"""Synthetic test-cycle streams (joint states + status) from the friction model, for tests and benchmarks.

The joint follows the test-cycle contract: for each speed it sweeps forward
from ``centre - half_width - ext`` to ``centre + half_width + ext`` with a
trapezoidal velocity profile (constant speed over the window), then back in
reverse; ``ext`` leaves room to accelerate and settle before the window. The
applied torque is ``u = tau_g(phi) + sign(v) tau_f(|v|) + J a + noise`` with
``tau_g(phi) = load * cos(phi)``, the friction from the model at the given
temperature and wear, and AR(1) noise; ``effort = u * torque_scale``.

The status stream is what the test-cycle node publishes, as
:class:`~jointwear_ros.contract.CycleStatus` (``stamp`` set): RUNNING with the
phase, ``current_speed`` and ``speeds_done`` on every change and at
``status_rate``; DONE at the end.

Pure numpy; no ROS import.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from itertools import accumulate

import numpy as np
import numpy.typing as npt

from ..contract import CyclePhase, CycleState, CycleStatus
from ..model import Model, Parameters, load_parameter_set, paper_wear_model

__all__ = [
    "PHASE_APPROACH",
    "PHASE_FORWARD",
    "PHASE_REVERSE",
    "PHASE_SETTLE",
    "SyntheticCycle",
    "SyntheticRobotCycle",
    "ar1",
    "synthetic_cycle",
    "synthetic_robot_cycle",
]

Array = npt.NDArray[np.float64]

#: ``TestCycleStatus.PHASE_*``: aliases of :class:`jointwear_ros.contract.CyclePhase`.
PHASE_NONE = CyclePhase.NONE
PHASE_APPROACH = CyclePhase.APPROACH
PHASE_FORWARD = CyclePhase.FORWARD
PHASE_REVERSE = CyclePhase.REVERSE
PHASE_SETTLE = CyclePhase.SETTLE


@dataclass
class SyntheticCycle:
    """Samples and statuses of one synthetic test cycle, with the truth used to make them."""

    stamps: Array
    position: Array
    velocity: Array
    effort: Array
    statuses: list[CycleStatus]
    temperatures: list[tuple[float, float]]
    speeds: Array  # commanded, motor side
    tau_f_true: Array  # model friction at each speed, normalized
    load_true: float  # |tau_g(centre)|, normalized
    window_load_true: float  # mean |tau_g| over the window (what (u+ + u-)/2 measures)
    info: dict[str, float] = field(default_factory=dict)


def _trapezoid(p0: float, p1: float, vmax: float, acc: float, dt: float) -> tuple[Array, Array, Array]:
    """Positions, velocities, accelerations from p0 to p1 (at rest at both ends)."""
    dist = abs(p1 - p0)
    d = 1.0 if p1 >= p0 else -1.0
    vmax = min(vmax, math.sqrt(dist * acc))
    t_acc = vmax / acc
    d_acc = 0.5 * acc * t_acc**2
    t_cruise = max(0.0, (dist - 2 * d_acc) / vmax)
    total = 2 * t_acc + t_cruise
    t = np.arange(0.0, total, dt)
    s = np.empty_like(t)
    v = np.empty_like(t)
    a = np.empty_like(t)
    m1 = t < t_acc
    m2 = (t >= t_acc) & (t < t_acc + t_cruise)
    m3 = t >= t_acc + t_cruise
    s[m1] = 0.5 * acc * t[m1] ** 2
    v[m1] = acc * t[m1]
    a[m1] = acc
    s[m2] = d_acc + vmax * (t[m2] - t_acc)
    v[m2] = vmax
    a[m2] = 0.0
    tr = t[m3] - t_acc - t_cruise
    s[m3] = d_acc + vmax * t_cruise + vmax * tr - 0.5 * acc * tr**2
    v[m3] = vmax - acc * tr
    a[m3] = -acc
    return p0 + d * s, d * v, d * a


def ar1(innovations: npt.ArrayLike, corr: float, start: float) -> Array:
    """The AR(1) series ``x[k] = innovations[k] + corr * x[k - 1]`` with ``x[-1] = start``.

    The same float operations, bit for bit, as ``scipy.signal.lfilter([1], [1, -corr], innovations,
    zi=[corr * start])[0]`` (without importing scipy.signal: 1.9 s here).

    >>> ar1([1.0, 0.0, 0.0], 0.5, 2.0).tolist()
    [2.0, 1.0, 0.5]
    """
    e = np.asarray(innovations, dtype=float).reshape(-1)
    c = float(corr)
    return np.fromiter(accumulate(e.tolist(), lambda y, x: x + c * y, initial=float(start)), float, e.size + 1)[1:]


def synthetic_cycle(
    speeds: Sequence[float] = (10, 20, 30, 40, 50, 80, 120, 160),
    *,
    wear: float = 20.0,
    temperature: float = 40.0,
    load: float = 0.1,
    rate: float = 2000.0,
    gear_ratio: float = 100.0,
    torque_scale: float = 200.0,
    window_center: float = 0.0,
    window_half_width: float = 0.1,
    acceleration: float = 20.0,
    settle: float = 0.05,
    inertia: float = 0.002,
    noise_std: float = 0.01,
    noise_corr: float = 0.9,
    velocity_noise: float = 0.0,
    status_rate: float = 10.0,
    cycle_id: int = 1,
    joint_name: str = "joint_1",
    t0: float = 100.0,
    temperature_rate: float = 0.0,
    model: Model | None = None,
    params: Parameters | str = "ref-2011r",
    seed: int = 0,
) -> SyntheticCycle:
    """One test cycle at ``speeds`` (motor side, rad/s) as joint-side samples at ``rate`` Hz.

    ``acceleration`` is joint side (rad/s²); ``settle`` (rad) of constant speed
    precede and follow the window; ``inertia`` is in normalized torque per
    rad/s² (joint side); noise is AR(1) with marginal std ``noise_std``
    (normalized) and lag-one correlation ``noise_corr``. ``temperature_rate``
    > 0 adds temperature samples at that rate.
    """
    rng = np.random.default_rng(seed)
    m = model if model is not None else paper_wear_model()
    p = load_parameter_set(params) if isinstance(params, str) else params
    dt = 1.0 / rate
    pos_chunks: list[Array] = []
    vel_chunks: list[Array] = []
    acc_chunks: list[Array] = []
    statuses: list[CycleStatus] = []
    t_cursor = t0
    current = window_center - window_half_width - 0.2
    pos_chunks.append(np.full(int(0.2 * rate), current))
    vel_chunks.append(np.zeros(int(0.2 * rate)))
    acc_chunks.append(np.zeros(int(0.2 * rate)))
    t_cursor += pos_chunks[-1].size * dt
    n_total = len(speeds)
    phase_marks: list[tuple[float, int, CyclePhase, float]] = []  # (stamp, speeds_done, phase, speed)
    for k, v_m in enumerate(speeds):
        v_j = float(v_m) / gear_ratio
        ext = v_j**2 / (2 * acceleration) + settle
        s0 = window_center - window_half_width - ext
        s1 = window_center + window_half_width + ext
        legs = [(current, s0, max(v_j, 0.2), PHASE_APPROACH), (s0, s1, v_j, PHASE_FORWARD),
                (s1, s0, v_j, PHASE_REVERSE)]
        for a_pos, b_pos, vmax, phase in legs:
            phase_marks.append((t_cursor, k, phase, float(v_m)))
            if abs(b_pos - a_pos) < 1e-9:
                continue
            pp, vv, aa = _trapezoid(a_pos, b_pos, vmax, acceleration, dt)
            pos_chunks.append(pp)
            vel_chunks.append(vv)
            acc_chunks.append(aa)
            t_cursor += pp.size * dt
        current = s0
        phase_marks.append((t_cursor, k, PHASE_SETTLE, float(v_m)))
        rest = np.full(int(0.05 * rate), current)
        pos_chunks.append(rest)
        vel_chunks.append(np.zeros(rest.size))
        acc_chunks.append(np.zeros(rest.size))
        t_cursor += rest.size * dt
    t_done = t_cursor
    tail = np.full(int(1.0 * rate), current)
    pos_chunks.append(tail)
    vel_chunks.append(np.zeros(tail.size))
    acc_chunks.append(np.zeros(tail.size))

    pos = np.concatenate(pos_chunks)
    vel = np.concatenate(vel_chunks)
    acc = np.concatenate(acc_chunks)
    n = pos.size
    stamps: Array = t0 + np.arange(n, dtype=float) * dt
    v_motor = vel * gear_ratio
    friction = m.evaluate(p, speed=np.abs(v_motor), load_torque=np.abs(load * np.cos(pos)),
                          temperature=temperature, wear=wear)
    innov = rng.normal(0.0, noise_std * math.sqrt(1 - noise_corr**2), n)
    x0 = rng.normal(0.0, noise_std)
    noise = ar1(innov, noise_corr, x0)
    u = load * np.cos(pos) + np.sign(vel) * friction + inertia * acc + noise
    if velocity_noise > 0:
        vel = vel + rng.normal(0.0, velocity_noise, n)

    # status stream: every change of (speeds_done, phase), plus periodic repeats
    def status(ts: float, state: CycleState, phase: CyclePhase, v_m: float, k: int) -> CycleStatus:
        return CycleStatus(cycle_id=cycle_id, state=state, phase=phase, current_speed=v_m, speeds_done=k,
                           speeds_total=n_total, window_center=window_center, window_half_width=window_half_width,
                           joint_name=joint_name, stamp=float(ts))

    for ts, k, phase, v_m in phase_marks:
        statuses.append(status(ts, CycleState.RUNNING, phase, v_m, k))
    periodic = np.arange(t0, t_done, 1.0 / status_rate)
    mark_t = np.array([pm[0] for pm in phase_marks])
    for ts in periodic:
        j = int(np.searchsorted(mark_t, ts, side="right")) - 1
        if j < 0:
            continue
        _, k, phase, v_m = phase_marks[j]
        statuses.append(status(float(ts), CycleState.RUNNING, phase, v_m, k))
    for ts in (t_done, *np.arange(t_done + 1.0 / status_rate, stamps[-1], 1.0 / status_rate)):
        statuses.append(status(float(ts), CycleState.DONE, PHASE_NONE, 0.0, n_total))
    statuses.sort(key=lambda s: s.stamp)

    temps: list[tuple[float, float]] = []
    if temperature_rate > 0:
        temps = [(float(ts), float(temperature)) for ts in np.arange(t0, stamps[-1], 1.0 / temperature_rate)]
    sp = np.asarray(speeds, dtype=float)
    tau_true = m.evaluate(p, speed=sp, load_torque=abs(load * math.cos(window_center)), temperature=temperature,
                          wear=wear)
    grid = np.linspace(window_center - window_half_width, window_center + window_half_width, 201)
    return SyntheticCycle(
        stamps=stamps, position=pos, velocity=vel, effort=u * torque_scale, statuses=statuses, temperatures=temps,
        speeds=sp, tau_f_true=np.asarray(tau_true, dtype=float), load_true=abs(load * math.cos(window_center)),
        window_load_true=float(np.mean(np.abs(load * np.cos(grid)))), info={"t_done": t_done},
    )


@dataclass
class SyntheticRobotCycle:
    """A robot cycle: every joint tested in turn under one cycle id, the others held still.

    ``position``, ``velocity``, ``effort`` are ``(samples, joints)``, columns in
    the order of ``joints`` (one JointState per row). ``statuses`` are the
    robot cycle's statuses in stamp order: the joint under test is their
    ``joint_name``, ``joints`` every joint, ``joints_done`` the joints finished
    before it (``TestCycleStatus.joints_done``). ``temperatures`` are ``(stamp, celsius,
    joint)`` (``Temperature.header.frame_id`` = the joint). ``cycles`` are the
    one-joint cycles it is made of (the truth of each joint).
    """

    joints: list[str]
    stamps: Array
    position: Array
    velocity: Array
    effort: Array
    statuses: list[CycleStatus]
    temperatures: list[tuple[float, float, str]]
    cycles: dict[str, SyntheticCycle]


def synthetic_robot_cycle(
    joints: Sequence[str],
    wears: Sequence[float],
    speeds: Sequence[float] = (30, 45, 60),
    *,
    cycle_id: int = 1,
    t0: float = 100.0,
    rate: float = 500.0,
    load: float = 0.1,
    torque_scale: float = 200.0,
    hold_noise_std: float = 0.002,
    seed: int = 0,
    torque_scales: Sequence[float] | None = None,
    temperatures: Sequence[float] | None = None,
    **kwargs: object,
) -> SyntheticRobotCycle:
    """One robot cycle of ``joints`` (wear ``wears[k]`` for joint k) as docs/robot.md describes it.

    Joint k is tested by :func:`synthetic_cycle` (``speeds``, seed ``seed + k``, other keyword
    arguments passed on) starting right after joint k-1's last sample; while it moves, every
    other joint holds its position (velocity 0, effort the gravity load plus white noise of
    ``hold_noise_std``, normalized). ``torque_scales`` and ``temperatures`` (one per joint)
    override ``torque_scale`` and the ``temperature`` keyword per joint. Deterministic in ``seed``.
    """
    names = [str(j) for j in joints]
    if len(names) != len(wears) or not names:
        raise ValueError(f"synthetic_robot_cycle: {len(names)} joints and {len(wears)} wears; need one wear per joint")
    scales = [float(torque_scale)] * len(names) if torque_scales is None else [float(x) for x in torque_scales]
    if len(scales) != len(names) or (temperatures is not None and len(temperatures) != len(names)):
        raise ValueError("synthetic_robot_cycle: torque_scales and temperatures need one value per joint")
    rng = np.random.default_rng(seed + 7919)
    cycles: dict[str, SyntheticCycle] = {}
    t_cursor = float(t0)
    for k, (j, w) in enumerate(zip(names, wears)):
        extra = dict(kwargs)
        if temperatures is not None:
            extra["temperature"] = float(temperatures[k])
        c = synthetic_cycle(speeds, wear=float(w), rate=rate, load=load, torque_scale=scales[k], cycle_id=cycle_id,
                            joint_name=j, t0=t_cursor, seed=seed + k, **extra)  # type: ignore[arg-type]
        cycles[j] = c
        t_cursor = float(c.stamps[-1]) + 1.0 / rate
    stamps = np.concatenate([cycles[j].stamps for j in names])
    n, m = stamps.size, len(names)
    pos = np.empty((n, m))
    vel = np.zeros((n, m))
    eff = np.empty((n, m))
    start = 0
    spans = []
    for j in names:
        size = cycles[j].stamps.size
        spans.append((start, start + size))
        start += size
    for col, j in enumerate(names):
        c = cycles[j]
        a, b = spans[col]
        pos[:a, col] = c.position[0]
        pos[a:b, col] = c.position
        pos[b:, col] = c.position[-1]
        vel[a:b, col] = c.velocity
        held = np.ones(n, dtype=bool)
        held[a:b] = False
        eff[a:b, col] = c.effort
        eff[held, col] = (load * np.cos(pos[held, col])
                          + rng.normal(0.0, hold_noise_std, int(held.sum()))) * scales[col]
    statuses = [replace(st, joints=tuple(names), joints_done=k) for k, j in enumerate(names) for st in cycles[j].statuses]
    temps = [(t, c, j) for j in names for t, c in cycles[j].temperatures]
    return SyntheticRobotCycle(joints=names, stamps=stamps, position=pos, velocity=vel, effort=eff,
                               statuses=sorted(statuses, key=lambda s: s.stamp),
                               temperatures=sorted(temps, key=lambda s: s[0]), cycles=cycles)
