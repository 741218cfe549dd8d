"""The ``jointwear`` command line: a thin adapter over the core.

Each sub-command lives in its own module ``*_cmd.py`` in this package with a
``register(subparsers)`` function. :data:`COMMANDS` names them (command -> module, one-line
help): :func:`main` imports only the module of the command on the line (``jointwear --help``
imports none), and each module imports its heavy parts (scipy, the estimators, rclpy,
SQLAlchemy, matplotlib) inside its command functions, so any ``--help`` answers at once
(bench/bench_cli_startup.py). :func:`build_parser` without ``argv`` builds the whole parser. Any
:class:`~jointwear_ros.errors.JointwearError` becomes a one-line message on
stderr and exit code 2, as do argument errors; sub-commands check their
arguments (output paths included) before they start any work. An error of the
environment met half-way (disk full, out of memory) is one line and exit code 2
too; an unexpected error (a bug) is one line and exit code 1. ``--verbose``
adds the traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import re
import sys
import traceback
from collections.abc import Sequence
from typing import Any

from ..errors import JointwearError, one_line

__all__ = ["COMMANDS", "COMMAND_MODULES", "UsageError", "build_parser", "main"]

#: Modules (relative to this package) that register sub-commands.
COMMAND_MODULES: tuple[str, ...] = tuple(
    sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name.endswith("_cmd"))
)

#: Every top-level command: the module that registers it and its line in ``jointwear --help``
#: (test_cli_startup.py checks this table against what the modules register).
COMMANDS: dict[str, tuple[str, str]] = {
    "bag": ("bag_cmd", "inspect and recover rosbag2 (MCAP) bags"),
    "commission": ("commission_cmd", "identify a joint's nominal friction model from its baseline cycles"),
    "cycle": ("cycle_cmd", "test-cycle design: which speeds to measure"),
    "data": ("data_cmd", "synthetic observation tables with hidden effects; inspect a table"),
    "demo": ("demo_cmd", "run the simulated cell: all nodes, one test cycle by service call, the wear estimate"),
    "estimate": ("commission_cmd", "wear estimate of every test cycle with a parameter set"),
    "fleet": ("fleet_cmd", "a fleet's wear history: re-analyse bags on Dask, compare versions, a page"),
    "history": ("history_cmd", "the wear history store: import bags/CSV, export CSV, maintenance events"),
    "model": ("model_cmd", "evaluate, fit and diagnose the friction model"),
    "replay": ("replay_cmd", "re-run the friction observer and wear estimator on a recorded bag (offline), "
               "or play it"),
    "serve": ("serve_cmd", "live web page, /api/joints and Prometheus /metrics over the history store"),
    "study": ("study_cmd", "the paper's Section 5.1 simulation study, robustness, and a Section 6 style "
              "case study"),
    "trend": ("trend_cmd", "wear trend and time to alarm of every joint in the history"),
}

EXIT_USAGE = 2
EXIT_INTERNAL = 1


class UsageError(JointwearError):
    """A command-line argument is malformed or out of range."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit code 2.

    A value that starts with a minus sign is a value, not an option, when it is a number, a range or
    a list of numbers (``--position -2.5:2.5``, ``--speeds -5,5``): argparse alone knows only
    ``-2`` and ``-2.5``.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-\d*\.?\d+(?:[eE][-+]?\d+)?(?:[:,]-?\d*\.?\d+(?:[eE][-+]?\d+)?)*$")

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _command_word(argv: Sequence[str]) -> str | None:
    """The command of a command line: its first word that is not a top-level option."""
    return next((w for w in argv if not w.startswith("-")), None)


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The ``jointwear`` parser: every command in full, or, given the command line ``argv``, in full only
    the commands of the module of its command (the others by name and help line, enough for ``--help``)."""
    parser = _Parser(
        prog="jointwear",
        description="Robot-joint wear diagnosis from static friction (ROS 2 Jazzy).",
    )
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="on an error, print the traceback as well as the one-line message")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    if argv is None:
        modules = list(COMMAND_MODULES)
    else:
        word = _command_word(argv)
        modules = [COMMANDS[word][0]] if word in COMMANDS else []
    for mod in modules:
        importlib.import_module(f"{__name__}.{mod}").register(sub)
    for name, (_, text) in COMMANDS.items():
        if name not in sub.choices:
            sub.add_parser(name, help=text)
    # argparse lists the commands in the order they were added: by name, as before
    sub._choices_actions.sort(key=lambda a: a.dest)
    return parser


def _fail(args: argparse.Namespace, message: str, code: int) -> int:
    if getattr(args, "verbose", False):
        traceback.print_exc(file=sys.stderr)
    print(f"jointwear: {one_line(message)}", file=sys.stderr)
    return code


def main(argv: Sequence[str] | None = None) -> int:
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser([w for w in words if w != "--verbose"])
    # --verbose is accepted anywhere on the line, not only before the sub-command
    verbose = "--verbose" in words
    args = parser.parse_args([w for w in words if w != "--verbose"])
    args.verbose = bool(args.verbose or verbose)
    try:
        rc = args.func(args)
    except JointwearError as exc:
        return _fail(args, f"error: {exc}", EXIT_USAGE)
    except MemoryError:
        return _fail(args, "error: out of memory; ask for a smaller job (fewer runs, speeds, cycles or samples)",
                     EXIT_USAGE)
    except BrokenPipeError:  # output piped into head, less, ...: not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except OSError as exc:  # disk full, a file removed under us, ...: the environment, not a bug
        where = f"{exc.filename}: " if exc.filename else ""
        return _fail(args, f"error: {where}{exc.strerror or exc}", EXIT_USAGE)
    except KeyboardInterrupt:
        print("jointwear: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # a bug: say so in one line; --verbose shows where
        hint = "" if getattr(args, "verbose", False) else " (run with --verbose for the traceback)"
        return _fail(args, f"internal error: {type(exc).__name__}: {exc}{hint}", EXIT_INTERNAL)
    return int(rc or 0)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
