"""A simulated production on the rigid-body arm: programs as data, and an executor that records what a cell sees.

A :class:`ProductionProgram` is what a robot program is to a cell: named joint-space waypoints of one arm
(:mod:`.arms`) and the moves between them. Each :class:`Move` goes in a straight line in joint space to a
waypoint at a cruise speed (a ``fraction`` of every joint's URDF velocity limit, or ``absolute`` joint-side
rad/s: no joint of the move goes faster, and the joint that needs longest sets the pace), then dwells; a
move may pick the payload up (``event="pick"``, at its end) or put it down (``"place"``). The program runs
its ``prologue`` once (from ``start``) and then repeats its ``cycle``, which ends where it begins.

Two programs ship for the UR5 and the Panda (:func:`pick_and_place`, :func:`machine_tending`); their
waypoints are inside the URDF limits and every move is clear of the arm's own links and the table
(:func:`check_program`, the collision module's 1 cm clearance; ``test/test_production_sim.py`` asserts it):

- **pick_and_place**: home -> above pick; then each cycle: down slowly to pick (approach), pick (the payload
  on), up (retract), transfer to above place, down, place (the payload off), up, transfer back along the
  *same* line to above pick. Every line of the cycle is passed forward and back, the payload on in one
  direction only (down to pick without it, up with it; transfer out with it, back without it). Approaches
  and retracts cruise at 6 % of the velocity limits, transfers at 30 %: the joints that move see two cruise
  speeds each. The tool-flange joint (the UR5's ``wrist_3``, the Panda's joint 7) is held: the program
  never moves it (a gripper's rotation is held when parts lie the same way).
- **machine_tending**: A -> B -> C -> A, a loop whose lines are not retraced (at 25, 20 and 30 %).

:func:`run_production` drives an :class:`~.arm.ArmSim` through a program for shifts of cycles and records
what ``/joint_states`` would carry (time, position, velocity, effort: the drive's torque with its noise,
N·m, joint side) with each joint's temperature and the payload, plus the truth (:class:`ProductionRun`).

**The motion.** Each move is one trapezoid in a path parameter ``λ`` (0 -> 1) for all joints, so every
joint of a move reaches its cruise speed at the same instant and the path is the line also while
accelerating: ``q_ref(λ) = q_from + λ D``; cruise ``λ' = min_j(v_max,j / |D_j|)``, acceleration
``λ'' = min_j(acceleration / |D_j|)`` (the program's ``acceleration``, joint rad/s², below the drives'
8 rad/s² reference ramp). Each joint is commanded ``D_j λ'(t + dt/2)`` (the mean over the sample period
the command holds) plus a position correction toward the nearest point of the line (gain
:data:`CORRECTION_GAIN`, clipped to :data:`CORRECTION_FRACTION` of the joint's cruise speed: a lag along
the line is left alone, a joint's drift off the line is pulled back, and the cruise speed stays within
0.5 % of its value). After the reference ends, each joint is pulled to the waypoint (within
:data:`ARRIVAL_TOLERANCE`, at most :data:`ARRIVAL_TIMEOUT`), then commanded zero for the dwell.

**Self-heating** (:class:`SelfHeating`). Every ``update_period`` seconds each joint's temperature takes one
exact step of the first-order law ``dT/dt = (T_start + rise * m - T) / time_constant``, ``m`` the fraction
of that period's samples in which the joint moved (motor speed above :data:`MOVING_SPEED`): a joint that
keeps moving heats toward ``T_start + rise``, a held one cools back toward ``T_start``. The friction is
rebuilt at the new temperature (a :class:`~.friction.FrictionTable` build costs about 13 ms: hence a
period of seconds); the temperature recorded with each sample is the one the friction model uses.

**Wear** is set per shift (a number for every joint, one per joint, one list per shift, or a callable of
the shift index); the drive's per-sweep friction offset (:class:`~.joint.JointSimConfig` ``noise_std``) is
drawn at every change of a joint's direction, the effort noise at every sample, from per-joint generators
seeded ``seed + i``: a run is deterministic for a seed.

Cost: about 80-90 µs per physics step at 1 kHz (the held flange joint sits in the drive's stick band, solved
with the inertia matrix at every step), 5-6 CPU seconds per simulated minute (``bench/bench_production_sim.py``).
Memory: every sample is kept (6 joints at 250 Hz: about 3 MB of arrays per simulated minute, several times
that in lists while the run goes).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError, ParameterError
from .arms import ArmSpec, arm_spec

__all__ = ["ARRIVAL_TIMEOUT", "ARRIVAL_TOLERANCE", "CORRECTION_FRACTION", "CORRECTION_GAIN", "EVENTS", "MOVING_SPEED",
           "PROGRAMS", "Move", "MoveRecord", "ProductionProgram", "ProductionRun", "SelfHeating", "check_program",
           "machine_tending", "pick_and_place", "production_program", "run_production"]

Array = npt.NDArray[np.float64]

#: Gain of the position correction toward the line, 1/s (a time constant of 0.2 s).
CORRECTION_GAIN = 5.0
#: The correction's limit: this fraction of the joint's cruise speed (keeps the cruise speed constant).
CORRECTION_FRACTION = 0.005
#: A move has arrived when every joint is within this of its waypoint, rad.
ARRIVAL_TOLERANCE = 1e-3
#: The longest pull to a waypoint after a move's reference has ended, s.
ARRIVAL_TIMEOUT = 1.0
#: A joint moves (self-heating) above this motor speed, rad/s.
MOVING_SPEED = 1.0
#: The payload events a move may end with.
EVENTS = ("", "pick", "place")


@dataclass(frozen=True)
class Move:
    """One move of a program: a straight joint-space line to waypoint ``to``, then a dwell.

    ``speed``: the cruise speed, a fraction (0, 1] of every joint's URDF velocity limit, or with
    ``absolute`` joint-side rad/s that no joint of the move exceeds. ``dwell``: seconds at rest at the end.
    ``event``: ``"pick"`` (the payload on at the end) or ``"place"`` (off), or ``""``. ``label`` names it."""

    to: str
    speed: float
    dwell: float = 0.0
    event: str = ""
    absolute: bool = False
    label: str = ""


@dataclass(frozen=True)
class ProductionProgram:
    """A robot program for one arm (module docstring): waypoints (name -> one position per arm joint, rad),
    ``start`` (where the arm stands first), a ``prologue`` run once, a ``cycle`` repeated (it ends where it
    begins), the moves' acceleration (joint rad/s², the fastest joint of a move) and the payload a pick takes
    (kg; :func:`run_production` may override it)."""

    name: str
    arm: str
    waypoints: Mapping[str, tuple[float, ...]]
    start: str
    prologue: tuple[Move, ...]
    cycle: tuple[Move, ...]
    acceleration: float = 3.0
    payload: float = 2.0
    #: what the program holds still throughout, and why (documentation)
    held: tuple[str, ...] = ()

    def lines(self) -> list[tuple[str, str, Move]]:
        """``(from, to, move)`` of every move: the prologue from ``start``, then one cycle."""
        out: list[tuple[str, str, Move]] = []
        at = self.start
        for m in self.prologue + self.cycle:
            out.append((at, m.to, m))
            at = m.to
        return out

    @property
    def cycle_start(self) -> str:
        """The waypoint the cycle begins (and ends) at."""
        return self.prologue[-1].to if self.prologue else self.start


def _fail(program: ProductionProgram, what: str) -> InputDataError:
    return InputDataError(f"production program {program.name!r} ({program.arm}): {what}")


def _spec(program: ProductionProgram) -> ArmSpec:
    try:
        return arm_spec(program.arm)
    except ParameterError as exc:
        raise _fail(program, str(exc)) from None


def cruise(program: ProductionProgram, frm: str, move: Move, spec: ArmSpec | None = None) -> tuple[Array, float, float]:
    """The line of ``move`` from waypoint ``frm``: ``(D, λ', λ'')`` (module docstring), D in rad."""
    spec = spec or _spec(program)
    d = np.asarray(program.waypoints[move.to], dtype=float) - np.asarray(program.waypoints[frm], dtype=float)
    vmax = np.array([move.speed if move.absolute else move.speed * j.velocity for j in spec.joints])
    span = np.abs(d)
    moving = span > 0.0
    if not moving.any():
        return d, 0.0, 0.0
    lam_v = float(np.min(vmax[moving] / span[moving]))
    lam_a = float(np.min(program.acceleration / span[moving]))
    return d, lam_v, lam_a


def check_program(program: ProductionProgram, collisions: bool = True) -> float:
    """Check a program before it runs: every waypoint finite and inside the arm's URDF limits, every move's
    waypoint known, speed > 0 (a fraction at most 1, an absolute speed at most the slowest limit of the
    joints it moves), dwell >= 0, a known event, the cycle ending where it begins, the acceleration and
    payload valid; with ``collisions``, every move clear of the arm's links and the table
    (:class:`~.collision.CollisionChecker`, its clearances). Returns the least margin of the program's
    moves (m); one :class:`InputDataError` line at the first problem."""
    spec = _spec(program)
    n = len(spec.joints)
    for name, q in program.waypoints.items():
        if len(q) != n:
            raise _fail(program, f"waypoint {name!r} has {len(q)} positions, the arm has {n} joints")
        for j, x in zip(spec.joints, q, strict=True):
            if not (math.isfinite(x) and j.lower <= x <= j.upper):
                raise _fail(program, f"waypoint {name!r}: {j.name} at {x:g} rad is outside its limits "
                                     f"[{j.lower:g}, {j.upper:g}] rad")
    if program.start not in program.waypoints:
        raise _fail(program, f"start {program.start!r} is not a waypoint ({', '.join(program.waypoints)})")
    if not program.cycle:
        raise _fail(program, "the cycle has no move")
    if not (math.isfinite(program.acceleration) and program.acceleration > 0):
        raise _fail(program, f"acceleration must be > 0 rad/s^2, got {program.acceleration}")
    if not (math.isfinite(program.payload) and program.payload >= 0):
        raise _fail(program, f"payload must be >= 0 kg, got {program.payload}")
    for k, (frm, to, m) in enumerate(program.lines()):
        what = f"move {k + 1} ({m.label or frm + ' -> ' + to})"
        if to not in program.waypoints:
            raise _fail(program, f"{what}: waypoint {to!r} is not defined ({', '.join(program.waypoints)})")
        if not (math.isfinite(m.speed) and m.speed > 0):
            raise _fail(program, f"{what}: speed must be > 0, got {m.speed}")
        if not m.absolute and m.speed > 1.0:
            raise _fail(program, f"{what}: speed {m.speed:g} is a fraction of the velocity limits, at most 1")
        if m.absolute:
            d = np.abs(np.asarray(program.waypoints[to], dtype=float) - np.asarray(program.waypoints[frm]))
            lim = min((j.velocity for j, x in zip(spec.joints, d, strict=True) if x > 0), default=math.inf)
            if m.speed > lim:
                raise _fail(program, f"{what}: speed {m.speed:g} rad/s is above a moving joint's limit {lim:g} rad/s")
        if not (math.isfinite(m.dwell) and m.dwell >= 0):
            raise _fail(program, f"{what}: dwell must be >= 0 s, got {m.dwell}")
        if m.event not in EVENTS:
            raise _fail(program, f"{what}: event {m.event!r} is not one of pick, place or none")
    if program.cycle[-1].to != program.cycle_start:
        raise _fail(program, f"the cycle ends at {program.cycle[-1].to!r}, not where it begins "
                             f"({program.cycle_start!r})")
    if not collisions:
        return math.nan
    from .collision import collision_checker

    checker = collision_checker(spec.name, n)
    best = math.inf
    for k, (frm, to, m) in enumerate(program.lines()):
        c = checker.sweep_closest(program.waypoints[frm], program.waypoints[to])
        if c.collides:
            raise _fail(program, f"move {k + 1} ({m.label or frm + ' -> ' + to}): {c.describe()}")
        best = min(best, c.margin)
    return best


# --------------------------------------------------------------------------- the programs

_SLOW = 0.06  # approaches and retracts: this fraction of the velocity limits
_FAST = 0.30  # transfers

_PICK_PLACE: dict[str, dict[str, tuple[float, ...]]] = {
    # UR5: the tool points down over pick (y < 0) and over place (y > 0, tilted 0.3 rad by wrist 2);
    # wrist_3 held at 0. The upper arm stays 1.9 cm from the table (the closest pair of every move).
    "ur5": {"home": (0.0, -1.3, 0.3, 0.7, 0.0, 0.0),
            "above_pick": (-0.9, -1.2, 1.6, -1.97, -1.5708, 0.0),
            "pick": (-0.9, -0.95, 1.75, -2.37, -1.5708, 0.0),
            "above_place": (0.8, -1.45, 1.45, -1.57, -1.2708, 0.0),
            "place": (0.8, -1.2, 1.65, -2.02, -1.2708, 0.0)},
    # Panda: the hand points down over pick, tilted over place; joint 7 held at 0.785.
    "panda": {"home": (0.0, -0.3, 0.0, -1.65, 0.0, 2.5, 0.785),
              "above_pick": (-0.8, 0.1, 0.0, -2.2, 0.0, 2.3, 0.785),
              "pick": (-0.8, 0.4, 0.0, -2.0, 0.0, 2.4, 0.785),
              "above_place": (0.7, -0.1, 0.3, -2.4, -0.3, 2.3, 0.785),
              "place": (0.7, 0.2, 0.3, -2.2, -0.3, 2.4, 0.785)},
}
_TENDING: dict[str, dict[str, tuple[float, ...]]] = {
    "ur5": {"A": (-1.6, -1.5, 1.4, -1.5, -1.5708, 0.0),
            "B": (-0.5, -1.0, 1.9, -2.4, -1.2, 0.0),
            "C": (0.6, -1.7, 1.0, -0.9, -1.9, 0.0)},
    "panda": {"A": (-1.3, -0.2, 0.0, -2.3, 0.0, 2.1, 0.785),
              "B": (-0.3, 0.3, 0.3, -2.0, 0.3, 2.3, 0.785),
              "C": (0.9, -0.4, -0.3, -2.6, -0.3, 2.2, 0.785)},
}
_HELD = {"ur5": ("wrist_3_joint",), "panda": ("panda_joint7",)}


def _arm_name(arm: str | ArmSpec) -> str:
    return arm.name if isinstance(arm, ArmSpec) else arm_spec(arm).name


def pick_and_place(arm: str | ArmSpec = "ur5", payload: float = 2.0) -> ProductionProgram:
    """The pick-and-place program of ``arm`` (module docstring); ``payload`` kg (2 on the UR5 by default)."""
    name = _arm_name(arm)
    return ProductionProgram(
        name="pick_and_place", arm=name, waypoints=dict(_PICK_PLACE[name]), start="home",
        prologue=(Move("above_pick", 0.2, dwell=0.5, label="home -> above pick"),),
        cycle=(Move("pick", _SLOW, dwell=0.5, event="pick", label="approach pick"),
               Move("above_pick", _SLOW, dwell=0.2, label="retract from pick"),
               Move("above_place", _FAST, dwell=0.2, label="transfer to place"),
               Move("place", _SLOW, dwell=0.5, event="place", label="approach place"),
               Move("above_place", _SLOW, dwell=0.2, label="retract from place"),
               Move("above_pick", _FAST, dwell=0.2, label="transfer back")),
        payload=float(payload), held=_HELD[name])


def machine_tending(arm: str | ArmSpec = "ur5", payload: float = 2.0) -> ProductionProgram:
    """The machine-tending loop A -> B -> C -> A of ``arm``: no line retraced (module docstring); the part is
    picked at A and placed at C."""
    name = _arm_name(arm)
    return ProductionProgram(
        name="machine_tending", arm=name, waypoints=dict(_TENDING[name]), start="A", prologue=(),
        cycle=(Move("B", 0.25, dwell=0.4, label="A -> B (load the machine)"),
               Move("C", 0.20, dwell=0.4, event="place", label="B -> C"),
               Move("A", 0.30, dwell=0.4, event="pick", label="C -> A")),
        payload=float(payload), held=_HELD[name])


#: The shipped programs by name.
PROGRAMS: dict[str, Callable[..., ProductionProgram]] = {"pick_and_place": pick_and_place,
                                                         "machine_tending": machine_tending}


def production_program(name: str, arm: str | ArmSpec = "ur5", **kwargs: Any) -> ProductionProgram:
    """The shipped program ``name`` for ``arm`` (one :class:`InputDataError` line for an unknown one)."""
    try:
        make = PROGRAMS[str(name)]
    except KeyError:
        raise InputDataError(f"unknown production program {name!r}; known: {', '.join(PROGRAMS)}") from None
    return make(arm, **kwargs)


# --------------------------------------------------------------------------- the run

@dataclass(frozen=True)
class SelfHeating:
    """First-order self-heating of every joint (module docstring): ``rise`` degC above its start temperature
    while it keeps moving, ``time_constant`` s, a step every ``update_period`` s. ``rise = 0``: none."""

    rise: float = 15.0
    time_constant: float = 1800.0
    update_period: float = 5.0

    def check(self) -> None:
        for what, v, lo in (("rise", self.rise, 0.0), ("time_constant", self.time_constant, 1e-9),
                            ("update_period", self.update_period, 1e-9)):
            if not (math.isfinite(v) and v >= lo):
                raise InputDataError(f"self-heating: {what} must be a finite number >= {lo:g}, got {v}")

    def step(self, temperature: Array, start: Array, moving: Array, dt: float) -> Array:
        """One exact step of ``dT/dt = (start + rise * moving - T) / time_constant`` over ``dt`` seconds."""
        target = start + self.rise * moving
        return target + (temperature - target) * math.exp(-dt / self.time_constant)


@dataclass
class MoveRecord:
    """One executed move: where it is in the run and the truth at its cruise.

    Times are simulated seconds: ``t_start`` (the reference starts), ``cruise`` (the reference's cruise
    starts, ends; the same instant for a move too short to reach its cruise speed), ``t_end`` (arrived).
    ``velocity``: each joint's cruise speed, joint side rad/s (0: the move does not move it; a move too
    short to reach its cruise: its peak). ``true_friction``: each moving joint's model friction at its cruise speed at the
    line's midpoint (every joint at its cruise speed; :meth:`~.arm.ArmSim.true_friction`, N·m, the current
    wear and temperature, the payload carried), NaN for a joint the move does not move; ``temperature``:
    each joint's there, degC."""

    index: int
    shift: int
    cycle: int  #: 0: the prologue; 1 ...: the cycles of the shift
    move: int  #: index of the move in the prologue + cycle
    label: str
    frm: str
    to: str
    t_start: float
    cruise: tuple[float, float]
    t_end: float
    velocity: tuple[float, ...]
    payload: float
    midpoint: tuple[float, ...]
    true_friction: tuple[float, ...]
    temperature: tuple[float, ...]

    def as_dict(self) -> dict[str, Any]:
        """Plain values for JSON (NaN as None)."""
        def clean(x: Any) -> Any:
            if isinstance(x, float):
                return None if not math.isfinite(x) else x
            if isinstance(x, (tuple, list)):
                return [clean(v) for v in x]
            return x
        return {k: clean(getattr(self, k)) for k in self.__dataclass_fields__}


@dataclass
class ProductionRun:
    """What :func:`run_production` simulated: the samples (one row per ``/joint_states`` sample: ``t`` s,
    ``q`` rad, ``v`` rad/s, ``effort`` N·m, ``temperature`` degC, ``payload`` kg, ``segment``: the index of
    the :class:`MoveRecord` whose reference runs, -1 between moves) and the truth."""

    arm: str
    program: ProductionProgram
    names: tuple[str, ...]
    arm_joints: tuple[str, ...]
    gear_ratio: tuple[float, ...]
    torque_scale: tuple[float, ...]
    t: Array
    q: Array
    v: Array
    effort: Array
    temperature: Array
    payload: Array
    segment: npt.NDArray[np.int64]
    moves: list[MoveRecord]
    #: per shift: each joint's wear, and the time the shift starts (s)
    wear: list[tuple[float, ...]]
    shift_start: list[float]
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        return float(self.t[-1]) if len(self.t) else 0.0

    def observe(self, observer: Any) -> list[Any]:
        """Feed every sample to ``observer`` (a :class:`~jointwear_ros.observer.ProductionObserver` of this run's
        joints) and end a shift at each of the run's shift starts: its :class:`~jointwear_ros.observer.production.
        ProductionShift` per shift (ids 1, 2, ...), what a node that ended the shifts there would have published."""
        out = []
        bounds = [*self.shift_start[1:], math.inf]
        k = 0
        for s, end in enumerate(bounds):
            while k < len(self.t) and self.t[k] < end:
                observer.add(float(self.t[k]), self.q[k], self.v[k], self.effort[k], self.temperature[k])
                k += 1
            out.append(observer.end_shift(s + 1))
        return out

    def truth(self) -> dict[str, Any]:
        """The truth as plain values (what :func:`~jointwear_ros.io.production_bag.record_production` stores)."""
        return {"arm": self.arm, "program": self.program.name, "joints": list(self.names),
                "arm_joints": list(self.arm_joints), "held": list(self.program.held),
                "wear": [list(w) for w in self.wear], "shift_start": list(self.shift_start),
                "settings": dict(self.settings), "moves": [m.as_dict() for m in self.moves]}


WearSpec = float | Sequence[float] | Sequence[Sequence[float]] | Callable[[int], Sequence[float]]


def _per_joint(value: float | Sequence[float], n: int, what: str, lo: float, hi: float) -> Array:
    arr = np.full(n, float(value)) if isinstance(value, (int, float)) else np.asarray(value, dtype=float)
    if arr.shape != (n,):
        raise InputDataError(f"production run: {what} needs one value or {n} (one per joint), got {arr.size}")
    if not (np.isfinite(arr).all() and (arr >= lo).all() and (arr <= hi).all()):
        raise InputDataError(f"production run: {what} must be in [{lo:g}, {hi:g}], got {arr.tolist()}")
    return arr


def _wear_of(wear: WearSpec, shift: int, n: int) -> Array:
    if callable(wear):
        return _per_joint(wear(shift), n, f"wear of shift {shift + 1}", 0.0, 100.0)
    if isinstance(wear, (int, float)):
        return _per_joint(wear, n, "wear", 0.0, 100.0)
    items = list(wear)
    if items and not isinstance(items[0], (int, float)):
        if shift >= len(items):
            raise InputDataError(f"production run: wear is given for {len(items)} shifts, shift {shift + 1} has none")
        return _per_joint(items[shift], n, f"wear of shift {shift + 1}", 0.0, 100.0)  # type: ignore[arg-type]
    return _per_joint(items, n, "wear", 0.0, 100.0)  # type: ignore[arg-type]


def _trap(tau: float, cruise_v: float, accel: float) -> tuple[float, float, float, float]:
    """(λ, λ') at ``tau`` of a rest-to-rest trapezoid over λ in [0, 1]; then its accel time and total."""
    if 1.0 >= cruise_v * cruise_v / accel:
        ta, vp = cruise_v / accel, cruise_v
        tc = 1.0 / cruise_v - cruise_v / accel
    else:
        ta = math.sqrt(1.0 / accel)
        vp, tc = accel * ta, 0.0
    total = 2.0 * ta + tc
    if tau <= 0.0:
        return 0.0, 0.0, ta, total
    if tau < ta:
        return 0.5 * accel * tau * tau, accel * tau, ta, total
    if tau < ta + tc:
        return 0.5 * accel * ta * ta + vp * (tau - ta), vp, ta, total
    if tau < total:
        td = total - tau
        return 1.0 - 0.5 * accel * td * td, accel * td, ta, total
    return 1.0, 0.0, ta, total


def run_production(arm: str | ArmSpec, program: ProductionProgram, *, shifts: int = 1, cycles: int | None = None,
                   duration: float | None = None, wear: WearSpec = 0.0, temperature: float | Sequence[float] = 40.0,
                   heating: SelfHeating | None = None, payload: float | None = None, seed: int = 0,
                   sample_rate: float = 250.0, physics_rate: float = 1000.0, check_collisions: bool = True,
                   speed_override: Sequence[float] = (1.0,),
                   progress: Callable[[int, int, float], None] | None = None) -> ProductionRun:
    """Run ``program`` on ``arm`` for ``shifts`` shifts of ``cycles`` program cycles each (or cycles started
    while less than ``duration`` simulated seconds of the shift have passed; give one of the two).

    ``wear``: per joint (a number for all, one per joint, one list per shift, or a callable of the shift
    index 0 ...); ``temperature``: each joint's start temperature, degC, from which ``heating``
    (:class:`SelfHeating`; default: its defaults) drifts; ``payload``: kg a pick takes (default: the
    program's); ``seed``: the joints' noise seeds are ``seed + i``; ``sample_rate``: samples recorded (and
    commands sent) per second; ``physics_rate``: the arm's integration rate. ``speed_override``: the program's
    speed override cycle by cycle (an operator's override or a product mix): cycle ``c`` (1, 2, ... counted over
    the whole run) runs every move's cruise speed times ``speed_override[(c - 1) % len]``; the prologue runs at
    1. ``progress(shift, cycle,
    sim_time)`` is called after each cycle. Returns a :class:`ProductionRun`; bad input is one
    :class:`InputDataError` line.
    """
    from .arm import ArmSim, arm_configs

    spec = arm if isinstance(arm, ArmSpec) else arm_spec(arm)
    if program.arm != spec.name:
        raise InputDataError(f"production program {program.name!r} is for arm {program.arm}, not {spec.name}")
    check_program(program, collisions=check_collisions)
    n = len(spec.joints)
    if (cycles is None) == (duration is None):
        raise InputDataError("production run: give either cycles or duration per shift (one of them)")
    if cycles is not None and not (isinstance(cycles, int) and cycles >= 1):
        raise InputDataError(f"production run: cycles must be an integer >= 1, got {cycles!r}")
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise InputDataError(f"production run: duration must be > 0 s, got {duration}")
    if not (isinstance(shifts, int) and shifts >= 1):
        raise InputDataError(f"production run: shifts must be an integer >= 1, got {shifts!r}")
    for what, rate in (("sample_rate", sample_rate), ("physics_rate", physics_rate)):
        if not (math.isfinite(rate) and rate > 0):
            raise InputDataError(f"production run: {what} must be > 0 Hz, got {rate}")
    heat = heating if heating is not None else SelfHeating()
    heat.check()
    kg = program.payload if payload is None else float(payload)
    if not (math.isfinite(kg) and kg >= 0):
        raise InputDataError(f"production run: payload must be >= 0 kg, got {payload}")
    override = [float(x) for x in speed_override]
    if not override or not all(math.isfinite(x) and x > 0 for x in override):
        raise InputDataError(f"production run: speed_override must be factors > 0, got {list(speed_override)!r}")
    for m in program.cycle:
        if not m.absolute and m.speed * max(override) > 1.0:
            raise InputDataError(f"production run: speed_override {max(override):g} takes move "
                                 f"{m.label or m.to!r} to {m.speed * max(override):g} of the velocity limits "
                                 "(at most 1)")
    t_start = _per_joint(temperature, n, "temperature", -50.0, 200.0)
    wear0 = _wear_of(wear, 0, n)

    names = tuple(f"joint_{i + 1}" for i in range(n))
    start_q = program.waypoints[program.start]
    configs = [replace(c, initial_position=float(x), wear=float(w), temperature=float(tt))
               for c, x, w, tt in zip(arm_configs(spec, names), start_q, wear0, t_start, strict=True)]
    sim = ArmSim(spec, names, configs, seeds=[seed + i for i in range(n)], physics_rate=physics_rate)
    gear = np.array([c.gear_ratio for c in configs])
    dt = 1.0 / sample_rate
    temp = t_start.copy()
    moving_count = np.zeros(n)
    period_samples = 0
    next_heat = heat.update_period

    ts: list[float] = []
    qs: list[list[float]] = []
    vs: list[list[float]] = []
    es: list[list[float]] = []
    temps: list[list[float]] = []
    loads: list[float] = []
    segs: list[int] = []
    moves: list[MoveRecord] = []
    wear_log: list[tuple[float, ...]] = []
    shift_start: list[float] = []
    seg = -1
    done_cycles = 0

    def set_friction(w: Array | None) -> None:
        for i, name in enumerate(names):
            j = sim[name]
            cfg = j.config
            new = replace(cfg, temperature=float(temp[i]), wear=float(cfg.wear if w is None else w[i]))
            if new != cfg:
                sim.reconfigure(name, new)

    def tick(command: Sequence[float]) -> tuple[Array, Array]:
        nonlocal period_samples, next_heat, temp
        sim.set_commands(command)
        sim.step(dt)
        q, v, e = sim.sample()
        ts.append(sim.time)
        qs.append(q)
        vs.append(v)
        es.append(e)
        temps.append(temp.tolist())
        loads.append(sim.payload)
        segs.append(seg)
        va = np.asarray(v)
        moving_count[:] += np.abs(va) * gear > MOVING_SPEED
        period_samples += 1
        if heat.rise > 0 and sim.time >= next_heat - 1e-9:
            temp = heat.step(temp, t_start, moving_count / period_samples, period_samples * dt)
            moving_count[:] = 0.0
            period_samples = 0
            next_heat += heat.update_period
            set_friction(None)
        return np.asarray(q), va

    def hold(seconds: float) -> None:
        zero = [0.0] * n
        for _ in range(max(0, round(seconds * sample_rate))):
            tick(zero)

    def do_move(shift: int, cycle: int, k: int, frm: str, m: Move, factor: float = 1.0) -> None:
        nonlocal seg
        if factor != 1.0:
            m = replace(m, speed=m.speed * factor)
        q0 = np.asarray(program.waypoints[frm], dtype=float)
        target = np.asarray(program.waypoints[m.to], dtype=float)
        d, lam_v, lam_a = cruise(program, frm, m, spec)
        if lam_v > 0:
            _, _, ta, total = _trap(0.0, lam_v, lam_a)
            w = d * min(lam_v, lam_a * ta)  # a move too short to reach its cruise: its peak (no cruise window)
            t0 = sim.time
            cruise_t = (t0 + ta, t0 + total - ta)
            seg = len(moves)
            clip = CORRECTION_FRACTION * np.abs(w)
            dd = float(d @ d)
            mid = q0 + 0.5 * d
            rec = MoveRecord(seg, shift, cycle, k, m.label or f"{frm} -> {m.to}", frm, m.to, t0, cruise_t, math.nan,
                             tuple(w.tolist()), sim.payload, tuple(mid.tolist()), (), ())
            moves.append(rec)
            q = sim.positions
            truth_done = False
            while True:
                tau = sim.time - t0
                if tau >= total:
                    break
                _, lam_dot, _, _ = _trap(tau + 0.5 * dt, lam_v, lam_a)
                lam_star = float((q - q0) @ d) / dd
                corr = np.clip(CORRECTION_GAIN * (q0 + lam_star * d - q), -clip, clip)
                q, _ = tick((d * lam_dot + corr).tolist())
                if not truth_done and sim.time >= 0.5 * (cruise_t[0] + cruise_t[1]):
                    truth_done = True
                    mid_l, w_l = mid.tolist(), w.tolist()
                    rec.true_friction = tuple(
                        sim.true_friction(nm, float(w[i]), positions=mid_l, velocities=w_l) if w[i] != 0.0 else math.nan
                        for i, nm in enumerate(names))
                    rec.temperature = tuple(temp.tolist())
            seg = -1
            end_clip = np.maximum(0.02 * np.abs(w), 0.005)
            t_pull = sim.time
            while np.max(np.abs(target - q)) > ARRIVAL_TOLERANCE and sim.time - t_pull < ARRIVAL_TIMEOUT:
                q, _ = tick(np.clip(CORRECTION_GAIN * (target - q), -end_clip, end_clip).tolist())
            rec.t_end = sim.time
        if m.event == "pick":
            sim.set_payload(kg)
        elif m.event == "place":
            sim.set_payload(0.0)
        hold(m.dwell)

    for shift in range(shifts):
        w_shift = _wear_of(wear, shift, n)
        set_friction(w_shift)
        wear_log.append(tuple(w_shift.tolist()))
        shift_start.append(sim.time)
        if shift == 0:
            at = program.start
            for k, m in enumerate(program.prologue):
                do_move(shift, 0, k, at, m)
                at = m.to
        c = 0
        while (cycles is not None and c < cycles) or (duration is not None and sim.time - shift_start[-1] < duration):
            c += 1
            factor = override[done_cycles % len(override)]
            done_cycles += 1
            at = program.cycle_start
            for k, m in enumerate(program.cycle):
                do_move(shift, c, len(program.prologue) + k, at, m, factor)
                at = m.to
            if progress is not None:
                progress(shift, c, sim.time)

    return ProductionRun(
        arm=spec.name, program=program, names=names, arm_joints=spec.names,
        gear_ratio=tuple(gear.tolist()), torque_scale=tuple(c.torque_scale for c in configs),
        t=np.asarray(ts), q=np.asarray(qs), v=np.asarray(vs), effort=np.asarray(es),
        temperature=np.asarray(temps), payload=np.asarray(loads), segment=np.asarray(segs, dtype=np.int64),
        moves=moves, wear=wear_log, shift_start=shift_start,
        settings={"seed": seed, "sample_rate": sample_rate, "physics_rate": physics_rate, "payload": kg,
                  "shifts": shifts, "cycles": cycles, "duration": duration, "speed_override": override,
                  "temperature": t_start.tolist(), "heating": {"rise": heat.rise, "time_constant": heat.time_constant,
                                                               "update_period": heat.update_period}})
