"""The layering of docs/architecture.md, enforced on the import graph of ``jointwear_ros``.

Every ``import`` of every module (top level and inside functions) is read with ``ast``; the rules:

- the pure cores never import rclpy, ROS message packages, ``io``, ``cli`` or ``nodes``;
- ``io`` (bags and tables, no ROS runtime) never imports rclpy, ``nodes`` or ``cli``;
- ``nodes`` never import ``cli``, and the live nodes never import the offline replay pipeline;
- one ``cli`` sub-command module never imports another (what they share lives in ``cli/common.py``
  or in a library module);
- no module imports a private name (``_name``) of another module;
- the workbench's cores return data and never import its rendering side (:data:`RENDERERS`: ``render``,
  ``phrases``, ``report``); only those modules import each other;
- the layer map: every package and top-level module of ``jointwear_ros`` has a rank (:data:`RANK`, lowest =
  foundation) and imports only from lower ranks (never from its own rank or above, its own package aside);
- no import circle among the package's modules (strongly connected components of the module graph);
- docs/architecture.md's package table carries the same ranks, in rank order.

Imports under ``if TYPE_CHECKING:`` and inside functions count as edges like any other: a lazy import does not
hide a layer crossed or a circle.
"""

from __future__ import annotations

import ast
import contextlib
import functools
from collections.abc import Iterator
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "jointwear_ros"
ARCHITECTURE = PKG.parent / "docs" / "architecture.md"

#: The layer map: the rank of every package (``io`` for ``jointwear_ros/io/``) and top-level module
#: (``replay`` for ``jointwear_ros/replay.py``; ``__init__`` is the root package's own module). A module imports
#: only from lower ranks. Derived from the package-level import graph: each rank is above everything its
#: package imports.
RANK: dict[str, int] = {
    # the foundation: no import of the package (observation: the data type the contract and observer share)
    "__init__": 0, "errors": 0, "fmt": 0, "plots": 0, "observation": 0, "lazy": 0,
    "types": 1, "resources": 1, "contract": 1, "settings": 1,
    "units": 2, "condition": 2, "cycle": 2,
    "model": 3,
    "estimation": 4, "observer": 4, "workbench": 4,
    "data": 5,
    "sim": 6,
    "commission": 7, "monitor": 7, "trend": 7,
    "io": 8,
    "simcell": 8,
    "replay": 9,
    "history": 10,
    "fleet": 11, "serve": 11, "nodes": 11,
    "cli": 12,
    "__main__": 13,
}

CORES = ("model", "estimation", "workbench", "commission", "data", "sim", "cycle", "observer", "monitor", "trend",
         "types", "units", "errors", "fmt", "contract", "resources", "condition", "observation", "settings", "lazy",
         "simcell")
ROS = ("rclpy", "rcl_interfaces", "std_msgs", "std_srvs", "sensor_msgs", "diagnostic_msgs", "rosgraph_msgs",
       "builtin_interfaces", "jointwear_msgs", "launch", "launch_ros")
#: The workbench's rendering side: the sentences, the text and Markdown reports, the HTML page. The workbench's
#: other modules (its cores) return data and import none of these.
RENDERERS = ("jointwear_ros.workbench.render", "jointwear_ros.workbench.phrases", "jointwear_ros.workbench.report")


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
    return list(_parsed_imports(str(path), package, path.read_text()))


@functools.cache
def _parsed_imports(where: str, package: str, text: str) -> tuple[tuple[str, tuple[str, ...], int], ...]:
    """:func:`_imports` of one file's ``text`` in ``package``: each module is read by two tests of each rule and by
    the circle search, and is parsed once (the key holds the text, so a planted file that changes is read again)."""
    out = []
    for node in ast.walk(ast.parse(text, where)):
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
    return tuple(out)


MODULES = sorted(PKG.rglob("*.py"))


def _layer(mod: str) -> str:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else ""


def _rank_key(mod: str) -> str:
    """The :data:`RANK` key of a module: its package or top-level module (the root package: ``__init__``)."""
    return _layer(mod) or "__init__"


