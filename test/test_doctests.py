"""The examples in the pure modules' docstrings run and print what they say (docs stay true)."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import jointwear_ros

# the ROS adapters are exercised by the node tests (their docstrings hold no examples); __main__ runs the CLI
SKIP = ("jointwear_ros.nodes", "jointwear_ros.__main__")
MODULES = sorted(
    m.name for m in pkgutil.walk_packages(jointwear_ros.__path__, "jointwear_ros.")
    if not m.name.startswith(SKIP)
)


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} docstring examples in {name} failed"
