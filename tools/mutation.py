#!/usr/bin/env python3
"""Mutation check: plant each known bug in a copy of the package and check that the tests catch it.

A mutant names *where* (a module and a function, method or class by its qualified name, such as
``WearEstimatorNode._log_result``) and *what changes there*, written as code and matched on the
syntax tree (``ast``), not on the text: an expression or statements replaced, a statement inserted
before or after another, an early return at the top. So a mutant survives reformatting, comments and
code moving within its file; if its function is renamed or the matched code is gone or ambiguous it
is reported ``STALE`` with the reason (update the mutant). In a pattern, ``...`` matches anything.

For every mutant the package, tests and config are copied to a temporary directory (the working
tree is never touched), the change is made there, and the tests that must catch it run with the copy
first on ``PYTHONPATH`` (also for the node processes the ROS tests start). A mutant the tests do not
catch (``SURVIVED``) is a hole in the suite. A mutant caught without a ROS graph runs its tests in a fork
of this process once it has loaded pytest, its plugins, numpy, scipy.stats and yaml (never the package: the fork
imports the copy's, and says so if its tests imported another; ``--no-fork``: a new interpreter each, as
the ROS-level ones always do). The full run runs a mutant's test files (``tests``, narrowed
by ``select``); ``--catchers`` runs only the test functions known to catch it (``catchers``, node ids
checked against the test files' syntax trees before the run: a renamed test is ``STALE``), which is what
the suite's own check (test/test_mutation.py) runs.

    .venv/bin/python tools/mutation.py                  # every mutant, a table (minutes)
    .venv/bin/python tools/mutation.py --fast           # only those caught without a ROS graph
    .venv/bin/python tools/mutation.py --catchers --only crawl_speeds_accepted
    .venv/bin/python tools/mutation.py --only alarm_forced_true --json
    .venv/bin/python tools/mutation.py --list

Exit code 0 when every mutant run was caught, 1 when one survived, 2 when one is stale or its
tests could not run.
"""

from __future__ import annotations

import argparse
import ast
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: What a copy needs to run the tests.
COPY = ("jointwear_ros", "config", "test", "launch", "msg_defs", "docs", "resource", "pyproject.toml", "setup.cfg",
        "setup.py", "package.xml", "README.md", "Makefile", "requirements.txt")


class Stale(ValueError):
    """The mutant's place or pattern is not (exactly once) in the source any more."""


# --------------------------------------------------------------------------- changes, matched on the syntax tree


@dataclass(frozen=True)
class Change:
    """What a mutant changes inside its definition.

    ``kind``: ``expr`` (replace the expression ``old`` by ``new``; with ``inside``, only within the one
    expression matching that pattern), ``stmts`` (replace the consecutive statements ``old`` by
    ``new``), ``before`` / ``after`` (insert ``new`` before / after the statement ``old``),
    ``prepend`` (insert ``new`` at the top of the body, after the docstring).
    """

    kind: str
    old: str
    new: str
    inside: str = ""

    def describe(self) -> str:
        if self.kind == "prepend":
            return f"insert at the top: {self.new!r}"
        if self.kind in ("before", "after"):
            return f"insert {self.new!r} {self.kind} {self.old!r}"
        return f"{self.old!r} -> {self.new!r}" + (f" in {self.inside!r}" if self.inside else "")


def expr(old: str, new: str, inside: str = "") -> Change:
    return Change("expr", old, new, inside)


def stmts(old: str, new: str) -> Change:
    return Change("stmts", old, new)


def before(stmt: str, new: str) -> Change:
    return Change("before", stmt, new)


def after(stmt: str, new: str) -> Change:
    return Change("after", stmt, new)


def prepend(new: str) -> Change:
    return Change("prepend", "", new)


def _same(pattern: ast.AST, node: ast.AST) -> bool:
    """``node`` has the shape of ``pattern`` (positions and contexts aside; ``...`` matches anything)."""
    if isinstance(pattern, ast.Constant) and pattern.value is Ellipsis:
        return True
    if isinstance(pattern, ast.Expr) and isinstance(pattern.value, ast.Constant) and pattern.value.value is Ellipsis:
        return True
    if type(pattern) is not type(node):
        return False
    for field in pattern._fields:
        if field in ("ctx", "type_comment", "kind"):
            continue
        a, b = getattr(pattern, field, None), getattr(node, field, None)
        if isinstance(a, list):
            if not isinstance(b, list) or len(a) != len(b) or not all(_same(x, y) for x, y in zip(a, b, strict=True)):
                return False
        elif isinstance(a, ast.AST):
            if not isinstance(b, ast.AST) or not _same(a, b):
                return False
        elif a != b:
            return False
    return True


