"""Sweeps that cannot hit the arm itself or the table: a collision check of a planned cycle, before anything moves.

:class:`CollisionChecker` is an arm of :mod:`jointwear_ros.sim.arms` as Pinocchio sees its collision
geometry: the URDF's collision meshes of ``example-robot-data`` (each made convex, its convex hull: a
hull contains the mesh, so a hull's distance never overstates the clearance), every pair of links that
the arm's SRDF does not disable (adjacent links, pairs that never meet), and the **table**: the
half-space ``z <= 0`` of the base frame (the arm stands on it), against every link that moves (not those
fixed to the base). For a configuration of the driven joints (the arm's first ``n`` joints; the others at
their ``home``, the Panda's fingers at their locked opening, as :class:`~jointwear_ros.sim.arm.ArmSim`
holds them) :meth:`CollisionChecker.closest` gives the pair with the least **margin**: its distance (coal's
GJK/EPA, negative when the hulls overlap) less its clearance (``clearance`` between two links,
``table_clearance`` from the table). A margin below zero is a contact. About 0.03 ms per configuration on
a UR5 (20 pairs), 0.06 ms on a Panda (59 pairs; ``docs/robot.md``).

:meth:`CollisionChecker.check_sweep` samples a straight joint-space segment (no joint moves more than
``step`` rad between two samples) and returns the first contact, or None. Between samples a point of
the arm moves at most ``step`` times its distance from the joints' axes (about 1.8 cm at 0.02 rad on a
UR5 at full reach): the clearance is what keeps a contact thinner than that from slipping between two
samples.

:func:`check_plan` checks a planned test cycle (:class:`~jointwear_ros.cycle.LinePlan`: every joint at
once; :class:`~jointwear_ros.cycle.RobotPlan`: one joint after another, the others where they stand) as
the runners move the arm: each step's approach (a straight joint-space move from where the arm stands)
and its sweep, forward and back along one segment, the segment lengthened at both ends by the stopping
allowance the planner leaves inside the joint limits (:func:`~jointwear_ros.cycle.plan.stop_allowance`,
the travel of a late control update). A cycle with a contact is refused with one line naming the step,
the links, the distance and the configuration (:class:`~jointwear_ros.cycle.CycleRequestError`,
``BAD_REQUEST``); a clear one gives its closest approach (:class:`PlanClearance`).

>>> checker = collision_checker("ur5", 6)
>>> checker.home, checker.check(checker.home) is None
((0.0, -1.3, 0.3, 0.7, 0.0, 0.0), True)
>>> print(checker.check([0.0, -1.3, 3.1, 0.7, 0.0, 0.0]).describe())  # the elbow folded into the upper arm
upper_arm_link and wrist_1_link overlap by 7.8 cm at q = [0.000, -1.300, 3.100, 0.700, 0.000, 0.000] rad
>>> print(checker.check_sweep(checker.home, [0.0, -1.3, 3.1, 0.7, 0.0, 0.0]).describe())  # the first too close
upper_arm_link and wrist_3_link come within 0.6 cm at q = [0.000, -1.300, 2.600, 0.700, 0.000, 0.000] rad
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import coal
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..contract import RefusalReason
from ..cycle import CycleConfig, CycleRequestError, LinePlan, RobotPlan
from ..cycle.plan import stop_allowance
from ..errors import ParameterError
from .arms import ArmSpec, arm_spec, robots_dir

__all__ = ["CLEARANCE", "SWEEP_STEP", "TABLE", "TABLE_CLEARANCE", "CollisionChecker", "Contact", "PlanClearance",
           "check_plan", "collision_checker"]

Array = npt.NDArray[np.float64]
#: joint positions: a sequence or an array, rad
Positions = Sequence[float] | Array

#: Least distance between two links, m.
CLEARANCE = 0.01
#: Least distance of a moving link from the table (z = 0 of the base frame), m.
TABLE_CLEARANCE = 0.01
#: Largest joint step between two checked configurations of a segment, rad.
SWEEP_STEP = 0.02
#: The name the table goes by in a :class:`Contact`.
TABLE = "the table"


@dataclass(frozen=True)
class Contact:
    """The closest pair of one configuration: two links (``second`` may be :data:`TABLE`), their distance (m,
    negative: the hulls overlap by that much), the clearance that pair must keep (m) and the configuration of
    the driven joints (rad)."""

    first: str
    second: str
    distance: float
    clearance: float
    q: tuple[float, ...]

    @property
    def margin(self) -> float:
        """Distance less clearance, m: below zero the configuration is refused."""
        return self.distance - self.clearance

    @property
    def collides(self) -> bool:
        return self.margin < 0.0

    def describe(self) -> str:
        """One phrase: the links, how close, where (``q``, rad)."""
        cm = 100.0 * self.distance
        where = f"at q = [{', '.join(f'{x:.3f}' for x in self.q)}] rad"
        if self.second == TABLE:
            if cm < 0.0:
                return f"{self.first} goes {-cm:.1f} cm into {TABLE} (z = 0 of the base) {where}"
            return f"{self.first} comes within {cm:.1f} cm of {TABLE} (z = 0 of the base) {where}"
        if cm < 0.0:
            return f"{self.first} and {self.second} overlap by {-cm:.1f} cm {where}"
        return f"{self.first} and {self.second} come within {cm:.1f} cm {where}"


class CollisionChecker:
    """An arm's self-collision and table check for configurations of its first ``n`` joints (module docstring).

    Build it once per arm (:func:`collision_checker` caches it): reading the meshes and making them convex
    takes about 0.1 s.

    Parameters
    ----------
    spec
        The arm.
    n
        How many of its joints are driven (its first ``n``; the others stay at their ``home``).
    clearance
        Least distance between two links, m.
    table_clearance
        Least distance of a moving link from the table, m.
    """

    def __init__(self, spec: ArmSpec, n: int, clearance: float = CLEARANCE,
                 table_clearance: float = TABLE_CLEARANCE) -> None:
        if not 1 <= n <= len(spec.joints):
            raise ParameterError(f"arm {spec.name}: {n} driven joints; it has {len(spec.joints)}")
        for what, v in (("clearance", clearance), ("table_clearance", table_clearance)):
            if not (math.isfinite(v) and v >= 0.0):
                raise ParameterError(f"collision check: {what} must be a distance >= 0 m, got {v}")
        self.spec = spec
        self.joints = spec.joints[:n]
        self.clearance = float(clearance)
        self.table_clearance = float(table_clearance)
        urdf = str(spec.urdf_path())
        model = pin.buildModelFromUrdf(urdf)
        # the meshes are package://example-robot-data/robots/...: the package folder's parent resolves them
        geom = pin.buildGeomFromUrdf(model, urdf, pin.GeometryType.COLLISION, package_dirs=[str(robots_dir().parents[1])])
        for go in geom.geometryObjects:
            if isinstance(go.geometry, coal.BVHModelBase):
                go.geometry.buildConvexHull(True, "Qt")
                go.geometry = go.geometry.convex
        geom.addAllCollisionPairs()
        srdf = spec.srdf_path()
        if srdf is not None:
            before = {(p.first, p.second) for p in geom.collisionPairs}
            pin.removeCollisionPairs(model, geom, str(srdf))
            # a link fixed to another (the UR5's ee_link to wrist_3_link) is one body with it: the pairs the SRDF
            # disables for one link of a body it disables for every link of that body
            body = [go.parentJoint for go in geom.geometryObjects]
            kept = [(p.first, p.second) for p in geom.collisionPairs]
            off = {frozenset((body[a], body[b])) for a, b in before.difference(kept)}
            geom.removeAllCollisionPairs()
            for a, b in kept:
                if frozenset((body[a], body[b])) not in off:
                    geom.addCollisionPair(pin.CollisionPair(a, b))
        # the table against every body that moves, but a body turning about the table's normal right at the base
        # (the UR5's shoulder, the Panda's link 1) keeps its height: its fixed distance would only mask the others
        data = model.createData()
        pin.forwardKinematics(model, data, pin.neutral(model))
        level = {jid for jid in range(1, model.njoints) if model.parents[jid] == 0
                 and abs(abs(float((data.oMi[jid].rotation @ _axis(model.joints[jid]))[2])) - 1.0) < 1e-9}
        moving = [i for i, go in enumerate(geom.geometryObjects) if go.parentJoint not in (0, *level)]
        table = geom.addGeometryObject(pin.GeometryObject(TABLE, 0, 0, pin.SE3.Identity(),
                                                          coal.Halfspace(np.array([0.0, 0.0, 1.0]), 0.0)))
        for i in moving:
            geom.addCollisionPair(pin.CollisionPair(i, table))
        self.model = model
        self.geom = geom
        self.data = model.createData()
        self.gdata = pin.GeometryData(geom)
        #: per collision pair: the two link names and the clearance it keeps
        self.pairs: list[tuple[str, str, float]] = []
        for p in geom.collisionPairs:
            a, b = self._link(p.first), self._link(p.second)
            self.pairs.append((a, b, self.table_clearance) if b == TABLE else (a, b, self.clearance))
        self._clear = np.array([c for _, _, c in self.pairs])
        positions = {**{j.name: j.home for j in spec.joints}, **dict(spec.locked)}
        self._q0: Array = np.array(pin.neutral(model), dtype=float)
        for jid in range(1, model.njoints):
            name = model.names[jid]
            if name in positions:
                self._q0[model.joints[jid].idx_q] = positions[name]
        self._index = []
        for j in self.joints:
            if not model.existJointName(j.name):
                raise ParameterError(f"arm {spec.name}: joint {j.name} is not in {spec.urdf}")
            self._index.append(model.joints[model.getJointId(j.name)].idx_q)

    def _link(self, k: int) -> str:
        go = self.geom.geometryObjects[k]
        if go.name == TABLE:
            return TABLE
        return str(self.model.frames[go.parentFrame].name)

    @property
    def n(self) -> int:
        return len(self.joints)

    @property
    def home(self) -> tuple[float, ...]:
        """The test pose of the driven joints, rad."""
        return tuple(j.home for j in self.joints)

    def _full(self, q: Positions) -> Array:
        if len(q) != self.n:
            raise ParameterError(f"arm {self.spec.name}: {len(q)} joint positions for {self.n} driven joints")
        full = self._q0.copy()
        full[self._index] = np.asarray(q, dtype=float)
        return full

    def closest(self, q: Positions) -> Contact:
        """The pair with the least margin (distance less its clearance) at ``q`` (the driven joints, rad)."""
        pin.computeDistances(self.model, self.data, self.geom, self.gdata, self._full(q))
        d = np.array([r.min_distance for r in self.gdata.distanceResults])
        k = int(np.argmin(d - self._clear))
        a, b, c = self.pairs[k]
        return Contact(a, b, float(d[k]), c, tuple(float(x) for x in q))

    def check(self, q: Positions) -> Contact | None:
        """The closest pair at ``q`` if it is closer than its clearance, else None."""
        c = self.closest(q)
        return c if c.collides else None

    def samples(self, q_from: Positions, q_to: Positions, step: float = SWEEP_STEP) -> Iterator[Array]:
        """Configurations along the straight segment ``q_from -> q_to``, both ends included, no joint moving
        more than ``step`` rad between two."""
        if not (math.isfinite(step) and step > 0.0):
            raise ParameterError(f"collision check: step must be > 0 rad, got {step}")
        a = np.asarray(q_from, dtype=float)
        b = np.asarray(q_to, dtype=float)
        span = float(np.max(np.abs(b - a))) if a.size else 0.0
        count = max(1, math.ceil(span / step))
        for i in range(count + 1):
            yield a + (b - a) * (i / count)

    def check_sweep(self, q_from: Positions, q_to: Positions,
                    step: float = SWEEP_STEP) -> Contact | None:
        """The first configuration of the segment ``q_from -> q_to`` closer than a clearance (the pair named),
        or None when the whole segment is clear (sampled every ``step`` rad)."""
        for q in self.samples(q_from, q_to, step):
            c = self.check(q)
            if c is not None:
                return c
        return None

    def sweep_closest(self, q_from: Positions, q_to: Positions,
                      step: float = SWEEP_STEP) -> Contact:
        """The closest approach along the segment ``q_from -> q_to`` (the first contact if there is one)."""
        best: Contact | None = None
        for q in self.samples(q_from, q_to, step):
            c = self.closest(q)
            if c.collides:
                return c
            if best is None or c.margin < best.margin:
                best = c
        assert best is not None
        return best


def _axis(joint: Any) -> Array:
    """The rotation axis of a revolute joint about x, y or z, in its own frame (zero for any other joint)."""
    m = re.fullmatch(r"JointModelR(?:UB)?([XYZ])", str(joint.shortname()))
    return np.eye(3)["XYZ".index(m.group(1))] if m else np.zeros(3)


@functools.lru_cache(maxsize=16)
def collision_checker(arm: str, n: int, clearance: float = CLEARANCE,
                      table_clearance: float = TABLE_CLEARANCE) -> CollisionChecker:
    """The :class:`CollisionChecker` of arm ``arm`` with its first ``n`` joints driven (built once, cached)."""
    return CollisionChecker(arm_spec(arm), n, clearance, table_clearance)


@dataclass(frozen=True)
class PlanClearance:
    """A cycle's closest approach: where in the cycle (``step``: e.g. ``"step 8 (160 rad/s)"``) and the pair."""

    step: str
    contact: Contact

    def describe(self) -> str:
        return f"{self.step}: {self.contact.describe()}"


