"""The message contract in one place: the constants of the ``.msg``/``.srv`` files and the conversions.

``jointwear_msgs`` defines the graph's contract (``msg_defs/msg/*.msg``, ``msg_defs/srv/*.srv``);
``diagnostic_msgs/DiagnosticStatus`` the level bytes. This module mirrors their constants as
:class:`enum.IntEnum` (so ``CycleState.RUNNING == 1`` and a message field compares directly) and
holds the conversions between messages and the cores' plain dataclasses. It imports no ROS
package: the conversions read any object with the message's field names (an rclpy message or
a rosbags-deserialized one) and write into a message class the caller passes, so the live
nodes, the bag reader, replay, the recorder and the CLI share them.

>>> CycleState.RUNNING == 1, CycleState(4).name
(True, 'FAILED')
>>> CycleState.name_of(9), level_name(DiagnosticLevel.ERROR), level_name(3), level_name(None)
('9', 'ERROR', 'STALE', 'NONE')
>>> worst_level([DiagnosticLevel.OK, DiagnosticLevel.STALE, DiagnosticLevel.WARN]).name
'WARN'
>>> seconds_to_stamp_fields(12.25)
(12, 250000000)
>>> stamp_to_seconds(type("Stamp", (), {"sec": 12, "nanosec": 250000000})())
12.25
>>> st = CycleStatus(cycle_id=3, state=CycleState.DONE, speeds_done=2, speeds_total=2, joint_name="joint_2",
...                  joints=("joint_1", "joint_2"), joints_done=1)
>>> st.ended, st.robot_cycle_over, st.in_cycle(3, "joint_2")
(True, True, True)
>>> Source.parse(""), Source.parse("production"), Source.PRODUCTION == "production"
(<Source.TEST_CYCLE: 'test_cycle'>, <Source.PRODUCTION: 'production'>, True)
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields
from functools import cache
from typing import Any, TypeVar

from .errors import InputDataError
from .observation import FrictionObservationData

M = TypeVar("M")

__all__ = [
    "ENDED_STATES",
    "CyclePhase",
    "CycleState",
    "CycleStatus",
    "DiagnosticLevel",
    "RefusalReason",
    "Source",
    "level_name",
    "level_rank",
    "observation_from_msg",
    "observation_to_msg",
    "robot_cycle_over",
    "seconds_to_stamp_fields",
    "source_of",
    "stamp_to_seconds",
    "status_from_msg",
    "status_to_msg",
    "worst_level",
]


class _Contract(enum.IntEnum):
    """An IntEnum mirroring a message's constants, with a total name lookup for received bytes."""

    @classmethod
    def name_of(cls, value: int) -> str:
        """The constant's name, or the number as text for a value the contract does not define."""
        try:
            return cls(value).name
        except ValueError:
            return str(value)


E = TypeVar("E", bound=_Contract)


class Source(enum.StrEnum):
    """Where a friction observation or a wear estimate comes from: the ``source`` field of
    ``FrictionObservation`` and ``WearEstimate``, the history's ``source`` column, the surfaces' label.

    ``TEST_CYCLE``: the dedicated test cycle (its ``cycle_id`` is the cycle's); ``PRODUCTION``: the robot's
    own program (its ``cycle_id`` is the production shift's). A test cycle and a shift with the same id are
    different things: every consumer keys by (source, cycle_id). An empty value (a bag or a database from
    before the field) is a test cycle's. Being a ``str``, a member compares equal to its value.
    """

    TEST_CYCLE = "test_cycle"
    PRODUCTION = "production"

    @classmethod
    def parse(cls, value: object) -> Source:
        """``value`` as a :class:`Source`: ``""``/``None`` is ``TEST_CYCLE``; anything else not of the vocabulary
        raises :class:`~jointwear_ros.errors.InputDataError` naming it and the two values."""
        text = "" if value is None else str(value).strip()
        if not text:
            return cls.TEST_CYCLE
        try:
            return cls(text)
        except ValueError:
            raise InputDataError(f"source {text!r} is neither {cls.TEST_CYCLE.value!r} nor "
                                 f"{cls.PRODUCTION.value!r}") from None


def source_of(value: object) -> str:
    """The source's value as plain text (``"test_cycle"`` or ``"production"``; empty: ``"test_cycle"``), for a
    message field, a column or a label (:meth:`Source.parse`, the same error for a value outside the vocabulary).

    >>> source_of(None), source_of(Source.PRODUCTION)
    ('test_cycle', 'production')
    """
    return Source.parse(value).value


class CycleState(_Contract):
    """``TestCycleStatus.state`` (IDLE, RUNNING, DONE, ABORTED, FAILED)."""

    IDLE = 0
    RUNNING = 1
    DONE = 2
    ABORTED = 3
    FAILED = 4

    @property
    def ended(self) -> bool:
        """DONE, ABORTED or FAILED: the cycle will not sweep again."""
        return self in ENDED_STATES


#: DONE, ABORTED, FAILED (``state in ENDED_STATES`` also works on a message's plain int).
ENDED_STATES = frozenset({CycleState.DONE, CycleState.ABORTED, CycleState.FAILED})


