"""The trend of every joint in a history store (store query + the pure trend core)."""

from __future__ import annotations

from ..trend import TrendConfig, TrendResult, analyze_joint
from .store import LIVE, HistoryStore

__all__ = ["trends_from_store"]


def trends_from_store(store: HistoryStore, cfg: TrendConfig | None = None, *, robot: str | None = None,
                      joint: str | None = None, analysis_version: str = LIVE,
                      smooth: bool = False) -> list[TrendResult]:
    """One :class:`~jointwear_ros.trend.TrendResult` per (robot, joint) with estimates, sorted by name."""
    out = []
    for (rb, jt), (recs, events) in sorted(store.history(analysis_version, robot=robot, joint=joint).items()):
        out.append(analyze_joint(
            [r.time for r in recs], [r.wear for r in recs], [r.wear_std for r in recs],
            cycle_ids=[r.cycle_id for r in recs], maintenance_times=[e.time for e in events],
            cfg=cfg, robot=rb, joint=jt, smooth=smooth,
        ))
    return out
