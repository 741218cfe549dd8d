"""wear_trend faults of issue 28: a locked store never stops the node's diagnostics, and estimates the store and the
spool could not take survive a kill (the spool's disk full too) and raise the alarm after the restart.

Old behaviour: a locked SQLite file blocked the node for the 30 s busy timeout per statement (no /diagnostics for
about 36 s); the default spool sat beside the store's file, so when that disk filled the buffer lived in memory only
and a kill lost it (six estimates rising through 35 and the alarm gone after the restart).
"""

from __future__ import annotations

import itertools
import os
import sqlite3
import time
from pathlib import Path

import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import spin_until  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from jointwear_msgs.msg import WearEstimate, WearTrend  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

from jointwear_ros.history import HistoryStore  # noqa: E402
from jointwear_ros.history.outbox import default_spool as _default_spool  # noqa: E402
from jointwear_ros.history.outbox import fallback_spool as _fallback_spool  # noqa: E402
from jointwear_ros.history.outbox import same_disk as _same_disk  # noqa: E402
from jointwear_ros.nodes.wear_trend import WearTrendNode  # noqa: E402

pytestmark = pytest.mark.ros

DAY = 86400.0
RELIABLE = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
LATCHED = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _estimate(joint, cycle, t, wear, std=0.5):
    m = WearEstimate()
    ns = round(t * 1e9)
    m.header.stamp.sec, m.header.stamp.nanosec = ns // 10**9, ns % 10**9
    m.joint_name, m.cycle_id, m.method = joint, cycle, "joint"
    m.wear, m.wear_std, m.temperature_estimate = float(wear), float(std), 41.0
    m.alarm_threshold, m.evidence, m.confirmation = 35.0, "complete", "confirmed"
    return m


