"""README.md's commands of the walk's chain "bags" run in order: the six-joint and the one-joint demos, then every command that reads their bags or the history made from them (readme_walk.py)."""

from __future__ import annotations

import pytest
from readme_walk import chain_params, walk_fixture

readme_walk = walk_fixture("bags")


@pytest.mark.slow
@pytest.mark.ros
@pytest.mark.parametrize(("index", "line", "cmd"), **chain_params("bags"))
def test_the_readme_commands_run_in_order(readme_walk, index, line, cmd):
    """Each exits 0, the placeholders replaced by what the chain's earlier commands made."""
    failed = readme_walk.run(index)
    assert failed is None, failed
