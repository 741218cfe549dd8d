"""A real arm as the simulated plant: Pinocchio's rigid-body dynamics behind one velocity drive per joint.

:class:`ArmSim` has the interface of :class:`~jointwear_ros.sim.RobotSim` (the ``joint_sim`` node runs
either), but its joints are coupled: the plant is the arm of an :class:`~jointwear_ros.sim.arms.ArmSpec`
built from its URDF by Pinocchio, with the full configuration-dependent inertia, Coriolis and
centrifugal torques and the gravity of the whole configuration and a payload (paper Eq. 2, joint side,
N·m)::

    M(q) q'' + C(q, q') q' + g(q) + tau_f(q') = tau_u
    tau_u,j = u_j * torque_scale_j                     (the drive torque; u normalized, as JointSim's)
    tau_f,j = (F_j(|q'_j| * gear_j, |n_j(q, q')| / torque_scale_j) + o_j) * torque_scale_j * sign(q'_j)
    n(q, q') = C(q, q') q' + g(q)                      (the torque the gear transmits at constant speed)

The accelerations are Pinocchio's ``aba`` (articulated-body algorithm; ``model.armature``, each
joint's reflected rotor inertia, adds to the diagonal of ``M``); the friction's load ``n`` is
``nonLinearEffects``. No rigid-body term is written here.

Per joint, as :class:`~jointwear_ros.sim.JointSim` (each joint *is* one, :class:`ArmJointSim`, for
its drive state, its friction and its noise): the velocity reference follows the command at most at
``accel_limit``; the velocity PI on the motor side with anti-windup; saturation at ``torque_limit`` and
never above the URDF effort limit; the friction ``F_j`` of the joint's own
:class:`~jointwear_ros.sim.FrictionTable` (parameter set, wear, temperature, hidden effects) at its
motor speed, with the load ``|n_j(q, q')|``: the torque *that* joint's gear transmits at constant
speed, gravity of the whole configuration and payload plus the Coriolis and centrifugal push of the
other joints (the paper's ``tau_m``, a gravity torque on its one joint; a gear's friction grows with
the torque it carries, whatever makes it). At constant speed it is what the observer's
``(u+ + u-)/2`` measures, so the load column carries it; the per-sweep friction offset ``o_j``; the
white effort noise. The effort published is ``(u + n) * torque_scale``: what a drive reports, not the
link-side torque.

Where JointSim's settings do not apply: ``inertia``, ``gravity_torque`` and ``gravity_angle`` of a
:class:`~jointwear_ros.sim.JointSimConfig` are not used on the arm (its inertia and gravity are
Pinocchio's, from the URDF). Each arm joint's defaults for ``gear_ratio``, ``torque_scale``,
``initial_position`` (the test pose), ``kp``, ``ki`` and ``torque_limit`` come from its spec
(:func:`arm_configs`; the gains are sized for its inertia, :mod:`jointwear_ros.sim.arms`). The drives
start holding the arm (torque on, then brakes released): each integrator starts at the joint's gravity
torque, so the arm does not sag at start.

The arm's limits: a command is clamped to the URDF velocity limit; near a position limit the drive
lowers the velocity reference towards it to ``sqrt(2 a d)`` (``d`` the distance left, ``a`` the
``accel_limit``), so a joint commanded into its limit stops there, and a joint that still reaches it
stops dead (an end stop).

**Stick band with coupling.** A joint whose motor speed is inside ``stick_speed`` is held (Karnopp, as
JointSim's) while the torque needed to hold it is within its breakaway friction. On the arm that
torque depends on the other joints, and it is solved within the step (:meth:`ArmSim._stick`): with the
joints in the band at rest (acceleration 0), the others' accelerations follow from
``M_FF a_F = tau_F - n_F`` (``M`` Pinocchio's ``crba``, armature included) and a held joint needs
``M_hF a_F + n_h``; the joint whose drive misses that by most beyond its breakaway friction breaks away
(the breakaway friction against its net torque) and the rest are solved again, until every joint still
held can be held. So the push of an accelerating joint on a held one is the push of that same step. (With
the other joints' accelerations of the *previous* step, two strongly coupled joints chattered: on the
Panda, whose joints 1 and 3 are nearly coaxial at its test pose, ``M[0, 2]`` 1.05 against ``M[0, 0]`` 1.14
kg·m², joint 1 swinging ±7 rad/s² every step while joint 3 stuck, its drive torque at constant speed 2.5
times its friction.) A held joint gets exactly the torque it needs from friction; its acceleration and
velocity are 0. A moving joint whose velocity would change sign within one step stops at 0 instead
(friction cannot reverse a motion); the stick test of the next step decides. Away from 0 (the sweeps,
where friction is observed) the friction is the model's kinetic friction, exactly.

Integration: semi-implicit Euler at ``physics_rate`` (velocity first, position with the new velocity);
:meth:`ArmSim.step` splits a longer ``dt`` into equal sub-steps no longer than ``1 / physics_rate``.
Cost: about 30-45 µs per step for six or seven joints all moving or all held (``bench/bench_arm_sim.py``),
40-90 µs while some are held and others move (the band solved with the inertia matrix).

>>> from jointwear_ros.sim.arms import arm_spec
>>> ur5 = arm_spec("ur5")
>>> names = ["joint_1", "joint_2", "joint_3", "joint_4", "joint_5", "joint_6"]
>>> arm = ArmSim(ur5, names, arm_configs(ur5, names), seeds=range(6))
>>> arm.set_commands([0.2, 0.0, 0.0, 0.0, 0.0, 0.0])
>>> arm.step(1.0)
>>> pos, vel, eff = arm.sample()
>>> round(arm.time, 3), round(vel[0], 3), vel[1], round(arm.gravity()[1])
(1.0, 0.2, 0.0, -20)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..errors import ParameterError
from .arms import ArmJoint, ArmSpec
from .joint import JointSim, JointSimConfig, command_all

__all__ = ["ArmJointSim", "ArmModel", "ArmSim", "arm_configs"]

Array = npt.NDArray[np.float64]

#: the deceleration of a joint nearing its position limit when its accel_limit is 0 (none), joint rad/s^2
_LIMIT_DECEL = 8.0


def arm_configs(spec: ArmSpec, names: Sequence[str], **settings: Any) -> list[JointSimConfig]:
    """One :class:`JointSimConfig` per name of ``names`` (the i-th drives the arm's i-th joint): the arm
    joint's defaults (:meth:`~jointwear_ros.sim.arms.ArmJoint.sim_defaults`), then ``settings`` (the same
    for every joint, e.g. ``wear=20.0``; per joint, ``dataclasses.replace`` the result)."""
    return [JointSimConfig(**{**j.sim_defaults(), **settings}) for j in spec.for_names(names)]


class ArmJointSim(JointSim):
    """One joint of an :class:`ArmSim`: its drive state, friction table, per-sweep offset and noise are
    :class:`JointSim`'s; its dynamics are the arm's (it is stepped by :meth:`ArmSim.step` only)."""

    def __init__(self, arm: ArmSim, index: int, joint: ArmJoint, config: JointSimConfig, seed: int) -> None:
        super().__init__(config, seed=seed)
        self.arm = arm
        self.arm_index = index
        #: the arm joint it drives (URDF name, limits)
        self.arm_joint = joint

    def gravity(self, position: float | None = None) -> float:
        """This joint's gravity torque in the arm's current configuration, payload included, normalized.
        ``position`` is not used: on an arm, a joint's gravity depends on every joint."""
        return float(self.arm.gravity()[self.arm_index]) / self.config.torque_scale

    def step(self, dt: float) -> None:
        """Not on its own: the joints of an arm move together (:meth:`ArmSim.step`)."""
        raise TypeError("a joint of an ArmSim moves with its arm: call ArmSim.step")


