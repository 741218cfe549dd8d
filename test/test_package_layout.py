"""The colcon/rosdep-facing layout: both package.xml files validate, entry points and data files exist."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

catkin_pkg = pytest.importorskip("catkin_pkg.package")

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(("path", "name", "build_type"), [
    ("package.xml", "jointwear_ros", "ament_python"),
    ("msg_defs/package.xml", "jointwear_msgs", "ament_cmake"),
])
def test_package_xml_validates_with_catkin_pkg(path, name, build_type):
    pkg = catkin_pkg.parse_package(ROOT / path)
    pkg.validate()
    assert pkg.name == name
    assert pkg.get_build_type() == build_type
    assert pkg.package_format == 3


def test_python_package_declares_its_runtime_ros_dependencies():
    deps = {d.name for d in catkin_pkg.parse_package(ROOT / "package.xml").exec_depends}
    assert {"rclpy", "jointwear_msgs", "sensor_msgs", "std_msgs", "std_srvs", "diagnostic_msgs"} <= deps


def test_every_ros_package_the_code_imports_is_an_exec_depend():
    """rosdep installs what package.xml lists: every ROS package imported by the nodes and the launch file."""
    deps = {d.name for d in catkin_pkg.parse_package(ROOT / "package.xml").exec_depends}
    ros_packages = {"rclpy", "rcl_interfaces", "ament_index_python", "launch", "launch_ros", "std_msgs", "std_srvs",
                    "sensor_msgs", "diagnostic_msgs", "rosgraph_msgs", "builtin_interfaces", "jointwear_msgs"}
    imported = set()
    for path in [*ROOT.glob("jointwear_ros/**/*.py"), *ROOT.glob("launch/*.py")]:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                imported.update(a.name.split(".")[0] for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                imported.add(node.module.split(".")[0])
    missing = sorted((imported & ros_packages) - deps)
    assert not missing, f"imported but not in package.xml: {missing}"


def test_interface_package_generates_every_definition_it_ships():
    cmake = (ROOT / "msg_defs" / "CMakeLists.txt").read_text()
    defs = [*(ROOT / "msg_defs").glob("msg/*.msg"), *(ROOT / "msg_defs").glob("srv/*.srv")]
    shipped = sorted(p.relative_to(ROOT / "msg_defs").as_posix() for p in defs)
    assert len(shipped) == 6, shipped
    for rel in shipped:
        assert f'"{rel}"' in cmake, f"{rel} is not listed in rosidl_generate_interfaces"


def test_every_console_script_is_declared_for_ros2_run():
    tree = ast.parse((ROOT / "setup.py").read_text())
    scripts = [
        elt.value
        for node in ast.walk(tree)
        if isinstance(node, ast.Dict)
        for k, v in zip(node.keys, node.values)
        if isinstance(k, ast.Constant) and k.value == "console_scripts"
        for elt in v.elts
    ]
    names = {s.split("=")[0].strip() for s in scripts}
    assert {"jointwear", "joint_sim", "test_cycle", "friction_observer", "wear_estimator", "recorder",
            "wear_trend"} <= names
    assert (ROOT / "resource" / "jointwear_ros").is_file()
    cfg = (ROOT / "setup.cfg").read_text()
    assert "install_scripts=$base/lib/jointwear_ros" in cfg  # where ros2 run looks
