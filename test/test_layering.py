"""The layering of docs/architecture.md, enforced on the import graph of ``jointwear_ros``.

Every ``import`` of every module (top level and inside functions) is read with ``ast``; the rules:

- the pure cores never import rclpy, ROS message packages, ``io``, ``cli`` or ``nodes``;
- ``io`` (bags and tables, no ROS runtime) never imports rclpy, ``nodes`` or ``cli``;
- ``nodes`` never import ``cli``, and the live nodes never import the offline replay pipeline;
- one ``cli`` sub-command module never imports another (what they share lives in ``cli/common.py``
  or in a library module);
- no module imports a private name (``_name``) of another module.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "jointwear_ros"

CORES = ("model", "estimation", "workbench", "commission", "data", "sim", "cycle", "observer", "monitor", "trend",
         "types", "units", "errors", "fmt", "contract", "resources", "condition")
ROS = ("rclpy", "rcl_interfaces", "std_msgs", "std_srvs", "sensor_msgs", "diagnostic_msgs", "rosgraph_msgs",
       "builtin_interfaces", "jointwear_msgs", "launch", "launch_ros")


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[str, tuple[str, ...], int]]:
    """(absolute module, imported names, line) for each import in ``path``."""
    mod = _module_name(path)
    package = mod if path.name == "__init__.py" else mod.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out.extend((a.name, (), node.lineno) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                target = ".".join([*base, node.module] if node.module else base)
            else:
                target = node.module or ""
            out.append((target, tuple(a.name for a in node.names), node.lineno))
    return out


MODULES = sorted(PKG.rglob("*.py"))


def _layer(mod: str) -> str:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else ""


def _violations(path: Path) -> list[str]:
    mod = _module_name(path)
    layer = _layer(mod)
    found = []
    for target, names, line in _imports(path):
        where = f"{path.relative_to(PKG.parent)}:{line}"
        top = target.split(".")[0]
        inner = _layer(target) if top == "jointwear_ros" else None
        if layer in CORES:
            if top in ROS:
                found.append(f"{where}: core module imports ROS package {target}")
            if inner in ("io", "cli", "nodes"):
                found.append(f"{where}: core module imports {target}")
        if layer == "io":
            if top in ROS:
                found.append(f"{where}: io imports ROS package {target}")
            if inner in ("cli", "nodes"):
                found.append(f"{where}: io imports {target}")
        if layer == "nodes":
            if inner == "cli":
                found.append(f"{where}: node imports {target}")
            if target == "jointwear_ros.replay" or "replay_bag" in names:
                found.append(f"{where}: live node imports the offline replay pipeline ({target})")
        if layer == "cli" and inner == "cli" and mod.endswith("_cmd") and target.endswith("_cmd"):
            found.append(f"{where}: sub-command {mod} imports sub-command {target}")
        if top == "jointwear_ros":
            target_file = PKG.parent / Path(*target.split("."))
            same_module = target == mod
            for n in names:
                if n.startswith("_") and not n.startswith("__") and not same_module:
                    # importing a private *module* of one's own package (estimation/_common.py) is fine;
                    # a private *name* of another module is not
                    if not (target_file / f"{n}.py").is_file():
                        found.append(f"{where}: imports private name {n} of {target}")
    return found


@pytest.mark.parametrize("path", MODULES, ids=[_module_name(p) for p in MODULES])
def test_module_respects_the_layering(path):
    bad = _violations(path)
    assert not bad, "\n".join(bad)


def test_the_rules_catch_what_they_are_for(tmp_path):
    """Each rule fires on a planted import (so a rule cannot silently go blind)."""
    planted = {
        "model/bad_rclpy.py": "import rclpy\n",
        "estimation/bad_cli.py": "def f():\n    from ..cli.common import format_table\n",
        "sim/bad_private.py": "from ..data.synth import _effect_value\n",
        "nodes/bad_cli.py": "from ..cli import main\n",
        "nodes/bad_replay.py": "from ..replay import ReplayResult\n",
        "cli/demo_cmd.py": "from .replay_cmd import config_path\n",
        "io/bad_node.py": "from ..nodes.runtime import run_node\n",
    }
    root = tmp_path / "jointwear_ros"
    for rel, text in planted.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    global PKG
    saved, PKG = PKG, root
    try:
        for rel in planted:
            assert _violations(root / rel), f"no rule caught {rel}"
    finally:
        PKG = saved
