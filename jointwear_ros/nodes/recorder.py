"""recorder: every topic on the graph into rosbag2 MCAP bags, as raw CDR bytes (docs/nodes-bag-demo.md).

The node is the ROS adapter of :mod:`jointwear_ros.io.recording`, which makes
every decision about the recorded stream without a ROS runtime (filters,
``split: session``/``cycle``, loss counts, settings capture, syncs, write
errors, health). Here: topics are discovered every ``discovery_period``
wall seconds (a steady timer: on sim time a recorder waiting for the first ``/clock`` subscribed late),
(``get_topic_names_and_types``, so later topics are recorded too) and
subscribed with ``raw=True`` and a QoS matched to their publishers (RELIABLE
when every publisher is, TRANSIENT_LOCAL when every publisher offers it,
KEEP_LAST ``queue_depth``); callbacks only enqueue, a writer thread runs the
core. Every node on the graph is asked once for its parameters (they go into
each bag's metadata.yaml). Messages DDS reports lost before reception
(``message_lost``) are logged and counted per topic. Health:
``recorder: <bag name>`` on ``/diagnostics`` every ``diagnostics_period``.
A write error stops recording; the process exits with status 1.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.interfaces import Qos

from ..io.bags import ensure_msgtype
from ..io.recording import (
    Item,
    Lost,
    Params,
    Recording,
    RecordingSettings,
    TopicFilter,
    WriterThread,
    bag_qos,
    count_lost,
    free_mb,
    recorder_health,
    subscription_policy,
)
from ..io.typestore import new_jointwear_typestore
from .diagnostics import Status, Updater
from .runtime import (
    ParamDecl,
    ask_node_parameters,
    declare_parameters,
    message_class,
    run_node,
    signals_held,
    subscribe_reporting_loss,
    wait_acked,
)

__all__ = ["PARAMETERS", "RecorderNode", "main"]


PARAMETERS: tuple[ParamDecl, ...] = (
    ParamDecl("output_dir", "bags", "directory under which bag directories are created"),
    ParamDecl("bag_prefix", "jointwear", "bag directory names start with this"),
    ParamDecl("split", "session", "session: one bag per run; cycle: one bag per test cycle"),
    ParamDecl("discovery_period", 0.5, "wall seconds between graph scans for new topics", 0.05, 60.0),
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
    ParamDecl("include", [], "regexes; record topics matching any (empty: all)", dynamic=True),
    ParamDecl("exclude", [], "regexes; never record topics matching any", dynamic=True),
)


def _writer_side(name: str, doc: str) -> Any:
    """A read-only attribute of the node that is the writer side's (:class:`Recording`)."""
    return property(lambda self: getattr(self.recording, name), doc=doc)


