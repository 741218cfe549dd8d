"""A simulated robot joint behind a velocity controller: dynamics, PI loop, noise.

Units: the dynamics run on the **motor side** in the model's units (speed rad/s,
torque normalized); :meth:`JointSim.sample` converts to what a ``JointState``
carries (joint side: position rad, velocity rad/s, effort N·m) with
``gear_ratio`` and ``torque_scale``.

Dynamics (motor side)::

    J * dv/dt = u - tau_g(phi) - sign(v) * (tau_f(|v|, |tau_g|, phi, t) + o_k)
    tau_g(phi) = g * cos(phi - phi_g)                       (gravity, normalized)
    u = sat(Kp * (v_ref - v) + Ki * integral(v_ref - v))    (velocity PI, anti-windup)
    v_ref follows the command with at most accel_limit         (drive reference ramp)
    dphi/dt = v / gear_ratio                                (joint position)

``tau_f`` is the full friction model (:class:`~jointwear_ros.sim.friction.FrictionTable`:
``ref-2011r`` + wear + temperature + optional hidden effects). Near ``v = 0`` a
Karnopp stick band holds the joint still while ``|u - tau_g|`` is below the
breakaway friction, so the direction of friction never chatters. The integrator
is semi-implicit Euler (velocity first, then position with the new velocity),
stable with the default gains from 200 Hz up (``Kp * dt / J`` = 0.2 at 500 Hz).

Noise design (so that observations ``tau_f = (u+ - u-) / 2`` scatter like the
paper's ``sigma_e = 0.0015``):

- a **per-sweep friction offset** ``o_k ~ N(0, 2 sigma_e^2)``, drawn each time the
  commanded velocity leaves zero or changes sign (each sweep in each direction).
  It acts on the dynamics like real friction variation, the PI loop absorbs it
  and it appears in ``u``. ``(u+ - u-)/2`` averages two independent offsets,
  so its standard deviation is ``sqrt(2 sigma_e^2 / 2) = sigma_e``;
- **white torque-measurement noise** ``n ~ N(0, sigma_w^2)`` on each published
  effort sample (default ``sigma_w`` = 0.003). Averaged over ``N`` samples per
  window it adds ``sigma_w^2 / (2 N)`` to the variance of ``tau_f``: 1.6 % of
  ``sigma_e`` at N = 60 (160 rad/s at 500 Hz), less at lower speeds or 2 kHz.

Pure Python per step (a few microseconds), numpy for tables and noise blocks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..data.synth import HIDDEN_EFFECTS
from ..errors import ParameterError
from ..settings import check_ranges, setting
from .friction import FrictionTable

__all__ = ["JointSample", "JointSim", "JointSimConfig", "command_all", "parse_effects"]


def parse_effects(text: Any) -> tuple[str, ...]:
    """``"ripple, load_viscous"`` -> ``("ripple", "load_viscous")``, checking each name (the
    ``hidden_effects`` parameter; a list or tuple of names is taken as it is)."""
    parts = [str(s) for s in text] if isinstance(text, (list, tuple)) else str(text).replace(";", ",").split(",")
    names = tuple(s.strip() for s in parts if s.strip())
    unknown = [n for n in names if n not in HIDDEN_EFFECTS]
    if unknown:
        raise ParameterError(
            f"joint_sim: unknown hidden effect(s) {', '.join(unknown)} in hidden_effects={text!r}; "
            f"known: {', '.join(HIDDEN_EFFECTS)}"
        )
    return names


def command_all(joints: Sequence[JointSim], names: Sequence[str], velocities: Sequence[float],
                owner: str = "the robot", kind: str = "joint") -> None:
    """Set each joint's velocity command (joint rad/s, joint order); all or none: a wrong length or a
    non-finite entry raises :class:`ParameterError` and changes nothing (the robot's and the arm's
    ``set_commands``; ``owner`` and ``kind`` name them in the message)."""
    v = [float(x) for x in velocities]
    if len(v) != len(joints):
        raise ParameterError(f"command has {len(v)} value(s), {owner} has {len(joints)} {kind}(s) "
                             f"({', '.join(names)})")
    bad = [f"data[{i}] = {x}" for i, x in enumerate(v) if not math.isfinite(x)]
    if bad:
        raise ParameterError(f"command not finite: {', '.join(bad)}")
    for j, x in zip(joints, v, strict=True):
        j.set_command(x)


@dataclass(frozen=True)
class JointSimConfig:
    """Parameters of the simulated joint (defaults: the project's shared defaults).

    A field declared with :func:`~jointwear_ros.settings.setting` is also a per-joint parameter of the
    ``joint_sim`` node (description, unit, range and read-only flag in its field metadata); ``model``
    and ``stick_speed`` are not parameters.

    Attributes
    ----------
    gear_ratio
        Motor speed / joint speed.
    torque_scale
        N·m (joint side) per normalized torque unit.
    inertia
        Motor-side inertia, normalized torque per (rad/s^2).
    gravity_torque
        Gravity amplitude ``g`` (normalized); ``tau_g = g cos(phi - gravity_angle)``,
        so ``tau_m`` is about ``g`` near ``phi = gravity_angle``.
    gravity_angle
        Joint angle (rad) of the largest gravity torque.
    params, model, temperature, wear, hidden_effects, lube_hours
        The friction model (see :class:`FrictionTable`).
    kp, ki
        Velocity PI gains (normalized torque per rad/s, per rad).
    torque_limit
        Saturation of the applied torque, normalized.
    noise_std
        Target scatter ``sigma_e`` of ``tau_f = (u+ - u-)/2``; the per-sweep offset
        has standard deviation ``sqrt(2) * noise_std``.
    effort_noise_std
        White noise on each effort sample, normalized.
    stick_speed
        Half width of the stick band around ``v = 0``, motor rad/s.
    initial_position
        Joint position at start, rad.
    accel_limit
        The drive's reference acceleration limit, joint rad/s^2: the velocity
        reference follows the command at most this fast, so a command that
        arrives in steps (a stream at 50-100 Hz, a late message) does not
        kick the torque. 0 disables it.
    """

    gear_ratio: float = setting(100.0, description="motor speed / joint speed", range=(1e-3, 1e6), per_joint=True,
                                read_only=True)
    torque_scale: float = setting(200.0, description="N·m (joint side) per normalized torque unit", unit="N·m",
                                  range=(1e-6, 1e9), per_joint=True, read_only=True)
    inertia: float = setting(5.0e-4, description="motor-side inertia, normalized torque per rad/s^2",
                             range=(1e-9, 1e3), per_joint=True)
    gravity_torque: float = setting(0.1, description="gravity amplitude g (normalized): tau_g = g cos(phi - "
                                    "gravity_angle)", range=(-10.0, 10.0), per_joint=True)
    gravity_angle: float = setting(0.0, description="joint angle of the largest gravity torque, rad", unit="rad",
                                   range=(-10.0, 10.0), per_joint=True)
    params: str = setting("ref-2011r", description="friction parameter set: a name or a YAML path", per_joint=True,
                          read_only=True)
    model: str = "paper+wear"
    temperature: float = setting(40.0, description="joint temperature, degC", unit="degC", range=(-50.0, 200.0),
                                 per_joint=True)
    wear: float = setting(0.0, description="true wear level 0-100", range=(0.0, 100.0), per_joint=True)
    hidden_effects: tuple[str, ...] = setting(
        (), description="comma-separated hidden friction effects: " + ", ".join(HIDDEN_EFFECTS), per_joint=True,
        parse=parse_effects, param_default="")
    lube_hours: float = setting(0.0, description="hours since lubrication (lubrication effect)", unit="h",
                                range=(0.0, 1e6), per_joint=True)
    kp: float = setting(0.05, description="velocity PI proportional gain, normalized torque per motor rad/s",
                        range=(0.0, 1e3), per_joint=True)
    ki: float = setting(1.0, description="velocity PI integral gain, normalized torque per motor rad",
                        range=(0.0, 1e6), per_joint=True)
    torque_limit: float = setting(1.0, description="saturation of the applied torque, normalized",
                                  range=(1e-6, 1e3), per_joint=True)
    noise_std: float = setting(0.0015, description="target scatter sigma_e of (u+ - u-)/2, normalized",
                               range=(0.0, 1.0), per_joint=True)
    effort_noise_std: float = setting(0.003, description="white noise on each effort sample, normalized",
                                      range=(0.0, 1.0), per_joint=True)
    stick_speed: float = 0.05
    initial_position: float = setting(0.0, description="joint position at start, rad", unit="rad",
                                      range=(-100.0, 100.0), per_joint=True, read_only=True)
    accel_limit: float = setting(8.0, description="reference acceleration limit of the drive, joint rad/s^2 "
                                 "(0: none)", unit="rad/s^2", range=(0.0, 1e6), per_joint=True)

    def check(self) -> None:
        """Raise :class:`ParameterError` on a value the simulator cannot run with."""
        check_ranges(self, ParameterError, "joint sim:")
        if not (math.isfinite(self.stick_speed) and self.stick_speed > 0):  # not a parameter
            raise ParameterError(f"joint sim: stick_speed must be finite and > 0, got {self.stick_speed}")


@dataclass(frozen=True)
class JointSample:
    """One simulated sample, in JointState units (joint side, N·m)."""

    time: float
    position: float
    velocity: float
    effort: float


class JointSim:
    """The simulated joint. Feed a velocity command, step at a fixed rate, read samples.

    Parameters
    ----------
    config
        :class:`JointSimConfig`.
    rng, seed
        Random generator for the noise, or the seed of a new one (``rng`` wins).
    friction
        A prebuilt :class:`FrictionTable` (built from ``config`` when omitted).
    """

    _BLOCK = 4096

    def __init__(
        self,
        config: JointSimConfig | None = None,
        *,
        rng: np.random.Generator | None = None,
        seed: int | None = 0,
        friction: FrictionTable | None = None,
    ) -> None:
        self.config = cfg = config if config is not None else JointSimConfig()
        cfg.check()
        self.rng = rng if rng is not None else np.random.default_rng(seed)
        self.friction = friction if friction is not None else FrictionTable(
            cfg.params,
            cfg.model,
            temperature=cfg.temperature,
            wear=cfg.wear,
            hidden_effects=cfg.hidden_effects,
            lube_hours=cfg.lube_hours,
            gear_ratio=cfg.gear_ratio,
            torque_scale=cfg.torque_scale,
        )
        self.time = 0.0
        self.position = float(cfg.initial_position)  # joint side, rad
        self.speed = 0.0  # motor side, rad/s (signed)
        self.torque = 0.0  # applied u, normalized
        self._integral = 0.0
        self.command = 0.0  # joint side, rad/s
        self.reference = 0.0  # velocity reference of the PI loop, motor side, rad/s
        self._cmd_sign = 0
        self.offset = 0.0
        self._offset_std = math.sqrt(2.0) * cfg.noise_std
        self._white: list[float] = []
        self._wi = 0
        self.sweeps = 0

    def reconfigure(self, config: JointSimConfig) -> None:
        """Apply new settings now, keeping the state (position, speed, integrator, time).

        The friction table is rebuilt when a friction setting changed (wear,
        temperature, hidden effects, ...): a live change of the simulated wear.
        ``gear_ratio``, ``torque_scale``, ``params``, ``model`` and
        ``initial_position`` define the joint and cannot change on a running
        simulation (:class:`ParameterError`).
        """
        config.check()
        old = self.config
        fixed = ("gear_ratio", "torque_scale", "params", "model", "initial_position")
        changed = [n for n in fixed if getattr(config, n) != getattr(old, n)]
        if changed:
            raise ParameterError(
                f"joint sim: {', '.join(changed)} cannot change on a running simulation; restart it with the new value"
            )
        friction = ("temperature", "wear", "hidden_effects", "lube_hours")
        if any(getattr(config, n) != getattr(old, n) for n in friction):
            self.friction = FrictionTable(config.params, config.model, temperature=config.temperature, wear=config.wear,
                                          gear_ratio=config.gear_ratio, torque_scale=config.torque_scale,
                                          hidden_effects=config.hidden_effects, lube_hours=config.lube_hours)
        self.config = config
        self._offset_std = math.sqrt(2.0) * config.noise_std
        if config.effort_noise_std != old.effort_noise_std:
            self._white, self._wi = [], 0

    # -- inputs --------------------------------------------------------------
    def set_command(self, velocity: float) -> None:
        """Set the velocity command, joint side rad/s (non-finite values are refused)."""
        if not math.isfinite(velocity):
            raise ParameterError(f"velocity command must be finite, got {velocity}")
        sign = 0 if abs(velocity) < 1e-9 else (1 if velocity > 0 else -1)
        if sign != 0 and sign != self._cmd_sign:
            # a new sweep: the friction offset of this motion
            self.offset = float(self.rng.normal(0.0, self._offset_std)) if self._offset_std > 0 else 0.0
            self.sweeps += 1
        self._cmd_sign = sign
        self.command = float(velocity)

    # -- physics -------------------------------------------------------------
    def gravity(self, position: float) -> float:
        """Gravity torque at a joint position, normalized."""
        return self.config.gravity_torque * math.cos(position - self.config.gravity_angle)

    def step(self, dt: float) -> None:
        """Advance one fixed step of ``dt`` seconds (semi-implicit Euler)."""
        cfg = self.config
        v = self.speed
        target = self.command * cfg.gear_ratio
        ref = self.reference
        if cfg.accel_limit > 0.0 and ref != target:
            dmax = cfg.accel_limit * cfg.gear_ratio * dt
            ref = min(target, ref + dmax) if target > ref else max(target, ref - dmax)
        else:
            ref = target
        self.reference = ref
        e = ref - v
        u_raw = cfg.kp * e + self._integral
        lim = cfg.torque_limit
        u = lim if u_raw > lim else (-lim if u_raw < -lim else u_raw)
        if u == u_raw or (u_raw > lim and e < 0.0) or (u_raw < -lim and e > 0.0):
            self._integral += cfg.ki * e * dt
        tg = cfg.gravity_torque * math.cos(self.position - cfg.gravity_angle)
        ff = self.friction(v, tg, self.position, self.time) + self.offset
        if ff < 0.0:
            ff = 0.0
        net = u - tg
        inv_j = dt / cfg.inertia
        if abs(v) < cfg.stick_speed:
            if abs(net) <= ff:
                v_new = 0.0
            else:
                v_new = v + (net - math.copysign(ff, net)) * inv_j
        else:
            v_new = v + (net - math.copysign(ff, v)) * inv_j
            if v_new * v < 0.0 and abs(net) <= ff:
                v_new = 0.0
        self.speed = v_new
        self.position += v_new / cfg.gear_ratio * dt
        self.torque = u
        self.time += dt

    def _noise(self) -> float:
        if self._wi >= len(self._white):
            sd = self.config.effort_noise_std
            self._white = self.rng.normal(0.0, sd, self._BLOCK).tolist() if sd > 0 else [0.0] * self._BLOCK
            self._wi = 0
        n = self._white[self._wi]
        self._wi += 1
        return n

    def sample(self) -> JointSample:
        """The current state in JointState units, with effort measurement noise."""
        cfg = self.config
        return JointSample(
            self.time,
            self.position,
            self.speed / cfg.gear_ratio,
            (self.torque + self._noise()) * cfg.torque_scale,
        )

    def run(self, n_steps: int, dt: float) -> tuple[list[float], list[float], list[float], list[float]]:
        """Step ``n_steps`` times; return the sampled (time, position, velocity, effort) after each step."""
        cfg = self.config
        ts: list[float] = []
        ps: list[float] = []
        vs: list[float] = []
        es: list[float] = []
        g = cfg.gear_ratio
        s = cfg.torque_scale
        for _ in range(int(n_steps)):
            self.step(dt)
            ts.append(self.time)
            ps.append(self.position)
            vs.append(self.speed / g)
            es.append((self.torque + self._noise()) * s)
        return ts, ps, vs, es

    def true_friction(self, speed: float | Sequence[float], position: float | None = None) -> float:
        """Noise-free model friction at a motor speed and joint position (at the current time)."""
        pos = self.position if position is None else float(position)
        sp = float(np.asarray(speed, dtype=float).reshape(-1)[0])
        return float(self.friction.exact(np.array([sp]), abs(self.gravity(pos)), pos, self.time)[0])
