r"""Observation tables from and to files: CSV, and rosbag2 (MCAP) bags of FrictionObservation.

Bags are read and written with rosbags and the jointwear typestore; no ROS
runtime is needed. Every problem with the input raises
:class:`~jointwear_ros.errors.InputDataError` with a one-line message naming
the file, the column and the row. Writers write to a temporary name and
rename, so a failed write leaves nothing half-written.

CSV rules: a header line of column names (lines starting with ``#`` before it
are comments), then one observation per line. ``speed`` and ``tau_f`` are
required. Every cell of a numeric column must be a finite number (leave out a
column rather than fill it with blanks or NaN: NaN is refused in optional
columns too); a column in which no cell is a number (a joint name, a comment)
is ignored, unless it is one of the standard columns.

**Source.** An observation of a production shift (``FrictionObservation.source`` ``production``, see
:class:`~jointwear_ros.contract.Source`) is marked by the numeric column ``production`` (1; 0: a test
cycle's), present only when some row is one; in CSV it is the text column ``source`` (``test_cycle`` or
``production``; optional on read, absent or empty: ``test_cycle``), which :func:`write_csv` writes back.
A table's cycles are then (``production``, ``cycle``) pairs: shift 3 and test cycle 3 are two cycles.

Both readers refuse physically impossible values (:func:`check_physical`): a
negative speed (the model is for the speed magnitude), a negative
``tau_f_std``, a temperature below absolute zero.

>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "obs.csv").write_text("speed,tau_f,temperature\n10,0.0750,40\n47,0.0728,40\n")
>>> t = read_table(d / "obs.csv")
>>> len(t), t.names, float(t["tau_f"][1])
(2, ['speed', 'tau_f', 'temperature'], 0.0728)
>>> _ = (d / "bad.csv").write_text("speed,tau_f,load_torque\n10,0.0750,nan\n")
>>> read_table(d / "bad.csv")
Traceback (most recent call last):
...
jointwear_ros.errors.InputDataError: ...bad.csv: column 'load_torque', row 1 (line 2): 'nan' is not a finite number; fill in the value or leave the column out
"""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from ..contract import seconds_to_stamp_fields, stamp_to_seconds
from ..errors import InputDataError
from ..types import OBSERVATION_COLUMNS, ObservationTable
from ..units import SUITE_UNITS, TableUnits, convert_temperature
from .typestore import jointwear_typestore

__all__ = [
    "ABSOLUTE_ZERO",
    "DEFAULT_OBSERVATION_TOPIC",
    "FRICTION_OBSERVATION_TYPE",
    "PRODUCTION_COLUMN",
    "check_physical",
    "read_bag",
    "read_csv",
    "read_table",
    "read_text_file",
    "write_bag",
    "write_csv",
    "write_table",
]

Array = npt.NDArray[np.float64]

FRICTION_OBSERVATION_TYPE = "jointwear_msgs/msg/FrictionObservation"
DEFAULT_OBSERVATION_TOPIC = "/jointwear/friction_observations"

_REQUIRED = ("speed", "tau_f")
#: 0 K in degC.
ABSOLUTE_ZERO = -273.15


def check_physical(cols: dict[str, Array], src: str, locate: Any = None, units: TableUnits | None = None) -> None:
    """Refuse values no measurement can have; ``locate(i)`` names row ``i`` (0-based) in the source.

    A negative ``speed`` (the model and FrictionObservation hold the speed
    magnitude), a negative ``tau_f_std``, a ``temperature`` below absolute zero.
    NaN passes here (the CSV reader refuses it, a bag's NaN means unknown).

    >>> import numpy as np
    >>> check_physical({"speed": np.array([10.0, -5.0])}, "obs.csv")
    Traceback (most recent call last):
    ...
    jointwear_ros.errors.InputDataError: obs.csv: column 'speed', row 2: -5 is negative; give the speed magnitude (motor side, rad/s)
    """
    where = locate if locate is not None else (lambda i: f"row {i + 1}")
    rules = (
        ("speed", lambda v: v < 0, "is negative; give the speed magnitude (motor side, rad/s)"),
        ("tau_f_std", lambda v: v < 0, "is negative; a standard error is >= 0"),
        ("temperature", lambda v: v < ABSOLUTE_ZERO, f"degC is below absolute zero ({ABSOLUTE_ZERO} degC)"),
    )
    for name, bad_if, what in rules:
        if name not in cols:
            continue
        values = np.asarray(cols[name], dtype=float)
        if name == "temperature" and units is not None:
            values = convert_temperature(values, units.temperature_unit)
        with np.errstate(invalid="ignore"):
            bad = np.flatnonzero(bad_if(values))
        if bad.size:
            i = int(bad[0])
            raise InputDataError(f"{src}: column {name!r}, {where(i)}: {float(cols[name][i]):g} {what}")


