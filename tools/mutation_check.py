#!/usr/bin/env python3
"""Plant known bugs one at a time and check that the tests catch each.

Each mutation is a small text patch of one source file. For every mutation the
tool copies the package (``jointwear_ros/``, ``config/``, ``test/`` and the
project files) into a temporary directory, applies the patch there (the
working tree is never touched), runs the tests that should catch it with the
copy first on ``PYTHONPATH``, and reports ``caught by <test>`` or
``SURVIVED``. A patch whose anchor text is no longer in the source (the code
was changed) is reported as ``STALE``: update the mutation.

    .venv/bin/python tools/mutation_check.py             # every mutation, a table
    .venv/bin/python tools/mutation_check.py --json      # the same as JSON
    .venv/bin/python tools/mutation_check.py --only csv_nan_optional_column --only estimator_checks_off
    .venv/bin/python tools/mutation_check.py --list

Exit code 0 when every mutation run was caught, 1 when one survived, 2 when
one is stale or its tests could not run.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: What a copy needs to run the tests.
COPY = ("jointwear_ros", "config", "test", "launch", "msg_defs", "docs", "resource", "pyproject.toml", "setup.cfg",
        "setup.py", "package.xml", "README.md", "Makefile", "requirements.txt")


@dataclass(frozen=True)
class Mutation:
    """A planted bug: replace ``old`` (which must occur exactly once) by ``new`` in ``path``."""

    name: str
    description: str
    path: str
    old: str
    new: str
    tests: tuple[str, ...]
    #: quick enough (seconds, no ROS graph) for the test suite's own check
    fast: bool = False
    #: pytest -k expression narrowing ``tests`` to the ones that should catch it
    select: str = ""


MUTATIONS: tuple[Mutation, ...] = (
    # -- the planted bugs an earlier suite let through --------------------------
    Mutation(
        "alarm_forced_true", "WearEstimate.alarm is always true",
        "jointwear_ros/nodes/wear_estimator.py",
        "m.alarm = bool(res.wear >= r.alarm_threshold)", "m.alarm = True",
        ("test/test_nodes_observer_estimator.py", "test/test_replay.py"),
    ),
    Mutation(
        "alarm_ge_to_gt_message", "WearEstimate.alarm uses > instead of >= (w_hat = 35 gives no alarm)",
        "jointwear_ros/nodes/wear_estimator.py",
        "m.alarm = bool(res.wear >= r.alarm_threshold)", "m.alarm = bool(res.wear > r.alarm_threshold)",
        ("test/test_nodes_observer_estimator.py", "test/test_replay.py"),
    ),
    Mutation(
        "alarm_ge_to_gt_level", "the diagnostic level's ERROR uses > instead of >=",
        "jointwear_ros/contract.py",
        "        if wear >= alarm:\n            return cls.ERROR", "        if wear > alarm:\n            return cls.ERROR",
        ("test/test_monitor.py", "test/test_doctests.py"),
        fast=True,
    ),
    Mutation(
        "observer_std_under_reported", "the observer reports tau_f_std 30 % too small",
        "jointwear_ros/observer/segmentation.py",
        "tau_f_std=0.5 * math.hypot(ses[1], ses[-1]),", "tau_f_std=0.35 * math.hypot(ses[1], ses[-1]),",
        ("test/test_observer_core.py",),
    ),
    Mutation(
        "recorder_drops_every_1000th", "the recorder silently drops every 1000th message",
        "jointwear_ros/io/recording.py",
        "        self._writer.write(conn, stamp, item.data)\n        self._last = stamp\n        self.count += 1",
        "        self.count += 1\n        if self.count % 1000 == 0:\n            return\n"
        "        self._writer.write(conn, stamp, item.data)\n        self._last = stamp",
        ("test/test_recorder.py",),
    ),
    Mutation(
        "observer_memory_trim_disabled", "the observer never trims its joint-state buffer",
        "jointwear_ros/observer/core.py",
        '        """Bound memory: idle history beyond ``idle_keep_seconds``, any beyond ``max_buffer_seconds``."""\n',
        '        """Bound memory: idle history beyond ``idle_keep_seconds``, any beyond ``max_buffer_seconds``."""\n'
        "        self._trim_at = self._samples.size + 4096\n        return\n",
        ("test/test_observer_core.py",),
    ),
    Mutation(
        "csv_nan_optional_column", "the CSV reader accepts NaN in an optional column",
        "jointwear_ros/io/tables.py",
        "            if not math.isfinite(v):\n",
        "            if not math.isfinite(v) and (name in _REQUIRED or not math.isnan(v)):\n",
        ("test/test_io_tables.py", "test/test_properties_io.py"),
        fast=True, select="csv or nan",
    ),
    # -- the input checks of the command line and the estimators -----------------------------
    Mutation(
        "estimator_checks_off", "the estimators' own value checks (check_observation_values) skipped",
        "jointwear_ros/estimation/_common.py",
        "    check_observation_values(table, temperature=use_temperature)",
        "    pass",
        ("test/test_properties_estimators.py",),
        fast=True, select="estimators_give",
    ),
    Mutation(
        "model_accepts_non_finite", "the model evaluates NaN/inf inputs silently",
        "jointwear_ros/model/model.py",
        "            if not np.isfinite(a).all():\n",
        "            if False:\n",
        ("test/test_properties_estimators.py",),
        fast=True, select="model_evaluates",
    ),
    Mutation(
        "csv_accepts_negative_speed", "the table readers accept a negative speed",
        "jointwear_ros/io/tables.py",
        '("speed", lambda v: v < 0,', '("speed", lambda v: v < -1e300,',
        ("test/test_properties_io.py", "test/test_cli_faults.py"),
        fast=True, select="csv_reader_gives or negative_speed",
    ),
    Mutation(
        "cli_output_dir_unchecked", "output directories are not checked before the work starts",
        "jointwear_ros/cli/common.py",
        '    p = Path(value)\n    text = str(value)\n    if p.exists() and not p.is_dir():\n'
        '        raise UsageError(f"{flag}: {text!r} exists and is not a directory")\n',
        '    return Path(value)\n',
        ("test/test_cli_faults.py",),
        fast=True, select="output_path",
    ),
    Mutation(
        "cli_method_unchecked", "replay and demo start without checking --method",
        "jointwear_ros/cli/common.py",
        "    if method is not None and str(method).strip().lower() not in ESTIMATORS:",
        "    if False:",
        ("test/test_cli_faults.py",),
        fast=True, select="method",
    ),
    Mutation(
        "bound_quadrature_unguarded", "the bound is computed with an unresolved temperature quadrature",
        "jointwear_ros/estimation/crb.py",
        "    if not math.isfinite(spread) or spread / float(noise_std) + _MIN_NODES > _MAX_NODES:",
        "    if False:",
        ("test/test_properties_estimators.py",),
        fast=True, select="quadrature",
    ),
)


@dataclass
class Outcome:
    name: str
    description: str
    status: str  # caught, SURVIVED, STALE, ERROR, TIMEOUT
    caught_by: list[str]
    seconds: float
    detail: str = ""

    def to_dict(self) -> dict[str, object]:
        return {"mutation": self.name, "description": self.description, "status": self.status,
                "caught_by": self.caught_by, "seconds": round(self.seconds, 1), "detail": self.detail}


def _copy_tree(dst: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".pytest_cache", ".hypothesis")
    for name in COPY:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dst / name, ignore=ignore)
        elif src.is_file():
            shutil.copy2(src, dst / name)


def apply(m: Mutation, tree: Path) -> None:
    """Patch ``tree`` (a copy); ValueError when the anchor is missing or not unique."""
    f = tree / m.path
    text = f.read_text()
    count = text.count(m.old)
    if count != 1:
        raise ValueError(f"anchor found {count} times in {m.path} (expected once): {m.old.strip()[:80]!r}")
    f.write_text(text.replace(m.old, m.new))


def run_one(m: Mutation, python: str, timeout: float, extra: list[str]) -> Outcome:
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix=f"mutation-{m.name}-") as tmp:
        tree = Path(tmp)
        _copy_tree(tree)
        try:
            apply(m, tree)
        except ValueError as exc:
            return Outcome(m.name, m.description, "STALE", [], time.monotonic() - t0, str(exc))
        env = dict(os.environ)
        env["PYTHONPATH"] = str(tree) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        env.setdefault("MPLBACKEND", "Agg")
        sel = ["-k", m.select] if m.select else []
        cmd = [python, "-m", "pytest", "-q", "-x", "-rf", "-p", "no:cacheprovider", *sel, *extra, *m.tests]
        try:
            r = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return Outcome(m.name, m.description, "TIMEOUT", [], time.monotonic() - t0,
                           f"tests still running after {timeout:g} s")
        out = r.stdout + r.stderr
        # the copy must really have been imported, or the check proves nothing
        failed = re.findall(r"^FAILED (\S+)", out, flags=re.M)
        if r.returncode == 0:
            return Outcome(m.name, m.description, "SURVIVED", [], time.monotonic() - t0)
        if r.returncode == 1 and failed:
            return Outcome(m.name, m.description, "caught", failed, time.monotonic() - t0)
        tail = " | ".join(out.strip().splitlines()[-5:])
        return Outcome(m.name, m.description, "ERROR", failed, time.monotonic() - t0,
                       f"pytest exit code {r.returncode}: {tail}")


def check_copy_is_used(python: str) -> None:
    """The mutated copy must shadow the installed package (an editable install must not win)."""
    with tempfile.TemporaryDirectory(prefix="mutation-probe-") as tmp:
        tree = Path(tmp)
        _copy_tree(tree)
        env = dict(os.environ, PYTHONPATH=str(tree))
        r = subprocess.run([python, "-c", "import jointwear_ros; print(jointwear_ros.__file__)"], cwd=tree, env=env,
                           capture_output=True, text=True, timeout=120)
        if not r.stdout.strip().startswith(str(tree)):
            raise SystemExit(f"mutation_check: the copy is not imported (got {r.stdout.strip() or r.stderr.strip()}); "
                             "cannot check mutations")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true", help="print JSON")
    ap.add_argument("--only", action="append", default=[], metavar="NAME", help="run only this mutation (repeatable)")
    ap.add_argument("--fast", action="store_true", help="only the mutations whose tests take seconds (no ROS graph)")
    ap.add_argument("--list", action="store_true", help="list the mutations and exit")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per mutation (default 900)")
    ap.add_argument("--python", default=sys.executable, help="interpreter with the test dependencies")
    ap.add_argument("--jobs", type=int, default=1,
                    help="mutations run at once (default 1; the ROS tests of two at once would share a DDS domain)")
    args = ap.parse_args(argv)
    chosen = [m for m in MUTATIONS if (not args.only or m.name in args.only) and (not args.fast or m.fast)]
    unknown = set(args.only) - {m.name for m in MUTATIONS}
    if unknown:
        print(f"mutation_check: unknown mutation(s) {', '.join(sorted(unknown))}; see --list", file=sys.stderr)
        return 2
    if args.list:
        for m in chosen:
            print(f"{m.name:32s} {'fast' if m.fast else 'slow'}  {m.description}  [{', '.join(m.tests)}]")
        return 0
    check_copy_is_used(args.python)
    results: list[Outcome] = []

    def report(o: Outcome) -> None:
        if not args.json:
            what = f"caught by {o.caught_by[0]}" if o.status == "caught" else o.status
            print(f"{o.name}: {what} ({o.seconds:.0f} s){'; ' + o.detail if o.detail else ''}", flush=True)

    if args.jobs > 1:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            for o in pool.map(lambda m: run_one(m, args.python, args.timeout, []), chosen):
                results.append(o)
                report(o)
    else:
        for m in chosen:
            results.append(run_one(m, args.python, args.timeout, []))
            report(results[-1])
    if args.json:
        print(json.dumps({"mutations": [o.to_dict() for o in results],
                          "caught": sum(o.status == "caught" for o in results), "total": len(results)}, indent=2))
    else:
        print(f"{sum(o.status == 'caught' for o in results)} of {len(results)} mutations caught")
    if any(o.status in ("STALE", "ERROR", "TIMEOUT") for o in results):
        return 2
    return 0 if all(o.status == "caught" for o in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
