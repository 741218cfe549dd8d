"""A robot cycle: every joint of a robot tested in sequence, the others held still (pure).

:func:`plan_robot_cycle` checks a whole request (the joints, one window centre
per joint, the speeds) and plans every joint before anything moves;
:class:`RobotCycleRunner` runs the plan with one :class:`~jointwear_ros.cycle.CycleRunner`
per joint, one after another, and a watchdog over **every** joint it drives:

- the joint under test: its own runner's watchdog (stale or non-finite state,
  limits, effort, speed at the window start, moves that do not finish);
- every other joint (held: commanded back toward where it is held, :meth:`RobotCycleRunner._hold_correction`,
  zero where it stands there): a state older than its
  ``state_timeout``, a non-finite reading, a position outside its
  ``joint_limits``, ``|effort|`` above its ``effort_limit``, a move of more
  than ``hold_tolerance`` from where the cycle found it (a joint tested earlier
  in the cycle: from where its test left it), or corrections that have moved
  it back more than ``hold_tolerance`` in all (net: a push that comes and goes
  cancels; a steady one, a creeping brake or a drifting sensor, adds up).

Any trip stops the robot cycle: state FAILED, zero for every joint, the reason
in the message, with the joints that were not tested named.

Status stream (``TestCycleStatus`` per joint, one cycle id): RUNNING .. DONE for
the first joint, RUNNING .. DONE for the next, ...; :meth:`RobotCycleRunner.status`
reports a finished joint's DONE for one update before the next joint starts, so a
node that publishes the status after each update publishes every joint's DONE.

>>> configs = {"joint_1": CycleConfig(joint_name="joint_1"), "joint_2": CycleConfig(joint_name="joint_2")}
>>> plan = plan_robot_cycle(configs, ["joint_2", "joint_1"], speeds=[40.0], start_positions={"joint_1": 0.0, "joint_2": 0.0})
>>> plan.joints, [len(p.speeds) for p in plan.plans], round(plan.duration, 1)
(('joint_2', 'joint_1'), [1, 1], 8.2)
>>> plan_robot_cycle(configs, ["joint_1", "joint_9"])
Traceback (most recent call last):
...
jointwear_ros.cycle.plan.CycleRequestError: unknown joint 'joint_9': this node drives 'joint_1', 'joint_2'
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from ..contract import CycleStatus, RefusalReason
from .plan import CycleConfig, CyclePlan, CycleRequestError, plan_cycle
from .runner import CycleMachine, CycleRunner, CycleState, JointReading, reading_fault

__all__ = ["JointOutcome", "RobotCycleRunner", "RobotPlan", "plan_robot_cycle"]


@dataclass(frozen=True)
class RobotPlan:
    """A validated robot cycle: the joints in test order and each joint's :class:`CyclePlan`."""

    joints: tuple[str, ...]
    plans: tuple[CyclePlan, ...]

    @property
    def duration(self) -> float:
        """Planned duration of the whole robot cycle (the joints one after another), s."""
        return float(sum(p.duration for p in self.plans))

    def plan_of(self, joint: str) -> CyclePlan:
        return self.plans[self.joints.index(joint)]

    def summary(self) -> str:
        """One line per joint joined by ``; ``, and the total when there are several joints."""
        parts = [f"{j}: {p.summary()}" for j, p in zip(self.joints, self.plans, strict=True)]
        if len(self.joints) > 1:
            parts.append(f"{len(self.joints)} joints, about {self.duration:.1f} s in total")
        return "; ".join(parts)


def _names(joints: Sequence[str]) -> str:
    return ", ".join(f"'{j}'" for j in joints)


