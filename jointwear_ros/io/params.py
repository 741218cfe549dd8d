"""ROS 2 node parameters outside a running graph: params files and recorded ``/parameter_events``.

The offline replay, the CLI and the fleet re-analysis configure the pure cores with the same
parameters the live nodes had: from a node's params YAML (``<node>: ros__parameters: ...``) and
from the ``ParameterEvent`` messages a bag recorded. Names are flattened to ROS's dotted form.

>>> flatten({"estimator_options": {"n_samples": 200}, "method": "joint"})
{'estimator_options.n_samples': 200, 'method': 'joint'}
>>> nest({"estimator_options.n_samples": 200})
{'estimator_options': {'n_samples': 200}}
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ..errors import InputDataError

__all__ = ["flatten", "nest", "node_params_from_yaml", "parameter_value", "recorded_node_params"]


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


def flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        else:
            out[name] = value
    return out


def node_params_from_yaml(path: str | os.PathLike[str], node_name: str) -> dict[str, Any]:
    """The ``ros__parameters`` of ``node_name`` in a ROS 2 params file, flattened to dotted names.

    Accepts ``node_name``, ``/node_name`` and the ``/**`` wildcard section.
    """
    import yaml

    p = Path(path)
    try:
        doc = yaml.safe_load(p.read_text())
    except FileNotFoundError:
        raise InputDataError(f"{p}: no such parameter file") from None
    except yaml.YAMLError as exc:
        raise InputDataError(f"{p}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, dict):
        raise InputDataError(f"{p}: not a ROS 2 parameter file (expected '<node>: ros__parameters: ...')")
    out: dict[str, Any] = {}
    for key in ("/**", node_name, f"/{node_name}"):
        section = doc.get(key)
        if isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
            out.update(flatten(section["ros__parameters"]))
    return out


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
