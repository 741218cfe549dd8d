"""What the recorder writes and when: the pure core of ``nodes/recorder.py`` (no ROS runtime).

The recorder node discovers topics, subscribes and queues what arrives; every
decision about that stream is made here, in the writer thread, without rclpy:

- :class:`TopicFilter`: which topics are recorded (``include``/``exclude`` regexes);
- :class:`Recording`: the bags of a session: one bag (``split: session``) or
  one per cycle (``split: cycle``: a bag starts when a status shows a new
  ``cycle_id`` RUNNING and ends ``cycle_tail`` seconds after that robot cycle
  ended, :func:`~jointwear_ros.contract.robot_cycle_over`), messages lost
  before reception counted per bag, the settings of the graph's nodes captured
  into every bag (kept current from the recorded ``/parameter_events``),
  periodic syncs, and a write error that stops recording (``fatal``);
- :class:`RecordingBag`: one open bag (MCAP via
  :class:`~jointwear_ros.io.mcap_bag.McapBagWriter`, metadata.yaml v9);
- :func:`recorder_health`: the level, message and key/values of the
  recorder's ``/diagnostics`` status.

The stream is a sequence of :class:`Item` (a message's raw CDR bytes),
:class:`Lost` (messages DDS reported lost) and :class:`Params` (a node's
parameters as its ``~/get_parameters`` answered), in arrival order.

**Crash safety**: every ``flush_period`` (0.5 s) the writer ends the open
chunk, flushes and fsyncs the file and rewrites ``metadata.yaml`` with the
counts on disk; a chunk is also closed when it reaches ``chunk_size``. A
SIGKILL, a power cut or a full disk therefore risks only the last period (plus
what was still queued); ``jointwear bag recover`` rebuilds an indexed bag from
what is on disk. A write error (disk full, file size limit, permission, I/O)
stops recording: the cause is logged, the file closed as it stands, the
health says ERROR and the recorder process exits with status 1.

**Health** (``recorder: <bag name>``): rate, messages recorded / on disk /
lost / dropped, queue backlog, write errors, free disk space; OK while
recording, WARN when messages were lost before reception, the disk has less
than ``min_free_disk_mb`` free or more than ``warn_backlog`` messages wait in
the writer queue; ERROR after a write error.

**Losses**: messages lost before they reach the recorder (a reliable
publisher's history overflowed while the recorder was stalled; best-effort
samples dropped) are counted per bag into its ``metadata.yaml``
(``custom_data`` ``jointwear.messages_lost``, JSON ``{topic: count}``), which
``jointwear bag info`` and ``jointwear replay`` show: such a bag is
incomplete, and a replay of it may differ from the live run. On shutdown the
open bag is closed properly (its MCAP summary and indexes written).
"""

from __future__ import annotations

import errno
import json
import queue
import re
import shutil
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Protocol

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.typesys.store import Typestore

from ..contract import ENDED_STATES, CycleState, DiagnosticLevel, status_from_msg
from .bags import LOST_KEY, NODE_PARAMS_KEY, STATUS_TYPE
from .mcap_bag import COMPRESSIONS, McapBagWriter, qos_profiles_v9
from .params import parameter_value

__all__ = [
    "SPLITS",
    "Item",
    "Logger",
    "Lost",
    "Params",
    "Recording",
    "RecordingBag",
    "RecordingSettings",
    "TopicFilter",
    "WriterThread",
    "bag_qos",
    "count_lost",
    "free_mb",
    "os_error_text",
    "recorder_health",
    "subscription_policy",
]

#: the ``split`` values: one bag per session, or one per (robot) test cycle
SPLITS = ("session", "cycle")
#: the writer thread's pause after a batch, s (the messages that come meanwhile are the next batch), and the most
#: elements it takes in one batch: the writer woke for every /joint_states message of a demo at 3x (1.5 kHz)
WRITER_PAUSE = 0.01
WRITER_BATCH = 2000
PARAMETER_EVENT_TYPE = "rcl_interfaces/msg/ParameterEvent"


