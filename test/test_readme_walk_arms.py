"""README.md's commands of the walk's chain "arms" run in order: the Panda's demo and the UR5's with a payload (readme_walk.py)."""

from __future__ import annotations

import pytest
from readme_walk import chain_params, walk_fixture

readme_walk = walk_fixture("arms")


@pytest.mark.slow
@pytest.mark.ros
@pytest.mark.parametrize(("index", "line", "cmd"), **chain_params("arms"))
def test_the_readme_commands_run_in_order(readme_walk, index, line, cmd):
    """Each exits 0, the placeholders replaced by what the chain's earlier commands made."""
    failed = readme_walk.run(index)
    assert failed is None, failed
