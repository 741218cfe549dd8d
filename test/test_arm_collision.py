"""Sweeps that cannot hit the arm itself or the table: the collision check of ``jointwear_ros.sim.collision``.

The checker is the arm's URDF collision meshes (convex hulls) in Pinocchio, the SRDF's never-colliding pairs off,
and the table (z = 0 of the base frame); 1 cm clearance between links and from the table. The cycles are the
cell's of ``jointwear demo --joints N --arm ARM`` (``simcell.cycle_settings``), planned from the arm's test pose.
"""

from __future__ import annotations

import math

import pytest

from jointwear_ros.contract import RefusalReason
from jointwear_ros.cycle import CycleRequestError, plan_line_cycle, plan_robot_cycle
from jointwear_ros.cycle.plan import DEFAULT_SPEEDS
from jointwear_ros.errors import ParameterError
from jointwear_ros.sim.collision import TABLE, check_plan, collision_checker
from jointwear_ros.simcell import cycle_settings

ARMS = {"ur5": 6, "panda": 7}


def _names(n: int) -> list[str]:
    return [f"joint_{i}" for i in range(1, n + 1)]


def _cell(arm: str, **cycle):
    checker = collision_checker(arm, ARMS[arm])
    names = _names(ARMS[arm])
    cycles, _ = cycle_settings(arm, names, **cycle)
    return checker, names, cycles, dict(zip(names, checker.home, strict=True))


@pytest.mark.parametrize("arm", list(ARMS))
def test_each_arms_test_pose_is_clear_of_itself_and_the_table(arm):
    checker = collision_checker(arm, ARMS[arm])
    assert checker.check(checker.home) is None
    assert checker.closest(checker.home).margin > 0.0
    assert collision_checker(arm, ARMS[arm]) is checker  # built once


def test_the_ur5_elbow_folded_into_its_upper_arm_is_a_collision_with_the_links_named():
    checker = collision_checker("ur5", 6)
    folded = list(checker.home)
    folded[2] = 3.1
    c = checker.check(folded)
    assert c is not None and c.collides and c.distance < 0.0
    assert {c.first, c.second} == {"upper_arm_link", "wrist_1_link"}
    assert "upper_arm_link and wrist_1_link overlap by" in c.describe() and "3.100" in c.describe()


def test_a_panda_pose_through_the_table_is_a_collision_with_the_table():
    checker = collision_checker("panda", 7)
    down = list(checker.home)
    down[1] = 1.5  # leaning forward, the forearm bent down
    c = checker.check(down)
    assert c is not None and c.second == TABLE and c.distance < 0.0
    assert c.first.startswith("panda_") and "into the table" in c.describe()


def test_a_sweep_through_a_collision_is_caught_at_its_first_configuration_too_close_with_the_links_named():
    checker = collision_checker("ur5", 6)
    folded = list(checker.home)
    folded[2] = 3.1
    c = checker.check_sweep(checker.home, folded)
    assert c is not None and c.collides
    assert c.first == "upper_arm_link" and c.second.startswith("wrist_")
    elbow = c.q[2]
    assert checker.home[2] < elbow < 3.1  # before the folded end: the first sample too close
    # the sample before it (one step back) was still clear: it is the first
    before = list(c.q)
    before[2] = elbow - 0.02 * (3.1 - checker.home[2]) / abs(3.1 - checker.home[2])
    assert checker.check(before) is None
    assert checker.check_sweep(checker.home, checker.home) is None


@pytest.mark.parametrize(("arm", "together"), [("ur5", False), ("panda", False), ("panda", True)])
def test_the_default_cycles_clear_the_arm_and_the_table(arm, together):
    """Every step's approach and sweep of the cell's default cycle (8 speeds, 10-160 rad/s), from the test pose."""
    checker, names, cycles, here = _cell(arm)
    plan = plan_line_cycle(cycles, start_positions=here) if together else plan_robot_cycle(cycles, start_positions=here)
    clear = check_plan(checker, plan, cycles, names, here)
    assert clear.contact.margin > 0.0 and not clear.contact.collides, clear.describe()


