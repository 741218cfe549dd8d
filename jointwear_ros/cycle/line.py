"""Every joint at once: a test cycle along one straight line in joint space and back (pure).

Why it works (``docs/nodes-sim-cycle.md``, ARMS.md): at a configuration ``q`` with every joint
at a constant velocity ``v``, the arm's torques are ``u± = C(q, ±v)(±v) + g(q) + τ_f(±v)``; the
Coriolis/centrifugal term is quadratic in ``v`` and gravity depends on ``q`` only, so
``(u⁺ − u⁻)/2 = τ_f`` for **every** joint, as in the paper's Eq. (5) for one joint. The
line cycle therefore moves every requested joint at once, forward along a straight line and
back along the same line, each joint at its own constant speed inside its own window.

**The plan** (:func:`plan_line_cycle`). Speed step ``k`` gives each joint ``j`` a motor speed
``s_jk`` from its own speed set (the request's speeds, else the joint's configured ``speeds``);
the cycle has as many steps ``K`` as the longest set, and a shorter set of ``n_j`` speeds is
**stretched** over the steps: ``s_jk = set_j[⌊k · n_j / K⌋]`` (each of its speeds is swept at
about ``K / n_j`` consecutive steps, in its order). Every joint moves at every step (the line
stays a line of all joints), a joint with fewer speeds observes each of them about ``K / n_j``
times, and sets given in the same order (slow to fast, say) pair slow speeds with slow ones,
which keeps the windows of step ``k`` alike (below). The joint
speed is ``w_jk = s_jk / gear_j`` and the motion of step ``k`` is

    q(σ) = c + σ · w_k        (c: the window centres, one per joint; σ in seconds of cruise)

with one trapezoid in ``σ`` for all joints: cruise ``dσ/dt = 1``, acceleration
``α_k = min_j(acceleration_j / |w_jk|)`` (no joint accelerates faster than its own
``acceleration``; all reach cruise at the same instant, so the path is the line also while
accelerating). The window in ``σ`` is ``±T_k/2`` with ``T_k/2 = max_j(window_half_width_j / |w_jk|)``:
**every** joint covers at least its own ``window_half_width`` (its window at this step is
``h_jk = |w_jk| · T_k/2``), so every joint is at least as long at constant speed inside its
window as in its one-joint cycle and its observation scatters no more; the joint that needs
the longest sets ``T_k`` and the others' windows widen. The run-up in ``σ`` is
``R_k = 1/(2 α_k) + steady_time`` (the longest ``steady_time`` of the joints), so joint ``j``
runs up ``|w_jk| R_k``, at least its one-joint run-up. The sweep goes from
``start_k = c − S_k w_k`` to ``end_k = c + S_k w_k``, ``S_k = T_k/2 + R_k``, and back.

Every joint's extent ``c_j ± |w_jk| S_k`` must stay ``limit_margin + stop_allowance(w_jk)``
(:func:`~jointwear_ros.cycle.plan.stop_allowance`) inside its ``joint_limits``: the request is
refused before anything moves, naming the joint and the speed. Each joint's own request is
first checked as :func:`~jointwear_ros.cycle.robot.plan_robot_cycle` checks it (unknown or
repeated joints, speeds, windows, positions): the line needs at least the one-joint extents.

Each step: APPROACH (a straight joint-space move from where the arm stands to ``start_k``,
one trapezoid in a path parameter whose speed and acceleration keep every joint within its
``approach_speed`` and ``acceleration``), SETTLE, FORWARD, SETTLE, REVERSE, SETTLE (the longest
``settle_time``), as the one-joint cycle. The plan's ``duration`` is the cell time.

**The runner** (:class:`LineCycleRunner`, fed ``(now, readings)`` like
:class:`~jointwear_ros.cycle.robot.RobotCycleRunner`) follows the planned trajectory in time:
each move is ``q_ref(λ) = P0 + D · λ`` with ``λ(t)`` the trapezoid (a sweep: ``P0`` the line's
start or end, ``D = ±w_k``, ``λ = σ ± S_k``; an approach: ``P0`` where the arm stood, ``D`` to
the line's start, ``λ`` from 0 to 1), and each joint is commanded

    v_j = D_j · dλ/dt(t + control_period/2) + clip(LINE_GAIN · (P0_j + D_j λ* − q_j), ±c_j)

the reference speed (half an update ahead: the mean over the interval the command holds) plus
a position correction with gain ``LINE_GAIN`` = 5 1/s (a time constant of 0.2 s, twenty
control periods at 100 Hz, far below a velocity loop's bandwidth) toward the **nearest point
of the line**: ``λ*`` is the measured configuration projected on the line
(``λ* = Σ_j (q_j − P0_j) D_j / Σ_j D_j²``). A lag along the line (every joint a little behind
its reference, e.g. while the velocity loops follow the acceleration) moves no joint off the
line and is left alone, so inside the windows each joint runs at its own ``w_jk`` and not at a
speed that chases the clock; what the correction removes is a joint's lag *relative to the
others* (velocity loops that lag differently, a joint pushed by another), which would bend the
path. It is clipped to ``c_j`` = half the joint's ``speed_tolerance`` times its sweep speed
(a sweep: the correction cannot take the speed out of the observer's band) or a fifth of its
``approach_speed`` (an approach). Once the reference has ended, the correction (clipped to a
fifth of ``approach_speed``) pulls toward the move's target, and the move has arrived when
every joint is within ``position_tolerance`` of its target or past it along the move. Settles
command zero (as in the one-joint cycle); a sweep starts only when every joint stands within
its ``approach_tolerance`` of the line's start, else the approach is repeated at half the
speed (at most ``MAX_APPROACHES`` times).

**The reference's clock** runs with the controller's clock, but by at most ``reference_step``
(``control_period + reaction_time``, 0.11 s by default) per update, and never more than that behind
the arm's progress along the line (the inverse of the trapezoid at ``λ*``). On sim time a starved
controller can see the clock jump: the simulator ran on while every joint was commanded to rest,
and the sweep's first command reached the arm late. A profile that ran on by the jump would
decelerate inside the windows (the observer rejects "speed not constant"); it now waits for the
arm. An arm that did move on through a stalled update (a real cell's clock) keeps the reference
within ``reference_step`` of it, the travel the stopping allowance plans for.

Watchdog over every moving joint (any trip: state FAILED, zero for every joint, the joint and
the reason in the message): a state missing, stale (``state_timeout``, and in wall time when
``wall_ages`` are given) or not finite; a position outside ``joint_limits``; ``|effort|`` above
``effort_limit``; the speed off by more than ``speed_tolerance`` (relative) where the joint
enters its window; a move not finished within ``move_timeout_factor`` × its planned time + 2 s;
a joint farther than ``hold_tolerance`` from the line of the move (the distance of the joint
from the nearest point of the line, the point found by projecting the measured configuration).
A driven joint not in the request is held at zero velocity and watched as a held joint of the
sequential cycle (it may move ``hold_tolerance`` from where the cycle found it).

**Status** (:meth:`LineCycleRunner.statuses`): one :class:`~jointwear_ros.contract.CycleStatus`
per joint per update, in the plan's order: ``joint_name`` that joint, ``current_speed`` its
motor speed ``s_jk``, ``window_center`` its ``c_j``, ``window_half_width`` its ``h_jk``,
``speeds_done = k``, ``speeds_total`` the step count; state, phase and message shared;
``joints`` the plan's joints and ``joints_done`` the joint's index in them. Each joint's
friction observer therefore sees the status stream of a one-joint cycle, and the last joint's
ended status (``joints_done + 1 == len(joints)``) ends the robot cycle for every consumer
(:func:`~jointwear_ros.contract.robot_cycle_over`) when the statuses are published in order.

>>> configs = {j: CycleConfig(joint_name=j) for j in ("joint_1", "joint_2", "joint_3")}
>>> plan = plan_line_cycle(configs, speeds=[40.0, 160.0])
>>> plan.joints, len(plan.steps), round(plan.duration, 1), round(plan.sequential_duration, 1)
(('joint_1', 'joint_2', 'joint_3'), 2, 9.5, 28.5)
>>> configs["joint_1"] = CycleConfig(joint_name="joint_1", speeds=(10.0,))  # 2 s in its window at every step
>>> plan_line_cycle(configs)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
jointwear_ros.cycle.plan.CycleRequestError: joint_2: speed #7 = 120 rad/s needs positions [-1.740, 1.740] rad on the line of 3 joints (window 0 ± 1.200 plus run-up 0.540 rad), beyond the joint limits ...
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..contract import CyclePhase, CycleState, CycleStatus, RefusalReason
from .plan import CycleConfig, CycleRequestError, move_duration, stop_allowance
from .robot import DrivenJoints, JointOutcome, plan_robot_cycle
from .runner import JointReading, SpeedSteps, reading_fault

__all__ = ["LineCycleRunner", "LinePlan", "LineStep", "plan_line_cycle", "trapezoid"]

Phase = CyclePhase


@dataclass(frozen=True)
class LineStep:
    """One speed step of a line cycle; the tuples have one entry per joint of the plan, in its order."""

    speeds: tuple[float, ...]  # s_jk, motor side, rad/s
    velocities: tuple[float, ...]  # w_jk, joint side, rad/s (dq/dσ)
    acceleration: float  # α_k, 1/s (dσ/dt per s)
    window: float  # T_k / 2, s of σ
    run_up: float  # R_k, s of σ
    half_widths: tuple[float, ...]  # h_jk = |w_jk| T_k / 2, rad
    start: tuple[float, ...]  # c - S_k w_k, rad
    end: tuple[float, ...]  # c + S_k w_k, rad
    duration: float  # approach + sweeps + settles, s

    @property
    def reach(self) -> float:
        """``S_k = T_k/2 + R_k``: σ from the centre to either end of the sweep, s."""
        return self.window + self.run_up


@dataclass(frozen=True)
class LinePlan:
    """A validated line cycle: the joints, their window centres and the steps, the planned cell time."""

    joints: tuple[str, ...]
    centers: tuple[float, ...]
    start_positions: tuple[float, ...]
    steps: tuple[LineStep, ...]
    settle_time: float
    duration: float
    sequential_duration: float  # the same request one joint after another (plan_robot_cycle), s

    def speeds_of(self, joint: str) -> tuple[float, ...]:
        """``joint``'s motor speed at each step, rad/s."""
        i = self.joints.index(joint)
        return tuple(s.speeds[i] for s in self.steps)

    def extent(self, joint: str) -> tuple[float, float]:
        """Lowest and highest planned position of ``joint``, rad (its sweeps' ends)."""
        i = self.joints.index(joint)
        ends = [p for s in self.steps for p in (s.start[i], s.end[i])]
        return min(ends), max(ends)

    def summary(self) -> str:
        """One line: the joints, each joint's speeds and window, the duration against one joint after another."""
        parts = []
        for i, j in enumerate(self.joints):
            sp = ", ".join(f"{s.speeds[i]:g}" for s in self.steps)
            lo, hi = self.extent(j)
            parts.append(f"{j}: {sp} rad/s (motor), window {self.centers[i]:g} ± "
                         f"{min(s.half_widths[i] for s in self.steps):.3g}..{max(s.half_widths[i] for s in self.steps):.3g}"
                         f" rad, positions [{lo:.3f}, {hi:.3f}] rad")
        return (f"{len(self.joints)} joints at once along one line, {len(self.steps)} speed step(s): "
                + "; ".join(parts)
                + f"; about {self.duration:.1f} s (one joint after another: {self.sequential_duration:.1f} s)")