def _modules(root: Path) -> dict[str, Path]:
    return {_module_name(p): p for p in sorted(root.rglob("*.py"))}


def _edges(path: Path, mods: dict[str, Path]) -> list[tuple[str, int]]:
    """(module of the package, line) for each import of ``path``: ``from .x import y`` goes to module ``.x.y``
    when that is a module, else to ``.x`` (a package's ``__init__``)."""
    out = []
    for target, names, line in _imports(path):
        hits = [f"{target}.{n}" for n in names if f"{target}.{n}" in mods]
        if len(hits) < len(names) or not names:
            hits.append(target)
        out.extend((t, line) for t in hits if t in mods)
    return out


def _rank_violations(path: Path) -> list[str]:
    """Imports from ``path`` to a package of equal or higher rank (its own package aside)."""
    mods = _modules(PKG)
    mod = _module_name(path)
    own = _rank_key(mod)
    if own not in RANK:
        return [f"{path.relative_to(PKG.parent)}: {own!r} has no rank; add it to RANK in test/test_layering.py "
                "and to docs/architecture.md's table"]
    found = []
    for target, line in _edges(path, mods):
        other = _rank_key(target)
        if other == own or other not in RANK:
            continue
        if RANK[other] >= RANK[own]:
            found.append(f"{path.relative_to(PKG.parent)}:{line}: {own} (rank {RANK[own]}) imports {target} "
                         f"({other}, rank {RANK[other]}): a module imports only from lower ranks")
    return found


def _circles(root: Path) -> list[list[str]]:
    """The import circles among the modules under ``root``: strongly connected components (Tarjan) of more
    than one module, each sorted, function-local and TYPE_CHECKING imports included."""
    mods = _modules(root)
    graph = {m: sorted({t for t, _ in _edges(p, mods) if t != m}) for m, p in mods.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    return sorted(out)


def _circle_text(comp: list[str], root: Path) -> str:
    """One circle as a path through it: ``a -> b -> a``, each step with the importing line."""
    mods = _modules(root)
    members = set(comp)
    steps, seen, cur = [comp[0]], {comp[0]}, comp[0]
    while True:
        nxt = [(t, line) for t, line in _edges(mods[cur], mods) if t in members]
        back = next(((t, line) for t, line in nxt if t == comp[0]), None)
        fresh = next(((t, line) for t, line in nxt if t not in seen), None)
        step = fresh if fresh is not None and len(seen) < len(members) else back or fresh
        if step is None:
            break
        steps.append(f"(line {step[1]}) {step[0]}")
        if step[0] == comp[0] or step[0] in seen:
            break
        seen.add(step[0])
        cur = step[0]
    return " -> ".join(steps)


def _architecture_ranks(text: str) -> list[tuple[str, int]]:
    """(RANK key, rank) of each row of docs/architecture.md's package table, in the table's order."""
    section = text.split("## Packages and concerns", 1)[1].split("\n## ", 1)[0]
    rows = []
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 2 or not cells[0].startswith("`jointwear_ros/"):
            continue
        path = cells[0].strip("`")
        name = path.removeprefix("jointwear_ros/").rstrip("/").removesuffix(".py")
        rows.append((name, int(cells[1])))
    return rows


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
        if layer == "workbench" and mod not in RENDERERS:
            for r in {t for t in (target, *(f"{target}.{n}" for n in names)) if t in RENDERERS}:
                found.append(f"{where}: workbench core {mod} imports the renderer {r} (a core returns data)")
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


@pytest.mark.parametrize("path", MODULES, ids=[_module_name(p) for p in MODULES])
def test_module_imports_only_from_lower_ranks(path):
    bad = _rank_violations(path)
    assert not bad, "\n".join(bad)


def test_every_package_has_a_rank_and_every_rank_a_package():
    keys = {_rank_key(_module_name(p)) for p in MODULES}
    assert keys - set(RANK) == set(), f"packages without a rank: {sorted(keys - set(RANK))}"
    assert set(RANK) - keys == set(), f"ranks of packages that do not exist: {sorted(set(RANK) - keys)}"


def test_no_import_circle_among_the_modules():
    circles = _circles(PKG)
    assert not circles, "import circles:\n" + "\n".join(_circle_text(c, PKG) for c in circles)


def test_the_architecture_table_carries_the_ranks_in_order():
    rows = _architecture_ranks(ARCHITECTURE.read_text())
    names = [n for n, _ in rows]
    assert sorted(names) == sorted(RANK), (f"in RANK, not in the table: {sorted(set(RANK) - set(names))}; "
                                           f"in the table, not in RANK: {sorted(set(names) - set(RANK))}")
    wrong = [f"{n}: table {r}, RANK {RANK[n]}" for n, r in rows if RANK[n] != r]
    assert not wrong, "docs/architecture.md's ranks differ from RANK: " + "; ".join(wrong)
    ranks = [r for _, r in rows]
    assert ranks == sorted(ranks), f"docs/architecture.md's table is not in rank order: {rows}"



@contextlib.contextmanager
def _planted(tmp_path: Path, files: dict[str, str]) -> Iterator[Path]:
    """A package ``jointwear_ros`` of ``files`` (path -> text) in ``tmp_path``, read by the rules instead of the real one."""
    global PKG
    root = tmp_path / "jointwear_ros"
    for rel, text in files.items():
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        (root / rel).write_text(text)
    saved, PKG = PKG, root
    try:
        yield root
    finally:
        PKG = saved

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
        "workbench/bad_sentence.py": "def f():\n    from .phrases import shape_hint\n",
        "workbench/bad_render.py": "from . import render\n",
    }
    with _planted(tmp_path, planted) as root:
        for rel in planted:
            assert _violations(root / rel), f"no rule caught {rel}"
        (root / "workbench/report.py").write_text("from .render import noise_line\n")
        assert _violations(root / "workbench/report.py") == []  # the rendering side imports itself


