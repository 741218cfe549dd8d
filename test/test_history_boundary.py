"""The storage boundary (issue 29, item 4): the history package owns all storage IO. No module outside
``jointwear_ros/history/`` imports a database library, reaches for a store's engine or carries SQL text; the
fleet ledger, the fleet page and ``jointwear serve`` ask the store for what they read and write."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import jointwear_ros

PKG = Path(jointwear_ros.__file__).resolve().parent
HISTORY = PKG / "history"
#: database libraries: SQLAlchemy and the drivers behind it
DB_MODULES = ("sqlalchemy", "sqlite3", "psycopg", "psycopg2")
#: SQL statements as they are written in a query (upper-case keywords)
SQL = re.compile(r"\b(SELECT\b[^.]*\bFROM|INSERT\s+INTO|DELETE\s+FROM|UPDATE\s+\w+\s+SET|CREATE\s+(TABLE|INDEX)"
                 r"|ALTER\s+TABLE|DROP\s+TABLE|PRAGMA\s+\w+|ON\s+CONFLICT|GROUP\s+BY)\b")


def _outside_history() -> list[Path]:
    return sorted(p for p in PKG.rglob("*.py") if HISTORY not in p.parents)


def _leaks(path: Path) -> list[str]:
    """Each storage leak of one module, as ``name:line: what``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out: list[str] = []
    for node in ast.walk(tree):
        names: list[str] = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
        out += [f"{path.name}:{node.lineno}: imports {n}" for n in names if n.split(".")[0] in DB_MODULES]
        if isinstance(node, ast.Attribute) and node.attr == "engine":
            out.append(f"{path.name}:{node.lineno}: reaches for a store's .engine")
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and (m := SQL.search(node.value)):
            out.append(f"{path.name}:{node.lineno}: SQL text {m.group(0)!r}")
    return sorted(out, key=lambda x: int(x.split(":")[1]))


def test_no_module_outside_history_imports_a_database_library_or_holds_sql():
    leaks = [f"{p.parent.relative_to(PKG.parent)}/{x}" for p in _outside_history() for x in _leaks(p)]
    assert not leaks, "storage IO outside jointwear_ros/history/:\n" + "\n".join(leaks)


def test_the_check_finds_each_kind_of_leak(tmp_path):
    """The scan itself: an import of a driver, a query string and a store's engine are each found."""
    probe = tmp_path / "probe.py"
    probe.write_text("import sqlite3\nfrom sqlalchemy import select\n"
                     "Q = 'SELECT robot, joint FROM estimates GROUP BY robot'\n"
                     "def f(store):\n    return store.engine.connect()\n", encoding="utf-8")
    found = _leaks(probe)
    assert [x.split(": ", 1)[1] for x in found] == [
        "imports sqlite3", "imports sqlalchemy", "SQL text 'SELECT robot, joint FROM'", "reaches for a store's .engine"]


def test_prose_about_a_history_is_not_taken_for_sql(tmp_path):
    probe = tmp_path / "prose.py"
    probe.write_text('"""Select the joints from the history; insert a maintenance event into the store."""\n',
                     encoding="utf-8")
    assert _leaks(probe) == []
