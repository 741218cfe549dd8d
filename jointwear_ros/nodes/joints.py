"""The joints a node serves, and their per-joint settings, from ROS parameters (docs/robot.md).

A node of a whole robot declares ``joints`` (the joint names in order; empty
means the single joint ``joint_name``, as in every one-joint configuration).
A setting may be given per joint, nested under the joint's name in the params
YAML (ROS 2 turns it into a parameter ``<joint>.<setting>``); a joint without
its own value takes the node-level one. Per-joint parameters are declared
only when given (read at start-up: read-only), so ``ros2 param list`` shows
exactly what was set; a run-time change of a node-level setting applies to
every joint that has no value of its own.

Used by ``friction_observer`` and ``wear_estimator``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..errors import InputDataError
from .runtime import ParamDecl

__all__ = ["declare_joint_settings", "declare_joints"]


def declare_joints(node: Node, joint_name: str) -> list[str]:
    """Declare the read-only ``joints`` parameter (string array); the joints served, in order.

    Empty (or not given) -> ``[joint_name]``. Raises
    :class:`~jointwear_ros.errors.InputDataError` for an empty name, a name
    given twice or one with a ``.`` (it could not prefix its settings).
    """
    desc = ParameterDescriptor(
        description="joints served, in order (empty = the single joint joint_name); per-joint settings nest "
                    "under each name (read at start-up: restart the node to change it)",
        read_only=True)
    node.declare_parameter("joints", Parameter.Type.STRING_ARRAY, desc)
    value = node.get_parameter_or("joints", Parameter("joints", value=[])).value
    joints = [str(j) for j in (value or [])]
    if not joints:
        return [str(joint_name)]
    seen: set[str] = set()
    for j in joints:
        if not j.strip() or "." in j or j != j.strip():
            raise InputDataError(f"parameter joints = {joints!r}: joint name {j!r} must be non-empty, without "
                                 "spaces at the ends and without '.'")
        if j in seen:
            raise InputDataError(f"parameter joints = {joints!r}: {j!r} is named twice")
        seen.add(j)
    return joints


def declare_joint_settings(node: Node, joints: Sequence[str], decls: Sequence[ParamDecl],
                           node_values: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Per joint, the settings given as ``<joint>.<name>`` parameters (declared read-only here).

    ``decls`` are the node-level declarations of the settings a joint may have
    of its own (their ranges apply to the per-joint values too);
    ``node_values`` the node-level values (the default of each per-joint
    parameter, so a value of the wrong type is refused by rclpy with the name).
    Settings given for a joint not in ``joints`` are not used; they are logged
    (a typo would otherwise silently leave that joint on the node-level value).
    """
    overrides = set(getattr(node, "_parameter_overrides", {}) or {})
    names = {d.name: d for d in decls}
    known = set(joints)
    stray = sorted(k for k in overrides if "." in k and k.split(".", 1)[0] not in known
                   and k.split(".", 1)[1] in names)
    if stray:
        node.get_logger().warning(f"per-joint settings {', '.join(stray)} name a joint that is not in joints "
                                  f"{list(joints)!r}: not used (add the joint or fix the name)")
    out: dict[str, dict[str, Any]] = {j: {} for j in joints}
    for j in joints:
        for name, d in names.items():
            full = f"{j}.{name}"
            if full not in overrides:
                continue
            text = f"{d.description} ({j} only; read at start-up: restart the node to change it)"
            desc = ParameterDescriptor(description=text, read_only=True)
            default = node_values[name]
            if d.min is not None and d.max is not None and isinstance(default, float):
                from rcl_interfaces.msg import FloatingPointRange

                desc.floating_point_range = [FloatingPointRange(from_value=float(d.min), to_value=float(d.max))]
            node.declare_parameter(full, default, desc)
            out[j][name] = node.get_parameter(full).value
    return out
