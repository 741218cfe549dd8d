"""The command line starts without its heavy parts (issue 29): ``jointwear --help`` and a command's
``--help`` import the command's module only, and that module imports scipy, matplotlib, SQLAlchemy
and rclpy inside its command functions, not at import. (How fast: bench/bench_cli_startup.py.)"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

from jointwear_ros.cli import COMMAND_MODULES, COMMANDS

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("scipy", "matplotlib", "sqlalchemy", "rclpy")
#: commands whose parser names the estimators (``--method`` help and choices): building it imports
#: jointwear_ros.estimation, whose package import brings scipy; matplotlib, SQLAlchemy and rclpy they
#: still leave out
NAME_THE_ESTIMATORS = {"commission", "cycle", "demo", "estimate", "fleet", "study"}


def _imported_after(code: str) -> set[str]:
    """The HEAVY top-level modules in sys.modules after ``code`` ran in a fresh interpreter."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(m for m in {HEAVY!r} if m in sys.modules)))"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return set(json.loads(r.stdout.splitlines()[-1]))


def _help(*lines: list[str]) -> str:
    """Code that runs ``jointwear WORDS`` for each of ``lines`` (their output thrown away)."""
    return ("import contextlib, io\nfrom jointwear_ros.cli import main\n"
            f"for words in {list(lines)!r}:\n"
            "    with contextlib.redirect_stdout(io.StringIO()):\n"
            "        try:\n            main(words)\n        except SystemExit:\n            pass")


def test_importing_the_cli_imports_none_of_the_heavy_parts():
    assert _imported_after("import jointwear_ros.cli") == set()


def test_jointwear_help_imports_none_of_the_heavy_parts():
    assert _imported_after(_help(["--help"])) == set()


def test_the_help_of_every_other_command_imports_none_of_the_heavy_parts():
    others = sorted(set(COMMANDS) - NAME_THE_ESTIMATORS)
    assert len(others) >= 7
    assert _imported_after(_help(*([c, "--help"] for c in others))) == set()


def test_the_help_of_the_commands_that_name_the_estimators_imports_only_scipy():
    assert _imported_after(_help(*([c, "--help"] for c in sorted(NAME_THE_ESTIMATORS)))) <= {"scipy"}


def test_the_command_table_is_what_the_modules_register():
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    registered: dict[str, tuple[str, str]] = {}
    for mod in COMMAND_MODULES:
        before = set(sub.choices)
        importlib.import_module(f"jointwear_ros.cli.{mod}").register(sub)
        for name in set(sub.choices) - before:
            registered[name] = (mod, "")
    for action in sub._choices_actions:
        registered[action.dest] = (registered[action.dest][0], action.help)
    assert registered == COMMANDS


def test_a_command_line_builds_its_commands_parser_in_full():
    from jointwear_ros.cli import build_parser

    args = build_parser(["trend", "--db", "x.db"]).parse_args(["trend", "--db", "x.db"])
    assert args.command == "trend" and args.db == "x.db" and callable(args.func)