class Logger(Protocol):
    """What the core logs through (an rclpy logger fits; ``throttle_duration_sec`` as rclpy's)."""

    def info(self, message: str, **kwargs: Any) -> Any: ...

    def warning(self, message: str, **kwargs: Any) -> Any: ...

    def error(self, message: str, **kwargs: Any) -> Any: ...


@dataclass
class Item:
    """One received message: its topic, type, receive time (ns, node clock) and raw CDR bytes."""

    topic: str
    msgtype: str
    stamp: int
    data: bytes


@dataclass(frozen=True)
class Lost:
    """``count`` messages of ``topic`` lost before reception (queued in stream order)."""

    topic: str
    count: int


@dataclass(frozen=True)
class Params:
    """A node's parameters as its ``~/get_parameters`` service answered."""

    node: str
    values: dict[str, Any]


class TopicFilter:
    """``include``/``exclude`` regular expressions; :attr:`errors` names the invalid ones (ignored)."""

    def __init__(self, include: Sequence[str] = (), exclude: Sequence[str] = ()) -> None:
        self.errors: list[str] = []
        self.include = self._compile("include", include)
        self.exclude = self._compile("exclude", exclude)

    def _compile(self, name: str, texts: Sequence[str]) -> list[re.Pattern[str]]:
        out = []
        for text in texts:
            try:
                out.append(re.compile(text))
            except re.error as exc:
                self.errors.append(f"{name} regex {text!r} is invalid ({exc}); ignored")
        return out

    def wanted(self, topic: str) -> bool:
        """True when ``topic`` matches an include (or there is none) and no exclude."""
        if self.include and not any(r.search(topic) for r in self.include):
            return False
        return not any(r.search(topic) for r in self.exclude)


@dataclass
class RecordingSettings:
    """The recorder parameters the core uses (declared in ``nodes/recorder.py`` ``PARAMETERS``)."""

    output_dir: Path
    bag_prefix: str = "jointwear"
    split: str = "session"
    status_topic: str = "/test_cycle/status"
    cycle_tail: float = 5.0
    chunk_size: int = 1 << 20
    compression: str = "zstd"
    fsync: bool = True

    @classmethod
    def from_params(cls, p: Mapping[str, Any]) -> tuple[RecordingSettings, list[str]]:
        """The settings of the node's parameters, and one line per unusable value (replaced by its default)."""
        problems = []
        split, compression, chunk = str(p["split"]), str(p["compression"]), int(p["chunk_size"])
        if split not in SPLITS:
            problems.append(f"split {split!r} is not 'session' or 'cycle'; using 'session'")
            split = "session"
        if compression not in COMPRESSIONS:
            problems.append(f"compression {compression!r} is not one of {', '.join(COMPRESSIONS)}; using 'zstd'")
            compression = "zstd"
        if chunk < 1024:
            problems.append(f"chunk_size {chunk} is below 1024 bytes; using 1048576")
            chunk = 1 << 20
        return cls(Path(str(p["output_dir"])).expanduser(), str(p["bag_prefix"]), split, str(p["status_topic"]),
                   float(p["cycle_tail"]), chunk, compression, bool(p["fsync"])), problems


class RecordingBag:
    """One open bag (:class:`~jointwear_ros.io.mcap_bag.McapBagWriter`); connections are added as topics arrive.

    :meth:`sync` ends the open chunk, flushes and fsyncs the file and rewrites
    metadata.yaml: what was written before the last sync survives a SIGKILL or
    a full disk (``jointwear bag recover`` rebuilds the bag from it).
    """

    def __init__(self, path: Path, store: Typestore, offered: Mapping[str, list[Qos]], *,
                 chunk_size: int = 1 << 20, compression: str = "zstd", fsync: bool = True) -> None:
        self.path = path
        self._store = store
        self._offered = offered
        self._writer = McapBagWriter(path, chunk_size=chunk_size, compression=compression, fsync=fsync)
        self._conns: dict[str, int] = {}
        self._last = -1
        self._pre_clock: list[Item] = []
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

    def write(self, item: Item) -> None:
        # Under use_sim_time the node's clock reads 0 until the first /clock arrives:
        # hold those messages and stamp them with the first real time, so the bag's
        # start time and duration are the cycle's, not 1970's (their order is kept).
        if item.stamp <= 0:
            self._pre_clock.append(item)
            return
        if self._pre_clock:
            held, self._pre_clock = self._pre_clock, []
            for h in held:
                self._write(Item(h.topic, h.msgtype, item.stamp, h.data))
        self._write(item)

    def _write(self, item: Item) -> None:
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