def _trapezoid_shape(length: float, cruise: float, accel: float) -> tuple[float, float, float]:
    """(ramp time, peak speed, cruise time) of a rest-to-rest trapezoid over ``length`` > 0: a triangle when
    the length is too short to reach ``cruise``."""
    if length >= cruise * cruise / accel:
        return cruise / accel, cruise, length / cruise - cruise / accel
    ta = math.sqrt(length / accel)
    return ta, accel * ta, 0.0


def trapezoid_time(position: float, length: float, cruise: float, accel: float) -> float:
    """The time at which the rest-to-rest trapezoid of :func:`trapezoid` reaches ``position`` (0 at or before its
    start, its duration at or past its end): the inverse of its position.

    >>> [round(trapezoid_time(trapezoid(t, 2.0, 1.0, 2.0)[0], 2.0, 1.0, 2.0), 6) for t in (0.0, 0.25, 1.0, 2.3)]
    [0.0, 0.25, 1.0, 2.3]
    """
    if length <= 0.0 or position <= 0.0:
        return 0.0
    ta, vp, tc = _trapezoid_shape(length, cruise, accel)
    total = 2.0 * ta + tc
    ramp = 0.5 * accel * ta * ta
    if position >= length:
        return total
    if position < ramp:
        return math.sqrt(2.0 * position / accel)
    if position < length - ramp:
        return ta + (position - ramp) / vp
    return total - math.sqrt(2.0 * (length - position) / accel)


