"""Bag discovery counts each bag once and says what it skipped; fleet reprocess says which settings it used
per bag, refuses to guess, takes --robot, writes nothing for a bag that does not exist, and stops on Ctrl-C
with one line; history import reports one bad bag and imports the others (issues 20 and 24)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from jointwear_ros.cli import main as cli_main
from jointwear_ros.errors import InputDataError
from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_fleet
from jointwear_ros.history import HistoryStore
from jointwear_ros.io.bags import discover_bags


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    root = tmp_path_factory.mktemp("disc")
    paths = write_fleet(root / "archive", fleet_specs(1, 2, 2, rates=(0.0, 1.0), start_wear=15.0, method="joint"))
    return root, paths


def test_a_glob_matching_a_bag_and_the_mcap_inside_counts_the_bag_once(bags, tmp_path):
    root, paths = bags
    sel = discover_bags([str(root / "archive" / "**" / "robot_*")])
    assert sorted(p.resolve() for p in sel.bags) == sorted(p.resolve() for p in paths)
    # the folder, its .mcap and its metadata.yaml, named separately and twice: still one bag each
    one = paths[0]
    sel = discover_bags([str(one), str(next(one.glob("*.mcap"))), str(one / "metadata.yaml"), str(one)])
    assert [p.resolve() for p in sel.bags] == [one.resolve()]
    # what is not a bag is reported with the reason, never silently dropped
    (tmp_path / "empty").mkdir()
    (tmp_path / "notes.txt").write_text("x")
    sel = discover_bags([str(one), str(tmp_path / "*")])
    assert [p.resolve() for p in sel.bags] == [one.resolve()]
    reasons = {Path(s["path"]).name: s["reason"] for s in sel.skipped}
    assert set(reasons) == {"empty", "notes.txt"} and "no metadata.yaml" in reasons["empty"]
    with pytest.raises(InputDataError, match="no such file or bag directory"):
        discover_bags([str(tmp_path / "missing")])
    with pytest.raises(InputDataError, match="no bag matches"):
        discover_bags([str(tmp_path / "none*")])


def test_a_bag_folder_without_metadata_is_a_failed_bag_not_left_out(bags, tmp_path, capsys):
    _root, paths = bags
    broken = tmp_path / "robot_x_n9"
    broken.mkdir()
    (broken / "robot_x_n9.mcap").write_bytes(next(paths[0].glob("*.mcap")).read_bytes())
    sel = discover_bags([str(tmp_path / "*")])
    assert [p.name for p in sel.bags] == ["robot_x_n9"]
    db = tmp_path / "h.db"
    assert cli_main(["fleet", "reprocess", str(paths[0]), str(broken), "--db", str(db), "--workers", "1",
                     "--quiet", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bags"] == 2 and out["processed"] == 1
    assert [Path(f["bag"]).name for f in out["failed"]] == ["robot_x_n9"]
    assert "bag recover" in out["failed"][0]["error"]


def test_reprocess_says_the_settings_per_bag_and_robot_given_lines_up_with_history_import(bags, tmp_path, capsys):
    root, paths = bags
    db = tmp_path / "h.db"
    glob = str(root / "archive" / "**" / "robot_*")
    assert cli_main(["fleet", "reprocess", glob, "--db", str(db), "--robot", "cell_7", "--workers", "1",
                     "--quiet", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["bags"] == len(paths) and out["processed"] == len(paths) and not out["failed"]
    assert len(out["settings"]) == len(paths)
    for s in out["settings"]:
        assert (s["robot"], s["robot_from"]) == ("cell_7", "given")
        assert (s["method"], s["method_from"], s["params_from"], s["estimator"]) == ("joint", "recorded", "recorded",
                                                                                     "recorded")
    assert cli_main(["history", "import", *map(str, paths), "--db", str(db), "--robot", "cell_7", "--reestimate",
                     "--json"]) == 0
    capsys.readouterr()
    with HistoryStore(f"sqlite:///{db}") as store:
        versions = {r.analysis_version: {(r.robot, r.joint) for r in store.estimates(analysis_version=r.analysis_version)}
                    for r in store.estimates(analysis_version=None)}
    assert len(versions) == 2 and len({frozenset(v) for v in versions.values()}) == 1  # the same joints
    # the table says the same in words
    assert cli_main(["fleet", "reprocess", glob, "--db", str(tmp_path / "t.db"), "--workers", "1", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "joint (recorded)" in text and "robot_01 (recorded)" in text


def test_a_bag_without_recorded_settings_is_refused_unless_params_and_method_are_given(bags, tmp_path, capsys):
    _root, _paths = bags
    # the same bag with its /parameter_events left out (a recorder started after the nodes, an old bag)
    from jointwear_ros.fleet.synthetic_bags import write_cycle_bag

    spec = fleet_specs(1, 1, 1, rates=(0.0,), start_wear=15.0, method="paper")[0]
    bare = write_cycle_bag(tmp_path / "bare", spec, parameters=False)
    db = tmp_path / "h.db"
    assert cli_main(["fleet", "reprocess", str(bare), "--db", str(db), "--workers", "1", "--quiet", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["processed"] == 0 and "give --params and --method" in out["failed"][0]["error"]
    assert cli_main(["fleet", "reprocess", str(bare), "--db", str(db), "--workers", "1", "--quiet", "--json",
                     "--method", "paper", "--params", "ref-2011r"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["processed"] == 1 and out["settings"][0]["estimator"] == "config"
    assert (out["settings"][0]["method_from"], out["settings"][0]["params_from"]) == ("given", "given")


def test_a_missing_bag_gives_exit_2_and_creates_no_history(tmp_path, capsys):
    db = tmp_path / "new.db"
    assert cli_main(["fleet", "reprocess", str(tmp_path / "no_such_bag"), "--db", str(db)]) == 2
    err = capsys.readouterr().err
    assert "no such file or bag directory" in err and len(err.strip().splitlines()) == 1
    assert not db.exists()


def test_history_import_reports_one_bad_bag_and_imports_the_others(bags, tmp_path, capsys):
    _root, paths = bags
    broken = tmp_path / "robot_01_bad"
    broken.mkdir()
    (broken / "metadata.yaml").write_text("rosbag2_bagfile_information: {version: 9}\n")
    db = tmp_path / "h.db"
    assert cli_main(["history", "import", *map(str, paths), str(broken), "--db", str(db), "--reestimate",
                     "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["added"] == len(paths) and [Path(f["file"]).name for f in out["failed"]] == ["robot_01_bad"]
    # every input is checked before any work: a bad method is refused at once, nothing written
    assert cli_main(["history", "import", *map(str, paths), "--db", str(tmp_path / "x.db"), "--reestimate",
                     "--method", "bayse"]) == 2
    assert "unknown wear estimation method" in capsys.readouterr().err and not (tmp_path / "x.db").exists()


@pytest.mark.slow
def test_ctrl_c_during_fleet_reprocess_prints_one_line(tmp_path):
    paths = write_fleet(tmp_path / "bags", fleet_specs(2, 2, 10, rates=(0.0, 1.5), start_wear=15.0, method="joint"))
    p = subprocess.Popen([sys.executable, "-m", "jointwear_ros", "fleet", "reprocess", str(tmp_path / "bags"),
                          "--db", str(tmp_path / "c.db"), "--workers", "2"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                         env=dict(os.environ))
    while True:  # wait for the line saying the workers are up and Ctrl-C is handled, then Ctrl-C the process group
        line = p.stderr.readline()
        assert line, "reprocess ended before it said it was ready"
        if line.startswith("reprocess: ") and "ready" in line:
            break
    os.killpg(p.pid, signal.SIGINT)
    _out, err = p.communicate(timeout=120)
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("reprocess")]
    assert p.returncode == 130 and lines == ["jointwear: interrupted"], err
    assert len(paths) == 40
