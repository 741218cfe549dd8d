"""The test-cycle state machine and watchdog (pure; fed time and joint states).

:class:`CycleRunner` is driven by :meth:`CycleRunner.update` with the current time
and the latest joint reading (both in one clock: the node's, which may be sim
time). It returns the velocity command to send (joint rad/s) and keeps the
state and phase that the status topic reports. Moves are position-feedback
trapezoids: ``w_cmd = min(cruise, a * t_move, brake(remaining))`` (never
below a small creep speed until the target is reached), so braking points
follow the measured position and the joint stops at each target.

The command holds until the next update, so braking must start one update
interval ``T`` early: ``brake(rem) = sqrt((a T)^2 + 2 a rem) - a T``, the speed
from which the joint, travelling ``T`` at it and then braking at ``a``, stops
at the target. ``T`` is the runner's own measured update interval (the longest
of the last ``LEAD_UPDATES`` intervals in its clock), at least
``control_period`` and at most ``control_period + reaction_time`` and
``steady_time`` (the braking never reaches back into the window). With ``T = 0``
this is the plain ``sqrt(2 a rem)``, which overshoots by the travel of every
late update. A single update later than the recent ones is what the planner's
stopping allowance is for (:func:`jointwear_ros.cycle.plan.stop_allowance`).

Watchdog (any trip: command 0, state FAILED, the reason in ``message``):

- the joint reading is older than ``state_timeout`` (or missing; with
  simulated time also in wall time, see :meth:`CycleRunner.update`),
- ``|effort| > effort_limit``,
- the speed at the window start (first sample inside the window during a
  sweep) is off by more than ``speed_tolerance`` (relative),
- a reading is not finite, the joint leaves ``joint_limits``, or a move takes
  longer than ``move_timeout_factor`` × its planned time + 2 s,
- the joint is still not within ``approach_tolerance`` of a sweep start after
  ``MAX_APPROACHES`` approach moves (an approach that overshoots, e.g. on
  late joint states, is repeated, each time at half the speed, before the sweep starts: a sweep that starts
  inside its run-up would not reach constant speed before the window).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from ..contract import CyclePhase, CycleState, CycleStatus
from .plan import CycleConfig, CyclePlan, move_duration

__all__ = ["CycleMachine", "CycleRunner", "CycleState", "JointReading", "Phase", "SpeedSteps", "reading_fault"]


#: Phases of a running cycle: the contract's ``TestCycleStatus.PHASE_*``.
Phase = CyclePhase


@dataclass(frozen=True)
class JointReading:
    """The latest joint state: when it arrived (``stamp``, runner clock) and its joint-side values."""

    stamp: float
    position: float
    velocity: float
    effort: float


@dataclass
class _Move:
    target: float
    cruise: float
    t_start: float
    planned: float
    phase: Phase
    direction: int = 0
    checked_window: bool = False


def reading_fault(joint: str, cfg: CycleConfig, now: float, r: JointReading | None, wall_age: float | None,
                  what: str = "joint") -> str | None:
    """Why ``joint``'s latest reading trips the watchdog, or None: missing; older than ``state_timeout`` (in
    the runner's clock and, when ``wall_age`` is given, in wall time too: see :meth:`CycleRunner.update`); not
    finite; ``|effort|`` above ``effort_limit``; outside ``joint_limits``. ``what`` names the joint's role
    ("joint", "held joint"; "" in a one-joint cycle, where the joint is the cycle's)."""
    who = f"{what} {joint}".strip()
    if r is None:
        return f"no joint state for {who}"
    age = now - r.stamp
    if age > cfg.state_timeout and (wall_age is None or wall_age > cfg.state_timeout):
        return f"joint state of {who} stale for {age:.3f} s (state_timeout {cfg.state_timeout:g} s)"
    if not (math.isfinite(r.position) and math.isfinite(r.velocity) and math.isfinite(r.effort)):
        return f"joint state of {who} not finite (position {r.position}, velocity {r.velocity}, effort {r.effort})"
    if abs(r.effort) > cfg.effort_limit:
        return (f"{who}: |effort| {abs(r.effort):.1f} N·m > effort_limit {cfg.effort_limit:g} N·m "
                f"at {r.position:.3f} rad")
    lo, hi = cfg.joint_limits
    if not lo <= r.position <= hi:
        return f"{who} at {r.position:.3f} rad, outside its joint limits [{lo:g}, {hi:g}] rad"
    return None


class CycleMachine:
    """What every cycle machine (one joint, one joint after another, every joint at once) does alike: it is
    ``running`` in state RUNNING; the operator's :meth:`abort` ends a running cycle ABORTED and the watchdog's
    :meth:`fail` ends it FAILED, naming the joint whose reading tripped it (``fault_joint``); each is False
    when no cycle runs. A machine ends a cycle its own way in :meth:`_end` (its commands to zero)."""

    state: CycleState
    #: the joint whose reading tripped the last watchdog stop ("" for none, or a fault of the cycle itself)
    fault_joint: str = ""

    @property
    def running(self) -> bool:
        return self.state == CycleState.RUNNING

    def abort(self, reason: str = "aborted by operator") -> bool:
        """Stop a running cycle (state ABORTED); False if none was running."""
        if not self.running:
            return False
        self._end(CycleState.ABORTED, reason)
        return True

    def fail(self, reason: str, joint: str = "") -> bool:
        """Trip: stop a running cycle with state FAILED; False if none was running."""
        if not self.running:
            return False
        self.fault_joint = joint
        self._end(CycleState.FAILED, reason)
        return True

    def _end(self, state: CycleState, message: str) -> None:
        raise NotImplementedError


class SpeedSteps:
    """The step sequence of each speed, shared by the one-joint and the every-joint-at-once machines:
    0 approach, 1 settle, 2 forward, 3 settle, 4 reverse, 5 settle; ``speeds_done`` advances after the last
    settle. An approach that ends off the sweep's start is repeated (``_approaches`` counts them; the
    machine fails after ``MAX_APPROACHES``)."""

    #: Approach moves tried before the cycle fails for not reaching a sweep start.
    MAX_APPROACHES = 4

    speeds_done: int
    _step: int
    _approaches: int
    _move: object | None
    _settling: bool

    def _restart_steps(self) -> None:
        """At a cycle's start: the first speed's approach."""
        self.speeds_done = 0
        self._step = 0
        self._approaches = 0
        self._move = None
        self._settling = False

    def _approach_again(self) -> None:
        """The approach missed the start: back to step 0 (the caller counted it in ``_approaches``)."""
        self._move = None
        self._settling = False
        self._step = 0

    def _next_step(self) -> bool:
        """On to the next step; True when that finished a speed."""
        self._move = None
        self._settling = False
        self._approaches = 0 if self._step == 1 else self._approaches
        self._step += 1
        if self._step > 5:
            self._step = 0
            self.speeds_done += 1
            return True
        return False


class CycleRunner(SpeedSteps, CycleMachine):
    """Runs one cycle at a time; see the module docstring.

    The step sequence per speed is APPROACH, SETTLE, FORWARD, SETTLE, REVERSE,
    SETTLE; ``speeds_done`` advances after the last settle of each speed.
    """

    #: Slowest command while a move has not arrived, as a fraction of its cruise speed.
    CREEP = 0.05
    #: Update intervals remembered for the braking lead (the longest of them is used).
    LEAD_UPDATES = 50

    def __init__(self, config: CycleConfig | None = None) -> None:
        self.config = config if config is not None else CycleConfig()
        self.config.check()
        self.state = CycleState.IDLE
        self.phase = Phase.NONE
        self.cycle_id = 0
        self.plan: CyclePlan | None = None
        self.message = "idle"
        self.command = 0.0
        self._restart_steps()
        self._move: _Move | None = None
        self._settle_until = 0.0
        self._last_update: float | None = None
        self._intervals: deque[float] = deque(maxlen=self.LEAD_UPDATES)

    # -- control -------------------------------------------------------------
    def start(self, plan: CyclePlan, cycle_id: int, now: float) -> None:
        """Start running ``plan`` (a cycle must not be running)."""
        if self.running:
            raise RuntimeError("a cycle is already running")
        self.plan = plan
        self.cycle_id = int(cycle_id)
        self.state = CycleState.RUNNING
        self.phase = Phase.APPROACH
        self.fault_joint = ""
        self.message = f"running: {plan.summary()}"
        self.command = 0.0
        self._restart_steps()
        self._t_start = now
        self._last_update = None
        self._intervals.clear()

    def _end(self, state: CycleState, message: str) -> None:
        self.state = state
        self.phase = Phase.NONE
        self.message = message
        self.command = 0.0
        self._move = None

    # -- status --------------------------------------------------------------
    @property
    def current_speed(self) -> float:
        """Motor speed of the speed being swept (0 when not running)."""
        if not self.running or self.plan is None:
            return 0.0
        return self.plan.speeds[min(self.speeds_done, len(self.plan.speeds) - 1)].speed

    def status(self) -> CycleStatus:
        """The cycle's :class:`~jointwear_ros.contract.CycleStatus` (no stamp: the node stamps it on publishing)."""
        plan = self.plan
        return CycleStatus(
            joint_name=self.config.joint_name,
            cycle_id=self.cycle_id,
            state=self.state,
            phase=self.phase,
            current_speed=self.current_speed,
            speeds_done=self.speeds_done,
            speeds_total=0 if plan is None else len(plan.speeds),
            window_center=self.config.position if plan is None else plan.center,
            window_half_width=self.config.window_half_width if plan is None else plan.half_width,
            message=self.message,
        )

    @property
    def lead(self) -> float:
        """The braking lead ``T``, s: the measured update interval, clamped (see the module docstring)."""
        cfg = self.config
        measured = max(self._intervals, default=0.0)
        return max(0.0, min(max(measured, cfg.control_period), cfg.control_period + cfg.reaction_time,
                            cfg.steady_time))

    def brake_speed(self, remaining: float) -> float:
        """Largest speed (joint rad/s) from which the joint stops within ``remaining`` rad (see the module docstring)."""
        a = self.config.acceleration
        at = a * self.lead
        return math.sqrt(at * at + 2.0 * a * max(remaining, 0.0)) - at

    # -- the machine ---------------------------------------------------------
    def update(self, now: float, reading: JointReading | None, wall_age: float | None = None) -> float:
        """Advance the machine; return the velocity command (joint rad/s; 0 unless running).

        ``wall_age`` (optional) is the wall-clock age of ``reading``. Give it when
        ``now`` is simulated time: a busy executor can apply a clock update
        before the joint state that came with it, so the reading looks old in
        sim time although it is not; the reading is then stale only if it is
        also older than ``state_timeout`` in wall time.
        """
        if not self.running or self.plan is None:
            self.command = 0.0
            return 0.0
        if self._last_update is not None and now > self._last_update:
            self._intervals.append(now - self._last_update)
        self._last_update = now
        reason = self._watchdog(now, reading, wall_age)
        if reason is not None:
            self.fail(f"watchdog: {reason}", self.config.joint_name)
            return 0.0
        assert reading is not None
        self.command = self._advance(now, reading)
        return self.command if self.running else 0.0

    def _watchdog(self, now: float, r: JointReading | None, wall_age: float | None = None) -> str | None:
        return reading_fault(self.config.joint_name, self.config, now, r, wall_age, "")

    def _advance(self, now: float, r: JointReading) -> float:
        plan = self.plan
        assert plan is not None
        cfg = self.config
        while True:
            if self.speeds_done >= len(plan.speeds):
                self._end(CycleState.DONE, f"done: {len(plan.speeds)} speed(s) in {now - self._t_start:.1f} s")
                return 0.0
            sp = plan.speeds[self.speeds_done]
            # steps of one speed: 0 approach, 1 settle, 2 forward, 3 settle, 4 reverse, 5 settle
            k = self._step
            if k in (1, 3, 5):
                if not self._settling:
                    self._settling = True
                    self._settle_until = now + cfg.settle_time
                self.phase = Phase.SETTLE
                if now < self._settle_until:
                    return 0.0
                if k == 1 and abs(r.position - sp.start) > cfg.approach_tolerance:
                    # the approach overshot (or fell short): a shorter, slower move back to the start
                    self._approaches += 1
                    if self._approaches > self.MAX_APPROACHES:
                        self._end(
                            CycleState.FAILED,
                            f"watchdog: joint at {r.position:.3f} rad after {self.MAX_APPROACHES} approaches, "
                            f"not within {cfg.approach_tolerance:g} rad of the sweep start {sp.start:.3f} rad",
                        )
                        return 0.0
                    self._approach_again()
                    continue
                self._next_step()
                continue
            if self._move is None:
                if k == 0:
                    # each repeated approach at half the speed of the one before
                    target, cruise, phase = sp.start, cfg.approach_speed * 0.5**self._approaches, Phase.APPROACH
                elif k == 2:
                    target, cruise, phase = sp.end, sp.velocity, Phase.FORWARD
                else:
                    target, cruise, phase = sp.start, sp.velocity, Phase.REVERSE
                planned = move_duration(target - r.position, cruise, cfg.acceleration)
                d = 0 if target == r.position else (1 if target > r.position else -1)
                self._move = _Move(target, cruise, now, planned, phase, d)
            mv = self._move
            self.phase = mv.phase
            rem = (mv.target - r.position) * mv.direction
            if mv.direction == 0 or rem <= cfg.position_tolerance:
                self._next_step()
                continue
            if now - mv.t_start > cfg.move_timeout_factor * mv.planned + 2.0:
                self._end(
                    CycleState.FAILED,
                    f"watchdog: {mv.phase.name.lower()} move to {mv.target:.3f} rad not finished after "
                    f"{now - mv.t_start:.1f} s (planned {mv.planned:.1f} s); joint at {r.position:.3f} rad",
                )
                return 0.0
            if mv.phase in (Phase.FORWARD, Phase.REVERSE) and not mv.checked_window:
                edge = plan.center - plan.half_width * mv.direction
                if (r.position - edge) * mv.direction >= 0.0:
                    mv.checked_window = True
                    want = mv.direction * mv.cruise
                    if abs(r.velocity - want) > cfg.speed_tolerance * mv.cruise:
                        self._end(
                            CycleState.FAILED,
                            f"watchdog: speed not reached at the window start ({edge:.3f} rad): "
                            f"{r.velocity:.4f} rad/s vs {want:.4f} rad/s ± {100 * cfg.speed_tolerance:g} % "
                            f"(speed {sp.speed:g} rad/s motor)",
                        )
                        return 0.0
            a = cfg.acceleration
            w = min(mv.cruise, a * (now - mv.t_start) + self.CREEP * mv.cruise, self.brake_speed(rem))
            w = max(w, self.CREEP * mv.cruise)
            return mv.direction * w
