"""A node's own health on ``/diagnostics``, in the shape of diagnostic_updater.

Every jointwear node reports one ``diagnostic_msgs/DiagnosticStatus`` named
``"<node>: <task>"`` (``wear_estimator: joint_1``, ``test_cycle: joint_1``,
``friction_observer: joint_1``), with a ``hardware_id``, a one-line message
and key/value pairs, published in a ``DiagnosticArray`` on every change and
republished every ``period`` seconds of wall time (so an aggregator does not
mark it stale while ``/clock`` is stopped).

Use::

    self.diag = NodeDiagnostics(self, "test_cycle: joint_1", hardware_id="joint_1", period=1.0)
    self.diag.update(WARN, "cycle 3 ABORTED: ...", [("cycle_id", "3")])   # publishes now
    self.diag.publish()                                                    # republish as it is

:func:`merge_level` combines several checks the way diagnostic_updater
does (the highest level wins).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from ..contract import DiagnosticLevel

__all__ = ["ERROR", "OK", "STALE", "WARN", "NodeDiagnostics", "diagnostic_status", "merge_level"]

#: ``DiagnosticStatus`` level values (the message stores them as one byte): aliases of the contract's.
OK = DiagnosticLevel.OK
WARN = DiagnosticLevel.WARN
ERROR = DiagnosticLevel.ERROR
STALE = DiagnosticLevel.STALE

KeyValues = Sequence[tuple[str, str]]
#: what a ``refresh`` callback returns: (level, message, key/values)
Report = tuple[int, str, KeyValues]


def diagnostic_status(name: str, hardware_id: str, level: int, message: str, values: Iterable[tuple[str, str]]
                      ) -> DiagnosticStatus:
    """A DiagnosticStatus (level as the message's byte value)."""
    s = DiagnosticStatus()
    s.level = bytes([int(level)])
    s.name = name
    s.hardware_id = hardware_id
    s.message = message
    s.values = [KeyValue(key=str(k), value=str(v)) for k, v in values]
    return s


def merge_level(*levels: int) -> int:
    """The level of several checks: the highest (OK < WARN < ERROR < STALE)."""
    return max((int(x) for x in levels), default=OK)


class NodeDiagnostics:
    """One status of one node on ``topic``: published on :meth:`update`, republished every ``period`` s (wall).

    ``period <= 0`` disables the republication timer. ``refresh``, when given,
    is called before each periodic publication and returns the status to
    report (for counters that change too often to publish on every change).
    """

    def __init__(self, node: Node, name: str, hardware_id: str = "", *, topic: str = "/diagnostics",
                 period: float = 1.0, level: int = OK, message: str = "starting", values: KeyValues = (),
                 refresh: Callable[[], Report] | None = None) -> None:
        self.node = node
        self.name = name
        self.hardware_id = hardware_id
        self.pub = node.create_publisher(DiagnosticArray, topic, 10)
        self.status = diagnostic_status(name, hardware_id, level, message, values)
        self.published = 0
        self.refresh = refresh
        if period > 0:
            node.create_timer(float(period), self._on_timer, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _on_timer(self) -> None:
        if self.refresh is not None:
            self.set(*self.refresh())
        self.publish()

    @property
    def level(self) -> int:
        return int.from_bytes(self.status.level, "little") if isinstance(self.status.level, bytes) else int(self.status.level)

    @property
    def message(self) -> str:
        return str(self.status.message)

    def set(self, level: int, message: str, values: KeyValues = ()) -> None:
        """Change the status without publishing (the next :meth:`publish` or timer tick sends it)."""
        self.status = diagnostic_status(self.name, self.hardware_id, level, message, values)

    def update(self, level: int, message: str, values: KeyValues = ()) -> None:
        """Change the status and publish it now."""
        self.set(level, message, values)
        self.publish()

    def publish(self) -> None:
        """Publish the current status (stamped with the node clock)."""
        arr = DiagnosticArray()
        arr.header.stamp = self.node.get_clock().now().to_msg()
        arr.status = [self.status]
        self.pub.publish(arr)
        self.published += 1
