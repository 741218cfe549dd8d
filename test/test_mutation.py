"""The planted-bug check (tools/mutation.py): every mutant still finds its place in the source, the
placing is by name and syntax (not text), and the mutants caught without a ROS graph are caught, each
by the tests named as its catchers (which must exist). The full run, ROS-level mutants and whole test
files, is ``make mutation``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import mutation  # noqa: E402

FAST = [m.name for m in mutation.MUTANTS if m.fast]
#: The planted bugs the suite itself checks (seconds): those caught by tests of the pure cores (the trend
#: backtest's nightly WARN/ERROR boundaries included), the
#: CSV reader's NaN, the estimators' value checks and the CLI's --method. The other fast ones
#: (readers, model, bound, output paths) and the ROS-level ones run with ``make mutation``.
IN_SUITE = ["alarm_ge_to_gt_level", "observer_std_under_reported", "observer_memory_trim_disabled",
            "observation_screening_off", "observation_temperature_bounds_widened",
            "plausible_temperature_bound_widened", "crawl_speeds_accepted", "held_joints_not_watched",
            "held_reference_follows_joint", "held_movement_not_checked", "history_whole_seconds",
            "history_screening_off", "csv_nan_optional_column", "estimator_checks_off", "cli_method_unchecked",
            "trend_warn_strict", "trend_error_strict"]


@pytest.mark.parametrize("m", mutation.MUTANTS, ids=[m.name for m in mutation.MUTANTS])
def test_every_mutant_applies_to_the_current_source(m, tmp_path):
    (tmp_path / m.path).parent.mkdir(parents=True)
    (tmp_path / m.path).write_text((ROOT / m.path).read_text())
    mutation.apply(m, tmp_path)
    assert (tmp_path / m.path).read_text() != (ROOT / m.path).read_text()
    for t in m.tests:
        assert (ROOT / t).is_file(), t


@pytest.mark.parametrize("name", IN_SUITE)
def test_each_mutant_the_suite_runs_names_the_tests_that_catch_it_and_they_exist(name):
    """The suite's run (``--catchers``) runs only these node ids: each must name a test function of one of the
    mutant's own test files (those the full run runs), or the run would check nothing."""
    m = next(m for m in mutation.MUTANTS if m.name == name)
    assert m.catchers, f"{name}: no catchers"
    for nodeid in m.catchers:
        assert nodeid.split("::")[0] in m.tests, nodeid
        assert mutation.catcher_problem(ROOT, nodeid) == ""


@pytest.mark.parametrize("nodeid, why", [
    ("test/test_mutation.py::test_gone", "defines no test function 'test_gone'"),
    ("test/test_nope.py::test_x", "does not exist"),
    ("test/test_mutation.py::TestNone::test_x", "defines no test class 'TestNone'"),
    ("test/test_mutation.py", "expected file.py::test_function"),
    ("test/test_mutation.py::test_the_mutants_are_named_once_and_each_bug_is_planted_once[x]", "not one of its parameters"),
    ("test/test_mutation.py::_an_example_helper", "not collected as a test"),
])
def test_a_catcher_that_names_no_test_function_is_refused_with_the_reason(nodeid, why):
    assert why in mutation.catcher_problem(ROOT, nodeid)
    assert mutation.catcher_problem(ROOT, "test/test_mutation.py::test_a_catcher_that_names_no_test_function_is_"
                                          "refused_with_the_reason") == ""


def test_mutants_are_not_forked_from_a_process_that_already_imported_the_package():
    """A fork would test the package it has instead of the mutated copy: where it is imported (here: conftest
    imports it), the mutants run in new interpreters."""
    assert "jointwear_ros" in sys.modules
    assert mutation.preload() is False


def _an_example_helper():
    """Not a test (its name): a catcher naming it is refused."""


def test_the_mutants_are_named_once_and_each_bug_is_planted_once():
    names = [m.name for m in mutation.MUTANTS]
    assert len(names) == len(set(names))
    places = [(m.path, m.where, m.change) for m in mutation.MUTANTS]
    assert len(places) == len(set(places))


SOURCE = '''
class Node:
    def publish(self, res, r):
        """Docstring."""
        m = object()
        m.alarm = bool(res.wear >= r.alarm_threshold)  # a comment
        return m

    def other(self, res, r):
        return res.wear >= r.alarm_threshold
'''


def test_a_mutant_is_placed_by_name_and_syntax_whatever_the_formatting():
    change = mutation.expr("res.wear >= r.alarm_threshold", "res.wear > r.alarm_threshold")
    out = mutation.mutate(SOURCE, "Node.publish", change)
    assert "m.alarm = bool((res.wear > r.alarm_threshold))  # a comment" in out
    assert "return res.wear >= r.alarm_threshold" in out  # the other method is not touched
    reformatted = SOURCE.replace("bool(res.wear >= r.alarm_threshold)", "bool(\n            res.wear  >=  r.alarm_threshold\n        )")
    assert "res.wear > r.alarm_threshold" in mutation.mutate(reformatted, "Node.publish", change)
    top = mutation.mutate(SOURCE, "Node.publish", mutation.prepend("return None"))
    assert '"""Docstring."""\n        return None\n        m = object()' in top


@pytest.mark.parametrize("where, change, why", [
    ("Node.gone", mutation.expr("res.wear", "0"), "defined 0 times"),
    ("Node.publish", mutation.expr("res.wear < 0", "True"), "found 0 times"),
    ("Node", mutation.expr("res.wear >= r.alarm_threshold", "True"), "found 2 times"),
    ("Node.publish", mutation.after("m = object()", "x = ("), "does not parse"),
])
def test_a_mutant_whose_place_is_gone_or_ambiguous_is_stale_with_the_reason(where, change, why):
    with pytest.raises(mutation.Stale, match=why):
        mutation.mutate(SOURCE, where, change)


@pytest.mark.slow
def test_the_planted_bugs_of_the_pure_cores_readers_and_cli_are_caught():
    assert set(IN_SUITE) <= set(FAST)
    r = subprocess.run([sys.executable, str(ROOT / "tools" / "mutation.py"), "--json", "--jobs", "2", "--catchers",
                        *[a for n in IN_SUITE for a in ("--only", n)]],
                       capture_output=True, text=True, timeout=1800, cwd=ROOT)
    doc = json.loads(r.stdout)
    got = {d["mutation"]: d for d in doc["mutations"]}
    assert set(got) == set(IN_SUITE)
    catchers = {m.name: m.catchers for m in mutation.MUTANTS}
    for n in IN_SUITE:
        assert got[n]["status"] == "caught", got[n]
        assert got[n]["caught_by"], got[n]
        assert got[n]["caught_by"][0].partition("[")[0] in catchers[n], got[n]  # by the tests named for it
    assert r.returncode == 0, r.stderr