def test_the_rank_and_circle_rules_catch_what_they_are_for(tmp_path):
    """An upward import, an import from the same rank, a package without a rank and a circle each fire, also
    when the import hides inside a function or under TYPE_CHECKING."""
    planted = {
        "model/__init__.py": "",
        "model/up.py": "def f():\n    from ..workbench.fit import fit_model\n",  # rank 3 -> 4
        "observer/__init__.py": "",
        "observer/same.py": "from ..workbench import diagnose\n",  # rank 4 -> 4
        "workbench/__init__.py": "",
        "workbench/fit.py": "from ..model import Model\n",  # downward: fine
        "newpkg/__init__.py": "",
        "trend/__init__.py": "",
        "trend/a.py": "from .b import x\n",
        "trend/b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import c\n",
        "trend/c.py": "def g():\n    from .a import y\n",
    }
    with _planted(tmp_path, planted) as root:
        assert "rank 3) imports jointwear_ros.workbench.fit" in "".join(_rank_violations(root / "model/up.py"))
        assert "rank 4) imports jointwear_ros.workbench" in "".join(_rank_violations(root / "observer/same.py"))
        assert _rank_violations(root / "workbench/fit.py") == []
        assert "'newpkg' has no rank" in "".join(_rank_violations(root / "newpkg/__init__.py"))
        circles = _circles(root)
        assert circles == [["jointwear_ros.trend.a", "jointwear_ros.trend.b", "jointwear_ros.trend.c"]]
        assert _circle_text(circles[0], root) == ("jointwear_ros.trend.a -> (line 1) jointwear_ros.trend.b -> "
                                                  "(line 3) jointwear_ros.trend.c -> (line 2) jointwear_ros.trend.a")


def test_the_table_check_reads_ranks_and_order():
    table = ("## Packages and concerns\n\n| module | rank | concern |\n|---|---|---|\n"
             "| `jointwear_ros/errors.py` | 0 | errors |\n| `jointwear_ros/io/` | 8 | io |\n"
             "| `jointwear_ros/model/` | 3 | model |\n\n## Next\n| `jointwear_ros/cli/` | 12 | x |\n")
    assert _architecture_ranks(table) == [("errors", 0), ("io", 8), ("model", 3)]
