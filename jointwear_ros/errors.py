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
