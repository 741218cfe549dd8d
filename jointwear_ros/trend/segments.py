"""Segments and revisions of a joint's estimates (pure numpy).

**Segments.** A maintenance event (regrease, reducer replaced) starts a new segment: the trend uses the
estimates after the joint's last event. **Revisions.** A wear_estimator may re-estimate a cycle (same cycle
id, later stamp); estimates of the same cycle id within ``revision_window_s`` are one cycle and the newest is
kept.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import InputDataError
from .config import Array, TrendConfig

__all__ = ["collapse_revisions", "current_segment", "last_segment", "revision_keys"]


def revision_keys(cycle_ids: Any, sources: Any = None) -> npt.NDArray[np.int64]:
    """The cycle ids :func:`collapse_revisions` tells apart, with each estimate's source: a test cycle keeps its
    id, a production shift ``s`` becomes ``-s`` (0 stays 0, never collapsed), so a production shift and a test
    cycle of the same id are never taken for revisions of each other. ``sources`` None: all test cycles.

    >>> revision_keys([3, 3, 0], ["test_cycle", "production", "production"]).tolist()
    [3, -3, 0]
    """
    c = np.asarray(cycle_ids, dtype=np.int64).reshape(-1)
    if sources is None:
        return c
    prod = np.asarray([str(s) == "production" for s in sources], dtype=bool)
    if prod.size != c.size:
        raise InputDataError(f"sources has {prod.size} entries for {c.size} cycle ids")
    return np.where(prod, -c, c)


def collapse_revisions(times: Array, cycle_ids: Array, window_s: float) -> Array:
    """Indices to keep (time order): of estimates with one cycle id within ``window_s``, the newest.

    >>> collapse_revisions(np.array([0.0, 5.0, 100.0, 90000.0]), np.array([1, 1, 2, 1]), 3600.0).tolist()
    [1, 2, 3]
    """
    t = np.asarray(times, float)
    c = np.asarray(cycle_ids)
    order = np.argsort(t, kind="stable")
    keep: list[int] = []
    last_of_cycle: dict[Any, int] = {}  # cycle id -> position in keep
    for i in order:
        key = c[i].item() if hasattr(c[i], "item") else c[i]
        pos = last_of_cycle.get(key)
        if pos is not None and t[i] - t[keep[pos]] <= window_s and key != 0:
            keep[pos] = int(i)  # a revision replaces the earlier result of its cycle
            continue
        last_of_cycle[key] = len(keep)
        keep.append(int(i))
    return np.array(sorted(keep, key=lambda j: t[j]), dtype=int)


def last_segment(times: Array, maintenance_times: Sequence[float]) -> tuple[int, float, int]:
    """(first index of the current segment, its start time, number of segments) for times ascending.

    The current segment starts at the last maintenance event; an event after the last estimate gives
    an empty current segment (the old trend no longer applies).

    >>> last_segment(np.arange(10.0), [4.5]), last_segment(np.arange(10.0), [20.0])
    ((5, 4.5, 2), (10, 20.0, 2))
    """
    t = np.asarray(times, float)
    ev = sorted(float(x) for x in maintenance_times)
    if not ev:
        return 0, float(t[0]) if len(t) else math.nan, 1
    segs = 1 + len(ev)
    start = ev[-1]
    return int(np.searchsorted(t, start, side="left")), start, segs


def current_segment(times: Any, wear: Any, wear_std: Any, cycle_ids: Any, maintenance_times: Sequence[float],
           cfg: TrendConfig, where: str) -> tuple[Array, Array, Array, int, float, int]:
    """Checked, revision-collapsed estimates of the current segment: (t, w, s, total, segment start, segments)."""
    t = np.asarray(times, float)
    w = np.asarray(wear, float)
    s = np.asarray(wear_std, float)
    if not (t.shape == w.shape == s.shape) or t.ndim != 1:
        raise InputDataError(f"{where}: times, wear and wear_std must be 1-D of one length "
                             f"(got {t.shape}, {w.shape}, {s.shape})")
    bad = ~(np.isfinite(t) & np.isfinite(w) & np.isfinite(s) & (s > 0))
    if bad.any():
        i = int(np.argmax(bad))
        raise InputDataError(f"{where}: estimate {i} is not usable (time {t[i]!r}, wear {w[i]!r}, "
                             f"std {s[i]!r}): need finite values and std > 0")
    total = len(t)
    cid = np.zeros(total, int) if cycle_ids is None else np.asarray(cycle_ids)
    keep = collapse_revisions(t, cid, cfg.revision_window_s) if total else np.zeros(0, int)
    t, w, s = t[keep], w[keep], s[keep]
    first, seg_start, segs = last_segment(t, maintenance_times)
    return t[first:], w[first:], s[first:], total, seg_start, segs
