"""``jointwear demo --commission --arm none`` on a real graph, small: one independent joint (``cobot-j3``), four
baseline cycles (the default runs on the UR5: ``test_commission_arm*.py`` and docs/nodes-bag-demo.md).

The five node processes of the demo run one cycle that fails on purpose (its window's gravity load trips
test_cycle's effort limit), four baseline cycles at w = 0 while the joint warms up and its window load
changes, and one test cycle at wear 10. The contract: the failed cycle is skipped and named (state, joint,
reason) and never commissioned on; the joint is commissioned into a set file that loads; the test cycle's
estimate with that set lies within 3 of its standard deviations of the true wear; ``--json`` gives the keys
of the issue's contract. About a minute of wall time (six cycles of six speeds at 3x real time).

The sets are commissioned with ``--wear-calibration paper``: the simulated joints wear by the paper's Eq. (8)
in their own units, so that calibration is the truth here and the test checks the demo's path (cell, skip,
commissioning, estimate). The default calibration's scale on joints unlike the paper's is measured by the full
run (docs/nodes-bag-demo.md), not here.

The demo runs on this module's ROS domain; ``JOINTWEAR_TEST_DOMAIN`` pins another (a developer's own run).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("rclpy")

pytestmark = [pytest.mark.ros]

SPEEDS = "10,20,40,80,120,160"
CONTRACT = {"joint", "true_wear", "estimate", "std", "reference_estimate", "parameter_set"}


@pytest.fixture(scope="module")
def run(tmp_path_factory, ros_domain_of_the_module):
    out = tmp_path_factory.mktemp("commission")
    domain = os.environ.get("JOINTWEAR_TEST_DOMAIN") or str(ros_domain_of_the_module)
    proc = subprocess.run(
        [sys.executable, "-m", "jointwear_ros", "demo", "--commission", "--arm", "none", "--joints", "1",
         "--baseline-cycles", "4",
         "--speeds", SPEEDS, "--test-wear", "10", "--wear-calibration", "paper",
         "--json", "--out", str(out / "demo"), "--domain-id", domain],
        capture_output=True, text=True, timeout=240)
    return proc, out


def test_the_commissioning_demo_exits_0_with_the_contract_keys(run):
    proc, _ = run
    assert proc.returncode == 0, proc.stderr[-3000:]
    doc = json.loads(proc.stdout)
    assert len(doc["commissioned"]) == 1
    entry = doc["commissioned"][0]
    assert CONTRACT <= set(entry)
    assert entry["joint"] == "joint_1" and entry["true_wear"] == 10.0 and entry["simulated_set"] == "cobot-j3"
    assert entry["wear_calibration"] == "paper"
    assert doc["wall_seconds"] > 0 and doc["cell_seconds"] > 0


def test_each_estimate_with_the_commissioned_set_is_within_3_std_of_the_truth(run):
    proc, _ = run
    for e in json.loads(proc.stdout)["commissioned"]:
        assert e["std"] > 0
        assert abs(e["estimate"] - e["true_wear"]) <= 3.0 * e["std"], e
        assert e["reference_estimate"] is not None  # ref-2011r's estimate of the same cycle (the before)


def test_the_written_set_loads_and_names_its_baseline_cycles(run):
    from jointwear_ros.model import load_parameter_set_info

    proc, _ = run
    e = json.loads(proc.stdout)["commissioned"][0]
    pset = load_parameter_set_info(e["parameter_set"])
    assert pset.provenance["joint"] == "joint_1" and pset.provenance["cycles"] == 4
    assert Path(e["parameter_set"]).name == "joint_1.yaml"
    assert len(e["baseline_cycles"]) == 4


def test_a_cycle_that_tripped_the_effort_limit_is_skipped_and_named(run):
    proc, _ = run
    doc = json.loads(proc.stdout)
    skipped = doc["skipped_cycles"]
    assert skipped, "the overloaded cycle should have failed"
    first = skipped[0]
    assert first["stage"] == "overload" and first["state"] == "FAILED" and first["joint"] == "joint_1"
    assert "effort" in first["reason"] and first["node"] == "test_cycle"
    for s in skipped:  # never commissioned on
        assert s["cycle_id"] not in doc["commissioned"][0]["baseline_cycles"]
    assert f"{first['stage']} cycle {first['cycle_id']} FAILED at joint_1" in proc.stderr


def test_commissioning_demo_arguments_are_checked_before_anything_starts(tmp_path, capsys):
    from jointwear_ros.cli import main

    for args, match in ((["--wear", "10"], "--wear"), (["--baseline-cycles", "3"], "--baseline-cycles"),
                        (["--speeds", "10,20,40"], "at least 5"), (["--test-wear", "120"], "outside 0-100"),
                        (["--joints", "13"], "--joints"), (["--wear-calibration", "nope"], "--wear-calibration")):
        rc = main(["demo", "--commission", *args, "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert rc == 2 and match in err, (args, err)
        assert not (tmp_path / "o").exists()
