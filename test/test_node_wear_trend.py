"""wear_trend on a real rclpy graph (loopback DDS): history, trend, diagnostics, maintenance, restarts and SIGKILL."""

from __future__ import annotations

import math
import os
import signal
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")
from conftest import spin_until  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402
from jointwear_msgs.msg import WearEstimate, WearTrend  # noqa: E402
from jointwear_msgs.srv import RecordMaintenance  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

from jointwear_ros.history import HistoryStore  # noqa: E402
from jointwear_ros.nodes.runtime import loopback_env  # noqa: E402
from jointwear_ros.nodes.wear_trend import WearTrendNode  # noqa: E402

pytestmark = pytest.mark.ros

T0 = 1.7e9
DAY = 86400.0
RELIABLE = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=1000)
LATCHED = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=100,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _estimate(joint, cycle, t, wear, std=0.85):
    m = WearEstimate()
    ns = round(t * 1e9)
    m.header.stamp.sec, m.header.stamp.nanosec = ns // 10**9, ns % 10**9
    m.joint_name, m.cycle_id, m.method = joint, cycle, "joint"
    m.wear, m.wear_std, m.temperature_estimate = float(wear), float(std), 41.0
    m.alarm_threshold = 35.0
    return m


def _history(n, rate, w0, seed):
    rng = np.random.default_rng(seed)
    return [(i + 1, T0 + i * DAY, w0 + rate * i + rng.normal(0, 0.85)) for i in range(n)]


class _Probe:
    """A test node: publishes estimates, collects trends and diagnostics."""

    def __init__(self, ros_context, ns):
        self.node = rclpy.create_node("wear_trend_probe", context=ros_context)
        self.pub = self.node.create_publisher(WearEstimate, f"{ns}/wear_estimate", RELIABLE)
        self.trends: list[WearTrend] = []
        self.diags: list[DiagnosticArray] = []
        self.node.create_subscription(WearTrend, f"{ns}/wear_trend", self.trends.append, LATCHED)
        self.node.create_subscription(DiagnosticArray, f"{ns}/diagnostics", self.diags.append, 10)

    def last(self, joint):
        return next((t for t in reversed(self.trends) if t.joint_name == joint), None)

    def status(self, name):
        for arr in reversed(self.diags):
            for s in arr.status:
                if s.name == name:
                    return s
        return None


def _node(ros_context, ns, db):
    return WearTrendNode(context=ros_context, parameter_overrides=[
        Parameter("db_url", value=db), Parameter("robot", value="cell_7"),
        Parameter("estimate_topic", value=f"{ns}/wear_estimate"), Parameter("trend_topic", value=f"{ns}/wear_trend"),
        Parameter("diagnostics_topic", value=f"{ns}/diagnostics"), Parameter("diagnostics_period", value=0.2),
    ])


