"""The robot observer's health: what is counted, for which joint, and when "this cycle" restarts.

The friction_observer node publishes these counts as its ``friction_observer: <joint>`` statuses; here they are
plain state of :class:`~jointwear_ros.observer.RobotObserver`, fed without ROS.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from jointwear_ros.contract import CycleState, CycleStatus, DiagnosticLevel
from jointwear_ros.observer import ObserverConfig, RobotObserver
from jointwear_ros.observer.synthetic import synthetic_cycle

JOINTS = ("joint_1", "joint_2")


def _robot() -> RobotObserver:
    return RobotObserver({j: ObserverConfig(joint_name=j) for j in JOINTS})


def _values(robot: RobotObserver, joint: str) -> dict[str, str]:
    return dict(robot.health_report(joint).values)


def _feed(robot: RobotObserver, cyc, joint: str, temperatures=None) -> list:
    """A one-joint synthetic cycle as ``joint``'s column of two-joint JointStates, its statuses and temperatures in
    stamp order; returns every Routed."""
    col = JOINTS.index(joint)
    temps = cyc.temperatures if temperatures is None else temperatures
    events = [(s.stamp, 0, replace(s, joint_name=joint)) for s in cyc.statuses]
    events += [(t, 1, (t, c)) for t, c in temps]
    events += [(float(t), 2, i) for i, t in enumerate(cyc.stamps)]
    routed = []
    for _, kind, a in sorted(events, key=lambda e: (e[0], e[1])):
        if kind == 0:
            routed.append(robot.on_status(a, now=0.0))
        elif kind == 1:
            routed.append(robot.on_temperature(a[0], joint, a[1], now=0.0))
        else:
            pos, vel, eff = [0.0, 0.0], [0.0, 0.0], [1.0, 1.0]
            pos[col], vel[col], eff[col] = cyc.position[a], cyc.velocity[a], cyc.effort[a]
            routed += robot.on_joint_state(float(cyc.stamps[a]), list(JOINTS), pos, vel, eff, now=0.0).outputs
    return routed + robot.flush()


@pytest.fixture(scope="module")
def cycle():
    return synthetic_cycle(speeds=(20.0, 40.0), rate=1000.0, seed=5, temperature_rate=5.0)


def test_a_new_robot_observer_is_ok_with_every_count_zero():
    robot = _robot()
    for j in JOINTS:
        report = robot.health_report(j)
        assert report.level == DiagnosticLevel.OK and report.message == "0 observation(s), 0 window(s) rejected in all"
        v = dict(report.values)
        assert (v["observations"], v["rejected_windows"], v["bad_messages"], v["joint_missing"], v["cycle_id"]) == (
            "0", "0", "0", "0", "0")


def test_a_joint_state_unusable_as_a_whole_is_one_bad_message_for_every_joint():
    robot = _robot()
    js = robot.on_joint_state(1.0, list(JOINTS), [0.0, 0.0], [0.0, 0.0], [], now=1.0)
    assert not js.used and robot.bad_messages == {"no effort": 1}
    for j in JOINTS:
        report = robot.health_report(j)
        assert report.level == DiagnosticLevel.WARN and "latest: bad JointState: no effort" in report.message
        assert _values(robot, j)["bad_messages"] == "1"


def test_a_non_finite_value_is_a_bad_message_of_its_joint_only_and_a_joint_left_out_counts_as_missing():
    robot = _robot()
    robot.on_joint_state(1.0, ["joint_1", "joint_2"], [0.0, float("nan")], [0.0, 0.0], [0.0, 0.0], now=1.0)
    robot.on_joint_state(2.0, ["joint_1"], [0.0], [0.0], [0.0], now=2.0)
    assert sum(robot.bad_messages.values()) == 1
    one, two = _values(robot, "joint_1"), _values(robot, "joint_2")
    assert (one["bad_messages"], one["joint_missing"], one["samples_seen"]) == ("0", "0", "2")
    assert (two["bad_messages"], two["joint_missing"], two["samples_seen"]) == ("1", "1", "0")
    assert robot.health_report("joint_1").level == DiagnosticLevel.OK
    assert "non-finite value for joint_2" in robot.health_report("joint_2").message


def test_statuses_and_temperatures_of_joints_not_served_are_counted_and_named():
    robot = _robot()
    assert robot.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, joint_name="joint_9"), now=1.0) is None
    assert robot.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING), now=1.0) is None  # no name, two joints
    assert robot.on_temperature(1.0, "joint_7", 40.0, now=1.0) is None
    assert robot.ignored_messages == 3 and robot.unknown_joints == {"joint_9", "", "joint_7"}
    assert all(_values(robot, j)["ignored_messages"] == "3" for j in JOINTS)
    assert all(robot.health_report(j).level == DiagnosticLevel.OK for j in JOINTS)  # not a fault of a served joint


def test_observations_and_rejected_windows_count_for_their_joint_and_a_new_cycle_restarts_its_cycle_counts(cycle):
    robot = _robot()
    _feed(robot, cycle, "joint_1")
    moved = replace(cycle, statuses=[replace(s, cycle_id=2, window_center=1.0) for s in cycle.statuses])
    _feed(robot, moved, "joint_2")  # the window where the joint never is: every speed rejected
    one, two = _values(robot, "joint_1"), _values(robot, "joint_2")
    assert (one["observations"], one["rejected_windows"], one["cycle_id"]) == ("2", "0", "1")
    assert (two["observations"], two["rejected_windows"], two["cycle_id"]) == ("0", "2", "2")
    assert robot.observations == 2 and robot.rejections_total == 2 and len(robot.rejections) == 2
    assert all(r.startswith("joint_2: ") for r in robot.rejections)
    assert robot.health_report("joint_1").level == DiagnosticLevel.OK
    report = robot.health_report("joint_2")
    assert report.level == DiagnosticLevel.WARN and report.message.startswith("cycle 2: 2 window(s) rejected")
    assert "latest: window rejected: " in report.message

    # a status of another joint, or without a cycle id, restarts nothing
    robot.on_status(CycleStatus(cycle_id=3, state=CycleState.IDLE, joint_name="joint_1"), now=0.0)
    robot.on_status(CycleStatus(cycle_id=0, state=CycleState.IDLE, joint_name="joint_2"), now=0.0)
    assert robot.health_report("joint_2").level == DiagnosticLevel.WARN
    # joint_2's next cycle: its cycle counts restart, its totals stay
    robot.on_status(CycleStatus(cycle_id=4, state=CycleState.IDLE, joint_name="joint_2"), now=0.0)
    report = robot.health_report("joint_2")
    v = dict(report.values)
    assert report.level == DiagnosticLevel.OK and report.message == "0 observation(s), 2 window(s) rejected in all"
    assert (v["cycle_id"], v["rejected_windows"], v["rejected_windows_this_cycle"]) == ("4", "2", "0")
    assert _values(robot, "joint_1")["cycle_id"] == "3"
    assert _values(robot, "joint_1")["observations_this_cycle"] == "0"


def test_lost_messages_count_once_from_the_reported_total_and_are_every_joints_problem():
    robot = _robot()
    assert robot.lost("/joint_states", 3) == 3
    assert robot.lost("/joint_states", 3) == 0  # the same report again (the events executor repeats it)
    assert robot.lost("/joint_states", 5) == 2 and robot.lost("/test_cycle/status", 1) == 1
    assert robot.lost_messages == {"/joint_states": 5, "/test_cycle/status": 1}
    for j in JOINTS:
        report = robot.health_report(j)
        assert report.level == DiagnosticLevel.WARN and "6 lost message(s)" in report.message
        assert "latest: 1 message(s) lost on /test_cycle/status" in report.message
        assert _values(robot, j)["lost_messages_this_cycle"] == "6"
    robot.on_status(CycleStatus(cycle_id=1, state=CycleState.IDLE, joint_name="joint_1"), now=0.0)
    assert robot.health_report("joint_1").level == DiagnosticLevel.OK  # its new cycle starts clean
    assert robot.health_report("joint_2").level == DiagnosticLevel.WARN


def test_a_speed_whose_temperature_never_came_is_noted_once_and_is_the_joints_latest_problem(cycle):
    first_end = next(s.stamp for s in cycle.statuses if s.speeds_done == 1)
    temps = [(t, c) for t, c in cycle.temperatures if t < first_end - 1.0]  # the sensor dies before speed 1 ends
    robot = _robot()
    notes = [r.note for r in _feed(robot, cycle, "joint_2", temperatures=temps) if r is not None and r.note]
    core = robot.cores["joint_2"]
    assert core.temperatures_missing >= 1 and len(notes) == core.temperatures_missing
    assert all("no temperature reading within temperature_wait" in n for n in notes)
    report = robot.health_report("joint_2")
    assert report.level == DiagnosticLevel.WARN and "no temperature reading" in report.message
    assert robot.health_report("joint_1").level == DiagnosticLevel.OK


def test_a_joint_is_busy_while_one_of_its_speeds_is_observed():
    robot = _robot()
    assert robot.busy_reason("joint_2") is None
    robot.on_status(CycleStatus(cycle_id=3, state=CycleState.RUNNING, current_speed=40.0, speeds_total=2,
                                window_half_width=0.1, joint_name="joint_2", stamp=1.0), now=1.0)
    assert robot.busy_reason("joint_2") == ("joint_2: cycle 3 speed #1 is being observed; change the observer "
                                            "settings between cycles")
    assert robot.busy_reason("joint_1") is None
