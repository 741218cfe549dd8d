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
    "ARM_APPROACH_SPEED",
    "ARM_LOADING",
    "ARM_SET",
    "DEMO_SETS",
    "MIN_BASELINE_CYCLES",
    "OVERLOAD_GRAVITY",
    "ArmLoading",
    "JointSettings",
    "JointSetup",
    "PlannedCycle",
    "arm_joints",
    "demo_joints",
    "load_identifiable",
    "load_span",
    "observation_table",
    "plan_arm_commissioning",
    "plan_commissioning",
    "unloaded_joints",
    "window_range",
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
    """What joint_sim simulates for one joint during one cycle. On an arm, ``gravity_torque`` is not set in
    joint_sim: it is the planned load, the gravity torque of the arm's pose and payload at the joint's window
    centre (normalized), and ``position`` is that window centre (test_cycle's ``<joint>.position``, rad)."""

    temperature: float
    gravity_torque: float
    wear: float = 0.0
    position: float | None = None


@dataclass(frozen=True)
class PlannedCycle:
    """One cycle of the run: ``stage`` is ``baseline`` (w = 0, commissioned on), ``overload`` (expected to fail:
    skipped) or ``test`` (other wear levels, estimated with the commissioned sets); ``settings`` per joint."""

    stage: str
    settings: Mapping[str, JointSettings] = field(default_factory=dict)
    #: on an arm: the payload of the cycle (joint_sim's ``payload``, kg); None: independent joints
    payload: float | None = None
    #: the joint expected to trip test_cycle's effort limit (an overload cycle), "" otherwise
    overloaded: str = ""


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
                      noise_std: float = 0.0, load: bool = True) -> ObservationTable:
    """One joint's observations (dicts of FrictionObservation fields with ``cycle_id`` and optionally ``time``,
    the stamp in s; the table's ``time`` counts from the first) as a table in the suite's units; ``temperature=False`` leaves the temperature out (unknown to the
    estimator), ``load=False`` the load torque (a joint whose load cannot be identified). ``noise_std`` > 0 is added to each ``tau_f_std`` in quadrature, as the wear_estimator node does
    with its ``observation_noise_std`` (a window's own scatter says nothing of the sweep-to-sweep scatter).
    A column that is NaN throughout is left out, as a bag reader does."""
    if not rows:
        raise InputDataError(f"{source}: no observations")
    cols: dict[str, np.ndarray] = {"cycle": np.array([float(r["cycle_id"]) for r in rows])}
    if all("time" in r for r in rows):  # seconds since the first observation (epoch stamps lose the span)
        t = np.array([float(r["time"]) for r in rows])
        cols["time"] = t - np.nanmin(t)
    for f in _FIELDS:
        if (f == "temperature" and not temperature) or (f == "load_torque" and not load):
            continue
        if not all(f in r for r in rows):
            continue
        x = np.array([math.nan if r[f] is None else float(r[f]) for r in rows])
        if f in ("speed", "tau_f") or not np.all(np.isnan(x)):
            cols[f] = x
    if noise_std > 0 and "tau_f_std" in cols:
        cols["tau_f_std"] = np.sqrt(np.nan_to_num(cols["tau_f_std"]) ** 2 + noise_std**2)
    return ObservationTable(cols, source=source)


# --------------------------------------------------------------------------- on a real arm

@dataclass(frozen=True)
class ArmLoading:
    """How a commissioning run changes the load of an arm's joints from cycle to cycle, as on the real arm: the
    payload at the flange (``payload``: the largest of the baseline cycles, kg) and the pose (each joint's window
    centre shifted by up to ``pose_step`` rad from the arm's test pose, inside its limits). ``overload_payload``
    (kg) takes a joint over test_cycle's effort limit as the cycle starts to move; ``speeds`` (motor rad/s) are
    the run's default speeds (None: test_cycle's)."""

    payload: float
    overload_payload: float
    speeds: tuple[float, ...] | None = None
    pose_step: float = 0.25
    #: the direction each joint's centre is shifted in (one per joint, in order; None: alternating joint to joint,
    #: each cycle's shift taken with its sign): on the Panda, the shoulder (joint 2) leans back and the elbow
    #: (joint 4) folds, away from the stretched poses where the line's shoulder torque nears its effort limit
    pose_signs: tuple[float, ...] | None = None
    #: the test cycle's shift from the test pose, as a share of ``pose_step`` in each joint's ``pose_signs``
    test_pose: float = 0.0
    #: per joint, a shift every cycle takes beside its own (share of ``pose_step`` in ``pose_signs``; None: none):
    #: the Panda's shoulder stays leaning back
    pose_offset: tuple[float, ...] | None = None
    #: how far each joint's test window reaches either side of its centre at the run's top speed, rad (window,
    #: run-up, stopping allowance; about 1.2 rad at 160 rad/s, gear 100, 4 rad/s^2; 0.6 at 80 rad/s): a centre
    #: is shifted only as far as its window stays inside the cell's joint limits
    reach: float = 1.3