def trapezoid(tau: float, length: float, cruise: float, accel: float) -> tuple[float, float]:
    """Position and speed at time ``tau`` of a rest-to-rest trapezoid over ``length`` (cruise, accel > 0).

    >>> [tuple(round(x, 3) for x in trapezoid(t, 2.0, 1.0, 2.0)) for t in (0.0, 0.25, 1.0, 2.5, 9.0)]
    [(0.0, 0.0), (0.062, 0.5), (0.75, 1.0), (2.0, 0.0), (2.0, 0.0)]
    """
    if length <= 0.0:
        return 0.0, 0.0
    ta, vp, tc = _trapezoid_shape(length, cruise, accel)
    total = 2.0 * ta + tc
    if tau <= 0.0:
        return 0.0, 0.0
    if tau < ta:
        return 0.5 * accel * tau * tau, accel * tau
    if tau < ta + tc:
        return 0.5 * accel * ta * ta + vp * (tau - ta), vp
    if tau < total:
        td = total - tau
        return length - 0.5 * accel * td * td, accel * td
    return length, 0.0


def _approach(configs: Sequence[CycleConfig], frm: Sequence[float], to: Sequence[float],
              slow: float = 1.0) -> tuple[float, float]:
    """(path speed, path acceleration) of a straight move ``frm -> to`` as ``λ`` in [0, 1]: each joint within
    ``slow`` × its approach_speed and its acceleration; (inf, inf) when nothing moves."""
    v = a = math.inf
    for cfg, p, q in zip(configs, frm, to, strict=True):
        d = abs(q - p)
        if d > 0.0:
            v = min(v, slow * cfg.approach_speed / d)
            a = min(a, cfg.acceleration / d)
    return v, a


