r"""A joint's recorded time series from files: CSV columns, or ``sensor_msgs/JointState`` in a bag.

Adapters for :func:`jointwear_ros.observer.timeseries.timeseries_observations`;
every problem with a file is an :class:`~jointwear_ros.errors.InputDataError`
naming the file, the column and the line.

CSV rules: a header of column names (``#`` comment lines before it are
skipped), one sample per line; the delimiter is detected among ``, ; tab``
and runs of spaces. The columns named for time, position, effort (and
velocity, temperature, load when given) must be present; a cell that is empty
or ``nan`` is a missing value (the sample is dropped and counted), a cell that
is not a number is refused. Every other numeric column is kept as a measured
variable; a column with no number in it (a label) is ignored.

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "log.csv").write_text("t;q;tau;mode\n0;0.0;1.5;run\n0.01;0.002;1.6;run\n")
>>> s = read_timeseries_csv(d / "log.csv", time="t", position="q", effort="tau")
>>> s.time.tolist(), s.effort.tolist(), s.velocity is None, sorted(s.extra)
([0.0, 0.01], [1.5, 1.6], True, [])
>>> read_timeseries_csv(d / "log.csv", time="t", position="angle", effort="tau")
Traceback (most recent call last):
...
jointwear_ros.errors.InputDataError: ...log.csv: no column 'angle' (--position); columns: t, q, tau, mode
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from .bags import JOINT_STATE_TYPE, TEMPERATURE_TYPE, read_messages, stamp_seconds
from .tables import read_text_file

__all__ = ["JointSeries", "read_joint_states", "read_timeseries", "read_timeseries_csv"]

Array = npt.NDArray[np.float64]


@dataclass
class JointSeries:
    """One joint's samples: time (s), position, velocity (None: not recorded), effort, other variables."""

    source: str
    time: Array
    position: Array
    velocity: Array | None
    effort: Array
    extra: dict[str, Array] = field(default_factory=dict)
    temperature: str | None = None
    load: str | None = None


def _delimiter(line: str) -> str | None:
    for d in (",", ";", "\t"):
        if d in line:
            return d
    return None


def _cell(text: str) -> float | None:
    s = text.strip()
    if s == "" or s.lower() in ("nan", "na", "null", "none"):
        return math.nan
    try:
        return float(s)
    except ValueError:
        return None


