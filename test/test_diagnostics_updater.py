"""The node kit's health pieces (nodes/diagnostics.py): Status merging, tasks, and an Updater on a real rclpy graph."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")

from conftest import spin_until  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402

from jointwear_ros.contract import DiagnosticLevel  # noqa: E402
from jointwear_ros.nodes.diagnostics import (  # noqa: E402
    CompositeTask,
    FunctionTask,
    HeldStatus,
    NodeDiagnostics,
    Status,
    Updater,
)

LEVELS = st.sampled_from(list(DiagnosticLevel))


@settings(deadline=None, derandomize=True)
@given(st.lists(st.tuples(LEVELS, st.text(max_size=8)), min_size=1, max_size=6))
def test_merged_status_has_the_highest_level_and_the_message_of_a_check_at_that_severity(checks):
    stat = Status("n: t")
    stat.summary(*checks[0])
    for level, message in checks[1:]:
        stat.merge_summary(level, message)
    assert stat.level == max(lv for lv, _ in checks)
    assert isinstance(stat.level, DiagnosticLevel)
    worst = [m for lv, m in checks if (lv > DiagnosticLevel.OK) == (stat.level > DiagnosticLevel.OK) and m]
    for m in worst:
        assert m in stat.message


def test_status_levels_are_the_contracts_and_a_level_outside_it_is_refused():
    stat = Status("n: t", level=2)
    assert stat.level is DiagnosticLevel.ERROR
    assert stat.to_msg().level == DiagnosticStatus.ERROR == b"\x02"
    with pytest.raises(ValueError):
        stat.summary(7, "no such level")


def test_composite_task_reports_its_parts_as_one_status_and_skips_parts_that_say_so():
    comp = CompositeTask("joint_1", [
        HeldStatus("a", level=DiagnosticLevel.OK, message="fine", values=[("x", "1")]),
        FunctionTask("b", lambda s: s.summary(DiagnosticLevel.WARN, "slow") or s.add("y", 2)),
        FunctionTask("c", lambda s: False),
    ])
    stat = Status("n: joint_1")
    assert comp.run(stat) is None
    assert (stat.level, stat.message, stat.values) == (DiagnosticLevel.WARN, "slow", [("x", "1"), ("y", "2")])
    assert CompositeTask("empty", [FunctionTask("c", lambda s: False)]).run(Status()) is False


@pytest.fixture
def graph(ros_context_per_test):
    ctx = ros_context_per_test
    ex = SingleThreadedExecutor(context=ctx)
    node = rclpy.create_node("jw_diag_kit", context=ctx)
    probe = rclpy.create_node("jw_diag_probe", context=ctx)
    ex.add_node(node)
    ex.add_node(probe)
    got: list[DiagnosticArray] = []
    probe.create_subscription(DiagnosticArray, "/jw_kit/diagnostics", got.append, 100)
    yield node, ex, got
    ex.shutdown()
    node.destroy_node()
    probe.destroy_node()


def test_updater_publishes_every_task_in_one_array_per_update_and_republishes_on_its_period(graph):
    node, ex, got = graph
    state = {"n": 0}
    up = Updater(node, "kit", hardware_id="cell_1", period=0.1, topic="/jw_kit/diagnostics")
    held = up.add(HeldStatus("robot", hardware_id="robot", message="idle"))
    up.add("joint_1", lambda s: s.summary(DiagnosticLevel.OK, f"n={state['n']}") or s.add("n", state["n"]))
    up.add("history", lambda s: False if state["n"] < 2 else s.summary(DiagnosticLevel.ERROR, "store failing"))
    assert spin_until(ex, lambda: up.pub.get_subscription_count() > 0)
    assert spin_until(ex, lambda: len(got) >= 2), "no periodic update"
    first = got[0]
    assert [s.name for s in first.status] == ["kit: robot", "kit: joint_1"]  # one array, every task, in order
    assert [s.hardware_id for s in first.status] == ["robot", "cell_1"]
    assert first.status[0].message == "idle" and first.status[0].level == b"\x00"
    held.set(DiagnosticLevel.WARN, "busy", [("cycle_id", 3)])
    state["n"] = 2
    n = len(got)
    up.update()
    assert spin_until(ex, lambda: len(got) > n)
    last = got[n]
    by_name = {s.name: s for s in last.status}
    assert set(by_name) == {"kit: robot", "kit: joint_1", "kit: history"}
    assert by_name["kit: robot"].level == b"\x01" and [(v.key, v.value) for v in by_name["kit: robot"].values] == [
        ("cycle_id", "3")]
    assert by_name["kit: history"].level == b"\x02" and by_name["kit: joint_1"].message == "n=2"
    assert up.status("history").level is DiagnosticLevel.ERROR and up.status("kit: robot").message == "busy"
    assert up.remove("history") and not up.remove("history")


def test_node_diagnostics_keeps_its_one_status_interface(graph):
    node, ex, got = graph
    d = NodeDiagnostics(node, "kit: joint_2", "joint_2", topic="/jw_kit/diagnostics", period=0.0, message="idle")
    assert spin_until(ex, lambda: d.pub.get_subscription_count() > 0)
    d.update(DiagnosticLevel.ERROR, "broken", [("k", "v")])
    assert spin_until(ex, lambda: bool(got))
    (s,) = got[-1].status
    assert (s.name, s.hardware_id, s.level, s.message) == ("kit: joint_2", "joint_2", b"\x02", "broken")
    assert d.level == 2 and d.status.name == "kit: joint_2" and d.updater.published == 1


def test_a_node_on_sim_time_publishes_its_status_again_as_its_first_clock_arrives(ros_context_per_test):
    """A cell starts a cycle once each sim-time node's status is stamped on the sim clock: the node publishes
    again as the first /clock arrives, not a period (here 100 s) later."""
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock as ClockMsg

    ctx = ros_context_per_test
    ex = SingleThreadedExecutor(context=ctx)
    node = rclpy.create_node("jw_diag_sim", context=ctx,
                             parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, True)])
    probe = rclpy.create_node("jw_diag_clock", context=ctx)
    ex.add_node(node)
    ex.add_node(probe)
    got: list[DiagnosticArray] = []
    probe.create_subscription(DiagnosticArray, "/jw_kit/diagnostics", got.append, 100)
    clock = probe.create_publisher(ClockMsg, "/clock", 10)
    try:
        up = Updater(node, "kit", period=100.0, topic="/jw_kit/diagnostics")
        up.add(HeldStatus("robot", message="idle"))
        assert spin_until(ex, lambda: up.pub.get_subscription_count() > 0 and clock.get_subscription_count() > 0)
        up.update()
        assert spin_until(ex, lambda: len(got) == 1)
        assert got[0].header.stamp.sec == 0  # no /clock yet
        msg = ClockMsg()
        msg.clock.sec = 1_800_000_000
        clock.publish(msg)
        assert spin_until(ex, lambda: len(got) == 2), "no update on the first /clock"
        assert got[1].header.stamp.sec == 1_800_000_000
        msg.clock.sec += 5  # later jumps (a replay) are no first clock
        clock.publish(msg)
        spin_until(ex, lambda: node.get_clock().now().nanoseconds >= msg.clock.sec * 10**9, timeout=5.0)
        ex.spin_once(timeout_sec=0.2)
        assert len(got) == 2 and up.published == 2
    finally:
        ex.shutdown()
        node.destroy_node()
        probe.destroy_node()
