"""Simulated joint dynamics (pure: numpy and the model core, no ROS).

:class:`JointSim` is a robot joint behind a velocity PI controller, with
inertia, gravity, the full friction model (wear, temperature, optional hidden
effects) and torque noise designed so that friction observations scatter like
the paper's ``sigma_e``. :class:`RobotSim` runs N of them on one clock behind
one command array. :class:`ArmSim` is a real arm (:mod:`.arms`: a UR5, a Panda)
with the same interface: Pinocchio's rigid-body dynamics of its URDF, every
joint driven as a JointSim is. The ``joint_sim`` node wraps either.
:class:`CollisionChecker` (:mod:`.collision`) is an arm's self-collision and table
check from its URDF's collision meshes; :func:`check_plan` checks a planned test
cycle with it before anything moves.

Importing the package does not import Pinocchio: :class:`ArmSim`,
:class:`ArmJointSim` and :func:`arm_configs` load :mod:`.arm`, and
:class:`CollisionChecker`, :func:`collision_checker` and :func:`check_plan`
load :mod:`.collision`, and the simulated production (:func:`run_production`, its programs: :mod:`.production`)
loads its module, on first use (PEP 562).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_names
from .arms import ARMS, ArmJoint, ArmSpec, arm_spec
from .friction import FrictionTable
from .joint import JointSample, JointSim, JointSimConfig, parse_effects
from .robot import RobotSim

if TYPE_CHECKING:  # what __getattr__ loads on first use, for type checkers and readers
    from .arm import ArmJointSim, ArmModel, ArmSim, arm_configs
    from .collision import CollisionChecker, check_plan, collision_checker
    from .production import (
        Move,
        ProductionProgram,
        ProductionRun,
        SelfHeating,
        check_program,
        machine_tending,
        pick_and_place,
        production_program,
        run_production,
    )

__all__ = ["ARMS", "ArmJoint", "ArmJointSim", "ArmModel", "ArmSim", "ArmSpec", "CollisionChecker", "FrictionTable", "JointSample",
           "JointSim", "JointSimConfig", "Move", "ProductionProgram", "ProductionRun", "RobotSim", "SelfHeating",
           "arm_configs", "arm_spec", "check_plan", "check_program", "collision_checker", "machine_tending",
           "parse_effects", "pick_and_place", "production_program", "run_production"]

#: The module of each name loaded on first use (each imports pinocchio).
_LAZY: dict[str, str] = {**dict.fromkeys(("ArmJointSim", "ArmModel", "ArmSim", "arm_configs"), "arm"),
                         **dict.fromkeys(("CollisionChecker", "check_plan", "collision_checker"), "collision"),
                 **dict.fromkeys(("Move", "ProductionProgram", "ProductionRun", "SelfHeating", "check_program",
                                  "machine_tending", "pick_and_place", "production_program", "run_production"),
                                 "production")}

__getattr__, __dir__ = lazy_names(__name__, _LAZY, globals())
