"""The real arms the suite simulates: their joints, limits, test poses and drive sizing (pure data).

An :class:`ArmSpec` names a URDF of ``example-robot-data`` (BSD-3, installed as a wheel; the
rigid-body dynamics are Pinocchio's, :mod:`jointwear_ros.sim.arm`) and carries, per actuated joint,
what the URDF says (effort, velocity and position limits) and what the suite chooses for it:

- ``home``: the window centre of the joint's test sweep (the test pose), inside the URDF limits;
- ``gear_ratio``: motor speed / joint speed of the drive (harmonic drives of this class: about 100);
- ``torque_scale``: N·m at the joint per normalized torque unit of the friction model, ``effort / 2``:
  the reference set's Coulomb level (0.075 normalized at 40 degC, 0.08-0.16 over 10-280 rad/s motor
  side) is then about 4 % of the joint's effort limit (6-12 % at the top speed), the order the issue
  gives for published identifications of UR and Panda joints;
- ``armature``: reflected rotor inertia, kg·m² at the joint (rotor inertia × gear²);
- ``inertia``: the joint's nominal inertia, kg·m² at the joint (armature included): the geometric mean
  of the smallest and largest diagonal entry ``M(q)_jj`` of Pinocchio's mass matrix over the test
  windows (every joint within ±1.1 rad of ``home``, inside the URDF limits) and payloads 0-5 kg
  (``test/test_sim_arm.py`` checks it against the model). The drive's velocity PI gains
  (:attr:`ArmJoint.kp`, :attr:`ArmJoint.ki`) are sized from it: a critically damped loop of
  bandwidth :data:`LOOP_BANDWIDTH` at the nominal inertia (joint side ``Kp = 2 ω J``,
  ``Ki = ω² J``), so over the windows' inertia range (a factor 3-4 either way on the base
  joints) the loop stays stable at 1 kHz (``Kp dt / M_jj`` <= 0.8) and at least half critically
  damped.

The suite's joint names (``joint_1`` ...) map onto the arm's joints in order: the i-th name of a
node's ``joints`` drives the i-th joint of the arm. No URDF is read here (no Pinocchio import):
:func:`ArmSpec.urdf_path` only locates the file.

>>> ur5 = arm_spec("ur5")
>>> [j.name for j in ur5.joints][:2], ur5.joints[0].torque_scale, ur5.joints[3].torque_scale
(['shoulder_pan_joint', 'shoulder_lift_joint'], 75.0, 14.0)
>>> arm_spec("kuka")
Traceback (most recent call last):
...
jointwear_ros.errors.ParameterError: unknown arm 'kuka'; known arms: ur5, panda
"""

from __future__ import annotations

import sysconfig
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import ParameterError

__all__ = ["ARMS", "ARM_DEFAULTS", "LOOP_BANDWIDTH", "ArmJoint", "ArmSpec", "arm_spec", "robots_dir"]

#: Bandwidth of each joint's velocity loop at its nominal inertia, rad/s (critically damped there).
LOOP_BANDWIDTH = 100.0

#: The joint-simulation settings (fields of :class:`~jointwear_ros.sim.JointSimConfig`) an arm gives each
#: of its joints by default (:meth:`ArmJoint.sim_defaults`): its drive, its test pose and its loop gains.
ARM_DEFAULTS = ("gear_ratio", "torque_scale", "initial_position", "kp", "ki", "torque_limit")


@dataclass(frozen=True)
class ArmJoint:
    """One actuated joint of an arm (URDF values and the suite's choices, joint side)."""

    name: str  #: the URDF joint name
    lower: float  #: URDF position limit, rad
    upper: float  #: URDF position limit, rad
    effort: float  #: URDF effort limit, N·m
    velocity: float  #: URDF velocity limit, rad/s
    home: float  #: test pose (window centre), rad
    armature: float  #: reflected rotor inertia, kg·m²
    gear_ratio: float = 100.0
    inertia: float = 1.0  #: nominal joint-side inertia incl. armature, kg·m² (sizes the loop gains)

    @property
    def torque_scale(self) -> float:
        """N·m per normalized torque unit: half the effort limit (see the module docstring)."""
        return self.effort / 2.0

    @property
    def torque_limit(self) -> float:
        """The effort limit in normalized units (the drive saturates there)."""
        return self.effort / self.torque_scale

    @property
    def kp(self) -> float:
        """Velocity-loop proportional gain, normalized torque per motor rad/s: ``2 ω J`` N·m per joint rad/s."""
        return 2.0 * LOOP_BANDWIDTH * self.inertia / (self.gear_ratio * self.torque_scale)

    @property
    def ki(self) -> float:
        """Velocity-loop integral gain, normalized torque per motor rad: ``ω² J`` N·m per joint rad."""
        return LOOP_BANDWIDTH**2 * self.inertia / (self.gear_ratio * self.torque_scale)

    def sim_defaults(self) -> dict[str, float]:
        """The joint-simulation settings this joint gives by default (:data:`ARM_DEFAULTS`, by name)."""
        return {"gear_ratio": self.gear_ratio, "torque_scale": self.torque_scale, "initial_position": self.home,
                "kp": self.kp, "ki": self.ki, "torque_limit": self.torque_limit}


