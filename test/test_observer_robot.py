"""The robot observer and robot monitor: the per-joint routing the nodes and replay share, and the status type."""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from jointwear_ros.contract import CyclePhase, CycleState, CycleStatus, status_from_msg, status_to_msg
from jointwear_ros.monitor import MonitorConfig, RobotMonitor
from jointwear_ros.observer import FrictionObserverCore, ObserverConfig, RobotObserver, observe_arrays
from jointwear_ros.observer.synthetic import synthetic_cycle

JOINTS = ("joint_1", "joint_2", "joint_3")


def _robot(joints=JOINTS) -> RobotObserver:
    return RobotObserver({j: ObserverConfig(joint_name=j) for j in joints})


def _feed_robot(robot: RobotObserver, cyc, joint: str, offset: int):
    """One joint's synthetic cycle through the robot observer in a 3-joint JointState (its column at ``offset``)."""
    names = [JOINTS[(offset + k) % 3] for k in range(3)]
    col = names.index(joint)
    out = []
    events = [(s.stamp, 0, replace(s, joint_name=joint)) for s in cyc.statuses] + [(float(t), 1, i) for i, t in enumerate(cyc.stamps)]
    for _, kind, a in sorted(events, key=lambda e: (e[0], e[1])):
        if kind == 0:
            routed = robot.on_status(a, now=0.0)
            assert routed is not None and routed.joint == joint
            out += routed.output.observations
        else:
            pos, vel, eff = [0.0] * 3, [0.0] * 3, [0.0] * 3
            pos[col], vel[col], eff[col] = cyc.position[a], cyc.velocity[a], cyc.effort[a]
            js = robot.on_joint_state(float(cyc.stamps[a]), names, pos, vel, eff, now=0.0)
            assert js.used
            out += [o for r in js.outputs if r.joint == joint for o in r.output.observations]
    out += [o for r in robot.flush() if r.joint == joint for o in r.output.observations]
    return out


def test_a_joint_split_out_of_a_robot_state_gives_what_its_own_core_gives():
    cyc = synthetic_cycle((20.0, 40.0, 80.0), seed=3)
    alone = observe_arrays(ObserverConfig(joint_name="joint_2"), cyc.stamps, cyc.position, cyc.velocity, cyc.effort,
                           [replace(s, joint_name="joint_2") for s in cyc.statuses]).observations
    routed = _feed_robot(_robot(), cyc, "joint_2", offset=1)
    assert len(alone) == 3 and [o.speed for o in routed] == [o.speed for o in alone]
    assert [(o.tau_f, o.tau_f_std, o.joint_name) for o in routed] == [(o.tau_f, o.tau_f_std, o.joint_name) for o in alone]


@pytest.mark.parametrize(("name", "served", "expected"), [
    ("", ("joint_1",), "joint_1"),      # empty name: the joint of a one-joint setup
    ("", JOINTS, None),                 # ... but no joint of a robot
    ("joint_3", JOINTS, "joint_3"),
    ("joint_9", JOINTS, None),          # not served
])
def test_statuses_and_temperatures_route_by_name(name, served, expected):
    robot = _robot(served)
    st_ = CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=2, current_speed=20.0, joint_name=name)
    routed = robot.on_status(st_, now=5.0)
    assert (routed.joint if routed else None) == expected
    t = robot.on_temperature(5.0, name, 40.0, now=5.0)
    assert (t.joint if t else None) == expected
    mon = RobotMonitor({j: MonitorConfig(joint_name=j) for j in served})
    assert mon.route(name) == expected
    assert (mon.on_status(st_, now=5.0) is None) == (expected is None)