def test_wear_trend_node_stores_trends_warns_takes_maintenance_and_reloads_after_a_restart(ros_context, tmp_path):
    ns = "/jw_trend_a"
    db = str(tmp_path / "h.db")
    node = _node(ros_context, ns, db)
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        grow, flat = _history(60, 0.3, 12.0, 1), _history(60, 0.0, 15.0, 2)  # joint_1 reaches 35 ~17 days later
        for (c, t, w), (c2, t2, w2) in zip(grow, flat):
            probe.pub.publish(_estimate("joint_1", c, t, w))
            probe.pub.publish(_estimate("joint_2", c2, t2 + 600.0, w2))
        probe.pub.publish(_estimate("joint_2", 999, T0 + 100 * DAY, math.nan))  # malformed: rejected, counted
        assert spin_until(ex, lambda: node.rejected == 1 and node.stored == 120), (node.stored, node.rejected)
        assert spin_until(ex, lambda: (probe.last("joint_1") or WearTrend()).estimates_total == 60
                           and (probe.last("joint_2") or WearTrend()).estimates_total == 60)
        g, f = probe.last("joint_1"), probe.last("joint_2")
        # the condition (its newest estimate about 29.7: OK or, within its std, WARN) and the forecast apart
        assert g.level in (WearTrend.OK, WearTrend.WARN) and g.alarm_expected and g.forecast == "within_horizon"
        assert g.growth_detected and g.robot == "cell_7"
        assert g.time_to_alarm_lo90 <= (35 - 12 - 0.3 * 59) / 0.3 <= g.time_to_alarm_hi90  # 17.7 days
        assert 0.25 < g.rate_per_day < 0.35 and g.wear_std < 1.0
        assert f.level == WearTrend.OK and not f.growth_detected and math.isnan(f.time_to_alarm_median)
        assert not f.alarm_expected
        assert spin_until(ex, lambda: probe.status("wear_trend: joint_1") is not None
                           and dict((kv.key, kv.value) for kv in
                                    probe.status("wear_trend: joint_1").values)["alarm_expected"] == "true")
        assert probe.status("wear_trend: joint_1").level == bytes([g.level])
        assert spin_until(ex, lambda: dict((kv.key, kv.value) for kv in
                                            probe.status("wear_trend: joint_2").values)["rejected"] == "1")
        s2 = probe.status("wear_trend: joint_2")
        assert s2.level == bytes([0]) and dict((kv.key, kv.value) for kv in s2.values)["stored"] == "120"
        # the same estimates again (a bag played onto the graph): nothing new stored
        for c, t, w in grow[:10]:
            probe.pub.publish(_estimate("joint_1", c, t, w))
        assert spin_until(ex, lambda: node.duplicates == 10)
        assert HistoryStore(db).count() == 120
        # a maintenance event by service call: joint_1 starts a new segment
        cli = probe.node.create_client(RecordMaintenance, "/wear_trend/record_maintenance")
        assert cli.wait_for_service(timeout_sec=10.0)
        req = RecordMaintenance.Request(joint_name="joint_1", kind="reducer_replaced", note="test")
        req.stamp.sec = int(T0 + 58.5 * DAY)  # one estimate (day 59) after it
        fut = cli.call_async(req)
        assert spin_until(ex, fut.done)
        assert fut.result().success, fut.result().message
        assert spin_until(ex, lambda: probe.last("joint_1").estimates == 1)
        assert probe.last("joint_1").level == WearTrend.OK
        fut = cli.call_async(RecordMaintenance.Request(joint_name="", kind="regrease"))
        assert spin_until(ex, fut.done) and not fut.result().success
        assert "must be non-empty" in fut.result().message
    finally:
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
    # restart: the new node reloads both joints from the store and publishes their trends (latched)
    probe.trends.clear()
    node2 = _node(ros_context, ns, db)
    ex.add_node(node2)
    try:
        assert spin_until(ex, lambda: probe.last("joint_1") is not None and probe.last("joint_2") is not None)
        assert probe.last("joint_2").estimates_total == 60
        assert probe.last("joint_1").estimates_total == 60 and probe.last("joint_1").estimates == 1
    finally:
        ex.remove_node(node2)
        node2.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()


def _start_node(db, ns, domain):
    env = loopback_env(domain)
    return subprocess.Popen(
        [sys.executable, "-m", "jointwear_ros.nodes.wear_trend", "--ros-args", "-p", f"db_url:={db}",
         "-p", f"estimate_topic:={ns}/wear_estimate", "-p", f"trend_topic:={ns}/wear_trend",
         "-p", f"diagnostics_topic:={ns}/diagnostics"],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)


