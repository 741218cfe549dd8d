"""Estimates for the history store from bags (recorded or re-estimated) and CSV tables; CSV export.

Every reader parses its whole input before anything is written, and raises
:class:`~jointwear_ros.errors.InputDataError` with a one-line message naming
the file, the line and what is wrong.

CSV tables: columns ``robot, joint, time, wear, wear_std`` (``time`` ISO 8601,
naive = UTC, or seconds since the epoch), optional ``cycle_id``,
``temperature``, ``method``, ``params``, ``hardware_id``, ``bag``, ``evidence`` (``complete`` or ``partial``),
``time_ns`` (takes precedence over ``time``: what :func:`write_csv` writes, so
an export imports back to the very same entries).
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import InputDataError
from .store import LIVE, EstimateRecord

__all__ = ["CSV_COLUMNS", "estimates_from_bag", "estimates_from_csv", "parse_time", "reestimate_bag", "write_csv"]

REQUIRED = ("robot", "joint", "time", "wear", "wear_std")
CSV_COLUMNS = ("robot", "joint", "time", "time_ns", "cycle_id", "wear", "wear_std", "temperature", "method",
               "params", "hardware_id", "software_version", "bag", "analysis_version", "source", "evidence",
               "cycle_source")


def parse_time(text: str, where: str = "time") -> float:
    """ISO 8601 (naive = UTC) or seconds since the epoch -> seconds since the epoch.

    >>> parse_time("2026-11-23T02:00:00Z"), parse_time("1700000000.5")
    (1795399200.0, 1700000000.5)
    """
    s = str(text).strip()
    if not s:
        raise InputDataError(f"{where}: empty time; give ISO 8601 (2026-11-23T02:00:00Z) or seconds since the epoch")
    try:
        v = float(s)
    except ValueError:
        pass
    else:
        if not (math.isfinite(v) and -1e9 < v < 1e11):
            raise InputDataError(f"{where}: time {s!r} is not seconds since the epoch")
        return v
    try:
        d = datetime.fromisoformat(s.replace("Z", "+00:00"))
    except ValueError:
        raise InputDataError(f"{where}: time {s!r} is neither ISO 8601 (2026-11-23T02:00:00Z) "
                             "nor seconds since the epoch") from None
    if d.tzinfo is None:
        d = d.replace(tzinfo=UTC)
    return d.timestamp()


def _float(row: dict[str, str], key: str, where: str, default: float | None = None) -> float:
    text = (row.get(key) or "").strip()
    if not text:
        if default is not None:
            return default
        raise InputDataError(f"{where}: column {key!r} is empty")
    try:
        return float(text)
    except ValueError:
        raise InputDataError(f"{where}: {key} = {text!r} is not a number") from None


def _evidence(text: str | None, where: str) -> str:
    """An optional ``evidence`` cell: ``complete`` (the default) or ``partial`` (docs/levels.md)."""
    v = (text or "").strip().lower() or "complete"
    if v not in ("complete", "partial"):
        raise InputDataError(f"{where}: evidence = {text!r}: use complete or partial (or leave it empty)")
    return v


def _cycle_source(text: str | None, where: str) -> str:
    """An optional ``cycle_source`` cell: ``test_cycle`` (the default: a table from before the column) or
    ``production`` (:class:`jointwear_ros.contract.Source`)."""
    from ..contract import source_of

    try:
        return source_of((text or "").strip().lower())
    except InputDataError as exc:
        raise InputDataError(f"{where}: cycle_source: {exc} (or leave it empty)") from None


def estimates_from_csv(path: str | os.PathLike[str], *, robot: str | None = None) -> list[EstimateRecord]:
    """The estimates of a CSV table (see the module docstring); ``robot`` fills an absent robot column."""
    p = Path(path)
    if not p.is_file():
        raise InputDataError(f"{p}: no such file")
    try:
        with p.open(newline="", encoding="utf-8") as fh:
            reader = csv.DictReader(fh)
            cols = [c.strip() for c in (reader.fieldnames or [])]
            reader.fieldnames = cols
            need = [c for c in REQUIRED if c not in cols and not (c == "robot" and robot)
                    and not (c == "time" and "time_ns" in cols)]
            if need:
                raise InputDataError(f"{p}: missing column(s) {', '.join(need)}; a history CSV needs "
                                     f"{', '.join(REQUIRED)} (columns present: {', '.join(cols) or 'none'})")
            out = []
            for i, row in enumerate(reader, start=2):
                where = f"{p}:{i}"
                tns = (row.get("time_ns") or "").strip()
                if tns:
                    try:
                        t = int(tns) * 1e-9
                    except ValueError:
                        raise InputDataError(f"{where}: time_ns = {tns!r} is not an integer") from None
                else:
                    t = parse_time(row.get("time") or "", where)
                cid = _float(row, "cycle_id", where, 0.0)
                if not math.isfinite(cid) or cid != int(cid):
                    raise InputDataError(f"{where}: cycle_id = {row.get('cycle_id')!r} is not an integer")
                rec = EstimateRecord(
                    robot=(row.get("robot") or "").strip() or (robot or ""),
                    joint=(row.get("joint") or "").strip(),
                    cycle_id=int(cid), time=t,
                    wear=_float(row, "wear", where), wear_std=_float(row, "wear_std", where),
                    temperature=_float(row, "temperature", where, math.nan),
                    method=(row.get("method") or "").strip(), params=(row.get("params") or "").strip(),
                    hardware_id=(row.get("hardware_id") or "").strip(),
                    software_version=(row.get("software_version") or "").strip() or "",
                    bag=(row.get("bag") or "").strip(),
                    analysis_version=(row.get("analysis_version") or "").strip() or LIVE,
                    source="csv", evidence=_evidence(row.get("evidence"), where),
                    cycle_source=_cycle_source(row.get("cycle_source"), where),
                )
                out.append(rec.check(where))
    except UnicodeDecodeError:
        raise InputDataError(f"{p}: not a UTF-8 text CSV file") from None
    except csv.Error as exc:
        raise InputDataError(f"{p}: malformed CSV ({exc})") from None
    return out


def estimates_from_bag(path: str | os.PathLike[str], *, robot: str, params: str = "",
                       hardware_id: str = "") -> list[EstimateRecord]:
    """The WearEstimate messages recorded in a bag (the cell's live estimates), as history entries.

    The time is the message's header stamp (its log time when the stamp is 0), so the same estimate
    stored live by ``wear_trend`` and imported from the bag is one entry.
    """
    from ..contract import stamp_to_seconds
    from ..io.bags import ESTIMATE_TYPE, read_messages
    from ..io.params import recorded_node_params

    p = Path(path)
    out: list[EstimateRecord] = []
    events: list[Any] = []
    for m in read_messages(p, msgtypes=[ESTIMATE_TYPE, "rcl_interfaces/msg/ParameterEvent"]):
        if m.msgtype != ESTIMATE_TYPE:
            events.append(m.msg)
            continue
        t = stamp_to_seconds(m.msg.header)
        if t <= 0:
            t = m.log_time * 1e-9
        joint = str(m.msg.joint_name)
        out.append(EstimateRecord(
            robot=robot, joint=joint, cycle_id=int(m.msg.cycle_id), time=t, wear=float(m.msg.wear),
            wear_std=float(m.msg.wear_std), hardware_id=hardware_id or f"{robot}/{joint}",
            temperature=float(m.msg.temperature_estimate), method=str(m.msg.method), params=params,
            software_version="", bag=p.name, analysis_version=LIVE, source="bag", received=m.log_time * 1e-9,
            evidence=str(getattr(m.msg, "evidence", "") or "complete"),  # a bag from before the field: complete
            cycle_source=_cycle_source(getattr(m.msg, "source", ""), f"{p}: WearEstimate"),  # before: test_cycle
        ).check(f"{p}: WearEstimate at log time {m.log_time} ns"))
    if out and not params:
        recorded = recorded_node_params(events, "wear_estimator").get("params")
        if recorded:
            out = [EstimateRecord(**{**r.__dict__, "params": str(recorded)}) for r in out]
    return out


def reestimate_bag(path: str | os.PathLike[str], *, robot: str, observer_params: dict[str, Any],
                   monitor_params: dict[str, Any], method: str | None = None, params: str | None = None,
                   analysis_version: str | None = None, hardware_id: str = "") -> tuple[list[EstimateRecord], str]:
    """Re-run the observer and the estimator on a bag with today's model (``replay.replay_bag``).

    A bag of a robot cycle gives one entry per joint and cycle (every joint the live observer
    served, each with its own settings and hardware id ``<joint>.hardware_id`` when recorded).
    Returns the estimates (every result, revisions too; the trend keeps the newest per cycle) and the
    analysis version they are stored under (default ``METHOD:PARAMS:SOFTWARE_VERSION``).
    """
    from ..replay import replay_bag

    overrides: dict[str, Any] = {}
    if method:
        overrides["method"] = method
    if params:
        overrides["params"] = params
    res = replay_bag(path, observer_params, monitor_params, overrides=overrides or None)
    if not res.settings_recorded:
        missing = [f"--{k}" for k in ("params", "method") if res.settings.get(f"{k}_from") != "given"]
        raise InputDataError(f"{path}: the bag does not hold the wear estimator's recorded settings; give "
                             f"{' and '.join(missing)} to re-estimate it with those (nothing is guessed)")
    used_method = str(res.monitor_params.get("method", method or ""))
    used_params = str(res.monitor_params.get("params", params or ""))
    version = analysis_version or f"{used_method}:{used_params}:{__version__}"
    p = Path(path)
    out = []
    for c in res.cycles:
        if c.result is None:
            continue
        out.append(EstimateRecord(
            robot=robot, joint=c.joint_name, cycle_id=int(c.cycle_id), time=float(c.stamp),
            wear=float(c.result.wear), wear_std=float(c.result.wear_std),
            hardware_id=(hardware_id or str(res.monitor_params.get(f"{c.joint_name}.hardware_id", "") or "")
                         or f"{robot}/{c.joint_name}"), temperature=float(c.result.temperature),
            method=str(c.result.method), params=used_params, software_version=__version__, bag=p.name,
            analysis_version=version, source="bag", evidence=c.evidence, cycle_source=c.source,
        ).check(f"{p}: re-estimated cycle {c.cycle_id}"))
    return out, version


def write_csv(records: Iterable[EstimateRecord], path: str | os.PathLike[str]) -> int:
    """Write estimates as CSV (:data:`CSV_COLUMNS`; ``time`` ISO 8601 UTC, ``time_ns`` exact); return rows.

    The rows go to ``<path>.part`` first, which replaces ``path`` when complete: a reader never sees half a
    table, and a write that fails midway (a full disk, a bad record, ``path`` a directory) removes the
    ``.part`` and leaves ``path`` as it was.
    """
    p = Path(path)
    rows = list(records)
    p.parent.mkdir(parents=True, exist_ok=True)
    tmp = p.with_name(p.name + ".part")
    try:
        with tmp.open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(CSV_COLUMNS)
            for r in rows:
                iso = datetime.fromtimestamp(r.time_ns // 1_000_000_000, UTC).strftime("%Y-%m-%dT%H:%M:%S")
                iso += f".{(r.time_ns % 1_000_000_000) // 1000:06d}Z"
                w.writerow([r.robot, r.joint, iso, r.time_ns, r.cycle_id, repr(float(r.wear)),
                            repr(float(r.wear_std)), "" if math.isnan(r.temperature) else repr(float(r.temperature)),
                            r.method, r.params, r.hardware_id, r.software_version, r.bag, r.analysis_version,
                            r.source, r.evidence, r.cycle_source])
        tmp.replace(p)
    except BaseException:  # a failure (or Ctrl-C) midway: no .part left behind, the old table untouched
        tmp.unlink(missing_ok=True)
        raise
    return len(rows)
