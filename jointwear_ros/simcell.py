"""A simulated cell: the node settings that put a cell on a real arm, and the whole cell in one process.

:func:`arm_cell_parameters` gives the parameters of ``joint_sim``, ``test_cycle`` and ``friction_observer``
for an arm of :mod:`jointwear_ros.sim.arms` (what ``jointwear demo --joints N --arm ARM`` passes): the arm
simulated, each joint's test window at the arm's test pose inside its URDF limits, its effort limit, its drive
sizing. :func:`cycle_settings` gives the same as the cores' dataclasses.

:func:`run_cycle` runs one test cycle of a cell in one process, without ROS, as the nodes run it: the
simulated robot (an :class:`~jointwear_ros.sim.arm.ArmSim` or a :class:`~jointwear_ros.sim.RobotSim`)
sampled at 500 Hz, the cycle runner at 100 Hz (every joint at once, :class:`~jointwear_ros.cycle.LineCycleRunner`,
or one after another, :class:`~jointwear_ros.cycle.RobotCycleRunner`), one friction observer core and one wear
monitor per joint fed with every joint's status and samples. The benchmarks and the tests of the arm use it;
the live cell (the nodes over DDS) runs the same cores.

>>> p = arm_cell_parameters("ur5", ["joint_1", "joint_2"])
>>> p["joint_sim"]["arm"], p["test_cycle"]["joint_2.position"], p["friction_observer"]["joint_2.torque_scale"]
('ur5', -1.3, 75.0)
>>> p["test_cycle"]["joint_2.joint_limits"], p["test_cycle"]["joint_2.effort_limit"]
([-2.9, 0.3], 142.5)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .contract import CyclePhase, CycleState
from .cycle import CycleConfig, JointReading, LineCycleRunner, RobotCycleRunner, plan_line_cycle, plan_robot_cycle
from .monitor.core import MonitorConfig, WearMonitor
from .observation import FrictionObservationData
from .observer import ObserverConfig
from .observer.core import FrictionObserverCore
from .sim.arms import arm_spec

__all__ = ["ARM_EFFORT_FRACTION", "ARM_SWEEP_RANGE", "CellRun", "arm_cell_parameters", "cycle_settings", "run_cycle"]

#: How far the test cycle may take a joint of an arm from its test pose, rad (inside the URDF's limits).
ARM_SWEEP_RANGE = 1.6
#: The test cycle's effort limit on an arm: this fraction of the URDF's effort limit (the drive saturates there).
ARM_EFFORT_FRACTION = 0.95
#: The test cycle's acceleration (joint rad/s^2) and time at speed before a window (s) on an arm: shorter run-ups
#: than the independent joints' defaults (4, 0.3), so every joint at once at 160 rad/s (motor) stays clear of the
#: UR5's own links and the table (its run-ups otherwise take the wrist to the table from any loaded pose,
#: test/test_arm_collision.py); well inside what the arms' drives do.
ARM_ACCELERATION = 8.0
ARM_STEADY_TIME = 0.2


def arm_cell_parameters(arm: str, names: Sequence[str], payload: float = 0.0) -> dict[str, dict[str, Any]]:
    """The node parameters that put the cell on arm ``arm``: joint_sim simulates it (``arm``, ``payload``; each
    joint's drive from the arm's spec), test_cycle sweeps each joint around the arm's test pose inside its URDF
    limits (``ARM_SWEEP_RANGE`` at most) below its effort limit, at ``ARM_ACCELERATION`` and ``ARM_STEADY_TIME``,
    and checks every planned path against the arm's links and the table (``arm``), friction_observer scales
    each joint's effort by the arm's torque scale. The i-th of ``names`` is the arm's i-th joint."""
    spec = arm_spec(arm)
    out: dict[str, dict[str, Any]] = {"joint_sim": {"arm": spec.name, "payload": float(payload)},
                                      "test_cycle": {"arm": spec.name}, "friction_observer": {}}
    for name, j in zip(names, spec.for_names(names), strict=False):
        lo = max(j.lower + 0.05, j.home - ARM_SWEEP_RANGE)
        hi = min(j.upper - 0.05, j.home + ARM_SWEEP_RANGE)
        out["test_cycle"].update({f"{name}.gear_ratio": j.gear_ratio, f"{name}.position": j.home,
                                  f"{name}.joint_limits": [round(lo, 4), round(hi, 4)],
                                  f"{name}.effort_limit": round(ARM_EFFORT_FRACTION * j.effort, 4),
                                  f"{name}.acceleration": ARM_ACCELERATION, f"{name}.steady_time": ARM_STEADY_TIME})
        out["friction_observer"].update({f"{name}.gear_ratio": j.gear_ratio, f"{name}.torque_scale": j.torque_scale})
    return out


def cycle_settings(arm: str, names: Sequence[str], **cycle: Any) -> tuple[dict[str, CycleConfig],
                                                                           dict[str, ObserverConfig]]:
    """:func:`arm_cell_parameters` as the cores' settings: each joint's :class:`CycleConfig` (``cycle``: more
    settings for every joint, e.g. ``speeds``) and :class:`ObserverConfig`."""
    params = arm_cell_parameters(arm, names)
    tc, fo = params["test_cycle"], params["friction_observer"]
    own = ("gear_ratio", "position", "effort_limit", "acceleration", "steady_time")
    cycles = {j: CycleConfig(joint_name=j, joint_limits=tuple(tc[f"{j}.joint_limits"]),
                             **{**{k: tc[f"{j}.{k}"] for k in own}, **cycle}) for j in names}
    observers = {j: ObserverConfig(joint_name=j, gear_ratio=fo[f"{j}.gear_ratio"],
                                   torque_scale=fo[f"{j}.torque_scale"]) for j in names}
    return cycles, observers