def _segments(plan: LinePlan | RobotPlan, configs: Mapping[str, CycleConfig], names: Sequence[str],
              positions: Mapping[str, float]) -> Iterator[tuple[str, Array, Array]]:
    """(step, from, to) of every straight move of ``plan`` in the driven joints ``names`` (in order), the arm
    starting at ``positions``; each sweep once (forward and back go along the same segment), lengthened by the
    stopping allowance at both ends."""
    q = np.array([float(positions.get(j, math.nan)) for j in names], dtype=float)
    if isinstance(plan, LinePlan):
        idx = [names.index(j) for j in plan.joints]
        for k, st in enumerate(plan.steps):
            speeds = sorted(set(st.speeds))
            label = f"step {k + 1} ({', '.join(f'{s:g}' for s in speeds)} rad/s)"
            start, end = q.copy(), q.copy()
            start[idx] = st.start
            end[idx] = st.end
            yield f"{label}, approach", q.copy(), start
            w = np.zeros(len(names))
            w[idx] = st.velocities
            extra = max(stop_allowance(x, configs[j]) / abs(x) for j, x in zip(plan.joints, st.velocities, strict=True))
            yield f"{label}, sweep", start - extra * w, end + extra * w
            q = start
        return
    for j, jp in zip(plan.joints, plan.plans, strict=True):
        i = names.index(j)
        lo = hi = q[i]
        for k, sp in enumerate(jp.speeds):
            label = f"{j}, speed #{k + 1} ({sp.speed:g} rad/s)"
            s = stop_allowance(sp.velocity, configs[j])
            a, b = sp.start - s, sp.end + s
            # one joint moves, the others stand: only the part of its range not checked yet is new
            for x0, x1 in ((a, min(b, lo)), (max(a, hi), b)):
                if x1 > x0:
                    qa, qb = q.copy(), q.copy()
                    qa[i], qb[i] = x0, x1
                    yield label, qa, qb
            lo, hi = min(lo, a), max(hi, b)
        q[i] = jp.speeds[-1].start  # a joint's test ends at the last sweep's start