#: The loading of each arm (measured with ``simcell.run_cycle`` and the ROS demo, every joint at once, 20-48 degC):
#: the UR5 carries 0-4 kg (the test cycle 2 kg, its pose half a step up: at the test pose 2 kg loads the shoulder
#: more than any baseline cycle, and the test cycle should lie inside the commissioned loads) on 7 speeds, its shoulder (joint 2) shifted up and its elbow
#: folded (at 5 kg and the shoulder 0.25 rad nearer horizontal the live cell tripped the shoulder at 143-145 N·m >
#: 142.5); 15 kg trips the shoulder as it accelerates. The
#: Panda's top speed 160 rad/s tripped its shoulder (joint 2, 83 N·m > 82.65) at 1 kg and 120 rad/s its wrist
#: (joint 6, 11.6 N·m > 11.4) at 2 kg: its run stops at 80 rad/s and 1.5 kg, its shoulder leaning back 0.4-0.8 rad,
#: its elbow folding and its wrist (joint 6) bending back (the live cell, at the test pose leaning 0.2 rad back, still tripped the
#: shoulder at 87 N·m > 82.65 braking at the sweep's end); 5 kg trips joint 6. So the Panda's top speed, the only
#: one with a lever on the unknown temperature (viscous friction falls with T), stays low: it sweeps 80 rad/s twice
#: (stop 45, docs/arm.md: nine seeds of the in-process run, 63 joint estimates, rms z 0.79 -> 0.64, largest |z|
#: 3.08 -> 1.87, the base joint's std 2.98 -> 2.47 on average; 18 s more cell time in the run's 8 cycles).
ARM_LOADING: dict[str, ArmLoading] = {
    "ur5": ArmLoading(payload=4.0, overload_payload=15.0, speeds=(10.0, 20.0, 30.0, 40.0, 50.0, 80.0, 120.0),
                      pose_signs=(1.0, -1.0, 1.0, 1.0, -1.0, 1.0), test_pose=0.5),
    "panda": ArmLoading(payload=1.5, overload_payload=5.0, speeds=(10.0, 20.0, 30.0, 40.0, 60.0, 80.0, 80.0),
                        pose_step=0.4,
                        pose_signs=(1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0), test_pose=0.5, reach=0.9,
                        pose_offset=(0.0, 1.0)),
}
#: test_cycle's approach speed on an arm during commissioning, joint rad/s (its default 0.5): with a payload the
#: shoulder lags the other joints on the approach line, and the live cell (3x and 2x real time) tripped its
#: ``hold_tolerance`` (0.020-0.027 rad off the line) at 3.4 kg; half the speed halves the lag.
ARM_APPROACH_SPEED = 0.25
#: The parameter set every joint of an arm runs in the sim (``joint_sim``'s default, sized by each joint's torque
#: scale = effort / 2 and gear 100): commissioning identifies each joint's own model from its baseline all the same.
ARM_SET = "ref-2011r"
#: Payload of each baseline cycle as a share of :attr:`ArmLoading.payload`, taken in turn.
BASELINE_PAYLOAD = (0.0, 1.0, 0.5, 0.85, 0.2, 0.65, 0.1, 0.9)
#: Pose shift of each baseline cycle as a share of :attr:`ArmLoading.pose_step` (the sign alternates joint to joint),
#: taken in turn; shifted against the payload's order so that load, pose and temperature do not move together.
BASELINE_POSE = (0.0, -1.0, 1.0, 0.5, -0.5, -1.0, 1.0, 0.0)
#: Payload of the test cycle, as a share of :attr:`ArmLoading.payload` (at the arm's test pose).
TEST_PAYLOAD = 0.5
#: The cell's sweep range about the arm's test pose, rad (``simcell.ARM_SWEEP_RANGE``; commission ranks below simcell).
ARM_SWEEP_RANGE = 1.6
#: A joint whose planned gravity load stays under this (normalized: 1 % of its effort limit) has no load to identify.
MIN_ARM_LOAD = 0.02


