"""Run every benchmark (bench/bench_*.py) and print its figures.

Usage: python bench/run_all.py [NAME ...]   (NAME: e.g. estimators, observer)
Benchmarks measure; they do not pass or fail. Each prints its own table.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    scripts = sorted(HERE.glob("bench_*.py"))
    if argv:
        scripts = [s for s in scripts if s.stem.removeprefix("bench_") in argv]
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST", MPLBACKEND="Agg")
    env.setdefault("ROS_DOMAIN_ID", str(os.getpid() % 90 + 10))
    rc = 0
    for s in scripts:
        print(f"=== {s.stem} ===", flush=True)
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, str(s)], env=env)
        print(f"--- {s.stem}: {time.perf_counter() - t0:.1f} s wall, exit {r.returncode}\n", flush=True)
        rc = rc or r.returncode
    if not scripts:
        print("no benchmarks found")
    return rc


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
