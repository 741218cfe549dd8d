"""Model workbench speed: diagnose on 400 observations with the whole candidate library, and fits.

Usage: python bench/run_all.py workbench   (or python bench/bench_workbench.py [--repeat N])

The workbench's target: diagnose on 400 observations with the whole library
(and the model-free ranking of every column) in at most 10 s
on the project's 2-core machine. Both libraries are timed: ``guided`` (the
default: generic shapes only for the columns the ranking finds) and ``full``
(generic shapes for every column), and the ranking alone, also with 12
irrelevant columns. Each case is run ``--repeat`` times;
the table gives the median wall time and the median CPU time of this process
(the machine is shared: wall time grows with other people's load, CPU time
much less), the number of candidates tried, and the ratio of the wall time to
the 10 s target. Benchmarks measure; they do not pass or fail.
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
import statistics
import sys
import time
from collections.abc import Callable

from jointwear_ros.cli.common import format_table
from jointwear_ros.data import EFFECT_FAMILIES, synth_observations
from jointwear_ros.workbench import diagnose, fit_model, parse_spec, residual_dependence

TARGET_S = 10.0


def timed(fn: Callable[[], object], repeat: int) -> tuple[float, float, object]:
    """Median wall and CPU seconds of ``fn()`` over ``repeat`` runs, and its last result."""
    walls, cpus = [], []
    out: object = None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return statistics.median(walls), statistics.median(cpus), out


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"# {os.cpu_count()} CPUs, load average {load:.2f} at start; median of {args.repeat} runs")

    cases = [("standard", (), "guided"), ("standard", (), "full"), ("paper", (), "guided"), ("paper", (), "full")]
    cases += [("paper", (e,), "guided") for e in EFFECT_FAMILIES]
    cases += [("paper", ("ripple_fast",), "full")]
    rows = []
    for spec, effects, mode in cases:
        table = synth_observations(n_cycles=40, effects=effects, seed=0)
        wall, cpu, diag = timed(lambda t=table, s=spec, m=mode: diagnose(t, s, mode=m), args.repeat)
        rows.append([
            spec, ",".join(effects) or "none", mode, len(table), len(diag.candidates),  # type: ignore[attr-defined]
            f"{wall:.2f}", f"{cpu:.2f}", f"{wall / TARGET_S:.2f}", diag.verdict,  # type: ignore[attr-defined]
            diag.suggestion or "-",  # type: ignore[attr-defined]
        ])
    print("\n## diagnose: noise test, model-free ranking, candidates, verdict (target: <= 10 s on 400 observations)")
    print(format_table(["model", "hidden", "library", "n", "candidates", "wall s", "cpu s", "wall/10s", "verdict",
                        "suggestion"], rows))

    dep_rows = []
    for irr in (0, 12):
        table = synth_observations(n_cycles=40, seed=0, irrelevant=irr)
        fit = fit_model(parse_spec("paper"), table, cv_folds=0)
        wall, cpu, dep = timed(lambda t=table, f=fit: residual_dependence(t, f.residuals, noise=0.0015), args.repeat)
        dep_rows.append([irr, len(dep), f"{wall:.2f}", f"{cpu:.2f}"])  # type: ignore[arg-type]
    print("\n## model-free ranking alone (400 observations, 199 permutations per test)")
    print(format_table(["irrelevant columns", "variables", "wall s", "cpu s"], dep_rows))

    table = synth_observations(n_cycles=40, effects=["ripple"], seed=0)
    fit_rows = []
    for spec in ("standard", "paper", "paper + ripple(position)", "paper+wear"):
        model = parse_spec(spec)
        data = table if spec != "paper+wear" else synth_observations(n_cycles=40, seed=0, model="paper+wear", wear=20.0)
        for folds in (0, 5):
            wall, cpu, fit = timed(lambda m=model, d=data, k=folds: fit_model(m, d, cv_folds=k), args.repeat)
            fit_rows.append([spec, len(data), len(model.param_names), folds or "-", f"{wall * 1e3:.0f}",
                             f"{cpu * 1e3:.0f}", f"{fit.rmse:.5f}"])  # type: ignore[attr-defined]
    print("\n## fit (400 observations; CV folds grouped by cycle)")
    print(format_table(["model", "n", "params", "CV folds", "wall ms", "cpu ms", "RMSE"], fit_rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