def _definition(tree: ast.Module, where: str) -> ast.AST:
    """The one function, method or class whose qualified name is ``where``."""
    found: list[ast.AST] = []

    def walk(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = f"{prefix}.{child.name}" if prefix else child.name
                if name == where:
                    found.append(child)
                walk(child, name)
            else:
                walk(child, prefix)

    walk(tree, "")
    if len(found) != 1:
        raise Stale(f"{where!r} is defined {len(found)} times (expected once)")
    return found[0]


def _expr_pattern(src: str) -> ast.expr:
    return ast.parse(src.strip(), mode="eval").body


def _stmt_pattern(src: str) -> list[ast.stmt]:
    return ast.parse(_dedent(src)).body


def _dedent(src: str) -> str:
    import textwrap

    return textwrap.dedent(src).strip("\n")


def _one(matches: list, what: str, where: str) -> object:
    if len(matches) != 1:
        raise Stale(f"{what} found {len(matches)} times in {where} (expected once)")
    return matches[0]


def _stmt_lists(node: ast.AST):
    for n in ast.walk(node):
        for field in ("body", "orelse", "finalbody"):
            body = getattr(n, field, None)
            if isinstance(body, list) and body and isinstance(body[0], ast.stmt):
                yield body
        for h in getattr(n, "handlers", []) or []:
            yield h.body


def _runs(node: ast.AST, pattern: list[ast.stmt]) -> list[list[ast.stmt]]:
    """The runs of consecutive statements in ``node`` matching ``pattern``."""
    out = []
    k = len(pattern)
    for body in _stmt_lists(node):
        for i in range(len(body) - k + 1):
            if all(_same(p, s) for p, s in zip(pattern, body[i:i + k], strict=True)):
                out.append(body[i:i + k])
    return out


class _Source:
    """The file's bytes with (line, column) positions (ast columns are UTF-8 byte offsets)."""

    def __init__(self, text: str):
        self.data = text.encode()
        self.starts = [0]
        for i, b in enumerate(self.data):
            if b == 0x0A:
                self.starts.append(i + 1)

    def offset(self, line: int, col: int) -> int:
        return self.starts[line - 1] + col

    def splice(self, start: int, end: int, text: str) -> str:
        return (self.data[:start] + text.encode() + self.data[end:]).decode()


def _indented(code: str, indent: int) -> str:
    lines = _dedent(code).splitlines()
    return "\n".join((" " * indent + ln) if ln.strip() else ln for ln in lines)


def mutate(source: str, where: str, change: Change) -> str:
    """``source`` with ``change`` made in the definition ``where``; :class:`Stale` when it cannot be placed."""
    tree = ast.parse(source)
    node = _definition(tree, where)
    src = _Source(source)
    if change.kind == "expr":
        scope: ast.AST = node
        if change.inside:
            pat = _expr_pattern(change.inside)
            scope = _one([n for n in ast.walk(node) if isinstance(n, ast.expr) and _same(pat, n)],
                         f"{change.inside!r}", where)
        pat = _expr_pattern(change.old)
        hit = _one([n for n in ast.walk(scope) if isinstance(n, ast.expr) and _same(pat, n)], f"{change.old!r}", where)
        start, end = src.offset(hit.lineno, hit.col_offset), src.offset(hit.end_lineno, hit.end_col_offset)
        new = change.new.strip()
        atoms = (ast.Name, ast.Attribute, ast.Call, ast.Constant, ast.Subscript)
        if not isinstance(_expr_pattern(new), atoms):
            new = f"({new})"  # keep the precedence of the place it goes
        out = src.splice(start, end, new)
    elif change.kind in ("stmts", "before", "after"):
        run = _one(_runs(node, _stmt_pattern(change.old)), f"{change.old.strip()!r}", where)
        first, last = run[0], run[-1]
        indent = first.col_offset
        if change.kind == "stmts":
            start = src.offset(first.lineno, first.col_offset)
            end = src.offset(last.end_lineno, last.end_col_offset)
            out = src.splice(start, end, _indented(change.new, indent).lstrip())
        elif change.kind == "before":
            start = src.offset(first.lineno, 0)
            out = src.splice(start, start, _indented(change.new, indent) + "\n")
        else:
            end = src.offset(last.end_lineno, last.end_col_offset)
            out = src.splice(end, end, "\n" + _indented(change.new, indent))
    elif change.kind == "prepend":
        body = getattr(node, "body", None)
        if not body:
            raise Stale(f"{where!r} has no body")
        doc = isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) and isinstance(
            body[0].value.value, str)
        if doc and len(body) > 1:
            start = src.offset(body[1].lineno, 0)
            out = src.splice(start, start, _indented(change.new, body[1].col_offset) + "\n")
        elif doc:
            end = src.offset(body[0].end_lineno, body[0].end_col_offset)
            out = src.splice(end, end, "\n" + _indented(change.new, body[0].col_offset))
        else:
            start = src.offset(body[0].lineno, 0)
            out = src.splice(start, start, _indented(change.new, body[0].col_offset) + "\n")
    else:  # pragma: no cover - a typo in the table below
        raise ValueError(f"unknown change kind {change.kind!r}")
    try:
        ast.parse(out)
    except SyntaxError as exc:
        raise Stale(f"the mutated {where!r} does not parse: {exc}") from None
    if out == source:
        raise Stale(f"the change leaves {where!r} as it was")
    return out


# --------------------------------------------------------------------------- the planted bugs


@dataclass(frozen=True)
class Mutant:
    """A planted bug: ``change`` made in the definition ``where`` of ``path``; ``tests`` must catch it."""

    name: str
    description: str
    path: str
    where: str
    change: Change
    tests: tuple[str, ...]
    #: pytest -k expression narrowing ``tests`` to the ones that should catch it
    select: str = ""
    #: node ids (``file::function``, in ``tests``) of the tests known to catch it: ``--catchers`` runs only
    #: these (the suite's own check), the full run ``tests`` with ``select``
    catchers: tuple[str, ...] = ()
    #: caught by tests without a ROS graph (seconds each; the suite runs these itself)
    fast: bool = False