def test_wear_trend_killed_mid_stream_loses_no_reported_estimate_and_duplicates_none(ros_context, tmp_path):
    ns = "/jw_trend_kill"
    db = str(tmp_path / "kill.db")
    domain = int(os.environ["ROS_DOMAIN_ID"])
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(probe.node)
    stream = _history(150, 0.1, 5.0, 3)
    proc = _start_node(db, ns, domain)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1, timeout=60)
        for c, t, w in stream:
            probe.pub.publish(_estimate("joint_3", c, t, w))
        # kill it hard while it is working through the stream
        assert spin_until(ex, lambda: any(m.estimates_total >= 25 for m in probe.trends), timeout=60)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    ex.spin_once(timeout_sec=0.1)
    reported = max(m.estimates_total for m in probe.trends)  # the node stores before it reports
    with sqlite3.connect(db) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        stored = conn.execute("SELECT COUNT(*) FROM estimates").fetchone()[0]
        distinct = conn.execute("SELECT COUNT(DISTINCT cycle_id) FROM estimates").fetchone()[0]
    assert reported <= stored < len(stream), (reported, stored)
    assert distinct == stored
    # restart, and the cell sends everything again: the history ends with each estimate exactly once
    probe.trends.clear()
    proc = _start_node(db, ns, domain)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1
                           and any(m.estimates_total == stored for m in probe.trends), timeout=60)
        # The killed node's subscription lingers in discovery until its lease ends, so the count above may
        # be the dead one's and the new node's may not be matched yet: what is published before the match
        # is not delivered (volatile). So the cell sends everything again until the history is whole, as a
        # cell resends what it has not seen acknowledged; the node stores each estimate once whatever comes.
        def all_stored() -> bool:
            return any(m.estimates_total == len(stream) for m in probe.trends)

        for _ in range(6):
            for c, t, w in stream:
                probe.pub.publish(_estimate("joint_3", c, t, w))
            if spin_until(ex, all_stored, timeout=20):
                break
        assert all_stored()
        assert max(m.estimates_total for m in probe.trends) == len(stream)  # never more: no duplicate stored
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 0, proc.stderr.read()[-2000:] if proc.stderr else ""
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        probe.node.destroy_node()
        ex.shutdown()
    with HistoryStore(db) as s:
        recs = s.estimates(robot="robot_1", joint="joint_3")
    assert [r.cycle_id for r in recs] == list(range(1, len(stream) + 1))


def test_wear_trend_node_writes_to_postgresql_given_as_its_db_url(ros_context, postgres_url):
    ns = "/jw_trend_pg"
    node = _node(ros_context, ns, postgres_url.replace("postgresql+psycopg://", "postgresql://", 1))
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        for c, t, w in _history(12, 0.2, 10.0, 5):
            probe.pub.publish(_estimate("joint_5", c, t, w))
        assert spin_until(ex, lambda: (probe.last("joint_5") or WearTrend()).estimates_total == 12)
        assert node.stored == 12 and node.store.dialect == "postgresql"
    finally:
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()
    with HistoryStore(postgres_url) as s:
        assert [r.cycle_id for r in s.estimates(robot="cell_7", joint="joint_5")] == list(range(1, 13))


def _values(status):
    return {kv.key: kv.value for kv in status.values}


def _now_history(n, w0, rate, seed):
    """n nightly estimates ending an hour ago (stamped by a cell on wall time)."""
    rng = np.random.default_rng(seed)
    end = time.time() - 3600.0
    return [(i + 1, end - (n - 1 - i) * DAY, w0 + rate * i + rng.normal(0, 0.5)) for i in range(n)]