def plan_robot_cycle(
    configs: Mapping[str, CycleConfig],
    joints: Sequence[str] = (),
    speeds: Sequence[float] | None = None,
    positions: Sequence[float] | None = None,
    start_positions: Mapping[str, float] | None = None,
    max_duration: float | None = None,
) -> RobotPlan:
    """Check a robot-cycle request and plan every joint; raise :class:`CycleRequestError` if any cannot run.

    Parameters
    ----------
    configs
        Every joint the node drives, in command order, with its settings.
    joints
        The joints to test, in this order; empty: every joint of ``configs``.
        A joint not in ``configs`` or named twice: ``REASON_WRONG_JOINT``.
    speeds
        Motor-side speeds for every joint; ``None`` or empty: each joint's configured speeds.
    positions
        One window centre per joint of ``joints`` (joint rad); ``None`` or empty: each
        joint's configured position.
    start_positions
        Where each joint stands now (its first approach starts there); a joint missing: its centre.
    max_duration
        Longest planned robot cycle (all joints), s; ``None``: no limit beyond each joint's own.
    """
    order = list(joints) if len(joints) else list(configs)
    unknown = [j for j in order if j not in configs]
    if unknown:
        raise CycleRequestError(f"unknown joint {unknown[0]!r}: this node drives {_names(list(configs))}",
                                RefusalReason.WRONG_JOINT)
    twice = sorted({j for j in order if order.count(j) > 1})
    if twice:
        raise CycleRequestError(f"joint {twice[0]!r} is named more than once in joints {order}: name each joint once",
                                RefusalReason.WRONG_JOINT)
    centres = list(positions) if positions is not None and len(positions) else None
    if centres is not None and len(centres) != len(order):
        raise CycleRequestError(
            f"positions has {len(centres)} value(s) for {len(order)} joint(s) ({', '.join(order)}): give one "
            "window centre per joint, in the order of joints, or none for the configured positions"
        )
    start = dict(start_positions or {})
    plans: list[CyclePlan] = []
    for i, j in enumerate(order):
        try:
            plans.append(plan_cycle(configs[j], speeds, None if centres is None else float(centres[i]), start.get(j)))
        except CycleRequestError as exc:
            raise CycleRequestError(f"{j}: {exc}", exc.reason) from None
    plan = RobotPlan(tuple(order), tuple(plans))
    if max_duration is not None and plan.duration > max_duration:
        raise CycleRequestError(
            f"the robot cycle of {len(order)} joint(s) would take about {plan.duration:.0f} s, more than max_duration "
            f"{max_duration:g} s; test fewer joints per cycle or use fewer or faster speeds",
            RefusalReason.BAD_SPEEDS,
        )
    return plan


@dataclass(frozen=True)
class JointOutcome:
    """How one joint fared in the last robot cycle that included it (for its diagnostics)."""

    cycle_id: int
    state: CycleState
    message: str
    speeds_done: int = 0
    speeds_total: int = 0


#: Gain of a held joint's correction toward where it is held, 1/s (the line cycle's ``LINE_GAIN``: a time
#: constant of 0.2 s, far below a velocity loop's bandwidth).
HOLD_GAIN = 5.0
#: Within this fraction of ``hold_tolerance`` of where it is held a held joint gets no correction: a joint that
#: static friction holds a little off would creep under a tiny command, its drive winding up until it breaks
#: away (hunting: on the Panda's one-after-another cycle, two speeds, without it the held joints got a
#: correction nearly all the time and joint 1 broke away 257 times, with it 66, the run-ups' pushes). It is
#: not what made the Panda's joint 1 read 192 % high: that was the arm sim's stick band, solved with the
#: previous step's accelerations (:mod:`jointwear_ros.sim.arm`); without the deadband every joint is within
#: 1.6 % too.
HOLD_DEADBAND = 0.1


class DrivenJoints(CycleMachine):
    """A cycle machine over every joint a node drives (one after another, or all at once): their settings
    by name in command order (each checked), the held joints' tolerance, and new settings only between
    cycles (:meth:`reconfigure`). ``KIND`` names the machine in its messages."""

    KIND = "multi-joint"

    def __init__(self, configs: Mapping[str, CycleConfig], hold_tolerance: float = 0.02) -> None:
        if not configs:
            raise CycleRequestError(f"a {self.KIND} cycle needs at least one joint")
        self.configs = dict(configs)
        for c in self.configs.values():
            c.check()
        self.hold_tolerance = float(hold_tolerance)
        if not (math.isfinite(self.hold_tolerance) and self.hold_tolerance > 0):
            raise CycleRequestError(f"hold_tolerance must be finite and > 0 rad, got {hold_tolerance}")
        self.names: tuple[str, ...] = tuple(self.configs)

    def reconfigure(self, configs: Mapping[str, CycleConfig], hold_tolerance: float | None = None) -> None:
        """New settings for the next cycle (refused while one runs: its plan used the old ones)."""
        if self.running:
            raise RuntimeError(f"a {self.KIND} cycle is running")
        if list(configs) != list(self.names):
            raise CycleRequestError(f"the driven joints cannot change: {list(self.names)} -> {list(configs)}")
        self.configs = dict(configs)
        if hold_tolerance is not None:
            self.hold_tolerance = float(hold_tolerance)


