"""How fast the ``jointwear`` command line answers ``--help`` (issue 29: at most 0.3 s a command).

Usage: python bench/bench_cli_startup.py [--runs N]

Each line runs ``python -m jointwear_ros [COMMAND] --help`` N times in a fresh process (subprocess,
wall time) and prints the minimum and the median, and the ratio of the minimum to a bare interpreter
(``python -c pass``), and the same for CPU time (user + system, which a loaded machine disturbs
less than wall time). The minimum is the figure to compare on a shared machine: it is the run the
other processes disturbed least. The package is imported from this checkout.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: what the issue asks of any command's --help, seconds (on an idle machine)
TARGET = 0.3


def wall_times(argv: list[str], runs: int, env: dict[str, str]) -> tuple[list[float], list[float]]:
    """Wall and CPU (user + system) seconds of each of ``runs`` runs of ``argv``."""
    times, cpu = [], []
    for _ in range(runs):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        times.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return times, cpu


def main(argv: list[str]) -> int:
    from jointwear_ros.cli import COMMANDS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=7, help="runs of each command (default 7)")
    runs = ap.parse_args(argv).runs
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    bare, bare_cpu = wall_times([sys.executable, "-c", "pass"], runs, env)
    base, base_cpu = min(bare), min(bare_cpu)
    print(f"{'command':<28} {'min s':>7} {'median s':>9} {'x bare':>7} {'CPU s':>6} {'x bare':>7}"
          f"  (runs {runs}; target {TARGET} s)")
    print(f"{'python -c pass':<28} {base:7.3f} {statistics.median(bare):9.3f} {1.0:7.1f} {base_cpu:6.3f} {1.0:7.1f}")
    over = []
    for words in [[], *([c] for c in sorted(COMMANDS))]:
        t, cpu = wall_times([sys.executable, "-m", "jointwear_ros", *words, "--help"], runs, env)
        label = " ".join(["jointwear", *words, "--help"])
        print(f"{label:<28} {min(t):7.3f} {statistics.median(t):9.3f} {min(t) / base:7.1f} {min(cpu):6.3f} "
              f"{min(cpu) / max(base_cpu, 1e-3):7.1f}")
        if min(t) > TARGET:
            over.append(label)
    if over:
        print(f"over {TARGET} s: {', '.join(over)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
