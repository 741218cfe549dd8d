"""An example plant history: 30 joints (5 robots x 6), nightly estimates, levels known by construction.

Condition levels (docs/levels.md) and forecasts:

- most joints flat (OK, no alarm expected);
- ``cell_2/joint_2`` and ``cell_4/joint_5`` rising towards the alarm (OK today, about 27; the forecast:
  alarm expected within 30 days);
- ``cell_1/joint_3`` and ``cell_3/joint_1`` flat in the warning band (WARN, about 32; no growth);
- ``cell_3/joint_4`` past the alarm (ERROR, wear about 38);
- ``cell_5/joint_6`` silent for three weeks (STALE);
- ``cell_1/joint_6`` flat with one last estimate 20 above it (held unconfirmed: OK stands);
- ``cell_4/joint_1`` whose last estimate came from a FAILED cycle (partial; OK);
- ``cell_2/joint_5`` flat just below the warning level (near the threshold: its level is whatever the rule says
  of its newest estimate, the same on every surface);

every estimate with std 0.85, seeded. Times end at ``now`` (seconds since the epoch), so the levels
hold whenever it is written. Used by the serve tests and by ``tools/plant_screenshot.py``::

    python tools/plant_example.py history.db     # writes (or adds to) an SQLite history
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from jointwear_ros.history import EstimateRecord, HistoryStore

DAY = 86400.0
ROBOTS = [f"cell_{i}" for i in range(1, 6)]
JOINTS = [f"joint_{i}" for i in range(1, 7)]
RISING_JOINTS = {("cell_2", "joint_2"): (9.5, 0.30), ("cell_4", "joint_5"): (8.5, 0.30)}  # start, wear per day
WARN_JOINTS = {("cell_1", "joint_3"): 32.0, ("cell_3", "joint_1"): 31.5}  # flat in the warning band
ERROR_JOINT = ("cell_3", "joint_4")
STALE_JOINT = ("cell_5", "joint_6")
OUTLIER_JOINT = ("cell_1", "joint_6")
PARTIAL_JOINT = ("cell_4", "joint_1")
NEAR_JOINT = ("cell_2", "joint_5")
NIGHTS = 60
STD = 0.85


def expected_levels() -> dict[tuple[str, str], str]:
    """The condition level each joint is built to have (the near-threshold joint: None, whatever the rule says)."""
    out: dict[tuple[str, str], str | None] = {(r, j): "OK" for r in ROBOTS for j in JOINTS}
    out.update({k: "WARN" for k in WARN_JOINTS})
    out[ERROR_JOINT] = "ERROR"
    out[STALE_JOINT] = "STALE"
    out[NEAR_JOINT] = None
    return out  # type: ignore[return-value]


def expected_alarm_expected() -> dict[tuple[str, str], bool]:
    """The forecast each joint is built to have: the alarm expected within 30 days (the rising and ERROR ones)."""
    return {(r, j): (r, j) in RISING_JOINTS or (r, j) == ERROR_JOINT for r in ROBOTS for j in JOINTS}


def plant_records(now: float, seed: int = 7) -> list[EstimateRecord]:
    """The estimates of the example plant, the newest of each (not STALE) joint about a day before ``now``."""
    rng = np.random.default_rng(seed)
    recs = []
    for ri, robot in enumerate(ROBOTS):
        for ji, joint in enumerate(JOINTS):
            key = (robot, joint)
            base = 8.0 + 1.5 * ri + 0.7 * ji
            nights = np.arange(NIGHTS, dtype=float)
            if key in RISING_JOINTS:
                start, rate = RISING_JOINTS[key]
                wear = start + rate * nights
            elif key in WARN_JOINTS:
                wear = np.full(NIGHTS, WARN_JOINTS[key])
            elif key == ERROR_JOINT:
                wear = 30.0 + 0.14 * nights
            elif key == NEAR_JOINT:
                wear = np.full(NIGHTS, 29.6)
            else:
                wear = np.full(NIGHTS, base)
            end = now - DAY - (21 * DAY if key == STALE_JOINT else 0.0) - 600.0 * ji
            times = end - (NIGHTS - 1 - nights) * DAY
            noisy = wear + rng.normal(0.0, STD, NIGHTS)
            if key == OUTLIER_JOINT:
                noisy[-1] += 20.0  # one estimate far above the joint's history: held until the next one
            for k in range(NIGHTS):
                partial = key == PARTIAL_JOINT and k == NIGHTS - 1
                recs.append(EstimateRecord(robot, joint, cycle_id=k + 1, time=float(round(times[k], 3)),
                                           wear=float(noisy[k]), wear_std=STD, method="joint", params="ref-2011r",
                                           hardware_id=f"{robot}/{joint}", source="csv",
                                           evidence="partial" if partial else "complete"))
    return recs


def write_plant(url: str, now: float | None = None, seed: int = 7) -> int:
    """Write the example plant into the store at ``url`` (created if needed); the number of new rows."""
    with HistoryStore(url) as store:
        return store.add_estimates(plant_records(time.time() if now is None else now, seed))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python tools/plant_example.py HISTORY_DB")
    n = write_plant(sys.argv[1])
    print(f"{n} estimates of {len(ROBOTS) * len(JOINTS)} joints written to {sys.argv[1]}")