@dataclass(frozen=True)
class ArmSpec:
    """A simulated arm: its URDF (relative to example-robot-data's ``robots/``), joints and payload mount."""

    name: str
    title: str
    urdf: str
    joints: tuple[ArmJoint, ...]
    #: joints of the URDF that the arm sim locks (fingers), name -> position
    locked: tuple[tuple[str, float], ...] = ()
    #: the joint whose body carries the payload, and the payload's centre in that body's frame, m
    payload_joint: str = ""
    payload_offset: tuple[float, float, float] = (0.0, 0.0, 0.05)
    #: the SRDF beside the URDF (relative to ``robots/``): the link pairs that never meet (collision check)
    srdf: str = ""

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def urdf_path(self) -> Path:
        """The URDF file (a one-line :class:`ParameterError` naming the wheel when it is missing)."""
        path = robots_dir() / self.urdf
        if not path.is_file():
            raise ParameterError(f"arm {self.name}: URDF {path} not found; install example-robot-data "
                                 "(pip install example-robot-data, in requirements.txt)")
        return path

    def srdf_path(self) -> Path | None:
        """The SRDF file (None when the arm names none; a one-line :class:`ParameterError` when it is missing)."""
        if not self.srdf:
            return None
        path = robots_dir() / self.srdf
        if not path.is_file():
            raise ParameterError(f"arm {self.name}: SRDF {path} not found; install example-robot-data "
                                 "(pip install example-robot-data, in requirements.txt)")
        return path

    def for_names(self, names: Sequence[str]) -> tuple[ArmJoint, ...]:
        """The arm joints the suite's ``names`` drive (the i-th name: the i-th joint)."""
        if len(names) > len(self.joints):
            raise ParameterError(f"arm {self.name} has {len(self.joints)} joints ({', '.join(self.names)}); "
                                 f"{len(names)} joint names given ({', '.join(names)})")
        return self.joints[: len(names)]


def robots_dir() -> Path:
    """example-robot-data's ``robots/`` folder in this environment (it may not exist)."""
    return Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


_TAU = 6.283185307179586

#: Universal Robots UR5 (example-robot-data ``ur_description/urdf/ur5_robot.urdf``). Test pose: the upper
#: arm 1.3 rad up from horizontal, the forearm 1.0 rad up (elbow 0.3), the wrist pitched 0.7 rad forward:
#: every joint sweeps about ±1.1 rad around it inside the URDF limits, one after another clear of the arm
#: and the table (:mod:`jointwear_ros.sim.collision`, 1 cm; the forearm level, elbow 1.3, took the wrist into
#: the table), and the shoulder and elbow carry gravity (20 and 8.5 N·m; 3 kg at the flange: 10.8 and 7.5).
UR5 = ArmSpec(
    name="ur5",
    title="Universal Robots UR5",
    urdf="ur_description/urdf/ur5_robot.urdf",
    joints=(
        ArmJoint("shoulder_pan_joint", -_TAU, _TAU, 150.0, 3.15, 0.0, 0.6, inertia=3.1),
        ArmJoint("shoulder_lift_joint", -_TAU, _TAU, 150.0, 3.15, -1.3, 0.6, inertia=4.5),
        ArmJoint("elbow_joint", -3.14159, 3.14159, 150.0, 3.15, 0.3, 0.6, inertia=2.0),
        ArmJoint("wrist_1_joint", -_TAU, _TAU, 28.0, 3.2, 0.7, 0.1, inertia=0.39),
        ArmJoint("wrist_2_joint", -_TAU, _TAU, 28.0, 3.2, 0.0, 0.1, inertia=0.35),
        ArmJoint("wrist_3_joint", -_TAU, _TAU, 28.0, 3.2, 0.0, 0.1, inertia=0.12),
    ),
    payload_joint="wrist_3_joint",
    srdf="ur_description/srdf/ur5.srdf",
)

#: Franka Emika Panda (example-robot-data ``panda_description/urdf/panda.urdf``), fingers locked open.
#: Test pose: upper arm 0.3 rad back from upright, forearm near horizontal (joint 4 at -1.65), wrist bent
#: (joint 6 at 2.5): each sweep clear of the arm and the table (with the upper arm upright and joint 6 at 1.87
#: the fingers reached the table leaning forward), the shoulder and elbow loaded (17.8 and 20.5 N·m).
PANDA = ArmSpec(
    name="panda",
    title="Franka Emika Panda",
    urdf="panda_description/urdf/panda.urdf",
    joints=(
        ArmJoint("panda_joint1", -2.8973, 2.8973, 87.0, 2.175, 0.0, 0.3, inertia=1.8),
        ArmJoint("panda_joint2", -1.7628, 1.7628, 87.0, 2.175, -0.3, 0.3, inertia=2.8),
        ArmJoint("panda_joint3", -2.8973, 2.8973, 87.0, 2.175, 0.0, 0.3, inertia=1.4),
        ArmJoint("panda_joint4", -3.0718, -0.0698, 87.0, 2.175, -1.65, 0.3, inertia=1.8),
        ArmJoint("panda_joint5", -2.8973, 2.8973, 12.0, 2.61, 0.0, 0.05, inertia=0.14),
        ArmJoint("panda_joint6", -0.0175, 3.7525, 12.0, 2.61, 2.5, 0.05, inertia=0.16),
        ArmJoint("panda_joint7", -2.8973, 2.8973, 12.0, 2.61, 0.785, 0.05, inertia=0.057),
    ),
    locked=(("panda_finger_joint1", 0.04), ("panda_finger_joint2", 0.04)),
    payload_joint="panda_joint7",
    payload_offset=(0.0, 0.0, 0.15),
    srdf="panda_description/srdf/panda.srdf",
)

#: The arms by name (the ``arm`` parameter of ``joint_sim``; ``jointwear demo --arm``).
ARMS: dict[str, ArmSpec] = {a.name: a for a in (UR5, PANDA)}


def arm_spec(name: str) -> ArmSpec:
    """The arm called ``name`` (a one-line :class:`ParameterError` naming the known arms)."""
    try:
        return ARMS[str(name).strip().lower()]
    except KeyError:
        raise ParameterError(f"unknown arm {name!r}; known arms: {', '.join(ARMS)}") from None