def test_on_the_ur5_every_joint_at_once_clears_up_to_120_rad_s_and_at_160_with_a_faster_run_up():
    """At 160 rad/s every joint runs ±1.11 rad at once (window, run-up at 4 rad/s² and 0.3 s steady, stopping
    allowance): the forearm and wrist pitch 2.2 and 3.3 rad along the line and reach the table from any pose that
    loads the shoulder and elbow. The steps up to 120 rad/s clear; 160 does at 8 rad/s², 0.2 s steady, the arm
    cell's settings (simcell.ARM_ACCELERATION, ARM_STEADY_TIME)."""
    checker, names, cycles, here = _cell("ur5", acceleration=4.0, steady_time=0.3)
    slower = plan_line_cycle(cycles, speeds=DEFAULT_SPEEDS[:-1], start_positions=here)
    assert check_plan(checker, slower, cycles, names, here).contact.margin > 0.0
    with pytest.raises(CycleRequestError, match=r"^step 8 \(160 rad/s\), sweep: wrist_1_link comes within .* of the "
                       r"table .* at q = \[.*\] rad \(clearance 1 cm, arm ur5\); narrow the speeds or move the window "
                       r"centres$") as exc:
        check_plan(checker, plan_line_cycle(cycles, start_positions=here), cycles, names, here)
    assert exc.value.reason == RefusalReason.BAD_REQUEST
    checker, names, cycles, here = _cell("ur5")  # the arm cell's own settings
    assert (cycles["joint_1"].acceleration, cycles["joint_1"].steady_time) == (8.0, 0.2)
    assert check_plan(checker, plan_line_cycle(cycles, start_positions=here), cycles, names, here).contact.margin > 0.0


def test_a_request_whose_path_would_collide_is_refused_before_anything_moves_naming_step_links_and_configuration():
    checker, names, cycles, here = _cell("ur5", acceleration=4.0, steady_time=0.3)
    # the shoulder's window moved down to -0.4 rad (inside its limits [-2.9, 0.3]): the wrist reaches the table
    plan = plan_robot_cycle(cycles, ["joint_2"], [40.0], [-0.4], here)
    with pytest.raises(CycleRequestError, match=r"^joint_2, speed #1 \(40 rad/s\): wrist_\d_link (goes .* into|comes "
                       r"within .* of) the table \(z = 0 of the base\) at q = \[0\.000, -0\.\d{3}, 0\.300, 0\.700, "
                       r"0\.000, 0\.000\] rad \(clearance 1 cm, arm ur5\); narrow the speeds or move the window "
                       r"centres$") as exc:
        check_plan(checker, plan, cycles, names, here)
    assert exc.value.reason == RefusalReason.BAD_REQUEST
    # the same window where the pose puts it is clear; the approach from where the arm stands is checked too
    assert check_plan(checker, plan_robot_cycle(cycles, ["joint_2"], [40.0], None, here), cycles, names, here)
    # every joint at once: the shoulder's and elbow's windows moved down, the line's sweep reaches the table
    line = plan_line_cycle(cycles, ["joint_2", "joint_3"], [40.0], [-0.5, 0.3], here)
    with pytest.raises(CycleRequestError, match=r"^step 1 \(40 rad/s\), sweep: wrist_2_link goes 0\.7 cm into the table"):
        check_plan(checker, line, cycles, names, here)
    # the arm standing with its wrist at the table: the approach from there is refused at its first configuration
    low = {**here, "joint_2": 0.0}
    line = plan_line_cycle(cycles, ["joint_2", "joint_3"], [40.0], None, low)
    with pytest.raises(CycleRequestError, match=r"^step 1 \(40 rad/s\), approach: wrist_2_link goes 11\.7 cm into the "
                       r"table \(z = 0 of the base\) at q = \[0\.000, 0\.000, 0\.300,"):
        check_plan(checker, line, cycles, names, low)


def test_a_plan_check_needs_every_driven_joints_position_and_the_checkers_joints():
    checker, names, cycles, here = _cell("ur5")
    plan = plan_robot_cycle(cycles, ["joint_1"], [40.0], None, here)
    with pytest.raises(CycleRequestError, match=r"^no position of joint_4 to check") as exc:
        check_plan(checker, plan, cycles, names, {**here, "joint_4": math.nan})
    assert exc.value.reason == RefusalReason.STATE_MISSING
    with pytest.raises(ParameterError, match=r"5 driven joints, the checker has 6"):
        check_plan(checker, plan, cycles, names[:5], here)
    with pytest.raises(ParameterError, match=r"arm ur5: 7 driven joints; it has 6"):
        collision_checker("ur5", 7)
