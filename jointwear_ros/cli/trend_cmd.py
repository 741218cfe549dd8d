"""``jointwear trend --db DB``: per joint, current wear and rate, time to the alarm (median, 90 %), level.

JSON (``--json``): ``{"joints": [{"robot", "joint", "estimates", "wear",
"wear_std", "rate_per_day", "time_to_alarm_days": {"median", "lo90", "hi90"}
or null, "level", "trend_level", "newest_time", "age_days", ...}]}``, times in days from the joint's last estimate (a
bound beyond the prediction horizon is null; ``time_to_alarm_days`` also holds
``model_weights`` and ``unbounded_reason``). ``level`` is the plant's level
(:func:`jointwear_ros.condition.plant_level`, as ``jointwear serve`` shows it): the
trend's OK / WARN / ERROR, or STALE when the newest estimate is older than
``--stale-days`` and the trend's level is not ERROR; ``trend_level`` is the trend's own.
The top level also has ``analysis_version`` (the one shown), ``analysis_version_why`` and
``analysis_versions`` (``[{"name", "estimates"}]``, every version in the store; :func:`pick_version` says
which is shown without ``--analysis-version``); the text says the same under the table.
``--fleet-prior``: each joint's prior from its siblings (off by default). ``--plot DIR`` writes one PNG
per joint, ``--html DIR`` a page ranking the joints by time to alarm.
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path
from typing import Any

from . import UsageError
from .common import format_table, parse_float, print_json

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("trend", help="wear trend and time to alarm of every joint in the history",
                       description="Per joint (current segment, after the last maintenance): current wear and "
                                   "rate, the time until the trend reaches the alarm as a median and 90 % "
                                   "interval, and the level (OK / WARN / ERROR, STALE when silent).")
    p.add_argument("--db", required=True, help="history store URL or SQLite file path")
    p.add_argument("--robot", default=None, help="only this robot")
    p.add_argument("--joint", default=None, help="only this joint")
    p.add_argument("--analysis-version", default=None,
                   help="which estimates (default: live, the cell's own, when the store has them; else the only "
                        "version there; the versions present are listed either way)")
    p.add_argument("--horizon", default="30", help="WARN horizon in days (default 30)")
    p.add_argument("--alarm", default="35", help="alarm wear level (default 35)")
    p.add_argument("--fleet-prior", action="store_true",
                   help="each joint's prior from its siblings in the store (same parameter set and joint name, "
                        "at least 5; off by default)")
    p.add_argument("--stale-days", default="7", help="STALE when the newest estimate is older (default 7)")
    p.add_argument("--json", action="store_true", help="print JSON")
    p.add_argument("--plot", default=None, metavar="DIR", help="write one PNG per joint into DIR")
    p.add_argument("--html", default=None, metavar="DIR", help="write DIR/index.html ranking the joints (and PNGs)")
    p.set_defaults(func=cmd_trend)


def pick_version(given: str | None, present: dict[str, int]) -> tuple[str, str]:
    """The analysis version ``trend`` shows and why: the one given; else ``live`` (the cell's own estimates)
    when the store has it, or when it is empty; else the only version there. Several versions and no live
    ones: one line naming them, exit 2 (which one is the user's choice, not a guess).

    >>> pick_version(None, {"live": 3, "v2": 5}), pick_version(None, {"v2": 5})[0], pick_version("v2", {})[1]
    (('live', 'the default: the estimates the cell made'), 'v2', 'given with --analysis-version')
    """
    from ..history import LIVE

    if given is not None:
        return given, "given with --analysis-version"
    if LIVE in present or not present:
        return LIVE, "the default: the estimates the cell made"
    if len(present) == 1:
        (only,) = present
        return only, "the only analysis version in the store (it has no live estimates)"
    raise UsageError("the store has no live estimates but several analysis versions: "
                     + ", ".join(f"{v} ({n})" for v, n in present.items())
                     + "; choose one with --analysis-version V")


def versions_line(shown: str, why: str, present: dict[str, int]) -> str:
    """One line: the analysis version shown and why, and every version in the store with its count."""
    others = [f"{v} ({n} estimates)" for v, n in present.items() if v != shown]
    n = present.get(shown, 0)
    return (f"analysis version {shown} ({n} estimates; {why})"
            + (f"; also in the store: {', '.join(others)}: --analysis-version V shows one" if others else ""))


#: how the table names the sources (the JSON and the history use the full names)
_SHORT = {"test_cycle": "test", "production": "prod"}


def _sources(recs: Any) -> Any:
    """The newest estimate's source and the per-source summaries of a joint's records."""
    from ..serve.core import source_summary

    return source_summary([x.time for x in recs], [x.wear for x in recs], [x.wear_std for x in recs],
                          [x.cycle_source for x in recs])


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def cmd_trend(args: argparse.Namespace) -> int:
    import time

    from ..history import HistoryStore, screened_history
    from ..serve.core import calibrated_of, joint_view
    from ..trend import TrendConfig, analyze_joint
    from ..trend.report import plot_trend, rank_key, write_html

    horizon = parse_float(args.horizon, "--horizon")
    alarm = parse_float(args.alarm, "--alarm")
    stale = parse_float(args.stale_days, "--stale-days")
    if stale <= 0:
        raise UsageError(f"--stale-days {stale:g} must be > 0 days")
    if horizon < 0 or not 0 < alarm <= 100:
        raise UsageError(f"--horizon {horizon:g} must be >= 0 days and --alarm {alarm:g} in (0, 100]")
    cfg = TrendConfig(alarm=alarm, horizon_days=horizon)
    from ..history import backend_for

    backend = backend_for(args.db)
    if not backend.exists():
        raise UsageError(f"--db {args.db}: no such history file (fill it with jointwear history import or wear_trend)")
    priors = {}
    with HistoryStore(backend.url, read_only=True) as store:
        present = {v: store.count(v) for v in store.analysis_versions()}
        args.analysis_version, why = pick_version(args.analysis_version, present)
        hist, refused = screened_history(store, args.analysis_version, robot=args.robot, joint=args.joint)
        if args.fleet_prior:
            from ..history.trends import fleet_priors

            # every joint of the version is a sibling, whatever --robot / --joint select (screened too)
            priors = fleet_priors(screened_history(store, args.analysis_version)[0], cfg)
    if not hist and (args.robot or args.joint):
        raise UsageError(f"no estimates of robot {args.robot or '*'} joint {args.joint or '*'} "
                         f"(analysis version {args.analysis_version!r}) in {args.db}")
    results = []
    raw = {}
    draw = args.plot is not None or args.html is not None
    for key, (recs, events) in sorted(hist.items()):
        r = analyze_joint([x.time for x in recs], [x.wear for x in recs], [x.wear_std for x in recs],
                          cycle_ids=[x.cycle_id for x in recs], maintenance_times=[e.time for e in events],
                          cfg=cfg, robot=key[0], joint=key[1], smooth=draw, prior=priors.get(key),
                          evidence=[x.evidence for x in recs], sources=[x.cycle_source for x in recs])
        results.append(r)
        raw[key] = (recs, events)
    now = time.time()
    views = {(r.robot, r.joint): joint_view(r, max(x.time for x in raw[(r.robot, r.joint)][0]), now, stale)
             for r in results}
    images: dict[tuple[str, str], str] = {}
    for out_dir in [d for d in (args.plot, args.html) if d is not None]:
        for r in results:
            recs, events = raw[(r.robot, r.joint)]
            name = f"trend_{_safe(r.robot)}_{_safe(r.joint)}.png"
            plot_trend(Path(out_dir) / name, r, cfg, [x.time for x in recs], [x.wear for x in recs],
                       [x.wear_std for x in recs], [e.time for e in events], sources=[x.cycle_source for x in recs])
            if out_dir == args.html:
                images[(r.robot, r.joint)] = name
    if args.html is not None:
        write_html(Path(args.html), results, images)
    n_refused: dict[tuple[str, str], int] = {}
    for f in refused:
        n_refused[(f["robot"], f["joint"])] = n_refused.get((f["robot"], f["joint"]), 0) + 1
    if args.json:
        rows_json = []
        for r in results:
            v = views[(r.robot, r.joint)]
            newest = max(raw[(r.robot, r.joint)][0], key=lambda x: x.time)
            _, per_source = _sources(raw[(r.robot, r.joint)][0])
            rows_json.append({**r.as_dict(), "level": v.level_name, "trend_level": r.level_name,
                              "newest_time": v.time, "age_days": v.age_days,
                              "refused": n_refused.get((r.robot, r.joint), 0),
                              "parameter_set": newest.params or None,
                              "wear_scale_calibrated": calibrated_of(newest.params),
                              "newest_source": newest.cycle_source,
                              "sources": {name: s.as_api() for name, s in per_source}})
        print_json({"joints": rows_json, "refused": refused, "analysis_version": args.analysis_version,
                    "analysis_version_why": why,
                    "analysis_versions": [{"name": v, "estimates": n} for v, n in present.items()]})
        return 0
    if not results:
        print(f"no estimates in {args.db}" + (f" ({len(refused)} refused)" if refused else "")
              + ": fill it with jointwear history import FILE... --db DB, or run the wear_trend node on it")

    from ..trend.report import time_to_alarm_text

    rows = []
    for r in sorted(results, key=rank_key):
        fin = math.isfinite(r.wear)
        newest_source, per_source = _sources(raw[(r.robot, r.joint)][0])
        rows.append([r.robot, r.joint, views[(r.robot, r.joint)].level_name, r.estimates,
                     f"{r.wear:.1f} ± {r.wear_std:.1f}" if fin else "-",
                     f"{r.rate_per_day:+.3f}" if math.isfinite(r.rate_per_day) else "-",
                     time_to_alarm_text(r, "-"), newest_source,
                     " ".join(f"{_SHORT.get(name, name)} {s.estimates}" for name, s in per_source)])
    if rows:
        print(format_table(["robot", "joint", "level", "n", "wear", "rate/day", "days to alarm (90 %)", "newest from",
                            "estimates by source"], rows))
    print(versions_line(args.analysis_version, why, present))
    for f in refused:
        what = (f"maintenance {f.get('kind')} at {f.get('time')}" if f.get("source") == "maintenance"
                else f"cycle {f.get('cycle_id')} wear {f.get('wear')} std {f.get('wear_std')} time {f.get('time')}")
        print(f"refused {f['robot']}/{f['joint']} {what}: {f['reason']}: {f['detail']}")
    if args.html is not None:
        print(f"page: {Path(args.html) / 'index.html'}")
    return 0
