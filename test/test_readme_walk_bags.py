"""README.md's commands of the walk's chain "bags" run in order: the six-joint and the one-joint demos, then every command that reads their bags or the history made from them (readme_walk.py)."""

from readme_walk import chain_tests

readme_walk, test_the_readme_commands_run_in_order = chain_tests("bags")
