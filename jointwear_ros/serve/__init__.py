"""The plant's view: ``jointwear serve``, a read-only live web page and Prometheus metrics over the history store.

:mod:`.core` (pure) turns trend results into the plant's rows and levels (OK, WARN, ERROR, STALE),
shared with ``jointwear trend``; :mod:`.watch` reads the store read-only in a thread; :mod:`.web`
is the Starlette adapter (pages, plots, ``/api/joints``, ``/metrics``).
"""

from __future__ import annotations

from .core import JointHistory, JointView, analyze_plant, joint_view, plant_level, rank_views

__all__ = ["JointHistory", "JointView", "analyze_plant", "joint_view", "plant_level", "rank_views"]