def robot_cycle_over(state: int, joints: int, joints_done: int) -> bool:
    """Whether a ``TestCycleStatus`` ends its robot cycle: the last joint DONE (``joints_done + 1 >= joints``;
    ``joints`` 0 is one joint), or any joint ABORTED or FAILED (the cycle stops there). A joint's DONE before
    the last is not the end: the next joint runs under the same cycle id (docs/robot.md).

    >>> robot_cycle_over(CycleState.DONE, 3, 0), robot_cycle_over(CycleState.DONE, 3, 2)
    (False, True)
    >>> robot_cycle_over(CycleState.FAILED, 3, 0), robot_cycle_over(CycleState.DONE, 0, 0)
    (True, True)
    """
    if state in (CycleState.ABORTED, CycleState.FAILED):
        return True
    return state == CycleState.DONE and int(joints_done) + 1 >= max(int(joints), 1)


class CyclePhase(_Contract):
    """``TestCycleStatus.phase`` (its ``PHASE_*`` constants)."""

    NONE = 0
    APPROACH = 1
    FORWARD = 2
    REVERSE = 3
    SETTLE = 4


@dataclass(frozen=True)
class CycleStatus:
    """One ``TestCycleStatus``: what the test-cycle runners report, the node publishes, and the observer,
    the estimator, replay, the recorder's readers and the operator read (one type for all of them).

    ``state`` is a :class:`CycleState` and ``phase`` a :class:`CyclePhase`; a received message with a value
    the contract does not define keeps it as a plain int (the consumers compare it, and it is neither
    RUNNING nor DONE; :attr:`state_name` names it: never take ``state.name`` of a received status). ``current_speed`` is the motor-side speed being swept (rad/s), the window joint
    side (rad). ``stamp`` is the header stamp in seconds (0: none; the consumers use their clock at
    receipt). ``joints`` lists every joint of a robot cycle in test order (empty: only ``joint_name``),
    ``joints_done`` how many finished before ``joint_name``. :func:`status_from_msg` and
    :func:`status_to_msg` convert from and to the message.
    """

    cycle_id: int = 0
    state: CycleState = CycleState.IDLE
    phase: CyclePhase = CyclePhase.NONE
    current_speed: float = 0.0
    speeds_done: int = 0
    speeds_total: int = 0
    window_center: float = 0.0
    window_half_width: float = 0.0
    message: str = ""
    joint_name: str = ""
    joints: tuple[str, ...] = ()
    joints_done: int = 0
    stamp: float = 0.0

    @property
    def ended(self) -> bool:
        """DONE, ABORTED or FAILED: this joint's test will not sweep again."""
        return self.state in ENDED_STATES

    @property
    def robot_cycle_over(self) -> bool:
        """This status ends its robot cycle (:func:`robot_cycle_over`)."""
        return robot_cycle_over(self.state, len(self.joints), self.joints_done)

    @property
    def state_name(self) -> str:
        """The state's name (the number as text for a value the contract does not define)."""
        return CycleState.name_of(self.state)

    def in_cycle(self, cycle_id: int, joint: str | None = None) -> bool:
        """This status is of cycle ``cycle_id`` (and of ``joint``, when given)."""
        return self.cycle_id == cycle_id and (joint is None or self.joint_name == joint)


def _known(enum_type: type[E], value: int) -> E:
    """``enum_type(value)``, or the plain ``value`` when the contract does not define it (see :class:`CycleStatus`)."""
    try:
        return enum_type(value)
    except ValueError:
        return value  # type: ignore[return-value]


#: the plain fields of ``TestCycleStatus`` and their Python type (``joints``, ``stamp`` and the enums aside)
_STATUS_FIELDS: dict[str, Callable[[Any], Any]] = {
    "joint_name": str, "cycle_id": int, "state": int, "phase": int, "current_speed": float, "speeds_done": int,
    "speeds_total": int, "window_center": float, "window_half_width": float, "message": str, "joints_done": int,
}


def status_from_msg(msg: Any) -> CycleStatus:
    """A ``TestCycleStatus`` message (rclpy or rosbags) -> :class:`CycleStatus`."""
    values = {name: conv(getattr(msg, name)) for name, conv in _STATUS_FIELDS.items()}
    values["state"] = _known(CycleState, values["state"])
    values["phase"] = _known(CyclePhase, values["phase"])
    return CycleStatus(**values, joints=tuple(str(j) for j in msg.joints), stamp=stamp_to_seconds(msg.header.stamp))


def status_to_msg(st: CycleStatus, msg_type: Callable[[], M]) -> M:
    """Fill a new ``msg_type()`` (the generated ``TestCycleStatus`` class) from ``st``."""
    msg: Any = msg_type()
    msg.header.stamp.sec, msg.header.stamp.nanosec = seconds_to_stamp_fields(st.stamp)
    for name, conv in _STATUS_FIELDS.items():
        setattr(msg, name, conv(getattr(st, name)))
    msg.joints = list(st.joints)
    return msg  # type: ignore[no-any-return]


