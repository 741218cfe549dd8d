"""The trend of every joint in a history store (store query + screening + the pure trend core), optionally
with the fleet as a prior (joints of the same type: same parameter set and joint name)."""

from __future__ import annotations

import time as _time
from collections.abc import Mapping, Sequence
from typing import Any

from ..trend import DAY, RatePrior, TrendConfig, TrendResult, analyze_joint, current_segment, pool_prior, sibling_fit
from .screen import ScreenConfig, screen
from .store import LIVE, EstimateRecord, HistoryStore, MaintenanceEvent

__all__ = ["FLEET_MIN_JOINTS", "fleet_priors", "joint_type", "screened_history", "trends_from_store"]

#: siblings a joint type needs before its fleet prior is used
FLEET_MIN_JOINTS = 5

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


def joint_type(key: tuple[str, str], recs: Sequence[Any]) -> tuple[str, str]:
    """A joint's type for the fleet prior: (the parameter set of its newest estimate, the joint name)."""
    return (str(getattr(recs[-1], "params", "") or "") if recs else "", key[1])


def fleet_priors(hist: Mapping[tuple[str, str], tuple[Sequence[Any], Sequence[Any]]], cfg: TrendConfig | None = None,
                 min_joints: int = FLEET_MIN_JOINTS) -> dict[tuple[str, str], RatePrior | None]:
    """Per (robot, joint) of ``hist`` (``HistoryStore.history``): the empirical-Bayes prior from the *other*
    joints of its type (leave-one-out), else from the other joints of its parameter set; None when neither has
    ``min_joints`` siblings with a trend."""
    cfg = cfg or TrendConfig()
    fits = {}
    for key, (recs, events) in hist.items():
        t, w, s, *_ = current_segment([r.time for r in recs], [r.wear for r in recs], [r.wear_std for r in recs],
                                      [r.cycle_id for r in recs], [e.time for e in events], cfg, f"{key[0]}/{key[1]}")
        fits[key] = sibling_fit((t - t[0]) / DAY if len(t) else t, w, s, cfg)
    types = {key: joint_type(key, recs) for key, (recs, _) in hist.items()}
    out: dict[tuple[str, str], RatePrior | None] = {}
    for key in hist:
        jt = types[key]
        prior = None
        for level, n_key in (("type", 2), ("parameter set", 1)):
            sibs = [fits[k] for k in hist if k != key and types[k][:n_key] == jt[:n_key]]
            label = f"{level} {jt[0] or '(none)'}" + (f"/{jt[1]}" if level == "type" else "")
            prior = pool_prior(sibs, cfg, min_joints=min_joints, source=f"fleet: {label}")
            if prior is not None:
                break
        out[key] = prior
    return out


def trends_from_store(store: HistoryStore, cfg: TrendConfig | None = None, *, robot: str | None = None,
                      joint: str | None = None, analysis_version: str = LIVE,
                      smooth: bool = False, fleet_prior: bool = False, now: float | None = None) -> list[TrendResult]:
    """One :class:`~jointwear_ros.trend.TrendResult` per (robot, joint) with screened estimates, sorted by name.

    ``fleet_prior``: each joint's prior from its siblings in the store (:func:`fleet_priors`; all joints of the
    version are siblings, whatever ``robot`` / ``joint`` select; screened too)."""
    hist, _refused = screened_history(store, analysis_version, robot=robot, joint=joint, now=now)
    priors = fleet_priors(screened_history(store, analysis_version, now=now)[0], cfg) if fleet_prior else {}
    out = []
    for (rb, jt), (recs, events) in sorted(hist.items()):
        out.append(analyze_joint(
            [r.time for r in recs], [r.wear for r in recs], [r.wear_std for r in recs],
            cycle_ids=[r.cycle_id for r in recs], maintenance_times=[e.time for e in events],
            cfg=cfg, robot=rb, joint=jt, smooth=smooth, prior=priors.get((rb, jt)),
            evidence=[r.evidence for r in recs], sources=[r.cycle_source for r in recs],
        ))
    return out
