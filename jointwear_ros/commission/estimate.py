"""The wear estimate of every test cycle of every joint in observation tables, with one parameter set.

What ``jointwear estimate`` and ``jointwear history import --reestimate`` (tables) share.
Pure: tables in, estimates out.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from ..estimation import make_estimator
from ..model import ParameterSet
from ..types import ObservationTable, WearResult

__all__ = ["CycleEstimate", "estimate_cycles"]


@dataclass(frozen=True)
class CycleEstimate:
    """One cycle's estimate: where it came from, the result, and the time of its last observation."""

    source: str
    joint: str
    cycle: int
    time: float
    result: WearResult

    def level(self, warn: float, alarm: float) -> str:
        w = self.result.wear
        return "alarm" if w >= alarm else ("warn" if w >= warn else "ok")


def estimate_cycles(tables: Iterable[tuple[str, str, ObservationTable]], pset: ParameterSet, method: str = "joint",
                    seed: int = 0) -> list[CycleEstimate]:
    """``(source, joint, table)`` -> one :class:`CycleEstimate` per ``cycle`` of each table (all rows one cycle
    when there is no ``cycle`` column); a table without ``temperature`` has an unknown temperature."""
    est = make_estimator(method, params=pset, seed=seed)
    out = []
    for source, joint, table in tables:
        groups = table.groups("cycle") if "cycle" in table else [(0.0, table)]
        for cyc, t in groups:
            res = est.estimate(ObservationTable(dict(t.columns), source=f"{source} [{joint}] cycle {cyc:g}"))
            stamp = float(max(t["time"])) if "time" in t else math.nan
            out.append(CycleEstimate(str(source), joint, int(cyc), stamp, res))
    return out
