"""The workbench tests' scenarios, their results saved and compared, and their CPU time.

Runs the diagnoses and fits of test/test_workbench_discovery.py and test/test_workbench_acceptance.py over
their fixed seeds and records what the workbench returns: the verdict, the ranked columns (p-values, shares),
every candidate (CV RMSE, statistic, p-value, fitted parameters), the base fit's parameters and the refits of
the suggestions. ``--save FILE`` writes them (JSON), ``--compare FILE`` compares a run with a saved one (the
largest relative difference of each kind of number, and every difference in a name, a verdict or an order).
The CPU seconds of each scenario are printed (process time: the machine may be shared).

    python bench/bench_workbench39.py --save /tmp/wb_old.json
    python bench/bench_workbench39.py --compare /tmp/wb_old.json [--only family]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from jointwear_ros.data import EFFECT_FAMILIES, NOISE_STD, synth_observations
from jointwear_ros.types import ObservationTable
from jointwear_ros.workbench import diagnose, fit_model, noise_test, parse_spec, residual_dependence
from jointwear_ros.workbench.diagnose import Diagnosis
from jointwear_ros.workbench.fit import FitResult


def fit_dict(fit: FitResult) -> dict[str, Any]:
    return {
        "spec": fit.spec, "success": fit.success, "message": fit.message, "ssr": fit.ssr, "rmse": fit.rmse,
        "cv_rmse": fit.cv_rmse, "bic": fit.bic, "n_free": fit.n_free,
        "params": {n: p.value for n, p in fit.params.items()},
        "stderr": {n: p.stderr for n, p in fit.params.items()},
        "at_bound": [h.name for h in fit.at_bound],
    }


def diag_dict(diag: Diagnosis) -> dict[str, Any]:
    d = diag.to_dict()
    d["base"] = fit_dict(diag.base)
    d["candidate_fits"] = {c.term: fit_dict(c.fit) for c in diag.candidates}
    d["verdict_fields"] = {"agrees": diag.agrees, "isolates_outliers": diag.isolates_outliers}
    return d


def dep_list(dep: list[Any]) -> list[dict[str, Any]]:
    return [d.to_dict() for d in dep]


def _families() -> Iterator[tuple[str, Callable[[], Any]]]:
    for effect in sorted(EFFECT_FAMILIES):
        def run(effect: str = effect) -> Any:
            table = synth_observations(n_cycles=40, effects=[effect], seed=1)
            diag = diagnose(table, "paper", n_bootstrap=50)
            out = diag_dict(diag)
            if diag.suggestion is not None:
                out["refit"] = fit_dict(fit_model(parse_spec(f"{diag.model} + {diag.suggestion}"), table))
            return out
        yield f"family/{effect}", run


def _diag_case(name: str, n_cycles: int, effects: list[str], seed: int, n_bootstrap: int, irrelevant: int = 0,
               refit: bool = True) -> tuple[str, Callable[[], Any]]:
    def run() -> Any:
        table = synth_observations(n_cycles=n_cycles, effects=effects, seed=seed, irrelevant=irrelevant)
        diag = diagnose(table, "paper", n_bootstrap=n_bootstrap)
        out = diag_dict(diag)
        if refit and diag.suggestion is not None:
            out["refit"] = fit_dict(fit_model(parse_spec(f"{diag.model} + {diag.suggestion}"), table))
        return out
    return name, run


def _ranking(effect: str, seed: int, irrelevant: int, n_cycles: int = 40) -> Any:
    table = synth_observations(n_cycles=n_cycles, seed=seed, effects=[effect] if effect else (),
                               irrelevant=irrelevant)
    fit = fit_model(parse_spec("paper"), table, cv_folds=0)
    return {"fit": fit_dict(fit), "dep": dep_list(residual_dependence(table, fit.residuals, noise=NOISE_STD))}


def _discovery_misc() -> Iterator[tuple[str, Callable[[], Any]]]:
    def noise() -> Any:
        out = {}
        for eff in (None, "ripple_fast"):
            t = synth_observations(n_cycles=20, seed=21, effects=[eff] if eff else ())
            f = fit_model(parse_spec("paper"), t, cv_folds=0)
            out[str(eff)] = [fit_dict(f), noise_test(t, f.residuals, f.n_free).to_dict()]
        for eff in (None, "time_drift", "ripple"):
            t0 = synth_observations(n_cycles=20, seed=22, effects=[eff] if eff else ())
            t = ObservationTable({k: v for k, v in t0.columns.items() if k != "tau_f_std"}, source=t0.source)
            f = fit_model(parse_spec("paper"), t, cv_folds=0)
            out[f"std/{eff}"] = [fit_dict(f), noise_test(t, f.residuals, f.n_free).to_dict()]
        base = synth_observations(n_cycles=10, seed=23, noise=0.0)
        rng = np.random.default_rng(0)
        cols = {k: np.repeat(v, 3) for k, v in base.columns.items() if k != "tau_f_std"}
        cols["tau_f"] = cols["tau_f"] + rng.normal(0.0, NOISE_STD, cols["tau_f"].size)
        t = ObservationTable(cols)
        for spec in ("paper", "standard"):
            f = fit_model(parse_spec(spec), t, cv_folds=0)
            out[f"rep/{spec}"] = [fit_dict(f), noise_test(t, f.residuals, f.n_free).to_dict()]
        return out
    yield "misc/noise", noise
    for eff in ("ripple_fast", "warmup", "load_viscous"):
        yield f"rank/{eff}", lambda eff=eff: _ranking(eff, 31, 12)
    for eff in ("ripple_fast", "regreasing"):
        yield f"rank32/{eff}", lambda eff=eff: _ranking(eff, 32, 0)
    for seed in (41, 42):
        yield f"rank_clean/{seed}", lambda seed=seed: _ranking("", seed, 12, n_cycles=20)
    for seed, irr in ((51, 0), (52, 12), (53, 0)):
        yield _diag_case(f"clean/{seed}", 20, [], seed, 200, irr)

    def halved(keep_cycle: bool) -> Any:
        table = synth_observations(n_cycles=20, seed=61)
        cols = dict(table.columns)
        cols["tau_f_std"] = cols["tau_f_std"] / 2.0
        if not keep_cycle:
            cols = {k: v for k, v in cols.items() if k != "cycle"}
        return diag_dict(diagnose(ObservationTable(cols, source="halved-std"), "paper"))
    yield "halved/no_cycle", lambda: halved(False)
    yield "halved/cycle", lambda: halved(True)
    yield _diag_case("two_effects", 40, ["ripple_fast", "warmup"], 62, 0, refit=False)
    yield _diag_case("few/regreasing1005", 12, ["regreasing"], 1005, 0, 12)
    yield _diag_case("few/torque1003", 12, ["torque_constant"], 1003, 0, 12)
    yield _diag_case("few/drift1002", 12, ["time_drift"], 1002, 0)
    yield _diag_case("few/stribeck_t1000", 12, ["stribeck_temperature"], 1000, 50)
    yield _diag_case("stribeck_t1002", 40, ["stribeck_temperature"], 1002, 50)
    yield _diag_case("few/torque1004", 12, ["torque_constant"], 1004, 50)

    def two_sensors() -> Any:
        table = synth_observations(n_cycles=12, effects=["torque_constant"], seed=1004)
        cols = dict(table.columns)
        per_cycle = np.random.default_rng(3).normal(0.0, 0.3, 12)
        cols["motor_temperature_b"] = cols["motor_temperature"] + np.repeat(per_cycle, 10)
        return diag_dict(diagnose(ObservationTable(cols, source="two-sensors"), "paper", n_bootstrap=200))
    yield "two_sensors", two_sensors

    def tangent() -> Any:
        from jointwear_ros.workbench.fit import model_inputs
        table = synth_observations(n_cycles=12, effects=["stribeck_temperature"], seed=1000)
        fit = fit_model(parse_spec("paper"), table, cv_folds=0)
        bare = residual_dependence(table, fit.residuals, noise=NOISE_STD, alpha=0.005)
        x = model_inputs(fit.model, table)
        dep = residual_dependence(table, fit.residuals, noise=NOISE_STD, alpha=0.005,
                                  tangent=fit.model.jacobian(fit.params, fit.free, **x),
                                  components=fit.model.components(fit.params, **x))
        return {"fit": fit_dict(fit), "bare": dep_list(bare), "dep": dep_list(dep)}
    yield "tangent", tangent


def _acceptance() -> Iterator[tuple[str, Callable[[], Any]]]:
    def journey() -> Any:
        table = synth_observations(n_cycles=40, seed=11)
        spec = "standard"
        diag = diagnose(table, spec)
        steps = [diag_dict(diag)]
        for _ in range(8):
            if not diag.missing_effect_found:
                break
            spec = f"{spec} + {diag.candidates[0].term}"
            diag = diagnose(table, spec)
            steps.append(diag_dict(diag))
        return steps
    yield "journey", journey
    for effect in ("load_viscous", "lubrication", "ripple", "time_drift"):
        def hidden(effect: str = effect) -> Any:
            table = synth_observations(n_cycles=40, effects=[effect], seed=5)
            diag = diagnose(table, "paper")
            out = diag_dict(diag)
            out["refit"] = fit_dict(fit_model(parse_spec(f"paper + {diag.candidates[0].term}"), table))
            return out
        yield f"hidden/{effect}", hidden
    for seed in range(100, 120):
        yield _diag_case(f"clean20/{seed}", 20, [], seed, 200, refit=False)


def scenarios() -> Iterator[tuple[str, Callable[[], Any]]]:
    yield from _families()
    yield from _discovery_misc()
    yield from _acceptance()


def _walk(a: Any, b: Any, path: str, out: dict[str, Any]) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        if list(a) != list(b):
            out["diffs"].append(f"{path}: keys {list(a)} != {list(b)}")
        for k in a:
            if k in b:
                _walk(a[k], b[k], f"{path}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out["diffs"].append(f"{path}: length {len(a)} != {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            _walk(x, y, f"{path}[{i}]", out)
    elif isinstance(a, float) and isinstance(b, float) and not isinstance(a, bool):
        if (math.isnan(a) and math.isnan(b)) or a == b:
            return
        rel = abs(a - b) / max(abs(a), abs(b), 1e-300)
        key = path.split(".")[-1].split("[")[0]
        if rel > out["worst"].get(key, (0.0, ""))[0]:
            out["worst"][key] = (rel, path)
        out["n_changed"] += 1
    elif a != b:
        out["diffs"].append(f"{path}: {a!r} != {b!r}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--save")
    ap.add_argument("--compare")
    ap.add_argument("--only", default="", help="run the scenarios whose name contains this")
    a = ap.parse_args()
    results: dict[str, Any] = {}
    total = 0.0
    for name, run in scenarios():
        if a.only and a.only not in name:
            continue
        t0 = time.process_time()
        results[name] = json.loads(json.dumps(run(), default=float))
        dt = time.process_time() - t0
        total += dt
        print(f"{name:32s} {dt:7.2f} s CPU", flush=True)
    print(f"{'total':32s} {total:7.2f} s CPU")
    if a.save:
        with open(a.save, "w") as fh:
            json.dump(results, fh)
    if a.compare:
        with open(a.compare) as fh:
            old = json.load(fh)
        out: dict[str, Any] = {"diffs": [], "worst": {}, "n_changed": 0}
        for name, new in results.items():
            if name not in old:
                print(f"{name}: not in {a.compare}")
                continue
            _walk(old[name], new, name, out)
        print(f"numbers changed: {out['n_changed']}")
        for key, (rel, path) in sorted(out["worst"].items(), key=lambda kv: -kv[1][0]):
            print(f"  {key:24s} {rel:.3g}  ({path})")
        print(f"other differences: {len(out['diffs'])}")
        for d in out["diffs"][:40]:
            print("  " + d)


if __name__ == "__main__":
    main()
