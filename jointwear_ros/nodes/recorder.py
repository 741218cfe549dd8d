"""recorder: every topic on the graph into rosbag2 MCAP bags, as raw CDR bytes.

Topics are discovered at run time (``get_topic_names_and_types`` every
``discovery_period`` seconds, so topics that appear later are recorded too),
filtered by the ``include``/``exclude`` regular expressions, and subscribed
with ``raw=True`` and a QoS matched to their publishers (RELIABLE when every
publisher is reliable, else BEST_EFFORT; TRANSIENT_LOCAL when every publisher
offers it; KEEP_LAST ``queue_depth``, default 10000, so that a few seconds
without CPU at 2 kHz lose nothing). The bytes are written unchanged by a writer thread with
rosbags (``metadata.yaml`` version 9, MCAP storage, message definitions from
the typestore), so the callbacks only enqueue.

``split: session`` writes one bag for the node's lifetime; ``split: cycle``
starts a bag when ``/test_cycle/status`` shows a new ``cycle_id`` RUNNING and
closes it ``cycle_tail`` seconds after that cycle's DONE/ABORTED/FAILED (so
the cycle's WearEstimate is in it) or when the next cycle starts. On shutdown
the open bag is closed properly. A failed write is logged and counted; it does
not stop the node.

Messages lost before they reach the recorder (a reliable publisher's history
overflowed while the recorder was stalled; best-effort samples dropped) are
reported by DDS through the subscription's ``message_lost`` event: the recorder
logs them, counts them per topic (:attr:`RecorderNode.lost`) and writes the
counts of each bag into its ``metadata.yaml`` (``custom_data``, key
``jointwear.messages_lost``, JSON ``{topic: count}``), which ``jointwear bag
info`` and ``jointwear replay`` show: such a bag is incomplete, and a replay of
it may differ from the live run.
"""

from __future__ import annotations

import importlib
import json
import queue
import re
import signal
import threading
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from ..io.bags import LOST_KEY, STATUS_TYPE, ensure_msgtype
from ..io.typestore import JOINTWEAR_MSG_TYPES, msg_definition_dirs
from .runtime import ParamDecl, declare_parameters, run_node, subscribe_reporting_loss

__all__ = ["RecorderNode", "main", "message_class"]

_STATUS_RUNNING, _STATUS_ENDS = 1, (2, 3, 4)


def message_class(msgtype: str) -> Any:
    """The rosidl Python class of ``pkg/msg/Type`` (what ``rosidl_runtime_py.get_message`` does)."""
    parts = msgtype.split("/")
    if len(parts) != 3:
        raise ValueError(f"message type {msgtype!r} is not of the form pkg/msg/Type")
    module = importlib.import_module(f"{parts[0]}.{parts[1]}")
    return getattr(module, parts[2])


