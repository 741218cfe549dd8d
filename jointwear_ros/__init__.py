"""jointwear: robot-joint wear diagnosis from static friction (ROS 2 Jazzy).

The scientific core (``model``, and later identification and estimators) is
plain numpy/scipy; ROS nodes, bag IO and the CLI wrap it.
"""

__version__ = "0.1.0"