def plan_line_cycle(
    configs: Mapping[str, CycleConfig],
    joints: Sequence[str] = (),
    speeds: Sequence[float] | None = None,
    positions: Sequence[float] | None = None,
    start_positions: Mapping[str, float] | None = None,
    max_duration: float | None = None,
) -> LinePlan:
    """Check a request for every joint at once and plan it; raise :class:`CycleRequestError` if it cannot run.

    The arguments are those of :func:`~jointwear_ros.cycle.robot.plan_robot_cycle` (see the module docstring
    for the plan). ``max_duration`` bounds the line cycle's duration (each joint's ``max_duration`` too).
    """
    robot = plan_robot_cycle(configs, joints, speeds, positions, start_positions)
    order = robot.joints
    cfgs = [configs[j] for j in order]
    sets = [[s.speed for s in p.speeds] for p in robot.plans]
    centres = [p.center for p in robot.plans]
    pos = [p.start_position for p in robot.plans]
    starts = tuple(pos)
    n_steps = max(len(s) for s in sets)
    steady = max(c.steady_time for c in cfgs)
    settle = max(c.settle_time for c in cfgs)
    steps: list[LineStep] = []
    total = 0.0
    for k in range(n_steps):
        sp = [s[k * len(s) // n_steps] for s in sets]
        w = [v / c.gear_ratio for v, c in zip(sp, cfgs, strict=True)]
        alpha = min(c.acceleration / abs(x) for c, x in zip(cfgs, w, strict=True))
        window = max(c.window_half_width / abs(x) for c, x in zip(cfgs, w, strict=True))
        run = 1.0 / (2.0 * alpha) + steady
        reach = window + run
        start = [c0 - reach * x for c0, x in zip(centres, w, strict=True)]
        end = [c0 + reach * x for c0, x in zip(centres, w, strict=True)]
        for i, (j, cfg) in enumerate(zip(order, cfgs, strict=True)):
            lo, hi = cfg.joint_limits
            m = cfg.limit_margin
            s_allow = stop_allowance(w[i], cfg)
            a, b = min(start[i], end[i]), max(start[i], end[i])
            if a < lo + m + s_allow or b > hi - m - s_allow:
                raise CycleRequestError(
                    f"{j}: speed #{k + 1} = {sp[i]:g} rad/s needs positions [{a:.3f}, {b:.3f}] rad on the line of "
                    f"{len(order)} joints (window {centres[i]:g} ± {abs(w[i]) * window:.3f} plus run-up "
                    f"{abs(w[i]) * run:.3f} rad), beyond the joint limits [{lo:g}, {hi:g}] rad less margin {m:g} and "
                    f"stopping allowance {s_allow:.3f} rad; use a lower speed, a position nearer the middle, or "
                    "sweep the joints one after another (sweep: sequential)",
                    RefusalReason.OUTSIDE_LIMITS,
                )
        v_ap, a_ap = _approach(cfgs, pos, start)
        t_ap = 0.0 if math.isinf(v_ap) else move_duration(1.0, v_ap, a_ap)
        dur = t_ap + 2.0 * move_duration(2.0 * reach, 1.0, alpha) + 3.0 * settle
        steps.append(LineStep(tuple(sp), tuple(w), alpha, window, run,
                              tuple(abs(x) * window for x in w), tuple(start), tuple(end), dur))
        total += dur
        pos = start
    limit = min(c.max_duration for c in cfgs)
    if max_duration is not None:
        limit = min(limit, float(max_duration))
    if total > limit:
        raise CycleRequestError(
            f"the line cycle of {len(order)} joint(s) would take about {total:.0f} s, more than max_duration "
            f"{limit:g} s; use fewer or faster speeds",
            RefusalReason.BAD_SPEEDS,
        )
    return LinePlan(order, tuple(centres), starts, tuple(steps), settle, total, robot.duration)


@dataclass
class _Move:
    origin: tuple[float, ...]  # P0
    direction: tuple[float, ...]  # D (rad per unit of λ)
    length: float  # L (λ from 0 to L)
    cruise: float
    accel: float
    limits: tuple[float, ...]  # the correction's clip per joint, rad/s
    t_start: float
    planned: float
    phase: Phase
    checked: list[bool]  # window start checked, per joint
    t_ref: float = math.nan  # when the reference started (shifted by the runner's reference clock), s
    t_last: float = math.nan  # the previous update, s

    def __post_init__(self) -> None:
        if math.isnan(self.t_ref):
            self.t_ref = self.t_start
        if math.isnan(self.t_last):
            self.t_last = self.t_start

    def target(self) -> list[float]:
        return [p + d * self.length for p, d in zip(self.origin, self.direction, strict=True)]


class LineCycleRunner(SpeedSteps, DrivenJoints):
    """Runs one line cycle at a time (see the module docstring).

    Parameters
    ----------
    configs
        Every joint the node drives (name -> settings), in command order.
    hold_tolerance
        Largest distance of a moving joint from the line of its move, and of a held joint from where the
        cycle found it, rad.
    """

    #: Gain of the position correction toward the reference, 1/s (module docstring).
    LINE_GAIN = 5.0
    #: The correction's clip during a sweep, as a fraction of the joint's speed_tolerance × its sweep speed.
    SWEEP_CORRECTION = 0.5
    #: The correction's clip during an approach, as a fraction of the joint's approach_speed.
    APPROACH_CORRECTION = 0.2

    KIND = "line"

    def __init__(self, configs: Mapping[str, CycleConfig], hold_tolerance: float = 0.02) -> None:
        super().__init__(configs, hold_tolerance)
        self.state = CycleState.IDLE
        self.phase = Phase.NONE
        self.cycle_id = 0
        self.plan: LinePlan | None = None
        self.message = "idle"
        self.results: dict[str, JointOutcome] = {}
        self.fault_joint = ""
        self._commands: dict[str, float] = dict.fromkeys(self.names, 0.0)
        self._cfgs: list[CycleConfig] = []
        self._restart_steps()
        self._move: _Move | None = None
        self._settle_until = 0.0
        self._hold: dict[str, float] = {}
        self._t_start = 0.0
        #: largest distance of any joint from the line of a sweep so far in this cycle, rad
        self.max_deviation = 0.0
        #: updates that came more than reference_step after the one before (the reference waited), this cycle
        self.reference_holds = 0
        self.reference_step = max(c.control_period + c.reaction_time for c in self.configs.values())

    # -- control -------------------------------------------------------------
    @property
    def joint_name(self) -> str:
        """The last joint of the plan (whose ended status ends the robot cycle); the first driven one before any."""
        return self.plan.joints[-1] if self.plan is not None else self.names[0]

    def start(self, plan: LinePlan, cycle_id: int, now: float, positions: Mapping[str, float] | None = None) -> None:
        """Start ``plan``; ``positions`` are where the joints stand (the held joints' references)."""
        if self.running:
            raise RuntimeError("a cycle is already running")
        self.plan = plan
        self._cfgs = [self.configs[j] for j in plan.joints]
        #: the largest step of the reference's clock per update, s: an update late by the planned
        #: reaction_time still advances it in full
        self.reference_step = max(c.control_period + c.reaction_time for c in self._cfgs)
        self.cycle_id = int(cycle_id)
        self.state = CycleState.RUNNING
        self.phase = Phase.APPROACH
        self.fault_joint = ""
        self.message = f"running: {plan.summary()}"
        self._commands = dict.fromkeys(self.names, 0.0)
        self._restart_steps()
        self._t_start = now
        self.max_deviation = 0.0
        self.reference_holds = 0
        self._hold = {j: float(p) for j, p in (positions or {}).items()
                      if j not in plan.joints and math.isfinite(p)}
        self._note_results(CycleState.RUNNING, self.message)

    def _end(self, state: CycleState, message: str) -> None:
        self.state = state
        self.phase = Phase.NONE
        self.message = message
        self._commands = dict.fromkeys(self.names, 0.0)
        self._move = None
        self._note_results(state, message)

    def _note_results(self, state: CycleState, message: str) -> None:
        plan = self.plan
        assert plan is not None
        n = len(plan.steps)
        for j in plan.joints:
            self.results[j] = JointOutcome(self.cycle_id, state, message, min(self.speeds_done, n), n)

    # -- status --------------------------------------------------------------
    @property
    def commands(self) -> dict[str, float]:
        """The velocity command of every driven joint (joint rad/s; 0 for the held ones and when not running)."""
        if not self.running:
            return dict.fromkeys(self.names, 0.0)
        return dict(self._commands)

    def statuses(self) -> list[CycleStatus]:
        """One :class:`~jointwear_ros.contract.CycleStatus` per joint of the plan, in its order (module docstring)."""
        plan = self.plan
        if plan is None:
            cfg = self.configs[self.names[0]]
            return [CycleStatus(joint_name=self.names[0], cycle_id=self.cycle_id, state=self.state,
                                window_center=cfg.position, window_half_width=cfg.window_half_width,
                                message=self.message)]
        n = len(plan.steps)
        step = plan.steps[min(self.speeds_done, n - 1)]
        return [CycleStatus(
            joint_name=j, cycle_id=self.cycle_id, state=self.state, phase=self.phase,
            current_speed=step.speeds[i] if self.running else 0.0, speeds_done=self.speeds_done, speeds_total=n,
            window_center=plan.centers[i], window_half_width=step.half_widths[i], message=self.message,
            joints=plan.joints, joints_done=i) for i, j in enumerate(plan.joints)]

    def status(self) -> CycleStatus:
        """The last joint's status (the one whose end ends the robot cycle)."""
        return self.statuses()[-1]

    # -- the machine ---------------------------------------------------------
    def update(self, now: float, readings: Mapping[str, JointReading | None],
               wall_ages: Mapping[str, float] | None = None) -> dict[str, float]:
        """Advance; return the command of every driven joint (joint rad/s; all 0 unless running).

        ``readings``: the latest reading of each driven joint; ``wall_ages``: their wall-clock ages (give them
        when ``now`` is simulated time, see :meth:`~jointwear_ros.cycle.CycleRunner.update`).
        """
        plan = self.plan
        if not self.running or plan is None:
            return self.commands
        ages = wall_ages or {}
        for j in self.names:
            held = j not in plan.joints
            reason = reading_fault(j, self.configs[j], now, readings.get(j), ages.get(j),
                                    "held joint" if held else "joint")
            if reason is None and held:
                r = readings[j]
                assert r is not None
                ref = self._hold.setdefault(j, r.position)
                if abs(r.position - ref) > self.hold_tolerance:
                    reason = (f"held joint {j} moved {r.position - ref:+.3f} rad from {ref:.3f} rad "
                              f"(hold_tolerance {self.hold_tolerance:g} rad)")
            if reason is not None:
                self.fail(f"watchdog: {reason}", j)
                return self.commands
        q = []
        v = []
        for j in plan.joints:
            r = readings[j]
            assert r is not None
            q.append(r.position)
            v.append(r.velocity)
        out = self._advance(now, q, v)
        self._commands = dict.fromkeys(self.names, 0.0)
        if self.running:
            for j, x in zip(plan.joints, out, strict=True):
                self._commands[j] = x
        return self.commands

    def _trip(self, joint: str, reason: str) -> list[float]:
        assert self.plan is not None
        self.fail(f"watchdog: {reason}", joint)
        return [0.0] * len(self.plan.joints)

    def _advance(self, now: float, q: list[float], v: list[float]) -> list[float]:
        plan = self.plan
        assert plan is not None
        cfgs = self._cfgs
        zero = [0.0] * len(q)
        while True:
            if self.speeds_done >= len(plan.steps):
                self._end(CycleState.DONE, f"done: {len(plan.joints)} joints at once, {len(plan.steps)} speed "
                             f"step(s) in {now - self._t_start:.1f} s")
                return zero
            step = plan.steps[self.speeds_done]
            k = self._step  # 0 approach, 1 settle, 2 forward, 3 settle, 4 reverse, 5 settle
            if k in (1, 3, 5):
                if not self._settling:
                    self._settling = True
                    self._settle_until = now + plan.settle_time
                self.phase = Phase.SETTLE
                if now < self._settle_until:
                    return zero
                if k == 1:
                    off = [(abs(x - s), c.approach_tolerance, j)
                           for x, s, c, j in zip(q, step.start, cfgs, plan.joints, strict=True)]
                    worst = max(off, key=lambda o: o[0] / o[1])
                    if worst[0] > worst[1]:
                        self._approaches += 1
                        if self._approaches > self.MAX_APPROACHES:
                            return self._trip(worst[2], (
                                f"{worst[2]} at {q[plan.joints.index(worst[2])]:.3f} rad after {self.MAX_APPROACHES} "
                                f"approaches, not within {worst[1]:g} rad of the line's start "
                                f"{step.start[plan.joints.index(worst[2])]:.3f} rad"))
                        self._approach_again()
                        continue
                self._next_step()
                continue
            if self._move is None:
                mv = self._new_move(now, k, step, q)
                if mv is None:  # already at the line's start
                    self._next_step()
                    continue
                self._move = mv
            mv = self._move
            self.phase = mv.phase
            return self._follow(now, mv, step, q, v)

    def _new_move(self, now: float, k: int, step: LineStep, q: list[float]) -> _Move | None:
        cfgs = self._cfgs
        if k == 0:
            slow = 0.5**self._approaches
            vp, ap = _approach(cfgs, q, step.start, slow)
            if math.isinf(vp):
                return None
            direction = tuple(s - x for s, x in zip(step.start, q, strict=True))
            limits = tuple(self.APPROACH_CORRECTION * slow * c.approach_speed for c in cfgs)
            return _Move(tuple(q), direction, 1.0, vp, ap, limits, now, move_duration(1.0, vp, ap), Phase.APPROACH,
                         [True] * len(q))
        sign = 1.0 if k == 2 else -1.0
        origin = step.start if k == 2 else step.end
        length = 2.0 * step.reach
        limits = tuple(self.SWEEP_CORRECTION * c.speed_tolerance * abs(w) for c, w in zip(cfgs, step.velocities,
                                                                                         strict=True))
        return _Move(tuple(origin), tuple(sign * w for w in step.velocities), length, 1.0, step.acceleration,
                     limits, now, move_duration(length, 1.0, step.acceleration),
                     Phase.FORWARD if k == 2 else Phase.REVERSE, [False] * len(q))

    def _follow(self, now: float, mv: _Move, step: LineStep, q: list[float], v: list[float]) -> list[float]:
        plan = self.plan
        assert plan is not None
        cfgs = self._cfgs
        # distance from the line of the move (the nearest point: the projection of q)
        dd = sum(d * d for d in mv.direction)
        lam = sum((x - p) * d for x, p, d in zip(q, mv.origin, mv.direction, strict=True)) / dd
        # the reference's clock: it runs with ``now`` but at most reference_step per update (a clock that jumped
        # while the arm, commanded to rest, stood still must not run the profile on without the arm, else its
        # deceleration falls inside the windows), and never more than reference_step behind the arm along the
        # line (an arm that moved on through a stalled update is not commanded past its end: it stays within
        # reference_step, as the stopping allowance plans)
        gap = now - mv.t_last
        if gap > self.reference_step:
            mv.t_ref += gap - self.reference_step
            self.reference_holds += 1
        mv.t_last = now
        tau = now - mv.t_ref
        behind = trapezoid_time(lam, mv.length, mv.cruise, mv.accel) - self.reference_step
        if behind > tau:
            tau = behind
            mv.t_ref = now - tau
        for i, j in enumerate(plan.joints):
            dev = abs(q[i] - mv.origin[i] - lam * mv.direction[i])
            if mv.phase != Phase.APPROACH:
                self.max_deviation = max(self.max_deviation, dev)
            if dev > self.hold_tolerance:
                return self._trip(j, f"{j} {dev:.3f} rad off the line of the {mv.phase.name.lower()} move "
                                     f"(hold_tolerance {self.hold_tolerance:g} rad) at {q[i]:.3f} rad")
        if mv.phase != Phase.APPROACH:
            for i, j in enumerate(plan.joints):
                if mv.checked[i]:
                    continue
                d = 1.0 if mv.direction[i] > 0 else -1.0
                edge = plan.centers[i] - step.half_widths[i] * d
                if (q[i] - edge) * d >= 0.0:
                    mv.checked[i] = True
                    want = mv.direction[i]
                    if abs(v[i] - want) > cfgs[i].speed_tolerance * abs(want):
                        return self._trip(j, (
                            f"{j}: speed not reached at the window start ({edge:.3f} rad): {v[i]:.4f} rad/s vs "
                            f"{want:.4f} rad/s ± {100 * cfgs[i].speed_tolerance:g} % (speed {step.speeds[i]:g} "
                            "rad/s motor)"))
        if tau >= mv.planned:
            target = mv.target()
            arrived = True
            for i, c in enumerate(cfgs):
                d = mv.direction[i]
                rem = (target[i] - q[i]) * (1.0 if d > 0 else -1.0) if abs(d) * mv.length > c.position_tolerance \
                    else abs(target[i] - q[i])
                if rem > c.position_tolerance:
                    arrived = False
            if arrived:
                self._next_step()
                return self._advance(now, q, v)
            limit = max(c.move_timeout_factor for c in cfgs) * mv.planned + 2.0
            if now - mv.t_start > limit:
                far = max(range(len(q)), key=lambda i: abs(target[i] - q[i]))
                return self._trip(plan.joints[far], (
                    f"{mv.phase.name.lower()} move not finished after {now - mv.t_start:.1f} s (planned {mv.planned:.1f} s): "
                    f"{plan.joints[far]} at {q[far]:.3f} rad, target {target[far]:.3f} rad"))
        # toward the nearest point of the line while the reference runs (a lag along the line is the same
        # for every joint and harmless), toward the target once it has ended
        ended = tau >= mv.planned
        ref_lam = mv.length if ended else lam
        _, rate = trapezoid(tau + 0.5 * cfgs[0].control_period, mv.length, mv.cruise, mv.accel)
        out = []
        for i, c in enumerate(cfgs):
            ref = mv.origin[i] + mv.direction[i] * ref_lam
            corr = self.LINE_GAIN * (ref - q[i])
            lim = self.APPROACH_CORRECTION * c.approach_speed if ended else mv.limits[i]
            out.append(mv.direction[i] * rate + max(-lim, min(lim, corr)))
        return out

    def _next_step(self) -> bool:
        """:meth:`SpeedSteps._next_step`; a speed finished is noted in each joint's result."""
        finished = super()._next_step()
        if finished and self.running and self.plan is not None:
            self._note_results(CycleState.RUNNING, self.message)
        return finished