def _recorder_typestore() -> Typestore:
    """A private Jazzy typestore with jointwear_msgs (types found later are added to it)."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for d in msg_definition_dirs():
        if all((d / f"{n}.msg").is_file() for n in JOINTWEAR_MSG_TYPES):
            types: dict[str, Any] = {}
            for n in JOINTWEAR_MSG_TYPES:
                types.update(get_types_from_msg((d / f"{n}.msg").read_text(), f"jointwear_msgs/msg/{n}"))
            store.register(types)
            break
    return store


def _qos_time(d: Duration) -> QosTime:
    sec, nsec = divmod(int(d.nanoseconds), 1_000_000_000)
    return QosTime(sec=sec, nsec=nsec)


def _to_bag_qos(p: QoSProfile) -> Qos:
    return Qos(
        history=QosHistory(int(p.history)),
        depth=int(p.depth),
        reliability=QosReliability(int(p.reliability)),
        durability=QosDurability(int(p.durability)),
        deadline=_qos_time(p.deadline),
        lifespan=_qos_time(p.lifespan),
        liveliness=QosLiveliness(int(p.liveliness)),
        liveliness_lease_duration=_qos_time(p.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(p.avoid_ros_namespace_conventions),
    )


@dataclass
class _Item:
    topic: str
    msgtype: str
    stamp: int
    data: bytes


@dataclass(frozen=True)
class _Lost:
    """``count`` messages of ``topic`` lost before reception (queued in stream order)."""

    topic: str
    count: int


class _Bag:
    """One open rosbag2 writer; connections are added as topics first arrive."""

    def __init__(self, path: Path, store: Typestore, offered: dict[str, list[Qos]]) -> None:
        self.path = path
        self._store = store
        self._offered = offered
        self._writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._conns: dict[str, Any] = {}
        self._last = -1
        self._pre_clock: list[_Item] = []
        self.count = 0
        self.lost: dict[str, int] = {}

    def write(self, item: _Item) -> None:
        # Under use_sim_time the node's clock reads 0 until the first /clock arrives:
        # hold those messages and stamp them with the first real time, so the bag's
        # start time and duration are the cycle's, not 1970's (their order is kept).
        if item.stamp <= 0:
            self._pre_clock.append(item)
            return
        if self._pre_clock:
            held, self._pre_clock = self._pre_clock, []
            for h in held:
                self._write(_Item(h.topic, h.msgtype, item.stamp, h.data))
        self._write(item)

    def _write(self, item: _Item) -> None:
        conn = self._conns.get(item.topic)
        if conn is None:
            conn = self._writer.add_connection(
                item.topic, item.msgtype, typestore=self._store,
                offered_qos_profiles=self._offered.get(item.topic, ()),
            )
            self._conns[item.topic] = conn
        # strictly increasing log times keep the receive order in log-time order
        stamp = max(item.stamp, self._last + 1)
        self._writer.write(conn, stamp, item.data)
        self._last = stamp
        self.count += 1

    def close(self) -> None:
        held, self._pre_clock = self._pre_clock, []
        for h in held:  # no clock ever came: keep them at time 0 rather than lose them
            self._write(h)
        if self.lost:
            self._writer.set_custom_data(LOST_KEY, json.dumps(dict(sorted(self.lost.items()))))
        self._writer.close()


class RecorderNode(Node):
    """Record every (included, not excluded) topic into MCAP bags; see the module docstring."""

    PARAMS = (
        ParamDecl("output_dir", "bags", "directory under which bag directories are created"),
        ParamDecl("bag_prefix", "jointwear", "bag directory names start with this"),
        ParamDecl("split", "session", "session: one bag per run; cycle: one bag per test cycle"),
        ParamDecl("discovery_period", 0.5, "seconds between graph scans for new topics", 0.05, 60.0),
        ParamDecl("status_topic", "/test_cycle/status", "TestCycleStatus topic that drives split: cycle"),
        ParamDecl("cycle_tail", 5.0, "seconds (node clock) recorded after a cycle ends", 0.0, 3600.0),
        ParamDecl("queue_depth", 10000, "subscription history depth: messages buffered while the recorder is busy"),
    )

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("recorder", **kwargs)
        self.p = declare_parameters(self, self.PARAMS)
        for name, doc in (("include", "regexes; record topics matching any (empty: all)"),
                          ("exclude", "regexes; never record topics matching any")):
            self.declare_parameter(name, [], ParameterDescriptor(description=doc, dynamic_typing=True))
            self.p[name] = [str(x) for x in (self.get_parameter(name).value or [])]
        if self.p["split"] not in ("session", "cycle"):
            self.get_logger().error(f"split {self.p['split']!r} is not 'session' or 'cycle'; using 'session'")
            self.p["split"] = "session"
        self._include = self._compile("include")
        self._exclude = self._compile("exclude")
        self._store = _recorder_typestore()
        self._offered: dict[str, list[Qos]] = {}
        self._subs: dict[str, Any] = {}
        self._skipped: set[str] = set()
        self._queue: queue.SimpleQueue[_Item | _Lost | None] = queue.SimpleQueue()
        self._bag: _Bag | None = None
        self._bags: list[Path] = []
        self._cycle: int | None = None
        self._cycle_end: float | None = None
        self._cycle_ended = False  # the current cycle id has ended: RUNNING with that id again is a new cycle
        self.write_errors = 0
        self.received: dict[str, int] = {}
        #: per topic, messages DDS reported lost before they reached the recorder
        self.lost: dict[str, int] = {}
        self.dropped = 0
        self._lock = threading.Lock()
        self._stopped = False
        self._out = Path(self.p["output_dir"]).expanduser()
        if self.p["split"] == "session":
            self._open_bag(None)
        self._thread = threading.Thread(target=self._write_loop, name="recorder-writer", daemon=True)
        self._thread.start()
        self._timer = self.create_timer(float(self.p["discovery_period"]), self.discover)
        self.discover()

    # ----------------------------------------------------------------- discovery

    def _compile(self, name: str) -> list[re.Pattern[str]]:
        out = []
        for text in self.p[name]:
            try:
                out.append(re.compile(text))
            except re.error as exc:
                self.get_logger().error(f"{name} regex {text!r} is invalid ({exc}); ignored")
        return out

    def wanted(self, topic: str) -> bool:
        """True when ``topic`` passes the include/exclude filters."""
        if self._include and not any(r.search(topic) for r in self._include):
            return False
        return not any(r.search(topic) for r in self._exclude)

    def discover(self) -> None:
        """Subscribe to every wanted topic that has publishers and is not yet recorded."""
        for topic, types in self.get_topic_names_and_types():
            if topic in self._subs or topic in self._skipped or not self.wanted(topic):
                continue
            if len(types) != 1:
                self._skip(topic, f"has {len(types)} types ({', '.join(types)}); cannot record one stream")
                continue
            msgtype = types[0]
            pubs = self.get_publishers_info_by_topic(topic)
            if not pubs:
                continue  # only subscribers so far: nothing to record yet
            try:
                cls = message_class(msgtype)
            except Exception as exc:
                self._skip(topic, f"type {msgtype} is not importable here ({exc})")
                continue
            if not ensure_msgtype(self._store, msgtype):
                self._skip(topic, f"no message definition for {msgtype} found (.msg under share/)")
                continue
            reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in pubs)
            latched = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in pubs)
            qos = QoSProfile(
                history=HistoryPolicy.KEEP_LAST,
                depth=max(int(self.p["queue_depth"]), 1),
                reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
            )
            self._offered[topic] = [_to_bag_qos(p.qos_profile) for p in pubs]
            self._subs[topic] = subscribe_reporting_loss(
                self, cls, topic, self._callback(topic, msgtype), qos, self._lost_callback(topic), raw=True
            )
            self.get_logger().info(
                f"recording {topic} ({msgtype}, {'reliable' if reliable else 'best effort'}"
                f"{', transient local' if latched else ''})"
            )

    def _skip(self, topic: str, why: str) -> None:
        self._skipped.add(topic)
        self.get_logger().warning(f"not recording {topic}: {why}")

    def _callback(self, topic: str, msgtype: str) -> Any:
        clock = self.get_clock()
        q = self._queue

        received = self.received
        received[topic] = 0

        def cb(data: bytes) -> None:
            received[topic] += 1
            q.put(_Item(topic, msgtype, clock.now().nanoseconds, bytes(data)))

        return cb

    def _lost_callback(self, topic: str) -> Any:
        logger = self.get_logger()
        lost = self.lost
        lost[topic] = 0

        def cb(info: Any) -> None:
            # some executors repeat the event with total_count_change 0: count from the total
            total = int(info.total_count)
            change = total - lost[topic]
            if change <= 0:
                return
            lost[topic] = total
            self._queue.put(_Lost(topic, change))
            logger.warning(
                f"{change} message(s) on {topic} lost before reaching the recorder ({total} in all): the "
                "publisher's history overflowed while the recorder was stalled (CPU starved?); the bag "
                "is incomplete there", throttle_duration_sec=2.0,
            )

        return cb

    @property
    def recorded_topics(self) -> list[str]:
        return sorted(self._subs)

    @property
    def bags(self) -> list[Path]:
        """Bags opened so far (the last may still be open)."""
        with self._lock:
            return list(self._bags)

    # ----------------------------------------------------------------- writing

    def _new_path(self, cycle: int | None) -> Path:
        stamp = datetime.now(UTC).strftime("%Y%m%d_%H%M%S")
        base = f"{self.p['bag_prefix']}_{stamp}" + (f"_cycle{cycle}" if cycle is not None else "")
        path = self._out / base
        n = 1
        while path.exists():
            n += 1
            path = self._out / f"{base}_{n}"
        return path

    def _open_bag(self, cycle: int | None) -> None:
        path = self._new_path(cycle)
        try:
            self._out.mkdir(parents=True, exist_ok=True)
            bag = _Bag(path, self._store, self._offered)
        except Exception as exc:
            self.write_errors += 1
            self.get_logger().error(f"cannot open bag {path}: {exc}; messages are dropped until the next bag")
            return
        with self._lock:
            self._bag = bag
            self._bags.append(path)
        self.get_logger().info(f"bag {path} opened")

    def _close_bag(self) -> None:
        with self._lock:
            bag, self._bag = self._bag, None
        if bag is None:
            return
        try:
            bag.close()
            if bag.lost:
                lost = ", ".join(f"{t} {n}" for t, n in sorted(bag.lost.items()))
                self.get_logger().error(
                    f"bag {bag.path} closed ({bag.count} messages); INCOMPLETE, messages lost before "
                    f"reception: {lost} (noted in its metadata.yaml)"
                )
            else:
                self.get_logger().info(f"bag {bag.path} closed ({bag.count} messages)")
        except Exception as exc:
            self.write_errors += 1
            self.get_logger().error(f"closing bag {bag.path} failed: {exc}")

    def _status(self, item: _Item) -> tuple[int, int] | None:
        try:
            msg: Any = self._store.deserialize_cdr(item.data, STATUS_TYPE)
            return int(msg.cycle_id), int(msg.state)
        except Exception as exc:
            self.get_logger().warning(f"undecodable status message on {item.topic}: {exc}", throttle_duration_sec=5.0)
            return None

    def _handle(self, item: _Item | _Lost) -> None:
        if isinstance(item, _Lost):
            if self._bag is not None:
                self._bag.lost[item.topic] = self._bag.lost.get(item.topic, 0) + item.count
            return
        if self.p["split"] == "cycle" and item.topic == self.p["status_topic"] and item.msgtype == STATUS_TYPE:
            st = self._status(item)
            if st is not None:
                cycle, state = st
                # a RUNNING status after the cycle ended is a new cycle even with the same id
                # (a restarted test_cycle counts from 1 again)
                if state == _STATUS_RUNNING and (cycle != self._cycle or self._cycle_ended):
                    self._close_bag()
                    self._cycle, self._cycle_end, self._cycle_ended = cycle, None, False
                    self._open_bag(cycle)
                elif state in _STATUS_ENDS and cycle == self._cycle and not self._cycle_ended:
                    self._cycle_end, self._cycle_ended = item.stamp * 1e-9, True
        bag = self._bag
        if bag is None:
            self.dropped += 1
            return
        try:
            bag.write(item)
        except Exception as exc:  # a failed write never stops the recorder
            self.write_errors += 1
            self.get_logger().error(f"write to {bag.path} failed ({item.topic}): {exc}", throttle_duration_sec=5.0)

    def _tail_done(self) -> bool:
        if self._cycle_end is None or self._bag is None:
            return False
        return self.get_clock().now().nanoseconds * 1e-9 - self._cycle_end >= float(self.p["cycle_tail"])

    def _write_loop(self) -> None:
        while True:
            try:
                item = self._queue.get(timeout=0.2)
            except queue.Empty:
                item = False  # type: ignore[assignment]
            if item is None:
                break
            if item:
                self._handle(item)
            if self._tail_done():
                self._close_bag()
                self._cycle_end = None
        self._close_bag()

    def on_shutdown(self) -> None:
        """Stop discovery, write what is queued, close the bag (idempotent)."""
        if self._stopped:
            return
        self._stopped = True
        saved: dict[signal.Signals, Any] = {}
        try:  # a second Ctrl-C must not interrupt closing the bag
            for sig in (signal.SIGINT, signal.SIGTERM):
                saved[sig] = signal.signal(sig, signal.SIG_IGN)
        except ValueError:  # not the main thread
            pass
        self._timer.cancel()
        for sub in self._subs.values():
            self.destroy_subscription(sub)
        self._queue.put(None)
        deadline = time.monotonic() + 30.0
        while self._thread.is_alive() and time.monotonic() < deadline:
            self._thread.join(timeout=0.5)
        if self._thread.is_alive():
            self.get_logger().error("writer thread did not finish within 30 s; the bag may be incomplete")
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def main(args: list[str] | None = None) -> int:
    # rclpy's C++ EventsExecutor: about half the CPU per message of the Python executor
    return run_node(RecorderNode, args, events=True)


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
