"""Nightly test-cycle bags of a synthetic fleet, in the recorder's format, for tests and benchmarks.

Each bag is a rosbag2 directory (metadata v9, MCAP storage) as the
``recorder`` writes it for one cycle: ``/joint_states`` (the tested joint and
a second, still one), ``/test_cycle/status`` and ``/parameter_events`` with
the parameters the live ``friction_observer`` and ``wear_estimator`` declared
(``joint_name``, ``hardware_id``, ``method``, ``params``, ...). Replay (and
so ``jointwear fleet reprocess``) reads the robot from the ``robot`` parameter
of the cell's ``wear_trend`` node and the joint from the observer's
``joint_name``, exactly as from a real cell's bag (see
:func:`jointwear_ros.fleet.reanalysis.bag_identity`).

The samples come from :func:`~jointwear_ros.observer.synthetic.synthetic_cycle`
(the friction model with wear, AR(1) torque noise); the time stamps are wall
times of nights (``start + night * 86400``), so a robot's bags make a
history a trend can follow.

No ROS runtime: rosbags writes the bag with the jointwear typestore.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..contract import seconds_to_stamp_fields
from ..io.typestore import jointwear_typestore
from ..observer.synthetic import SyntheticCycle, SyntheticRobotCycle, synthetic_cycle

__all__ = ["BagSpec", "fleet_specs", "write_cycle_bag", "write_fleet", "write_robot_cycle_bag"]

#: 2026-01-01 00:00 UTC, the first night of a synthetic fleet
DEFAULT_START = 1767225600.0


@dataclass(frozen=True)
class BagSpec:
    """One recorded night of one joint: who, when, its true wear, and the cycle's shape."""

    robot: str
    joint: str
    night: int
    wear: float
    temperature: float = 40.0
    speeds: tuple[float, ...] = (30.0, 45.0, 60.0)
    rate: float = 250.0
    cycle_id: int = 1
    seed: int = 0
    start: float = DEFAULT_START
    method: str = "paper"
    params: str = "ref-2011r"

    @property
    def t0(self) -> float:
        """Start of the cycle: 02:00 of the night."""
        return self.start + 86400.0 * self.night + 7200.0

    @property
    def name(self) -> str:
        return f"{self.robot}_{self.joint}_n{self.night:04d}"


def fleet_specs(robots: int, joints: int, nights: int, *, rates: Sequence[float] | None = None,
                start_wear: float = 8.0, seed: int = 0, **kw: Any) -> list[BagSpec]:
    """``robots x joints x nights`` specs; joint ``k`` wears at ``rates[k % len(rates)]`` per night."""
    rates = list(rates) if rates is not None else [0.0, 0.3, 0.8]
    out = []
    for r in range(robots):
        for j in range(joints):
            rate = rates[(r * joints + j) % len(rates)]
            for n in range(nights):
                out.append(BagSpec(robot=f"robot_{r + 1:02d}", joint=f"joint_{j + 1}", night=n,
                                   wear=start_wear + rate * n, seed=seed + 7919 * r + 104729 * j + n, **kw))
    return out


def _time(store: Any, t: float) -> Any:
    sec, nanosec = seconds_to_stamp_fields(t)
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _header(store: Any, t: float) -> Any:
    return store.types["std_msgs/msg/Header"](stamp=_time(store, t), frame_id="")


def _param(store: Any, name: str, value: Any) -> Any:
    T = store.types
    kw: dict[str, Any] = {
        "type": 0, "bool_value": False, "integer_value": 0, "double_value": 0.0, "string_value": "",
        "byte_array_value": np.zeros(0, np.uint8), "bool_array_value": np.zeros(0, bool), "integer_array_value": np.zeros(0, np.int64),
        "double_array_value": np.zeros(0), "string_array_value": [],
    }
    if isinstance(value, bool):
        kw.update(type=1, bool_value=value)
    elif isinstance(value, int):
        kw.update(type=2, integer_value=value)
    elif isinstance(value, float):
        kw.update(type=3, double_value=value)
    elif isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
        kw.update(type=9, string_array_value=list(value))
    elif isinstance(value, (list, tuple)):
        kw.update(type=8, double_array_value=np.asarray(value, dtype=float))
    else:
        kw.update(type=4, string_value=str(value))
    return T["rcl_interfaces/msg/Parameter"](name=name, value=T["rcl_interfaces/msg/ParameterValue"](**kw))


