"""README.md's commands of the walk's chain "offline" run in order: the commands without a ROS graph: synthetic tables, commissioning, the workbench, studies, curves (readme_walk.py)."""

from readme_walk import chain_tests

readme_walk, test_the_readme_commands_run_in_order = chain_tests("offline")