def test_the_default_spool_is_not_beside_the_store_and_a_shared_disk_is_detected(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db = tmp_path / "data" / "history.db"
    spool = _default_spool(str(db), "cell_7")
    assert spool.parent != db.parent and spool == tmp_path / "ros_home" / "wear_trend_cell_7.pending.jsonl"
    assert _same_disk(spool, db) and not _same_disk(spool, None)  # one tmp file system here: detected
    fb = _fallback_spool(str(db), "cell_7")
    assert fb != _fallback_spool(str(tmp_path / "other.db"), "cell_7")  # one per store and robot
    if Path("/dev/shm").is_dir():
        assert fb.parent == Path("/dev/shm")


def test_a_locked_store_keeps_the_diagnostics_period_and_a_kill_with_the_spool_disk_full_loses_nothing(
        ros_context, tmp_path):
    ns = "/jw_trend_faults28"
    db = tmp_path / "h.db"
    blocked = tmp_path / "not_a_dir"
    blocked.write_text("a file where the spool's folder should be: the spool cannot be written (a full disk)\n")
    robot = f"cell_f28_{os.getpid()}"
    params = [Parameter("db_url", value=str(db)), Parameter("robot", value=robot),
              Parameter("estimate_topic", value=f"{ns}/wear_estimate"), Parameter("trend_topic", value=f"{ns}/wear_trend"),
              Parameter("diagnostics_topic", value=f"{ns}/diagnostics"), Parameter("diagnostics_period", value=0.2),
              Parameter("retry_period", value=0.2), Parameter("buffer_path", value=str(blocked / "spool.jsonl"))]
    fallback = _fallback_spool(str(db), robot)
    fallback.unlink(missing_ok=True)
    probe = rclpy.create_node("faults28_probe", context=ros_context)
    pub = probe.create_publisher(WearEstimate, f"{ns}/wear_estimate", RELIABLE)
    trends: list[WearTrend] = []
    arrivals: list[float] = []
    probe.create_subscription(WearTrend, f"{ns}/wear_trend", trends.append, LATCHED)
    probe.create_subscription(DiagnosticArray, f"{ns}/diagnostics", lambda m: arrivals.append(time.monotonic()), 100)
    node = WearTrendNode(context=ros_context, parameter_overrides=params)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe)
    now = time.time()
    series = [(k + 1, now - (20 - k) * 3600.0, 29.0 + 0.2 * k) for k in range(12)]
    crossing = [(13 + k, now - (6 - k) * 600.0, 34.8 + 0.6 * k) for k in range(6)]  # 34.8 ... 37.8
    locker = None
    node2 = None
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() >= 1)
        for c, t, w in series:
            pub.publish(_estimate("joint_6", c, t, w))
        assert spin_until(ex, lambda: node.stored == 12, 30.0, "12 estimates stored")
        locker = sqlite3.connect(str(db), timeout=10.0)  # another writer holds the store's write lock
        locker.execute("BEGIN IMMEDIATE")
        t_lock = time.monotonic()
        for c, t, w in crossing:
            pub.publish(_estimate("joint_6", c, t, w))
        assert spin_until(ex, lambda: len(node.pending) == 6 and node.store_error is not None, 60.0,
                          "six estimates buffered while the store is locked"), (len(node.pending), node.store_error)
        spin_until(ex, lambda: time.monotonic() - t_lock > 3.0, 10.0)
        during = [t for t in arrivals if t >= t_lock]
        gaps = [b - a for a, b in itertools.pairwise(during)]
        assert len(during) >= 5 and max(gaps) < 5.0, gaps  # diagnostics kept coming (period 0.2 s), never 30 s apart
        assert trends[-1].level == WearTrend.ERROR  # the level follows the newest (buffered) estimates
        lines = fallback.read_text().splitlines()
        assert len(lines) == 6  # the spool's disk is "full": the buffer went to RAM, each estimate once
        # killed: no on_shutdown, no last flush
        ex.remove_node(node)
        node.destroy_node()
        node = None
        locker.rollback()
        locker.close()
        locker = None
        trends.clear()
        node2 = WearTrendNode(context=ros_context, parameter_overrides=params)
        ex.add_node(node2)
        assert spin_until(ex, lambda: node2.stored == 6 and not node2.pending, 30.0, "the six stored after restart")
        assert spin_until(ex, lambda: trends and trends[-1].estimates_total == 18 and trends[-1].level == WearTrend.ERROR,
                          30.0, "the alarm after the restart")
        with HistoryStore(str(db)) as st:
            assert [r.cycle_id for r in st.estimates(robot=robot, joint="joint_6")] == list(range(1, 19))
        assert not fallback.exists()
    finally:
        if locker is not None:
            locker.rollback()
            locker.close()
        for n in (node, node2):
            if n is not None:
                ex.remove_node(n)
                n.on_shutdown()
                n.destroy_node()
        probe.destroy_node()
        fallback.unlink(missing_ok=True)


def test_a_spool_an_earlier_version_left_beside_the_store_is_stored_on_start(ros_context, tmp_path, monkeypatch):
    """Earlier versions spooled beside the store's file by default: an upgrade must not lose what a killed node
    left there."""
    import json
    from dataclasses import asdict

    from jointwear_ros.history import EstimateRecord

    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db = tmp_path / "h.db"
    robot = f"cell_legacy_{os.getpid()}"
    legacy = tmp_path / f"h.db.{robot}.pending.jsonl"
    now = time.time()
    recs = [EstimateRecord(robot, "joint_2", cycle_id=k, time=now - (5 - k) * 60.0, wear=36.0 + k, wear_std=0.5)
            for k in range(1, 4)]
    legacy.write_text("".join(json.dumps(asdict(r)) + "\n" for r in recs))
    node = WearTrendNode(context=ros_context, parameter_overrides=[
        Parameter("db_url", value=str(db)), Parameter("robot", value=robot),
        Parameter("estimate_topic", value="/jw_legacy/wear_estimate"), Parameter("trend_topic", value="/jw_legacy/trend"),
        Parameter("diagnostics_topic", value="/jw_legacy/diagnostics"), Parameter("retry_period", value=0.1)])
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: node.stored == 3 and not node.pending, 20.0, "the legacy spool stored")
        assert not legacy.exists()
        with HistoryStore(str(db)) as st:
            assert [r.cycle_id for r in st.estimates(robot=robot, joint="joint_2")] == [1, 2, 3]
    finally:
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        _fallback_spool(str(db), robot).unlink(missing_ok=True)
