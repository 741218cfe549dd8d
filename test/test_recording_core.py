"""The recorder's pure core (io/recording.py): filters, splitting, loss counts, settings capture, write errors, health.

No ROS runtime: the stream is built from the jointwear typestore's messages and fed to a Recording; the bags
it writes are read back with the package's bag reader (rosbags).
"""

from __future__ import annotations

import json
from datetime import UTC, datetime

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from jointwear_ros.contract import CycleState, DiagnosticLevel
from jointwear_ros.io.bags import NODE_PARAMS_KEY, STATUS_TYPE, bag_custom_data, bag_info, read_messages
from jointwear_ros.io.recording import (
    Item,
    Lost,
    Params,
    Recording,
    RecordingSettings,
    TopicFilter,
    count_lost,
    recorder_health,
    subscription_policy,
)
from jointwear_ros.io.typestore import jointwear_typestore

STORE = jointwear_typestore()
T = STORE.types
S = 1_000_000_000  # ns per s
T0 = 1_795_000_000


class _Log:
    """What the core logged (severity, text)."""

    def __init__(self) -> None:
        self.lines: list[tuple[str, str]] = []

    def info(self, message: str, **_: object) -> None:
        self.lines.append(("info", message))

    def warning(self, message: str, **_: object) -> None:
        self.lines.append(("warning", message))

    def error(self, message: str, **_: object) -> None:
        self.lines.append(("error", message))


def _time(t: float):
    return T["builtin_interfaces/msg/Time"](sec=int(t), nanosec=round((t % 1) * 1e9))


def _status(t: float, cycle: int, state: int, joint: str = "joint_1", joints=(), done: int = 0) -> Item:
    msg = T[STATUS_TYPE](
        header=T["std_msgs/msg/Header"](stamp=_time(t), frame_id=""), joint_name=joint, cycle_id=cycle,
        state=state, phase=0, current_speed=0.0, speeds_done=0, speeds_total=1, window_center=0.0,
        window_half_width=0.1, message="", joints=list(joints), joints_done=done)
    return Item("/test_cycle/status", STATUS_TYPE, int(t * S), bytes(STORE.serialize_cdr(msg, STATUS_TYPE)))


def _text(t: float, text: str, topic: str = "/chatter") -> Item:
    data = bytes(STORE.serialize_cdr(T["std_msgs/msg/String"](data=text), "std_msgs/msg/String"))
    return Item(topic, "std_msgs/msg/String", int(t * S), data)


def _param_changed(t: float, node: str, name: str, value: float) -> Item:
    pv = T["rcl_interfaces/msg/ParameterValue"](
        type=3, bool_value=False, integer_value=0, double_value=value, string_value="",
        byte_array_value=np.zeros(0, np.uint8), bool_array_value=np.zeros(0, bool),
        integer_array_value=np.zeros(0, np.int64), double_array_value=np.zeros(0), string_array_value=[])
    ev = T["rcl_interfaces/msg/ParameterEvent"](
        stamp=_time(t), node=f"/{node}", new_parameters=[],
        changed_parameters=[T["rcl_interfaces/msg/Parameter"](name=name, value=pv)], deleted_parameters=[])
    typ = "rcl_interfaces/msg/ParameterEvent"
    return Item("/parameter_events", typ, int(t * S), bytes(STORE.serialize_cdr(ev, typ)))


def _recording(tmp_path, split="session", tail=0.0, on_fatal=None, out=None):
    settings = RecordingSettings(out or tmp_path / "bags", split=split, cycle_tail=tail, fsync=False)
    log = _Log()
    clock = iter(range(10_000))
    rec = Recording(settings, STORE, {}, log, on_fatal=on_fatal,
                    now=lambda: datetime(2026, 11, 25, 12, 0, next(clock) % 60, tzinfo=UTC))
    rec.start()
    return rec, log


def _texts(bag) -> list[str]:
    return [m.msg.data for m in read_messages(bag, topics=["/chatter"])]


def test_topic_filter_names_invalid_regexes_and_applies_include_then_exclude():
    f = TopicFilter(include=["^/joint", "(unclosed"], exclude=["_raw$"])
    assert f.errors == ["include regex '(unclosed' is invalid (missing ), unterminated subpattern at position 0); "
                        "ignored"]
    assert [t for t in ("/joint_states", "/joint_states_raw", "/tf") if f.wanted(t)] == ["/joint_states"]
    assert TopicFilter().wanted("/anything")