class ArmSim:
    """A real arm (Pinocchio forward dynamics) behind one velocity command array (see the module docstring).

    Parameters
    ----------
    spec
        The arm (:func:`~jointwear_ros.sim.arms.arm_spec`).
    names
        The suite's joint names, in command-array order: the i-th drives the arm's i-th joint (at most
        as many as the arm has). The arm's other joints, and ``spec.locked`` (the Panda's fingers), are
        locked (Pinocchio's reduced model) at their ``home`` (``spec.locked``: their locked position).
    configs
        One :class:`JointSimConfig` per joint (:func:`arm_configs` gives the arm's defaults).
    seeds
        One noise seed per joint.
    payload
        Point mass at ``spec.payload_offset`` in the body of ``spec.payload_joint``, kg (:meth:`set_payload`).
    physics_rate
        Integration rate, Hz: the longest sub-step is ``1 / physics_rate``.
    """

    def __init__(self, spec: ArmSpec, names: Sequence[str], configs: Sequence[JointSimConfig],
                 seeds: Iterable[int], payload: float = 0.0, physics_rate: float = 1000.0) -> None:
        names = [str(n) for n in names]
        seed_list = [int(s) for s in seeds]
        if not names:
            raise ParameterError("arm sim: give at least one joint name")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup or any(not n for n in names):
            raise ParameterError(f"arm sim: joint names must be non-empty and unique, got {names}")
        self.arm_joints: tuple[ArmJoint, ...] = spec.for_names(names)
        if not (len(configs) == len(names) == len(seed_list)):
            raise ParameterError(f"arm sim: {len(names)} joint names need as many configs and seeds, got "
                                 f"{len(configs)} and {len(seed_list)}")
        if not (math.isfinite(physics_rate) and physics_rate > 0):
            raise ParameterError(f"arm sim: physics_rate must be a finite number of Hz > 0, got {physics_rate}")
        self.spec = spec
        self.names: tuple[str, ...] = tuple(names)
        self.index = {n: i for i, n in enumerate(self.names)}
        self.physics_rate = float(physics_rate)
        #: per joint: URDF position limits (rad), velocity limit (rad/s), effort limit (normalized)
        self._limits = [(aj.lower, aj.upper, aj.velocity, aj.torque_limit) for aj in self.arm_joints]
        #: the drive constants of :meth:`_substep` and the (config, friction) of each joint they were taken from
        self._drive_key: list[Any] = []
        self._drive_list: list[tuple[Any, ...]] = []
        for aj, cfg, name in zip(self.arm_joints, configs, names, strict=True):
            if not aj.lower <= cfg.initial_position <= aj.upper:
                raise ParameterError(f"arm sim: {name} ({aj.name}) initial_position {cfg.initial_position:g} rad is "
                                     f"outside the URDF limits [{aj.lower:g}, {aj.upper:g}]")
        self.joints: tuple[ArmJointSim, ...] = tuple(
            ArmJointSim(self, i, aj, cfg, seed)
            for i, (aj, cfg, seed) in enumerate(zip(self.arm_joints, configs, seed_list, strict=True)))
        self._full = pin.buildModelFromUrdf(str(spec.urdf_path()))
        for aj in self.arm_joints:
            if not self._full.existJointName(aj.name):
                raise ParameterError(f"arm {spec.name}: joint {aj.name} is not in {spec.urdf}")
        self._payload_id = int(self._full.getJointId(spec.payload_joint)) if spec.payload_joint else 0
        self._payload_body = self._full.inertias[self._payload_id].copy() if self._payload_id else None
        n = len(names)
        self._q: Array = np.array([c.initial_position for c in configs], dtype=float)
        self._v: Array = np.zeros(n)
        self._tau: Array = np.zeros(n)
        self._g: Array = np.zeros(n)
        self._g_at: Array | None = None
        self.time = 0.0
        self.payload = 0.0
        self.model: Any = None
        self.data: Any = None
        self.set_payload(payload)
        # the drives start holding the arm (torque on, then the brakes released): no sag at start
        for j, g in zip(self.joints, self.gravity().tolist(), strict=True):
            lim = min(j.config.torque_limit, j.arm_joint.torque_limit)
            j.torque = j._integral = max(-lim, min(lim, g / j.config.torque_scale))
        self._sync()

    # -- the model -----------------------------------------------------------
    def _build(self, payload: float) -> None:
        """The reduced model: the driven joints free, the others locked; the payload in its body."""
        full = self._full
        if self._payload_body is not None:
            point = pin.Inertia(float(payload), np.array(self.spec.payload_offset, dtype=float), np.zeros((3, 3)))
            full.inertias[self._payload_id] = self._payload_body + point
        driven = {aj.name for aj in self.arm_joints}
        positions = {**{j.name: j.home for j in self.spec.joints}, **dict(self.spec.locked)}
        q_lock = pin.neutral(full)
        lock: list[int] = []
        for jid in range(1, full.njoints):
            name = full.names[jid]
            if name in driven:
                continue
            if full.joints[jid].nq != 1:
                raise ParameterError(f"arm {self.spec.name}: joint {name} is not a 1-DoF joint; cannot lock it")
            q_lock[full.joints[jid].idx_q] = positions.get(name, 0.0)
            lock.append(jid)
        model = pin.buildReducedModel(full, lock, q_lock) if lock else full.copy()
        order = [model.names[j] for j in range(1, model.njoints)]
        if order != [aj.name for aj in self.arm_joints] or model.nv != len(self.arm_joints):
            raise ParameterError(f"arm {self.spec.name}: the model's joints {order} are not the arm's "
                                 f"{[aj.name for aj in self.arm_joints]}")
        model.armature = np.array([aj.armature for aj in self.arm_joints], dtype=float)
        self.model = model
        self.data = model.createData()
        self._g_at = None

    def set_payload(self, kg: float) -> None:
        """Set the payload now (kg, at ``spec.payload_offset`` in the body of ``spec.payload_joint``); the
        state (positions, speeds, integrators) is kept: the arm sags until its drives catch it."""
        kg = float(kg)
        if not (math.isfinite(kg) and kg >= 0.0):
            raise ParameterError(f"arm sim: payload must be a finite mass >= 0 kg, got {kg}")
        if kg and self._payload_body is None:
            raise ParameterError(f"arm {self.spec.name} has no payload mount (payload_joint)")
        self._build(kg)
        self.payload = kg

    # -- the RobotSim interface ------------------------------------------------
    def __len__(self) -> int:
        return len(self.joints)

    def __getitem__(self, name: str) -> ArmJointSim:
        """The joint called ``name`` (``KeyError`` if there is none)."""
        return self.joints[self.index[name]]

    @property
    def commands(self) -> tuple[float, ...]:
        """The velocity commands being followed, joint side rad/s, in joint order (as given, before the
        URDF velocity limit)."""
        return tuple(j.command for j in self.joints)

    def set_commands(self, velocities: Sequence[float]) -> None:
        """Set every joint's velocity command (joint rad/s, joint order); all or none (a wrong length or
        a non-finite value raises :class:`ParameterError` and changes nothing). The drive clamps each to
        the joint's URDF velocity limit."""
        command_all(self.joints, self.names, velocities, "the arm", "driven joint")

    def stop(self) -> None:
        """Command zero velocity on every joint."""
        for j in self.joints:
            j.set_command(0.0)

    def reconfigure(self, name: str, config: JointSimConfig) -> None:
        """Apply new settings to one joint now (see :meth:`JointSim.reconfigure`: wear, temperature,
        gains, noise ...; its ``inertia`` and gravity settings have no effect on the arm)."""
        self[name].reconfigure(config)

    # -- the model's torques -------------------------------------------------
    def gravity(self) -> Array:
        """Gravity torque of every driven joint in the current configuration, payload included, N·m
        (joint side; what a motor holds at rest: the paper's ``tau_m``)."""
        if self._g_at is None or not np.array_equal(self._g_at, self._q):
            self._g = np.array(pin.computeGeneralizedGravity(self.model, self.data, self._q), dtype=float)
            self._g_at = self._q.copy()
        return self._g.copy()

    def inverse_dynamics(self, q: Sequence[float], v: Sequence[float], a: Sequence[float] | None = None) -> Array:
        """``M(q) a + C(q, v) v + g(q)`` (armature included, the current payload), N·m: Pinocchio's RNEA."""
        qa = np.asarray(q, dtype=float)
        va = np.asarray(v, dtype=float)
        aa = np.zeros_like(va) if a is None else np.asarray(a, dtype=float)
        return np.array(pin.rnea(self.model, self.data, qa, va, aa), dtype=float)

    def true_friction(self, name: str, velocity: float | None = None,
                      positions: Sequence[float] | None = None, velocities: Sequence[float] | None = None) -> float:
        """Noise-free model friction of joint ``name``, N·m (joint side): at ``velocity`` (joint rad/s;
        default: its current one) with the load ``|C(q, v) v + g(q)|`` of the configuration ``positions``
        and every joint's ``velocities`` (defaults: the current ones; with ``positions`` given, the other
        joints at rest unless ``velocities`` says otherwise), at the current time; the per-sweep offset not
        included."""
        j = self[name]
        i = j.arm_index
        cfg = j.config
        vj = float(self._v[i]) if velocity is None else float(velocity)
        q = self._q if positions is None else np.asarray(positions, dtype=float)
        if velocities is not None:
            vv = np.asarray(velocities, dtype=float)
        elif positions is None:
            vv = self._v.copy()
        else:
            vv = np.zeros_like(self._v)
            vv[i] = vj
        n = np.array(pin.nonLinearEffects(self.model, self.data, q, vv), dtype=float)
        load = abs(float(n[i])) / cfg.torque_scale
        f = j.friction.exact(np.array([vj * cfg.gear_ratio]), load, float(q[i]), self.time)
        return float(f[0]) * cfg.torque_scale

    # -- physics -------------------------------------------------------------
    def _drives(self) -> list[tuple[Any, ...]]:
        """Each joint's drive constants for :meth:`_substep`, from its current config and friction table (kept
        while neither changed: :meth:`JointSim.reconfigure` replaces them)."""
        key = [j.config for j in self.joints] + [j.friction for j in self.joints]
        if key != self._drive_key:  # the same objects (or equal configs): the same constants
            drives = []
            for j, (lower, upper, lim_v, lim_u) in zip(self.joints, self._limits, strict=True):
                cfg = j.config
                drives.append((cfg.gear_ratio, cfg.torque_scale, lower, upper, lim_v,
                               cfg.accel_limit if cfg.accel_limit > 0.0 else _LIMIT_DECEL, cfg.accel_limit,
                               cfg.kp, cfg.ki, cfg.torque_limit if cfg.torque_limit < lim_u else lim_u,
                               cfg.stick_speed, j.friction, j.friction.speed_tables()))
            self._drive_list = drives
            self._drive_key = key
        return self._drive_list

    def step(self, dt: float) -> None:
        """Advance the arm by ``dt`` seconds, in equal sub-steps of at most ``1 / physics_rate``."""
        n = max(1, math.ceil(dt * self.physics_rate - 1e-9))
        h = dt / n
        joints = self.joints
        drives = self._drives()
        # the drives' state, in lists for the sub-steps, written back after them
        cmds = [j.command for j in joints]
        refs = [j.reference for j in joints]
        ints = [j._integral for j in joints]
        offs = [j.offset for j in joints]
        us = [0.0] * len(joints)
        for _ in range(n):
            self._substep(h, drives, cmds, refs, ints, offs, us)
        for j, ref, i, u in zip(joints, refs, ints, us, strict=True):
            j.reference = ref
            j._integral = i
            j.torque = u
        self._sync()

    def _substep(self, h: float, drives: list[tuple[Any, ...]], cmds: list[float], refs: list[float],
                 ints: list[float], offs: list[float], torques: list[float]) -> None:
        """One semi-implicit Euler step of ``h`` s; ``refs``, ``ints`` and ``torques`` (each drive's velocity
        reference, integrator and torque ``u``) are updated in place."""
        model, data = self.model, self.data
        q, v = self._q, self._v
        ql = q.tolist()
        vl = v.tolist()
        gl = pin.nonLinearEffects(model, data, q, v).tolist()  # the friction's load: g(q) + C(q, v) v
        t = self.time
        n = len(drives)
        taul = [0.0] * n
        us = [0.0] * n
        ffs = [0.0] * n
        band: list[int] = []
        for i in range(n):
            gr, ts, lower, upper, lim_v, acc, accel_limit, kp, ki, lim, stick_speed, friction, tables = drives[i]
            vm = vl[i] * gr
            # the drive's reference: the command within the velocity limit, ramped, slowed near a limit
            cmd = cmds[i]
            cmd = lim_v if cmd > lim_v else (-lim_v if cmd < -lim_v else cmd)
            if cmd > 0.0:
                room = upper - ql[i]
                cmd = 0.0 if room <= 0.0 else min(cmd, math.sqrt(2.0 * acc * room))
            elif cmd < 0.0:
                room = ql[i] - lower
                cmd = 0.0 if room <= 0.0 else max(cmd, -math.sqrt(2.0 * acc * room))
            target = cmd * gr
            ref = refs[i]
            if accel_limit > 0.0 and ref != target:
                dmax = accel_limit * gr * h
                ref = min(target, ref + dmax) if target > ref else max(target, ref - dmax)
            else:
                ref = target
            refs[i] = ref
            # the velocity PI, saturated at the torque limit (never above the URDF effort), anti-windup
            e = ref - vm
            u_raw = kp * e + ints[i]
            u = lim if u_raw > lim else (-lim if u_raw < -lim else u_raw)
            if u == u_raw or (u_raw > lim and e < 0.0) or (u_raw < -lim and e > 0.0):
                ints[i] += ki * e * h
            torques[i] = u
            if tables is None:
                ff = friction(vm, abs(gl[i]) / ts, ql[i], t) + offs[i]
            else:  # FrictionTable.__call__ without position and time effects, inline (it runs most in the sim)
                ta, tb, inv_step, last = tables
                x = abs(vm) * inv_step
                k = int(x)
                if k > last:
                    k, f = last, 1.0
                else:
                    f = x - k
                a0 = ta[k]
                b0 = tb[k]
                ff = (a0 + f * (ta[k + 1] - a0) + abs(gl[i]) / ts * (b0 + f * (tb[k + 1] - b0)) + 0.0) + offs[i]
            if ff < 0.0:
                ff = 0.0
            us[i] = u * ts
            ffs[i] = ff * ts
            if abs(vm) < stick_speed:
                band.append(i)
            else:
                taul[i] = (u - math.copysign(ff, vm)) * ts
        tau = self._tau = np.array(taul)
        held: list[int] = []
        if band:
            al, held = self._stick(q, gl, us, ffs, band, tau)
        else:
            al = pin.aba(model, data, q, v, tau).tolist()
        # semi-implicit Euler joint by joint (the same float operations as on the arrays): a held joint and one
        # whose velocity would change sign stop at 0; a joint past a position limit stops at it (the end stops)
        vn = [0.0] * n
        qn = [0.0] * n
        limits = self._limits
        for i in range(n):
            vi = vl[i]
            x = 0.0 if i in held else vi + al[i] * h
            if x * vi < 0.0:
                x = 0.0
            y = ql[i] + x * h
            lower, upper = limits[i][0], limits[i][1]
            if not lower <= y <= upper:
                y = upper if y > upper else lower
                x = 0.0
            vn[i] = x
            qn[i] = y
        self._v = np.array(vn)
        self._q = np.array(qn)
        self.time = t + h

    def _stick(self, q: Array, nle: list[float], us: list[float], ffs: list[float], band: list[int],
               tau: Array) -> tuple[list[float], list[int]]:
        """The stick band with coupling, solved in the step: the accelerations and the joints held.

        Every joint of ``band`` starts held (acceleration 0); the others' accelerations solve
        ``M_FF a_F = tau_F - n_F``, and a held joint needs ``M_hF a_F + n_h`` from its drive and friction
        together. Where the drive's torque ``us`` misses that by more than the breakaway friction ``ffs``,
        the joint that misses most breaks away (the breakaway friction against its net torque, in ``tau``)
        and the rest are solved again, until every joint still held is held. ``tau`` gets each held
        joint's torque (what it needs). ``M_FF`` (symmetric positive definite, at most the arm's joints) is
        solved by Cholesky in plain Python: numpy's solve on a 5 x 5 costs more in its call than in its sums."""
        n = len(us)
        held = list(band)
        up: list[list[float]] = []  # M(q): crba's upper triangle (armature included), when first needed

        while True:
            free = [i for i in range(n) if i not in held]
            af: list[float] = []
            if free:
                if not up:
                    up = pin.crba(self.model, self.data, q).tolist()
                r = [float(tau[i]) - nle[i] for i in free]
                af = _solve_spd(up, free, r)
            need = [nle[i] + sum((up[i][k] if i <= k else up[k][i]) * ak for k, ak in zip(free, af, strict=True))
                    for i in held]
            worst, excess = -1, 0.0
            for k, i in enumerate(held):
                over = abs(us[i] - need[k]) - ffs[i]
                if over > excess:
                    worst, excess = k, over
            if worst < 0:
                tau[held] = need
                a = [0.0] * n
                for i, ai in zip(free, af, strict=True):
                    a[i] = ai
                return a, held
            i = held.pop(worst)
            tau[i] = us[i] - math.copysign(ffs[i], us[i] - need[worst])

    def _sync(self) -> None:
        """Copy the arm's state into each joint (position, motor speed, time): what they sample."""
        ql = self._q.tolist()
        vl = self._v.tolist()
        for i, j in enumerate(self.joints):
            j.position = ql[i]
            j.speed = vl[i] * j.config.gear_ratio
            j.time = self.time

    def sample(self) -> tuple[list[float], list[float], list[float]]:
        """Positions (rad), velocities (rad/s) and efforts (N·m: the drive torque with noise), joint side,
        in joint order."""
        eff = []
        for j in self.joints:
            k = j._wi
            if k < len(j._white):  # JointSim._noise's next draw, without the call
                j._wi = k + 1
                w = j._white[k]
            else:
                w = j._noise()
            eff.append((j.torque + w) * j.config.torque_scale)
        return self._q.tolist(), self._v.tolist(), eff

    @property
    def positions(self) -> Array:
        """Joint positions, rad (a copy)."""
        return self._q.copy()

    @property
    def velocities(self) -> Array:
        """Joint velocities, rad/s (a copy)."""
        return self._v.copy()


