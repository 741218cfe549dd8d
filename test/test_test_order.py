"""The suite's order: the costliest test files first, each file's tests together and in their own order.

``tools/test_costs.py`` sums each file's seconds from JUnit reports into ``test/file_costs.json``;
``conftest._costliest_files_first`` orders the collected tests by it, so pytest-xdist's workers
(``--dist loadfile --no-loadscope-reorder``) take the long files first.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import SimpleNamespace

import conftest

ROOT = Path(__file__).resolve().parent.parent


def _tool():
    spec = importlib.util.spec_from_file_location("test_costs_tool", ROOT / "tools" / "test_costs.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


JUNIT = """<?xml version="1.0" encoding="utf-8"?>
<testsuites><testsuite name="pytest">
<testcase classname="test.test_a" name="test_one" time="1.5"/>
<testcase classname="test.test_a" name="test_two" time="1.0"/>
<testcase classname="test.test_b.TestGroup" name="test_three" time="7.4"/>
<testcase classname="test.test_c" name="test_quick" time="0.2"/>
</testsuite></testsuites>
"""


def test_the_tool_sums_each_files_seconds_and_leaves_out_the_cheap_ones(tmp_path):
    (tmp_path / "r.xml").write_text(JUNIT)
    (tmp_path / "s.xml").write_text(JUNIT.replace('time="7.4"', 'time="0.6"'))
    assert _tool().file_costs([tmp_path / "r.xml"]) == {"test_a.py": 2, "test_b.py": 7}
    assert _tool().file_costs([tmp_path / "r.xml", tmp_path / "s.xml"]) == {"test_a.py": 5, "test_b.py": 8}


def test_a_report_that_is_not_xml_is_one_line_and_exit_2(tmp_path, capsys):
    (tmp_path / "bad.xml").write_text("not xml")
    assert _tool().main([str(tmp_path / "bad.xml"), "--check"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_the_costliest_files_come_first_with_each_files_tests_in_their_own_order(tmp_path, monkeypatch):
    costs = tmp_path / "file_costs.json"
    costs.write_text(json.dumps({"test_slow.py": 90, "test_mid.py": 12}))
    monkeypatch.setattr(conftest, "FILE_COSTS", costs)

    def item(f, n):
        return SimpleNamespace(path=tmp_path / f, name=n)

    items = [item("test_a.py", "1"), item("test_mid.py", "1"), item("test_mid.py", "2"), item("test_b.py", "1"),
             item("test_slow.py", "1"), item("test_slow.py", "2"), item("test_a.py", "2")]
    conftest._costliest_files_first(items)
    assert [(i.path.name, i.name) for i in items] == [
        ("test_slow.py", "1"), ("test_slow.py", "2"), ("test_mid.py", "1"), ("test_mid.py", "2"),
        ("test_a.py", "1"), ("test_a.py", "2"), ("test_b.py", "1")]


def test_without_costs_the_order_is_the_collections(tmp_path, monkeypatch):
    monkeypatch.setattr(conftest, "FILE_COSTS", tmp_path / "none.json")
    items = [SimpleNamespace(path=tmp_path / f, name="x") for f in ("test_b.py", "test_a.py", "test_b.py")]
    before = list(items)
    conftest._costliest_files_first(items)
    assert items == before


def test_the_shipped_costs_name_test_files_that_exist():
    costs = json.loads((ROOT / "test" / "file_costs.json").read_text())
    assert costs and all((ROOT / "test" / f).is_file() for f in costs), sorted(f for f in costs
                                                                                if not (ROOT / "test" / f).is_file())
    assert all(isinstance(s, int) and s >= 2 for s in costs.values())
