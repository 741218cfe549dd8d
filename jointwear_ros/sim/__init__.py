"""Simulated joint dynamics (pure: numpy and the model core, no ROS).

:class:`JointSim` is a robot joint behind a velocity PI controller, with
inertia, gravity, the full friction model (wear, temperature, optional hidden
effects) and torque noise designed so that friction observations scatter like
the paper's ``sigma_e``. :class:`RobotSim` runs N of them on one clock behind
one command array. The ``joint_sim`` node wraps it.
"""

from __future__ import annotations

from .friction import FrictionTable
from .joint import JointSample, JointSim, JointSimConfig, parse_effects
from .robot import RobotSim

__all__ = ["FrictionTable", "JointSample", "JointSim", "JointSimConfig", "RobotSim", "parse_effects"]