class ArmModel:
    """An arm's rigid-body model as a friction observer uses it (Pinocchio's RNEA on the URDF, armature
    included, :meth:`ArmSim.inverse_dynamics`), for the joints ``joints`` (the arm's first ``len(joints)``):

    - :meth:`gravity` ``(q)``: the gravity torque of the configuration without a payload, N·m joint side;
    - :meth:`rigid_body` ``(q, v, a)``: the whole inverse dynamics with ``payload`` kg at the payload mount;
    - :meth:`payload_rigid_body` ``(q, v, a)``: what 1 kg at the payload mount adds (its gravity and its
      Coriolis/centrifugal and inertial torque), the production observer's payload-aware pairing.

    One :class:`~jointwear_ros.errors.ParameterError` line for an unknown arm, too many joints or a bad payload.

    >>> m = ArmModel("ur5", [f"joint_{i}" for i in range(1, 7)])
    >>> [round(float(x), 1) for x in m.gravity([0.0, -1.2, 1.4, -1.6, -1.57, 0.0])][:3]
    [0.0, -31.3, -15.5]
    """

    def __init__(self, arm: str, joints: Sequence[str], payload: float = 0.0) -> None:
        from .arms import arm_spec

        if not (isinstance(payload, (int, float)) and math.isfinite(payload) and payload >= 0):
            raise ParameterError(f"payload must be a mass >= 0 kg, got {payload!r}")
        spec = arm_spec(arm)
        self.arm = spec.name
        self.joints = [str(j) for j in joints]
        self.payload = float(payload)
        cfgs = arm_configs(spec, self.joints)
        seeds = range(len(self.joints))
        self._bare = ArmSim(spec, self.joints, cfgs, seeds=seeds)
        self._kg = ArmSim(spec, self.joints, cfgs, seeds=seeds, payload=1.0)
        self._loaded = self._bare if self.payload == 0 else ArmSim(spec, self.joints, cfgs, seeds=seeds,
                                                                  payload=self.payload)

    def gravity(self, q: Sequence[float]) -> Array:
        return self._bare.inverse_dynamics(q, [0.0] * len(q))

    def rigid_body(self, q: Sequence[float], v: Sequence[float], a: Sequence[float] | None = None) -> Array:
        return self._loaded.inverse_dynamics(q, v, a)

    def payload_rigid_body(self, q: Sequence[float], v: Sequence[float], a: Sequence[float] | None = None) -> Array:
        return self._kg.inverse_dynamics(q, v, a) - self._bare.inverse_dynamics(q, v, a)

    def observer_models(self, *, payload_mass: float | None = None, model_based: bool = False) -> dict[str, Any]:
        """The keyword arguments of :class:`~jointwear_ros.observer.ProductionObserver` this model gives: the
        gravity and the payload's torque per kg always (pairs whose load differs are corrected, or rejected as
        a load mismatch), ``payload_mass`` (the part's kg when known; None: fitted per pair), and with
        ``model_based`` the inverse dynamics for u - tau_model of passes without a reverse partner."""
        out: dict[str, Any] = {"gravity": self.gravity, "payload_rigid_body": self.payload_rigid_body,
                               "payload_mass": payload_mass}
        if model_based:
            out["rigid_body"] = self.rigid_body
        return out


