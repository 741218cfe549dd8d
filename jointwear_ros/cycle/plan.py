"""Test-cycle planning and limit checks (pure).

For each speed ``v`` (motor side; joint ``w = v / gear_ratio``) the cycle

1. approaches ``A = c - h - r(w)`` (from wherever the joint is),
2. settles, sweeps forward ``A -> B = c + h + r(w)`` at ``w``, settles,
3. sweeps in reverse ``B -> A`` at ``w``, settles,

where ``c`` is the window centre, ``h`` its half width and the **run-up**
``r(w) = w^2 / (2 a) + w * steady_time`` is the distance to accelerate at ``a``
and then hold the speed for ``steady_time`` before the window, so the speed is
constant (the velocity loop settled) everywhere inside ``[c - h, c + h]``; the
same distance after the window is where the joint brakes.

**Stopping allowance.** A velocity command holds until the next control update,
so a joint stops past its target by what it travels while the update is late
and while its velocity loop follows the braking command. Every planned
position of a speed (its sweep start ``A`` and end ``B``, reached by the sweeps
at ``w`` and ``A`` also by the approach) therefore stays
``limit_margin + s(w)`` inside the joint limits, with the allowance

``s(w) = max(w, approach_speed) * (control_period + reaction_time + velocity_lag)``

where ``control_period`` is the time between control updates (the node's
``1 / command_rate``), ``reaction_time`` the lateness of one update the plan
allows for (a starved process, a late joint state; in the node's clock, so sim
time when the simulator runs faster than real time) and ``velocity_lag`` how
long the joint's velocity loop keeps the old speed after the command changes.
A speed whose positions do not fit is refused before anything moves, with the
allowance in the reason. The runner, in addition, brakes early by its own
measured update interval (:mod:`jointwear_ros.cycle.runner`), so a steadily
slow loop stops at the target and the allowance is left for a sudden stall.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from ..contract import RefusalReason
from ..errors import JointwearError
from ..settings import check_ranges, setting

__all__ = [
    "DEFAULT_SPEEDS",
    "CycleConfig",
    "CyclePlan",
    "CycleRequestError",
    "SpeedPlan",
    "move_duration",
    "plan_cycle",
    "run_up",
    "stop_allowance",
]

#: Default cycle speeds, motor side, rad/s (the project's shared defaults).
DEFAULT_SPEEDS: tuple[float, ...] = (10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0, 160.0)


class CycleRequestError(JointwearError):
    """A test-cycle request cannot be run as asked (the message says why and what to do).

    ``reason`` is the machine-readable kind (``RunTestCycle.Response.reason``), so a caller decides
    what to do (retry, give up) without reading the text.
    """

    def __init__(self, message: str, reason: RefusalReason = RefusalReason.BAD_REQUEST) -> None:
        super().__init__(message)
        self.reason = RefusalReason(reason)


@dataclass(frozen=True)
class CycleConfig:
    """Settings of the test cycle (defaults: the shared defaults of the project).

    A field declared with :func:`~jointwear_ros.settings.setting` is also a parameter of the
    ``test_cycle`` node (its description, unit, range, per-joint and read-only flags in the field
    metadata; ``settings.declarations`` and ``settings.from_mapping`` build the node's declarations and
    the config from it); ``joint_name``, ``control_period`` (the node's ``1 / command_rate``),
    ``position_tolerance`` and ``move_timeout_factor`` are not parameters.

    Attributes
    ----------
    joint_name, gear_ratio
        The joint driven; motor speed = joint speed × gear_ratio.
    speeds
        Default speeds, motor side, rad/s.
    window_half_width, position
        Observation window half width and default centre, joint side, rad.
    joint_limits
        Allowed joint positions, rad; every planned position must stay
        ``limit_margin`` plus the stopping allowance of its speed inside
        (:func:`stop_allowance`).
    limit_margin
        Fixed distance every planned position stays inside the limits, rad.
    control_period
        Time between two control updates of the runner, s (the node's
        ``1 / command_rate``).
    reaction_time
        Lateness of one control update beyond ``control_period`` that the
        plan allows for, s (node clock): while an update is late the joint
        keeps its commanded speed.
    velocity_lag
        Time the joint's velocity loop takes to follow a braking command, s
        (the joint keeps travelling at about its old speed that long).
    max_speed
        Largest allowed speed, motor side, rad/s.
    acceleration
        Joint acceleration of every move, rad/s^2.
    approach_speed
        Joint speed of approach moves, rad/s.
    steady_time
        Time at constant speed before the window, s (part of the run-up).
    settle_time
        Time at rest after each move, s.
    state_timeout
        A joint state older than this (s) trips the watchdog.
    speed_tolerance
        Relative speed error allowed at the window start (0.05 = 5 %).
    effort_limit
        Largest allowed ``|effort|``, N·m joint side.
    position_tolerance
        A move has arrived within this distance of its target, rad.
    approach_tolerance
        The joint must stand within this distance of a sweep start before the
        sweep begins (else the approach is repeated), rad.
    move_timeout_factor
        A move taking longer than this × its planned duration + 2 s fails.
    min_speed
        Slowest speed a cycle sweeps, motor side, rad/s (a crawl of 1e-6 rad/s
        would plan a cycle of ~4e7 s).
    max_speeds
        Most speeds one request may ask for (every status message carries the
        plan; the estimators gain little beyond a few tens).
    max_duration
        Longest planned cycle, s.
    """

    joint_name: str = "joint_1"
    gear_ratio: float = setting(100.0, description="motor speed / joint speed", range=(1e-3, 1e6), per_joint=True,
                                read_only=True)
    speeds: tuple[float, ...] = setting(DEFAULT_SPEEDS, description="default speeds, motor side, rad/s",
                                        unit="rad/s", per_joint=True)
    window_half_width: float = setting(0.1, description="observation window half width, joint rad", unit="rad",
                                       range=(1e-4, 10.0), per_joint=True)
    position: float = setting(0.0, description="default window centre, joint rad", unit="rad",
                              range=(-100.0, 100.0), per_joint=True)
    joint_limits: tuple[float, float] = setting((-1.5, 1.5), description="allowed joint positions [low, high], rad",
                                                unit="rad", per_joint=True)
    max_speed: float = setting(280.0, description="largest allowed speed, motor side, rad/s", unit="rad/s",
                               range=(1e-3, 1e6), per_joint=True)
    acceleration: float = setting(4.0, description="joint acceleration of every move, rad/s^2", unit="rad/s^2",
                                  range=(1e-3, 1e4), per_joint=True)
    approach_speed: float = setting(0.5, description="joint speed of approach moves, rad/s", unit="rad/s",
                                    range=(1e-3, 100.0), per_joint=True)
    steady_time: float = setting(0.3, description="time at constant speed before the window, s", unit="s",
                                 range=(0.0, 100.0), per_joint=True)
    settle_time: float = setting(0.3, description="time at rest after each move, s", unit="s", range=(0.0, 100.0),
                                 per_joint=True)
    limit_margin: float = setting(0.02, description="planned positions stay this far inside the limits, rad",
                                  unit="rad", range=(0.0, 10.0), per_joint=True)
    control_period: float = 0.01  # the node's 1 / command_rate
    reaction_time: float = setting(
        0.1, description="lateness of one control update (s, node time) the plan allows for: each speed's positions "
        "also keep the stopping allowance speed x (1/command_rate + reaction_time + velocity_lag) inside the limits",
        unit="s", range=(0.0, 10.0), per_joint=True)
    velocity_lag: float = setting(0.02, description="time the joint's velocity loop takes to follow a braking "
                                  "command, s (part of the stopping allowance)", unit="s", range=(0.0, 10.0),
                                  per_joint=True)
    state_timeout: float = setting(0.25, description="watchdog: joint state older than this (s) stops the cycle",
                                   unit="s", range=(1e-3, 100.0))
    speed_tolerance: float = setting(0.05, description="watchdog: relative speed error allowed at the window start",
                                     range=(1e-4, 10.0), per_joint=True)
    effort_limit: float = setting(150.0, description="watchdog: largest allowed |effort|, N·m", unit="N·m",
                                  range=(1e-3, 1e9), per_joint=True)
    position_tolerance: float = 1e-3
    approach_tolerance: float = setting(0.01, description="the joint must stand this close to a sweep start, rad",
                                        unit="rad", range=(1e-4, 1.0), per_joint=True)
    move_timeout_factor: float = 3.0
    min_speed: float = setting(1.0, description="smallest allowed speed, motor side, rad/s", unit="rad/s",
                               range=(1e-3, 1e6), per_joint=True)
    max_speeds: int = setting(32, description="most speeds in one cycle", range=(1, 10_000))
    max_duration: float = setting(3600.0, description="longest planned cycle (all joints), s", unit="s",
                                  range=(1.0, 1e6))

    def check(self) -> None:
        """Raise :class:`CycleRequestError` on settings that cannot plan a cycle: a setting outside its
        declared range (:func:`~jointwear_ros.settings.check_ranges`), then what no one range says."""
        check_ranges(self, CycleRequestError, "test cycle setting")
        for name in ("position_tolerance", "move_timeout_factor", "control_period"):  # not node parameters
            val = getattr(self, name)
            if not (math.isfinite(val) and val > 0):
                raise CycleRequestError(f"test cycle setting {name} must be finite and > 0, got {val}")
        if not self.min_speed <= self.max_speed:
            raise CycleRequestError(
                f"test cycle setting min_speed {self.min_speed:g} rad/s must not exceed max_speed {self.max_speed:g} rad/s"
            )
        lo, hi = self.joint_limits
        if not (math.isfinite(lo) and math.isfinite(hi) and lo + 2 * self.limit_margin < hi):
            raise CycleRequestError(
                f"joint_limits [{lo}, {hi}] must be finite with low + 2 × limit_margin < high"
            )


def run_up(velocity: float, config: CycleConfig) -> float:
    """Distance (rad) to reach ``velocity`` (joint rad/s) and hold it ``steady_time`` before the window."""
    w = abs(velocity)
    return w * w / (2.0 * config.acceleration) + w * config.steady_time


def stop_allowance(velocity: float, config: CycleConfig) -> float:
    """Distance (rad) a joint may travel past a target reached at ``velocity`` (joint rad/s) before it stops.

    ``max(|velocity|, approach_speed) * (control_period + reaction_time + velocity_lag)``: the travel
    while one control update is late by up to ``reaction_time`` and while the velocity loop follows
    the braking command (the approach speed too: the sweep start is also the approach target).
    See the module docstring.
    """
    w = max(abs(velocity), config.approach_speed)
    return w * (config.control_period + config.reaction_time + config.velocity_lag)


def move_duration(distance: float, cruise: float, accel: float) -> float:
    """Time (s) of a trapezoidal move over ``distance`` at ``cruise`` speed and ``accel``."""
    d = abs(distance)
    if d == 0.0:
        return 0.0
    if d >= cruise * cruise / accel:
        return d / cruise + cruise / accel
    return 2.0 * math.sqrt(d / accel)


@dataclass(frozen=True)
class SpeedPlan:
    """One speed of the cycle: the sweep between ``start`` and ``end`` (joint side, rad)."""

    speed: float  # motor side, rad/s
    velocity: float  # joint side, rad/s
    start: float  # A = c - h - run-up
    end: float  # B = c + h + run-up
    run_up: float
    duration: float  # approach + sweeps + settles, s


@dataclass(frozen=True)
class CyclePlan:
    """A validated cycle: the speeds in order, the window, the estimated duration."""

    speeds: tuple[SpeedPlan, ...]
    center: float
    half_width: float
    start_position: float
    duration: float

    @property
    def extent(self) -> tuple[float, float]:
        """Lowest and highest planned joint position, rad."""
        return (min(s.start for s in self.speeds), max(s.end for s in self.speeds))

    def summary(self) -> str:
        """One line: speeds, window, positions used, duration."""
        sp = [s.speed for s in self.speeds]
        lo, hi = self.extent
        return (
            f"{len(sp)} speed(s) {', '.join(f'{v:g}' for v in sp)} rad/s (motor), window "
            f"{self.center:g} ± {self.half_width:g} rad, positions [{lo:.3f}, {hi:.3f}] rad, "
            f"about {self.duration:.1f} s"
        )


def plan_cycle(
    config: CycleConfig,
    speeds: Sequence[float] | None = None,
    center: float | None = None,
    start_position: float | None = None,
) -> CyclePlan:
    """Validate a request and plan it; raise :class:`CycleRequestError` with the reason if it cannot run.

    Parameters
    ----------
    config
        The cycle settings.
    speeds
        Motor-side speeds, rad/s; ``None`` or empty: ``config.speeds``.
    center
        Window centre, joint rad; ``None``: ``config.position``.
    start_position
        Where the joint is now (for the first approach); ``None``: the centre.
    """
    config.check()
    sp = list(config.speeds if speeds is None or len(speeds) == 0 else speeds)
    c = config.position if center is None else float(center)
    if not math.isfinite(c):
        raise CycleRequestError(f"position (window centre) {c} is not finite; give a joint angle in rad")
    lo, hi = config.joint_limits
    m = config.limit_margin
    h = config.window_half_width
    if not sp:
        raise CycleRequestError("no speeds to sweep: give at least one speed (motor side, rad/s) or set speeds", RefusalReason.BAD_SPEEDS)
    if len(sp) > config.max_speeds:
        raise CycleRequestError(
            f"{len(sp)} speeds asked for; at most max_speeds = {config.max_speeds} per cycle: split them over "
            "several cycles",
            RefusalReason.BAD_SPEEDS,
        )
    for i, v in enumerate(sp):
        if not math.isfinite(v):
            raise CycleRequestError(f"speed #{i + 1} = {v} is not finite; give speeds in rad/s (motor side)", RefusalReason.BAD_SPEEDS)
        if v <= 0.0:
            raise CycleRequestError(
                f"speed #{i + 1} = {v:g} rad/s must be > 0 (motor side; the cycle sweeps both directions itself)",
                RefusalReason.BAD_SPEEDS,
            )
        if v < config.min_speed:
            raise CycleRequestError(
                f"speed #{i + 1} = {v:g} rad/s (motor side) is below min_speed {config.min_speed:g} rad/s, the "
                "slowest speed the cycle sweeps",
                RefusalReason.BAD_SPEEDS,
            )
        if v > config.max_speed:
            raise CycleRequestError(
                f"speed #{i + 1} = {v:g} rad/s (motor side) exceeds max_speed {config.max_speed:g} rad/s",
                RefusalReason.BAD_SPEEDS,
            )
    if not (lo + m <= c - h and c + h <= hi - m):
        raise CycleRequestError(
            f"window {c:g} ± {h:g} rad is outside the joint limits [{lo:g}, {hi:g}] rad "
            f"(margin {m:g}); choose a position nearer the middle",
            RefusalReason.OUTSIDE_LIMITS,
        )
    pos = c if start_position is None else float(start_position)
    if not math.isfinite(pos):
        raise CycleRequestError(f"current joint position {pos} is not finite; check /joint_states", RefusalReason.OUTSIDE_LIMITS)
    if not lo <= pos <= hi:
        raise CycleRequestError(
            f"joint is at {pos:.3f} rad, outside the limits [{lo:g}, {hi:g}] rad; move it inside first",
            RefusalReason.OUTSIDE_LIMITS,
        )
    a = config.acceleration
    plans: list[SpeedPlan] = []
    total = 0.0
    for i, v in enumerate(sp):
        w = v / config.gear_ratio
        r = run_up(w, config)
        s = stop_allowance(w, config)
        start, end = c - h - r, c + h + r
        if start < lo + m + s or end > hi - m - s:
            raise CycleRequestError(
                f"speed #{i + 1} = {v:g} rad/s needs positions [{start:.3f}, {end:.3f}] rad (window {c:g} ± {h:g} "
                f"plus run-up {r:.3f} rad), beyond the joint limits [{lo:g}, {hi:g}] rad less margin {m:g} and "
                f"stopping allowance {s:.3f} rad (travel in control_period + reaction_time + velocity_lag = "
                f"{config.control_period + config.reaction_time + config.velocity_lag:g} s); "
                "use a lower speed or a position nearer the middle",
                RefusalReason.OUTSIDE_LIMITS,
            )
        dur = (
            move_duration(start - pos, config.approach_speed, a)
            + 2.0 * move_duration(end - start, w, a)
            + 3.0 * config.settle_time
        )
        plans.append(SpeedPlan(float(v), w, start, end, r, dur))
        total += dur
        pos = start
    if total > config.max_duration:
        raise CycleRequestError(
            f"the cycle would take about {total:.0f} s, more than max_duration {config.max_duration:g} s; "
            "use fewer or faster speeds",
            RefusalReason.BAD_SPEEDS,
        )
    return CyclePlan(tuple(plans), c, h, float(c if start_position is None else start_position), total)
