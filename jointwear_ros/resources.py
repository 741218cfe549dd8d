"""Where the package's data files are: parameter sets, node configs, message definitions.

One lookup for every resource, in this order:

1. a **development checkout** (this package imported from a source tree that has
   ``package.xml`` beside it): the source tree's own files (``config/``,
   ``msg_defs/msg``), so an edit is seen at once;
2. the **ament index**: ``share/<package>`` of the prefix that registered the
   package (``AMENT_PREFIX_PATH``, as after ``colcon build`` and
   ``. install/setup.bash``), through ``ament_index_python`` when it is importable;
3. every ``AMENT_PREFIX_PATH`` entry's ``share/<package>`` and the running
   interpreter's ``sys.prefix/share/<package>`` (a venv is an ament prefix).

:func:`node_config` reads a node's parameters from ``config/<node>.yaml`` (or a
params file the user gives): the one reader of node configuration.

Nothing here imports rclpy.

>>> p = find_resource("jointwear_ros", "config/params/ref-2011r.yaml")
>>> p.name, p.is_file()
('ref-2011r.yaml', True)
>>> find_resource("jointwear_ros", "config/params/no-such-set.yaml") is None
True
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

from .errors import InputDataError

__all__ = ["config_path", "find_resource", "flatten", "node_config", "resource_dirs", "source_tree"]

# source-tree location of each package's share files, relative to the checkout root
_SOURCE_SHARE = {
    "jointwear_ros": Path("."),
    "jointwear_msgs": Path("msg_defs"),
}


def source_tree() -> Path | None:
    """The checkout root when this package runs from a source tree (``package.xml`` beside it), else None."""
    root = Path(__file__).resolve().parents[1]
    if (root / "package.xml").is_file() and (root / "jointwear_ros").is_dir():
        return root
    return None


def _ament_index_share(package: str) -> Path | None:
    if not os.environ.get("AMENT_PREFIX_PATH"):
        return None
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    except ImportError:  # no ament_index_python: the prefix scan below covers the same directories
        return None
    try:
        return Path(get_package_share_directory(package))
    except PackageNotFoundError:
        return None


def resource_dirs(package: str) -> list[Path]:
    """Candidate ``share/<package>`` directories (or the source-tree equivalent), best first, deduplicated."""
    dirs: list[Path] = []
    root = source_tree()
    if root is not None and package in _SOURCE_SHARE:
        dirs.append(root / _SOURCE_SHARE[package])
    indexed = _ament_index_share(package)
    if indexed is not None:
        dirs.append(indexed)
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if prefix:
            dirs.append(Path(prefix) / "share" / package)
    dirs.append(Path(sys.prefix) / "share" / package)
    out: list[Path] = []
    for d in dirs:
        if d not in out:
            out.append(d)
    return out


def find_resource(package: str, relative: str | Path) -> Path | None:
    """The first existing ``<share dir>/<relative>`` of ``package`` (file or directory), or None."""
    for d in resource_dirs(package):
        cand = d / relative
        if cand.exists():
            return cand
    return None


def config_path(name: str) -> Path:
    """``config/<name>`` of jointwear_ros (a node's parameter file); the first candidate when none exists."""
    found = find_resource("jointwear_ros", Path("config") / name)
    return found if found is not None else resource_dirs("jointwear_ros")[0] / "config" / name


def flatten(tree: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}`` (nested params YAML to ROS's dotted parameter names)."""
    out: dict[str, Any] = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        else:
            out[name] = value
    return out


def node_config(node: str, path: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """The ``ros__parameters`` of ``node`` in a ROS 2 params file, flattened to dotted names.

    ``path`` None: the package's ``config/<node>.yaml`` (``{}`` when the package has none).
    Accepts the sections ``node``, ``/node`` and the ``/**`` wildcard. A file that is missing,
    not YAML or not a params file: :class:`~jointwear_ros.errors.InputDataError`.

    >>> node_config("wear_trend")["robot"]
    'robot_1'
    """
    import yaml

    if path is None:
        path = config_path(f"{node}.yaml")
        if not path.is_file():
            return {}
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
    for key in ("/**", node, f"/{node}"):
        section = doc.get(key)
        if isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
            out.update(flatten(section["ros__parameters"]))
    return out