def test_bad_estimates_never_hide_an_error_joint_and_each_is_counted_with_its_reason(ros_context, tmp_path):
    """A joint at ERROR, then wear 1e300, wear 0 with std 1e-300, a stamp ten years ahead and one in 2000: the
    joint stays ERROR on /diagnostics, each refusal counted by reason and kept in the store's refused table."""
    ns = "/jw_trend_bad"
    db = str(tmp_path / "bad.db")
    node = _node(ros_context, ns, db)
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        hist = _now_history(30, 36.0, 0.1, 4)
        for c, t, w in hist:
            probe.pub.publish(_estimate("joint_5", c, t, w, std=0.7))
        assert spin_until(ex, lambda: node.stored == 30)
        now = time.time()
        for c, t, w, sd in [(31, now - 60, 1e300, 0.7), (32, now - 50, 0.0, 1e-300),
                            (33, now + 3652 * DAY, 36.5, 0.7), (34, 946684800.0, 40.0, 0.7)]:
            probe.pub.publish(_estimate("joint_5", c, t, w, std=sd))
        assert spin_until(ex, lambda: node.rejected == 4)
        assert spin_until(ex, lambda: probe.status("wear_trend: joint_5") is not None
                           and _values(probe.status("wear_trend: joint_5")).get("refused_time_before_min") == "1")
        s = probe.status("wear_trend: joint_5")
        v = _values(s)
        assert s.level == bytes([2]), s.message
        assert 36.0 < float(v["wear"]) < 40.0 and v["estimates_total"] == "30"
        assert (v["refused_wear_out_of_range"], v["refused_std_out_of_range"], v["refused_time_in_future"],
                v["refused_time_before_min"]) == ("1", "1", "1", "1")
        assert "newest estimate refused (time_before_min" in s.message
        assert probe.last("joint_5").level == WearTrend.ERROR
    finally:
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()
    with HistoryStore(db) as st:
        assert st.count() == 30
        assert sorted((r["cycle_id"], r["reason"]) for r in st.refused()) == [
            (31, "wear_out_of_range"), (32, "std_out_of_range"), (33, "time_in_future"), (34, "time_before_min")]


def _set_connections(base_uri, db, allow):
    import psycopg

    with psycopg.connect(base_uri, autocommit=True) as conn:
        conn.execute(f'ALTER DATABASE "{db}" ALLOW_CONNECTIONS {"true" if allow else "false"}')
        if not allow:
            conn.execute("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = %s", (db,))


def test_wear_trend_buffers_while_postgresql_refuses_then_stores_every_estimate_once(ros_context, postgres_url,
                                                                                      postgres_server, tmp_path):
    """PostgreSQL stops accepting the node's connections during a series crossing 35: ERROR on /diagnostics while
    it fails, the level follows the newest (buffered) estimate, and afterwards every estimate is stored once."""
    ns = "/jw_trend_pgdown"
    from sqlalchemy.engine import make_url

    dbname = make_url(postgres_url).database
    node = WearTrendNode(context=ros_context, parameter_overrides=[
        Parameter("db_url", value=postgres_url), Parameter("robot", value="cell_7"),
        Parameter("estimate_topic", value=f"{ns}/wear_estimate"), Parameter("trend_topic", value=f"{ns}/wear_trend"),
        Parameter("diagnostics_topic", value=f"{ns}/diagnostics"), Parameter("diagnostics_period", value=0.2),
        Parameter("retry_period", value=0.2), Parameter("buffer_path", value=str(tmp_path / "spool.jsonl"))])
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    series = _now_history(20, 25.0, 0.5, 6)  # 25 -> 34.5 ...
    end = series[-1][1]
    crossing = [(21 + k, end + (k + 1) * 1800.0, 34.8 + 0.6 * k) for k in range(6)]  # 34.8 ... 37.8
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        for c, t, w in series:
            probe.pub.publish(_estimate("joint_2", c, t - 3 * 3600.0, w, std=0.5))
        assert spin_until(ex, lambda: node.stored == 20)
        assert probe.last("joint_2").level != WearTrend.ERROR
        _set_connections(postgres_server.get_uri(), dbname, allow=False)
        for c, t, w in crossing:
            probe.pub.publish(_estimate("joint_2", c, t - 3 * 3600.0, w, std=0.5))
        assert spin_until(ex, lambda: len(node.pending) == 6 and node.store_error is not None)
        assert spin_until(ex, lambda: (probe.status("wear_trend: history") or DiagnosticStatus()).level == bytes([2])
                           and _values(probe.status("wear_trend: joint_2"))["buffered"] == "6")
        s = probe.status("wear_trend: joint_2")
        assert s.level == bytes([2]) and "history store failing" in s.message and _values(s)["buffered"] == "6"
        assert probe.last("joint_2").level == WearTrend.ERROR and probe.last("joint_2").estimates_total == 26
        assert node.rejected == 0 and node.stored == 20
        _set_connections(postgres_server.get_uri(), dbname, allow=True)
        assert spin_until(ex, lambda: node.store_error is None and not node.pending and node.stored == 26)
        assert spin_until(ex, lambda: "history store failing" not in probe.status("wear_trend: joint_2").message)
        assert probe.status("wear_trend: joint_2").level == bytes([2])
        assert not (tmp_path / "spool.jsonl").exists()
    finally:
        _set_connections(postgres_server.get_uri(), dbname, allow=True)
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()
    with HistoryStore(postgres_url) as st:
        assert [r.cycle_id for r in st.estimates(robot="cell_7", joint="joint_2")] == list(range(1, 27))