def check_plan(checker: CollisionChecker, plan: LinePlan | RobotPlan, configs: Mapping[str, CycleConfig],
               names: Sequence[str], positions: Mapping[str, float], step: float = SWEEP_STEP) -> PlanClearance:
    """Check every move of ``plan`` on the arm of ``checker`` before anything moves (module docstring).

    ``names``: the driven joints in command order (the i-th is the arm's i-th joint); ``positions``: where each
    stands now (a driven joint the plan does not move stays there); ``configs``: each joint's settings (its
    stopping allowance). Returns the closest approach of the whole cycle; raises
    :class:`~jointwear_ros.cycle.CycleRequestError` (``BAD_REQUEST``) at the first move that comes closer than a
    clearance, naming the step, the links, the distance and the configuration.
    """
    names = list(names)
    if len(names) != checker.n:
        raise ParameterError(f"collision check of arm {checker.spec.name}: {len(names)} driven joints, the checker "
                             f"has {checker.n}")
    missing = [j for j in names if not math.isfinite(float(positions.get(j, math.nan)))]
    if missing:
        raise CycleRequestError(f"no position of {missing[0]} to check the cycle's path against the arm's model",
                                RefusalReason.STATE_MISSING)
    best: PlanClearance | None = None
    for label, a, b in _segments(plan, configs, names, positions):
        c = checker.sweep_closest(a, b, step)
        if c.collides:
            raise CycleRequestError(
                f"{label}: {c.describe()} (clearance {100 * c.clearance:g} cm, arm {checker.spec.name}); narrow the "
                "speeds or move the window centres", RefusalReason.BAD_REQUEST)
        if best is None or c.margin < best.contact.margin:
            best = PlanClearance(label, c)
    if best is None:  # nothing moves: the arm as it stands
        best = PlanClearance("where the arm stands", checker.closest([float(positions[j]) for j in names]))
        if best.contact.collides:
            raise CycleRequestError(f"{best.describe()}; move the arm clear first", RefusalReason.BAD_REQUEST)
    return best
