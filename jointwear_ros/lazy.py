"""Names a package loads on first use (PEP 562), written once for every package that does it.

A package whose modules import scipy (``estimation``, ``commission``) lists its names and the module
of each; importing the package then imports none of them, so a command's parser can read a package's
light constants without the estimators' import cost (``jointwear --help``, docs/testing.md).

>>> import types
>>> ns = {}
>>> get, names = lazy_names("jointwear_ros", {"JointwearError": "errors"}, ns)
>>> get("JointwearError").__name__, "JointwearError" in ns, names()
('JointwearError', True, ['JointwearError'])
>>> get("nothing")
Traceback (most recent call last):
AttributeError: module 'jointwear_ros' has no attribute 'nothing'
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_names"]


def lazy_names(package: str, names: Mapping[str, str],
               namespace: dict[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` of ``package``: each name of ``names`` (name -> module of the package) is
    imported from its module on first use and kept in ``namespace`` (the package's ``globals()``)."""

    def __getattr__(name: str) -> Any:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__
