"""README.md's commands of the walk's chain "demos" run in order: the other multi-joint demos (one joint after another, the independent-joint robot) (readme_walk.py)."""

from readme_walk import chain_tests

readme_walk, test_the_readme_commands_run_in_order = chain_tests("demos")