def _is_bag(path: Path) -> bool:
    return (path.is_dir() and (path / "metadata.yaml").is_file()) or path.suffix in (".mcap", ".db3")


def read_table(path: str | os.PathLike[str], topic: str | None = None) -> ObservationTable:
    """Read a CSV file or a rosbag2 bag (directory, or its ``.mcap`` file) into a table."""
    p = Path(path)
    if not p.exists():
        raise InputDataError(f"{p}: no such file or directory")
    if _is_bag(p):
        return read_bag(p, topic=topic)
    if p.is_dir():
        raise InputDataError(f"{p}: a directory without metadata.yaml is not a rosbag2 bag; give a CSV file or a bag")
    return read_csv(p)


def _parse_cell(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def read_text_file(path: str | os.PathLike[str]) -> str:
    """A CSV file's text (UTF-8, a BOM dropped); every failure is one :class:`InputDataError` line."""
    src = str(path)
    try:
        return Path(path).read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputDataError(f"{src}: no such file") from None
    except IsADirectoryError:
        raise InputDataError(f"{src}: is a directory without metadata.yaml; give a CSV file or a rosbag2 bag") from None
    except UnicodeDecodeError as exc:
        raise InputDataError(f"{src}: not a UTF-8 text file ({exc.reason} at byte {exc.start}); give a CSV file") from None
    except OSError as exc:
        raise InputDataError(f"{src}: cannot read ({exc.strerror})") from None


def read_csv(path: str | os.PathLike[str]) -> ObservationTable:
    """Read an observation table from CSV (see the module docstring for the rules)."""
    p = Path(path)
    src = str(p)
    raw = read_text_file(p)
    if not raw.strip():
        raise InputDataError(f"{src}: the file is empty; expected a header line with at least speed,tau_f and data rows")
    lines = list(csv.reader(io.StringIO(raw)))
    header: list[str] | None = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    units = None
    for lineno, fields in enumerate(lines, start=1):
        if not fields or all(not f.strip() for f in fields):
            continue
        if header is None:
            if fields[0].lstrip().startswith("#"):
                try:
                    declared = TableUnits.parse_header(",".join(fields))
                except InputDataError as exc:
                    raise InputDataError(f"{src}: line {lineno}: {exc}") from None
                units = declared or units
                continue
            header = [f.strip() for f in fields]
            header_line = lineno
            continue
        rows.append((lineno, [f.strip() for f in fields]))
    if header is None:
        raise InputDataError(f"{src}: no header line; expected column names such as speed,tau_f")
    for i, name in enumerate(header):
        if not name:
            raise InputDataError(f"{src}: line {header_line}: column {i + 1} of the header has no name")
        if header.count(name) > 1:
            raise InputDataError(f"{src}: line {header_line}: column {name!r} appears twice in the header")
    for req in _REQUIRED:
        if req not in header:
            raise InputDataError(
                f"{src}: column {req!r} is missing (required); columns in the header: {', '.join(header)}"
            )
    if not rows:
        raise InputDataError(f"{src}: no data rows after the header (line {header_line})")
    for r, (lineno, fields) in enumerate(rows, start=1):
        if len(fields) != len(header):
            raise InputDataError(
                f"{src}: row {r} (line {lineno}) has {len(fields)} fields, the header has {len(header)}"
            )
    cols: dict[str, Array] = {}
    for j, name in enumerate(header):
        if name == "source":  # test_cycle / production (text): the production column when some row is one
            prod = _production_cells([fields[j] for _, fields in rows], src, [ln for ln, _ in rows])
            if prod.any():
                cols[PRODUCTION_COLUMN] = prod
            continue
        values = [_parse_cell(fields[j]) for _, fields in rows]
        if name not in OBSERVATION_COLUMNS and all(v is None for v in values) and any(f[j] for _, f in rows):
            continue  # a text column (joint name, note): not data for the model
        for r, ((lineno, fields), v) in enumerate(zip(rows, values), start=1):
            cell = fields[j]
            if v is None:
                what = "is empty" if not cell else f"{cell!r} is not a number"
                raise InputDataError(f"{src}: column {name!r}, row {r} (line {lineno}): {what}")
            if not math.isfinite(v):
                raise InputDataError(
                    f"{src}: column {name!r}, row {r} (line {lineno}): {cell!r} is not a finite number; "
                    "fill in the value or leave the column out"
                )
        cols[name] = np.asarray(values, dtype=float)
    check_physical(cols, src, lambda i: f"row {i + 1} (line {rows[i][0]})", units=units)
    return ObservationTable(cols, source=src, units=units)


#: the numeric column that marks a production shift's observation (1.0; 0.0 a test cycle's)
PRODUCTION_COLUMN = "production"


def _production_cells(cells: Sequence[str], src: str, lines: Sequence[int]) -> Array:
    """A CSV ``source`` column as the ``production`` column (1.0 production, 0.0 test_cycle or empty)."""
    out = np.zeros(len(cells), dtype=float)
    for r, (cell, lineno) in enumerate(zip(cells, lines), start=1):
        v = cell.strip().lower()
        if v == "production":
            out[r - 1] = 1.0
        elif v not in ("", "test_cycle"):
            raise InputDataError(f"{src}: column 'source', row {r} (line {lineno}): {cell!r} is neither "
                                 "'test_cycle' nor 'production' (or leave it empty)")
    return out


def production_of(source: object) -> float:
    """A message's ``source`` as the ``production`` column's value (absent or empty: a test cycle's, 0.0)."""
    return 1.0 if str(source or "") == "production" else 0.0


def _bag_dir(p: Path) -> Path:
    if p.is_dir():
        return p
    if (p.parent / "metadata.yaml").is_file():
        return p.parent
    return p


def read_bag(path: str | os.PathLike[str], topic: str | None = None) -> ObservationTable:
    """Read ``jointwear_msgs/msg/FrictionObservation`` messages of a rosbag2 bag into a table.

    ``topic`` restricts to one topic (default: every topic of that type).
    Columns: the message's fields, ``cycle`` (cycle_id) and ``time`` (header
    stamp, s). ``speed`` and ``tau_f`` must be finite; NaN in another field
    means unknown (a field NaN in every message is left out); infinity is an
    error.
    """
    from rosbags.highlevel import AnyReader

    p = Path(path)
    src = str(p)
    store = jointwear_typestore()
    fields = ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position")
    data: dict[str, list[float]] = {k: [] for k in ("cycle", "time", *fields, PRODUCTION_COLUMN)}
    try:
        with AnyReader([_bag_dir(p)], default_typestore=store) as reader:
            conns = [c for c in reader.connections if c.msgtype == FRICTION_OBSERVATION_TYPE
                     and (topic is None or c.topic == topic)]
            if not conns:
                present = ", ".join(sorted(f"{c.topic} ({c.msgtype})" for c in reader.connections)) or "none"
                want = f"on topic {topic!r} " if topic else ""
                raise InputDataError(
                    f"{src}: no {FRICTION_OBSERVATION_TYPE} messages {want}in the bag; topics: {present}"
                )
            for i, (conn, _t, raw) in enumerate(reader.messages(connections=conns), start=1):
                msg: Any = reader.deserialize(raw, conn.msgtype)
                data["cycle"].append(float(msg.cycle_id))
                data["time"].append(stamp_to_seconds(msg.header))
                data[PRODUCTION_COLUMN].append(production_of(getattr(msg, "source", "")))
                for f in fields:
                    val = float(getattr(msg, f))
                    if (f in _REQUIRED and not math.isfinite(val)) or math.isinf(val):
                        raise InputDataError(
                            f"{src}: column {f!r}, row {i} (message {i} on {conn.topic}): {val!r} is not finite"
                        )
                    data[f].append(val)
    except InputDataError:
        raise
    except Exception as exc:
        raise InputDataError(f"{src}: cannot read the bag ({type(exc).__name__}: {exc})") from None
    if not data["speed"]:
        raise InputDataError(f"{src}: the bag holds no {FRICTION_OBSERVATION_TYPE} messages")
    cols = {k: np.asarray(v, dtype=float) for k, v in data.items()}
    # a field that is NaN in every message was not measured: leave the column out
    cols = {k: v for k, v in cols.items() if k in _REQUIRED or not np.all(np.isnan(v))}
    if not cols[PRODUCTION_COLUMN].any():  # only test cycles: the table as it always was
        del cols[PRODUCTION_COLUMN]
    check_physical(cols, src, lambda i: f"row {i + 1} (message {i + 1})")
    return ObservationTable(cols, source=src, units=SUITE_UNITS)


def _fmt(v: float) -> str:
    return repr(float(v))


def write_csv(table: ObservationTable, path: str | os.PathLike[str], *,
              text_columns: Mapping[str, Sequence[str]] | None = None) -> Path:
    """Write ``table`` as CSV, atomically (a temporary file, then rename).

    ``text_columns`` (name -> one string per row, e.g. ``joint``) are written
    after the numeric columns; :func:`read_csv` skips them again. The ``production`` column is written as the
    text column ``source`` (``test_cycle``/``production``), which :func:`read_csv` reads back.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    texts = dict(text_columns or {})
    if PRODUCTION_COLUMN in table:
        texts["source"] = ["production" if v else "test_cycle" for v in table[PRODUCTION_COLUMN]]
        table = ObservationTable({k: v for k, v in table.columns.items() if k != PRODUCTION_COLUMN},
                                 source=table.source, units=table.units)
    for name, vals in texts.items():
        if len(vals) != len(table) or name in table:
            raise InputDataError(f"text column {name!r}: {len(vals)} values for {len(table)} rows, or a numeric "
                                 "column of that name exists")
    names = table.names
    fd, tmp = tempfile.mkstemp(prefix=p.name + ".", suffix=".tmp", dir=p.parent)
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            if table.units is not None:
                fh.write(table.units.header() + "\n")
            w = csv.writer(fh)
            w.writerow(names + list(texts))
            cols = [table[n] for n in names]
            tcols = list(texts.values())
            for i in range(len(table)):
                w.writerow([_fmt(c[i]) for c in cols] + [str(c[i]) for c in tcols])
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return p


def write_bag(
    table: ObservationTable,
    path: str | os.PathLike[str],
    *,
    topic: str = DEFAULT_OBSERVATION_TOPIC,
    joint_name: str = "joint",
) -> Path:
    """Write ``table`` as a rosbag2 MCAP bag (a directory) of FrictionObservation messages.

    Only the message's fields are kept (extra columns such as ``lube_hours``
    need CSV). The bag is built under a temporary name and renamed.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    p = Path(path)
    if p.exists():
        raise InputDataError(f"{p}: already exists; give a new bag directory name or delete it")
    store = jointwear_typestore()
    Msg: Any = store.types[FRICTION_OBSERVATION_TYPE]
    Header: Any = store.types["std_msgs/msg/Header"]
    Time: Any = store.types["builtin_interfaces/msg/Time"]
    n = len(table)
    col = {k: table.get(k, math.nan) for k in
           ("speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position")}
    cyc = table.get("cycle", 0.0)
    prod = table.get(PRODUCTION_COLUMN, 0.0)
    tim = table["time"] if "time" in table else np.arange(n, dtype=float)
    src = table.source or "observations"
    for name, values in (("speed", col["speed"]), ("tau_f", col["tau_f"]), ("time", tim)):
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise InputDataError(f"{src}: column {name!r}, row {int(bad[0]) + 1}: {float(values[bad[0]])!r} is not finite; "
                                 "a FrictionObservation needs a finite value")
    bad = np.flatnonzero(~((cyc >= 0) & (cyc < 2**32) & (cyc == np.round(cyc))))
    if bad.size:
        raise InputDataError(f"{src}: column 'cycle', row {int(bad[0]) + 1}: {float(cyc[bad[0]])!r} is not a cycle id "
                             "(an integer 0 .. 4294967295, the message's uint32 cycle_id)")
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=p.name + ".", dir=p.parent)) / "bag"
    try:
        with Writer(tmp, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            conn = writer.add_connection(topic, FRICTION_OBSERVATION_TYPE, typestore=store)
            for i in range(n):
                sec, nsec = seconds_to_stamp_fields(float(tim[i]))
                msg = Msg(
                    header=Header(stamp=Time(sec=sec, nanosec=nsec), frame_id=""),
                    joint_name=joint_name,
                    cycle_id=int(cyc[i]) if math.isfinite(cyc[i]) else 0,
                    samples_plus=0,
                    samples_minus=0,
                    source="production" if prod[i] else "test_cycle",
                    **{k: float(v[i]) for k, v in col.items()},
                )
                writer.write(conn, sec * 1_000_000_000 + nsec, store.serialize_cdr(msg, FRICTION_OBSERVATION_TYPE))
        os.replace(tmp, p)
    finally:
        shutil.rmtree(tmp.parent, ignore_errors=True)
    return p


def write_table(table: ObservationTable, path: str | os.PathLike[str], **kwargs: Any) -> Path:
    """CSV when ``path`` ends in ``.csv``, else a rosbag2 MCAP bag directory."""
    if str(path).lower().endswith(".csv"):
        return write_csv(table, path)
    return write_bag(table, path, **kwargs)


