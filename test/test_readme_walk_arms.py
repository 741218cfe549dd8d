"""README.md's commands of the walk's chain "arms" run in order: the Panda's demo and the UR5's with a payload (readme_walk.py)."""

from readme_walk import chain_tests

readme_walk, test_the_readme_commands_run_in_order = chain_tests("arms")