def arm_joints(arm: str, names: Sequence[str]) -> list[JointSetup]:
    """The joints of a commissioning run on arm ``arm``: each runs :data:`ARM_SET` at the arm joint's gear ratio
    and torque scale (:mod:`jointwear_ros.sim.arms`), commissioned in the suite's units (motor side, normalized)."""
    from ..sim.arms import arm_spec

    return [JointSetup(str(n), ARM_SET, "joint", j.gear_ratio, j.torque_scale)
            for n, j in zip(names, arm_spec(arm).for_names(names), strict=False)]


def window_range(arm: str, names: Sequence[str], reach: float = 1.3) -> dict[str, tuple[float, float]]:
    """Where each joint's window centre may go on arm ``arm`` (rad): ``reach`` inside the cell's joint limits (the
    URDF's less 0.05, at most :data:`ARM_SWEEP_RANGE` from the test pose), the test pose always."""
    from ..sim.arms import arm_spec

    out = {}
    for n, j in zip(names, arm_spec(arm).for_names(names), strict=False):
        lo = max(j.lower + 0.05, j.home - ARM_SWEEP_RANGE) + reach
        hi = min(j.upper - 0.05, j.home + ARM_SWEEP_RANGE) - reach
        out[str(n)] = (min(lo, j.home), max(hi, j.home))
    return out


def plan_arm_commissioning(arm: str, joints: Sequence[JointSetup], baseline_cycles: int = 6,
                           test_wear: Sequence[float] = (10, 30, 40), overload: bool = True,
                           test_temperature: float = 38.0, loading: ArmLoading | None = None) -> list[PlannedCycle]:
    """The cycles of a commissioning run on arm ``arm`` (:func:`plan_commissioning`'s stages and warm-up).

    What changes a joint's load from cycle to cycle is what changes it on the real arm: the payload
    (:data:`BASELINE_PAYLOAD` of ``loading.payload``) and the pose (each window centre shifted by
    :data:`BASELINE_POSE` of ``loading.pose_step``, inside :func:`window_range`). Each joint's planned load
    (``gravity_torque``) is the arm's gravity torque at the cycle's window centres and payload (Pinocchio,
    normalized by the joint's torque scale); the sweep adds the Coriolis and centrifugal push, which the observer
    measures. The overload cycle carries ``loading.overload_payload`` at the test pose; ``overloaded`` names the
    joint it loads nearest its effort limit. The test cycle carries :data:`TEST_PAYLOAD` at the test pose shifted
    by ``loading.test_pose``.

    >>> js = arm_joints("ur5", [f"joint_{i}" for i in range(1, 7)])
    >>> plan = plan_arm_commissioning("ur5", js, baseline_cycles=4)
    >>> [(c.stage, c.payload) for c in plan]
    [('overload', 15.0), ('baseline', 0.0), ('baseline', 4.0), ('baseline', 2.0), ('baseline', 3.4), ('test', 2.0)]
    >>> plan[0].overloaded, [round(load_span(plan, j.name)[1], 2) for j in js]
    ('joint_2', [0.0, 0.33, 0.22, 0.05, 0.0, 0.03])
    >>> sorted(unloaded_joints(plan))  # the base joint's axis is vertical; wrist 2's passes through the load
    ['joint_1', 'joint_5']
    """
    from ..sim.arm import ArmSim, arm_configs
    from ..sim.arms import arm_spec

    if baseline_cycles < MIN_BASELINE_CYCLES:
        raise InputDataError(f"{baseline_cycles} baseline cycle(s); commissioning needs at least "
                             f"{MIN_BASELINE_CYCLES}")
    if not test_wear:
        raise InputDataError("no test wear levels: give at least one (e.g. 10,30,40)")
    spec = arm_spec(arm)
    loading = loading or ARM_LOADING[spec.name]
    names = [j.name for j in joints]
    if not names:
        raise InputDataError("no joints to commission")
    home = {n: j.home for n, j in zip(names, spec.for_names(names), strict=False)}
    allowed = window_range(spec.name, names, loading.reach)
    scale = {j.name: j.torque_scale for j in joints}
    model = ArmSim(spec, names, arm_configs(spec, names), seeds=range(len(names)))

    def loads(payload: float, centres: Mapping[str, float]) -> dict[str, float]:
        model.set_payload(payload)
        g = model.inverse_dynamics([centres[n] for n in names], [0.0] * len(names))
        return {n: float(g[i]) / scale[n] for i, n in enumerate(names)}

    def cycle(stage: str, payload: float, centres: Mapping[str, float], temps: Mapping[str, float],
              wear: Mapping[str, float] | None = None) -> PlannedCycle:
        g = loads(payload, centres)
        return PlannedCycle(stage, {n: JointSettings(temps[n], round(g[n], 4), (wear or {}).get(n, 0.0),
                                                     round(centres[n], 4)) for n in names}, round(payload, 4))

    plan: list[PlannedCycle] = []
    if overload:
        pc = cycle("overload", loading.overload_payload, home, dict.fromkeys(names, warm_up(0, baseline_cycles)))
        limit = {j.name: 0.95 * 2.0 for j in joints}  # test_cycle's effort limit: 95 % of the URDF's = 2 x scale
        worst = max(names, key=lambda n: abs(pc.settings[n].gravity_torque) / limit[n])
        plan.append(PlannedCycle(pc.stage, pc.settings, pc.payload, worst))
    for k in range(baseline_cycles):
        centres = _centres(home, allowed, loading, BASELINE_POSE[k % len(BASELINE_POSE)])
        temps = {n: round(warm_up(k, baseline_cycles) + 1.5 * (i % 3) * min(k, 1), 2) for i, n in enumerate(names)}
        plan.append(cycle("baseline", loading.payload * BASELINE_PAYLOAD[k % len(BASELINE_PAYLOAD)], centres, temps))
    plan.append(cycle("test", loading.payload * TEST_PAYLOAD, _centres(home, allowed, loading, loading.test_pose),
                      dict.fromkeys(names, test_temperature),
                      {n: float(test_wear[i % len(test_wear)]) for i, n in enumerate(names)}))
    return plan