@settings(deadline=None, derandomize=True)
@given(st.lists(st.tuples(st.sampled_from(["/a", "/b"]), st.integers(0, 50)), max_size=30))
def test_lost_counts_add_up_to_the_running_totals_and_a_repeated_event_counts_nothing(events):
    totals: dict[str, int] = {}
    counted: dict[str, int] = {}
    high: dict[str, int] = {}
    for topic, total in events:
        change = count_lost(totals, topic, total)
        assert change >= 0
        assert count_lost(totals, topic, total) == 0  # the same event again
        counted[topic] = counted.get(topic, 0) + change
        high[topic] = max(high.get(topic, 0), total)
    assert {k: v for k, v in counted.items() if v} == {k: v for k, v in high.items() if v}


def test_split_cycle_makes_one_bag_per_robot_cycle_and_ends_it_after_its_tail(tmp_path):
    rec, log = _recording(tmp_path, split="cycle", tail=2.0)
    assert rec.bag is None and rec.bags == []
    rec.handle(_text(T0, "before any cycle"))  # no bag open: dropped, counted
    joints = ("joint_1", "joint_2")
    rec.handle(_status(T0 + 1, 7, CycleState.RUNNING, "joint_1", joints, 0))
    rec.handle(_text(T0 + 1.5, "j1"))
    rec.handle(_status(T0 + 2, 7, CycleState.DONE, "joint_1", joints, 0))  # a joint's DONE: not the end
    rec.handle(_status(T0 + 2.5, 7, CycleState.RUNNING, "joint_2", joints, 1))
    rec.handle(_text(T0 + 3, "j2"))
    rec.handle(_status(T0 + 4, 7, CycleState.DONE, "joint_2", joints, 1))  # the last joint: the end
    assert not rec.tail_done(T0 + 5.9) and rec.bag is not None
    rec.handle(_text(T0 + 5, "the estimate, in the tail"))
    assert rec.tail_done(T0 + 6.0) and rec.bag is None
    rec.handle(_status(T0 + 10, 7, CycleState.RUNNING))  # the same id after its end: a new cycle (a restart)
    rec.handle(_text(T0 + 11, "again"))
    rec.handle(_status(T0 + 12, 8, CycleState.RUNNING))  # the next cycle before the tail: closes the previous
    rec.close_bag()
    first, second, third = rec.bags
    assert [p.name for p in rec.bags] == ["jointwear_20261125_120000_cycle7", "jointwear_20261125_120001_cycle7",
                                          "jointwear_20261125_120002_cycle8"]
    assert _texts(first) == ["j1", "j2", "the estimate, in the tail"]
    assert bag_info(first).topics["/test_cycle/status"]["count"] == 4
    assert _texts(second) == ["again"] and _texts(third) == []
    assert (rec.dropped, rec.recorded, rec.write_errors, rec.fatal) == (1, 10, 0, None)
    assert sum(1 for sev, text in log.lines if sev == "info" and "opened" in text) == 3


def test_settings_are_captured_into_every_bag_and_kept_current_from_parameter_events(tmp_path):
    rec, _ = _recording(tmp_path, split="cycle")
    rec.handle(Params("wear_estimator", {"method": "paper", "warn_threshold": 30.0}))
    rec.handle(_param_changed(T0, "wear_estimator", "warn_threshold", 25.0))
    rec.handle(_param_changed(T0, "never_asked", "x", 1.0))  # a node not asked yet: its answer will say
    rec.handle(_status(T0 + 1, 1, CycleState.RUNNING))
    rec.handle(Params("friction_observer", {"torque_scale": 2.0}))  # seen while the bag is open
    rec.handle(_status(T0 + 2, 1, CycleState.DONE))
    rec.handle(_status(T0 + 3, 2, CycleState.RUNNING))
    rec.close_bag()
    first, second = (json.loads(bag_custom_data(b)[NODE_PARAMS_KEY]) for b in rec.bags)
    assert first == {"wear_estimator": {"method": "paper", "warn_threshold": 25.0},
                     "friction_observer": {"torque_scale": 2.0}}
    assert second == first and "never_asked" not in rec.node_settings


