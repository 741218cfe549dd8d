"""What a robot cycle costs in cell time, and a rotation that fits a between-shift budget.

Testing every joint of a six-axis robot one after another costs six single-joint cycles of cell
time: at the paper's 14 s per speed and 8 speeds, 6 × 112 s ≈ 11 min. When the window between two
shifts is shorter, :func:`rotation_schedule` splits the joints over as few nights as possible so
that each night's robot cycle fits the budget; each joint is then tested once every
``period`` nights. The split is exact (the fewest nights; a dynamic programme over subsets of
joints, fine for the dozen joints a robot has), and joints keep their order within a night.

>>> s = rotation_schedule({"j1": 100.0, "j2": 100.0, "j3": 60.0, "j4": 40.0}, budget=160.0)
>>> s.period, s.nights, s.night_seconds()
(2, [['j1', 'j3'], ['j2', 'j4']], [160.0, 140.0])
>>> round(s.total, 1), s.fits_one_night
(300.0, False)
>>> rotation_schedule({"j1": 100.0}, budget=90.0)
Traceback (most recent call last):
...
jointwear_ros.cycle.schedule.ScheduleError: j1 alone needs 100 s, more than the 90 s budget: use fewer speeds for it (jointwear cycle design --budget 90) or a longer window

A night's time per joint includes ``overhead`` (moving the arm to the joint's test pose, say).
The trend (``wear_trend``) takes irregular sampling: a joint tested every second night loses
little in time-to-alarm precision as long as wear changes over weeks.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..errors import JointwearError

__all__ = ["MAX_SCHEDULE_JOINTS", "RobotSchedule", "ScheduleError", "rotation_schedule"]

#: Most joints the exact split handles (2^n subsets).
MAX_SCHEDULE_JOINTS = 16


class ScheduleError(JointwearError):
    """No schedule exists (a joint alone exceeds the budget) or the input is invalid."""


@dataclass(frozen=True)
class RobotSchedule:
    """Joints per night so that each night's robot cycle fits ``budget`` seconds."""

    budget: float
    #: cell seconds of each joint's part of a robot cycle (its plan plus the overhead)
    durations: dict[str, float]
    #: the joints tested on night 1, 2, ... (then the rotation repeats)
    nights: list[list[str]]

    @property
    def period(self) -> int:
        """Each joint is tested once every ``period`` nights."""
        return len(self.nights)

    @property
    def total(self) -> float:
        """Cell seconds to test every joint once (one robot cycle over all joints)."""
        return float(sum(self.durations.values()))

    @property
    def fits_one_night(self) -> bool:
        return self.period <= 1

    def night_seconds(self) -> list[float]:
        return [float(sum(self.durations[j] for j in night)) for night in self.nights]

    def to_dict(self) -> dict[str, Any]:
        return {
            "budget_seconds": self.budget,
            "joints": [{"joint": j, "seconds": d} for j, d in self.durations.items()],
            "total_seconds": self.total,
            "period_nights": self.period,
            "nights": [{"joints": night, "seconds": s} for night, s in zip(self.nights, self.night_seconds())],
        }


def rotation_schedule(durations: Mapping[str, float], budget: float, overhead: float = 0.0) -> RobotSchedule:
    """Split the joints over the fewest nights whose robot cycles each fit ``budget`` seconds.

    Parameters
    ----------
    durations : joint -> cell seconds of its test cycle (e.g. ``plan_cycle(...).duration``), in test order.
    budget : cell seconds available between two shifts.
    overhead : extra seconds per joint tested (moving to its test pose).
    """
    if not durations:
        raise ScheduleError("no joints to schedule")
    if len(durations) > MAX_SCHEDULE_JOINTS:
        raise ScheduleError(f"{len(durations)} joints; the exact split handles at most {MAX_SCHEDULE_JOINTS}")
    if not (math.isfinite(budget) and budget > 0):
        raise ScheduleError(f"budget {budget!r} must be a positive number of seconds")
    if not (math.isfinite(overhead) and overhead >= 0):
        raise ScheduleError(f"overhead {overhead!r} must be a number of seconds >= 0")
    names = list(durations)
    cost: dict[str, float] = {}
    for j in names:
        d = float(durations[j])
        if not (math.isfinite(d) and d >= 0):
            raise ScheduleError(f"{j}: duration {d!r} must be a number of seconds >= 0")
        cost[j] = d + overhead
        if cost[j] > budget:
            raise ScheduleError(f"{j} alone needs {cost[j]:.0f} s, more than the {budget:g} s budget: use fewer "
                                f"speeds for it (jointwear cycle design --budget {budget:g}) or a longer window")
    n = len(names)
    # dp[mask] = (nights used, seconds in the last night) for the best packing of the joints in mask
    # (bin packing over subsets, O(n 2^n)); parent[mask] = the joint added last
    full = (1 << n) - 1
    inf = (n + 1, math.inf)
    dp: list[tuple[int, float]] = [inf] * (full + 1)
    parent = [-1] * (full + 1)
    dp[0] = (1, 0.0)
    for mask in range(full + 1):
        used, fill = dp[mask]
        if used > n:
            continue
        for i in range(n):
            if mask & (1 << i):
                continue
            c = cost[names[i]]
            cand = (used, fill + c) if fill + c <= budget + 1e-9 else (used + 1, c)
            nxt = mask | (1 << i)
            if cand < dp[nxt]:
                dp[nxt] = cand
                parent[nxt] = i
    # walk back: the order joints were added gives the nights
    order: list[int] = []
    mask = full
    while mask:
        i = parent[mask]
        order.append(i)
        mask &= ~(1 << i)
    order.reverse()
    split: list[list[int]] = [[]]
    fill = 0.0
    for i in order:
        c = cost[names[i]]
        if fill + c > budget + 1e-9:
            split.append([])
            fill = 0.0
        split[-1].append(i)
        fill += c
    ordered = sorted((sorted(night) for night in split), key=lambda night: night[0])
    return RobotSchedule(float(budget), cost, [[names[i] for i in night] for night in ordered])
