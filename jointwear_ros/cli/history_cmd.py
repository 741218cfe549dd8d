"""``jointwear history import|export|maintenance``: the wear history store from the command line.

``--db`` takes a URL (``sqlite:///path``, ``postgresql://user@host/db``) or a
path (an SQLite file). Imports are idempotent: the same bag or table imported
twice adds nothing. Every input file is read and checked before anything is
written. An import ends with where it stored (robot, joints, analysis version,
store) and the ``jointwear trend`` command that shows them (``--json``: ``stored``).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from . import UsageError
from .common import add_unit_flags, print_json, trend_command, units_from_args

__all__ = ["MAINTENANCE_KINDS", "register"]

#: what ``history maintenance --kind`` takes: each starts a new trend segment
MAINTENANCE_KINDS = ("regrease", "reducer_replaced", "motor_replaced", "joint_replaced", "other")

#: the robot of bag estimates and of CSV rows without one when ``history import`` is given no ``--robot``
DEFAULT_ROBOT = "robot_1"



def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("history", help="the wear history store: import bags/CSV, export CSV, maintenance events")
    hsub = p.add_subparsers(dest="history_command", metavar="ACTION", parser_class=type(p))
    hsub.required = True

    i = hsub.add_parser("import", help="add estimates from bags (WearEstimate messages) or CSV tables",
                        description="Add the estimates of rosbag2 bags (the recorded WearEstimate messages, or "
                                    "with --reestimate a replay of the observer and estimator with today's model) "
                                    "and CSV tables (robot, joint, time, wear, wear_std) to the history. "
                                    "Importing the same data twice adds nothing.")
    i.add_argument("files", nargs="+", metavar="FILE",
                   help="bag directories and/or .csv files (estimates; with --reestimate also observation tables, "
                        "as jointwear estimate takes them)")
    i.add_argument("--db", required=True, help="history store URL or SQLite file path")
    i.add_argument("--robot", default=None,
                   help=f"robot of bag estimates and of CSV rows without one (default {DEFAULT_ROBOT}, said so)")
    i.add_argument("--reestimate", action="store_true",
                   help="bags: re-run observer and estimator (replay) instead of importing the recorded estimates")
    i.add_argument("--method", default=None, help="with --reestimate: estimator method")
    i.add_argument("--params", default=None, help="with --reestimate: parameter set")
    i.add_argument("--analysis-version", default=None,
                   help="with --reestimate: version the estimates are stored under (default METHOD:PARAMS:VERSION)")
    i.add_argument("--time-origin", default=None,
                   help="observation tables whose time column counts from the start of the recording (not s since "
                        "the epoch): when time 0 was, ISO 8601 or s since the epoch")
    add_unit_flags(i)
    i.add_argument("--json", action="store_true", help="print JSON")
    i.set_defaults(func=cmd_import)

    e = hsub.add_parser("export", help="write the stored estimates as CSV")
    e.add_argument("--db", required=True, help="history store URL or SQLite file path")
    e.add_argument("--out", required=True, help="CSV file to write")
    e.add_argument("--robot", default=None)
    e.add_argument("--joint", default=None)
    e.add_argument("--analysis-version", default=None, help="only this analysis version (default: all)")
    e.set_defaults(func=cmd_export)

    m = hsub.add_parser("maintenance", help="record a maintenance event (starts a new trend segment)")
    m.add_argument("--db", required=True, help="history store URL or SQLite file path")
    m.add_argument("--robot", required=True)
    m.add_argument("--joint", required=True)
    m.add_argument("--kind", required=True, help=f"what was done: {', '.join(MAINTENANCE_KINDS)}")
    m.add_argument("--time", default=None, help="ISO 8601 or seconds since the epoch (default: now)")
    m.add_argument("--note", default="")
    m.add_argument("--new-joint", action="store_true",
                   help="the joint has no estimates in the history yet (else a joint it does not know is refused)")
    m.set_defaults(func=cmd_maintenance)


def _is_csv(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() == ".csv"


def _is_observation_table(path: Path) -> bool:
    """A CSV of friction observations (``speed`` and ``tau_f`` columns), not of estimates."""
    import csv

    with path.open(newline="", encoding="utf-8", errors="replace") as fh:
        body = (line for line in fh if line.strip() and not line.lstrip().startswith("#"))
        header = {h.strip() for h in next(csv.reader(body), [])}
    return {"speed", "tau_f"} <= header


def _reestimate_table(path: Path, args: argparse.Namespace) -> tuple[list[Any], str]:
    """Observation tables (as ``jointwear estimate`` takes them) estimated with --params / --method."""
    from .. import __version__
    from ..commission import estimate_cycles
    from ..history.importers import parse_time
    from ..history.screen import ScreenConfig
    from ..history.store import EstimateRecord
    from ..io.observations import read_observations
    from ..model import load_parameter_set_info
    from ..units import prepare_for_set

    pset = load_parameter_set_info(args.params or "ref-2011r")
    method = args.method or "joint"
    version = args.analysis_version or f"{method}:{pset.name}:{__version__}"
    default_joint = str(pset.provenance.get("joint", "")) or "joint_1"
    assumed, explicit = units_from_args(args)
    tau_range = pset.friction_range()
    # each table to the suite's units, checked against the set as `jointwear estimate` checks it: a unit slip or a
    # joint hotter than the set's range is one line, exit 2, and nothing is stored
    tables = [(str(path), j or default_joint,
               prepare_for_set(t, pset, assumed, explicit=explicit, where=t.source or str(path), tau_range=tau_range))
              for j, t in read_observations(path, default_joint).items()]
    origin = 0.0 if args.time_origin is None else parse_time(args.time_origin, "--time-origin")
    cycles = estimate_cycles(tables, pset, method)
    out = []
    for c in cycles:
        if not math.isfinite(c.time):
            raise UsageError(f"{path}: an observation table needs a 'time' column (s since the epoch) for the history")
    first = min((c.time for c in cycles), default=math.nan)
    if args.time_origin is None and first < ScreenConfig().min_time:
        raise UsageError(f"{path}: its time column starts at {first:.0f} s, not a time since the epoch (before "
                         "2010): give --time-origin, when its time 0 was (ISO 8601, e.g. 2026-03-01T06:00:00Z)")
    few = [c for c in cycles if c.evidence == "insufficient"]
    if few:  # fewer distinct speeds than a wear level needs (jointwear_ros.condition): not an estimate to store
        print(f"{path}: {len(few)} cycle(s) with too few speeds for a wear level not stored (cycle "
              + ", ".join(f"{c.joint}/{c.cycle}" for c in few[:5]) + (", ..." if len(few) > 5 else "") + ")",
              file=sys.stderr)
    for c in cycles:
        if c.evidence == "insufficient":
            continue
        out.append(EstimateRecord(
            robot=args.robot, joint=c.joint, cycle_id=c.cycle, time=c.time + origin, wear=float(c.result.wear),
            wear_std=float(c.result.wear_std), hardware_id=f"{args.robot}/{c.joint}",
            temperature=float(c.result.temperature), method=c.result.method, params=pset.name,
            software_version=__version__, bag=path.name, analysis_version=version, source="table",
            cycle_source=c.cycle_source,
        ).check(f"{path}: cycle {c.cycle} of {c.joint}"))
    return out, version


def cmd_import(args: argparse.Namespace) -> int:
    from ..errors import InputDataError
    from ..history import HistoryStore
    from ..history.importers import estimates_from_bag, estimates_from_csv, reestimate_bag
    from ..io.bags import discover_bags
    from .common import check_method, node_params

    if not args.reestimate and (args.method or args.params or args.analysis_version or args.time_origin):
        raise UsageError("--method, --params, --analysis-version and --time-origin need --reestimate")
    if not args.reestimate and units_from_args(args)[1]:
        raise UsageError("--joint-side, --gear-ratio, --torque-scale and the unit flags are for observation tables: "
                         "they need --reestimate")
    # every input is checked before any work: the method, the parameter set, every path
    check_method(args.method, "--method")
    if args.params:
        from ..model import load_parameter_set_info

        load_parameter_set_info(args.params)
    robot_given = args.robot is not None
    if robot_given and not args.robot.strip():
        raise UsageError("--robot: empty robot name")
    args.robot = args.robot.strip() if robot_given else DEFAULT_ROBOT
    selection = discover_bags(args.files, accept=_is_csv)
    observer = node_params(None, "friction_observer.yaml", "friction_observer") if args.reestimate else {}
    monitor = node_params(None, "wear_estimator.yaml", "wear_estimator") if args.reestimate else {}
    records = []
    per_file = []
    failed = []
    versions = set()
    for path in selection.bags:
        try:
            if _is_csv(path) and args.reestimate and _is_observation_table(path):
                recs, version = _reestimate_table(path, args)
                versions.add(version)
            elif _is_csv(path):
                recs = estimates_from_csv(path, robot=args.robot)
            elif args.reestimate:
                recs, version = reestimate_bag(path, robot=args.robot, observer_params=observer,
                                               monitor_params=monitor, method=args.method, params=args.params,
                                               analysis_version=args.analysis_version)
                versions.add(version)
            else:
                recs = estimates_from_bag(path, robot=args.robot)
        except InputDataError as exc:  # one bad bag is reported, the others are imported (a bad table: exit 2)
            if _is_csv(path):
                raise
            failed.append({"file": str(path), "error": str(exc)})
            continue
        per_file.append({"file": str(path), "estimates": len(recs)})
        records.extend(recs)
    if not per_file:
        raise UsageError("nothing to import: " + "; ".join([f["error"] for f in failed[:3]]
                                                           + [f"{k['path']}: {k['reason']}" for k in selection.skipped[:3]])
                         + ("" if len(failed) <= 3 else f"; and {len(failed) - 3} more"))
    with HistoryStore(args.db) as store:  # everything was read and checked: now write, in one transaction
        total_before = store.count()
        res = store.write_estimates(records)
    added = res.added
    total = total_before + added
    refused = [f.as_dict() for f in res.refused]
    stored = where_stored(records, res.refused, args.db, default_robot=None if robot_given else DEFAULT_ROBOT)
    out = {"files": per_file, "read": len(records), "added": added, "duplicates": res.duplicates,
           "refused": refused, "total": total, "analysis_versions": sorted(versions), "failed": failed,
           "not_bags": selection.skipped, "db": args.db, "stored": stored}
    if args.json:
        print_json(out)
    else:
        print(f"read {len(records)} estimates from {len(per_file)} file(s): {added} added, "
              f"{res.duplicates} already in the history, {len(refused)} refused; {total} stored"
              + (f"; {len(failed)} file(s) FAILED, not imported:" if failed else ""))
        for f in failed:
            print(f"failed: {f['error']}")
        for s_ in selection.skipped:
            print(f"not a bag, skipped: {s_['path']}: {s_['reason']}")
        for f in refused:
            src = f"{f['source']} {f['bag']}".strip()
            print(f"refused {f['robot']}/{f['joint']} cycle {f['cycle_id']} ({src}): {f['reason']}: {f['detail']}")
        for line in where_stored_lines(stored):
            print(line)
    return 0


def where_stored(records: list[Any], refused: list[Any], db: str, *,
                 default_robot: str | None = None) -> list[dict[str, Any]]:
    """Where the accepted estimates of an import are: per (analysis version, robot) its joints, how many, and the
    ``jointwear trend`` command that shows them; ``robot_from`` says "default" for ``default_robot`` (no --robot
    given), else "given or in the table"."""
    bad = {(f.record.robot, f.record.joint, f.record.analysis_version, f.record.cycle_id, f.record.time_ns)
           for f in refused if getattr(f, "record", None) is not None}
    groups: dict[tuple[str, str], dict[str, Any]] = {}
    for r in records:
        if (r.robot, r.joint, r.analysis_version, r.cycle_id, r.time_ns) in bad:
            continue
        g = groups.setdefault((r.analysis_version, r.robot), {"joints": set(), "estimates": 0})
        g["joints"].add(r.joint)
        g["estimates"] += 1
    return [{"robot": robot, "joints": sorted(g["joints"]), "analysis_version": version, "estimates": g["estimates"],
             "db": db, "robot_from": "default" if robot == default_robot else "given or in the table",
             "see": trend_command(db, robot, version)}
            for (version, robot), g in sorted(groups.items())]


def where_stored_lines(stored: list[dict[str, Any]]) -> list[str]:
    """The text of :func:`where_stored`: where each group is, and the command that shows it."""
    out = []
    for g in stored:
        who = (f"robot {g['robot']} (the default name: give --robot to set it)" if g["robot_from"] == "default"
               else f"robot {g['robot']}")
        out.append(f"stored in {g['db']}: {who}, joint(s) {', '.join(g['joints'])}, analysis version "
                   f"{g['analysis_version']}: {g['estimates']} estimate(s) (new or already there)")
        out.append(f"  see them: {g['see']}")
    return out


def cmd_export(args: argparse.Namespace) -> int:
    from ..history import HistoryStore, backend_for
    from ..history.importers import write_csv
    from .common import check_output_file

    backend = backend_for(args.db)
    if not backend.exists():
        raise UsageError(f"--db {args.db}: no such history file")
    check_output_file(args.out, "--out")  # a directory or an unwritable place: one line, nothing written
    with HistoryStore(backend.url, read_only=True) as store:
        recs = store.estimates(robot=args.robot, joint=args.joint, analysis_version=args.analysis_version)
    try:
        n = write_csv(recs, args.out)
    except OSError as exc:  # write_csv removed its .part; the table at --out is as it was
        raise UsageError(f"--out {args.out}: cannot write the CSV ({exc.strerror or type(exc).__name__}); "
                         "nothing written") from None
    print(f"{n} estimates written to {args.out}")
    return 0


def cmd_maintenance(args: argparse.Namespace) -> int:
    import time

    from ..history import MaintenanceEvent
    from ..history.importers import parse_time
    from .common import open_history

    t = time.time() if args.time is None else parse_time(args.time, "--time")
    with open_history(args.db, must_exist=True) as store:  # a bad URL or a missing file first: nothing to record in
        if args.kind not in MAINTENANCE_KINDS:
            raise UsageError(f"--kind {args.kind}: unknown maintenance kind; choose one of "
                             f"{', '.join(MAINTENANCE_KINDS)}")
        # a time in the future and a robot or joint without estimates are refused by the store (every writer)
        new = store.add_maintenance(MaintenanceEvent(args.robot, args.joint, t, args.kind, args.note),
                                    new_joint=args.new_joint)
    print(f"{args.kind} of {args.robot}/{args.joint} at {t:.3f} " + ("recorded" if new else "was already recorded"))
    return 0