def _centres(home: Mapping[str, float], allowed: Mapping[str, tuple[float, float]], loading: ArmLoading,
             share: float) -> dict[str, float]:
    """Each joint's window centre shifted ``share`` of ``loading.pose_step`` from ``home``, inside ``allowed``."""
    out = {}
    for i, n in enumerate(home):
        signs = loading.pose_signs
        shift = share * loading.pose_step * (-1) ** i if signs is None else \
            (_nth(loading.pose_offset, i) + abs(share)) * loading.pose_step * _nth(signs, i)
        out[n] = min(max(home[n] + shift, allowed[n][0]), allowed[n][1])
    return out


def unloaded_joints(plan: Sequence[PlannedCycle]) -> dict[str, str]:
    """The joints whose planned gravity load stays under :data:`MIN_ARM_LOAD` over the baseline (an axis that stays
    vertical, or a load through the axis), each with why its load dependence cannot be identified: their
    commissioning leaves the load column out (their sets then hold for the loads measured, as
    :func:`~jointwear_ros.commission.commission` says)."""
    out = {}
    names = next((list(c.settings) for c in plan if c.stage == "baseline"), [])
    for n in names:
        lo, hi = load_span(plan, n)
        if hi < MIN_ARM_LOAD:
            out[n] = (f"{n}: its gravity load stays {lo:.3f}-{hi:.3f} (normalized; under {MIN_ARM_LOAD:g}, 1 % of its "
                      "effort limit) in every pose and payload of the baseline: its axis stays vertical or the load "
                      "passes through it, so its load dependence cannot be identified; commissioned without the load "
                      "column (only the speed's Coriolis push loads it)")
    return out


def _nth(values: Sequence[float] | None, i: int) -> float:
    """``values[i]``, 0 beyond its end or without values."""
    return float(values[i]) if values is not None and i < len(values) else 0.0


def load_span(plan: Sequence[PlannedCycle], joint: str) -> tuple[float, float]:
    """The smallest and largest planned load (|gravity torque|, normalized) of ``joint`` over the baseline cycles."""
    x = [abs(c.settings[joint].gravity_torque) for c in plan if c.stage == "baseline"]
    return (min(x), max(x)) if x else (0.0, 0.0)


def load_identifiable(plan: Sequence[PlannedCycle], joint: str) -> bool:
    """Whether the baseline's planned loads of ``joint`` identify its load dependence: its gravity load reaches
    :data:`MIN_ARM_LOAD` and spans commissioning's ``MIN_LOAD_SPAN`` of its largest (the measured load adds the
    speed's Coriolis push; the commissioning itself decides on the measured one)."""
    from .core import MIN_LOAD_SPAN

    lo, hi = load_span(plan, joint)
    return hi >= MIN_ARM_LOAD and hi - lo >= MIN_LOAD_SPAN * hi