class Recording:
    """The writer side of a recorder: bags, splitting, loss counts, settings capture, write errors.

    Feed it the stream with :meth:`handle`; call :meth:`sync` every flush
    period and :meth:`tail_done` (with the node clock) to end a cycle's bag.
    ``on_fatal`` is called once recording has stopped after a write error
    (:attr:`fatal` says why). Only the writer thread calls the methods; the
    counters and :attr:`bags` may be read from any thread.
    """

    def __init__(self, settings: RecordingSettings, store: Typestore, offered: Mapping[str, list[Qos]],
                 log: Logger, on_fatal: Callable[[], None] | None = None,
                 now: Callable[[], datetime] = lambda: datetime.now(UTC)) -> None:
        self.settings = settings
        self._store = store
        self._offered = offered
        self.log = log
        self.on_fatal = on_fatal
        self._now = now
        #: every node's parameters: the answer of its ``~/get_parameters``, kept current from /parameter_events
        self.node_settings: dict[str, dict[str, Any]] = {}
        self.bag: RecordingBag | None = None
        self._bags: list[Path] = []
        self._lock = threading.Lock()
        self.cycle: int | None = None
        self.cycle_end: float | None = None
        self.cycle_ended = False  # the current cycle id has ended: RUNNING with that id again is a new cycle
        self.write_errors = 0
        #: the write error that stopped recording (None while healthy)
        self.fatal: str | None = None
        self.dropped = 0
        #: messages written to bags (all bags) and, of those, made durable by a sync
        self.recorded = 0
        self._synced_closed = 0
        self.last_bag_name = ""
        self._rate_from: tuple[float, int] | None = None

    @property
    def bags(self) -> list[Path]:
        """Bags opened so far (the last may still be open)."""
        with self._lock:
            return list(self._bags)

    @property
    def synced(self) -> int:
        """Messages made durable (complete chunks, fsynced) in all bags so far."""
        bag = self.bag
        return self._synced_closed + (bag.synced if bag is not None else 0)

    def rate(self, now: float) -> float:
        """Messages recorded per second since the previous call (``now``: a monotonic clock, s; 0 at the first)."""
        t0, n0 = self._rate_from if self._rate_from is not None else (now, self.recorded)
        recorded = self.recorded
        self._rate_from = (now, recorded)
        return (recorded - n0) / (now - t0) if now > t0 else 0.0

    def start(self) -> None:
        """Open the session's bag (``split: session``); a cycle's bag opens with its cycle."""
        if self.settings.split == "session":
            self.open_bag(None)

    # -- bags ------------------------------------------------------------------
    def _new_path(self, cycle: int | None) -> Path:
        s = self.settings
        base = f"{s.bag_prefix}_{self._now().strftime('%Y%m%d_%H%M%S')}" + (
            f"_cycle{cycle}" if cycle is not None else "")
        path = s.output_dir / base
        n = 1
        while path.exists():
            n += 1
            path = s.output_dir / f"{base}_{n}"
        return path

    def open_bag(self, cycle: int | None) -> None:
        if self.fatal is not None:
            return
        s = self.settings
        path = self._new_path(cycle)
        try:
            s.output_dir.mkdir(parents=True, exist_ok=True)
            bag = RecordingBag(path, self._store, self._offered, chunk_size=s.chunk_size,
                               compression=s.compression, fsync=s.fsync)
        except OSError as exc:
            self.fail(path, f"cannot create the bag: {os_error_text(exc)}")
            return
        for node, values in sorted(self.node_settings.items()):
            bag.note_params(node, values)
        with self._lock:
            self.bag = bag
            self._bags.append(path)
            self.last_bag_name = path.name
        self.log.info(f"bag {path} opened")

    def close_bag(self) -> None:
        with self._lock:
            bag, self.bag = self.bag, None
        if bag is None:
            return
        try:
            bag.close()
        except OSError as exc:
            self._synced_closed += bag.synced
            bag.abort()
            self.fail(bag.path, f"closing the bag failed: {os_error_text(exc)}")
            return
        self._synced_closed += bag.count
        if bag.lost:
            lost = ", ".join(f"{t} {n}" for t, n in sorted(bag.lost.items()))
            self.log.error(
                f"bag {bag.path} closed ({bag.count} messages); INCOMPLETE, messages lost before "
                f"reception: {lost} (noted in its metadata.yaml)"
            )
        else:
            self.log.info(f"bag {bag.path} closed ({bag.count} messages)")

    def fail(self, path: Path, why: str) -> None:
        """A write error: stop recording, keep what is on disk, then ``on_fatal``."""
        self.write_errors += 1
        with self._lock:
            bag, self.bag = self.bag, None
        if bag is not None:
            self._synced_closed += bag.synced
            bag.abort()
        self.fatal = f"{path}: {why}"
        self.last_bag_name = path.name
        self.log.error(
            f"recording stopped: {self.fatal}; {self.synced} message(s) are on disk in complete chunks "
            f"(`jointwear bag recover {path}` rebuilds the bag); the recorder exits with an error"
        )
        if self.on_fatal is not None:
            self.on_fatal()

    def sync(self) -> None:
        """Make the open bag durable (a refusal of the disk is a write error)."""
        bag = self.bag
        if bag is None:
            return
        try:
            bag.sync()
        except OSError as exc:
            self.fail(bag.path, f"flushing to disk failed: {os_error_text(exc)}")

    def tail_done(self, now_s: float) -> bool:
        """Whether the ended cycle's bag has had its ``cycle_tail`` (``now_s``: node clock, s); closes it then."""
        if self.cycle_end is None or self.bag is None:
            return False
        if now_s - self.cycle_end < self.settings.cycle_tail:
            return False
        self.close_bag()
        self.cycle_end = None
        return True

    # -- the stream ------------------------------------------------------------
    def _cycle_status(self, item: Item) -> tuple[int, int] | None:
        """(cycle id, state) of a status message; the state of a joint's DONE that does not end its robot
        cycle is -1 (one bag per robot cycle, not per joint)."""
        try:
            st = status_from_msg(self._store.deserialize_cdr(item.data, STATUS_TYPE))
            return st.cycle_id, int(st.state) if st.robot_cycle_over or st.state not in ENDED_STATES else -1
        except Exception as exc:
            self.log.warning(f"undecodable status message on {item.topic}: {exc}", throttle_duration_sec=5.0)
            return None

    def _parameter_event(self, item: Item) -> None:
        """Keep the settings snapshot current from a recorded ParameterEvent (new bags start from it)."""
        try:
            ev: Any = self._store.deserialize_cdr(item.data, PARAMETER_EVENT_TYPE)
        except Exception:
            return
        node = str(ev.node).lstrip("/")
        if node not in self.node_settings:
            return  # not asked yet: its answer will hold these values
        for param in (*ev.new_parameters, *ev.changed_parameters):
            value = parameter_value(param.value)
            if value is not None:
                self.node_settings[node][str(param.name)] = value
        for param in ev.deleted_parameters:
            self.node_settings[node].pop(str(param.name), None)

    def _split(self, item: Item) -> None:
        st = self._cycle_status(item)
        if st is None:
            return
        cycle, state = st
        # a RUNNING status after the cycle ended is a new cycle even with the same id
        # (a restarted test_cycle counts from 1 again)
        if state == CycleState.RUNNING and (cycle != self.cycle or self.cycle_ended):
            self.close_bag()
            self.cycle, self.cycle_end, self.cycle_ended = cycle, None, False
            self.open_bag(cycle)
        elif state in ENDED_STATES and cycle == self.cycle and not self.cycle_ended:
            self.cycle_end, self.cycle_ended = item.stamp * 1e-9, True

    def handle(self, item: Item | Lost | Params) -> None:
        """Take one element of the stream."""
        if isinstance(item, Params):
            self.node_settings[item.node] = dict(item.values)
            if self.bag is not None:
                self.bag.note_params(item.node, item.values)
            return
        if isinstance(item, Lost):
            if self.bag is not None:
                self.bag.lost[item.topic] = self.bag.lost.get(item.topic, 0) + item.count
            return
        if item.msgtype == PARAMETER_EVENT_TYPE:
            self._parameter_event(item)
        if self.fatal is not None:
            self.dropped += 1
            return
        s = self.settings
        if s.split == "cycle" and item.topic == s.status_topic and item.msgtype == STATUS_TYPE:
            self._split(item)
        bag = self.bag
        if bag is None:
            self.dropped += 1
            return
        try:
            bag.write(item)
        except OSError as exc:  # disk full, file too large, I/O error: the bag cannot go on
            self.fail(bag.path, f"write failed ({item.topic}): {os_error_text(exc)}")
            return
        except Exception as exc:  # a message that cannot be written (e.g. no definition): skip it
            self.write_errors += 1
            self.log.error(f"write to {bag.path} failed ({item.topic}): {exc}", throttle_duration_sec=5.0)
            return
        self.recorded += 1

    def run(self, stream: queue.SimpleQueue[Item | Lost | Params | None], *, flush_period: float,
            health_period: float, clock: Callable[[], float], monotonic: Callable[[], float],
            publish_health: Callable[[], None]) -> None:
        """The writer loop: take the stream until ``None``, sync every ``flush_period`` s (after a bag opens
        too), ``publish_health`` every ``health_period`` s (``monotonic``), end a cycle's bag after its tail
        (``clock``: node clock, s); then close the open bag."""
        next_sync = monotonic() + flush_period
        next_health = monotonic() + health_period
        running = True
        while running:
            # what is queued, taken at once: one wake-up of this thread (and one clock read) per batch, not per
            # message (the callbacks queue /joint_states at 1.5 kHz in a demo at 3x)
            batch: list[Item | Lost | Params | None] = []
            try:
                batch.append(stream.get(timeout=0.1))
                while len(batch) < WRITER_BATCH:
                    batch.append(stream.get_nowait())
            except queue.Empty:
                pass
            for item in batch:
                if item is None:
                    running = False
                    break
                opened = self.bag
                self.handle(item)
                if self.bag is not None and self.bag is not opened:
                    next_sync = monotonic() + flush_period
            now = monotonic()
            if now >= next_sync:
                next_sync = now + flush_period
                self.sync()
            if now >= next_health:
                next_health = now + health_period
                publish_health()
            self.tail_done(clock())
            if running and batch:
                time.sleep(WRITER_PAUSE)  # let the next messages gather
        self.close_bag()