MUTANTS: tuple[Mutant, ...] = (
    # -- the alarm and the diagnostic level ---------------------------------------------------
    Mutant("alarm_forced_true", "WearEstimate.alarm is always true",
           "jointwear_ros/nodes/wear_estimator.py", "estimate_to_msg",
           expr("bool(r.alarm)", "True"),
           ("test/test_nodes_observer_estimator.py",), select="exactly_the_threshold"),
    Mutant("alarm_ge_to_gt_level", "the condition level's ERROR uses > instead of >= (w_hat = 35 gives no alarm)",
           "jointwear_ros/condition.py", "condition_level",
           expr("w >= alarm", "w > alarm"),
           ("test/test_monitor.py", "test/test_condition.py"), fast=True,
           catchers=("test/test_monitor.py::test_levels_at_the_thresholds",)),
    Mutant("warn_bound_ignored", "the condition level ignores the estimate's uncertainty (an estimate that cannot "
                                 "rule the alarm out reads OK)",
           "jointwear_ros/condition.py", "condition_level",
           expr("w >= warn or w + z * s >= alarm", "w >= warn"),
           ("test/test_monitor.py", "test/test_condition.py"), fast=True),
    Mutant("outlier_not_held", "one estimate far from the joint's standing one moves the level at once",
           "jointwear_ros/condition.py", "ConfirmConfig.far",
           stmts("return d > allowance", "return False"),
           ("test/test_condition.py",), fast=True),
    Mutant("insufficient_speeds_give_a_level", "an estimate from 1 or 2 speeds with the temperature unknown "
                                               "carries a level",
           "jointwear_ros/condition.py", "min_speeds",
           expr("1 if temperature_known else 3", "1"),
           ("test/test_condition.py",), fast=True),
    Mutant("log_severity_one_line", "one logging line picks the severity (rclpy then logs every level as the first)",
           "jointwear_ros/nodes/wear_estimator.py", "WearEstimatorNode._log_result",
           stmts("""
                 if ...:
                     self.get_logger().error(text)
                 elif ...:
                     self.get_logger().warning(text)
                 else:
                     self.get_logger().info(text)
                 """,
                 """
                 log = self.get_logger()
                 (log.info if r.level == DiagnosticLevel.OK else log.warning if r.level == DiagnosticLevel.WARN
                  else log.error)(text)
                 """),
           ("test/test_nodes_observer_estimator.py",), select="in_sequence"),
    Mutant("threshold_change_ignored", "a run-time threshold change is not applied",
           "jointwear_ros/nodes/wear_estimator.py", "WearEstimatorNode._on_parameters",
           stmts("ch.monitor.reconfigure(new[ch.name])", "MonitorConfig(**{**new[ch.name].__dict__})"),
           ("test/test_nodes_observer_estimator.py",), select="thresholds_apply"),
    # -- the observer --------------------------------------------------------------------------
    Mutant("observer_std_under_reported", "the observer reports tau_f_std 30 % too small",
           "jointwear_ros/observer/segmentation.py", "measure_segment",
           expr("0.5 * math.hypot(ses[1], ses[-1], _coverage_bias(slopes, centres))",
                "0.35 * math.hypot(ses[1], ses[-1], _coverage_bias(slopes, centres))"),
           ("test/test_observer_core.py",), select="matches_scatter", fast=True,
           catchers=("test/test_observer_core.py::test_tau_f_std_matches_scatter_over_seeds",)),
    Mutant("observer_memory_trim_disabled", "the observer never trims its joint-state buffer",
           "jointwear_ros/observer/core.py", "FrictionObserverCore._trim",
           expr("math.isfinite(latest)", "False"),
           ("test/test_observer_core.py",), select="bounded", fast=True,
           catchers=("test/test_observer_core.py::test_memory_stays_bounded_when_a_speed_never_ends",)),
    Mutant("observer_impossible_temperature", "the observer uses physically impossible temperature readings",
           "jointwear_ros/observer/core.py", "FrictionObserverCore.on_temperature",
           expr("math.isfinite(celsius) and lo <= celsius <= hi", "math.isfinite(celsius)"),
           ("test/test_nodes_observer_estimator.py",), select="health"),
    Mutant("status_routed_to_another_joint", "a joint's status is routed to another joint's core",
           "jointwear_ros/observer/robot.py", "RobotObserver.route",
           expr("joint if joint in self.cores else None", "self.joints[0]"),
           ("test/test_nodes_robot.py",), select="robot_cycles"),
    # -- screening of observations -------------------------------------------------------------
    Mutant("observation_screening_off", "observations are not screened at all",
           "jointwear_ros/monitor/validation.py", "screen_observation",
           after("rng = dict(valid or {})", "return o, ''"),
           ("test/test_monitor.py",), select="impossible_temperature or non_physical or all_dropped", fast=True,
           catchers=("test/test_monitor.py::test_one_impossible_temperature_does_not_hide_the_alarm",)),
    Mutant("observation_temperature_bounds_widened", "the parameter set's temperature range is widened by 1 degC",
           "jointwear_ros/monitor/validation.py", "screen_observation",
           expr("lo <= t <= hi", "lo - 1.0 <= t <= hi + 1.0"),
           ("test/test_monitor_validation.py",), select="bounds_hold_exactly", fast=True,
           catchers=("test/test_monitor_validation.py::test_the_temperature_bounds_hold_exactly_on_both_sides",)),
    Mutant("plausible_temperature_bound_widened", "the plausible temperature range is widened by 1 degC below",
           "jointwear_ros/monitor/validation.py", "screen_observation",
           expr("plo <= t <= phi", "plo - 1.0 <= t <= phi"),
           ("test/test_monitor_validation.py",), select="bounds_hold_exactly", fast=True,
           catchers=("test/test_monitor_validation.py::test_the_temperature_bounds_hold_exactly_on_both_sides",)),
    # -- the test cycle ------------------------------------------------------------------------
    Mutant("motion_enabled_false_ignored", "motion_enabled := false at run time does not stop a running cycle",
           "jointwear_ros/nodes/test_cycle.py", "TestCycleNode._on_parameters",
           expr("self.runner.running and ...", "False"),
           ("test/test_nodes_sim_cycle.py",), select="motion_enabled_false"),
    Mutant("stale_state_wall_time_accepted", "a joint state stale in wall time is accepted (a dead simulator)",
           "jointwear_ros/nodes/test_cycle.py", "TestCycleNode._check_states",
           expr("wall_age > self.state_timeout_wall", "False"),
           ("test/test_nodes_sim_cycle.py",), select="simulator_that_died"),
    Mutant("crawl_speeds_accepted", "speeds below min_speed are planned",
           "jointwear_ros/cycle/plan.py", "plan_cycle",
           expr("v < config.min_speed", "False"),
           ("test/test_cycle_core.py",), select="crawl", fast=True,
           catchers=("test/test_cycle_core.py::test_plan_refuses_a_crawl_too_many_speeds_and_an_endless_cycle",)),
    Mutant("held_joints_not_watched", "the joints held while another is tested are not watched",
           "jointwear_ros/cycle/robot.py", "RobotCycleRunner.update",
           expr("self._hold_watchdog(j, now, readings.get(j), ages.get(j))", "None"),
           ("test/test_cycle_robot.py",), select="held", fast=True,
           catchers=("test/test_cycle_robot.py::test_a_fault_on_a_held_joint_fails_the_cycle_with_zero_for_all",)),
    Mutant("held_reference_follows_joint", "a held joint's reference follows the joint (a slow drift never trips)",
           "jointwear_ros/cycle/robot.py", "RobotCycleRunner._hold_watchdog",
           after("ref = self._hold.setdefault(j, r.position)", "self._hold[j] = r.position"),
           ("test/test_cycle_robot.py",), select="drifting_slowly", fast=True,
           catchers=("test/test_cycle_robot.py::test_a_held_joint_drifting_slowly_beyond_the_tolerance_fails_the_cycle",)),
    Mutant("held_movement_not_checked", "a held joint's movement is not checked",
           "jointwear_ros/cycle/robot.py", "RobotCycleRunner._hold_watchdog",
           expr("abs(r.position - ref) > self.hold_tolerance", "False"),
           ("test/test_cycle_robot.py",), select="held", fast=True,
           catchers=("test/test_cycle_robot.py::test_a_fault_on_a_held_joint_fails_the_cycle_with_zero_for_all",)),
    # -- the recorder and the history ----------------------------------------------------------
    Mutant("recorder_drops_every_1000th", "the recorder silently drops every 1000th message",
           "jointwear_ros/io/recording.py", "RecordingBag._write",
           stmts("""
                 self._writer.write(conn, stamp, item.data)
                 self._last = stamp
                 self.count += 1
                 """,
                 """
                 self.count += 1
                 if self.count % 1000 == 0:
                     return
                 self._writer.write(conn, stamp, item.data)
                 self._last = stamp
                 """),
           ("test/test_recorder.py",)),
    Mutant("history_whole_seconds", "the history stores times in whole seconds",
           "jointwear_ros/history/records.py", "EstimateRecord.time_ns",
           expr("round(self.time * 1e6) * 1000", "round(self.time) * 1_000_000_000"),
           ("test/test_history_store.py",), select="to_the_microsecond and sqlite", fast=True,
           catchers=("test/test_history_store.py::test_times_are_stored_to_the_microsecond_and_read_back_exactly",)),
    Mutant("history_screening_off", "estimates go into the history unscreened",
           "jointwear_ros/history/screen.py", "screen_record",
           before("cfg = cfg or ScreenConfig()", "return None"),
           ("test/test_cli_history.py",), select="bad_rows_never_hide", fast=True,
           catchers=("test/test_cli_history.py::test_bad_rows_never_hide_an_error_joint_and_each_is_reported_with_its_reason",)),
    # -- readers, estimators and the command line ----------------------------------------------
    Mutant("csv_nan_optional_column", "the CSV reader accepts NaN in an optional column",
           "jointwear_ros/io/tables.py", "read_csv",
           expr("not math.isfinite(v)", "not math.isfinite(v) and (name in _REQUIRED or not math.isnan(v))"),
           ("test/test_properties_io.py", "test/test_io_tables.py"), select="csv or nan", fast=True,
           catchers=("test/test_properties_io.py::test_nan_in_every_optional_csv_column_is_refused_with_the_column_named",)),  # the catching file first
    Mutant("csv_accepts_negative_speed", "the table readers accept a negative speed",
           "jointwear_ros/io/tables.py", "check_physical",
           expr("v < 0", "v < -1e300", inside='("speed", lambda v: v < 0, ...)'),
           ("test/test_properties_io.py", "test/test_cli_faults.py"), select="csv_reader_gives or negative_speed",
           fast=True),
    Mutant("estimator_checks_off", "the estimators' own value checks (check_observation_values) are skipped",
           "jointwear_ros/estimation/_common.py", "prepare_rows",
           stmts("check_observation_values(table, temperature=use_temperature)", "pass"),
           ("test/test_properties_estimators.py",), select="estimators_give", fast=True,
           catchers=("test/test_properties_estimators.py::test_estimators_give_a_finite_estimate_or_the_projects_error",)),
    Mutant("model_accepts_non_finite", "the model evaluates NaN/inf inputs silently",
           "jointwear_ros/model/model.py", "Model._inputs",
           expr("not np.isfinite(a).all()", "False"),
           ("test/test_properties_estimators.py",), select="model_evaluates", fast=True),
    Mutant("bound_quadrature_unguarded", "the bound is computed with an unresolved temperature quadrature",
           "jointwear_ros/estimation/crb.py", "temperature_nodes",
           expr("not math.isfinite(spread) or spread / float(noise_std) + _MIN_NODES > _MAX_NODES", "False"),
           ("test/test_properties_estimators.py",), select="quadrature", fast=True),
    Mutant("cli_output_dir_unchecked", "output directories are not checked before the work starts",
           "jointwear_ros/cli/common.py", "check_output_dir",
           before("p = Path(value)", "return Path(value)"),
           ("test/test_cli_faults.py",), select="output_path", fast=True),
    Mutant("cli_method_unchecked", "replay and demo start without checking --method",
           "jointwear_ros/cli/common.py", "check_method",
           expr("method is not None and str(method).strip().lower() not in ...", "False"),
           ("test/test_cli_faults.py",), select="method", fast=True,
           catchers=("test/test_cli_faults.py::test_replay_with_an_unknown_method_exits_2",)),
    # -- the trend: time to alarm -----------------------------------------------------------------
    Mutant("trend_evidence_ignored", "the model bank ignores each member's evidence (prior weights only)",
           "jointwear_ros/trend/states.py", "trend_states",
           expr("logprior + lev / cfg.evidence_temperature", "logprior + 0.0 * lev"),
           ("test/test_trend_bank.py",), select="accelerating_joint_moves_the_weight", fast=True),
    Mutant("trend_no_running_max", "the crossing probability may fall as the days ahead grow",
           "jointwear_ros/trend/alarm.py", "crossing_curves",
           expr("np.maximum.accumulate(ndtr(z), axis=1)", "ndtr(z)"),
           ("test/test_trend_bank.py",), select="never_falls", fast=True),
    Mutant("trend_warn_strict", "WARN only when the interval's lower bound is strictly inside the horizon",
           "jointwear_ros/trend/states.py", "trend_states",
           expr("qs[:, 0] <= cfg.horizon_days", "qs[:, 0] < cfg.horizon_days"),
           ("test/test_trend_bank.py",), select="backtests_nightly_warn", fast=True,
           catchers=("test/test_trend_bank.py::"
                     "test_the_backtests_nightly_warn_is_exactly_the_lower_bound_within_the_horizon_on_both_sides",)),
    Mutant("trend_error_strict", "the trend's ERROR uses > instead of >= at the alarm",
           "jointwear_ros/trend/states.py", "trend_states",
           expr("out['wear'] >= cfg.alarm", "out['wear'] > cfg.alarm"),
           ("test/test_trend_bank.py",), select="backtests_nightly_error", fast=True,
           catchers=("test/test_trend_bank.py::"
                     "test_the_backtests_nightly_error_is_exactly_the_trends_wear_at_or_above_the_alarm",)),
    Mutant("trend_no_step", "the steady members allow no unrecorded step (a reducer replaced unnoticed)",
           "jointwear_ros/trend/filters.py", "_steady_block",
           stmts("h = cfg.step_rate_per_day", "h = 0.0"),
           ("test/test_trend_bank.py",), select="step_without_a_maintenance_event", fast=True),
    Mutant("trend_no_process_noise", "the adaptive members forecast without their process noise",
           "jointwear_ros/trend/alarm.py", "forecast_basis",
           expr("m.q * tau ** 3 / 3 if m.order == 2 else m.q * tau ** 5 / 20", "0.0 * tau"),
           ("test/test_trend_bank.py",), select="adaptive_members_alone", fast=True),
    Mutant("trend_linear_accel_basis", "the accelerated shape's basis is a straight line",
           "jointwear_ros/trend/members.py", "steady_basis",
           expr("(efold * np.expm1(x), np.exp(x))", "(efold * x, np.ones_like(x))"),
           ("test/test_trend_bank.py",), select="accelerated_member_alone", fast=True),
    Mutant("trend_se_per_night", "the coverage's standard error counts nights, not joints",
           "jointwear_ros/trend/backtest.py", "_cluster_se",
           expr("int((n > 0).sum())", "int(n.sum())"),
           ("test/test_trend_bank.py",), select="standard_error_counts_joints", fast=True),
    Mutant("trend_type2_one_step", "the empirical-Bayes member weights stop after one EM step",
           "jointwear_ros/trend/prior.py", "type2_weights",
           expr("range(iterations)", "range(1)"),
           ("test/test_trend_bank.py",), select="type2_weights_maximize", fast=True),
    # -- guards no test held (issue 28): each with the test that now holds it ---------------------
    Mutant("history_std_min_lowered", "the history's minimum std lowered to 1e-9 (one row with std 1e-6 turned "
                                      "ERROR 38.9 into OK 0.0)",
           "jointwear_ros/history/screen.py", "ScreenConfig",
           stmts("std_min: float = 1e-3", "std_min: float = 1e-9"),
           ("test/test_faults28_guards.py",), select="std_1e_minus_6", fast=True),
    Mutant("commission_noise_at_floor", "a commissioned set keeps the noise floor as its noise std when the model "
                                        "misses an effect (estimates 2.3x overconfident)",
           "jointwear_ros/commission/core.py", "commission",
           expr("noise_std < fit.rmse and not nf.consistent", "False"),
           ("test/test_faults28_guards.py",), select="misses_an_effect", fast=True),
    Mutant("bound_tolerance_tight", "the bound detector's tolerance 1e-6 -> 1e-12 (a value a solver leaves beside "
                                    "its bound is not on it)",
           "jointwear_ros/model/scaling.py", "on_bound",
           expr("1e-6", "1e-12"),
           ("test/test_faults28_guards.py",), select="bound_detector", fast=True),
    Mutant("bound_tolerance_wide", "the bound detector's tolerance 1e-6 -> 1e-2 (a value 1 % inside its bound "
                                   "counts as on it)",
           "jointwear_ros/model/scaling.py", "on_bound",
           expr("1e-6", "1e-2"),
           ("test/test_faults28_guards.py",), select="bound_detector", fast=True),
    Mutant("spool_skipped_on_write_failure", "an estimate the store could not write (the store opened, the write "
                                             "failed) is not spooled: a kill loses it",
           "jointwear_ros/history/outbox.py", "Outbox.put",
           stmts("self._spool_append(rec)", "pass"),
           ("test/test_outbox.py",), select="fails_after_the_open", fast=True),
)


