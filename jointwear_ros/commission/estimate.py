"""The wear estimate of every test cycle of every joint in observation tables, with one parameter set.

What ``jointwear estimate`` and ``jointwear history import --reestimate`` (tables) share.
Pure: tables in, estimates out.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..condition import INSUFFICIENT, evidence_of, standing
from ..contract import level_name
from ..estimation import make_estimator
from ..model import ParameterSet
from ..types import ObservationTable, WearResult

__all__ = ["CycleCondition", "CycleEstimate", "conditions", "estimate_cycles"]


@dataclass(frozen=True)
class CycleEstimate:
    """One cycle's estimate: where it came from, the result, and the time of its last observation."""

    source: str
    joint: str
    cycle: int
    time: float
    result: WearResult
    #: ``complete`` or ``insufficient`` (fewer distinct speeds than a level needs, :mod:`jointwear_ros.condition`)
    evidence: str = "complete"
    #: ``test_cycle`` or ``production`` (a production shift's observations: the table's ``production`` column)
    cycle_source: str = "test_cycle"


@dataclass(frozen=True)
class CycleCondition:
    """The joint's condition after one cycle: the level name (``NONE`` without one), the estimate it stands on,
    the cycle's evidence and its confirmation (the live wear_estimator's rule, over the joint's cycles in order)."""

    level: str
    level_wear: float
    level_wear_std: float
    evidence: str
    confirmation: str
    reason: str


def conditions(cycles: Sequence[CycleEstimate], warn: float, alarm: float) -> list[CycleCondition]:
    """:class:`CycleCondition` of every cycle, each joint's cycles in time (else cycle) order, as the live
    monitor would have said after each."""
    out: list[CycleCondition | None] = [None] * len(cycles)
    by_joint: dict[str, list[int]] = {}
    for i, c in enumerate(cycles):
        by_joint.setdefault(c.joint, []).append(i)
    for idx in by_joint.values():
        idx = sorted(idx, key=lambda i: (cycles[i].time if math.isfinite(cycles[i].time) else math.inf,
                                         cycles[i].cycle))
        for k in range(len(idx)):
            seen = [cycles[i] for i in idx[: k + 1]]
            days = [(c.time if math.isfinite(c.time) else float(c.cycle)) / 86400.0 for c in seen]
            st = standing([c.result.wear for c in seen], [c.result.wear_std for c in seen], days,
                          [c.evidence for c in seen], warn, alarm)
            here = seen[-1]
            conf = "none" if here.evidence == INSUFFICIENT else st.newest_status
            out[idx[k]] = CycleCondition(level_name(st.level), st.wear, st.wear_std, here.evidence, conf, st.reason)
    return [c for c in out if c is not None]


def estimate_cycles(tables: Iterable[tuple[str, str, ObservationTable]], pset: ParameterSet, method: str = "joint",
                    seed: int = 0) -> list[CycleEstimate]:
    """``(source, joint, table)`` -> one :class:`CycleEstimate` per ``cycle`` of each table (all rows one cycle
    when there is no ``cycle`` column); a table without ``temperature`` has an unknown temperature. A table
    with the ``production`` column (:mod:`jointwear_ros.io.tables`) has test cycles and production shifts:
    each (source, cycle) is one estimate, never the two mixed."""
    est = make_estimator(method, params=pset, seed=seed)
    out = []
    for source, joint, whole in tables:
        by_source = whole.groups(_PRODUCTION) if _PRODUCTION in whole else [(0.0, whole)]
        for prod, table in by_source:
            cycle_source = "production" if prod == 1.0 else "test_cycle"
            table = ObservationTable({k: v for k, v in table.columns.items() if k != _PRODUCTION},
                                     source=table.source, units=table.units)
            out.extend(_estimate_table(est, source, joint, table, cycle_source))
    return out


#: the table column that marks a production shift's observations (io.tables.PRODUCTION_COLUMN)
_PRODUCTION = "production"


def _estimate_table(est: Any, source: str, joint: str, table: ObservationTable,
                    cycle_source: str) -> list[CycleEstimate]:
    out = []
    what = "production shift" if cycle_source == "production" else "cycle"
    groups = table.groups("cycle") if "cycle" in table else [(0.0, table)]
    for cyc, t in groups:
        res = est.estimate(ObservationTable(dict(t.columns), source=f"{source} [{joint}] {what} {cyc:g}"))
        stamp = float(max(t["time"])) if "time" in t else math.nan
        t_known = "temperature" in t and bool(np.all(np.isfinite(t["temperature"])))
        n_speeds = len(set(np.round(np.asarray(t["speed"], float), 9).tolist()))
        ev = evidence_of(n_speeds, 0, False, t_known)
        out.append(CycleEstimate(str(source), joint, int(cyc), stamp, res, ev, cycle_source))
    return out