class WriterThread:
    """A recorder's writer thread: the stream's queue (:meth:`put`, from any callback) and
    :meth:`Recording.run` on it until :meth:`stop`."""

    def __init__(self, recording: Recording, **run: Any) -> None:
        self.queue: queue.SimpleQueue[Item | Lost | Params | None] = queue.SimpleQueue()
        self.thread = threading.Thread(target=recording.run, args=(self.queue,), kwargs=run,
                                       name="recorder-writer", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def put(self, item: Item | Lost | Params) -> None:
        self.queue.put(item)

    @property
    def backlog(self) -> int:
        """Elements waiting for the writer."""
        return self.queue.qsize()

    def stop(self, timeout: float = 30.0) -> bool:
        """Let the writer take what is queued and close the bag; whether it finished within ``timeout`` s."""
        self.queue.put(None)
        self.thread.join(timeout)
        return not self.thread.is_alive()


def count_lost(totals: dict[str, int], topic: str, total: int) -> int:
    """Messages of ``topic`` newly lost, from DDS's running ``total`` (an event may repeat with no change);
    ``totals`` is updated."""
    change = int(total) - totals.get(topic, 0)
    if change <= 0:
        return 0
    totals[topic] = int(total)
    return change


def subscription_policy(offered: Sequence[Any]) -> tuple[bool, bool]:
    """(reliable, transient local) for a recorder's subscription to publishers offering these QoS profiles
    (rclpy's or rosbags'): reliable when every publisher is, transient local when every publisher offers it."""
    reliable = all(int(getattr(q.reliability, "value", q.reliability)) == QosReliability.RELIABLE.value
                   for q in offered)
    latched = all(int(getattr(q.durability, "value", q.durability)) == QosDurability.TRANSIENT_LOCAL.value
                  for q in offered)
    return reliable, latched


def _qos_time(d: Any) -> QosTime:
    sec, nsec = divmod(int(d.nanoseconds), 1_000_000_000)
    return QosTime(sec=sec, nsec=nsec)


def bag_qos(p: Any) -> Qos:
    """A publisher's QoS profile (rclpy's ``QoSProfile``: durations with ``nanoseconds``) as a bag records it."""
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


def recorder_health(rec: Recording, *, rate_hz: float, lost: int, backlog: int, topics: int,
                    free_disk_mb: float | None, min_free_disk_mb: float, warn_backlog: int
                    ) -> tuple[DiagnosticLevel, str, list[tuple[str, str]]]:
    """(level, message, key/values) of the recorder's status: ERROR after a write error; WARN when messages
    were lost before reception, the disk is low or the writer is behind; else OK."""
    bag = rec.bag
    values = [
        ("bag", str(bag.path) if bag is not None else ""),
        ("rate_hz", f"{rate_hz:.1f}"),
        ("messages_recorded", str(rec.recorded)),
        ("messages_on_disk", str(rec.synced)),
        ("messages_lost", str(lost)),
        ("messages_dropped", str(rec.dropped)),
        ("queue_backlog", str(backlog)),
        ("write_errors", str(rec.write_errors)),
        ("free_disk_mb", f"{free_disk_mb:.0f}" if free_disk_mb is not None else "unknown"),
        ("topics", str(topics)),
    ]
    if rec.fatal is not None:
        return DiagnosticLevel.ERROR, f"recording stopped: {rec.fatal}", values
    if lost:
        return DiagnosticLevel.WARN, f"{lost} message(s) lost before reaching the recorder (bag incomplete)", values
    if free_disk_mb is not None and free_disk_mb < min_free_disk_mb:
        return DiagnosticLevel.WARN, f"low disk space: {free_disk_mb:.0f} MiB free (< min_free_disk_mb)", values
    if backlog > warn_backlog:
        return (DiagnosticLevel.WARN, f"writer behind: {backlog} messages queued (> warn_backlog), at risk in a crash",
                values)
    if bag is None:
        return (DiagnosticLevel.OK, "waiting for a test cycle" if rec.settings.split == "cycle" else "no bag open",
                values)
    return DiagnosticLevel.OK, "recording", values


def os_error_text(exc: OSError) -> str:
    """An OSError as one line with its errno name (``No space left on device (ENOSPC)``)."""
    name = errno.errorcode.get(exc.errno or 0, "")
    return f"{exc.strerror or exc} ({name})" if name else str(exc)


def free_mb(path: Path) -> float | None:
    """Free space (MiB) on the disk of ``path`` (or of its nearest existing parent); None when unknown."""
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        return shutil.disk_usage(p).free / 2**20
    except OSError:
        return None