class DiagnosticLevel(_Contract):
    """``diagnostic_msgs/DiagnosticStatus.level`` byte values."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


def level_name(level: int | None) -> str:
    """The name of a level, the one every surface shows: ``OK``, ``WARN``, ``ERROR``, ``STALE``; the number as
    text for a byte the contract does not define; ``NONE`` for no level (a joint without a finite estimate).

    >>> level_name(0), level_name(DiagnosticLevel.STALE), level_name(9), level_name(None)
    ('OK', 'STALE', '9', 'NONE')
    """
    return "NONE" if level is None else DiagnosticLevel.name_of(int(level))


#: how urgent each level is, the least first: a silent joint (STALE) ranks above OK and below WARN, so an
#: alarm is never hidden by age (docs/levels.md); the plant page, ``trend`` and the demo rank by it
_RANK = {DiagnosticLevel.OK: 0, DiagnosticLevel.STALE: 1, DiagnosticLevel.WARN: 2, DiagnosticLevel.ERROR: 3}


def level_rank(level: int) -> int:
    """How urgent ``level`` is: OK 0, STALE 1, WARN 2, ERROR 3; a byte the contract does not define ranks 4,
    above ERROR (something is wrong that no level says). Sort by ``-level_rank`` to list ERROR first.

    >>> sorted([0, 3, 2, 1], key=lambda lv: -level_rank(lv))
    [2, 1, 3, 0]
    """
    return _RANK.get(int(level), len(_RANK))  # type: ignore[call-overload]


def worst_level(levels: Iterable[int]) -> int:
    """The most urgent of ``levels`` by :func:`level_rank` (OK when there are none); ERROR over STALE.

    >>> worst_level([DiagnosticLevel.STALE, DiagnosticLevel.ERROR]).name, worst_level([])
    ('ERROR', <DiagnosticLevel.OK: 0>)
    """
    return max(levels, key=level_rank, default=DiagnosticLevel.OK)


class RefusalReason(_Contract):
    """``RunTestCycle.Response.reason``: why a request was refused (``NONE`` when accepted)."""

    NONE = 0
    BUSY = 1
    MOTION_DISABLED = 2
    WRONG_JOINT = 3
    STATE_MISSING = 4
    STATE_STALE = 5
    BAD_SPEEDS = 6
    OUTSIDE_LIMITS = 7
    BAD_REQUEST = 8

    @property
    def retryable(self) -> bool:
        """A refusal an operator retries after a moment (the cell is still starting or busy)."""
        return self in (RefusalReason.BUSY, RefusalReason.STATE_MISSING, RefusalReason.STATE_STALE)


def stamp_to_seconds(stamp: Any) -> float:
    """``builtin_interfaces/Time`` (or a header: its ``stamp``) -> seconds."""
    st = getattr(stamp, "stamp", stamp)
    return float(st.sec) + 1e-9 * float(st.nanosec)


def seconds_to_stamp_fields(t: float) -> tuple[int, int]:
    """Seconds -> ``(sec, nanosec)`` of a ``builtin_interfaces/Time``; negative or non-finite -> ``(0, 0)``."""
    if not math.isfinite(t) or t <= 0:
        return 0, 0
    sec = math.floor(t)
    nsec = round((t - sec) * 1e9)
    if nsec >= 1_000_000_000:
        sec, nsec = sec + 1, nsec - 1_000_000_000
    return int(sec), int(nsec)


@cache
def _obs_fields() -> tuple[str, ...]:
    return tuple(f.name for f in fields(FrictionObservationData) if f.name != "stamp")


_INT_FIELDS = {"cycle_id", "samples_plus", "samples_minus"}
#: text fields of ``FrictionObservation``
_STR_FIELDS = {"joint_name", "source"}


def _obs_value(name: str, raw: Any) -> Any:
    if name == "source":
        return source_of(raw)
    return str(raw) if name in _STR_FIELDS else (int(raw) if name in _INT_FIELDS else float(raw))


def observation_from_msg(msg: Any) -> FrictionObservationData:
    """A ``FrictionObservation`` message (rclpy or rosbags) -> :class:`FrictionObservationData`.

    A message without ``source`` (a bag recorded before the field) or with it empty is a test cycle's; a source
    outside the vocabulary raises :class:`~jointwear_ros.errors.InputDataError`.
    """
    values: dict[str, Any] = {"stamp": stamp_to_seconds(msg.header.stamp)}
    for name in _obs_fields():
        values[name] = _obs_value(name, getattr(msg, name, "") if name == "source" else getattr(msg, name))
    return FrictionObservationData(**values)


def observation_to_msg(obs: FrictionObservationData, msg_type: Callable[[], M]) -> M:
    """Fill a new ``msg_type()`` (the generated ``FrictionObservation`` class) from ``obs``."""
    msg: Any = msg_type()
    msg.header.stamp.sec, msg.header.stamp.nanosec = seconds_to_stamp_fields(obs.stamp)
    for name in _obs_fields():
        setattr(msg, name, _obs_value(name, getattr(obs, name)))
    return msg  # type: ignore[no-any-return]
