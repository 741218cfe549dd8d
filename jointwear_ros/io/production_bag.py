"""A simulated production recorded as a rosbag2 MCAP bag, as the suite's recorder would have recorded the cell.

:func:`record_production` writes a :class:`~jointwear_ros.sim.production.ProductionRun` with the suite's
writer (:class:`~.mcap_bag.McapBagWriter`) and message typestore (:func:`~.typestore.jointwear_typestore`):

- ``/joint_states`` (``sensor_msgs/msg/JointState``): every sample, ``name`` the run's joints
  (``joint_1`` ...), ``position``/``velocity``/``effort`` (rad, rad/s, N·m joint side), the header stamp
  the simulated time (the log time the same);
- ``/joint_temperature`` (``sensor_msgs/msg/Temperature``, the ``joint_sim`` node's topic): one message per
  joint every ``1 / temperature_rate`` s, ``header.frame_id`` the joint, the temperature of that sample;
- in ``metadata.yaml`` ``custom_data``: ``jointwear.node_parameters`` (the recorder's key: the settings of
  a ``joint_sim`` that would have simulated this run, its first shift's wear and the start temperatures,
  read back by :func:`~.bags.recorded_settings`), and :data:`TRUTH_KEY` (JSON of
  :meth:`ProductionRun.truth`: the wear of every shift, the self-heating, and every move's cruise
  velocities, payload, temperatures and true friction), read back by :func:`production_truth`.

The bag reads back with the suite's readers (:func:`~.bags.read_messages`, the replay) sample for sample.

**Reading a production back** (any bag with ``/joint_states``, recorded from a cell or by
:func:`record_production`): :func:`read_production` gives every joint's samples as arrays
(:class:`ProductionSamples`), by the rules the live ``production_observer`` node applies to each message
(:class:`JointStateRows`: every joint of the first JointState, or the joints given; a message lacking one,
with arrays whose lengths differ from ``name``, a non-finite value, no header stamp, or a stamp not after
the previous sample's is skipped and counted by reason); each sample's temperatures are the latest
``/joint_temperature`` reading of each joint with a stamp at or before the sample's (NaN before the first).
:class:`ShiftClock` is the node's shift rule, :func:`production_shifts` runs the samples through
:class:`~jointwear_ros.observer.ProductionObserver` shift by shift with it (with the arm's model,
:class:`~jointwear_ros.sim.arm.ArmModel`, when one is given): the offline ``jointwear data from-production``
and the node share all three, so a replay equals the live run.
"""

from __future__ import annotations

import bisect
import json
import math
import os
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..contract import stamp_to_seconds
from ..errors import InputDataError, ParameterError
from .bags import JOINT_STATE_TYPE, NODE_PARAMS_KEY, TEMPERATURE_TYPE, bag_custom_data, check_bag_path, read_messages
from .mcap_bag import McapBagWriter
from .typestore import jointwear_typestore

if TYPE_CHECKING:
    from ..observer.production import ProductionConfig, ProductionShift
    from ..sim.production import ProductionRun

__all__ = ["JOINT_STATES_TOPIC", "TEMPERATURE_TOPIC", "TRUTH_KEY", "JointStateRows", "ProductionSamples", "ShiftClock",
           "TemperatureTrack", "production_shifts", "production_truth", "read_production",
           "record_production"]

Array = npt.NDArray[np.float64]

JOINT_STATES_TOPIC = "/joint_states"
#: the joint_sim node's temperature topic (one Temperature per joint, frame_id = the joint)
TEMPERATURE_TOPIC = "/joint_temperature"
#: ``custom_data`` key of the production's truth (JSON)
TRUTH_KEY = "jointwear.production"


