"""The trend of every joint in a history store (store query + the pure trend core), optionally with the
fleet as a prior (joints of the same type: same parameter set and joint name)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..trend import DAY, RatePrior, TrendConfig, TrendResult, analyze_joint, current_segment, pool_prior, sibling_fit
from .store import LIVE, HistoryStore

__all__ = ["FLEET_MIN_JOINTS", "fleet_priors", "joint_type", "trends_from_store"]

#: siblings a joint type needs before its fleet prior is used
FLEET_MIN_JOINTS = 5

History = Mapping[tuple[str, str], tuple[Sequence[Any], Sequence[Any]]]


def joint_type(key: tuple[str, str], recs: Sequence[Any]) -> tuple[str, str]:
    """A joint's type for the fleet prior: (the parameter set of its newest estimate, the joint name)."""
    return (str(getattr(recs[-1], "params", "") or "") if recs else "", key[1])


def fleet_priors(hist: History, cfg: TrendConfig | None = None,
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
                      smooth: bool = False, fleet_prior: bool = False) -> list[TrendResult]:
    """One :class:`~jointwear_ros.trend.TrendResult` per (robot, joint) with estimates, sorted by name.

    ``fleet_prior``: each joint's prior from its siblings in the store (:func:`fleet_priors`; all joints of the
    version are siblings, whatever ``robot`` / ``joint`` select)."""
    hist = store.history(analysis_version, robot=robot, joint=joint)
    priors = fleet_priors(store.history(analysis_version), cfg) if fleet_prior else {}
    out = []
    for (rb, jt), (recs, events) in sorted(hist.items()):
        out.append(analyze_joint(
            [r.time for r in recs], [r.wear for r in recs], [r.wear_std for r in recs],
            cycle_ids=[r.cycle_id for r in recs], maintenance_times=[e.time for e in events],
            cfg=cfg, robot=rb, joint=jt, smooth=smooth, prior=priors.get((rb, jt)),
        ))
    return out