def test_wear_trend_applies_its_thresholds_at_run_time_and_refuses_the_rest(ros_context, tmp_path):
    ns = "/jw_trend_params"
    node = _node(ros_context, ns, str(tmp_path / "p.db"))
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        for c, t, w in _now_history(20, 32.0, 0.0, 8):
            probe.pub.publish(_estimate("joint_3", c, t, w, std=0.5))
        assert spin_until(ex, lambda: node.stored == 20 and probe.last("joint_3").estimates_total == 20)
        assert probe.last("joint_3").level == WearTrend.WARN  # in the warning band [30, 35)
        r = node.set_parameters([Parameter("alarm_threshold", value=30.0)])[0]
        assert r.successful, r.reason
        assert spin_until(ex, lambda: probe.last("joint_3").level == WearTrend.ERROR
                           and probe.last("joint_3").alarm_threshold == 30.0)
        assert node.set_parameters([Parameter("min_estimates", value=1)])[0].successful is False
        bad = node.set_parameters([Parameter("db_url", value="other.db")])[0]
        assert not bad.successful and "read-only" in bad.reason
        assert node.cfg.min_estimates == 5 and node.params["db_url"] == str(tmp_path / "p.db")
        # maintenance: one in the future and one of a misspelt joint are refused with the reason
        cli = probe.node.create_client(RecordMaintenance, "/wear_trend/record_maintenance")
        assert cli.wait_for_service(timeout_sec=10.0)
        req = RecordMaintenance.Request(joint_name="joint_3", kind="regrease")
        req.stamp.sec = int(time.time() + 30 * DAY)
        fut = cli.call_async(req)
        assert spin_until(ex, fut.done) and not fut.result().success
        assert "in the future" in fut.result().message
        fut = cli.call_async(RecordMaintenance.Request(joint_name="jiont_3", kind="regrease"))
        assert spin_until(ex, fut.done) and not fut.result().success
        assert "'jiont_3'" in fut.result().message and "its joints: joint_3" in fut.result().message
        assert probe.last("joint_3").level == WearTrend.ERROR
    finally:
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()


def test_estimates_buffered_when_the_node_stops_are_stored_by_the_next_start(ros_context, postgres_url, postgres_server,
                                                                             tmp_path):
    """Stopped while PostgreSQL refuses it, the node leaves its buffered estimates in its spool file; the next
    start (the store back) writes them, once each, and removes the spool."""
    from sqlalchemy.engine import make_url

    ns = "/jw_trend_spool"
    dbname = make_url(postgres_url).database
    spool = tmp_path / "spool.jsonl"

    def make():
        return WearTrendNode(context=ros_context, parameter_overrides=[
            Parameter("db_url", value=postgres_url), Parameter("robot", value="cell_7"),
            Parameter("estimate_topic", value=f"{ns}/wear_estimate"),
            Parameter("trend_topic", value=f"{ns}/wear_trend"), Parameter("diagnostics_topic", value=f"{ns}/diagnostics"),
            Parameter("retry_period", value=0.2), Parameter("buffer_path", value=str(spool))])

    node = make()
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    series = _now_history(8, 20.0, 0.2, 9)
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        for c, t, w in series[:3]:
            probe.pub.publish(_estimate("joint_4", c, t, w))
        assert spin_until(ex, lambda: node.stored == 3)
        _set_connections(postgres_server.get_uri(), dbname, allow=False)
        for c, t, w in series[3:]:
            probe.pub.publish(_estimate("joint_4", c, t, w))
        assert spin_until(ex, lambda: len(node.pending) == 5)
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        assert len(spool.read_text().splitlines()) == 5
        _set_connections(postgres_server.get_uri(), dbname, allow=True)
        node = make()
        ex.add_node(node)
        assert spin_until(ex, lambda: not node.pending and node.stored == 5)
        assert not spool.exists()
    finally:
        _set_connections(postgres_server.get_uri(), dbname, allow=True)
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()
    with HistoryStore(postgres_url) as st:
        assert [r.cycle_id for r in st.estimates(robot="cell_7", joint="joint_4")] == list(range(1, 9))


