"""jointwear serve: how long a store change takes to reach the page and /metrics, and what a request costs.

For plants of 30, 120 and 300 joints (60 nightly estimates each, SQLite): the time to re-read the store
and run the trend of every joint (the watcher's load, once per change), then, against a running
service, the time from a new estimate committed to it showing in /metrics (default --refresh 2 s) and
the median time of a /metrics, /api/joints and plant-page request. Prints a table; measures only.
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from plant_example import plant_records  # noqa: E402
from plant_screenshot import start_serve, stop  # noqa: E402

from jointwear_ros.history import EstimateRecord, HistoryStore  # noqa: E402


def _get_s(url: str, n: int = 15) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        with urllib.request.urlopen(url, timeout=60) as r:
            r.read()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> int:
    print(f"{'joints':>6} {'load s':>7} {'change->metrics s':>18} {'/metrics ms':>11} {'/api/joints ms':>14} "
          f"{'page ms':>8}")
    for copies in (1, 4, 10):
        with tempfile.TemporaryDirectory() as tmp:
            db = str(Path(tmp) / "plant.db")
            now = time.time()
            recs = []
            for c in range(copies):
                recs += [EstimateRecord(f"{r.robot}_{c}", r.joint, r.cycle_id, r.time, r.wear, r.wear_std)
                         for r in plant_records(now, seed=c)]
            with HistoryStore(db) as s:
                s.add_estimates(recs)
            proc, base = start_serve(db)
            try:
                with urllib.request.urlopen(base + "/metrics", timeout=60) as r:
                    text = r.read().decode()
                load = float(next(ln.split()[1] for ln in text.splitlines()
                                  if ln.startswith("jointwear_store_load_duration_seconds ")))
                t0 = time.perf_counter()
                with HistoryStore(db) as s:
                    s.add_estimates([EstimateRecord("new_robot", "joint_1", 1, time.time() - 60, 20.0, 0.8)])
                while True:
                    with urllib.request.urlopen(base + "/metrics", timeout=60) as r:
                        if b'robot="new_robot"' in r.read():
                            break
                    time.sleep(0.05)
                delay = time.perf_counter() - t0
                m, a, p = (_get_s(base + u) for u in ("/metrics", "/api/joints", "/"))
            finally:
                stop(proc)
        print(f"{30 * copies:>6} {load:>7.2f} {delay:>18.2f} {1e3 * m:>11.1f} {1e3 * a:>14.1f} {1e3 * p:>8.1f}",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
