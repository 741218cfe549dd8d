"""The plan of a simulated commissioning run, and its observations as tables: what ``jointwear demo --commission`` does.

Pure (no ROS, no processes): the CLI drives the simulated cell through the plan and hands the observations it
heard back here.

- :func:`demo_joints` gives each joint of the simulated robot one of the shipped non-reference sets
  (``arm6-base`` and ``arm6-wrist`` joint side, N·m, with their gear ratio and torque scale; ``cobot-j3``
  normalized), so the robot is unlike ``ref-2011r`` in friction level, temperature sensitivity and units.
- :func:`plan_commissioning` lays out the cycles: baseline cycles at w = 0 while the joints warm up (the
  temperature rises from cycle to cycle) with the gravity load of each joint's window changing from cycle to
  cycle (what another pose of the other joints does on a real arm), optionally one cycle whose first joint
  carries a load that trips test_cycle's effort limit (a cycle that fails, to be skipped), then test cycles
  at other wear levels.
- :func:`observation_table` turns a joint's ``FrictionObservation`` fields into the
  :class:`~jointwear_ros.types.ObservationTable` that :func:`~jointwear_ros.commission.commission` and
  :func:`~jointwear_ros.commission.estimate_cycles` take (suite units: motor side, normalized).

>>> js = demo_joints(["joint_1", "joint_2", "joint_3"])
>>> [(j.name, j.params, j.frame) for j in js]
[('joint_1', 'arm6-base', 'joint'), ('joint_2', 'cobot-j3', 'motor_normalized'), ('joint_3', 'arm6-wrist', 'joint')]
>>> plan = plan_commissioning(js, baseline_cycles=4, test_wear=(10, 30, 40))
>>> [c.stage for c in plan]
['overload', 'baseline', 'baseline', 'baseline', 'baseline', 'test']
>>> [round(c.settings["joint_1"].temperature) for c in plan if c.stage == "baseline"]
[20, 36, 44, 48]
>>> [c.settings[j.name].wear for c in plan if c.stage == "test" for j in js]
[10.0, 30.0, 40.0]
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import InputDataError
from ..types import ObservationTable
from .names import MIN_BASELINE_CYCLES

__all__ = [
    "DEMO_SETS",
    "MIN_BASELINE_CYCLES",
    "OVERLOAD_GRAVITY",
    "JointSettings",
    "JointSetup",
    "PlannedCycle",
    "demo_joints",
    "observation_table",
    "plan_commissioning",
]


@dataclass(frozen=True)
class JointSetup:
    """One simulated joint: its shipped set and the units the cell and its commissioned set use.

    ``gear_ratio`` and ``torque_scale`` are the joint's (joint_sim, test_cycle, friction_observer all take
    them per joint); ``frame`` is the frame its set is commissioned in (``joint``: the baseline is converted
    to joint side N·m with them, as ``jointwear commission --gear-ratio G --torque-scale S`` does)."""

    name: str
    params: str
    frame: str
    gear_ratio: float
    torque_scale: float

    @property
    def joint_side(self) -> bool:
        return self.frame == "joint"

    @property
    def effort_limit(self) -> float:
        """test_cycle's effort limit for the joint, N·m: :data:`EFFORT_LIMIT` normalized units (the same share of
        the joint's torque on every joint; 160 N·m at the suite's 200 N·m per unit)."""
        return EFFORT_LIMIT * self.torque_scale


#: The shipped non-reference sets (docs/commissioning.md): base joints joint side at gear 120 and 300 N·m per
#: unit, a normalized joint, wrist joints joint side at gear 80 and 4 N·m per unit.
DEMO_SETS: tuple[tuple[str, str, float, float], ...] = (
    ("arm6-base", "joint", 120.0, 300.0),
    ("cobot-j3", "motor_normalized", 100.0, 200.0),
    ("arm6-wrist", "joint", 80.0, 4.0),
)
#: test_cycle's effort limit of every demo joint, normalized (times the joint's torque scale: N·m; 180 N·m at
#: the suite's 200 N·m per unit). The peak effort of a cycle is gravity + friction + the acceleration torque
#: (inertia x 4 joint rad/s^2 x gear: 0.2 at gear 100, 0.24 at 120): 0.83 was measured on arm6-base at load
#: 0.16 and 20-40 degC, so 0.75-0.8 tripped baseline cycles.
EFFORT_LIMIT = 0.9
#: Gravity amplitude (normalized) of the overloaded window: held at rest it stays below the effort limit; moving,
#: gravity + acceleration exceed it (the drive saturates at 1.0), so test_cycle stops the cycle (FAILED).
OVERLOAD_GRAVITY = 0.8
#: Gravity amplitudes (normalized) of the baseline windows, taken in turn: a load span of 0.04-0.16 (the
#: commissioning needs 25 % of the largest) with the peak effort clear of the effort limit.
BASELINE_GRAVITY = (0.05, 0.15, 0.1, 0.16, 0.07, 0.13, 0.04, 0.12)
#: Gravity of the test cycles' windows (inside the baseline's span).
TEST_GRAVITY = 0.1


def demo_joints(names: Sequence[str]) -> list[JointSetup]:
    """The joints of the demo robot: the shipped sets spread over ``names`` in the order base, normalized, wrist
    (six joints: two of each, like docs/commissioning.md; one joint: ``cobot-j3``; two: ``arm6-base``,
    ``cobot-j3``)."""
    n = len(names)
    out = []
    for k, name in enumerate(names):
        i = 1 if n == 1 else min(len(DEMO_SETS) - 1, k * len(DEMO_SETS) // n)
        params, frame, gear, scale = DEMO_SETS[i]
        out.append(JointSetup(str(name), params, frame, gear, scale))
    return out


@dataclass(frozen=True)
class JointSettings:
    """What joint_sim simulates for one joint during one cycle."""

    temperature: float
    gravity_torque: float
    wear: float = 0.0


@dataclass(frozen=True)
class PlannedCycle:
    """One cycle of the run: ``stage`` is ``baseline`` (w = 0, commissioned on), ``overload`` (expected to fail:
    skipped) or ``test`` (other wear levels, estimated with the commissioned sets); ``settings`` per joint."""

    stage: str
    settings: Mapping[str, JointSettings] = field(default_factory=dict)


def warm_up(k: int, n: int, cold: float = 20.0, warm: float = 48.0, tau: float = 0.45) -> float:
    """Temperature (degC) of baseline cycle ``k`` of ``n``: a joint warming from ``cold`` towards ``warm``,
    first-order (time constant ``tau`` of the run), so the early cycles rise fastest."""
    x = k / max(n - 1, 1)
    return cold + (warm - cold) * (1.0 - math.exp(-x / tau)) / (1.0 - math.exp(-1.0 / tau))


def plan_commissioning(joints: Sequence[JointSetup], baseline_cycles: int = 6, test_wear: Sequence[float] = (10, 30, 40),
                       overload: bool = True, test_temperature: float = 38.0) -> list[PlannedCycle]:
    """The cycles of a commissioning run (see the module docstring).

    Each joint's baseline temperature follows :func:`warm_up`, offset by up to 3 degC per joint (the joints of
    one arm do not warm alike); the gravity of its window takes :data:`BASELINE_GRAVITY` in turn, shifted per
    joint so load and temperature do not move together. ``test_wear`` is spread over the joints in turn (one
    test cycle); the test cycle runs at ``test_temperature`` (the estimate is not told it)."""
    if baseline_cycles < MIN_BASELINE_CYCLES:
        raise InputDataError(f"{baseline_cycles} baseline cycle(s); commissioning needs at least "
                             f"{MIN_BASELINE_CYCLES}")
    if not test_wear:
        raise InputDataError("no test wear levels: give at least one (e.g. 10,30,40)")
    plan: list[PlannedCycle] = []
    if overload and joints:
        first = joints[0].name
        plan.append(PlannedCycle("overload", {
            j.name: JointSettings(warm_up(0, baseline_cycles), OVERLOAD_GRAVITY if j.name == first else 0.1)
            for j in joints}))
    for k in range(baseline_cycles):
        plan.append(PlannedCycle("baseline", {
            j.name: JointSettings(round(warm_up(k, baseline_cycles) + 1.5 * (i % 3) * min(k, 1), 2),
                                  BASELINE_GRAVITY[(k + 3 * i) % len(BASELINE_GRAVITY)])
            for i, j in enumerate(joints)}))
    plan.append(PlannedCycle("test", {
        j.name: JointSettings(test_temperature, TEST_GRAVITY, float(test_wear[i % len(test_wear)]))
        for i, j in enumerate(joints)}))
    return plan


#: Columns of a commissioning table taken from a FrictionObservation (beside ``cycle`` and ``time``).
_FIELDS = ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position")


def observation_table(rows: Sequence[Mapping[str, Any]], source: str, temperature: bool = True,
                      noise_std: float = 0.0) -> ObservationTable:
    """One joint's observations (dicts of FrictionObservation fields with ``cycle_id`` and optionally ``time``,
    the stamp in s; the table's ``time`` counts from the first) as a table in the suite's units; ``temperature=False`` leaves the temperature out (unknown to the
    estimator). ``noise_std`` > 0 is added to each ``tau_f_std`` in quadrature, as the wear_estimator node does
    with its ``observation_noise_std`` (a window's own scatter says nothing of the sweep-to-sweep scatter).
    A column that is NaN throughout is left out, as a bag reader does."""
    if not rows:
        raise InputDataError(f"{source}: no observations")
    cols: dict[str, np.ndarray] = {"cycle": np.array([float(r["cycle_id"]) for r in rows])}
    if all("time" in r for r in rows):  # seconds since the first observation (epoch stamps lose the span)
        t = np.array([float(r["time"]) for r in rows])
        cols["time"] = t - np.nanmin(t)
    for f in _FIELDS:
        if f == "temperature" and not temperature:
            continue
        if not all(f in r for r in rows):
            continue
        x = np.array([math.nan if r[f] is None else float(r[f]) for r in rows])
        if f in ("speed", "tau_f") or not np.all(np.isnan(x)):
            cols[f] = x
    if noise_std > 0 and "tau_f_std" in cols:
        cols["tau_f_std"] = np.sqrt(np.nan_to_num(cols["tau_f_std"]) ** 2 + noise_std**2)
    return ObservationTable(cols, source=source)
