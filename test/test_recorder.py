"""The recorder on a real graph (rclpy over loopback DDS): every topic, raw CDR, MCAP, metadata v9."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml

rclpy = pytest.importorskip("rclpy")
from conftest import NodeProcess, spin_until  # noqa: E402
from jointwear_msgs.msg import TestCycleStatus  # noqa: E402  (a message, not a test class: conftest)
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64MultiArray, String  # noqa: E402

from jointwear_ros.io.bags import bag_info, read_messages  # noqa: E402
from jointwear_ros.nodes.recorder import RecorderNode  # noqa: E402

pytestmark = pytest.mark.ros

RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
BEST_EFFORT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture()
def ros(ros_context_per_test):
    ex = SingleThreadedExecutor(context=ros_context_per_test)
    yield ros_context_per_test, ex
    ex.shutdown()


def _recorder(ctx, ex, out: Path, **params) -> RecorderNode:
    overrides = [Parameter("output_dir", value=str(out)), Parameter("discovery_period", value=0.1)]
    overrides += [Parameter(k, value=v) for k, v in params.items()]
    node = RecorderNode(context=ctx, parameter_overrides=overrides)
    ex.add_node(node)
    return node


def _joint_state(i: int) -> JointState:
    m = JointState()
    m.header.stamp.sec, m.header.stamp.nanosec = i // 500, (i % 500) * 2_000_000
    m.name = ["joint_0", "joint_1"]
    m.position = [0.0, 0.001 * i]
    m.velocity = [0.0, 0.5]
    m.effort = [0.0, 12.5 + 0.01 * i]
    return m


def _read_with_mcap(bag: Path) -> tuple[dict[str, int], dict[str, tuple[str, bytes]]]:
    from mcap.reader import make_reader

    files = sorted(bag.glob("*.mcap"))
    assert len(files) == 1, files
    counts: dict[str, int] = {}
    schemas: dict[str, tuple[str, bytes]] = {}
    with files[0].open("rb") as fh:
        reader = make_reader(fh)
        for schema, channel, _message in reader.iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            schemas[channel.topic] = (schema.encoding, schema.data)
            assert channel.message_encoding == "cdr"
    return counts, schemas


def test_recorder_records_every_topic_including_late_ones_into_an_mcap_bag_readable_by_rosbags_and_mcap(ros, tmp_path):
    ctx, ex = ros
    pub_node = rclpy.create_node("recorder_test_pub", context=ctx)
    ex.add_node(pub_node)
    latched = pub_node.create_publisher(String, "/test_rec/latched", LATCHED)
    latched.publish(String(data="configuration v1"))
    js = pub_node.create_publisher(JointState, "/joint_states", RELIABLE)
    cmd = pub_node.create_publisher(Float64MultiArray, "/velocity_controller/commands", RELIABLE)
    noisy = pub_node.create_publisher(String, "/test_rec/best_effort", BEST_EFFORT)
    ignored = pub_node.create_publisher(String, "/test_rec/ignored", RELIABLE)

    rec = _recorder(ctx, ex, tmp_path, exclude=["^/test_rec/ignored$"])
    assert spin_until(ex, lambda: {"/joint_states", "/velocity_controller/commands", "/test_rec/latched",
                                    "/test_rec/best_effort"} <= set(rec.recorded_topics))
    assert spin_until(ex, lambda: js.get_subscription_count() >= 1 and cmd.get_subscription_count() >= 1)
    n_js, n_cmd = 300, 30
    for i in range(n_js):
        js.publish(_joint_state(i))
        if i % 10 == 0:
            cmd.publish(Float64MultiArray(data=[0.01 * i]))
        noisy.publish(String(data=f"n{i}"))
        ignored.publish(String(data="never recorded"))
        if i % 50 == 0:
            ex.spin_once(timeout_sec=0.0)

    # a topic that appears while the recorder runs, of a jointwear type
    late = pub_node.create_publisher(TestCycleStatus, "/test_cycle/status", RELIABLE)
    assert spin_until(ex, lambda: "/test_cycle/status" in rec.recorded_topics)
    assert spin_until(ex, lambda: late.get_subscription_count() >= 1)
    for k in range(5):
        st = TestCycleStatus(joint_name="joint_1", cycle_id=3, state=TestCycleStatus.RUNNING, speeds_done=k, speeds_total=8)
        late.publish(st)
    assert spin_until(ex, lambda: rec.received.get("/joint_states", 0) == n_js
                       and rec.received.get("/velocity_controller/commands", 0) == n_cmd
                       and rec.received.get("/test_cycle/status", 0) == 5), rec.received
    rec.on_shutdown()
    assert rec.write_errors == 0
    bags = rec.bags
    assert len(bags) == 1
    bag = bags[0]

    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9
    assert meta["storage_identifier"] == "mcap"
    meta_counts = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    assert meta_counts["/joint_states"] == n_js
    assert meta_counts["/velocity_controller/commands"] == n_cmd
    assert meta_counts["/test_cycle/status"] == 5
    assert meta_counts["/test_rec/latched"] == 1
    assert 1 <= meta_counts["/test_rec/best_effort"] <= n_js
    assert "/test_rec/ignored" not in meta_counts

    # rosbags: counts, types and values read back
    info = bag_info(bag)
    assert info.version == 9 and info.topics["/joint_states"] == {"type": "sensor_msgs/msg/JointState", "count": n_js}
    states = [m.msg for m in read_messages(bag, topics=["/joint_states"])]
    assert [round(s.effort[1], 6) for s in states] == [round(12.5 + 0.01 * i, 6) for i in range(n_js)]
    statuses = [m.msg for m in read_messages(bag, topics=["/test_cycle/status"])]
    assert [s.speeds_done for s in statuses] == [0, 1, 2, 3, 4]
    assert statuses[0].joint_name == "joint_1"
    latched_msgs = [m.msg.data for m in read_messages(bag, topics=["/test_rec/latched"])]
    assert latched_msgs == ["configuration v1"]
    log_times = [m.log_time for m in read_messages(bag)]
    assert log_times == sorted(log_times)

    # the mcap library: same counts, real ros2msg schemas
    counts, schemas = _read_with_mcap(bag)
    assert counts == meta_counts
    enc, text = schemas["/test_cycle/status"]
    assert enc == "ros2msg" and b"uint32 speeds_done" in text and b"std_msgs/Header header" in text
    enc, text = schemas["/joint_states"]
    assert enc == "ros2msg" and b"float64[] effort" in text
    pub_node.destroy_node()
    rec.destroy_node()


def test_recorder_splits_one_bag_per_test_cycle(ros, tmp_path):
    ctx, ex = ros
    pub_node = rclpy.create_node("recorder_test_cycles", context=ctx)
    ex.add_node(pub_node)
    status = pub_node.create_publisher(TestCycleStatus, "/test_cycle/status", RELIABLE)
    js = pub_node.create_publisher(JointState, "/joint_states", RELIABLE)
    rec = _recorder(ctx, ex, tmp_path, split="cycle", cycle_tail=0.0, include=["^/test_cycle/status$", "^/joint_states$"])
    assert spin_until(ex, lambda: len(rec.recorded_topics) == 2)
    assert spin_until(ex, lambda: status.get_subscription_count() >= 1 and js.get_subscription_count() >= 1)

    sent = 0

    def send(state: int, cycle: int, joint_states: int) -> None:
        nonlocal sent
        # status first (received before the samples: subscriptions are served in no fixed order)
        status.publish(TestCycleStatus(joint_name="joint_1", cycle_id=cycle, state=state, speeds_total=2))
        sent += 1
        assert spin_until(ex, lambda: sum(rec.received.values()) == sent)
        for i in range(joint_states):
            js.publish(_joint_state(i))
        sent += joint_states
        assert spin_until(ex, lambda: sum(rec.received.values()) == sent)

    send(TestCycleStatus.IDLE, 0, 5)          # before any cycle: not recorded
    send(TestCycleStatus.RUNNING, 1, 10)
    send(TestCycleStatus.DONE, 1, 0)
    assert spin_until(ex, lambda: len(rec.bags) == 1 and rec._bag is None)
    send(TestCycleStatus.RUNNING, 2, 7)
    send(TestCycleStatus.FAILED, 2, 0)
    assert spin_until(ex, lambda: len(rec.bags) == 2 and rec._bag is None)
    send(TestCycleStatus.RUNNING, 1, 4)  # test_cycle restarted: it counts from cycle 1 again, a new bag
    send(TestCycleStatus.DONE, 1, 0)
    assert spin_until(ex, lambda: len(rec.bags) == 3 and rec._bag is None)
    send(TestCycleStatus.RUNNING, 1, 3)  # restarted once more: cycle 1 right after a cycle 1
    send(TestCycleStatus.DONE, 1, 0)
    rec.on_shutdown()
    bags = rec.bags
    assert [b.name.split("_cycle")[-1].split("_")[0] for b in bags] == ["1", "2", "1", "1"]
    assert [bag_info(b).topics["/joint_states"]["count"] for b in bags[2:]] == [4, 3]
    counts = [bag_info(b).topics for b in bags]
    assert counts[0] == {"/joint_states": {"type": "sensor_msgs/msg/JointState", "count": 10},
                         "/test_cycle/status": {"type": "jointwear_msgs/msg/TestCycleStatus", "count": 2}}
    assert counts[1]["/joint_states"]["count"] == 7 and counts[1]["/test_cycle/status"]["count"] == 2
    for b, c in zip(bags, counts):  # each per-cycle bag reads back with the mcap library too
        assert _read_with_mcap(b)[0] == {t: v["count"] for t, v in c.items()}
    assert rec.dropped == 6
    pub_node.destroy_node()
    rec.destroy_node()


def test_messages_received_before_the_sim_clock_starts_are_logged_at_its_first_time(tmp_path):
    # use_sim_time without /clock yet: ROS time reads 0; those messages must not stretch the bag to 1970
    from jointwear_ros.io.recording import Item as _Item
    from jointwear_ros.io.recording import RecordingBag as _Bag
    from jointwear_ros.io.typestore import jointwear_typestore

    store = jointwear_typestore()
    data = bytes(store.serialize_cdr(store.types["std_msgs/msg/String"](data="x"), "std_msgs/msg/String"))
    t0 = 1_795_000_000_000_000_000
    bag = _Bag(tmp_path / "b", store, {})
    for stamp in (0, 0, t0, t0 + 10):
        bag.write(_Item("/s", "std_msgs/msg/String", stamp, data))
    bag.close()
    info = bag_info(tmp_path / "b")
    assert info.message_count == 4 and info.start_ns == t0 and info.duration_ns < 100
    assert [m.log_time for m in read_messages(tmp_path / "b")] == [t0, t0 + 1, t0 + 2, t0 + 10]

    never = _Bag(tmp_path / "c", store, {})  # the clock never started: kept, at time 0
    never.write(_Item("/s", "std_msgs/msg/String", 0, data))
    never.close()
    assert [m.log_time for m in read_messages(tmp_path / "c")] == [0]


def test_messages_lost_while_the_recorder_is_stalled_are_reported_and_noted_in_the_bag(ros_context_per_test,
                                                                                    tmp_path, capsys):
    """A recorder process frozen (SIGSTOP) while a reliable publisher with a short history keeps
    publishing: DDS reports the overflowed samples as lost; the recorder logs them and notes them in
    the bag's metadata, and ``bag info`` / ``replay`` show the bag as incomplete."""
    import json
    import signal

    from jointwear_ros.cli import main as cli_main

    topic = "/jw_loss_test/joint_states"
    log = tmp_path / "recorder.log"
    rec = NodeProcess("recorder", {"output_dir": tmp_path / "bags", "discovery_period": 0.1, "include": f"['^{topic}$']",
                                   "diagnostics_period": 0.2}, config=False, log=log)
    proc = rec.proc
    ctx = ros_context_per_test
    node = rclpy.create_node("jw_loss_pub", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    from diagnostic_msgs.msg import DiagnosticArray

    diags: list = []
    node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: diags.extend(m.status), 100)
    try:
        pub = node.create_publisher(JointState, topic, QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE))
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, 30.0), log.read_text()
        sent = 0

        def burst(n: int) -> None:
            nonlocal sent
            for _ in range(n):
                pub.publish(_joint_state(sent))
                sent += 1
                if sent % 10 == 0:
                    ex.spin_once(timeout_sec=0.001)

        burst(100)
        assert pub.wait_for_all_acked(rclpy.duration.Duration(seconds=10.0))
        assert spin_until(ex, lambda: bool(diags), 20.0)  # healthy before the stall
        assert [d.level for d in diags] == [b"\x00"] * len(diags)
        proc.send_signal(signal.SIGSTOP)
        try:
            burst(3000)  # more than the history (20) and the transport buffers hold: most cannot reach it
            time.sleep(0.3)
        finally:
            proc.send_signal(signal.SIGCONT)
        burst(100)
        assert pub.wait_for_all_acked(rclpy.duration.Duration(seconds=10.0))
        # the recorder's health turns WARN with the count (before: OK), and once it has taken every
        # delivered message its counts add up (waited for: the last messages may still be in its queue)

        def accounted() -> bool:
            last = {kv.key: kv.value for kv in diags[-1].values} if diags else {}
            return diags[-1].level == b"\x01" and int(last["messages_recorded"]) + int(last["messages_lost"]) == sent

        assert spin_until(ex, accounted, 20.0), [(d.message, d.values) for d in diags[-2:]]
    finally:
        rc = rec.stop(signal.SIGINT, 30.0)
        ex.shutdown()
        node.destroy_node()
    out = log.read_text()
    assert rc == 0, out
    assert "lost before reaching the recorder" in out and "INCOMPLETE" in out, out
    (bag,) = [m.parent for m in (tmp_path / "bags").rglob("metadata.yaml")]
    info = bag_info(bag)
    recorded, lost = info.topics[topic]["count"], info.messages_lost.get(topic, 0)
    assert lost > 0 and recorded + lost == sent == 3200, (recorded, lost, sent)
    assert diags[0].message == "recording" and diags[0].name == f"recorder: {bag.name}"
    warn = [d for d in diags if d.level == b"\x01"][-1]
    assert warn.message == f"{lost} message(s) lost before reaching the recorder (bag incomplete)"
    assert {kv.key: kv.value for kv in warn.values}["messages_lost"] == str(lost)
    capsys.readouterr()
    assert cli_main(["bag", "info", str(bag), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["messages_lost"] == {topic: lost}
    assert cli_main(["bag", "info", str(bag)]) == 0
    assert f"INCOMPLETE: the recorder was told these messages were lost before it received them: {topic} {lost}" \
        in capsys.readouterr().out


def test_recorder_writes_every_message_of_a_long_stream_exactly_once_in_order_and_reports_it_on_diagnostics(
        ros, tmp_path):
    """3000 reliable messages (more than enough for a recorder that drops one in a thousand to fail):
    the bag holds exactly the published sequence, and /diagnostics shows them recorded and on disk."""
    from diagnostic_msgs.msg import DiagnosticArray

    ctx, ex = ros
    pub_node = rclpy.create_node("recorder_test_exact", context=ctx)
    ex.add_node(pub_node)
    js = pub_node.create_publisher(JointState, "/jw_exact/joint_states", RELIABLE)
    statuses: list = []
    pub_node.create_subscription(DiagnosticArray, "/diagnostics", lambda m: statuses.extend(m.status), 100)
    rec = _recorder(ctx, ex, tmp_path, include=["^/jw_exact/joint_states$"], diagnostics_period=0.2,
                    flush_period=0.2)
    assert spin_until(ex, lambda: js.get_subscription_count() >= 1)
    n = 3000
    for i in range(n):
        js.publish(_joint_state(i))
        if i % 20 == 0:
            ex.spin_once(timeout_sec=0.0)
    assert js.wait_for_all_acked(rclpy.duration.Duration(seconds=20.0))
    assert spin_until(ex, lambda: rec.received.get("/jw_exact/joint_states", 0) == n), rec.received
    bag = rec.bags[0]

    def on_disk() -> list:
        return [s for s in statuses if s.name == f"recorder: {bag.name}"
                and {kv.key: kv.value for kv in s.values}.get("messages_on_disk") == str(n)]

    assert spin_until(ex, lambda: bool(on_disk())), [(s.name, s.message, s.values) for s in statuses[-3:]]
    st = on_disk()[-1]
    values = {kv.key: kv.value for kv in st.values}
    assert st.level == b"\x00" and st.message == "recording" and st.hardware_id == str(tmp_path)
    assert values["messages_recorded"] == str(n) and values["messages_lost"] == "0"
    assert values["write_errors"] == "0" and values["bag"] == str(bag) and float(values["free_disk_mb"]) > 0
    # while open, metadata.yaml already lists what is on disk
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    # (besides the settings of the nodes on the graph, which travel with every bag)
    custom = {k: v for k, v in meta["custom_data"].items() if k != "jointwear.node_parameters"}
    assert meta["message_count"] == n and custom == {"jointwear.recording": "open"}
    rec.on_shutdown()
    assert rec.write_errors == 0 and rec.recorded == n and rec.dropped == 0
    got = [m.msg for m in read_messages(bag, topics=["/jw_exact/joint_states"])]
    assert [round(m.effort[1], 6) for m in got] == [round(12.5 + 0.01 * i, 6) for i in range(n)]
    assert [m.header.stamp.sec * 500 + m.header.stamp.nanosec // 2_000_000 for m in got] == list(range(n))
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["message_count"] == n and set(meta["custom_data"] or {}) <= {"jointwear.node_parameters"}  # closed
    pub_node.destroy_node()
    rec.destroy_node()


def test_recorder_health_warns_on_low_disk_space_and_writer_backlog_only_above_the_thresholds(ros, tmp_path):
    ctx, ex = ros
    ok = _recorder(ctx, ex, tmp_path / "a", include=["^/nothing$"])
    level, message, values = ok.health()
    assert (level, message) == (0, "recording")
    low = _recorder(ctx, ex, tmp_path / "b", include=["^/nothing$"], min_free_disk_mb=1.0e9)
    level, message, values = low.health()
    assert values[0] == ("bag", str(low.bags[0])) and float(dict(values)["free_disk_mb"]) < 1.0e9
    assert level == 1 and message.startswith("low disk space: ") and "min_free_disk_mb" in message
    ok.p["warn_backlog"] = -1  # any backlog (even none) is above this threshold
    level, message, values = ok.health()
    assert level == 1 and message.startswith("writer behind: ") and int(dict(values)["queue_backlog"]) >= 0
    for r in (ok, low):
        r.on_shutdown()
        r.destroy_node()


def test_recorder_that_cannot_create_its_bag_reports_error_and_records_nothing(ros, tmp_path):
    ctx, ex = ros
    (tmp_path / "a_file").write_text("not a directory")
    out = tmp_path / "a_file" / "bags"
    rec = _recorder(ctx, ex, out, include=["^/nothing$"])
    assert rec.fatal is not None and rec.bags == [] and rec.write_errors == 1
    level, message, values = rec.health()
    assert level == 2 and message.startswith(f"recording stopped: {out}/jointwear_") and "(ENOTDIR)" in message
    assert dict(values)["write_errors"] == "1"
    ok = _recorder(ctx, ex, tmp_path / "fine", include=["^/nothing$"])
    assert ok.fatal is None and ok.health()[0] == 0
    for r in (rec, ok):
        r.on_shutdown()
        r.destroy_node()


def test_a_robot_cycle_recorded_with_per_cycle_bags_is_one_bag_and_its_replay_matches_live(ros, tmp_path):
    """A robot cycle (three joints one after another under one cycle id) played onto the graph as the live nodes
    published it, recorded with ``split: cycle``: one bag (a joint's DONE before the last is not the end of the
    cycle; it was one bag per joint, each joint's estimate in the next joint's bag), and the replay of that bag
    gives every joint's live observations and estimate exactly."""
    import importlib

    from rosbags.highlevel import AnyReader

    from jointwear_ros.fleet.synthetic_bags import write_robot_cycle_bag
    from jointwear_ros.io.typestore import jointwear_typestore
    from jointwear_ros.observer.synthetic import synthetic_robot_cycle
    from jointwear_ros.replay import replay_bag

    rr = importlib.import_module("test_replay_robot")
    cyc = synthetic_robot_cycle(rr.JOINTS, rr.WEARS, rr.SPEEDS, rate=250.0, seed=4, noise_std=0.002,
                                torque_scales=rr.TORQUE_SCALES, temperatures=rr.TEMPERATURES, temperature_rate=2.0)
    observations, results = rr._live(cyc)
    store = jointwear_typestore()
    session = write_robot_cycle_bag(tmp_path / "session", cyc, robot="cell_7", temperature_topic="/joint_temperature",
                                    observer_params={"joint_3.torque_scale": 100.0},
                                    extra=rr._extra(store, observations, results), store=store)
    with AnyReader([session]) as reader:
        raw = [(c.topic, c.msgtype, data) for c, _t, data in reader.messages()
               if c.topic != "/parameter_events"]
    ctx, ex = ros
    pub_node = rclpy.create_node("robot_cycle_player", context=ctx)
    ex.add_node(pub_node)
    msg_types = {"sensor_msgs/msg/JointState": JointState, "jointwear_msgs/msg/TestCycleStatus": TestCycleStatus}
    from jointwear_msgs.msg import FrictionObservation, WearEstimate
    from sensor_msgs.msg import Temperature
    msg_types.update({"jointwear_msgs/msg/FrictionObservation": FrictionObservation,
                      "jointwear_msgs/msg/WearEstimate": WearEstimate, "sensor_msgs/msg/Temperature": Temperature})
    pubs = {}
    for topic, typ, _ in raw:
        if topic not in pubs:
            pubs[topic] = pub_node.create_publisher(msg_types[typ], topic, RELIABLE)
    rec = _recorder(ctx, ex, tmp_path / "bags", split="cycle", cycle_tail=0.0,
                    include=["^" + t + "$" for t in pubs])
    assert spin_until(ex, lambda: len(rec.recorded_topics) == len(pubs))
    assert spin_until(ex, lambda: all(p.get_subscription_count() >= 1 for p in pubs.values()))
    sent = 0
    for topic, typ, data in raw:  # in the live order; each status received before what follows it
        pubs[topic].publish(bytes(data))
        sent += 1
        if typ == "jointwear_msgs/msg/TestCycleStatus" or sent % 50 == 0:
            assert spin_until(ex, lambda n=sent: sum(rec.received.values()) == n), (sent, rec.received)
    assert spin_until(ex, lambda: sum(rec.received.values()) == len(raw) and rec._bag is None and rec.bags)
    rec.on_shutdown()
    assert len(rec.bags) == 1 and rec.bags[0].name.endswith("_cycle1"), [b.name for b in rec.bags]
    topics = bag_info(rec.bags[0]).topics
    assert topics["/jointwear/wear_estimate"]["count"] == 3
    op, mp = rr._params()
    rep = replay_bag(rec.bags[0], {**op, "joints": rr.JOINTS, "joint_3.torque_scale": 100.0,
                                   "temperature_topic": "/joint_temperature"},
                     {**mp, "joints": rr.JOINTS, "method": "paper"})
    assert [(c.joint_name, c.cycle_id) for c in rep.cycles] == [(j, 1) for j in rr.JOINTS]
    cmp_ = rep.comparison()
    assert cmp_["observations"]["matched"] == 9 and cmp_["observations"]["max_abs_diff"] == 0.0, cmp_
    assert cmp_["estimates"]["matched"] == 3 and cmp_["estimates"]["max_abs_diff"] == 0.0, cmp_
    pub_node.destroy_node()


def test_a_recorder_on_sim_time_without_a_clock_yet_subscribes_to_a_new_topic_within_its_wall_scan(
        ros_context_per_test, tmp_path):
    """A recorder started with use_sim_time before anything publishes /clock (the production demo: the bag played
    onto the graph brings the clock) scans the graph on the wall clock: it subscribes to a topic advertised after
    it started while no /clock has come, so nothing played is missed. On sim time its scan waited for the first
    /clock, and under load the recorder subscribed 5 s into a played production (1267 joint states missing)."""
    topic = "/jw_wall_scan_test/joint_states"
    log = tmp_path / "recorder.log"
    rec = NodeProcess("recorder", {"output_dir": tmp_path / "bags", "discovery_period": 0.2, "use_sim_time": True,
                                   "include": f"['^{topic}$']"}, config=False, log=log)
    ctx = ros_context_per_test
    node = rclpy.create_node("jw_wall_scan_pub", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        time.sleep(2.0)  # the recorder's first scan (at start-up) has passed: the topic is not there yet
        pub = node.create_publisher(JointState, topic, QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE))
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, 20.0), log.read_text()
    finally:
        node.destroy_node()
        rec.stop()
