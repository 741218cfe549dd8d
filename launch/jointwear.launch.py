"""Launch the jointwear node suite: ``ros2 launch jointwear_ros jointwear.launch.py [arg:=value ...]``.

Starts ``test_cycle``, ``friction_observer``, ``wear_estimator``, ``wear_trend`` (``trend``), optionally
``joint_sim`` (``sim``) and ``recorder`` (``record``), each with its
parameters from the installed ``share/jointwear_ros/config/<node>.yaml`` (or
``config_dir``), then the launch arguments on top.

Simulated cell (default)::

    ros2 launch jointwear_ros jointwear.launch.py wear:=40

Real cell (a JointGroupVelocityController named ``velocity_controller`` is
active; see docs/nodes-bag-demo.md, "On a real cell")::

    ros2 launch jointwear_ros jointwear.launch.py sim:=false motion_enabled:=true \\
        controller:=velocity_controller config_dir:=/etc/jointwear

The joints come from the YAMLs' ``joints`` lists (six in the shipped configs; per-joint settings
nested under each name, see docs/robot.md); ``joint_name`` applies where a YAML's ``joints``
is empty (a one-joint cell).

Then trigger a cycle with ``ros2 service call /test_cycle/run
jointwear_msgs/srv/RunTestCycle "{...}"``.
"""

from __future__ import annotations

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, LogInfo
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

from launch import LaunchDescription

PACKAGE = "jointwear_ros"

#: (launch argument, default, description)
ARGUMENTS: list[tuple[str, object, str]] = [
    ("sim", "true", "start joint_sim, the simulated joint (false on a real cell)"),
    ("use_sim_time", LaunchConfiguration("sim"),
     "nodes follow /clock (default: as sim; joint_sim then publishes /clock)"),
    ("record", "true", "start the recorder (every topic into an MCAP bag)"),
    ("bag_dir", "bags", "directory the recorder creates its bags under"),
    ("motion_enabled", "false", "allow test_cycle to move a real joint (not needed with sim:=true)"),
    ("joint_name", "joint_1", "the joint under test, as named in the joint states, where the YAML's joints list "
     "is empty (a one-joint cell; a robot's joints come from the YAMLs' joints)"),
    ("controller", "velocity_controller", "name of the JointGroupVelocityController / forward_command_controller"),
    ("commands_topic", ["/", LaunchConfiguration("controller"), "/commands"],
     "velocity command topic (std_msgs/Float64MultiArray); default /<controller>/commands"),
    ("joint_states_topic", "/joint_states", "sensor_msgs/JointState topic of the joint"),
    ("wear", "0.0", "true wear of the simulated joint, 0-100 (sim only)"),
    ("real_time_factor", "1.0", "sim seconds per wall second (sim only)"),
    ("trend", "true", "start wear_trend (history store, trend, time to alarm)"),
    ("robot", "robot_1", "robot name in the wear history"),
    ("db_url", "wear_history.db", "wear history store: SQLite file path or postgresql://user@host/db"),
    ("config_dir", None,  # default: share/jointwear_ros/config, looked up when the launch runs
     "directory holding joint_sim.yaml, test_cycle.yaml, friction_observer.yaml, wear_estimator.yaml, recorder.yaml, "
     "wear_trend.yaml"),
]


def _config(node: str) -> PathJoinSubstitution:
    return PathJoinSubstitution([LaunchConfiguration("config_dir"), node + ".yaml"])


def _flag(name: str) -> ParameterValue:
    return ParameterValue(LaunchConfiguration(name), value_type=bool)


def generate_launch_description() -> LaunchDescription:
    """The six nodes with their YAML parameters and the launch arguments' overrides."""
    share_config = os.path.join(get_package_share_directory(PACKAGE), "config")
    args = [DeclareLaunchArgument(name, default_value=share_config if default is None else default, description=desc)
            for name, default, desc in ARGUMENTS]
    sim_time = _flag("use_sim_time")
    joint = LaunchConfiguration("joint_name")
    commands = LaunchConfiguration("commands_topic")
    states = LaunchConfiguration("joint_states_topic")
    nodes = [
        Node(
            package=PACKAGE, executable="joint_sim", name="joint_sim", output="screen",
            condition=IfCondition(LaunchConfiguration("sim")),
            parameters=[_config("joint_sim"), {
                # the simulator is the clock source: it runs on wall time and publishes /clock
                "use_sim_time": False,
                "publish_clock": sim_time,
                "real_time_factor": ParameterValue(LaunchConfiguration("real_time_factor"), value_type=float),
                "wear": ParameterValue(LaunchConfiguration("wear"), value_type=float),
                "joint_name": joint,
                "command_topic": commands,
            }],
            remappings=[("/joint_states", states)],
        ),
        Node(
            package=PACKAGE, executable="test_cycle", name="test_cycle", output="screen",
            parameters=[_config("test_cycle"), {
                "use_sim_time": sim_time,
                "simulator": _flag("sim"),
                "motion_enabled": _flag("motion_enabled"),
                "joint_name": joint,
                "command_topic": commands,
                "joint_states_topic": states,
            }],
        ),
        Node(
            package=PACKAGE, executable="friction_observer", name="friction_observer", output="screen",
            parameters=[_config("friction_observer"), {
                "use_sim_time": sim_time, "joint_name": joint, "joint_states_topic": states,
            }],
        ),
        Node(
            package=PACKAGE, executable="wear_estimator", name="wear_estimator", output="screen",
            parameters=[_config("wear_estimator"), {"use_sim_time": sim_time, "joint_name": joint}],
        ),
        Node(
            package=PACKAGE, executable="wear_trend", name="wear_trend", output="screen",
            condition=IfCondition(LaunchConfiguration("trend")),
            parameters=[_config("wear_trend"), {
                "use_sim_time": sim_time, "robot": LaunchConfiguration("robot"),
                "db_url": LaunchConfiguration("db_url"),
            }],
        ),
        Node(
            package=PACKAGE, executable="recorder", name="recorder", output="screen",
            condition=IfCondition(LaunchConfiguration("record")),
            parameters=[_config("recorder"), {"use_sim_time": sim_time, "output_dir": LaunchConfiguration("bag_dir")}],
        ),
    ]
    note = LogInfo(msg=["jointwear: sim=", LaunchConfiguration("sim"), " use_sim_time=",
                        LaunchConfiguration("use_sim_time"), " commands=", commands, " joint_states=", states])
    return LaunchDescription([*args, note, *nodes])