def read_timeseries_csv(
    path: str | os.PathLike[str], *, time: str, position: str, effort: str, velocity: str | None = None,
    temperature: str | None = None, load: str | None = None,
) -> JointSeries:
    """Read a time-series CSV (see the module docstring); column arguments name the header columns."""
    p = Path(path)
    src = str(p)
    raw = read_text_file(p)
    lines = [(i, ln) for i, ln in enumerate(raw.splitlines(), start=1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputDataError(f"{src}: no header line; expected column names such as {time},{position},{effort}")
    header_line, head = lines[0]
    delim = _delimiter(head)
    rows: list[tuple[int, list[str]]] = []
    if delim is None:
        header = head.split()
        rows = [(i, re.split(r"\s+", ln.strip())) for i, ln in lines[1:]]
    else:
        header = [h.strip() for h in next(csv.reader(io.StringIO(head), delimiter=delim))]
        for i, ln in lines[1:]:
            rows.append((i, next(csv.reader(io.StringIO(ln), delimiter=delim))))
    for j, name in enumerate(header):
        if not name:
            raise InputDataError(f"{src}: line {header_line}: column {j + 1} of the header has no name")
        if header.count(name) > 1:
            raise InputDataError(f"{src}: line {header_line}: column {name!r} appears twice in the header")
    roles = {"--time": time, "--position": position, "--effort": effort, "--velocity": velocity,
             "--temperature": temperature, "--load": load}
    for flag, col in roles.items():
        if col is not None and col not in header:
            raise InputDataError(f"{src}: no column {col!r} ({flag}); columns: {', '.join(header)}")
    if not rows:
        raise InputDataError(f"{src}: no data rows after the header (line {header_line})")
    for lineno, fields in rows:
        if len(fields) != len(header):
            raise InputDataError(f"{src}: line {lineno} has {len(fields)} fields, the header has {len(header)}")
    needed = {n for n in roles.values() if n is not None}
    cols: dict[str, Array] = {}
    for j, name in enumerate(header):
        vals = [_cell(f[j]) for _, f in rows]
        if name not in needed and all(v is None or math.isnan(v) for v in vals) and any(v is None for v in vals):
            continue  # a label column
        for (lineno, f), v in zip(rows, vals):
            if v is None:
                raise InputDataError(f"{src}: column {name!r}, line {lineno}: {f[j].strip()!r} is not a number")
        cols[name] = np.asarray(vals, dtype=float)
    extra = {k: v for k, v in cols.items() if k not in (time, position, effort, velocity)}
    return JointSeries(source=src, time=cols[time], position=cols[position],
                       velocity=None if velocity is None else cols[velocity], effort=cols[effort], extra=extra,
                       temperature=temperature, load=load)


def read_joint_states(
    path: str | os.PathLike[str], joint: str, *, topic: str | None = None, temperature_topic: str | None = None,
) -> JointSeries:
    """One joint's samples from a bag's ``sensor_msgs/JointState`` (header stamps, joint side as recorded).

    ``topic``: the JointState topic (default: every JointState topic of the
    bag); ``temperature_topic`` (default: every ``sensor_msgs/Temperature``
    topic): readings whose ``header.frame_id`` is ``joint`` (or empty) become
    a ``temperature`` column, each sample taking the latest reading before it.
    A message without velocity leaves the velocity to be derived from position.
    """
    src = str(path)
    t: list[float] = []
    q: list[float] = []
    v: list[float] = []
    e: list[float] = []
    temps: list[tuple[float, float]] = []
    names_seen: set[str] = set()
    n_js = 0
    for m in read_messages(path, msgtypes=(JOINT_STATE_TYPE, TEMPERATURE_TYPE)):
        if m.msgtype == JOINT_STATE_TYPE:
            if topic is not None and m.topic != topic:
                continue
            n_js += 1
            msg = m.msg
            names = list(msg.name)
            names_seen.update(names)
            if joint not in names:
                continue
            i = names.index(joint)
            n = len(names)
            if len(msg.position) != n or len(msg.effort) != n:
                continue
            t.append(stamp_seconds(msg.header) or m.log_time * 1e-9)
            q.append(float(msg.position[i]))
            e.append(float(msg.effort[i]))
            v.append(float(msg.velocity[i]) if len(msg.velocity) == n else math.nan)
        elif temperature_topic is None or m.topic == temperature_topic:
            if m.msg.header.frame_id in ("", joint):
                temps.append((stamp_seconds(m.msg.header) or m.log_time * 1e-9, float(m.msg.temperature)))
    if not n_js:
        raise InputDataError(f"{src}: no sensor_msgs/JointState messages"
                             + (f" on {topic}" if topic else "") + "; give the bag of the joint's states")
    if not t:
        known = ", ".join(sorted(names_seen)) or "none"
        raise InputDataError(f"{src}: joint {joint!r} is in no JointState with position and effort (--joint); "
                             f"joints present: {known}")
    time = np.asarray(t)
    vel = np.asarray(v)
    series = JointSeries(source=src, time=time, position=np.asarray(q),
                         velocity=None if np.isnan(vel).all() else vel, effort=np.asarray(e))
    if temps:
        tt = np.array([x[0] for x in temps])
        tv = np.array([x[1] for x in temps])
        order = np.argsort(tt, kind="stable")
        tt, tv = tt[order], tv[order]
        k = np.searchsorted(tt, time, side="right") - 1
        series.extra["temperature"] = np.where(k >= 0, tv[np.clip(k, 0, None)], math.nan)
        series.temperature = "temperature"
    return series


def _is_bag(p: Path) -> bool:
    return (p.is_dir() and (p / "metadata.yaml").is_file()) or p.suffix in (".mcap", ".db3")


def read_timeseries(
    path: str | os.PathLike[str], *, time: str | None = None, position: str | None = None,
    effort: str | None = None, velocity: str | None = None, temperature: str | None = None,
    load: str | None = None, joint: str | None = None, topic: str | None = None,
) -> JointSeries:
    """A CSV (the column names are needed) or a bag (``joint`` is needed) as a :class:`JointSeries`."""
    p = Path(path)
    if not p.exists():
        raise InputDataError(f"{p}: no such file or directory")
    if _is_bag(p):
        if not joint:
            raise InputDataError(f"{p}: a bag holds several joints' states; name the joint with --joint")
        return read_joint_states(p, joint, topic=topic)
    missing = [f for f, v in (("--time", time), ("--position", position), ("--effort", effort)) if not v]
    if missing:
        raise InputDataError(f"{p}: a CSV needs {', '.join(missing)} to name its column(s)")
    assert time is not None and position is not None and effort is not None
    return read_timeseries_csv(p, time=time, position=position, effort=effort, velocity=velocity,
                               temperature=temperature, load=load)
