"""Friction observations per joint from the inputs commissioning and estimation take: bags and CSV tables.

A bag of this suite holds ``FrictionObservation`` messages (``joint_name`` per
message) and, by default, ``/joint_temperature`` (``sensor_msgs/Temperature``,
``frame_id`` = joint). An observation without a temperature (the observer's
``temperature_topic`` is empty by default) takes the mean of its joint's recorded
temperature over the observation's window: the time since the joint's previous
observation of the same cycle (the window ends at the message stamp), or the
latest temperature before the stamp when none falls inside.

A CSV table may have a ``joint`` column (text): its rows are split by joint; a
table without one is ``default_joint``'s. A production shift's observations (``source`` ``production``)
carry the ``production`` column (:mod:`jointwear_ros.io.tables`: in CSV the text column ``source``).
"""

from __future__ import annotations

import csv
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputDataError
from ..types import ObservationTable
from ..units import SUITE_UNITS
from .bags import read_messages, stamp_seconds
from .tables import PRODUCTION_COLUMN, production_of, read_csv

__all__ = ["TEMPERATURE_TOPIC", "read_observations"]

#: Where joint_sim publishes the joint temperatures (frame_id = joint).
TEMPERATURE_TOPIC = "/joint_temperature"
#: Where the friction observer publishes its observations (its ``observations_topic``).
OBSERVATIONS_TOPIC = "/jointwear/friction_observations"
_OBS_TYPE = "jointwear_msgs/msg/FrictionObservation"
_TEMP_TYPE = "sensor_msgs/msg/Temperature"
_FIELDS = ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position")


def _is_bag(p: Path) -> bool:
    return p.is_dir() or p.suffix in (".mcap", ".db3")


def read_observations(path: str | os.PathLike[str], default_joint: str | None = None,
                      temperature_topic: str = TEMPERATURE_TOPIC) -> dict[str, ObservationTable]:
    """joint -> observation table of one bag or CSV file (see the module docstring)."""
    p = Path(path)
    if not p.exists():
        raise InputDataError(f"{p}: no such file or bag")
    if _is_bag(p):
        return _read_bag(p, temperature_topic)
    return _read_csv(p, default_joint)


def _read_csv(p: Path, default_joint: str | None) -> dict[str, ObservationTable]:
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            body = [line for line in fh if line.strip() and not line.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        raise InputDataError(f"{p}: cannot read the table ({exc})") from None
    header = next(csv.reader(body[:1]), [])
    if "joint" not in [h.strip() for h in header]:
        return {default_joint or "": read_csv(p)}
    rows = list(csv.DictReader(body))
    joints = [str(r.get("joint") or "").strip() for r in rows]
    if any(not j for j in joints):
        i = joints.index("")
        raise InputDataError(f"{p}: row {i + 1}: empty joint; name the joint of every row (or drop the column)")
    import tempfile

    units = read_csv(p).units  # the declared units of the whole file (its comment lines)
    out: dict[str, ObservationTable] = {}
    names = [h for h in header if h.strip() != "joint"]
    for j in dict.fromkeys(joints):
        with tempfile.TemporaryDirectory() as d:
            sub = Path(d) / p.name
            with sub.open("w", newline="", encoding="utf-8") as fh:
                if units is not None:
                    fh.write(units.header() + "\n")
                w = csv.writer(fh)
                w.writerow(names)
                for r, jj in zip(rows, joints):
                    if jj == j:
                        w.writerow([r.get(n, "") for n in names])
            t = read_csv(sub)
        out[j] = ObservationTable(dict(t.columns), source=f"{p} [{j}]", units=t.units)
    return out


def _read_bag(p: Path, temperature_topic: str) -> dict[str, ObservationTable]:
    data: dict[str, dict[str, list[float]]] = {}
    temps: dict[str, list[tuple[float, float]]] = {}
    for m in read_messages(p, msgtypes=(_OBS_TYPE, _TEMP_TYPE)):
        msg: Any = m.msg
        if m.msgtype == _TEMP_TYPE:
            if m.topic == temperature_topic:
                temps.setdefault(str(msg.header.frame_id), []).append(
                    (stamp_seconds(msg.header), float(msg.temperature)))
            continue
        j = str(msg.joint_name)
        d = data.setdefault(j, {k: [] for k in ("cycle", "time", *_FIELDS, PRODUCTION_COLUMN)})
        d["cycle"].append(float(msg.cycle_id))
        d[PRODUCTION_COLUMN].append(production_of(getattr(msg, "source", "")))
        d["time"].append(stamp_seconds(msg.header))
        for f in _FIELDS:
            v = float(getattr(msg, f))
            if math.isinf(v) or (f in ("speed", "tau_f") and not math.isfinite(v)):
                raise InputDataError(f"{p}: joint {j}: {f} {v!r} in observation {len(d['speed']) + 1} is not finite")
            d[f].append(v)
    if not data:
        raise InputDataError(f"{p}: the bag holds no {_OBS_TYPE} messages; record the friction observer's "
                             f"output ({OBSERVATIONS_TOPIC}, the recorder records it by default)")
    out: dict[str, ObservationTable] = {}
    for j, d in data.items():
        cols = {k: np.asarray(v, dtype=float) for k, v in d.items()}
        _fill_temperature(cols, temps.get(j, []))
        cols = {k: v for k, v in cols.items() if k in ("speed", "tau_f") or not np.all(np.isnan(v))}
        if not cols[PRODUCTION_COLUMN].any():  # only test cycles: the table as it always was
            del cols[PRODUCTION_COLUMN]
        out[j] = ObservationTable(cols, source=f"{p} [{j}]", units=SUITE_UNITS)
    return out


def _fill_temperature(cols: dict[str, np.ndarray], temps: list[tuple[float, float]]) -> None:
    """NaN temperatures from the joint's recorded temperature over each observation's window."""
    t_obs = cols["temperature"]
    missing = np.flatnonzero(np.isnan(t_obs))
    if missing.size == 0 or not temps:
        return
    arr = np.asarray(sorted(temps))
    ts, vals = arr[:, 0], arr[:, 1]
    stamps, cycles = cols["time"], cols["cycle"]
    order = np.argsort(stamps, kind="stable")
    prev = np.full(stamps.size, -math.inf)
    last: dict[float, float] = {}
    for i in order:
        prev[i] = last.get(float(cycles[i]), stamps[i] - 30.0)
        last[float(cycles[i])] = stamps[i]
    for i in missing:
        m = (ts > prev[i]) & (ts <= stamps[i])
        if m.any():
            t_obs[i] = float(np.mean(vals[m]))
        else:
            k = int(np.searchsorted(ts, stamps[i], side="right")) - 1
            if k >= 0:
                t_obs[i] = float(vals[k])