# --------------------------------------------------------------------------- running them


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


def copy_tree(dst: Path) -> None:
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".pytest_cache", ".hypothesis")
    for name in COPY:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, dst / name, ignore=ignore)
        elif src.is_file():
            shutil.copy2(src, dst / name)


def apply(m: Mutant, tree: Path) -> None:
    """Plant ``m`` in ``tree`` (a copy); :class:`Stale` when it cannot be placed."""
    f = tree / m.path
    if not f.is_file():
        raise Stale(f"{m.path} does not exist")
    try:
        f.write_text(mutate(f.read_text(), m.where, m.change))
    except Stale as exc:
        raise Stale(f"{m.path}: {exc}") from None


def catcher_problem(root: Path, nodeid: str) -> str:
    """Why the node id ``nodeid`` does not name a test function of ``root``'s suite ("" when it does).

    Read from the file's syntax tree (the test module is not imported): ``test/file.py::test_name`` or
    ``test/file.py::TestClass::test_name``, a function (all its parameters: ``-x`` stops at the first that
    fails), not one of its parameters.
    """
    path, _, rest = nodeid.partition("::")
    names = rest.split("::") if rest else []
    if not names or not all(names):
        return f"{nodeid!r}: expected file.py::test_function"
    if "[" in names[-1]:
        return f"{nodeid!r}: name the test function, not one of its parameters"
    f = root / path
    if not f.is_file():
        return f"{nodeid!r}: {path} does not exist"
    scope: list[ast.stmt] = ast.parse(f.read_text(encoding="utf-8")).body
    for i, name in enumerate(names):
        last = i == len(names) - 1
        kinds = (ast.FunctionDef, ast.AsyncFunctionDef) if last else (ast.ClassDef,)
        found = [n for n in scope if isinstance(n, kinds) and n.name == name]
        if len(found) != 1:
            what = "test function" if last else "test class"
            return f"{nodeid!r}: {path} defines no {what} {name!r}" if not found else \
                f"{nodeid!r}: {path} defines {name!r} {len(found)} times"
        if not name.startswith("test" if last else "Test"):
            return f"{nodeid!r}: {name!r} is not collected as a test (its name)"
        scope = getattr(found[0], "body", [])
    return ""


