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
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputDataError
from .bags import JOINT_STATE_TYPE, NODE_PARAMS_KEY, TEMPERATURE_TYPE, bag_custom_data, check_bag_path
from .mcap_bag import McapBagWriter
from .typestore import jointwear_typestore

if TYPE_CHECKING:
    from ..sim.production import ProductionRun

__all__ = ["JOINT_STATES_TOPIC", "TEMPERATURE_TOPIC", "TRUTH_KEY", "production_truth", "record_production"]

JOINT_STATES_TOPIC = "/joint_states"
#: the joint_sim node's temperature topic (one Temperature per joint, frame_id = the joint)
TEMPERATURE_TOPIC = "/joint_temperature"
#: ``custom_data`` key of the production's truth (JSON)
TRUTH_KEY = "jointwear.production"


def _stamp(store: Any, ns: int) -> Any:
    time_t = store.types["builtin_interfaces/msg/Time"]
    return time_t(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def record_production(run: ProductionRun, path: str | os.PathLike[str], *, temperature_rate: float = 10.0,
                      compression: str = "zstd") -> Path:
    """Write ``run`` to a new bag directory ``path`` (it must not exist; module docstring). Returns the path."""
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
              TRUTH_KEY: json.dumps(run.truth(), sort_keys=True)}
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
        stamps = np.rint(run.t * 1e9).astype(np.int64)
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