def _param_event(store: Any, t: float, node: str, params: dict[str, Any]) -> Any:
    return store.types["rcl_interfaces/msg/ParameterEvent"](
        stamp=_time(store, t), node=f"/{node}",
        new_parameters=[_param(store, k, v) for k, v in params.items()], changed_parameters=[], deleted_parameters=[])


def spec_cycle(spec: BagSpec) -> SyntheticCycle:
    """The synthetic samples and statuses of one spec (deterministic in its seed)."""
    return synthetic_cycle(spec.speeds, wear=spec.wear, temperature=spec.temperature, rate=spec.rate,
                           noise_std=0.002, seed=spec.seed, t0=spec.t0, cycle_id=spec.cycle_id,
                           joint_name=spec.joint, params=spec.params)


def write_cycle_bag(path: str | os.PathLike[str], spec: BagSpec, cycle: SyntheticCycle | None = None,
                    store: Any = None, parameters: bool = True) -> Path:
    """Write one night's bag of ``spec`` to ``path`` (a new directory) and return it; ``parameters=False``
    leaves the nodes' parameters out (a bag recorded by a recorder started after the nodes, an old bag)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    ts = store if store is not None else jointwear_typestore()
    T = ts.types
    cyc = cycle if cycle is not None else spec_cycle(spec)
    p = Path(path)
    t_start = float(cyc.stamps[0]) - 1.0
    params_obs = {"joint_name": spec.joint, "gear_ratio": 100.0, "torque_scale": 200.0}
    params_est = {"joint_name": spec.joint, "hardware_id": f"{spec.robot}/{spec.joint}", "method": spec.method,
                  "params": spec.params, "seed": 0}
    params_trend = {"robot": spec.robot, "db_url": "wear_history.db", "hardware_id": ""}
    js_type, st_type, pe_type = ("sensor_msgs/msg/JointState", "jointwear_msgs/msg/TestCycleStatus",
                                 "rcl_interfaces/msg/ParameterEvent")
    other = "joint_0" if spec.joint != "joint_0" else "joint_9"
    events: list[tuple[float, int, Any]] = [
        (t_start, 0, _param_event(ts, t_start, "friction_observer", params_obs)),
        (t_start + 0.001, 0, _param_event(ts, t_start + 0.001, "wear_estimator", params_est)),
        (t_start + 0.002, 0, _param_event(ts, t_start + 0.002, "wear_trend", params_trend)),
    ]
    if not parameters:
        events = []
    for st in cyc.statuses:
        events.append((st.stamp, 1, T[st_type](
            header=_header(ts, st.stamp), joint_name=st.joint_name, cycle_id=st.cycle_id, state=st.state,
            phase=st.phase, current_speed=st.current_speed, speeds_done=st.speeds_done, speeds_total=st.speeds_total,
            window_center=st.window_center, window_half_width=st.window_half_width, message="",
            joints=[st.joint_name], joints_done=0)))
    js = T[js_type]
    names = [other, spec.joint]
    for t, q, v, e in zip(cyc.stamps.tolist(), cyc.position.tolist(), cyc.velocity.tolist(), cyc.effort.tolist()):
        events.append((t, 2, js(header=_header(ts, t), name=names, position=np.array([0.5, q]),
                                velocity=np.array([0.0, v]), effort=np.array([3.0, e]))))
    events.sort(key=lambda e: (e[0], e[1]))
    topics = {0: ("/parameter_events", pe_type), 1: ("/test_cycle/status", st_type), 2: ("/joint_states", js_type)}
    with Writer(p, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {k: w.add_connection(topic, typ, typestore=ts) for k, (topic, typ) in topics.items()}
        for t, k, msg in events:
            w.write(conns[k], round(t * 1e9), ts.serialize_cdr(msg, topics[k][1]))
    return p


def write_fleet(root: str | os.PathLike[str], specs: Sequence[BagSpec]) -> list[Path]:
    """Write one bag per spec under ``root`` (``root/<robot>/<name>``); return the bag directories."""
    ts = jointwear_typestore()
    r = Path(root)
    out = []
    for s in specs:
        (r / s.robot).mkdir(parents=True, exist_ok=True)
        out.append(write_cycle_bag(r / s.robot / s.name, s, store=ts))
    return out


def write_robot_cycle_bag(path: str | os.PathLike[str], cycle: SyntheticRobotCycle, *, robot: str = "robot_01",
                          extra: Sequence[tuple[float, str, str, Any]] = (), observer_params: dict[str, Any] | None = None,
                          estimator_params: dict[str, Any] | None = None, temperature_topic: str = "",
                          store: Any = None) -> Path:
    """Write a robot cycle (every joint in one bag, docs/robot.md) as the recorder would, with the project's
    MCAP bag writer (:class:`~jointwear_ros.io.mcap_bag.McapBagWriter`); return the bag directory.

    ``/joint_states`` carries every joint of ``cycle`` in one message per sample, ``/test_cycle/status``
    the robot cycle's statuses (``joints``, ``joints_done`` set), ``temperature_topic`` (when given) the
    per-joint temperatures (``header.frame_id`` = joint), and ``/parameter_events`` the parameters the live
    nodes declared (``joints`` of the observer and the estimator, plus ``observer_params`` and
    ``estimator_params``; the robot as ``wear_trend``'s ``robot``). ``extra`` are more messages
    ``(stamp, topic, msgtype, message)``, e.g. the live observations and estimates to compare with.
    """
    from ..io.mcap_bag import McapBagWriter

    ts = store if store is not None else jointwear_typestore()
    T = ts.types
    t_start = float(cycle.stamps[0]) - 1.0
    obs = {"joints": list(cycle.joints), "gear_ratio": 100.0, "torque_scale": 200.0,
           "temperature_topic": temperature_topic, **(observer_params or {})}
    est = {"joints": list(cycle.joints), "method": "paper", "params": "ref-2011r", "seed": 0, **(estimator_params or {})}
    js_type, st_type, pe_type, tp_type = ("sensor_msgs/msg/JointState", "jointwear_msgs/msg/TestCycleStatus",
                                          "rcl_interfaces/msg/ParameterEvent", "sensor_msgs/msg/Temperature")
    events: list[tuple[float, int, str, str, Any]] = [
        (t_start, 0, "/parameter_events", pe_type, _param_event(ts, t_start, "friction_observer", obs)),
        (t_start + 0.001, 0, "/parameter_events", pe_type, _param_event(ts, t_start + 0.001, "wear_estimator", est)),
        (t_start + 0.002, 0, "/parameter_events", pe_type,
         _param_event(ts, t_start + 0.002, "wear_trend", {"robot": robot, "hardware_id": ""})),
    ]
    for st in cycle.statuses:
        events.append((st.stamp, 1, "/test_cycle/status", st_type, T[st_type](
            header=_header(ts, st.stamp), joint_name=st.joint_name, cycle_id=st.cycle_id, state=st.state,
            phase=st.phase, current_speed=st.current_speed, speeds_done=st.speeds_done, speeds_total=st.speeds_total,
            window_center=st.window_center, window_half_width=st.window_half_width, message="",
            joints=list(cycle.joints), joints_done=st.joints_done)))
    if temperature_topic:
        for t, celsius, joint in cycle.temperatures:
            events.append((t, 1, temperature_topic, tp_type, T[tp_type](
                header=store_header(ts, t, joint), temperature=celsius, variance=0.0)))
    js = T[js_type]
    names = list(cycle.joints)
    for i, t in enumerate(cycle.stamps.tolist()):
        events.append((t, 2, "/joint_states", js_type, js(
            header=_header(ts, t), name=names, position=np.array(cycle.position[i]),
            velocity=np.array(cycle.velocity[i]), effort=np.array(cycle.effort[i]))))
    for t, topic, typ, msg in extra:
        events.append((float(t), 3, topic, typ, msg))
    events.sort(key=lambda e: (e[0], e[1]))
    w = McapBagWriter(Path(path), fsync=False)
    try:
        channels: dict[str, int] = {}
        for t, _, topic, typ, msg in events:
            if topic not in channels:
                msgdef, _ = ts.generate_msgdef(typ, ros_version=2)
                channels[topic] = w.add_connection(topic, typ, msgdef, rihs01=ts.hash_rihs01(typ))
            w.write(channels[topic], round(t * 1e9), ts.serialize_cdr(msg, typ))
    finally:
        w.close()
    return Path(path)


def store_header(store: Any, t: float, frame_id: str) -> Any:
    """A ``std_msgs/Header`` at ``t`` with ``frame_id``."""
    return store.types["std_msgs/msg/Header"](stamp=_time(store, t), frame_id=frame_id)