def _stamp(store: Any, ns: int) -> Any:
    time_t = store.types["builtin_interfaces/msg/Time"]
    return time_t(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def record_production(run: ProductionRun, path: str | os.PathLike[str], *, temperature_rate: float = 10.0,
                      compression: str = "zstd", start: float = 0.0) -> Path:
    """Write ``run`` to a new bag directory ``path`` (it must not exist; module docstring). Returns the path.

    ``start``: s added to every stamp (the run's time 0 as a time of day, e.g. the epoch seconds of the shift
    start: a bag stamped from 0 looks like a clock that was never set)."""
    p = Path(path)
    if p.exists():
        raise InputDataError(f"{p}: exists; give a new bag directory")
    if not (math.isfinite(temperature_rate) and temperature_rate > 0):
        raise InputDataError(f"record production: temperature_rate must be > 0 Hz, got {temperature_rate}")
    store = jointwear_typestore()
    js_t = store.types[JOINT_STATE_TYPE]
    tm_t = store.types[TEMPERATURE_TYPE]
    header_t = store.types["std_msgs/msg/Header"]
    names = list(run.names)
    n = len(names)
    params: dict[str, Any] = {"arm": run.arm, "joints": names, "payload": float(run.settings.get("payload", 0.0)),
                              "publish_rate": float(run.settings.get("sample_rate", 0.0)),
                              "temperature_rate": float(temperature_rate), "seed": int(run.settings.get("seed", 0))}
    for i, j in enumerate(names):
        params[f"{j}.wear"] = float(run.wear[0][i]) if run.wear else 0.0
        params[f"{j}.temperature"] = float(run.settings.get("temperature", [math.nan] * n)[i])
        params[f"{j}.gear_ratio"] = float(run.gear_ratio[i])
        params[f"{j}.torque_scale"] = float(run.torque_scale[i])
    custom = {NODE_PARAMS_KEY: json.dumps({"joint_sim": params}, sort_keys=True),
              TRUTH_KEY: json.dumps({**run.truth(), "stamp_offset": float(start)}, sort_keys=True)}
    writer = McapBagWriter(p, compression=compression, fsync=False, custom_data=custom)
    try:
        def connect(topic: str, msgtype: str) -> int:
            msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
            return writer.add_connection(topic, msgtype, msgdef,
                                         encoding="ros2idl" if msgdef.startswith("=" * 80 + "\nIDL: ") else "ros2msg",
                                         rihs01=store.hash_rihs01(msgtype))

        js_c = connect(JOINT_STATES_TOPIC, JOINT_STATE_TYPE)
        tm_c = connect(TEMPERATURE_TOPIC, TEMPERATURE_TYPE)
        period = 1.0 / temperature_rate
        next_temp = 0.0
        if not (math.isfinite(start) and start >= 0):
            raise InputDataError(f"record production: start must be a time >= 0 s, got {start}")
        stamps = np.rint((run.t + float(start)) * 1e9).astype(np.int64)
        for k in range(len(run.t)):
            ns = int(stamps[k])
            stamp = _stamp(store, ns)
            msg = js_t(header=header_t(stamp=stamp, frame_id=""), name=names,
                       position=np.asarray(run.q[k], dtype=np.float64),
                       velocity=np.asarray(run.v[k], dtype=np.float64),
                       effort=np.asarray(run.effort[k], dtype=np.float64))
            writer.write(js_c, ns, store.serialize_cdr(msg, JOINT_STATE_TYPE))
            if run.t[k] >= next_temp - 1e-9:
                next_temp += period
                for i, j in enumerate(names):
                    tm = tm_t(header=header_t(stamp=stamp, frame_id=j), temperature=float(run.temperature[k, i]),
                              variance=0.0)
                    writer.write(tm_c, ns, store.serialize_cdr(tm, TEMPERATURE_TYPE))
    except BaseException:
        writer.abort()
        raise
    writer.close()
    return p


def production_truth(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The truth :func:`record_production` stored in a bag (one :class:`InputDataError` line when it has none)."""
    p = check_bag_path(Path(path))
    text = bag_custom_data(p).get(TRUTH_KEY)
    if not isinstance(text, str):
        raise InputDataError(f"{p}: no simulated production's truth in metadata.yaml (custom_data {TRUTH_KEY})")
    try:
        out = json.loads(text)
    except ValueError:
        raise InputDataError(f"{p}: metadata.yaml custom_data {TRUTH_KEY} is not JSON") from None
    if not isinstance(out, dict):
        raise InputDataError(f"{p}: metadata.yaml custom_data {TRUTH_KEY} is not a JSON object")
    return out


# --------------------------------------------------------------------------- reading a production back


class JointStateRows:
    """Every joint's position, velocity and effort from a ``sensor_msgs/JointState``, looked up by name (the
    lookup cached while the names stay the same), or why the message cannot be used: the rule of the
    production observer node and of :func:`read_production` alike.

    >>> rows = JointStateRows(["a", "b"])
    >>> rows.row(["b", "a"], [2.0, 1.0], [0.0, 0.5], [3.0, 4.0])[0].tolist()
    [1.0, 2.0]
    >>> rows.row(["a"], [1.0], [0.0], [0.0])
    ('joint missing', "no joint 'b' among the names ['a']")
    """

    def __init__(self, joints: Sequence[str]) -> None:
        self.joints = tuple(str(j) for j in joints)
        self._names: tuple[str, ...] | None = None
        self._index: list[int] = []
        self._missing: list[str] = []

    def row(self, names: Sequence[str], position: Sequence[float], velocity: Sequence[float],
            effort: Sequence[float]) -> tuple[Array, Array, Array] | tuple[str, str]:
        """``(q, v, u)`` in the joints' order, or ``(reason, text)`` (reason: ``joint missing``, ``lengths``,
        ``not finite``)."""
        key = tuple(str(n) for n in names)
        if key != self._names:
            self._names = key
            where = {n: i for i, n in enumerate(key)}
            self._missing = [j for j in self.joints if j not in where]
            self._index = [where.get(j, -1) for j in self.joints]
        if self._missing:
            return "joint missing", f"no joint {', '.join(map(repr, self._missing))} among the names {list(key)!r}"
        n = len(key)
        for what, arr in (("position", position), ("velocity", velocity), ("effort", effort)):
            if len(arr) != n:
                return "lengths", f"{what} has {len(arr)} value(s) for {n} name(s)"
        idx = self._index
        q = np.asarray(position, dtype=float)[idx]
        v = np.asarray(velocity, dtype=float)[idx]
        u = np.asarray(effort, dtype=float)[idx]
        if not (np.isfinite(q).all() and np.isfinite(v).all() and np.isfinite(u).all()):
            return "not finite", "a position, velocity or effort is NaN or infinite"
        return q, v, u


class TemperatureTrack:
    """Each joint's temperature readings by stamp: :meth:`at` gives, per joint, the latest reading with a
    stamp at or before ``t`` (NaN before the first). Readings may arrive out of stamp order; asking in stamp
    order forgets the readings no later ask can need (the memory stays a few readings per joint).

    >>> tr = TemperatureTrack(["a", "b"])
    >>> tr.add("a", 1.0, 40.0); tr.add("a", 2.0, 41.0)
    True
    True
    >>> tr.at(1.5).tolist(), tr.at(2.0).tolist()
    ([40.0, nan], [41.0, nan])
    """

    def __init__(self, joints: Sequence[str]) -> None:
        self._of = {str(j): i for i, j in enumerate(joints)}
        self._stamps: list[list[float]] = [[] for _ in self._of]
        self._values: list[list[float]] = [[] for _ in self._of]

    def add(self, joint: str, stamp: float, value: float) -> bool:
        """One reading; False (not kept) for a joint not tracked or a non-finite stamp or value."""
        i = self._of.get(str(joint))
        if i is None or not (math.isfinite(stamp) and math.isfinite(value)):
            return False
        ts, vs = self._stamps[i], self._values[i]
        k = bisect.bisect_right(ts, stamp)
        ts.insert(k, stamp)
        vs.insert(k, value)
        return True

    def at(self, t: float) -> Array:
        out = np.full(len(self._stamps), math.nan)
        for i, (ts, vs) in enumerate(zip(self._stamps, self._values, strict=True)):
            k = bisect.bisect_right(ts, t)
            if k:
                out[i] = vs[k - 1]
                if k > 1:  # the readings before the one used are needed by no later (not earlier) t
                    del ts[: k - 1], vs[: k - 1]
        return out


@dataclass
class ShiftClock:
    """The production observer's shift rule, by the samples' stamps (never a wall clock).

    Period ``p = 1 + floor((stamp - origin) / seconds)``; the shift being observed ends when a sample of a
    later period arrives (:meth:`on_sample` returns its id), or when :meth:`end` is called (the operator's
    ``~/end_shift``, the node's idle rule, the end of the recorded data). A shift's id is its period, or one
    more than the last shift's when that is larger (a shift ended early leaves the rest of its period to the
    next id; ids always grow, from 1).

    >>> c = ShiftClock(seconds=10.0, origin=0.0)
    >>> [c.on_sample(t) for t in (1.0, 9.0, 12.0)], c.current
    ([None, None, 1], 2)
    >>> c.end(), c.on_sample(13.0), c.current, c.on_sample(21.0), c.current
    (2, None, 3, 3, 4)
    """

    seconds: float = 8 * 3600.0
    origin: float = 0.0
    #: the shift being observed (None: none yet, or the last one ended)
    current: int | None = None
    #: its period
    period: int = 0
    #: the last shift ended (0: none)
    last: int = 0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ParameterError(f"shift_seconds must be a positive number of seconds, got {self.seconds!r}")
        if not math.isfinite(self.origin):
            raise ParameterError(f"shift_origin must be a finite number of seconds, got {self.origin!r}")

    def period_of(self, stamp: float) -> int:
        return 1 + math.floor((stamp - self.origin) / self.seconds)

    def end_time(self) -> float:
        """The stamp at which the current shift's period ends (inf when no shift is being observed)."""
        return self.origin + self.period * self.seconds if self.current is not None else math.inf

    def on_sample(self, stamp: float) -> int | None:
        """A sample at ``stamp``: the id of the shift it ends (it is of a later period), else None. The sample
        then belongs to :attr:`current`."""
        p = self.period_of(stamp)
        ended = self.end() if self.current is not None and p > self.period else None
        if self.current is None:
            self.period = p
            self.current = max(p, self.last + 1)
        return ended

    def end(self) -> int | None:
        """End the current shift now; its id (None when none is being observed)."""
        sid = self.current
        if sid is not None:
            self.last = sid
            self.current = None
        return sid

    def idle_due(self, now: float, silent_for: float, idle: float) -> bool:
        """The idle rule: a shift is being observed, ``now`` (the node's clock, stamps' time base) is past its
        period's end and no sample came for ``silent_for >= idle`` (wall) seconds."""
        return self.current is not None and now >= self.end_time() and silent_for >= idle


