"""Per-joint parameters of the nodes that serve several joints (docs/robot.md).

A node that serves a robot has a read-only ``joints`` parameter (the joint names
in order; empty: the one joint ``joint_name``) and, for each joint, parameters
``<joint>.<setting>`` whose default is the node-level ``<setting>`` (ROS 2 reads
them from the nested YAML ``joint_3: {wear: 40.0}``). A node-level setting set at
run time sets every joint's ``<joint>.<setting>`` with it (a pre-set-parameters
callback adds them to the same call), so the joints follow and read back the
new value; ``<joint>.<setting>`` sets that joint only.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..errors import ParameterError
from .runtime import ParamDecl

__all__ = ["declare_joints", "declare_per_joint", "propagate_node_level"]


def declare_joints(node: Node, joint_name: str, description: str) -> list[str]:
    """Declare the read-only string array ``joints`` (empty by default) and return the joints served.

    Empty or not given: ``[joint_name]``. An empty name or a joint named twice is a :class:`ParameterError`.
    """
    desc = ParameterDescriptor(description=description + " (read at start-up: restart the node to change it)",
                               read_only=True)
    node.declare_parameter("joints", Parameter.Type.STRING_ARRAY, desc)
    value = node.get_parameter_or("joints", Parameter("joints", Parameter.Type.STRING_ARRAY, [])).value
    joints = [str(j) for j in (value or [])] or [joint_name]
    twice = sorted({j for j in joints if joints.count(j) > 1})
    if twice or any(not j.strip() for j in joints):
        raise ParameterError(f"{node.get_name()}: joints {joints}: every joint needs a name, and each name once")
    return joints


def declare_per_joint(node: Node, joints: Sequence[str], decls: Sequence[ParamDecl],
                      defaults: Mapping[str, Sequence[Any]] | None = None) -> dict[str, dict[str, Any]]:
    """Declare ``<joint>.<name>`` for every joint and every ``decls`` entry; return joint -> name -> value.

    The default is the node-level parameter's value (declared before), or ``defaults[name][i]`` for
    the i-th joint when given (e.g. a seed per joint). Same description, range and read-only flag as the
    node-level one.
    """
    out: dict[str, dict[str, Any]] = {}
    for i, j in enumerate(joints):
        out[j] = {}
        for d in decls:
            default = node.get_parameter(d.name).value if not defaults or d.name not in defaults else defaults[d.name][i]
            if isinstance(default, Sequence) and not isinstance(default, str):
                default = list(default)
            text = f"{d.description}; for {j} (default: the node-level {d.name})"
            if d.read_only:
                text += " (read at start-up: restart the node to change it)"
            desc = ParameterDescriptor(description=text, read_only=d.read_only)
            if d.min is not None and d.max is not None and isinstance(d.default, float):
                desc.floating_point_range = [FloatingPointRange(from_value=float(d.min), to_value=float(d.max))]
            try:
                node.declare_parameter(f"{j}.{d.name}", default, desc)
            except InvalidParameterTypeException as exc:
                raise ParameterError(f"{node.get_name()}: parameter {j}.{d.name}: {exc}; give it the type of "
                                     f"{d.name} (e.g. 40.0 for a float, not 40)") from None
            out[j][d.name] = node.get_parameter(f"{j}.{d.name}").value
    return out


def propagate_node_level(names: Sequence[str], joints: Sequence[str]) -> Callable[[list[Parameter]], list[Parameter]]:
    """A pre-set-parameters callback: a node-level ``name`` (of ``names``) set at run time also sets
    ``<joint>.<name>`` of every joint, unless the same call sets that one itself."""
    watched = frozenset(names)

    def pre(params: list[Parameter]) -> list[Parameter]:
        given = {p.name for p in params}
        out = list(params)
        for p in params:
            if p.name in watched:
                out += [Parameter(f"{j}.{p.name}", p.type_, p.value) for j in joints if f"{j}.{p.name}" not in given]
        return out

    return pre
