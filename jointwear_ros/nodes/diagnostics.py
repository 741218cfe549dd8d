"""A node's own health on ``/diagnostics``: tasks and one updater, in the shape of diagnostic_updater.

Every jointwear node reports its health as ``diagnostic_msgs/DiagnosticStatus``
entries named ``"<node>: <task>"`` (``wear_estimator: joint_1``,
``test_cycle: robot``, ``recorder: <bag>``), each with a ``hardware_id``, a
one-line message and key/value pairs. The pieces (after ros/diagnostics
``_diagnostic_updater.py``):

- :class:`Status`: what a task fills in: :meth:`Status.summary` (level and
  message; levels are :class:`~jointwear_ros.contract.DiagnosticLevel`),
  :meth:`Status.add` (a key/value), :meth:`Status.merge_summary` (several
  checks, the highest level wins).
- a **task**, one per concern: :class:`FunctionTask` (a callable filling a
  :class:`Status`, asked at every update), :class:`HeldStatus` (a status the
  node sets when something happens, e.g. at a cycle's end) and
  :class:`CompositeTask` (several tasks merged into one status, e.g. the
  checks of one joint).
- :class:`Updater`: owns the period, the default hardware id and the
  publisher. :meth:`Updater.update` runs every task and publishes their
  statuses in **one** ``DiagnosticArray`` (call it on every change); a
  wall-clock timer does the same every ``period`` seconds, so an aggregator
  does not mark the node stale while ``/clock`` is stopped (``period <= 0``: no
  timer, the node calls :meth:`Updater.update` itself, e.g. from a writer
  thread).

Use::

    self.health = Updater(self, "test_cycle", period=1.0)
    self.health.add("robot", self._robot_status, hardware_id="robot")   # def _robot_status(self, stat): ...
    for j in joints:
        self.health.add(j, partial(self._joint_status, j), hardware_id=j)
    self.health.update()                                                   # publishes every status now

A task's callable may return ``False`` to leave its status out of this update
(a status that only exists in some states, e.g. ``wear_trend: history``), and
may rename the status (``stat.name``) when its name follows the state (the
recorder's ``recorder: <bag>``).

:class:`NodeDiagnostics` (one held status in its own updater), :func:`diagnostic_status`,
``Report`` and the ``OK``/``WARN`` aliases are the older helpers, kept only for
``friction_observer`` and ``wear_estimator`` until they move onto the updater.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType, JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node

from ..contract import DiagnosticLevel

__all__ = [
    "OK",
    "WARN",
    "CompositeTask",
    "DiagnosticTask",
    "FunctionTask",
    "HeldStatus",
    "NodeDiagnostics",
    "Status",
    "Updater",
    "diagnostic_status",
]

#: ``DiagnosticStatus`` level values (the message stores them as one byte): aliases of the contract's.
OK = DiagnosticLevel.OK
WARN = DiagnosticLevel.WARN

KeyValues = Sequence[tuple[str, str]]
#: what a ``refresh`` callback of :class:`NodeDiagnostics` returns: (level, message, key/values)
Report = tuple[int, str, KeyValues]


class Status:
    """One ``DiagnosticStatus`` being filled by a task (diagnostic_updater's ``DiagnosticStatusWrapper``)."""

    __slots__ = ("hardware_id", "level", "message", "name", "values")

    def __init__(self, name: str = "", hardware_id: str = "", level: int = OK, message: str = "",
                 values: Iterable[tuple[str, str]] = ()) -> None:
        self.name = name
        self.hardware_id = hardware_id
        self.level = DiagnosticLevel(int(level))
        self.message = message
        self.values: list[tuple[str, str]] = [(str(k), str(v)) for k, v in values]

    def summary(self, level: int, message: str) -> None:
        """Set the level and the one-line message."""
        self.level = DiagnosticLevel(int(level))
        self.message = message

    def merge_summary(self, level: int, message: str) -> None:
        """Combine with another check: the highest level wins; messages of the same severity class join."""
        lv = DiagnosticLevel(int(level))
        if (lv > OK) == (self.level > OK):
            self.message = f"{self.message}; {message}" if self.message and message else (self.message or message)
        elif lv > self.level:
            self.message = message
        self.level = max(self.level, lv)

    def add(self, key: str, value: object) -> None:
        """Append a key/value pair (the value as text)."""
        self.values.append((str(key), str(value)))

    def extend(self, values: Iterable[tuple[str, object]]) -> None:
        """Append several key/value pairs."""
        self.values.extend((str(k), str(v)) for k, v in values)

    def to_msg(self) -> DiagnosticStatus:
        """The ``DiagnosticStatus`` message."""
        return diagnostic_status(self.name, self.hardware_id, self.level, self.message, self.values)

    def __repr__(self) -> str:
        return f"Status({self.name!r}, {self.level.name}, {self.message!r})"


class DiagnosticTask:
    """One concern of a node's health: :meth:`run` fills a :class:`Status` (returns ``False`` to skip it)."""

    def __init__(self, name: str, hardware_id: str | None = None) -> None:
        self.name = name
        #: this task's hardware id (``None``: the updater's)
        self.hardware_id = hardware_id

    def run(self, stat: Status) -> bool | None:
        raise NotImplementedError


class FunctionTask(DiagnosticTask):
    """A task whose callable fills the status at every update."""

    def __init__(self, name: str, fn: Callable[[Status], bool | None], hardware_id: str | None = None) -> None:
        super().__init__(name, hardware_id)
        self.fn = fn

    def run(self, stat: Status) -> bool | None:
        return self.fn(stat)


class HeldStatus(DiagnosticTask):
    """A status the node sets when something happens (:meth:`set`); every update reports it as it stands."""

    def __init__(self, name: str, hardware_id: str | None = None, level: int = OK, message: str = "",
                 values: KeyValues = ()) -> None:
        super().__init__(name, hardware_id)
        self.set(level, message, values)

    def set(self, level: int, message: str, values: KeyValues = ()) -> None:
        """Change the status (published by the next update)."""
        self.level = DiagnosticLevel(int(level))
        self.message = message
        self.values = [(str(k), str(v)) for k, v in values]

    def run(self, stat: Status) -> bool | None:
        stat.summary(self.level, self.message)
        stat.extend(self.values)
        return None


class CompositeTask(DiagnosticTask):
    """Several tasks reported as one status: the highest level, their messages and all their key/values."""

    def __init__(self, name: str, tasks: Iterable[DiagnosticTask] = (), hardware_id: str | None = None) -> None:
        super().__init__(name, hardware_id)
        self.tasks = list(tasks)

    def add(self, task: DiagnosticTask) -> DiagnosticTask:
        self.tasks.append(task)
        return task

    def run(self, stat: Status) -> bool | None:
        shown = False
        for task in self.tasks:
            part = Status(stat.name, stat.hardware_id)
            if task.run(part) is False:
                continue
            if not shown:
                stat.summary(part.level, part.message)
                shown = True
            else:
                stat.merge_summary(part.level, part.message)
            stat.extend(part.values)
        return None if shown else False


class Updater:
    """A node's health publisher: its tasks' statuses in one ``DiagnosticArray`` per update.

    ``prefix`` names the statuses (``"<prefix>: <task>"``; empty: the task's name alone); ``hardware_id`` is
    the default of tasks that do not set their own; ``period`` seconds of wall
    time between periodic updates (``<= 0``: none).
    """

    def __init__(self, node: Node, prefix: str, hardware_id: str = "", *, period: float = 1.0,
                 topic: str = "/diagnostics") -> None:
        self.node = node
        self.prefix = prefix
        self.hardware_id = hardware_id
        self.period = float(period)
        self.pub = node.create_publisher(DiagnosticArray, topic, 10)
        self.tasks: list[DiagnosticTask] = []
        #: the statuses of the last update, by full name
        self.last: dict[str, Status] = {}
        #: DiagnosticArrays published so far
        self.published = 0
        self._lock = threading.Lock()
        self.timer = (node.create_timer(self.period, self.update, clock=Clock(clock_type=ClockType.STEADY_TIME))
                      if self.period > 0 else None)
        # a node on sim time stamps its statuses 0 until its first /clock: it publishes again as that arrives
        # (the clock jumps from 0), not up to a period later; a cell waits for each sim-time node's stamped
        # status before it starts a cycle
        self._clock_heard = False
        self._jump_handle = node.get_clock().create_jump_callback(
            JumpThreshold(min_forward=Duration(seconds=1.0), min_backward=None), post_callback=self._on_first_clock)

    def _on_first_clock(self, jump: object) -> None:
        if not self._clock_heard:
            self._clock_heard = True
            self.update()

    def add(self, task: DiagnosticTask | str, fn: Callable[[Status], bool | None] | None = None,
            hardware_id: str | None = None) -> DiagnosticTask:
        """Add a task (or a :class:`FunctionTask` made of ``name, fn``); returns it."""
        if isinstance(task, str):
            if fn is None:
                raise TypeError("Updater.add(name, fn): fn is required with a name")
            task = FunctionTask(task, fn, hardware_id)
        with self._lock:
            self.tasks.append(task)
        return task

    def remove(self, name: str) -> bool:
        """Remove the task named ``name``; whether there was one."""
        with self._lock:
            kept = [t for t in self.tasks if t.name != name]
            found = len(kept) != len(self.tasks)
            self.tasks = kept
        return found

    def run(self) -> list[Status]:
        """Every task's status as of now (in the order they were added), without publishing."""
        out = []
        with self._lock:
            tasks = list(self.tasks)
        for task in tasks:
            hw = self.hardware_id if task.hardware_id is None else task.hardware_id
            stat = Status(f"{self.prefix}: {task.name}" if self.prefix else task.name, hw)
            if task.run(stat) is not False:
                out.append(stat)
        return out

    def update(self) -> list[Status]:
        """Run every task and publish their statuses in one ``DiagnosticArray`` (stamped with the node clock)."""
        statuses = self.run()
        arr = DiagnosticArray()
        arr.header.stamp = self.node.get_clock().now().to_msg()
        arr.status = [s.to_msg() for s in statuses]
        with self._lock:
            self.last = {s.name: s for s in statuses}
        try:
            self.pub.publish(arr)
        except Exception:  # the context is shutting down
            return statuses
        self.published += 1
        return statuses

    def status(self, name: str) -> Status | None:
        """The last published status of the task ``name`` (or of the full status name)."""
        last = self.last
        return last.get(name) or last.get(f"{self.prefix}: {name}")


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


class NodeDiagnostics:
    """One held status of one node in its own :class:`Updater` (the older one-status interface).

    Published on :meth:`update`, republished every ``period`` s (wall);
    ``refresh``, when given, is called before each periodic publication and
    returns the status to report.
    """

    def __init__(self, node: Node, name: str, hardware_id: str = "", *, topic: str = "/diagnostics",
                 period: float = 1.0, level: int = OK, message: str = "starting", values: KeyValues = (),
                 refresh: Callable[[], Report] | None = None) -> None:
        self.name = name
        self.hardware_id = hardware_id
        self.held = HeldStatus(name, hardware_id, level, message, values)
        self.refresh = refresh
        self.updater = Updater(node, "", hardware_id, period=0.0, topic=topic)  # no prefix: the name is whole
        self.updater.add(self.held)
        self.pub = self.updater.pub
        if period > 0:
            node.create_timer(float(period), self._on_timer, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _on_timer(self) -> None:
        if self.refresh is not None:
            self.set(*self.refresh())
        self.publish()

    @property
    def status(self) -> DiagnosticStatus:
        """The status as it stands (a ``DiagnosticStatus`` message)."""
        return Status(self.name, self.hardware_id, self.held.level, self.held.message, self.held.values).to_msg()

    @property
    def level(self) -> int:
        return int(self.held.level)

    @property
    def message(self) -> str:
        return self.held.message

    def set(self, level: int, message: str, values: KeyValues = ()) -> None:
        """Change the status without publishing (the next :meth:`publish` or timer tick sends it)."""
        self.held.set(level, message, values)

    def update(self, level: int, message: str, values: KeyValues = ()) -> None:
        """Change the status and publish it now."""
        self.set(level, message, values)
        self.publish()

    def publish(self) -> None:
        """Publish the current status (stamped with the node clock)."""
        self.updater.update()