class RobotCycleRunner(DrivenJoints):
    """Runs one robot cycle at a time (see the module docstring).

    Parameters
    ----------
    configs
        Every joint the node drives (name -> settings), in command order.
    hold_tolerance
        Largest move of a held joint from where the cycle found it, rad.
    """

    KIND = "robot"

    def __init__(self, configs: Mapping[str, CycleConfig], hold_tolerance: float = 0.02) -> None:
        super().__init__(configs, hold_tolerance)
        self.state = CycleState.IDLE
        self.cycle_id = 0
        self.plan: RobotPlan | None = None
        self.index = 0  # the joint under test: plan.joints[index]
        self.message = "idle"
        self.runner: CycleRunner | None = None
        self.results: dict[str, JointOutcome] = {}
        self.fault_joint = ""  # the joint whose reading tripped the last watchdog stop
        self._between = False  # a joint just finished (its DONE is the status); the next starts on the next update
        self._hold: dict[str, float] = {}
        self._hold_cmd: dict[str, float] = {}  # the held joints' corrections toward where they are held
        self._pushed: dict[str, float] = {}  # the distance each held joint's corrections moved it, net, rad
        self._t_last: float | None = None
        self._t_start = 0.0

    # -- control -------------------------------------------------------------
    @property
    def joint_name(self) -> str:
        """The joint under test (the last one tested when idle; the first configured before any cycle)."""
        if self.plan is None:
            return self.names[0]
        return self.plan.joints[min(self.index, len(self.plan.joints) - 1)]

    def start(self, plan: RobotPlan, cycle_id: int, now: float, positions: Mapping[str, float] | None = None) -> None:
        """Start ``plan``; ``positions`` are where the joints stand (the held joints' references)."""
        if self.running:
            raise RuntimeError("a robot cycle is already running")
        self.plan = plan
        self.cycle_id = int(cycle_id)
        self.state = CycleState.RUNNING
        self.index = 0
        self.fault_joint = ""
        self._between = False
        self._hold = {j: float(p) for j, p in (positions or {}).items() if math.isfinite(p)}
        self._hold_cmd = {}
        self._pushed = {}
        self._t_last = None
        self._t_start = now
        for j in plan.joints:
            self.results[j] = JointOutcome(self.cycle_id, CycleState.IDLE, f"waiting in cycle {cycle_id}", 0,
                                          len(plan.plan_of(j).speeds))
        self._start_joint(now)

    def _start_joint(self, now: float) -> None:
        assert self.plan is not None
        j = self.plan.joints[self.index]
        self.runner = CycleRunner(self.configs[j])
        self.runner.start(self.plan.plans[self.index], self.cycle_id, now)
        self.message = self.runner.message
        self._hold.pop(j, None)  # moving now; its reference is set again where its test leaves it
        self._hold_cmd.pop(j, None)
        self._pushed.pop(j, None)
        self.results[j] = JointOutcome(self.cycle_id, CycleState.RUNNING, self.runner.message, 0,
                                      len(self.plan.plans[self.index].speeds))

    def _end(self, state: CycleState, reason: str) -> None:
        assert self.plan is not None
        if self._between:  # the last joint finished; the stop belongs to the next one, which never started
            self._between = False
            self.index += 1
            self.runner = None
        j = self.plan.joints[self.index]
        rest = self.plan.joints[self.index + 1:]
        message = reason + (f"; not tested: {', '.join(rest)}" if rest else "")
        if self.runner is not None:
            if state == CycleState.ABORTED:
                self.runner.abort(message)
            else:
                self.runner.fail(message)
        self.state = state
        self.message = message
        done = 0 if self.runner is None else self.runner.speeds_done
        self.results[j] = JointOutcome(self.cycle_id, state, message, done, len(self.plan.plans[self.index].speeds))
        for k in rest:
            self.results[k] = JointOutcome(self.cycle_id, CycleState.IDLE,
                                          f"not tested: cycle {self.cycle_id} stopped at {j}", 0,
                                          len(self.plan.plan_of(k).speeds))
        if self.fault_joint and self.fault_joint != j:
            self.results[self.fault_joint] = JointOutcome(self.cycle_id, CycleState.FAILED, message)

    # -- status --------------------------------------------------------------
    @property
    def commands(self) -> dict[str, float]:
        """The velocity command of every driven joint: the joint under test's while it moves; each held joint's
        hold correction (:data:`HOLD_GAIN`), 0 for a joint where it was found (and for every joint when idle)."""
        out = dict.fromkeys(self.names, 0.0)
        if self.running:
            out.update(self._hold_cmd)
        if self.running and not self._between and self.runner is not None and self.runner.running:
            out[self.joint_name] = self.runner.command
        return out

    def status(self) -> CycleStatus:
        """The robot cycle's :class:`~jointwear_ros.contract.CycleStatus`: the joint under test, its progress."""
        plan = self.plan
        if plan is None:
            cfg = self.configs[self.names[0]]
            return CycleStatus(joint_name=self.names[0], cycle_id=self.cycle_id, state=self.state,
                               window_center=cfg.position, window_half_width=cfg.window_half_width,
                               message=self.message)
        i = min(self.index, len(plan.joints) - 1)
        p = plan.plans[i]
        if self.runner is None:  # stopped before this joint started
            return CycleStatus(joint_name=plan.joints[i], joints=plan.joints, joints_done=i, cycle_id=self.cycle_id,
                               state=self.state, speeds_total=len(p.speeds), window_center=p.center,
                               window_half_width=p.half_width, message=self.message)
        st = self.runner.status()
        if not self.running:
            st = replace(st, state=self.state, message=self.message)
        return replace(st, joint_name=plan.joints[i], joints=plan.joints, joints_done=i, cycle_id=self.cycle_id)

    def statuses(self) -> list[CycleStatus]:
        """``[status()]``: the statuses to publish after an update (one here; one per joint in a line cycle,
        :meth:`jointwear_ros.cycle.LineCycleRunner.statuses`)."""
        return [self.status()]

    # -- the machine ---------------------------------------------------------
    def update(self, now: float, readings: Mapping[str, JointReading | None],
               wall_ages: Mapping[str, float] | None = None) -> dict[str, float]:
        """Advance; return the command of every driven joint (joint rad/s; all 0 unless running).

        ``readings``: the latest reading of each driven joint; ``wall_ages``: their
        wall-clock ages (give them when ``now`` is simulated time, see
        :meth:`CycleRunner.update`).
        """
        if not self.running or self.plan is None:
            return self.commands
        ages = wall_ages or {}
        under_test = None if self._between else self.joint_name
        for j in self.names:
            if j == under_test:
                continue
            reason = self._hold_watchdog(j, now, readings.get(j), ages.get(j))
            if reason is not None:
                self.fail(f"watchdog: {reason}", j)
                return self.commands
            if self._t_last is not None and j in self._hold_cmd:  # what the last correction did since
                self._pushed[j] = self._pushed.get(j, 0.0) + self._hold_cmd[j] * (now - self._t_last)
                if abs(self._pushed[j]) > self.hold_tolerance:
                    self.fail(f"watchdog: held joint {j} keeps being pushed away: its hold correction moved it "
                              f"{self._pushed[j]:+.3f} rad in all (hold_tolerance {self.hold_tolerance:g} rad); "
                              "something pushes it steadily (a creeping brake, a drifting position sensor, a "
                              "coupling its drive cannot hold)", j)
                    return self.commands
            self._hold_cmd[j] = self._hold_correction(j, readings.get(j))
        self._t_last = now
        if self._between:
            self._between = False
            self.index += 1
            self._start_joint(now)
        runner = self.runner
        assert runner is not None
        j = self.joint_name
        r = readings.get(j)
        runner.update(now, r, ages.get(j))
        if runner.state == CycleState.RUNNING:
            self.message = runner.message
            return self.commands
        n = len(self.plan.plans[self.index].speeds)
        if runner.state == CycleState.DONE:
            self.results[j] = JointOutcome(self.cycle_id, CycleState.DONE, runner.message, runner.speeds_done, n)
            if r is not None and math.isfinite(r.position):
                self._hold[j] = r.position
            if self.index + 1 < len(self.plan.joints):
                self._between = True
                self.message = runner.message
            else:
                self.state = CycleState.DONE
                k = len(self.plan.joints)
                self.message = (runner.message if k == 1
                                else f"done: {k} joints in {now - self._t_start:.1f} s ({j}: {runner.message})")
        else:  # FAILED by the joint's own watchdog (the runner never ends ABORTED by itself)
            if runner.message.startswith("watchdog:"):
                self.fault_joint = j
            self._end(runner.state, runner.message)
        return self.commands

    def _hold_correction(self, j: str, r: JointReading | None) -> float:
        """A held joint's command: back toward where it is held, ``HOLD_GAIN`` × the distance, at most a fifth of
        its ``approach_speed``. On a coupled arm a joint under test pushes the others (inertia, Coriolis); a
        velocity loop at zero lets them creep, and a held joint that stands elsewhere in the reverse sweep than
        in the forward one changes the tested joint's gravity between the two: (u+ - u-)/2 is then no longer
        its friction (measured on the UR5's elbow at 1.6 rad/s: 20 % off without the correction,
        bench/bench_arm_cycle.py)."""
        ref = self._hold.get(j)
        if r is None or ref is None or not math.isfinite(r.position):
            return 0.0
        cap = 0.2 * self.configs[j].approach_speed
        err = ref - r.position
        band = HOLD_DEADBAND * self.hold_tolerance
        if abs(err) <= band:  # where static friction holds it: a creeping command would only wind its drive up
            return 0.0
        return max(-cap, min(cap, HOLD_GAIN * (err - math.copysign(band, err))))

    def _hold_watchdog(self, j: str, now: float, r: JointReading | None, wall_age: float | None) -> str | None:
        reason = reading_fault(j, self.configs[j], now, r, wall_age, "held joint")
        if reason is not None:
            return reason
        assert r is not None
        ref = self._hold.setdefault(j, r.position)
        if abs(r.position - ref) > self.hold_tolerance:
            return (f"held joint {j} moved {r.position - ref:+.3f} rad from {ref:.3f} rad "
                    f"(hold_tolerance {self.hold_tolerance:g} rad)")
        return None