@dataclass
class CellRun:
    """One cycle of :func:`run_cycle`: how it ended, its planned and simulated cell time (s), each joint's
    observations and estimate (wear, std; NaN without one), and where the arm stood when each joint crossed
    its window centre sweeping forward at each speed (``crossings[(joint, round(speed))] = (q, v)``, the whole
    arm's positions and velocities: where the observation's truth is)."""

    state: CycleState
    message: str
    planned: float
    cell_seconds: float
    observations: dict[str, list[FrictionObservationData]]
    estimates: dict[str, tuple[float, float]]
    crossings: dict[tuple[str, int], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    def crossing(self, joint: str, speed: float) -> tuple[np.ndarray, np.ndarray]:
        """Where the arm stood (q, v) when ``joint`` crossed its window centre forward at the commanded motor speed
        nearest ``speed`` (an observation's speed is the measured one); ``KeyError`` if it never did."""
        keys = [k for k in self.crossings if k[0] == joint]
        if not keys:
            raise KeyError(f"{joint} never crossed its window centre sweeping forward")
        return self.crossings[min(keys, key=lambda k: abs(k[1] - speed))]


def run_cycle(sim: Any, cycles: Mapping[str, CycleConfig], observers: Mapping[str, ObserverConfig], *,
              together: bool = True, seed: int = 0, method: str = "joint", cycle_id: int = 1,
              max_seconds: float = 2000.0, sample_rate: float = 500.0, command_rate: float = 100.0) -> CellRun:
    """Run one test cycle of the cell on ``sim`` (see the module docstring). ``cycles`` and ``observers`` hold
    every joint of ``sim.names``; ``together``: every joint at once along one line, else one after another.
    The temperature is not given to the estimator (``method``, the monitor's)."""
    names = list(sim.names)
    dt = 1.0 / sample_rate
    every = max(1, round(sample_rate / command_rate))
    home = {j: float(p) for j, p in zip(names, sim.sample()[0], strict=True)}
    if together:
        plan: Any = plan_line_cycle(cycles, start_positions=home)
        runner: Any = LineCycleRunner(cycles)
    else:
        plan = plan_robot_cycle(cycles, start_positions=home)
        runner = RobotCycleRunner(cycles)
    cores = {j: FrictionObserverCore(observers[j]) for j in names}
    monitors = {j: WearMonitor(MonitorConfig(joint_name=j, method=method, seed=seed)) for j in names}
    obs: dict[str, list[FrictionObservationData]] = {j: [] for j in names}
    results: dict[str, Any] = {}
    centre = {j: cycles[j].position for j in names}
    forward: dict[str, float] = {}
    crossed: dict[tuple[str, int], tuple[np.ndarray, np.ndarray]] = {}

    def take(j: str, out: Any, now: float) -> None:
        for o in out.observations:
            obs[j].append(o)
            for r in monitors[j].add(o, now):
                results[j] = r

    def statuses(now: float) -> None:
        forward.clear()
        for st in runner.statuses():
            if st.state == CycleState.RUNNING and st.phase == CyclePhase.FORWARD:
                forward[st.joint_name] = st.current_speed
            st = replace(st, stamp=now)
            take(st.joint_name, cores[st.joint_name].on_status(st), now)
            for r in monitors[st.joint_name].on_status(st, now):
                results[st.joint_name] = r

    on_joint_state = [cores[j].on_joint_state for j in names]
    runner.start(plan, cycle_id, sim.time, home)
    t0 = sim.time
    last = sim.sample()[0]
    k = 0
    while runner.running and sim.time < t0 + max_seconds:
        if k % every == 0:
            pos, vel, eff = sim.sample()
            cmd = runner.update(sim.time, {j: JointReading(sim.time, pos[i], vel[i], eff[i])
                                           for i, j in enumerate(names)})
            sim.set_commands([cmd[j] for j in names])
            statuses(sim.time)
        sim.step(dt)
        k += 1
        pos, vel, eff = sim.sample()
        now = sim.time
        for i, j in enumerate(names):
            out = on_joint_state[i](now, pos[i], vel[i], eff[i])
            if out.observations:
                take(j, out, now)
            if j in forward and last[i] < centre[j] <= pos[i]:
                crossed.setdefault((j, round(forward[j])), (np.array(pos, dtype=float), np.array(vel, dtype=float)))
        last = pos
    cell_seconds = sim.time - t0
    if runner.running:
        runner.fail(f"still running after {max_seconds:g} s of simulated time")
    statuses(sim.time)
    for j in names:
        take(j, cores[j].flush(), sim.time)
        for r in monitors[j].poll(sim.time + 60.0):
            results[j] = r
    est = {j: (results[j].result.wear, results[j].result.wear_std) if j in results and results[j].result
           else (math.nan, math.nan) for j in names}
    return CellRun(runner.state, runner.message, plan.duration, cell_seconds, obs, est, crossed)
