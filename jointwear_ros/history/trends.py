"""The trend of every joint in a history store (store query + screening + the pure trend core)."""

from __future__ import annotations

import time as _time
from typing import Any

from ..trend import TrendConfig, TrendResult, analyze_joint
from .screen import ScreenConfig, screen
from .store import LIVE, EstimateRecord, HistoryStore, MaintenanceEvent

__all__ = ["screened_history", "trends_from_store"]

History = dict[tuple[str, str], tuple[list[EstimateRecord], list[MaintenanceEvent]]]


def screened_history(store: HistoryStore, analysis_version: str = LIVE, *, robot: str | None = None,
                     joint: str | None = None, now: float | None = None,
                     cfg: ScreenConfig | None = None) -> tuple[History, list[dict[str, Any]]]:
    """The history the trend may use, and every refused estimate with its reason.

    The stored estimates passed the screening when they were written; they are screened again against
    ``now`` (a row written by another tool straight into the database, or by a version without the
    screening, must not reach the trend either). Refused: the ``refused`` table's rows and those refused
    here (``"source": "read"``), oldest first per joint. A maintenance event after ``now`` (plus the
    tolerance) is ignored and reported: it would hide every estimate before it.
    """
    now = _time.time() if now is None else float(now)
    cfg = cfg or ScreenConfig()
    hist = store.history(analysis_version, robot=robot, joint=joint)
    refused = list(store.refused(robot=robot, joint=joint, analysis_version=analysis_version))
    out: History = {}
    for key, (recs, events) in hist.items():
        ok, bad = screen(recs, now=now, cfg=cfg)
        for f in bad:
            d = f.as_dict()
            refused.append({**d, "analysis_version": analysis_version, "source": "read"})
        evs = [e for e in events if e.time <= now + cfg.future_tolerance_s]
        for e in events:
            if e not in evs:
                refused.append({"robot": e.robot, "joint": e.joint, "analysis_version": analysis_version,
                                "time": e.time, "kind": e.kind, "source": "maintenance",
                                "reason": "time_in_future",
                                "detail": f"maintenance event {e.kind!r} in the future: ignored"})
        if ok:
            out[key] = (ok, evs)
    refused.sort(key=lambda d: (str(d["robot"]), str(d["joint"])))
    return out, refused


def trends_from_store(store: HistoryStore, cfg: TrendConfig | None = None, *, robot: str | None = None,
                      joint: str | None = None, analysis_version: str = LIVE,
                      smooth: bool = False, now: float | None = None) -> list[TrendResult]:
    """One :class:`~jointwear_ros.trend.TrendResult` per (robot, joint) with screened estimates, sorted by name."""
    out = []
    hist, _refused = screened_history(store, analysis_version, robot=robot, joint=joint, now=now)
    for (rb, jt), (recs, events) in sorted(hist.items()):
        out.append(analyze_joint(
            [r.time for r in recs], [r.wear for r in recs], [r.wear_std for r in recs],
            cycle_ids=[r.cycle_id for r in recs], maintenance_times=[e.time for e in events],
            cfg=cfg, robot=rb, joint=jt, smooth=smooth,
        ))
    return out
