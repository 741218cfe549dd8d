"""An example plant history: 30 joints (5 robots x 6), nightly estimates, levels known by construction.

- most joints flat (OK), ``cell_2/joint_2`` and ``cell_4/joint_5`` rising towards the alarm (WARN),
- ``cell_3/joint_4`` past the alarm (ERROR, wear about 38),
- ``cell_5/joint_6`` silent for three weeks (STALE),

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
WARN_JOINTS = {("cell_2", "joint_2"): (12.0, 0.30), ("cell_4", "joint_5"): (10.0, 0.30)}  # start, wear per day
ERROR_JOINT = ("cell_3", "joint_4")
STALE_JOINT = ("cell_5", "joint_6")
NIGHTS = 60
STD = 0.85


def expected_levels() -> dict[tuple[str, str], str]:
    """The level each joint is built to have."""
    out = {(r, j): "OK" for r in ROBOTS for j in JOINTS}
    out.update({k: "WARN" for k in WARN_JOINTS})
    out[ERROR_JOINT] = "ERROR"
    out[STALE_JOINT] = "STALE"
    return out


def plant_records(now: float, seed: int = 7) -> list[EstimateRecord]:
    """The estimates of the example plant, the newest of each (not STALE) joint about a day before ``now``."""
    rng = np.random.default_rng(seed)
    recs = []
    for ri, robot in enumerate(ROBOTS):
        for ji, joint in enumerate(JOINTS):
            key = (robot, joint)
            base = 8.0 + 1.5 * ri + 0.7 * ji
            nights = np.arange(NIGHTS, dtype=float)
            if key in WARN_JOINTS:
                start, rate = WARN_JOINTS[key]
                wear = start + rate * nights
            elif key == ERROR_JOINT:
                wear = 30.0 + 0.14 * nights
            else:
                wear = np.full(NIGHTS, base)
            end = now - DAY - (21 * DAY if key == STALE_JOINT else 0.0) - 600.0 * ji
            times = end - (NIGHTS - 1 - nights) * DAY
            noisy = wear + rng.normal(0.0, STD, NIGHTS)
            for k in range(NIGHTS):
                recs.append(EstimateRecord(robot, joint, cycle_id=k + 1, time=float(round(times[k], 3)),
                                           wear=float(noisy[k]), wear_std=STD, method="joint", params="ref-2011r",
                                           hardware_id=f"{robot}/{joint}", source="csv"))
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
