"""``jointwear fleet``: re-analyse a fleet's bags on Dask, compare analysis versions, write the fleet page.

- ``fleet reprocess BAG_GLOB... --db URL [--params SET] [--method M] [--label NAME] [--scheduler ADDRESS]
  [--workers N] [--json]``: every bag through the same cores as ``jointwear replay``, on a Dask
  LocalCluster (or an existing scheduler), into the history as a new analysis version; idempotent and
  resumable; a broken bag is reported and skipped.
- ``fleet compare --db URL --from V --to V [--json]``: the joints whose level or time to alarm changed.
- ``fleet report --db URL --out DIR [--version V] [--from V --to V]``: a static HTML page.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

from ..estimation.names import ESTIMATOR_NAMES
from . import UsageError
from .common import format_table, open_history, parse_float, print_json, trend_command

__all__ = ["register"]

#: robots named one per line at the end of ``fleet reprocess`` (all of them in --json)
MAX_ROBOT_LINES = 10


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("fleet", help="a fleet's wear history: re-analyse bags on Dask, compare versions, a page",
                       description="Re-analyse a fleet's recorded bags on Dask into the wear history, compare "
                                   "two analysis versions, write the fleet page.")
    fsub = p.add_subparsers(dest="fleet_command", metavar="SUBCOMMAND", parser_class=type(p))
    fsub.required = True

    r = fsub.add_parser("reprocess", help="replay every bag with a parameter set and method into the history",
                        description="Replay every bag through the friction observer and wear monitor cores (as "
                                    "`jointwear replay`) on dask.distributed, and write the estimates to the "
                                    "history as a new analysis version. Bags already done with the same analysis "
                                    "version are skipped; a broken bag is reported in `failed`, never fatal.")
    r.add_argument("bags", nargs="+", metavar="BAG_GLOB",
                   help="bag directories, globs (quote them: 'bags/**/jointwear_*'), or directories of bags")
    r.add_argument("--db", required=True, help="history URL: sqlite:///path, postgresql://user@host/db, or a path")
    r.add_argument("--params", default=None, metavar="SET",
                   help="friction-model parameter set (name or YAML path); default: each bag's recorded one "
                        "(a bag without recorded settings is refused unless --params and --method are given)")
    r.add_argument("--method", default=None, help=f"estimator ({', '.join(ESTIMATOR_NAMES)}); default: recorded")
    r.add_argument("--robot", default=None,
                   help="robot of every bag's estimates (as `history import --robot`); default: the robot the "
                        "cell recorded (wear_trend's `robot`, the estimator's `robot` or `hardware_id`), else the "
                        "name of the directory holding the bag")
    r.add_argument("--label", default=None, help="name the analysis version (default: <params>/<method>/<hash of "
                                                 "the set's content, the method and the software version>)")
    r.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="an existing Dask scheduler (tcp://host:8786); default: a LocalCluster of --workers")
    r.add_argument("--workers", default="2", metavar="N", help="worker processes of a Dask LocalCluster (default 2); 1 without --scheduler: the bags "
                        "one after another in this process, no cluster")
    r.add_argument("--json", action="store_true",
                   help='print JSON {"bags", "estimates", "skipped", "failed": [{"bag", "error"}], '
                        '"analysis_version", "seconds", ...}')
    r.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
    r.set_defaults(func=cmd_reprocess)

    c = fsub.add_parser("compare", help="joints whose level or time to alarm changed between two analysis versions")
    c.add_argument("--db", required=True, help="history URL")
    c.add_argument("--from", dest="v_from", required=True, metavar="VERSION", help="analysis version before")
    c.add_argument("--to", dest="v_to", required=True, metavar="VERSION", help="analysis version after")
    c.add_argument("--wear-tol", default="1.0", help="a wear change above this counts (default 1.0)")
    c.add_argument("--days-tol", default="7", help="a time-to-alarm change above this many days (and 10 %%) "
                                                  "counts (default 7)")
    c.add_argument("--all", action="store_true", help="list unchanged joints too")
    c.add_argument("--json", action="store_true", help='print JSON {"from", "to", "joints", "changed": [...]}')
    c.set_defaults(func=cmd_compare)

    o = fsub.add_parser("report", help="write the fleet page (static HTML with PNG plots)")
    o.add_argument("--db", required=True, help="history URL")
    o.add_argument("--out", required=True, metavar="DIR", help="output directory (index.html, img/)")
    o.add_argument("--version", default=None, help="analysis version ranked and plotted (default: the newest)")
    o.add_argument("--from", dest="v_from", default=None, metavar="VERSION",
                   help="changes section: version before (default: the second newest)")
    o.add_argument("--to", dest="v_to", default=None, metavar="VERSION",
                   help="changes section: version after (default: the newest)")
    o.set_defaults(func=cmd_report)


def _open_store(url: str, *, must_exist: bool) -> Any:
    return open_history(url, must_exist=must_exist)


def _workers(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise UsageError(f"--workers: {text!r} is not a whole number") from None
    if not 1 <= n <= 1024:
        raise UsageError(f"--workers: {n} must be between 1 and 1024")
    return n


def cmd_reprocess(args: argparse.Namespace) -> int:
    from ..estimation import ESTIMATORS
    from ..fleet import Progress, analysis_version, reprocess
    from ..io.bags import discover_bags

    workers = _workers(args.workers)
    if args.method is not None:
        if args.method.strip().lower() not in ESTIMATORS:
            raise UsageError(f"--method: unknown method {args.method!r}; choose one of {', '.join(ESTIMATORS)}")
        args.method = args.method.strip().lower()
    version = analysis_version(args.params, args.method, label=args.label)  # a bad set or label: exit 2 first
    if args.robot is not None and not args.robot.strip():
        raise UsageError("--robot: empty robot name")
    selection = discover_bags(args.bags)  # a missing bag or a glob that matches nothing: exit 2, nothing written
    if not selection.bags:
        raise UsageError(f"{' '.join(args.bags)}: no bag among the matched paths ("
                         + "; ".join(f"{s['path']}: {s['reason']}" for s in selection.skipped[:3]) + ")")
    robot = args.robot.strip() if args.robot else None
    store = _open_store(args.db, must_exist=False)
    try:
        # with --robot, the bags this version already did must be stored under that robot (reads the version's
        # estimates: only when a name is given, the one case where a rerun could mean a rename)
        before = _already_stored(store, version, selection.bags) if robot is not None else {}
        moved = sorted(r for r in before if r != robot)
        if moved:
            n = sum(len(before[r]) for r in moved)
            raise UsageError(
                f"--robot {robot}: {n} of these bags were already re-analysed into analysis version {version} under "
                f"robot {', '.join(moved)}, and a rerun of the same version skips them (the store keeps what it "
                f"wrote; nothing is renamed): to store them under {robot}, give a new --label or another --db")
        bar = Progress(len(selection.bags), enabled=not args.quiet)
        rep = reprocess(selection.bags, store, params=args.params, method=args.method, label=args.label,
                        scheduler=args.scheduler, workers=workers, progress=bar, robot=robot)
        stored = _where_stored(store, rep, before, args.db, all_robots=robot is None and rep.skipped > 0)
    finally:
        store.close()
    rep.not_bags = selection.skipped
    folder = _robots_from_folders(rep.settings)
    if args.json:
        print_json({**rep.as_dict(), "db": args.db, "stored": stored, "robot_from_folder": folder,
                    "skipped_stored_under": {r: len(b) for r, b in sorted(before.items())}})
        return 0
    rate = f", {rep.processed / rep.seconds:.2f} bags/s" if rep.seconds > 0 and rep.processed else ""
    print(f"analysis version {rep.analysis_version}: {rep.bags} bags, {rep.processed} replayed, {rep.skipped} "
          f"skipped (already done), {len(rep.failed)} failed; {rep.estimates} new estimates in the history "
          f"({rep.seconds:.1f} s{rate})")
    if rep.settings:
        print(format_table(["bag", "robot", "method", "params", "other settings"],
                           [[Path(b["bag"]).name, f"{b['robot']} ({b['robot_from']})",
                             f"{b['method']} ({b['method_from']})", f"{b['params']} ({b['params_from']})",
                             "recorded" if b.get("estimator") == "recorded" else "config files (method and "
                             "params given)"] for b in rep.settings]))
    for f in rep.failed:
        print(f"failed: {f['error']}")
    for s_ in rep.not_bags:
        print(f"not a bag, skipped: {s_['path']}: {s_['reason']}")
    if before:
        print("the skipped bags' estimates are already stored under robot "
              + ", ".join(f"{r} ({len(b)} bag(s))" for r, b in sorted(before.items())))
    elif rep.skipped:
        print(f"the skipped bags were done before: their estimates are in analysis version {rep.analysis_version} "
              "(below)")
    for f_ in folder:
        print(f"robot name '{f_['robot']}' taken from folder {f_['folder']} (its bags record no robot); use --robot "
              "to set it")
    for g in stored[:MAX_ROBOT_LINES]:
        print(f"stored in {g['db']}: robot {g['robot']}, joint(s) {', '.join(g['joints'])}, analysis version "
              f"{g['analysis_version']}")
        print(f"  see them: {g['see']}")
    if len(stored) > MAX_ROBOT_LINES:
        print(f"... and {len(stored) - MAX_ROBOT_LINES} more robots (--json lists them): "
              + shlex.join(["jointwear", "trend", "--db", args.db, "--analysis-version", rep.analysis_version])
              + " shows them all")
    return 0


def _already_stored(store: Any, version: str, bags: list[Path]) -> dict[str, set[str]]:
    """robot -> the bags of ``bags`` that ``version`` has already done (the fleet ledger) whose estimates are
    stored under that robot (matched by the bag's path, as the estimates name it)."""
    from ..fleet import bag_fingerprint
    from ..fleet.ledger import LEDGER_SCHEMA_VERSION, done_fingerprints

    if store.schema_version() < LEDGER_SCHEMA_VERSION:
        return {}  # no ledger yet: nothing done
    done = done_fingerprints(store, version)
    paths = set()
    for b in bags:
        try:
            if bag_fingerprint(b) in done:
                paths.add(str(Path(b).resolve()))
        except OSError:
            continue  # the re-analysis reports it
    out: dict[str, set[str]] = {}
    if paths:
        for r in store.estimates(analysis_version=version):
            if r.bag in paths:
                out.setdefault(r.robot, set()).add(r.bag)
    return out


def _where_stored(store: Any, rep: Any, before: dict[str, set[str]], db: str, *,
                  all_robots: bool = False) -> list[dict[str, Any]]:
    """Per robot this run wrote to (or found done, ``before``; ``all_robots``: every robot of the version, where
    the skipped bags' estimates are): its joints in the analysis version and the ``jointwear trend`` command that
    shows them. One DISTINCT query, whatever the size of the version."""
    by_robot: dict[str, list[str]] = {}
    for r, j in store.joints(rep.analysis_version):
        by_robot.setdefault(r, []).append(j)
    robots = {str(s_["robot"]) for s_ in rep.settings} | set(before) | (set(by_robot) if all_robots else set())
    return [{"robot": robot, "joints": sorted(by_robot[robot]), "analysis_version": rep.analysis_version, "db": db,
             "see": trend_command(db, robot, rep.analysis_version)}
            for robot in sorted(robots) if robot in by_robot]


def _robots_from_folders(settings: list[dict[str, str]]) -> list[dict[str, Any]]:
    """The robot names taken from a bag's folder name (no robot recorded, none given), one entry per folder."""
    out: dict[tuple[str, str], int] = {}
    for s_ in settings:
        if s_.get("robot_from") == "folder":
            key = (str(s_["robot"]), str(Path(s_["bag"]).parent))
            out[key] = out.get(key, 0) + 1
    return [{"robot": r, "folder": f, "bags": n} for (r, f), n in sorted(out.items())]


def cmd_compare(args: argparse.Namespace) -> int:
    from ..fleet.compare import compare_versions

    wear_tol = parse_float(args.wear_tol, "--wear-tol")
    days_tol = parse_float(args.days_tol, "--days-tol")
    if wear_tol < 0 or days_tol < 0:
        raise UsageError("--wear-tol and --days-tol must be >= 0")
    store = _open_store(args.db, must_exist=True)
    try:
        changes = compare_versions(store, args.v_from, args.v_to, wear_tol=wear_tol, days_tol=days_tol)
    finally:
        store.close()
    shown = changes if args.all else [c for c in changes if c.changed]
    if args.json:
        print_json({"from": args.v_from, "to": args.v_to, "joints": len(changes),
                    "changed": [c.as_dict() for c in changes if c.changed],
                    **({"unchanged": [c.as_dict() for c in changes if not c.changed]} if args.all else {})})
        return 0
    print(f"{sum(c.changed for c in changes)} of {len(changes)} joints changed from {args.v_from} to {args.v_to}")
    if shown:
        rows = [[c.robot, c.joint, f"{c.level_from or '-'} -> {c.level_to or '-'}",
                 _num(c.wear_from), _num(c.wear_to), _num(c.wear_change, "+.1f"),
                 _num(c.days_from, ".0f"), _num(c.days_to, ".0f"), _num(c.days_change, "+.0f"),
                 "; ".join(c.reasons) or "-"] for c in shown]
        print(format_table(["robot", "joint", "level", "wear", "-> wear", "change", "days", "-> days",
                            "change", "why"], rows))
    return 0


def _num(x: float | None, spec: str = ".1f") -> str:
    if x is None:
        return "-"
    return "inf" if x == float("inf") else format(x, spec)


def cmd_report(args: argparse.Namespace) -> int:
    from ..fleet.report import write_report

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: exists and is not a directory")
    store = _open_store(args.db, must_exist=True)
    try:
        index = write_report(store, out, version=args.version, from_version=args.v_from, to_version=args.v_to)
    finally:
        store.close()
    print(f"fleet page: {index}", file=sys.stdout)
    return 0
