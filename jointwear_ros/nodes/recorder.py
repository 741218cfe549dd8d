"""recorder: every topic on the graph into rosbag2 MCAP bags, as raw CDR bytes.

Topics are discovered at run time (``get_topic_names_and_types`` every
``discovery_period`` seconds, so topics that appear later are recorded too),
filtered by the ``include``/``exclude`` regular expressions, and subscribed
with ``raw=True`` and a QoS matched to their publishers (RELIABLE when every
publisher is reliable, else BEST_EFFORT; TRANSIENT_LOCAL when every publisher
offers it; KEEP_LAST ``queue_depth``, default 10000, so that a few seconds
without CPU at 2 kHz lose nothing). The bytes are written unchanged by a writer thread
(the callbacks only enqueue) into a rosbag2 bag: ``metadata.yaml`` version 9 and
an MCAP file written with the ``mcap`` library (zstd chunks with CRCs, message
definitions from the typestore; :class:`~jointwear_ros.io.mcap_bag.McapBagWriter`).

Crash safety: every ``flush_period`` (0.5 s) the writer thread ends the open
chunk, flushes and fsyncs the file and rewrites ``metadata.yaml`` with the
counts on disk; a chunk is also closed when it reaches ``chunk_size``. A
SIGKILL, a power cut or a full disk therefore risks only the last period (plus
what was still queued); ``jointwear bag recover`` rebuilds an indexed bag from
what is on disk. A write error (disk full, file size limit, permission, I/O)
stops recording: the recorder logs the cause, closes the file as it stands,
reports ERROR on ``/diagnostics`` and the process exits with status 1.

Health: every ``diagnostics_period`` the recorder publishes a
``DiagnosticStatus`` named ``recorder: <bag name>`` on ``/diagnostics`` (rate,
messages recorded / on disk / lost / dropped, queue backlog, write errors,
free disk space): OK while recording, WARN when messages were lost before
reception, the disk has less than ``min_free_disk_mb`` free or more than
``warn_backlog`` messages wait in the writer queue; ERROR after a write error.

``split: session`` writes one bag for the node's lifetime; ``split: cycle``
starts a bag when ``/test_cycle/status`` shows a new ``cycle_id`` RUNNING and
closes it ``cycle_tail`` seconds after that cycle's end (so the cycle's
WearEstimate is in it) or when the next cycle starts. A robot cycle (several
joints one after another under one cycle id) is one bag: it ends with its last
joint's DONE or any ABORTED/FAILED (``contract.robot_cycle_over``), not with the
DONE of each joint. On shutdown
the open bag is closed properly (its MCAP summary and indexes written).

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

import errno
import importlib
import json
import os
import queue
import re
import shutil
import signal
import sys
import threading
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.typesys.store import Typestore

from ..contract import ENDED_STATES, CycleState, robot_cycle_over
from ..io.bags import LOST_KEY, NODE_PARAMS_KEY, STATUS_TYPE, ensure_msgtype
from ..io.mcap_bag import COMPRESSIONS, McapBagWriter, qos_profiles_v9
from ..io.params import parameter_value
from ..io.typestore import new_jointwear_typestore
from .runtime import ParamDecl, declare_parameters, run_node, subscribe_reporting_loss

__all__ = ["RecorderNode", "main", "message_class"]

def message_class(msgtype: str) -> Any:
    """The rosidl Python class of ``pkg/msg/Type`` (what ``rosidl_runtime_py.get_message`` does)."""
    parts = msgtype.split("/")
    if len(parts) != 3:
        raise ValueError(f"message type {msgtype!r} is not of the form pkg/msg/Type")
    module = importlib.import_module(f"{parts[0]}.{parts[1]}")
    return getattr(module, parts[2])


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


@dataclass(frozen=True)
class _Params:
    """A node's parameters as its ``~/get_parameters`` service answered (queued for the writer thread)."""

    node: str
    values: dict[str, Any]


