"""The ``jointwear`` command line: a thin adapter over the core.

Each sub-command lives in its own module ``*_cmd.py`` in this package with a
``register(subparsers)`` function; they are found at start-up. Any
:class:`~jointwear_ros.errors.JointwearError` becomes a one-line message on
stderr and exit code 2, as do argument errors.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
from collections.abc import Sequence

from ..errors import JointwearError

__all__ = ["COMMAND_MODULES", "UsageError", "build_parser", "main"]

#: Modules (relative to this package) that register sub-commands.
COMMAND_MODULES: tuple[str, ...] = tuple(
    sorted(m.name for m in pkgutil.iter_modules(__path__) if m.name.endswith("_cmd"))
)

EXIT_USAGE = 2


class UsageError(JointwearError):
    """A command-line argument is malformed or out of range."""


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose errors are one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="jointwear",
        description="Robot-joint wear diagnosis from static friction (ROS 2 Jazzy).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    for mod in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{mod}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        rc = args.func(args)
    except JointwearError as exc:
        print(f"jointwear: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("jointwear: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into head, less, ...: not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    return int(rc or 0)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
