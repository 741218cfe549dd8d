#!/usr/bin/env python3
"""Mutation check of the node suite: plant each known bug, run the tests that must catch it.

Each mutant is one text replacement in one source file (the bugs planted in a fault review and
their relatives), made in a temporary copy of the package (the working tree is never
touched). A mutant the tests do not catch is a hole in the suite: the script exits 1 and
names it.

    .venv/bin/python tools/mutants_nodes.py            # all mutants
    .venv/bin/python tools/mutants_nodes.py alarm      # those whose name contains "alarm"
    .venv/bin/python tools/mutants_nodes.py --pure     # those caught by pure-core tests (run by the suite)

ROS tests need ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST and a ROS_DOMAIN_ID of their own
(set here when missing). Takes ~2-3 min on a loaded 2-core machine.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Mutant:
    name: str
    path: str
    old: str
    new: str
    tests: tuple[str, ...]

    @property
    def pure(self) -> bool:
        """Caught by tests of the pure core (no ROS graph): cheap enough for every test run."""
        return not self.tests[0].startswith("test/test_nodes_")


MUTANTS: tuple[Mutant, ...] = (
    Mutant("alarm flag forced true", "jointwear_ros/nodes/wear_estimator.py",
           "m.alarm = bool(res.wear >= r.alarm_threshold)", "m.alarm = True",
           ("test/test_nodes_observer_estimator.py", "-k", "exactly_the_threshold")),
    Mutant("alarm flag >= turned into >", "jointwear_ros/nodes/wear_estimator.py",
           "m.alarm = bool(res.wear >= r.alarm_threshold)", "m.alarm = bool(res.wear > r.alarm_threshold)",
           ("test/test_nodes_observer_estimator.py", "-k", "exactly_the_threshold")),
    Mutant("monitor level >= turned into >", "jointwear_ros/contract.py",
           "        if wear >= alarm:\n            return cls.ERROR", "        if wear > alarm:\n            return cls.ERROR",
           ("test/test_monitor.py",)),
    Mutant("one logging line picks the severity", "jointwear_ros/nodes/wear_estimator.py",
           "        if r.level == DiagnosticLevel.ERROR:\n            self.get_logger().error(text)\n"
           "        elif r.level == DiagnosticLevel.WARN:\n"
           "            self.get_logger().warning(text)\n        else:\n            self.get_logger().info(text)",
           "        log = self.get_logger()\n"
           "        (log.info if r.level == DiagnosticLevel.OK else log.warning if r.level == DiagnosticLevel.WARN "
           "else log.error)(text)",
           ("test/test_nodes_observer_estimator.py", "-k", "in_sequence")),
    Mutant("observer tau_f_std under-reported by 30 %", "jointwear_ros/observer/segmentation.py",
           "tau_f_std=0.5 * math.hypot(", "tau_f_std=0.7 * 0.5 * math.hypot(",
           ("test/test_observer_core.py", "-k", "matches_scatter")),
    Mutant("observer memory trimming disabled", "jointwear_ros/observer/core.py",
           "        latest = self._max_stamp\n        if math.isfinite(latest):",
           "        latest = self._max_stamp\n        if False and math.isfinite(latest):",
           ("test/test_observer_core.py", "-k", "bounded")),
    Mutant("observation screening disabled", "jointwear_ros/monitor/validation.py",
           "    rng = dict(valid or {})\n", "    rng = dict(valid or {})\n    return o, ''\n",
           ("test/test_monitor.py",)),
    Mutant("observer uses impossible temperature readings", "jointwear_ros/observer/core.py",
           "        if not (math.isfinite(celsius) and lo <= celsius <= hi):",
           "        if not math.isfinite(celsius):",
           ("test/test_nodes_observer_estimator.py", "-k", "health")),
    Mutant("run-time threshold change ignored", "jointwear_ros/nodes/wear_estimator.py",
           "                ch.monitor.reconfigure(new[ch.name])", "                MonitorConfig(**{**new[ch.name].__dict__})",
           ("test/test_nodes_observer_estimator.py", "-k", "thresholds_apply")),
    Mutant("motion_enabled := false ignored", "jointwear_ros/nodes/test_cycle.py",
           "        if self.runner.running and ((\"motion_enabled\" in changes and not enabled)",
           "        if False and self.runner.running and ((\"motion_enabled\" in changes and not enabled)",
           ("test/test_nodes_sim_cycle.py", "-k", "motion_enabled_false")),
    Mutant("stale joint state (wall time) accepted", "jointwear_ros/nodes/test_cycle.py",
           "            if wall_age > self.state_timeout_wall:",
           "            if False:",
           ("test/test_nodes_sim_cycle.py", "-k", "simulator_that_died")),
    Mutant("a joint's status routed to another joint's core", "jointwear_ros/observer/robot.py",
           "        return joint if joint in self.cores else None", "        return self.joints[0]",
           ("test/test_nodes_robot.py", "-k", "robot_cycles")),
    Mutant("crawl speeds accepted", "jointwear_ros/cycle/plan.py",
           "        if v < config.min_speed:", "        if False:",
           ("test/test_cycle_core.py", "-k", "crawl")),
    Mutant("held joints not watched", "jointwear_ros/cycle/robot.py",
           "            reason = self._hold_watchdog(j, now, readings.get(j), ages.get(j))",
           "            reason = None",
           ("test/test_cycle_robot.py", "-k", "held")),
    Mutant("held joint's reference follows the joint (a slow drift never trips)", "jointwear_ros/cycle/robot.py",
           "        ref = self._hold.setdefault(j, r.position)\n",
           "        ref = self._hold.setdefault(j, r.position)\n        self._hold[j] = r.position\n",
           ("test/test_cycle_robot.py", "-k", "drifting_slowly")),
    Mutant("history stores times in whole seconds", "jointwear_ros/history/store.py",
           "        return round(self.time * 1e6) * 1000\n\n    def check(self, where: str = \"estimate\")",
           "        return round(self.time) * 1_000_000_000\n\n    def check(self, where: str = \"estimate\")",
           ("test/test_history_store.py", "-k", "to_the_microsecond and sqlite")),
    Mutant("history screening off", "jointwear_ros/history/screen.py",
           "    cfg = cfg or ScreenConfig()\n    try:", "    return None\n    cfg = cfg or ScreenConfig()\n    try:",
           ("test/test_cli_history.py", "-k", "bad_rows_never_hide")),
    Mutant("observation screening's temperature bounds widened", "jointwear_ros/monitor/validation.py",
           "        if not lo <= t <= hi:\n            return replace(o, temperature=math.nan), (\n"
           "                f\"temperature {t:g} degC is outside",
           "        if not lo - 1.0 <= t <= hi + 1.0:\n            return replace(o, temperature=math.nan), (\n"
           "                f\"temperature {t:g} degC is outside",
           ("test/test_monitor_validation.py", "-k", "bounds_hold_exactly")),
    Mutant("plausible temperature bound < for <=", "jointwear_ros/monitor/validation.py",
           "    if not (math.isfinite(t) and plo <= t <= phi):", "    if not (math.isfinite(t) and plo - 1.0 <= t <= phi):",
           ("test/test_monitor_validation.py", "-k", "bounds_hold_exactly")),
    Mutant("held joint movement not checked", "jointwear_ros/cycle/robot.py",
           "        if abs(r.position - ref) > self.hold_tolerance:", "        if False:",
           ("test/test_cycle_robot.py", "-k", "held")),
)


def run(m: Mutant) -> tuple[bool, float]:
    """Plant ``m`` in a copy of the package, run its tests there; (caught, seconds).

    The working tree is never modified: the package, tests and config are copied to a
    temporary directory that comes first on ``PYTHONPATH`` (also for the node processes the
    ROS tests start), so a killed run leaves nothing behind.
    """
    source = (ROOT / m.path).read_text()
    if source.count(m.old) != 1:
        raise SystemExit(f"mutant {m.name!r}: the text to replace is not found exactly once in {m.path}; update it")
    env = dict(os.environ)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault("ROS_DOMAIN_ID", "77")
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="jw-mutant-") as tmp:
        copy = Path(tmp)
        for name in ("jointwear_ros", "test", "config", "msg_defs", "docs"):
            shutil.copytree(ROOT / name, copy / name, ignore=shutil.ignore_patterns("__pycache__"))
        for name in ("setup.cfg", "setup.py", "package.xml", "README.md"):  # package.xml marks a source checkout
            shutil.copy2(ROOT / name, copy / name)
        (copy / m.path).write_text(source.replace(m.old, m.new))
        env["PYTHONPATH"] = os.pathsep.join([str(copy), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
        proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *m.tests],
                              cwd=copy, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # 1 = tests failed; 2-5 (collection error, no tests, ...) would be a broken mutant, not a catch
    if proc.returncode not in (0, 1):
        raise SystemExit(f"mutant {m.name!r}: pytest exit code {proc.returncode} (not a test failure); fix the mutant")
    return proc.returncode == 1, time.monotonic() - t0


def main(argv: list[str]) -> int:
    pure = "--pure" in argv
    words = [a for a in argv if a != "--pure"]
    chosen = [m for m in MUTANTS if (not words or any(a.lower() in m.name.lower() for a in words))
              and (m.pure or not pure)]
    missed = []
    for m in chosen:
        caught, secs = run(m)
        print(f"{'caught' if caught else 'MISSED':7s} {secs:5.1f} s  {m.name}  ({' '.join(m.tests)})", flush=True)
        if not caught:
            missed.append(m.name)
    print(f"{len(chosen) - len(missed)} of {len(chosen)} planted bugs caught")
    if missed:
        print("not caught: " + "; ".join(missed), file=sys.stderr)
    return 1 if missed else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