class _Bag:
    """One open bag (:class:`~jointwear_ros.io.mcap_bag.McapBagWriter`); connections are added as topics arrive.

    :meth:`sync` ends the open chunk, flushes and fsyncs the file and rewrites
    metadata.yaml: what was written before the last sync survives a SIGKILL or
    a full disk (``jointwear bag recover`` rebuilds the bag from it).
    """

    def __init__(self, path: Path, store: Typestore, offered: dict[str, list[Qos]], *,
                 chunk_size: int = 1 << 20, compression: str = "zstd", fsync: bool = True) -> None:
        self.path = path
        self._store = store
        self._offered = offered
        self._writer = McapBagWriter(path, chunk_size=chunk_size, compression=compression, fsync=fsync)
        self._conns: dict[str, int] = {}
        self._last = -1
        self._pre_clock: list[_Item] = []
        self.count = 0
        self.lost: dict[str, int] = {}
        self._lost_noted: dict[str, int] = {}
        #: node -> parameters as they stood when the bag opened (or when the node was first seen)
        self.node_params: dict[str, dict[str, Any]] = {}

    def note_params(self, node: str, values: dict[str, Any]) -> None:
        """Keep ``node``'s settings in metadata.yaml (``custom_data`` jointwear.node_parameters): the first
        snapshot of each node only, its later changes are the bag's /parameter_events."""
        if node in self.node_params:
            return
        self.node_params[node] = dict(values)
        self._writer.custom_data[NODE_PARAMS_KEY] = json.dumps(self.node_params, sort_keys=True, default=str)
        self._writer._meta_dirty = True

    @property
    def synced(self) -> int:
        """Messages on disk in complete chunks (safe from a crash)."""
        return self._writer.synced_count

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
            msgdef, _ = self._store.generate_msgdef(item.msgtype, ros_version=2)
            conn = self._writer.add_connection(
                item.topic, item.msgtype, msgdef,
                encoding="ros2idl" if msgdef.startswith("=" * 80 + "\nIDL: ") else "ros2msg",
                rihs01=self._store.hash_rihs01(item.msgtype),
                offered_qos_profiles=qos_profiles_v9(self._offered.get(item.topic, ())),
            )
            self._conns[item.topic] = conn
        # strictly increasing log times keep the receive order in log-time order
        stamp = max(item.stamp, self._last + 1)
        self._writer.write(conn, stamp, item.data)
        self._last = stamp
        self.count += 1

    def _note_lost(self) -> None:
        if self.lost != self._lost_noted:
            self._writer.custom_data[LOST_KEY] = json.dumps(dict(sorted(self.lost.items())))
            self._lost_noted = dict(self.lost)

    def sync(self) -> None:
        """Make everything written so far durable (raises OSError when the disk refuses)."""
        self._note_lost()
        self._writer.sync()

    def close(self) -> None:
        held, self._pre_clock = self._pre_clock, []
        for h in held:  # no clock ever came: keep them at time 0 rather than lose them
            self._write(h)
        self._note_lost()
        self._writer.close()

    def abort(self) -> None:
        """Close the file after a write error, without a summary (what was synced stays recoverable)."""
        self._writer.abort()


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
        ParamDecl("flush_period", 0.5, "seconds between syncs (end chunk, flush, fsync, metadata.yaml): at most "
                  "this much recording is at risk in a crash", 0.05, 60.0),
        ParamDecl("chunk_size", 1048576, "an MCAP chunk is also closed when its data exceeds this many bytes"),
        ParamDecl("compression", "zstd", "chunk compression: zstd, lz4 or none"),
        ParamDecl("fsync", True, "fsync the bag at each sync (survives power loss, not only a killed process)"),
        ParamDecl("diagnostics_topic", "/diagnostics", "DiagnosticArray output (recorder health)"),
        ParamDecl("diagnostics_period", 1.0, "seconds between health reports on diagnostics_topic", 0.1, 60.0),
        ParamDecl("hardware_id", "", "DiagnosticStatus.hardware_id (empty = the output directory)"),
        ParamDecl("warn_backlog", 2000, "WARN on /diagnostics when more messages than this wait in the writer queue "
                  "(they are at risk in a crash)"),
        ParamDecl("min_free_disk_mb", 1024.0, "WARN on /diagnostics when the output disk has less free space (MiB)",
                  0.0, 1.0e9),
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
        if self.p["compression"] not in COMPRESSIONS:
            self.get_logger().error(f"compression {self.p['compression']!r} is not one of "
                                    f"{', '.join(COMPRESSIONS)}; using 'zstd'")
            self.p["compression"] = "zstd"
        if int(self.p["chunk_size"]) < 1024:
            self.get_logger().error(f"chunk_size {self.p['chunk_size']} is below 1024 bytes; using 1048576")
            self.p["chunk_size"] = 1048576
        self._include = self._compile("include")
        self._exclude = self._compile("exclude")
        self._store = new_jointwear_typestore(required=False)  # private: types found later are added
        self._offered: dict[str, list[Qos]] = {}
        self._subs: dict[str, Any] = {}
        self._skipped: set[str] = set()
        self._queue: queue.SimpleQueue[_Item | _Lost | _Params | None] = queue.SimpleQueue()
        #: every node's parameters (writer thread): asked once per node, kept current from /parameter_events
        self._settings: dict[str, dict[str, Any]] = {}
        self._asked: dict[str, int] = {}
        self._bag: _Bag | None = None
        self._bags: list[Path] = []
        self._cycle: int | None = None
        self._cycle_end: float | None = None
        self._cycle_ended = False  # the current cycle id has ended: RUNNING with that id again is a new cycle
        self.write_errors = 0
        #: the write error that stopped recording (None while healthy); the process then exits non-zero
        self.fatal: str | None = None
        #: a process running this node stops itself after a fatal write error (set by ``main``)
        self.stop_process_on_fatal = False
        self.received: dict[str, int] = {}
        #: per topic, messages DDS reported lost before they reached the recorder
        self.lost: dict[str, int] = {}
        self.dropped = 0
        #: messages written to bags (all bags) and, of those, made durable by a sync
        self.recorded = 0
        self._synced_closed = 0
        self._last_bag_name = ""
        self._lock = threading.Lock()
        self._stopped = False
        self._out = Path(self.p["output_dir"]).expanduser()
        self._hardware_id = str(self.p["hardware_id"]) or str(self._out)
        self.diag_pub = self.create_publisher(DiagnosticArray, str(self.p["diagnostics_topic"]), 10)
        self._diag_last = (time.monotonic(), 0)
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
        """Subscribe to every wanted topic that has publishers and is not yet recorded; ask every new node
        for its parameters (they go into each bag's metadata.yaml)."""
        self._ask_settings()
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

    def _ask_settings(self) -> None:
        """Ask each node not asked yet for all its parameters (``~/list_parameters``, then ``~/get_parameters``,
        asynchronously); the answer is queued to the writer thread. A node whose services are not up yet
        is asked again at the next discovery (at most 20 times)."""
        from rcl_interfaces.srv import GetParameters, ListParameters

        me = self.get_fully_qualified_name()
        for name, ns in self.get_node_names_and_namespaces():
            fqn = (ns.rstrip("/") + "/" + name) if ns != "/" else "/" + name
            if fqn == me or name.startswith("_") or self._asked.get(fqn, 0) < 0 or self._asked.get(fqn, 0) >= 20:
                continue
            self._asked[fqn] = self._asked.get(fqn, 0) + 1
            lister = self.create_client(ListParameters, f"{fqn}/list_parameters")
            if not lister.service_is_ready():
                self.destroy_client(lister)
                continue
            self._asked[fqn] = -1  # asked: not again

            def listed(future: Any, fqn: str = fqn, lister: Any = lister) -> None:
                self.destroy_client(lister)
                try:
                    names = list(future.result().result.names)
                except Exception:
                    return
                getter = self.create_client(GetParameters, f"{fqn}/get_parameters")

                def got(f2: Any) -> None:
                    self.destroy_client(getter)
                    try:
                        values = [parameter_value(v) for v in f2.result().values]
                    except Exception:
                        return
                    self._queue.put(_Params(fqn.lstrip("/"), {n: v for n, v in zip(names, values) if v is not None}))

                getter.call_async(GetParameters.Request(names=names)).add_done_callback(got)

            lister.call_async(ListParameters.Request()).add_done_callback(listed)

    def _settings_event(self, item: _Item) -> None:
        """Keep the settings snapshot current from a recorded ParameterEvent (new bags start from it)."""
        try:
            ev: Any = self._store.deserialize_cdr(item.data, "rcl_interfaces/msg/ParameterEvent")
        except Exception:
            return
        node = str(ev.node).lstrip("/")
        if node not in self._settings:
            return  # not asked yet: its answer will hold these values
        for param in (*ev.new_parameters, *ev.changed_parameters):
            value = parameter_value(param.value)
            if value is not None:
                self._settings[node][str(param.name)] = value
        for param in ev.deleted_parameters:
            self._settings[node].pop(str(param.name), None)

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
        if self.fatal is not None:
            return
        path = self._new_path(cycle)
        try:
            self._out.mkdir(parents=True, exist_ok=True)
            bag = _Bag(path, self._store, self._offered, chunk_size=int(self.p["chunk_size"]),
                       compression=str(self.p["compression"]), fsync=bool(self.p["fsync"]))
        except OSError as exc:
            self._fail(path, f"cannot create the bag: {_os_error(exc)}")
            return
        for node, values in sorted(self._settings.items()):
            bag.note_params(node, values)
        with self._lock:
            self._bag = bag
            self._bags.append(path)
            self._last_bag_name = path.name
        self._next_sync = time.monotonic() + float(self.p["flush_period"])
        self.get_logger().info(f"bag {path} opened")

    def _close_bag(self) -> None:
        with self._lock:
            bag, self._bag = self._bag, None
        if bag is None:
            return
        try:
            bag.close()
        except OSError as exc:
            self._synced_closed += bag.synced
            bag.abort()
            self._fail(bag.path, f"closing the bag failed: {_os_error(exc)}")
            return
        self._synced_closed += bag.count
        if bag.lost:
            lost = ", ".join(f"{t} {n}" for t, n in sorted(bag.lost.items()))
            self.get_logger().error(
                f"bag {bag.path} closed ({bag.count} messages); INCOMPLETE, messages lost before "
                f"reception: {lost} (noted in its metadata.yaml)"
            )
        else:
            self.get_logger().info(f"bag {bag.path} closed ({bag.count} messages)")

    def _fail(self, path: Path, why: str) -> None:
        """A write error: stop recording, keep what is on disk, report ERROR, stop the process (``main``)."""
        self.write_errors += 1
        with self._lock:
            bag, self._bag = self._bag, None
        if bag is not None:
            self._synced_closed += bag.synced
            bag.abort()
        self.fatal = f"{path}: {why}"
        self._last_bag_name = path.name
        self.get_logger().error(
            f"recording stopped: {self.fatal}; {self.synced} message(s) are on disk in complete chunks "
            f"(`jointwear bag recover {path}` rebuilds the bag); the recorder exits with an error"
        )
        self.publish_diagnostics()
        try:
            self.diag_pub.wait_for_all_acked(Duration(seconds=1.0))
        except Exception:  # pragma: no cover - best effort on the way out
            pass
        if self.stop_process_on_fatal:
            os.kill(os.getpid(), signal.SIGTERM)  # run_node's handler: a clean stop, then main returns 1

    @property
    def synced(self) -> int:
        """Messages made durable (complete chunks, fsynced) in all bags so far."""
        bag = self._bag
        return self._synced_closed + (bag.synced if bag is not None else 0)

    def _status(self, item: _Item) -> tuple[int, int] | None:
        try:
            msg: Any = self._store.deserialize_cdr(item.data, STATUS_TYPE)
            # a robot cycle (several joints, one cycle id) ends with its last joint's DONE or any ABORTED/FAILED;
            # a joint's DONE before the last is not the end (one bag per robot cycle, not per joint)
            over = robot_cycle_over(int(msg.state), len(msg.joints), int(msg.joints_done))
            return int(msg.cycle_id), int(msg.state) if over or int(msg.state) not in ENDED_STATES else -1
        except Exception as exc:
            self.get_logger().warning(f"undecodable status message on {item.topic}: {exc}", throttle_duration_sec=5.0)
            return None

    def _handle(self, item: _Item | _Lost | _Params) -> None:
        if isinstance(item, _Params):
            self._settings[item.node] = dict(item.values)
            if self._bag is not None:
                self._bag.note_params(item.node, item.values)
            return
        if isinstance(item, _Lost):
            if self._bag is not None:
                self._bag.lost[item.topic] = self._bag.lost.get(item.topic, 0) + item.count
            return
        if item.msgtype == "rcl_interfaces/msg/ParameterEvent":
            self._settings_event(item)
        if self.fatal is not None:
            self.dropped += 1
            return
        if self.p["split"] == "cycle" and item.topic == self.p["status_topic"] and item.msgtype == STATUS_TYPE:
            st = self._status(item)
            if st is not None:
                cycle, state = st
                # a RUNNING status after the cycle ended is a new cycle even with the same id
                # (a restarted test_cycle counts from 1 again)
                if state == CycleState.RUNNING and (cycle != self._cycle or self._cycle_ended):
                    self._close_bag()
                    self._cycle, self._cycle_end, self._cycle_ended = cycle, None, False
                    self._open_bag(cycle)
                elif state in ENDED_STATES and cycle == self._cycle and not self._cycle_ended:
                    self._cycle_end, self._cycle_ended = item.stamp * 1e-9, True
        bag = self._bag
        if bag is None:
            self.dropped += 1
            return
        try:
            bag.write(item)
        except OSError as exc:  # disk full, file too large, I/O error: the bag cannot go on
            self._fail(bag.path, f"write failed ({item.topic}): {_os_error(exc)}")
            return
        except Exception as exc:  # a message that cannot be written (e.g. no definition): skip it
            self.write_errors += 1
            self.get_logger().error(f"write to {bag.path} failed ({item.topic}): {exc}", throttle_duration_sec=5.0)
            return
        self.recorded += 1

    def _sync(self) -> None:
        bag = self._bag
        self._next_sync = time.monotonic() + float(self.p["flush_period"])
        if bag is None:
            return
        try:
            bag.sync()
        except OSError as exc:
            self._fail(bag.path, f"flushing to disk failed: {_os_error(exc)}")

    def _tail_done(self) -> bool:
        if self._cycle_end is None or self._bag is None:
            return False
        return self.get_clock().now().nanoseconds * 1e-9 - self._cycle_end >= float(self.p["cycle_tail"])

    def _write_loop(self) -> None:
        # the health report is published from this thread too (not an executor timer): it keeps coming
        # while callbacks are busy, and the EventsExecutor is left with one timer (discovery)
        diag_period = float(self.p["diagnostics_period"])
        self._next_sync = time.monotonic() + float(self.p["flush_period"])
        next_diag = time.monotonic() + diag_period
        while True:
            try:
                item = self._queue.get(timeout=0.1)
            except queue.Empty:
                item = False  # type: ignore[assignment]
            if item is None:
                break
            if item:
                self._handle(item)
            now = time.monotonic()
            if now >= self._next_sync:
                self._sync()
            if now >= next_diag:
                next_diag = now + diag_period
                self.publish_diagnostics()
            if self._tail_done():
                self._close_bag()
                self._cycle_end = None
        self._close_bag()

    # ----------------------------------------------------------------- health

    def health(self) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, key/values) of the recorder's DiagnosticStatus."""
        now = time.monotonic()
        t0, n0 = self._diag_last
        recorded = self.recorded
        rate = (recorded - n0) / (now - t0) if now > t0 else 0.0
        self._diag_last = (now, recorded)
        bag = self._bag
        lost = sum(self.lost.values())
        free_mb = _free_mb(self._out)
        low_disk = free_mb is not None and free_mb < float(self.p["min_free_disk_mb"])
        backlog = self._queue.qsize()
        values = [
            ("bag", str(bag.path) if bag is not None else ""),
            ("rate_hz", f"{rate:.1f}"),
            ("messages_recorded", str(recorded)),
            ("messages_on_disk", str(self.synced)),
            ("messages_lost", str(lost)),
            ("messages_dropped", str(self.dropped)),
            ("queue_backlog", str(backlog)),
            ("write_errors", str(self.write_errors)),
            ("free_disk_mb", f"{free_mb:.0f}" if free_mb is not None else "unknown"),
            ("topics", str(len(self._subs))),
        ]
        if self.fatal is not None:
            return 2, f"recording stopped: {self.fatal}", values
        if lost:
            return 1, f"{lost} message(s) lost before reaching the recorder (bag incomplete)", values
        if low_disk:
            return 1, f"low disk space: {free_mb:.0f} MiB free (< min_free_disk_mb)", values
        if backlog > int(self.p["warn_backlog"]):
            return 1, f"writer behind: {backlog} messages queued (> warn_backlog), at risk in a crash", values
        if bag is None:
            return 0, "waiting for a test cycle" if self.p["split"] == "cycle" else "no bag open", values
        return 0, "recording", values

    def publish_diagnostics(self) -> None:
        """Publish the recorder's health (``recorder: <bag>``) on the diagnostics topic."""
        level, message, values = self.health()
        s = DiagnosticStatus()
        s.level = bytes([level])
        s.name = f"recorder: {self._last_bag_name or '(no bag)'}"
        s.hardware_id = self._hardware_id
        s.message = message
        s.values = [KeyValue(key=k, value=v) for k, v in values]
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        arr.status = [s]
        try:
            self.diag_pub.publish(arr)
        except Exception:  # the context is shutting down
            pass

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
        self.publish_diagnostics()  # the final state (ERROR after a write error)
        try:
            self.diag_pub.wait_for_all_acked(Duration(seconds=0.5))
        except Exception:  # pragma: no cover - best effort on the way out
            pass
        for sig, handler in saved.items():
            signal.signal(sig, handler)


def _os_error(exc: OSError) -> str:
    name = errno.errorcode.get(exc.errno or 0, "")
    return f"{exc.strerror or exc} ({name})" if name else str(exc)


def _free_mb(path: Path) -> float | None:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return shutil.disk_usage(p).free / 2**20
    except OSError:
        return None


def main(args: list[str] | None = None) -> int:
    """Console script ``recorder``: exit status 1 after a write error (disk full, file too large, ...)."""
    # a file-size limit (RLIMIT_FSIZE) must fail the write (EFBIG), not kill the process unreported
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    made: list[RecorderNode] = []

    def factory() -> RecorderNode:
        node = RecorderNode()
        node.stop_process_on_fatal = True
        made.append(node)
        return node

    # rclpy's C++ EventsExecutor: about half the CPU per message of the Python executor
    rc = run_node(factory, args, events=True)
    if made and made[0].fatal is not None:
        print(f"recorder: error: {made[0].fatal}", file=sys.stderr)
        return 1
    return rc


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
