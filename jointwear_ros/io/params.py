"""ROS 2 node parameters outside a running graph: declarations, params files and recorded ``/parameter_events``.

Every node declares its parameters once, as a tuple of :class:`ParamDecl` (name, default,
description, range, read-only; :mod:`jointwear_ros.settings`, re-exported here, also builds them from a
config dataclass's field metadata); the node declares them to ROS from it
(``nodes.runtime.declare_parameters``) and the CLI checks a ``--set node.name=value`` against
it (:meth:`ParamDecl.check`). The offline replay, the CLI and the fleet re-analysis configure
the pure cores with the same parameters the live nodes had: from a node's params YAML
(``<node>: ros__parameters: ...``, read by :func:`jointwear_ros.resources.node_config`) and
from the ``ParameterEvent`` messages a bag recorded. Names are flattened to ROS's dotted form.

>>> ParamDecl("warn_threshold", 30.0, "wear of WARN", 0.0, 100.0).check(31)
31.0

>>> flatten({"estimator_options": {"n_samples": 200}, "method": "joint"})
{'estimator_options.n_samples': 200, 'method': 'joint'}
>>> nest({"estimator_options.n_samples": 200})
{'estimator_options': {'n_samples': 200}}
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from typing import Any

from ..resources import flatten, node_config
from ..settings import ParamDecl

__all__ = ["ParamDecl", "flatten", "nest", "node_params_from_yaml", "parameter_value", "recorded_node_params"]


def nest(flat: dict[str, Any]) -> dict[str, Any]:
    """``{"a.b": 1}`` -> ``{"a": {"b": 1}}`` (ROS dotted parameter names to nested mappings)."""
    out: dict[str, Any] = {}
    for key, value in flat.items():
        parts = key.split(".")
        d = out
        for part in parts[:-1]:
            nxt = d.get(part)
            if not isinstance(nxt, dict):
                nxt = {}
                d[part] = nxt
            d = nxt
        d[parts[-1]] = value
    return out


def node_params_from_yaml(path: str | os.PathLike[str], node_name: str) -> dict[str, Any]:
    """The ``ros__parameters`` of ``node_name`` in a ROS 2 params file, flattened to dotted names
    (:func:`jointwear_ros.resources.node_config` with a file)."""
    return node_config(node_name, path)


_PARAM_VALUE_FIELDS = {
    1: "bool_value", 2: "integer_value", 3: "double_value", 4: "string_value", 5: "byte_array_value",
    6: "bool_array_value", 7: "integer_array_value", 8: "double_array_value", 9: "string_array_value",
}


def parameter_value(value: Any) -> Any:
    """The Python value of an ``rcl_interfaces/ParameterValue`` (None when NOT_SET)."""
    name = _PARAM_VALUE_FIELDS.get(int(value.type))
    if name is None:
        return None
    v = getattr(value, name)
    if hasattr(v, "tolist"):
        return v.tolist()
    return list(v) if isinstance(v, (list, tuple)) else v


def recorded_node_params(events: Iterable[Any], node_name: str) -> dict[str, Any]:
    """Parameters of ``node_name`` as its ``ParameterEvent`` messages declared or changed them."""
    out: dict[str, Any] = {}
    for ev in events:
        if str(ev.node).lstrip("/") != node_name.lstrip("/"):
            continue
        for param in (*ev.new_parameters, *ev.changed_parameters):
            value = parameter_value(param.value)
            if value is not None:
                out[str(param.name)] = value
        for param in ev.deleted_parameters:
            out.pop(str(param.name), None)
    return out
