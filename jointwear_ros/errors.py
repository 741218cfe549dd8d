"""Errors of jointwear: one root, specific subclasses.

Messages say what was wrong (the value), what was expected, and what to do.
The CLI turns any :class:`JointwearError` into a one-line message and exit
code 2; nodes log it and keep running.

>>> issubclass(InputDataError, JointwearError), issubclass(ParameterSetError, JointwearError)
(True, True)
>>> try:
...     raise InputDataError("obs.csv: column 'speed', row 2: -5 is negative")
... except JointwearError as exc:
...     print(f"jointwear: error: {exc}")
jointwear: error: obs.csv: column 'speed', row 2: -5 is negative
"""

from __future__ import annotations

__all__ = [
    "InputDataError",
    "JointwearError",
    "ModelError",
    "ParameterError",
    "ParameterSetError",
    "TransientError",
    "one_line",
]


class JointwearError(Exception):
    """Root of every error jointwear raises on purpose."""


class ModelError(JointwearError):
    """A model or term was built or evaluated wrongly (unknown term, name clash, missing input)."""


class ParameterError(JointwearError):
    """A parameter value is missing, not finite, or outside its bounds."""


class ParameterSetError(JointwearError):
    """A named parameter set could not be found or read."""


class InputDataError(JointwearError):
    """Input data from outside (CSV, bag, message, argument) is malformed."""


class TransientError(JointwearError):
    """A resource stayed busy through every retry (a database deadlock, a lock another writer held): nothing
    was wrong with the input, and running again may succeed. The CLI's exit code is 2, like every error here."""


def one_line(what: BaseException | str) -> str:
    """The one line that tells a user what went wrong: the one place that makes it (the CLI's
    ``jointwear: error: ...``, the history store's, serve's and the fleet's messages).

    An error: the first line of its message (a database driver's own message when a wrapper carries it
    as ``orig``, as SQLAlchemy's errors do: not the wrapper's statement and parameters), else the error's
    type name. A text (a message built around an error, as the CLI's): all its words, its line breaks
    and runs of spaces made single spaces.

    >>> one_line(ValueError("disk full\\n[SQL: INSERT ...]")), one_line(KeyError()), one_line(OSError("  "))
    ('disk full', 'KeyError', 'OSError')
    >>> one_line("error: obs.csv:\\n  row 2 is empty")
    'error: obs.csv: row 2 is empty'
    """
    if isinstance(what, str):
        return " ".join(what.split())
    orig = getattr(what, "orig", None)
    lines = str(orig if isinstance(orig, BaseException) else what).strip().splitlines()
    return lines[0].strip() if lines else type(what).__name__
