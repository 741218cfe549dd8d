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
- ``armature``: reflected rotor inertia, kg·m² at the joint (rotor inertia × gear²).

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

__all__ = ["ARMS", "ArmJoint", "ArmSpec", "arm_spec", "robots_dir"]


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

    @property
    def torque_scale(self) -> float:
        """N·m per normalized torque unit: half the effort limit (see the module docstring)."""
        return self.effort / 2.0

    @property
    def torque_limit(self) -> float:
        """The effort limit in normalized units (the drive saturates there)."""
        return self.effort / self.torque_scale


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
#: arm 1.3 rad up from horizontal, the forearm folded 1.3 rad, the wrist level: every joint sweeps about
#: ±1.1 rad around it inside the URDF limits, and the shoulder and elbow carry gravity.
UR5 = ArmSpec(
    name="ur5",
    title="Universal Robots UR5",
    urdf="ur_description/urdf/ur5_robot.urdf",
    joints=(
        ArmJoint("shoulder_pan_joint", -_TAU, _TAU, 150.0, 3.15, 0.0, 0.6),
        ArmJoint("shoulder_lift_joint", -_TAU, _TAU, 150.0, 3.15, -1.3, 0.6),
        ArmJoint("elbow_joint", -3.14159, 3.14159, 150.0, 3.15, 1.3, 0.6),
        ArmJoint("wrist_1_joint", -_TAU, _TAU, 28.0, 3.2, -1.57, 0.1),
        ArmJoint("wrist_2_joint", -_TAU, _TAU, 28.0, 3.2, -1.57, 0.1),
        ArmJoint("wrist_3_joint", -_TAU, _TAU, 28.0, 3.2, 0.0, 0.1),
    ),
    payload_joint="wrist_3_joint",
)

#: Franka Emika Panda (example-robot-data ``panda_description/urdf/panda.urdf``), fingers locked open.
#: Test pose: upper arm upright, forearm horizontal (joint 4 at -1.57), wrist bent (joint 6 at 1.87).
PANDA = ArmSpec(
    name="panda",
    title="Franka Emika Panda",
    urdf="panda_description/urdf/panda.urdf",
    joints=(
        ArmJoint("panda_joint1", -2.8973, 2.8973, 87.0, 2.175, 0.0, 0.3),
        ArmJoint("panda_joint2", -1.7628, 1.7628, 87.0, 2.175, 0.0, 0.3),
        ArmJoint("panda_joint3", -2.8973, 2.8973, 87.0, 2.175, 0.0, 0.3),
        ArmJoint("panda_joint4", -3.0718, -0.0698, 87.0, 2.175, -1.57, 0.3),
        ArmJoint("panda_joint5", -2.8973, 2.8973, 12.0, 2.61, 0.0, 0.05),
        ArmJoint("panda_joint6", -0.0175, 3.7525, 12.0, 2.61, 1.87, 0.05),
        ArmJoint("panda_joint7", -2.8973, 2.8973, 12.0, 2.61, 0.785, 0.05),
    ),
    locked=(("panda_finger_joint1", 0.04), ("panda_finger_joint2", 0.04)),
    payload_joint="panda_joint7",
    payload_offset=(0.0, 0.0, 0.15),
)

#: The arms by name (the ``arm`` parameter of ``joint_sim``; ``jointwear demo --arm``).
ARMS: dict[str, ArmSpec] = {a.name: a for a in (UR5, PANDA)}


def arm_spec(name: str) -> ArmSpec:
    """The arm called ``name`` (a one-line :class:`ParameterError` naming the known arms)."""
    try:
        return ARMS[str(name).strip().lower()]
    except KeyError:
        raise ParameterError(f"unknown arm {name!r}; known arms: {', '.join(ARMS)}") from None
