"""The joints a node serves, and their per-joint settings, from ROS parameters (docs/robot.md).

A node that serves a robot has a read-only ``joints`` parameter (the joint names
in order; empty: the one joint ``joint_name``, as in every one-joint
configuration). A setting may be given per joint, nested under the joint's name
in the params YAML (ROS 2 turns it into a parameter ``<joint>.<setting>``,
e.g. ``joint_3: {wear: 40.0}``). Every node that serves a robot (``joint_sim``,
``test_cycle``, ``friction_observer``, ``wear_estimator``) declares them the
same way:

- :func:`declare_per_joint`: every ``<joint>.<setting>`` is declared, for every
  joint, with the node-level value as default (a joint not given its own value
  in the YAML starts with the node-level one), read-only exactly when the
  node-level setting is;
- :func:`propagate_node_level` (a pre-set-parameters callback): a node-level
  setting set at run time sets every joint's ``<joint>.<setting>`` in the same
  call, **a value a joint was given of its own included** (unless that call
  sets the joint's value itself); ``<joint>.<setting>`` set at run time changes
  that joint only. The node validates the joints' new values together: one
  joint's invalid value refuses the whole call (nothing changes).
  :func:`split_per_joint` sorts a call's changes by joint.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException
from rclpy.node import Node
from rclpy.parameter import Parameter

from ..errors import ParameterError
from .runtime import JOINTS, JOINTS_DESCRIPTION, ParamDecl, declare_accepting_integers, declare_parameters

__all__ = ["JOINTS", "declare_joints", "declare_per_joint", "propagate_node_level", "replaced_own_values", "split_per_joint"]

def declare_joints(node: Node, joint_name: str, description: str = JOINTS_DESCRIPTION) -> list[str]:
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
    node-level one. Settings given for a joint not in ``joints`` are not used; they are logged
    (a typo would otherwise silently leave that joint on the node-level value).
    """
    _warn_stray(node, joints, [d.name for d in decls])
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
                declare_accepting_integers(node, f"{j}.{d.name}", default, desc)
            except InvalidParameterTypeException as exc:
                raise ParameterError(f"{node.get_name()}: parameter {j}.{d.name}: {exc}; give it the type of "
                                     f"{d.name}") from None
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


def split_per_joint(changes: Mapping[str, Any], joints: Sequence[str]) -> dict[str, dict[str, Any]]:
    """The ``<joint>.<name>`` entries of a parameter change, by joint: joint -> name -> value.

    Only the joints of ``joints`` (each present, maybe empty); node-level names are left out (with
    :func:`propagate_node_level` a node-level change arrives with every joint's ``<joint>.<name>``).
    """
    out: dict[str, dict[str, Any]] = {j: {} for j in joints}
    for key, value in changes.items():
        joint, _, name = key.partition(".")
        if name and joint in out:
            out[joint][name] = value
    return out


def replaced_own_values(node: Node, changes: Mapping[str, Any], joints: Sequence[str]) -> list[str]:
    """``<joint>.<name> old -> new`` for each joint value a node-level change in ``changes`` replaces
    although it differed from the node-level value (a value of the joint's own), for a log line.

    Call it from an on-set-parameters callback: the parameters still hold their old values.
    """
    out: list[str] = []
    for name, value in changes.items():
        if "." in name or not node.has_parameter(name):
            continue
        before = node.get_parameter(name).value
        for j in joints:
            full = f"{j}.{name}"
            if full in changes and node.has_parameter(full):
                own = node.get_parameter(full).value
                if own != before and own != changes[full] and changes[full] == value:
                    out.append(f"{full} {own!r} -> {value!r}")
    return out


def _warn_stray(node: Node, joints: Sequence[str], names: Sequence[str]) -> None:
    overrides = set(getattr(node, "_parameter_overrides", {}) or {})
    known, settings = set(joints), set(names)
    stray = sorted(k for k in overrides if "." in k and k.split(".", 1)[0] not in known
                   and k.split(".", 1)[1] in settings)
    if stray:
        node.get_logger().warning(f"per-joint settings {', '.join(stray)} name a joint that is not in joints "
                                  f"{list(joints)!r}: not used (add the joint or fix the name)")


def declare_robot(node: Node, decls: Sequence[ParamDecl], per_joint: Sequence[str],
                  defaults: Callable[[dict[str, Any], list[str]], Mapping[str, Sequence[Any]]] | None = None
                  ) -> tuple[dict[str, Any], list[str], dict[str, dict[str, Any]]]:
    """A robot node's parameters in one call: the node-level ``decls`` (``joints`` among them is declared
    read-only by :func:`declare_joints`, with its description), the joints served, and every joint's own
    ``per_joint`` settings (:func:`declare_per_joint`; ``defaults(params, joints)`` gives per-joint
    defaults, e.g. a seed per joint). Returns (node-level values, joints, joint -> setting -> value)."""
    by_name = {d.name: d for d in decls}
    params = declare_parameters(node, [d for d in decls if d.name != "joints"])
    joints_decl = by_name.get("joints")
    joints = declare_joints(node, str(params["joint_name"]),
                            joints_decl.description if joints_decl is not None else JOINTS_DESCRIPTION)
    values = declare_per_joint(node, joints, [by_name[n] for n in per_joint],
                               defaults(params, joints) if defaults is not None else None)
    return params, joints, values