@dataclass(frozen=True)
class ProductionSamples:
    """A recorded production's samples (:func:`read_production`): rows = stamps (s), columns = ``names``;
    rad, rad/s, N·m joint side, degC (NaN: no reading yet). ``skipped``: JointState messages not used, by
    reason; ``bags``: the bags read, in order."""

    names: tuple[str, ...]
    t: Array
    q: Array
    v: Array
    u: Array
    temps: Array
    skipped: dict[str, int] = field(default_factory=dict)
    bags: tuple[str, ...] = ()
    temperature_readings: int = 0


def read_production(paths: Iterable[str | os.PathLike[str]], *, joints: Sequence[str] | None = None,
                    joint_states_topic: str = JOINT_STATES_TOPIC,
                    temperature_topic: str = TEMPERATURE_TOPIC) -> ProductionSamples:
    """The ``/joint_states`` and ``/joint_temperature`` of ``paths`` (bags, read in the order given) as
    :class:`ProductionSamples`, by the node's rules (module docstring). ``joints`` default: the names of the
    first JointState. One :class:`InputDataError` line for a path that is no bag, a bag without a JointState
    on ``joint_states_topic``, or no usable sample."""
    bags = [str(p) for p in paths]
    if not bags:
        raise InputDataError("give at least one bag")
    rows: JointStateRows | None = JointStateRows(joints) if joints else None
    t: list[float] = []
    qs: list[Array] = []
    vs: list[Array] = []
    us: list[Array] = []
    temps: list[tuple[str, float, float]] = []
    skipped: Counter[str] = Counter()
    last = -math.inf
    for bag in bags:
        seen = 0
        for m in read_messages(bag, topics=[joint_states_topic, temperature_topic],
                               msgtypes=[JOINT_STATE_TYPE, TEMPERATURE_TYPE]):
            if m.msgtype == TEMPERATURE_TYPE:
                if m.topic == temperature_topic:
                    temps.append((str(m.msg.header.frame_id), stamp_to_seconds(m.msg.header),
                                  float(m.msg.temperature)))
                continue
            if m.topic != joint_states_topic:
                continue
            seen += 1
            msg = m.msg
            if rows is None:
                rows = JointStateRows(list(msg.name))
            got = rows.row(list(msg.name), msg.position, msg.velocity, msg.effort)
            stamp = stamp_to_seconds(msg.header)
            if isinstance(got[0], str):
                skipped[str(got[0])] += 1
            elif not stamp > 0:
                skipped["no stamp"] += 1
            elif not stamp > last:
                skipped["stamp not after the previous"] += 1
            else:
                last = stamp
                t.append(stamp)
                qs.append(got[0])  # type: ignore[arg-type]
                vs.append(got[1])  # type: ignore[arg-type]
                us.append(got[2])  # type: ignore[misc]
        if not seen:
            raise InputDataError(f"{bag}: no sensor_msgs/JointState on {joint_states_topic}; give a bag of the "
                                 "robot's joint states (position, velocity and effort of every joint)")
    assert rows is not None
    if not t:
        why = ", ".join(f"{k} {v}" for k, v in sorted(skipped.items()))
        raise InputDataError(f"{', '.join(bags)}: no usable JointState sample ({why}); every joint "
                             f"({', '.join(rows.joints)}) needs a position, velocity and effort")
    track = TemperatureTrack(rows.joints)
    used = sum(track.add(j, s, x) for j, s, x in temps)
    ta = np.asarray(t, dtype=float)
    temp = np.array([track.at(x) for x in ta]) if used else np.full((ta.size, len(rows.joints)), math.nan)
    return ProductionSamples(rows.joints, ta, np.array(qs), np.array(vs), np.array(us), temp, dict(sorted(skipped.items())),
                             tuple(bags), int(used))


def production_shifts(samples: ProductionSamples, config: ProductionConfig | Sequence[ProductionConfig] | None = None,
                      *, clock: ShiftClock | None = None, models: Mapping[str, Any] | None = None
                      ) -> list[ProductionShift]:
    """The samples through one :class:`~jointwear_ros.observer.ProductionObserver`, shift by shift by
    ``clock`` (:class:`ShiftClock`; default 8 h shifts from 0 s); the last shift ends with the data.
    ``models``: the observer's arm-model keyword arguments (:meth:`~jointwear_ros.sim.arm.ArmModel.observer_models`)."""
    from ..observer.production import ProductionObserver

    clock = clock or ShiftClock()
    obs = ProductionObserver(samples.names, config, **dict(models or {}))
    out: list[ProductionShift] = []
    for k in range(samples.t.size):
        t = float(samples.t[k])
        ended = clock.on_sample(t)
        if ended is not None:
            out.append(obs.end_shift(ended))
        obs.add(t, samples.q[k], samples.v[k], samples.u[k], samples.temps[k])
    sid = clock.end()
    if sid is not None:
        out.append(obs.end_shift(sid))
    return out