class RecorderNode(Node):
    """Record every (included, not excluded) topic into MCAP bags; see the module docstring."""

    PARAMS = PARAMETERS

    def __init__(self, **kwargs: Any) -> None:
        super().__init__("recorder", **kwargs)
        self.p = declare_parameters(self, self.PARAMS)
        for name in ("include", "exclude"):
            self.p[name] = [str(x) for x in (self.p[name] or [])]
        log = self.get_logger()
        settings, problems = RecordingSettings.from_params(self.p)
        self.filter = TopicFilter(self.p["include"], self.p["exclude"])
        for line in (*problems, *self.filter.errors):
            log.error(line)
        self.p["split"], self.p["compression"] = settings.split, settings.compression
        self.p["chunk_size"] = settings.chunk_size
        self._store = new_jointwear_typestore(required=False)  # private: types found later are added
        self._offered: dict[str, list[Qos]] = {}
        self._subs: dict[str, Any] = {}
        self._skipped: set[str] = set()
        self._asked: dict[str, int] = {}
        #: the writer side (bags, splitting, counts): run by the writer thread on what the callbacks queue
        self.recording = Recording(settings, self._store, self._offered, log, on_fatal=self._on_fatal)
        self.writer = WriterThread(self.recording, flush_period=float(self.p["flush_period"]),
                                   health_period=float(self.p["diagnostics_period"]), monotonic=time.monotonic,
                                   clock=lambda: self.get_clock().now().nanoseconds * 1e-9,
                                   publish_health=self.publish_diagnostics)
        self._queue = self.writer.queue
        #: a process running this node stops itself after a fatal write error (set by ``main``)
        self.stop_process_on_fatal = False
        self.received: dict[str, int] = {}
        #: per topic, messages DDS reported lost before they reached the recorder
        self.lost: dict[str, int] = {}
        self._stopped = False
        self._out = settings.output_dir
        # health: one task, named after the bag; published by the writer thread (no executor timer: it keeps
        # coming while callbacks are busy, and the EventsExecutor is left with one timer, discovery)
        self.health_updater = Updater(self, "recorder", str(self.p["hardware_id"]) or str(self._out), period=0.0,
                                      topic=str(self.p["diagnostics_topic"]))
        self.health_updater.add("(no bag)", self._health_task)
        self.diag_pub = self.health_updater.pub
        self.recording.rate(time.monotonic())
        self.recording.start()
        self.writer.start()
        # discovery on the steady clock: on sim time it waited for the first /clock, so a recorder started before
        # a bag played onto its graph subscribed seconds late under load (the first 5.07 s of a played production,
        # 1267 joint states, missing from the bag, and the replay no longer equal to live)
        self._timer = self.create_timer(float(self.p["discovery_period"]), self.discover,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.discover()

    # -- what the writer side knows, read by tests and main -----------------------------------
    fatal = _writer_side("fatal", "the write error that stopped recording (None while healthy): exit status 1")
    write_errors = _writer_side("write_errors", "write errors so far")
    recorded = _writer_side("recorded", "messages written to bags")
    dropped = _writer_side("dropped", "messages received but not written (no bag open, or after a write error)")
    synced = _writer_side("synced", "messages made durable (complete chunks, fsynced)")
    _bag = _writer_side("bag", "the open bag")
    _settings = _writer_side("node_settings", "every node's parameters as captured")

    @property
    def bags(self) -> list[Path]:
        """Bags opened so far (the last may still be open)."""
        return self.recording.bags

    @property
    def recorded_topics(self) -> list[str]:
        return sorted(self._subs)

    # -- discovery ---------------------------------------------------------------------------
    def wanted(self, topic: str) -> bool:
        """True when ``topic`` passes the include/exclude filters."""
        return self.filter.wanted(topic)

    def discover(self) -> None:
        """Subscribe to every wanted topic that has publishers and is not yet recorded; ask every new node
        for its parameters (they go into each bag's metadata.yaml)."""
        ask_node_parameters(self, self._asked, lambda node, values: self.writer.put(Params(node, values)))
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
            reliable, latched = subscription_policy([p.qos_profile for p in pubs])
            qos = QoSProfile(
                history=HistoryPolicy.KEEP_LAST,
                depth=max(int(self.p["queue_depth"]), 1),
                reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
            )
            self._offered[topic] = [bag_qos(p.qos_profile) for p in pubs]
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
        clock, put, received = self.get_clock(), self.writer.put, self.received
        received[topic] = 0

        def cb(data: bytes) -> None:
            received[topic] += 1
            put(Item(topic, msgtype, clock.now().nanoseconds, bytes(data)))

        return cb

    def _lost_callback(self, topic: str) -> Any:
        logger = self.get_logger()
        self.lost[topic] = 0

        def cb(info: Any) -> None:
            change = count_lost(self.lost, topic, int(info.total_count))
            if not change:
                return
            self.writer.put(Lost(topic, change))
            total = self.lost[topic]
            logger.warning(
                f"{change} message(s) on {topic} lost before reaching the recorder ({total} in all): the "
                "publisher's history overflowed while the recorder was stalled (CPU starved?); the bag "
                "is incomplete there", throttle_duration_sec=2.0,
            )

        return cb

    def _on_fatal(self) -> None:
        """After a write error: report ERROR, then stop the process (``main`` returns 1)."""
        self.publish_diagnostics()
        wait_acked([self.diag_pub], 1.0)
        if self.stop_process_on_fatal:
            os.kill(os.getpid(), signal.SIGTERM)  # run_node's handler: a clean stop, then main returns 1

    # -- health ------------------------------------------------------------------------------
    def health(self) -> tuple[int, str, list[tuple[str, str]]]:
        """(level, message, key/values) of the recorder's DiagnosticStatus."""
        return recorder_health(self.recording, rate_hz=self.recording.rate(time.monotonic()),
                               lost=sum(self.lost.values()), backlog=self.writer.backlog, topics=len(self._subs),
                               free_disk_mb=free_mb(self._out), min_free_disk_mb=float(self.p["min_free_disk_mb"]),
                               warn_backlog=int(self.p["warn_backlog"]))

    def _health_task(self, stat: Status) -> None:
        stat.name = f"recorder: {self.recording.last_bag_name or '(no bag)'}"
        level, message, values = self.health()
        stat.summary(level, message)
        stat.extend(values)

    def publish_diagnostics(self) -> None:
        """Publish the recorder's health (``recorder: <bag>``) on the diagnostics topic."""
        self.health_updater.update()

    def on_shutdown(self) -> None:
        """Stop discovery, write what is queued, close the bag (idempotent)."""
        if self._stopped:
            return
        self._stopped = True
        with signals_held():  # a second Ctrl-C must not interrupt closing the bag
            self._timer.cancel()
            for sub in self._subs.values():
                self.destroy_subscription(sub)
            if not self.writer.stop(30.0):
                self.get_logger().error("writer thread did not finish within 30 s; the bag may be incomplete")
            self.publish_diagnostics()  # the final state (ERROR after a write error)
            wait_acked([self.diag_pub])


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