#: Third-party modules the tests of nearly every mutant import besides pytest and its plugins (measured: all
#: fifteen of the suite's import numpy, fourteen yaml, ten scipy's base, three scipy.stats, whose docstrings
#: alone take 0.8 s to load: 1.3 s once instead of 2.4 s for those three). A mutant without a ROS graph runs its
#: tests in a fork of this process once it has loaded them (:func:`preload`) instead of in a new interpreter that
#: loads them again: about half the CPU of a mutant whose catcher takes a tenth of a second. Never the package:
#: each fork imports the mutated copy's.
PRELOAD = ("numpy", "scipy", "scipy.stats", "yaml")
#: pytest's warning that a plugin loaded before it started cannot have its asserts rewritten: true of the
#: preloaded plugins (hypothesis, anyio, ...) in every fork, and of no concern (their own asserts, not the tests').
_PRELOADED_PLUGINS = "ignore:Module already imported so cannot be rewritten:pytest.PytestAssertRewriteWarning"
#: a forked run's exit code when its tests imported the package from somewhere else than the mutated copy
_NOT_THE_COPY = 70


def preload() -> bool:
    """Load pytest, its plugins and :data:`PRELOAD` once, to fork test runs from; False if forking cannot be used
    (no ``os.fork``, or the package is already imported here and a fork would test it instead of the copy)."""
    if not hasattr(os, "fork") or _imports_the_package():
        return False
    import importlib
    import importlib.metadata

    import pytest  # noqa: F401

    for ep in importlib.metadata.entry_points(group="pytest11"):
        try:
            ep.load()
        except Exception:  # pytest reports a plugin that does not load, in the fork
            pass
    for name in PRELOAD:
        try:
            importlib.import_module(name)
        except ImportError:
            pass
    return not _imports_the_package()