def test_unusable_joint_states_say_why_and_feed_nothing():
    robot = _robot(("joint_1", "joint_2"))
    assert "none of the joints" in robot.on_joint_state(1.0, ["a"], [0.0], [0.0], [0.0], 1.0).unusable
    assert "no effort" in robot.on_joint_state(1.0, ["joint_1"], [0.0], [0.0], [], 1.0).unusable
    assert "array lengths" in robot.on_joint_state(1.0, ["joint_1", "x"], [0.0], [0.0, 0.0], [0.0, 0.0], 1.0).unusable
    one = _robot(("joint_1",))
    assert "set joint_name" in one.on_joint_state(1.0, ["a"], [0.0], [0.0], [0.0], 1.0).unusable
    assert all(c.samples_seen == 0 for c in (*robot.cores.values(), *one.cores.values()))


def test_a_non_finite_value_skips_that_joint_only_and_a_name_given_twice_counts_by_its_first_entry():
    robot = _robot(("joint_1", "joint_2"))
    js = robot.on_joint_state(1.0, ["joint_1", "joint_2", "joint_1"], [math.nan, 0.5, 9.0], [0.0, 0.1, 9.0],
                              [0.0, 0.2, 9.0], 1.0)
    assert js.used and [j for j, _ in js.skipped] == ["joint_1"] and "non-finite" in js.skipped[0][1]
    assert (robot.cores["joint_1"].samples_seen, robot.cores["joint_2"].samples_seen) == (0, 1)
    assert js.new_names and not robot.on_joint_state(2.0, ["joint_1", "joint_2", "joint_1"], [0.0] * 3, [0.0] * 3,
                                                     [0.0] * 3, 2.0).new_names


def test_a_joint_missing_while_it_is_tested_is_a_fault_and_a_stampless_message_takes_the_receivers_clock():
    robot = _robot(("joint_1", "joint_2"))
    robot.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=2, current_speed=20.0,
                                window_half_width=0.1, joint_name="joint_2", stamp=1.0), now=1.0)
    js = robot.on_joint_state(0.0, ["joint_1"], [0.0], [0.0], [0.0], now=7.5)
    assert js.missing == ("joint_2",) and js.skipped and "while it is being tested" in js.skipped[0][1]
    core: FrictionObserverCore = robot.cores["joint_1"]
    assert core.samples_seen == 1 and core.buffered_samples == 1


_names = st.text(alphabet="abcdefghij_0123456789", min_size=0, max_size=12)


@settings(max_examples=60, deadline=None)
@given(cycle_id=st.integers(0, 2**32 - 1), state=st.integers(0, 255), phase=st.integers(0, 255),
       speed=st.floats(allow_nan=False, allow_infinity=False, width=64), done=st.integers(0, 2**32 - 1),
       total=st.integers(0, 2**32 - 1), joint=_names, joints=st.lists(_names, max_size=4),
       sec=st.integers(0, 2**31 - 1), nsec=st.integers(0, 999_999_999))
def test_the_status_type_round_trips_the_message(cycle_id, state, phase, speed, done, total, joint, joints, sec, nsec):
    def msg_type():
        return SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(sec=0, nanosec=0)))

    msg = msg_type()
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nsec
    for k, v in dict(cycle_id=cycle_id, state=state, phase=phase, current_speed=speed, speeds_done=done,
                     speeds_total=total, window_center=0.25, window_half_width=0.1, message="m", joint_name=joint,
                     joints=joints, joints_done=1).items():
        setattr(msg, k, v)
    got = status_from_msg(msg)
    assert (got.cycle_id, int(got.state), int(got.phase), got.current_speed, got.joints) == (
        cycle_id, state, phase, speed, tuple(joints))
    assert isinstance(got.state, CycleState) == (state <= 4) and isinstance(got.phase, CyclePhase) == (phase <= 4)
    back = status_to_msg(got, msg_type)
    for k in ("cycle_id", "state", "phase", "current_speed", "speeds_done", "speeds_total", "message", "joint_name",
              "joints_done"):
        assert getattr(back, k) == getattr(msg, k), k
    assert back.joints == list(joints)
    assert abs((back.header.stamp.sec + 1e-9 * back.header.stamp.nanosec) - (sec + 1e-9 * nsec)) <= 1e-6 * max(1, sec)
    assert np.isclose(got.stamp, sec + 1e-9 * nsec)