def _solve_spd(up: list[list[float]], idx: list[int], rhs: list[float]) -> list[float]:
    """``x`` of ``M[idx][:, idx] x = rhs`` for the symmetric positive definite ``M`` whose upper triangle is ``up``
    (Pinocchio's ``crba``), by Cholesky in plain Python (as many unknowns as the arm has joints: seven at most).

    >>> [round(x, 12) for x in _solve_spd([[4.0, 2.0, 9.0], [0.0, 3.0, 9.0], [0.0, 0.0, 9.0]], [0, 1], [8.0, 8.0])]
    [1.0, 2.0]
    """
    m = len(idx)
    if m == 1:
        return [rhs[0] / up[idx[0]][idx[0]]]
    low: list[list[float]] = []  # L, row by row: M_FF = L L^T
    for a in range(m):
        ia = idx[a]
        row: list[float] = []
        for b in range(a):
            ib = idx[b]
            lb = low[b]
            acc = up[ib][ia] if ib <= ia else up[ia][ib]
            for c in range(b):
                acc -= row[c] * lb[c]
            row.append(acc / lb[b])
        d = up[ia][ia]
        for c in range(a):
            d -= row[c] * row[c]
        row.append(math.sqrt(d))
        low.append(row)
    y: list[float] = []
    for a in range(m):  # L y = rhs
        acc = rhs[a]
        row = low[a]
        for c in range(a):
            acc -= row[c] * y[c]
        y.append(acc / row[a])
    x = [0.0] * m
    for a in range(m - 1, -1, -1):  # L^T x = y
        acc = y[a]
        for c in range(a + 1, m):
            acc -= low[c][a] * x[c]
        x[a] = acc / low[a][a]
    return x