def test_messages_lost_before_reception_are_noted_in_the_open_bag(tmp_path):
    rec, log = _recording(tmp_path)
    rec.handle(_text(T0, "a"))
    rec.handle(Lost("/chatter", 3))
    rec.handle(Lost("/chatter", 2))
    rec.close_bag()
    (bag,) = rec.bags
    assert bag_info(bag).messages_lost == {"/chatter": 5}
    assert any(sev == "error" and "INCOMPLETE" in text and "/chatter 5" in text for sev, text in log.lines)


def test_a_bag_that_cannot_be_created_stops_recording_and_everything_after_is_dropped(tmp_path):
    (tmp_path / "a_file").write_text("not a directory")
    called = []
    rec, log = _recording(tmp_path, out=tmp_path / "a_file" / "bags", on_fatal=lambda: called.append(1))
    assert called == [1] and rec.bags == [] and rec.write_errors == 1
    assert rec.fatal is not None and "cannot create the bag" in rec.fatal and "(ENOTDIR)" in rec.fatal
    rec.handle(_text(T0, "lost"))
    assert rec.dropped == 1 and rec.recorded == 0
    assert [sev for sev, text in log.lines if "recording stopped" in text] == ["error"]
    level, message, values = recorder_health(rec, rate_hz=0.0, lost=0, backlog=0, topics=1, free_disk_mb=None,
                                             min_free_disk_mb=1.0, warn_backlog=10)
    assert level is DiagnosticLevel.ERROR and message == f"recording stopped: {rec.fatal}"
    assert dict(values)["free_disk_mb"] == "unknown" and dict(values)["write_errors"] == "1"


@pytest.mark.parametrize(("lost", "free", "backlog", "level", "start"), [
    (0, 5000.0, 0, DiagnosticLevel.OK, "recording"),
    (2, 5000.0, 0, DiagnosticLevel.WARN, "2 message(s) lost"),
    (0, 10.0, 0, DiagnosticLevel.WARN, "low disk space: 10 MiB free"),
    (0, 5000.0, 11, DiagnosticLevel.WARN, "writer behind: 11 messages queued"),
    (0, 5000.0, 10, DiagnosticLevel.OK, "recording"),  # at the threshold: not above it
])
def test_health_warns_only_above_its_thresholds(tmp_path, lost, free, backlog, level, start):
    rec, _ = _recording(tmp_path)
    got, message, values = recorder_health(rec, rate_hz=12.34, lost=lost, backlog=backlog, topics=3,
                                           free_disk_mb=free, min_free_disk_mb=100.0, warn_backlog=10)
    assert got is level and message.startswith(start)
    assert [k for k, _ in values] == ["bag", "rate_hz", "messages_recorded", "messages_on_disk", "messages_lost",
                                      "messages_dropped", "queue_backlog", "write_errors", "free_disk_mb", "topics"]
    assert dict(values)["rate_hz"] == "12.3" and dict(values)["bag"] == str(rec.bags[0])
    rec.close_bag()


def test_subscription_is_reliable_and_transient_local_only_when_every_publisher_offers_it():
    def q(rel, dur):
        z = QosTime(sec=0, nsec=0)
        return Qos(history=QosHistory.KEEP_LAST, depth=1, reliability=rel, durability=dur, deadline=z, lifespan=z,
                   liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=z,
                   avoid_ros_namespace_conventions=False)

    rl, be = QosReliability.RELIABLE, QosReliability.BEST_EFFORT
    tl, vo = QosDurability.TRANSIENT_LOCAL, QosDurability.VOLATILE
    assert subscription_policy([q(rl, tl), q(rl, tl)]) == (True, True)
    assert subscription_policy([q(rl, tl), q(be, vo)]) == (False, False)
    assert subscription_policy([q(rl, vo)]) == (True, False)


def test_invalid_settings_fall_back_to_their_defaults_with_one_line_each(tmp_path):
    p = {"output_dir": str(tmp_path), "bag_prefix": "x", "split": "hourly", "status_topic": "/s", "cycle_tail": 1.0,
         "chunk_size": 10, "compression": "bzip2", "fsync": False}
    settings, problems = RecordingSettings.from_params(p)
    assert (settings.split, settings.chunk_size, settings.compression) == ("session", 1 << 20, "zstd")
    assert [line.split(" ")[0] for line in problems] == ["split", "compression", "chunk_size"]