def test_wear_trend_with_its_disk_full_reports_error_and_stores_everything_afterwards(ros_context, tmp_path):
    """The SQLite file cannot grow (the process's file-size limit at 1 byte: every write fails with "database or
    disk is full", as on a full disk) while a series crosses 35: ERROR while it fails, the level follows the newest
    estimate, and once the disk has room again every estimate is stored once."""
    import resource

    ns = "/jw_trend_full"
    db = tmp_path / "full.db"
    node = WearTrendNode(context=ros_context, parameter_overrides=[
        Parameter("db_url", value=str(db)), Parameter("robot", value="cell_7"),
        Parameter("estimate_topic", value=f"{ns}/wear_estimate"), Parameter("trend_topic", value=f"{ns}/wear_trend"),
        Parameter("diagnostics_topic", value=f"{ns}/diagnostics"), Parameter("diagnostics_period", value=0.2),
        Parameter("retry_period", value=0.2), Parameter("buffer_path", value=str(tmp_path / "spool.jsonl"))])
    probe = _Probe(ros_context, ns)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    ex.add_node(probe.node)
    series = _now_history(12, 29.0, 0.5, 10)
    end = series[-1][1]
    crossing = [(13 + k, end + (k + 1) * 600.0, 34.8 + 0.6 * k) for k in range(6)]  # 34.8 ... 37.8
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    old_handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # EFBIG instead of a kill
    try:
        assert spin_until(ex, lambda: probe.pub.get_subscription_count() >= 1)
        for c, t, w in series:
            probe.pub.publish(_estimate("joint_6", c, t - 2 * 3600.0, w, std=0.5))
        assert spin_until(ex, lambda: node.stored == 12)
        try:
            resource.setrlimit(resource.RLIMIT_FSIZE, (1, hard))
            for c, t, w in crossing:
                probe.pub.publish(_estimate("joint_6", c, t - 2 * 3600.0, w, std=0.5))
            failing = spin_until(ex, lambda: len(node.pending) == 6 and node.store_error is not None
                                  and probe.status("wear_trend: joint_6") is not None
                                  and _values(probe.status("wear_trend: joint_6"))["buffered"] == "6")
        finally:
            resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        assert failing, (node.store_error, len(node.pending))
        s = probe.status("wear_trend: joint_6")
        assert s.level == bytes([2]) and "history store failing" in s.message and "full" in s.message, s.message
        assert probe.last("joint_6").level == WearTrend.ERROR and probe.last("joint_6").estimates_total == 18
        assert node.rejected == 0
        assert spin_until(ex, lambda: node.store_error is None and not node.pending and node.stored == 18)
    finally:
        signal.signal(signal.SIGXFSZ, old_handler)
        ex.remove_node(node)
        node.on_shutdown()
        node.destroy_node()
        probe.node.destroy_node()
        ex.shutdown()
    with HistoryStore(db) as st:
        assert [r.cycle_id for r in st.estimates(robot="cell_7", joint="joint_6")] == list(range(1, 19))