def _imports_the_package() -> bool:
    return any(k == "jointwear_ros" or k.startswith("jointwear_ros.") for k in sys.modules)


def _forked_pytest(tree: Path, args: list[str], env: dict[str, str], out: int) -> int:
    """Run ``pytest args`` in a fork of this process, in ``tree`` with ``env``, its output into the file ``out``."""
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid:
        return pid
    code = 3  # pytest's internal error: the fork failed before the tests ran
    try:
        os.setsid()  # its own process group: a timeout ends whatever the tests started too
        os.dup2(out, 1)
        os.dup2(out, 2)
        os.chdir(tree)
        os.environ.clear()
        os.environ.update(env)
        here = Path(__file__).resolve().parent
        # as `python -m pytest` in tree: the copy first; tools/ (this script's folder) is no test's path
        sys.path[:] = [str(tree), *(p for p in sys.path if p and Path(p).resolve() != here)]
        import pytest

        code = int(pytest.main(args))
        pkg = sys.modules.get("jointwear_ros")
        if pkg is not None and not str(getattr(pkg, "__file__", "")).startswith(str(tree)):
            print(f"mutation: the tests imported jointwear_ros from {getattr(pkg, '__file__', '?')}, not from the "
                  "mutated copy")
            code = _NOT_THE_COPY
    except BaseException:  # whatever it is, the parent reads it from the output
        import traceback

        traceback.print_exc()
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)


