"""Friction from production motion: forward and reverse passes of the robot's own program, Eq. (5).

The streaming core of the production observer (docs/production.md, "The production observer"). It is fed
every ``/joint_states`` sample of a shift (all joints, the arm's units: rad, rad/s, N·m) and, at the end
of the shift, pairs what it saw into friction observations in the suite's units (speed motor side
``|v| * gear_ratio``, torques normalized ``effort / torque_scale``):

1. **Constant-speed segments.** Per joint, a *motion* is a run of samples moving in one direction
   (``|v| * gear_ratio >= moving_speed``). Its *steady* samples have ``|acceleration| <= max_accel``
   (joint rad/s², the larger of the backward and forward differences of the velocity over half of
   ``accel_window`` each side, so a sample is judged once the samples ``accel_window / 2`` after it are
   in); a run of steady samples in one motion is a constant-speed segment when it lasts
   ``min_duration`` and ``min_samples``, its motor speed spread (std) is at most
   ``max(speed_spread * speed, speed_spread_min)`` and its speed at least ``min_speed``. Each segment is
   summarised into bins of that joint's position (``position_bin`` wide, on one grid for the shift:
   counts, sums of every joint's position and velocity, of the joint's torque and its square and of its
   temperature) and its samples are dropped: the memory grows with the segments, not the samples.
2. **Pairing.** A forward and a reverse segment of the same joint at the same speed (within
   ``speed_match``) are compared in the position bins both cover with ``min_bin_samples`` each, and a
   bin counts only when *every* joint's mean position in it matches within ``configuration_tolerance``
   (so gravity and the velocity-quadratic coupling cancel: docs/arm.md). With ``min_bins`` such bins
   the pair gives ``tau_f = sum w_b d_b / sum w_b``, ``d_b = (u+_b - u-_b) / 2`` (less half the
   gravity difference of the two bins' mean configurations when ``gravity`` is given), weights
   ``w_b = 2 n+ n- / (n+ + n-)``; its standard error is the larger of the bins' scatter (batch means
   with the bins as batches) and the samples' own (within-bin variances). A segment is paired when it
   ends, with the waiting segment of the other direction that matches it over the most samples; one that
   finds none waits ``pair_horizon`` seconds (or to the end of the shift) for a later partner. Each
   segment is in one pair at most; what is kept of it while it waits is its bins, so the memory is
   bounded by the segments of ``pair_horizon``.
3. **Load check.** With ``gravity`` or ``rigid_body`` given, ``(u+_b + u-_b) / 2`` must be the model's
   torque of the configuration (``rigid_body(q, v, 0)`` within ``load_tolerance``, else ``gravity(q)``
   within ``load_tolerance_gravity``, which must also hold the coupling torque ``C(q, v) v``), plus
   4 standard errors; a pair that is not (a payload carried one way only) is rejected with
   ``load mismatch``.
3b. **Payload.** With a payload model as well (``payload_gravity(q)``, or ``payload_rigid_body(q, v, a)``
   that also holds the payload's coupling torque: N·m per kg at the flange, the arm's model with 1 kg less
   without), a pair's payload difference ``dm`` is fitted to the load the model leaves,
   ``(u+ + u-)/2 - model = dm/2 * p`` by least squares over every joint and matched bin (N·m, bins weighted
   ``w_b``). When ``|dm|`` is at least ``payload_min`` and 4 of its standard errors, the pass that carried it
   is the one whose correction leaves less variation along the path in every joint's ``(u+ - u-)/2``
   (``payload_decision`` times less; else the pair is a ``load mismatch``: which pass carried it cannot be
   told), and ``d_b`` loses that pass's ``dm * p / 2`` (``payload_mass``, the part's known mass, replaces the
   fitted ``|dm|`` in the correction: the fit also takes up the friction's own load dependence). The pair is
   of kind ``paired+payload``, its load the mean of the two passes' (the carried payload's gravity
   included), the fitted ``dm`` in the joint's counts (``payload_kg``); the load check is then the fit.
4. **Model-based.** With ``rigid_body`` given, a segment that found no partner gives
   ``d * (u - rigid_body(q, v, 0) / torque_scale)`` over its bins (kind ``model``). A segment is never
   used twice.
5. **Per shift.** One observation per joint, kind and speed level (speeds within ``speed_match`` of the
   level's slowest): the inverse-variance weighted mean of its pairs; its std the within-pair one
   ``1 / sqrt(sum 1/se_i^2)``, or the pairs' scatter over ``sqrt(pairs)`` when that is larger (what varies
   from pass to pass, a per-pass friction offset, shows only there). The scatter of one pair about its
   level's mean is pooled over the joint's levels, once ``min_pairs_scatter`` pairs are in levels of two
   or more.

Every joint's counts say how many passes it made, how many were paired, used model-based, or rejected
and why (:data:`REASONS`), the speeds it held and whether it ever moved at an informative speed.

Pure numpy; no ROS import, no clock: a replay of the samples equals the live run by construction
(:func:`observe_production` feeds the same :meth:`ProductionObserver.add`).

>>> import numpy as np
>>> t = np.arange(0.0, 8.0, 0.002)
>>> v = np.select([t < 0.2, t < 3.8, t < 4.2, t < 7.8], [0.0, 0.5, 0.0, -0.5], 0.0)[:, None]
>>> q = np.concatenate(([0.0], np.cumsum(v[:-1, 0]) * 0.002))[:, None]
>>> u = np.sign(v) * 20.0 + 5.0 + 40.0 * q       # friction 20 N·m, a load varying along the path
>>> cfg = ProductionConfig(gear_ratio=100.0, torque_scale=100.0)
>>> shift = observe_production(t, q, v, u, joint_names=["joint_1"], config=cfg)
>>> [(round(o.speed), round(o.tau_f, 4)) for o in shift.levels], shift.level_kinds
([(50, 0.2)], ('paired',))
>>> shift.joints["joint_1"].passes, shift.joints["joint_1"].paired
(2, 2)
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..contract import Source
from ..errors import InputDataError
from ..settings import check_ranges, setting
from .types import FrictionObservationData

#: What an observer without the arm's model cannot see (said by the node at start-up and by the offline command).
NO_ARM_MODEL = ("without the arm's model a part carried one way is not seen: its pairs' (u+ - u-)/2 holds the part's "
                "torque on the joints it loads (give the arm)")

__all__ = [
    "KINDS",
    "NO_ARM_MODEL",
    "REASONS",
    "JointShiftCounts",
    "ProductionConfig",
    "ProductionObserver",
    "ProductionShift",
    "observe_production",
]

Array = npt.NDArray[np.float64]
#: ``gravity(q) -> N·m per joint`` (joint side, the arm's joint order)
GravityFn = Callable[[Array], Sequence[float] | Array]
#: ``rigid_body(q, v, a) -> N·m per joint``: inverse dynamics (e.g. Pinocchio's RNEA)
RigidBodyFn = Callable[[Array, Array, Array], Sequence[float] | Array]

#: The kinds of observation: a forward and reverse pair (Eq. 5); one corrected for a payload carried one way
#: (the payload difference fitted with the arm's model); u - tau_model of an unpaired segment.
KINDS = ("paired", "paired+payload", "model")
#: The reasons a pass (or, for ``held still``, a motion of the arm) gave no observation.
REASONS = (
    "acceleration",            # a motion with no sample at constant speed
    "too short",               # its constant-speed runs shorter than min_duration / min_samples
    "stop",                    # a constant-speed run cut short by a gap in the samples or the end of the shift
    "speed spread",            # a run whose speed spread exceeds the limit
    "below min speed",         # a run at constant speed slower than min_speed
    "configuration mismatch",  # reverse passes at its speed over its positions, but another joint elsewhere
    "no reverse partner",      # no reverse pass at its speed over its positions (and no rigid_body model)
    "load mismatch",           # paired, but (u+ + u-)/2 is not the model's torque: a load on one pass only
    "held still",              # the joint did not move during a motion of the others (counted per motion)
)


@dataclass(frozen=True)
class ProductionConfig:
    """Settings of :class:`ProductionObserver`, one joint's (or every joint's, given once).

    Speeds are motor side (rad/s, ``|joint velocity| * gear_ratio``), positions and accelerations joint side,
    torques normalized (``effort / torque_scale``) unless a unit says N·m, times in seconds of the stamps.
    ``configuration_tolerance``, ``accel_window`` and ``max_gap`` concern the whole arm: every joint's config
    must give the same value. The defaults suit a UR5 or a Panda publishing ``/joint_states`` at 100-500 Hz.
    """

    gear_ratio: float = setting(100.0, description="motor speed = joint speed x gear_ratio", range=(1e-6, 1e6),
                                per_joint=True)
    torque_scale: float = setting(100.0, description="N·m (joint side) per normalized torque unit", unit="N·m",
                                  range=(1e-9, 1e9), per_joint=True)
    moving_speed: float = setting(2.0, description="a joint moves above this motor speed", unit="rad/s",
                                  range=(1e-9, 1e6), per_joint=True)
    min_speed: float = setting(10.0, description="slowest informative constant motor speed", unit="rad/s",
                               range=(0.0, 1e6), per_joint=True)
    max_accel: float = setting(0.3, description="constant speed: |acceleration| at most this, joint side",
                               unit="rad/s^2", range=(1e-9, 1e6), per_joint=True)
    speed_spread: float = setting(0.02, description="a segment's motor speed std at most this x its speed",
                                  range=(1e-6, 10.0), per_joint=True)
    speed_spread_min: float = setting(0.5, description="floor of that limit, motor", unit="rad/s",
                                      range=(0.0, 1e6), per_joint=True)
    min_duration: float = setting(0.15, description="shortest constant-speed segment", unit="s",
                                  range=(0.0, 3600.0), per_joint=True)
    min_samples: int = setting(15, description="fewest samples of a constant-speed segment", range=(2, 1_000_000),
                               per_joint=True)
    position_bin: float = setting(0.02, description="width of the position bins a segment is summarised in, "
                                  "joint side", unit="rad", range=(1e-6, 10.0), per_joint=True)
    min_bin_samples: int = setting(2, description="samples a bin needs in each pass to be compared",
                                   range=(1, 1_000_000), per_joint=True)
    min_bins: int = setting(3, description="matched bins a pair needs", range=(1, 1_000_000), per_joint=True)
    speed_match: float = setting(0.05, description="a forward and a reverse pass are at one speed level when "
                                 "their speeds differ by at most this x the speed", range=(0.0, 1.0), per_joint=True)
    load_tolerance: float = setting(0.005, description="with rigid_body: (u+ + u-)/2 may differ from "
                                    "rigid_body(q, v, 0) by this (plus 4 standard errors) before the pair is a load "
                                    "mismatch, normalized", range=(0.0, 1e6), per_joint=True)
    load_tolerance_gravity: float = setting(0.02, description="the same with gravity only (the coupling torque "
                                            "C(q, v) v is not in the model and counts against it), normalized",
                                            range=(0.0, 1e6), per_joint=True)
    min_pairs_scatter: int = setting(3, description="pairs (in speed levels of two or more) from which their "
                                     "scatter, pooled over the joint's levels, may set the std", range=(2, 1_000_000),
                                     per_joint=True)
    payload_min: float = setting(0.05, description="with a payload model: a pair's fitted payload difference "
                                 "smaller than this (or than 4 of its standard errors) is none", unit="kg",
                                 range=(0.0, 1e6), per_joint=True)
    payload_decision: float = setting(3.0, description="with a payload model: the pass that carried the payload is "
                                      "the one whose correction leaves this many times less variation along the path "
                                      "in (u+ - u-)/2 than the other's; else the pair is a load mismatch",
                                      range=(1.0, 1e6), per_joint=True)
    pair_horizon: float = setting(600.0, description="a constant-speed segment waits this long for its reverse "
                                  "partner, then is model-based or rejected (bounds the memory)", unit="s",
                                  range=(0.0, 1e6), per_joint=True)
    configuration_tolerance: float = setting(0.01, description="every joint's mean position must match within "
                                             "this between a forward and a reverse bin (the whole arm)", unit="rad",
                                             range=(0.0, 10.0))
    accel_window: float = setting(0.04, description="window of the acceleration estimate, centred (the whole arm)",
                                  unit="s", range=(1e-6, 10.0))
    max_gap: float = setting(0.1, description="a longer gap between samples ends every motion (the whole arm)",
                             unit="s", range=(1e-6, 3600.0))

    def __post_init__(self) -> None:
        check_ranges(self, InputDataError, "production observer setting")


_ARM_WIDE = ("configuration_tolerance", "accel_window", "max_gap")
#: the largest magnitude of a position (rad), velocity (rad/s), effort (N·m) or temperature (degC) taken
_LARGEST = 1e9


@dataclass(frozen=True)
class JointShiftCounts:
    """One joint's counts of a shift: its passes (constant-speed runs; a motion without one is one pass)
    and what became of them; ``rejected`` by reason (:data:`REASONS`; ``held still`` counts the arm's
    motions during which the joint did not move, not passes). ``speed_levels``: the motor speeds (rad/s)
    it held at constant speed; ``informative``: one of them was at least ``min_speed``; ``note`` says
    so when not."""

    joint_name: str
    passes: int = 0
    paired: int = 0
    model: int = 0
    rejected: dict[str, int] = field(default_factory=dict)
    speed_levels: tuple[float, ...] = ()
    informative: bool = False
    note: str = ""
    #: the payload difference (kg) fitted to each pair corrected for it (kind ``paired+payload``, counted in
    #: ``paired``): positive when the forward pass carried more than the model's payload, negative the reverse
    payload_kg: tuple[float, ...] = ()

    @property
    def rejected_total(self) -> int:
        return sum(v for k, v in self.rejected.items() if k != "held still")


@dataclass(frozen=True)
class ProductionShift:
    """A shift's production observations and counts (:meth:`ProductionObserver.end_shift`).

    ``observations`` and ``kinds`` (:data:`KINDS`) are parallel: each pair's (or model-based segment's) own
    observation, ``cycle_id`` the shift id: what the node publishes and the wear monitor estimates from (each pair
    weighs as one sweep of a test cycle, with the sweep-to-sweep scatter the monitor adds to each). ``levels``
    and ``level_kinds``: the same pooled to one per joint, kind and speed level (the inverse-variance mean, its
    std never below the pairs' scatter), for reading a shift at a glance.
    """

    shift_id: int
    t_start: float
    t_end: float
    samples: int
    observations: tuple[FrictionObservationData, ...]
    kinds: tuple[str, ...]
    joints: dict[str, JointShiftCounts]
    levels: tuple[FrictionObservationData, ...] = ()
    level_kinds: tuple[str, ...] = ()

    def summary(self) -> str:
        """One line per joint: passes, paired, model, rejected by reason, or why it gave nothing."""
        lines = []
        for c in self.joints.values():
            why = ", ".join(f"{k} {v}" for k, v in sorted(c.rejected.items()))
            line = f"{c.joint_name}: {c.passes} passes, {c.paired} paired, {c.model} model, " \
                   f"{c.rejected_total} rejected" + (f" ({why})" if why else "")
            if c.payload_kg:
                line += f"; {len(c.payload_kg)} pair(s) corrected for a payload of " \
                        f"{float(np.mean(np.abs(c.payload_kg))):.2f} kg one way"
            lines.append(line + (f"; {c.note}" if c.note else ""))
        return "\n".join(lines)


# --------------------------------------------------------------------------- segments


class _Bin:
    __slots__ = ("n", "nt", "sq", "st", "su", "su2", "sua", "sv")

    def __init__(self, n_joints: int) -> None:
        self.n = 0
        self.sq = np.zeros(n_joints)
        self.sv = np.zeros(n_joints)
        self.sua = np.zeros(n_joints)  # every joint's normalized torque (the payload fit)
        self.su = 0.0
        self.su2 = 0.0
        self.st = 0.0
        self.nt = 0


class _Segment:
    """A constant-speed run of one joint being summarised (and, once finished, its summary)."""

    def __init__(self, joint: int, sign: int, t: float) -> None:
        self.joint = joint
        self.sign = sign
        self.t0 = t
        self.t1 = t
        self.n = 0
        self.s_speed = 0.0
        self.s_speed2 = 0.0
        self.bins: dict[int, _Bin] = {}
        self.speed = 0.0
        self.summary: _Bins | None = None
        self.mismatch = False

    def add(self, t: float, q: Array, v: Array, u_all: Array, temp: float, vm: float, key: int) -> None:
        u = float(u_all[self.joint])
        self.t1 = t
        self.n += 1
        self.s_speed += vm
        self.s_speed2 += vm * vm
        b = self.bins.get(key)
        if b is None:
            b = self.bins[key] = _Bin(q.size)
        b.n += 1
        b.sq += q
        b.sv += v
        b.sua += u_all
        b.su += u
        b.su2 += u * u
        if temp == temp:  # not NaN
            b.st += temp
            b.nt += 1

    def speed_std(self) -> float:
        m = self.s_speed / self.n
        return math.sqrt(max(self.s_speed2 / self.n - m * m, 0.0))


@dataclass
class _Motion:
    sign: int
    has_pass: bool = False
    longest: int = 0
    cut: bool = False


class _Bins:
    """A finished segment's bins as arrays (sorted by bin key): what is kept of it once its samples are gone."""

    def __init__(self, keys: list[int], n: Array, q: Array, v: Array, u: Array, var: Array, st: Array,
                 nt: Array, ua: Array) -> None:
        self.keys = keys
        self.index = {k: i for i, k in enumerate(keys)}
        self.n, self.q, self.v, self.u, self.var, self.st_b, self.nt_b = n, q, v, u, var, st, nt
        self.ua = ua  # every joint's mean normalized torque per bin

    @classmethod
    def of(cls, seg: _Segment) -> _Bins:
        ks = sorted(seg.bins)
        bs = [seg.bins[k] for k in ks]
        return cls(ks, np.array([b.n for b in bs], dtype=float),
                   np.array([b.sq / b.n for b in bs]).reshape(len(bs), -1),
                   np.array([b.sv / b.n for b in bs]).reshape(len(bs), -1),
                   np.array([b.su / b.n for b in bs]),
                   np.array([max(b.su2 / b.n - (b.su / b.n) ** 2, 0.0) for b in bs]),
                   np.array([b.st for b in bs]), np.array([b.nt for b in bs], dtype=float),
                   np.array([b.sua / b.n for b in bs]).reshape(len(bs), -1))

    def take(self, keys: list[int]) -> _Bins:
        i = np.array([self.index[k] for k in keys], dtype=int)
        return _Bins(keys, self.n[i], self.q[i], self.v[i], self.u[i], self.var[i], self.st_b[i], self.nt_b[i],
                     self.ua[i])

    @property
    def st(self) -> float:
        return float(self.st_b.sum())

    @property
    def nt(self) -> int:
        return int(self.nt_b.sum())


def _scatter_se(d: Array, w: Array) -> float:
    """Standard error of ``sum w d / sum w`` from the scatter of ``d`` (NaN with fewer than 2)."""
    if d.size < 2:
        return math.nan
    mean = float(np.dot(w, d) / w.sum())
    return float(math.sqrt(d.size / (d.size - 1) * float(np.sum(w**2 * (d - mean) ** 2))) / w.sum())


@dataclass
class _Result:
    joint: int
    kind: str
    speed: float
    tau_f: float
    se: float
    u_plus: float
    u_minus: float
    load: float
    position: float
    n_plus: int
    n_minus: int
    st: float
    nt: int
    t_end: float


# --------------------------------------------------------------------------- the observer


class ProductionObserver:
    """The streaming production observer (see the module docstring).

    Parameters
    ----------
    joint_names
        The arm's joints, in the order of every sample's arrays.
    config
        One :class:`ProductionConfig` for every joint, or one per joint (in ``joint_names`` order).
    gravity
        ``gravity(q) -> N·m per joint``: the gravity torque of a configuration (payload included), used
        for the load column, the residual gravity of matched bins and the load check.
    rigid_body
        ``rigid_body(q, v, a) -> N·m per joint``: inverse dynamics (Pinocchio's RNEA with the arm's URDF
        and payload). Unpaired segments then give model-based observations; it also serves as ``gravity``
        (``rigid_body(q, 0, 0)``) when that is not given.
    """

    def __init__(self, joint_names: Sequence[str], config: ProductionConfig | Sequence[ProductionConfig] | None = None,
                 *, gravity: GravityFn | None = None, rigid_body: RigidBodyFn | None = None,
                 payload_gravity: GravityFn | None = None, payload_rigid_body: RigidBodyFn | None = None,
                 payload_mass: float | None = None) -> None:
        names = [str(n) for n in joint_names]
        if not names or len(set(names)) != len(names) or any(not n for n in names):
            raise InputDataError(f"production observer: joint names must be non-empty and unique, got {names}")
        if config is None:
            config = ProductionConfig()
        configs = [config] * len(names) if isinstance(config, ProductionConfig) else list(config)
        if len(configs) != len(names) or not all(isinstance(c, ProductionConfig) for c in configs):
            raise InputDataError(f"production observer: {len(names)} joints need one ProductionConfig or "
                                 f"{len(names)}, got {len(configs)}")
        for name in _ARM_WIDE:
            values = {getattr(c, name) for c in configs}
            if len(values) > 1:
                raise InputDataError(f"production observer setting {name} concerns the whole arm; the joints give "
                                     f"{sorted(values)}: give one value")
        self.names: tuple[str, ...] = tuple(names)
        self.configs: tuple[ProductionConfig, ...] = tuple(configs)
        self._arm = configs[0]
        self._gravity = gravity
        self._rigid_body = rigid_body
        if (payload_gravity is not None or payload_rigid_body is not None) and gravity is None and rigid_body is None:
            raise InputDataError("production observer: a payload model (payload_gravity or payload_rigid_body) needs "
                                 "the arm's model too (gravity or rigid_body): the payload is fitted to the load "
                                 "the model does not explain")
        self._payload_gravity = payload_gravity
        self._payload_rigid_body = payload_rigid_body
        if payload_mass is not None and not (math.isfinite(float(payload_mass)) and float(payload_mass) > 0):
            raise InputDataError(f"production observer: payload_mass must be a mass > 0 kg, got {payload_mass!r}")
        self._payload_mass = None if payload_mass is None else float(payload_mass)
        #: per joint: the payload differences (kg) fitted to its corrected pairs, in the order paired
        self._payload_kg: list[list[float]] = []
        nj = len(names)
        self._gear = np.array([c.gear_ratio for c in configs])
        self._scale = np.array([c.torque_scale for c in configs])
        self._moving = np.array([c.moving_speed for c in configs])
        self._max_accel = np.array([c.max_accel for c in configs])
        self._bin = [c.position_bin for c in configs]
        self.shift_id = 0
        self._reset_shift()
        self._last_t = -math.inf
        # samples awaiting their forward acceleration difference: (t, q, v, u, temp)
        self._buf: deque[tuple[float, Array, Array, Array, Array]] = deque()
        self._pend = 0
        self._nj = nj

    # -- state -------------------------------------------------------------
    def _reset_shift(self) -> None:
        nj = len(self.names)
        self._pending: list[list[_Segment]] = [[] for _ in range(nj)]
        self._results: list[_Result] = []
        self._paired = [0] * nj
        self._payload_kg = [[] for _ in range(nj)]
        self._model_n = [0] * nj
        self._informative = [False] * nj
        self._cur: list[_Segment | None] = [None] * nj
        self._motion: list[_Motion | None] = [None] * nj
        self._passes = [0] * nj
        self._rejected: list[Counter[str]] = [Counter() for _ in range(nj)]
        self._levels: list[list[float]] = [[] for _ in range(nj)]
        self._arm_moving = False
        self._moved = [False] * nj
        self._t0 = math.nan
        self._n = 0

    @property
    def waiting(self) -> int:
        """Constant-speed segments waiting for their reverse partner (each kept as its bins: the memory)."""
        return sum(len(p) for p in self._pending)

    # -- input -------------------------------------------------------------
    def add(self, stamp: float, positions: Sequence[float] | Array, velocities: Sequence[float] | Array,
            efforts: Sequence[float] | Array, temperatures: Sequence[float] | Array | None = None) -> None:
        """One ``/joint_states`` sample of every joint (rad, rad/s, N·m; temperatures degC, NaN unknown).

        Bad input (a non-finite value, a wrong length, a stamp not after the previous one) raises one
        :class:`InputDataError` line and leaves the observer as it was."""
        t = _finite_float(stamp, "stamp")
        nj = len(self.names)
        q = self._vector(positions, "positions")
        v = self._vector(velocities, "velocities")
        u = self._vector(efforts, "efforts")
        if temperatures is None:
            temp = np.full(nj, math.nan)
        else:
            temp = self._vector(temperatures, "temperatures", allow_nan=True)
        if not t > self._last_t:
            raise InputDataError(f"production observer: stamp {t!r} s is not after the previous sample's "
                                 f"{self._last_t!r} s (time went backwards or repeated); feed samples in stamp order")
        if t - self._last_t > self._arm.max_gap and self._buf:
            self._flush(gap=True)
        self._last_t = t
        if self._n == 0:
            self._t0 = t
        self._n += 1
        self._buf.append((t, q, v, u, temp))
        half = 0.5 * self._arm.accel_window
        while self._pend < len(self._buf) and t >= self._buf[self._pend][0] + half:
            self._process(self._pend)
            self._pend += 1
            self._trim(half)

    def add_many(self, stamps: Sequence[float] | Array, positions: Array, velocities: Array, efforts: Array,
                 temperatures: Array | None = None) -> None:
        """Samples in rows (one row per stamp, one column per joint): :meth:`add` for each, in order."""
        t = np.asarray(stamps, dtype=float).reshape(-1)
        arrays = [np.asarray(a, dtype=float) for a in (positions, velocities, efforts)]
        for name, a in zip(("positions", "velocities", "efforts"), arrays, strict=True):
            if a.ndim != 2 or a.shape[0] != t.size:
                raise InputDataError(f"production observer: {name} has shape {a.shape}; expected ({t.size}, "
                                     f"{len(self.names)}): one row per stamp, one column per joint")
        temps = None if temperatures is None else np.asarray(temperatures, dtype=float)
        if temps is not None and (temps.ndim != 2 or temps.shape[0] != t.size):
            raise InputDataError(f"production observer: temperatures has shape {temps.shape}; expected ({t.size}, "
                                 f"{len(self.names)})")
        for k in range(t.size):
            self.add(float(t[k]), arrays[0][k], arrays[1][k], arrays[2][k], None if temps is None else temps[k])

    def _vector(self, values: Sequence[float] | Array, what: str, allow_nan: bool = False) -> Array:
        try:
            a = np.array(values, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise InputDataError(f"production observer: {what} are not numbers: {values!r}") from None
        if a.size != len(self.names):
            raise InputDataError(f"production observer: {what} has {a.size} value(s); the arm has {len(self.names)} "
                                 f"joints ({', '.join(self.names)})")
        if float(np.abs(a).max()) <= _LARGEST:  # every value finite and within range (NaN fails this): the usual case
            return a
        bad = ~np.isfinite(a) if not allow_nan else np.isinf(a)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise InputDataError(f"production observer: {what} of {self.names[i]} is {float(a[i])!r}; expected a "
                                 "finite number")
        huge = np.abs(a) > _LARGEST
        if huge.any():
            i = int(np.flatnonzero(huge)[0])
            raise InputDataError(f"production observer: {what} of {self.names[i]} is {float(a[i])!r}; beyond "
                                 f"±{_LARGEST:g} no arm's value (a unit slip or a corrupt message)")
        return a

    def _trim(self, half: float) -> None:
        if self._pend >= len(self._buf):
            return
        tk = self._buf[self._pend][0]
        while self._pend > 0 and self._buf[0][0] < tk - half:
            self._buf.popleft()
            self._pend -= 1

    def _flush(self, gap: bool) -> None:
        """Judge every waiting sample with the samples there are, then end every motion (a gap, a shift's end)."""
        while self._pend < len(self._buf):
            self._process(self._pend)
            self._pend += 1
        self._buf.clear()
        self._pend = 0
        for j in range(len(self.names)):
            self._end_motion(j, cut=gap)
        self._end_arm_motion()

    # -- per sample ----------------------------------------------------------
    def _process(self, k: int) -> None:
        with np.errstate(over="ignore", invalid="ignore"):  # finite but huge values: not steady, not informative
            self._judge(k)

    def _judge(self, k: int) -> None:
        buf = self._buf
        t, q, v, u, temp = buf[k]
        acc = np.zeros(len(self.names))
        t_b, _, v_b, _, _ = buf[0]
        if t_b < t:
            acc = np.abs(v - v_b) / (t - t_b)
        t_f, _, v_f, _, _ = buf[-1]
        if t_f > t:
            acc = np.maximum(acc, np.abs(v_f - v) / (t_f - t))
        vm_all = np.abs(v) * self._gear
        moving = vm_all >= self._moving
        if moving.any():
            self._arm_moving = True
            for j in np.flatnonzero(moving).tolist():
                self._moved[j] = True
        elif self._arm_moving:
            self._end_arm_motion()
        steady = (acc <= self._max_accel).tolist()
        un = u / self._scale
        # Python scalars for the per-joint decisions (a numpy scalar per index costs more than the decision)
        vl, ml, vml, ql, tl = v.tolist(), moving.tolist(), vm_all.tolist(), q.tolist(), temp.tolist()
        for j in range(len(self.names)):
            sign = (1 if vl[j] > 0 else -1) if ml[j] else 0
            motion = self._motion[j]
            if motion is not None and motion.sign != sign:
                self._end_motion(j, cut=False)
                motion = None
            if sign == 0:
                continue
            if motion is None:
                motion = self._motion[j] = _Motion(sign)
            seg = self._cur[j]
            if steady[j]:
                if seg is None:
                    seg = self._cur[j] = _Segment(j, sign, t)
                seg.add(t, q, v, un, tl[j], vml[j], math.floor(ql[j] / self._bin[j]))
            elif seg is not None:
                self._end_segment(j, cut=False)

    def _end_arm_motion(self) -> None:
        if self._arm_moving:
            for j, moved in enumerate(self._moved):
                if not moved:
                    self._rejected[j]["held still"] += 1
        self._arm_moving = False
        self._moved = [False] * len(self.names)

    def _end_segment(self, j: int, cut: bool) -> None:
        seg = self._cur[j]
        self._cur[j] = None
        motion = self._motion[j]
        if seg is None or motion is None:
            return
        cfg = self.configs[j]
        if seg.n < cfg.min_samples or seg.t1 - seg.t0 < cfg.min_duration:
            if seg.n > motion.longest:
                motion.longest = seg.n
            motion.cut = motion.cut or cut
            return
        motion.has_pass = True
        self._passes[j] += 1
        seg.speed = seg.s_speed / seg.n
        self._levels[j].append(seg.speed)
        if seg.speed_std() > max(cfg.speed_spread * seg.speed, cfg.speed_spread_min):
            self._rejected[j]["speed spread"] += 1
        elif seg.speed < cfg.min_speed:
            self._rejected[j]["below min speed"] += 1
        else:
            seg.summary = _Bins.of(seg)
            seg.bins = {}
            self._informative[j] = True
            self._expire(j, seg.t0 - cfg.pair_horizon)
            self._offer(j, seg)

    def _end_motion(self, j: int, cut: bool) -> None:
        if self._cur[j] is not None:
            self._end_segment(j, cut)
        motion = self._motion[j]
        self._motion[j] = None
        if motion is None or motion.has_pass:
            return
        self._passes[j] += 1
        reason = "stop" if motion.cut else ("too short" if motion.longest >= 2 else "acceleration")
        self._rejected[j][reason] += 1

    # -- the shift -----------------------------------------------------------
    def end_shift(self, shift_id: int, stamp: float | None = None) -> ProductionShift:
        """Pair the shift's segments into observations (``cycle_id = shift_id``) and start the next shift.

        ``stamp`` (s) is the shift's end; default the last sample's stamp. Motions still running are cut
        here (a constant-speed run too short by then counts as ``stop``)."""
        try:
            sid = int(shift_id)
        except (TypeError, ValueError):
            raise InputDataError(f"production observer: shift id {shift_id!r} is not an integer") from None
        self._flush(gap=True)
        t_end = self._last_t if stamp is None else _finite_float(stamp, "shift end stamp")
        counts: dict[str, JointShiftCounts] = {}
        for j, name in enumerate(self.names):
            self._expire(j, math.inf)
            cfg = self.configs[j]
            levels = _levels(sorted(self._levels[j]), cfg.speed_match)
            informative = self._informative[j]
            note = "" if informative else (
                f"{name}: never moved at a constant speed >= {cfg.min_speed:g} rad/s motor in this shift")
            counts[name] = JointShiftCounts(name, self._passes[j], self._paired[j], self._model_n[j],
                                            dict(sorted(self._rejected[j].items())), tuple(levels), informative, note,
                                            tuple(self._payload_kg[j]))
        results = self._results
        pooled = self._pool(results)
        shift = ProductionShift(
            shift_id=sid, t_start=self._t0, t_end=t_end, samples=self._n,
            observations=tuple(self._observation(r, sid) for r in results), kinds=tuple(r.kind for r in results),
            joints=counts, levels=tuple(self._observation(r, sid) for r in pooled),
            level_kinds=tuple(r.kind for r in pooled))
        self.shift_id = sid
        self._reset_shift()
        return shift

    def _model(self, fn: Callable[..., Sequence[float] | Array], *args: Array) -> Array:
        out = np.asarray(fn(*args), dtype=float).reshape(-1)
        if out.size != len(self.names) or not np.all(np.isfinite(out)):
            raise InputDataError(f"production observer: the arm model returned {out.size} torque(s) {out!r}; "
                                 f"expected {len(self.names)} finite N·m")
        return out

    def _gravity_at(self, q: Array) -> Array | None:
        if self._gravity is not None:
            return self._model(self._gravity, q)
        if self._rigid_body is not None:
            z = np.zeros(len(self.names))
            return self._model(self._rigid_body, q, z, z)
        return None

    def _offer(self, j: int, seg: _Segment) -> None:
        """A finished constant-speed segment: paired now with the pending segment of the other direction at
        its speed that matches it over the most samples (ties: the latest), else kept pending."""
        cfg = self.configs[j]
        tol = self._arm.configuration_tolerance
        a = seg.summary
        assert a is not None
        best: tuple[float, int, list[int]] | None = None
        for i, other in enumerate(self._pending[j]):
            b = other.summary
            assert b is not None
            if other.sign == seg.sign or abs(other.speed - seg.speed) > cfg.speed_match * max(other.speed, seg.speed):
                continue
            common = [k for k in a.keys if k in b.index and a.n[a.index[k]] >= cfg.min_bin_samples
                      and b.n[b.index[k]] >= cfg.min_bin_samples]
            if not common:
                continue
            matched = [k for k in common
                       if float(np.max(np.abs(a.q[a.index[k]] - b.q[b.index[k]]))) <= tol]
            if len(matched) < cfg.min_bins:
                seg.mismatch = other.mismatch = True
                continue
            na = a.n[[a.index[k] for k in matched]]
            nb = b.n[[b.index[k] for k in matched]]
            weight = float(np.sum(2.0 * na * nb / (na + nb)))
            if best is None or weight >= best[0]:
                best = (weight, i, matched)
        if best is None:
            self._pending[j].append(seg)
            return
        other = self._pending[j].pop(best[1])
        fw, rv = (seg, other) if seg.sign > 0 else (other, seg)
        r = self._pair(j, fw, rv, best[2])
        if r is None:
            self._rejected[j]["load mismatch"] += 2
        else:
            self._paired[j] += 2
            self._results.append(r)

    def _expire(self, j: int, before: float) -> None:
        """Pending segments that ended before ``before`` will find no partner: model-based, or rejected."""
        keep: list[_Segment] = []
        for seg in self._pending[j]:
            if seg.t1 >= before:
                keep.append(seg)
            elif self._rigid_body is not None:
                self._results.append(self._model_based(j, seg))
                self._model_n[j] += 1
            else:
                self._rejected[j]["configuration mismatch" if seg.mismatch else "no reverse partner"] += 1
        self._pending[j] = keep

    def _pair(self, j: int, sf: _Segment, sr: _Segment, keys: list[int]) -> _Result | None:
        cfg = self.configs[j]
        scale = float(self._scale[j])
        assert sf.summary is not None and sr.summary is not None
        f, r = sf.summary.take(keys), sr.summary.take(keys)
        w = 2.0 * f.n * r.n / (f.n + r.n)
        d = 0.5 * (f.u - r.u)
        m = 0.5 * (f.u + r.u)
        load = np.abs(m)
        g_f = g_r = None
        if self._gravity is not None or self._rigid_body is not None:
            g_f = np.array([self._gravity_at(qb)[j] for qb in f.q]) / scale  # type: ignore[index]
            g_r = np.array([self._gravity_at(qb)[j] for qb in r.q]) / scale  # type: ignore[index]
            d = d - 0.5 * (g_f - g_r)
            load = np.abs(0.5 * (g_f + g_r))
        kind = "paired"
        corr_m = np.zeros_like(d)
        if self._payload_gravity is not None or self._payload_rigid_body is not None:
            fit = self._payload_fit(j, f, r, w)
            if isinstance(fit, bool):  # a payload shows, but not which pass carried it
                return None
            if fit is not None:
                dm, corr_d, corr_m, (add_f, add_r) = fit
                d = d - corr_d
                if g_f is not None and g_r is not None:  # the load each pass carried: the payload's gravity too
                    load = 0.5 * (np.abs(g_f + add_f) + np.abs(g_r + add_r))
                kind = "paired+payload"
                self._payload_kg[j].append(dm)
        tau = float(np.dot(w, d) / w.sum())
        # the samples' own standard error: within-bin variances, both directions
        se_own = 0.5 * math.sqrt(float(np.dot(f.n, f.var)) / f.n.sum() ** 2 + float(np.dot(r.n, r.var)) / r.n.sum() ** 2)
        se_bins = _scatter_se(d, w)
        se = max(se_own, se_bins) if math.isfinite(se_bins) else se_own
        if g_f is not None and g_r is not None:
            if self._rigid_body is not None:
                z = np.zeros(len(self.names))
                expected = np.array([self._model(self._rigid_body, qb, vb, z)[j] for qb, vb in zip(f.q, f.v,
                                                                                                    strict=True)])
                expected = 0.5 * (expected + np.array([self._model(self._rigid_body, qb, vb, z)[j]
                                                       for qb, vb in zip(r.q, r.v, strict=True)]))
                expected = expected / scale
            else:
                expected = 0.5 * (g_f + g_r)
            resid = m - expected - corr_m
            off = float(np.dot(w, resid) / w.sum())
            se_m = _scatter_se(resid, w)
            se_m = max(se_own, se_m) if math.isfinite(se_m) else se_own
            tol = cfg.load_tolerance if self._rigid_body is not None else cfg.load_tolerance_gravity
            if kind == "paired" and abs(off) > tol + 4.0 * se_m:
                return None
        return _Result(
            joint=j, kind=kind, speed=0.5 * (sf.speed + sr.speed), tau_f=tau, se=se,
            u_plus=float(np.dot(w, f.u) / w.sum()), u_minus=float(np.dot(w, r.u) / w.sum()),
            load=float(np.dot(w, load) / w.sum()),
            position=float(np.dot(w, 0.5 * (f.q[:, j] + r.q[:, j])) / w.sum()),
            n_plus=int(f.n.sum()), n_minus=int(r.n.sum()), st=f.st + r.st, nt=f.nt + r.nt, t_end=max(sf.t1, sr.t1))

    def _payload_fit(self, j: int, f: _Bins, r: _Bins, w: Array
                     ) -> tuple[float, Array, Array, tuple[Array, Array]] | bool | None:
        """The payload difference of a pair (module docstring, "Payload"): ``(dm kg, correction of joint j's
        d_b, of its (u+ + u-)/2 per bin, the payload's gravity on joint j in each pass, normalized)``; None when no payload difference shows (the pair as it
        is); False when one shows but which pass carried it cannot be told (the pair is a load mismatch)."""
        cfg = self.configs[j]
        nj = len(self.names)
        z = np.zeros(nj)
        scale = self._scale

        def model(b: _Bins) -> Array:
            if self._rigid_body is not None:
                return np.array([self._model(self._rigid_body, qb, vb, z) for qb, vb in zip(b.q, b.v, strict=True)])
            assert self._gravity is not None
            return np.array([self._model(self._gravity, qb) for qb in b.q])

        def per_kg(b: _Bins) -> Array:
            if self._payload_rigid_body is not None:
                return np.array([self._model(self._payload_rigid_body, qb, vb, z)
                                 for qb, vb in zip(b.q, b.v, strict=True)])
            assert self._payload_gravity is not None
            return np.array([self._model(self._payload_gravity, qb) for qb in b.q])

        e_f, e_r, p_f, p_r = model(f), model(r), per_kg(f), per_kg(r)
        # the load the model leaves, N·m: (u+ + u-)/2 - model = dm/2 * p (whichever pass carried dm)
        s = 0.5 * (f.ua + r.ua) * scale - 0.5 * (e_f + e_r)
        p = 0.5 * (p_f + p_r)
        ww = np.broadcast_to(w[:, None], s.shape)
        den = float(np.sum(ww * p * p))
        if not den > 0.0 or s.size < 2:
            return None
        dm = 2.0 * float(np.sum(ww * s * p)) / den
        res = s - 0.5 * dm * p
        se_dm = 2.0 * math.sqrt(float(np.sum(ww * res * res)) / (s.size - 1) / den)
        if abs(dm) < max(cfg.payload_min, 4.0 * se_dm):
            return None
        # which pass carried it: friction is one number per joint at a constant speed, so the wrong pass leaves
        # dm * p's variation along the path in every joint's (u+ - u-)/2 (normalized, about each joint's mean)
        dd = (0.5 * (f.ua - r.ua) * scale - 0.5 * (e_f - e_r)) / scale
        sse = []
        for corr in (0.5 * dm * p_f / scale, -0.5 * dm * p_r / scale):
            tau = dd - corr
            mean = np.sum(ww * tau, axis=0) / np.sum(ww, axis=0)
            sse.append(float(np.sum(ww * (tau - mean) ** 2)))
        lo, hi = min(sse), max(sse)
        if not hi >= cfg.payload_decision * lo or hi == lo:
            return False
        forward = sse[0] < sse[1]
        fitted = dm
        if self._payload_mass is not None:
            dm = math.copysign(self._payload_mass, dm)
        sj = float(scale[j])
        corr_d = (0.5 * dm * p_f[:, j] if forward else -0.5 * dm * p_r[:, j]) / sj
        add = dm * (p_f[:, j] if forward else p_r[:, j]) / sj  # the carried payload's gravity on joint j
        zero = np.zeros_like(add)
        return ((fitted if forward else -fitted), corr_d, 0.5 * fitted * p[:, j] / sj,
                (add, zero) if forward else (zero, add))

    def _model_based(self, j: int, seg: _Segment) -> _Result:
        assert self._rigid_body is not None
        scale = float(self._scale[j])
        b = seg.summary
        assert b is not None
        z = np.zeros(len(self.names))
        model = np.array([self._model(self._rigid_body, qb, vb, z)[j] for qb, vb in zip(b.q, b.v, strict=True)]) / scale
        fr = seg.sign * (b.u - model)
        tau = float(np.dot(b.n, fr) / b.n.sum())
        se_own = math.sqrt(float(np.dot(b.n, b.var))) / float(b.n.sum())
        se_bins = _scatter_se(fr, b.n)
        se = max(se_own, se_bins) if math.isfinite(se_bins) else se_own
        g = self._gravity_at(b.q[0])
        load_b = np.abs(np.array([self._gravity_at(qb)[j] for qb in b.q]) / scale) if g is not None else np.abs(model)  # type: ignore[index]
        m = float(np.dot(b.n, model) / b.n.sum())
        n = int(b.n.sum())
        return _Result(
            joint=j, kind="model", speed=seg.speed, tau_f=tau, se=se, u_plus=m + tau, u_minus=m - tau,
            load=float(np.dot(b.n, load_b) / b.n.sum()), position=float(np.dot(b.n, b.q[:, j]) / b.n.sum()),
            n_plus=n if seg.sign > 0 else 0, n_minus=n if seg.sign < 0 else 0, st=b.st, nt=b.nt, t_end=seg.t1)

    def _pool(self, results: list[_Result]) -> list[_Result]:
        out: list[_Result] = []
        for j in range(len(self.names)):
            cfg = self.configs[j]
            for kind in KINDS:
                rs = sorted((r for r in results if r.joint == j and r.kind == kind), key=lambda r: r.speed)
                groups: list[list[_Result]] = []
                for r in rs:
                    if groups and r.speed - groups[-1][0].speed <= cfg.speed_match * groups[-1][0].speed:
                        groups[-1].append(r)
                    else:
                        groups.append([r])
                out.extend(_pool_group(g, _between_pairs(groups, cfg)) for g in groups)
        return out

    def _observation(self, r: _Result, shift_id: int) -> FrictionObservationData:
        return FrictionObservationData(
            stamp=r.t_end, joint_name=self.names[r.joint], cycle_id=shift_id, speed=r.speed, tau_f=r.tau_f,
            tau_f_std=r.se, tau_plus=r.u_plus, tau_minus=r.u_minus, load_torque=r.load,
            temperature=r.st / r.nt if r.nt else math.nan, position=r.position, samples_plus=r.n_plus,
            samples_minus=r.n_minus, source=Source.PRODUCTION.value)


def _between_pairs(groups: list[list[_Result]], cfg: ProductionConfig) -> float:
    """The scatter (std) of one pair's tau_f about its level's mean, pooled over a joint's levels (NaN with
    fewer than ``min_pairs_scatter`` pairs in levels of two or more): what varies from pass to pass."""
    ss, dof, n = 0.0, 0, 0
    for g in groups:
        if len(g) < 2:
            continue
        tau = np.array([r.tau_f for r in g])
        w = 1.0 / np.array([max(r.se, 1e-12) for r in g]) ** 2
        ss += float(np.sum((tau - np.dot(w, tau) / w.sum()) ** 2))
        dof += len(g) - 1
        n += len(g)
    return math.sqrt(ss / dof) if n >= cfg.min_pairs_scatter and dof else math.nan


def _pool_group(rs: list[_Result], between: float) -> _Result:
    """Several pairs (or model-based segments) of one speed level as one observation: the inverse-variance
    weighted mean; its std the within-pair one, or the between-pair scatter over sqrt(pairs) when larger."""
    se = np.array([max(r.se, 1e-12) for r in rs])
    w = 1.0 / se**2
    tau = np.array([r.tau_f for r in rs])
    mean = float(np.dot(w, tau) / w.sum())
    std = 1.0 / math.sqrt(float(w.sum()))
    if math.isfinite(between):
        std = max(std, between / math.sqrt(len(rs)))

    def avg(attr: str) -> float:
        return float(np.dot(w, [getattr(r, attr) for r in rs]) / w.sum())

    return _Result(joint=rs[0].joint, kind=rs[0].kind, speed=avg("speed"), tau_f=mean, se=std, u_plus=avg("u_plus"),
                   u_minus=avg("u_minus"), load=avg("load"), position=avg("position"),
                   n_plus=sum(r.n_plus for r in rs), n_minus=sum(r.n_minus for r in rs), st=sum(r.st for r in rs),
                   nt=sum(r.nt for r in rs), t_end=max(r.t_end for r in rs))


def _levels(speeds: list[float], match: float) -> list[float]:
    """The speed levels of sorted speeds: a new level past ``match`` x the level's slowest (their means)."""
    groups: list[list[float]] = []
    for s in speeds:
        if groups and s - groups[-1][0] <= match * groups[-1][0]:
            groups[-1].append(s)
        else:
            groups.append([s])
    return [float(np.mean(g)) for g in groups]


def _finite_float(x: object, what: str) -> float:
    try:
        f = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise InputDataError(f"production observer: {what} {x!r} is not a number") from None
    if not math.isfinite(f):
        raise InputDataError(f"production observer: {what} is {f!r}; expected a finite number of seconds")
    return f


def observe_production(
    t: Sequence[float] | Array, q: Array, v: Array, u: Array, temps: Array | None = None, *,
    joint_names: Sequence[str] | None = None, config: ProductionConfig | Sequence[ProductionConfig] | None = None,
    gravity: GravityFn | None = None, rigid_body: RigidBodyFn | None = None,
    payload_gravity: GravityFn | None = None, payload_rigid_body: RigidBodyFn | None = None,
    payload_mass: float | None = None, shift_id: int = 1,
    chunk: int | None = None,
) -> ProductionShift:
    """One shift of recorded samples (rows: stamps; columns: joints; rad, rad/s, N·m, degC) → its
    :class:`ProductionShift`, through :class:`ProductionObserver` sample by sample (``chunk`` rows at a time
    through :meth:`~ProductionObserver.add_many`: the same result, bit for bit). ``joint_names`` default
    ``joint_1`` ... ``joint_n``."""
    qa = np.asarray(q, dtype=float)
    if qa.ndim == 1:
        qa = qa[:, None]
    if qa.ndim != 2:
        raise InputDataError(f"production observer: positions have shape {qa.shape}; expected (samples, joints)")
    names = list(joint_names) if joint_names is not None else [f"joint_{i + 1}" for i in range(qa.shape[1])]
    obs = ProductionObserver(names, config, gravity=gravity, rigid_body=rigid_body, payload_gravity=payload_gravity,
                             payload_rigid_body=payload_rigid_body, payload_mass=payload_mass)
    ta = np.asarray(t, dtype=float).reshape(-1)

    def cols(a: Array | None) -> Array | None:
        if a is None:
            return None
        a = np.asarray(a, dtype=float)
        return a[:, None] if a.ndim == 1 else a

    va, ua, tt = cols(v), cols(u), cols(temps)
    assert va is not None and ua is not None
    step = max(ta.size, 1) if not chunk else int(chunk)
    if step < 1:
        raise InputDataError(f"production observer: chunk {chunk!r} must be at least 1 sample")
    for a in range(0, ta.size, step):
        b = a + step
        obs.add_many(ta[a:b], qa[a:b], va[a:b], ua[a:b], None if tt is None else tt[a:b])
    return obs.end_shift(shift_id)
