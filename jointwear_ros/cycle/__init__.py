"""Test-cycle planning, limit checks and the watchdog state machine (pure: no ROS, no clocks).

:func:`plan_cycle` validates a request against the joint limits and speed
limits and plans the sweeps; :class:`CycleRunner` runs a plan when fed
``(now, joint reading)`` and returns the velocity command.
:func:`plan_robot_cycle` and :class:`RobotCycleRunner` do the same for several
joints tested one after another, the others held still; :func:`plan_line_cycle`
and :class:`LineCycleRunner` sweep every joint at once along one straight line in
joint space and back. The ``test_cycle`` node wraps them.
"""

from __future__ import annotations

from .line import LineCycleRunner, LinePlan, LineStep, plan_line_cycle
from .plan import (
    DEFAULT_SPEEDS,
    CycleConfig,
    CyclePlan,
    CycleRequestError,
    SpeedPlan,
    move_duration,
    plan_cycle,
    run_up,
    stop_allowance,
)
from .robot import JointOutcome, RobotCycleRunner, RobotPlan, plan_robot_cycle
from .runner import CycleRunner, CycleState, JointReading, Phase

__all__ = [
    "DEFAULT_SPEEDS",
    "CycleConfig",
    "CyclePlan",
    "CycleRequestError",
    "CycleRunner",
    "CycleState",
    "JointOutcome",
    "JointReading",
    "LineCycleRunner",
    "LinePlan",
    "LineStep",
    "Phase",
    "RobotCycleRunner",
    "RobotPlan",
    "SpeedPlan",
    "move_duration",
    "plan_cycle",
    "plan_line_cycle",
    "plan_robot_cycle",
    "run_up",
    "stop_allowance",
]
