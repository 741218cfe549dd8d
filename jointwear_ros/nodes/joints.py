"""The joints a node serves, and their per-joint settings, from ROS parameters (docs/robot.md).

A node that serves a robot has a read-only ``joints`` parameter (the joint names
in order; empty: the one joint ``joint_name``, as in every one-joint
configuration). A setting may be given per joint, nested under the joint's name
in the params YAML (ROS 2 turns it into a parameter ``<joint>.<setting>``,
e.g. ``joint_3: {wear: 40.0}``); a joint without its own value takes the
node-level one. Two ways to declare them:

- :func:`declare_per_joint` (``joint_sim``, ``test_cycle``): every
  ``<joint>.<setting>`` is declared, with the node-level value as default; a
  node-level setting set at run time sets every joint's with it
  (:func:`propagate_node_level`), ``<joint>.<setting>`` sets that joint only.
- :func:`declare_joint_settings` (``friction_observer``, ``wear_estimator``):
  only the per-joint settings given are declared (read-only), so ``ros2 param
  list`` shows exactly what was set; a run-time change of a node-level setting
  applies to every joint without a value of its own.
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

__all__ = ["declare_joint_settings", "declare_joints", "declare_per_joint", "propagate_node_level"]

_JOINTS_DESCRIPTION = ("joints served, in order (empty = the single joint joint_name); per-joint settings nest "
                       "under each name")


def declare_joints(node: Node, joint_name: str, description: str = _JOINTS_DESCRIPTION) -> list[str]:
    """Declare the read-only string array ``joints`` (empty by default) and return the joints served.

    Empty or not given: ``[joint_name]``. A :class:`~jointwear_ros.errors.ParameterError` for an empty
    name, a name with spaces at its ends or a ``.`` (it could not prefix its settings), or a name given twice.
    """
    desc = ParameterDescriptor(description=description + " (read at start-up: restart the node to change it)",
                               read_only=True)
    node.declare_parameter("joints", Parameter.Type.STRING_ARRAY, desc)
    value = node.get_parameter_or("joints", Parameter("joints", Parameter.Type.STRING_ARRAY, [])).value
    joints = [str(j) for j in (value or [])]
    if not joints:
        return [str(joint_name)]
    seen: set[str] = set()
    for j in joints:
        if not j.strip() or "." in j or j != j.strip():
            raise ParameterError(f"{node.get_name()}: parameter joints = {joints!r}: joint name {j!r} must be "
                                 "non-empty, without spaces at the ends and without '.'")
        if j in seen:
            raise ParameterError(f"{node.get_name()}: parameter joints = {joints!r}: {j!r} is named twice")
        seen.add(j)
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
                desc.floating_point_range = [FloatingPointRange(from_value=float(d.min), to_value=float(d.max))]
            node.declare_parameter(full, default, desc)
            out[j][name] = node.get_parameter(full).value
    return out