class _Run:
    """One mutant's test run under way: its copy, its process (a fork or an interpreter) and its output file."""

    def __init__(self, m: Mutant, python: str, timeout: float, *, catchers: bool, fork: bool):
        self.m, self.t0, self.timeout = m, time.monotonic(), timeout
        self.tmp = tempfile.TemporaryDirectory(prefix=f"mutation-{m.name}-")
        self.out = tempfile.TemporaryFile()
        self.pid, self.proc = 0, None
        try:
            tree = Path(self.tmp.name)
            copy_tree(tree)
            apply(m, tree)
            env = dict(os.environ)
            env["PYTHONPATH"] = str(tree) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
            env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
            env.setdefault("MPLBACKEND", "Agg")
            which = list(m.catchers) if catchers else (["-k", m.select] if m.select else []) + list(m.tests)
            args = ["-q", "-x", "-rf", "-p", "no:cacheprovider", *which]
            if fork:
                self.pid = _forked_pytest(tree, ["-W", _PRELOADED_PLUGINS, *args], env, self.out.fileno())
            else:
                self.proc = subprocess.Popen([python, "-m", "pytest", *args], cwd=tree, env=env, stdout=self.out,
                                             stderr=subprocess.STDOUT, start_new_session=True)
        except BaseException:
            self.close()
            raise

    def outcome(self, status: str, caught_by: list[str] | None = None, detail: str = "") -> Outcome:
        return Outcome(self.m.name, self.m.description, status, caught_by or [], time.monotonic() - self.t0, detail)

    def poll(self) -> Outcome | None:
        """The outcome once the tests have ended (or run out of time), else None."""
        if self.proc is not None:
            rc = self.proc.poll()
        else:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            rc = None if pid == 0 else os.waitstatus_to_exitcode(status)
        if rc is None:
            if time.monotonic() - self.t0 < self.timeout:
                return None
            self.close()
            return self.outcome("TIMEOUT", detail=f"tests still running after {self.timeout:g} s")
        self.out.seek(0)
        out = self.out.read().decode(errors="replace")
        self.close()
        failed = re.findall(r"^FAILED (\S+)", out, flags=re.M)
        if rc == 0:
            return self.outcome("SURVIVED")
        if rc == 1 and failed:
            return self.outcome("caught", failed)
        # 2-5 (collection error, no tests selected, ...) is a broken mutant, not a catch
        tail = " | ".join(out.strip().splitlines()[-5:])
        return self.outcome("ERROR", failed, f"pytest exit code {rc}: {tail}")

    def close(self) -> None:
        """End the run's processes if still running, remove its copy."""
        pid = self.proc.pid if self.proc is not None else self.pid
        if pid:
            try:
                os.killpg(pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            if self.proc is not None:
                self.proc.wait()
            else:
                try:
                    os.waitpid(pid, 0)
                except ChildProcessError:
                    pass
            self.pid, self.proc = 0, None
        self.out.close()
        self.tmp.cleanup()


def run_mutants(mutants: list[Mutant], python: str, timeout: float, *, catchers: bool = False, jobs: int = 1,
                fork: bool = True) -> Iterator[Outcome]:
    """Plant each mutant in a copy of its own and run its tests there, ``jobs`` at once; yield the outcomes as
    they come. ``catchers``: only the tests known to catch a mutant, where given, instead of its test files.

    A mutant caught without a ROS graph (``fast``) runs in a fork of this process (:func:`preload`) when
    ``python`` is this interpreter (and ``fork``); the others in ``python -m pytest``, one at a time (their ROS
    graphs would meet on a domain).
    """
    same = fork and Path(python).resolve() == Path(sys.executable).resolve()
    can_fork: bool | None = None
    probed = False
    queue: list[Mutant] = list(mutants)
    running: list[_Run] = []

    def may_start(m: Mutant) -> bool:
        if not m.fast or any(not r.m.fast for r in running):
            return not running
        return len(running) < jobs

    try:
        while queue or running:
            while queue and may_start(queue[0]):
                m = queue.pop(0)
                use = catchers and bool(m.catchers)  # a mutant without catchers runs its test files
                why = next((w for w in (catcher_problem(ROOT, n) for n in m.catchers) if w), "") if use else ""
                if why:
                    yield Outcome(m.name, m.description, "STALE", [], 0.0, why)
                    continue
                if can_fork is None and m.fast and same:
                    can_fork = preload()
                forked = bool(m.fast and same and can_fork)
                if not forked and not probed:
                    check_copy_is_used(python)
                    probed = True
                try:
                    running.append(_Run(m, python, timeout, catchers=use, fork=forked))
                except Stale as exc:
                    yield Outcome(m.name, m.description, "STALE", [], 0.0, str(exc))
            for r in list(running):
                o = r.poll()
                if o is not None:
                    running.remove(r)
                    yield o
            if running:
                time.sleep(0.02)
    finally:
        for r in running:
            r.close()


def run_one(m: Mutant, python: str, timeout: float, *, catchers: bool = False) -> Outcome:
    """Plant ``m`` in a copy and run its tests there (``catchers``: only the tests known to catch it, if given)."""
    return next(iter(run_mutants([m], python, timeout, catchers=catchers)))


def check_copy_is_used(python: str) -> None:
    """The mutated copy must shadow the installed package (an editable install must not win)."""
    with tempfile.TemporaryDirectory(prefix="mutation-probe-") as tmp:
        tree = Path(tmp)
        shutil.copytree(ROOT / "jointwear_ros", tree / "jointwear_ros",
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        env = dict(os.environ, PYTHONPATH=str(tree))
        r = subprocess.run([python, "-c", "import jointwear_ros; print(jointwear_ros.__file__)"], cwd=tree, env=env,
                           capture_output=True, text=True, timeout=120)
        if not r.stdout.strip().startswith(str(tree)):
            raise SystemExit(f"mutation: the copy is not imported (got {r.stdout.strip() or r.stderr.strip()}); "
                             "cannot check mutants")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true", help="print JSON")
    ap.add_argument("--only", action="append", default=[], metavar="NAME", help="run only this mutant (repeatable)")
    ap.add_argument("--fast", action="store_true", help="only the mutants caught without a ROS graph")
    ap.add_argument("--catchers", action="store_true",
                    help="run only the tests known to catch each mutant (its catchers; the suite's check) instead "
                         "of its test files, where given")
    ap.add_argument("--list", action="store_true", help="list the mutants and exit")
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per mutant (default 900)")
    ap.add_argument("--python", default=sys.executable, help="interpreter with the test dependencies")
    ap.add_argument("--no-fork", dest="fork", action="store_false",
                    help="run every mutant's tests in a new interpreter (by default those without a ROS graph run in "
                         "a fork of this process, pytest and numpy loaded once)")
    ap.add_argument("--jobs", type=int, default=1,
                    help="mutants run at once (default 1); mutants with ROS tests always run one at a time")
    args = ap.parse_args(argv)
    unknown = set(args.only) - {m.name for m in MUTANTS}
    if unknown:
        print(f"mutation: unknown mutant(s) {', '.join(sorted(unknown))}; see --list", file=sys.stderr)
        return 2
    chosen = [m for m in MUTANTS if (not args.only or m.name in args.only) and (not args.fast or m.fast)]
    if args.list:
        for m in chosen:
            print(f"{m.name:36s} {'fast' if m.fast else 'ros '}  {m.path}:{m.where}  {m.description}")
        return 0
    results: list[Outcome] = []

    def report(o: Outcome) -> None:
        results.append(o)
        if not args.json:
            what = f"caught by {o.caught_by[0]}" if o.status == "caught" else o.status
            print(f"{o.status:8s} {o.seconds:5.0f} s  {o.name}: {what}{'; ' + o.detail if o.detail else ''}",
                  flush=True)

    # the fast ones first, jobs at once; then the others one at a time (their ROS graphs would meet on a domain)
    order = [m for m in chosen if m.fast] + [m for m in chosen if not m.fast] if args.jobs > 1 else chosen
    for o in run_mutants(order, args.python, args.timeout, catchers=args.catchers, jobs=args.jobs,
                         fork=args.fork):
        report(o)
    caught = sum(o.status == "caught" for o in results)
    if args.json:
        print(json.dumps({"mutations": [o.to_dict() for o in results], "caught": caught, "total": len(results)},
                         indent=2))
    else:
        print(f"{caught} of {len(results)} planted bugs caught")
        bad = [o.name for o in results if o.status != "caught"]
        if bad:
            print("not caught: " + ", ".join(bad), file=sys.stderr)
    if any(o.status in ("STALE", "ERROR", "TIMEOUT") for o in results):
        return 2
    return 0 if caught == len(results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
