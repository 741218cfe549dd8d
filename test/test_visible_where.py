"""Nothing stored out of sight (issue 28, item 3): every command that writes estimates says where (robot, joints,
analysis version, store) and the command that shows them; ``trend`` names the analysis versions in the store and
which one it shows; a robot name taken from a folder is said to be; a rerun with another ``--robot`` is refused
with the reason; ``replay`` compares like with like; ``history export`` leaves no ``.part`` behind."""

from __future__ import annotations

import csv
import json
import shlex

import pytest

from jointwear_ros.cli import main as cli_main
from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_cycle_bag, write_fleet


def run(argv, capsys):
    rc = cli_main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return rc, out, err


def see_command(line: str) -> list[str]:
    """The arguments of the ``jointwear ...`` command a ``see them:`` line prints."""
    words = shlex.split(line.split("see them:", 1)[1])
    assert words[0] == "jointwear"
    return words[1:]


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    """Two nights of two joints of robot_01, recorded with the joint method (settings in the bags)."""
    root = tmp_path_factory.mktemp("visible")
    return write_fleet(root / "archive", fleet_specs(1, 2, 2, rates=(0.0, 1.0), start_wear=15.0, method="joint"))


@pytest.fixture(scope="module")
def bare_bags(tmp_path_factory):
    """Two bags in a folder named ``bags`` that record no settings and no robot (an old recorder)."""
    root = tmp_path_factory.mktemp("bare") / "bags"
    root.mkdir()
    return [write_cycle_bag(root / s.name, s, parameters=False)
            for s in fleet_specs(1, 1, 2, rates=(0.5,), start_wear=15.0, method="paper")]


def test_history_import_reestimate_says_where_it_stored_and_the_trend_command_shows_them(bags, tmp_path, capsys):
    db = tmp_path / "h.db"
    rc, out, _ = run(["history", "import", *bags, "--db", db, "--reestimate", "--method", "bayes"], capsys)
    assert rc == 0
    where = [ln for ln in out.splitlines() if ln.startswith("stored in ")]
    assert len(where) == 1, out
    assert "robot robot_1 (the default name: give --robot to set it)" in where[0]
    assert "joint(s) joint_1, joint_2" in where[0] and "analysis version bayes:ref-2011r:" in where[0]
    see = next(ln for ln in out.splitlines() if "see them:" in ln)
    argv = see_command(see)
    assert argv[:3] == ["trend", "--db", str(db)] and "--analysis-version" in argv
    # the printed command shows exactly what was stored
    rc, shown, _ = run(argv, capsys)
    assert rc == 0 and "joint_1" in shown and "joint_2" in shown and "robot_1" in shown
    # the same in JSON, with the robot given this time (no default said)
    rc, out, _ = run(["history", "import", *bags, "--db", db, "--reestimate", "--method", "bayes", "--robot",
                      "cell_7", "--json"], capsys)
    stored = json.loads(out)["stored"]
    assert [(g["robot"], g["joints"], g["robot_from"]) for g in stored] == [
        ("cell_7", ["joint_1", "joint_2"], "given or in the table")]
    assert stored[0]["analysis_version"].startswith("bayes:ref-2011r:") and stored[0]["estimates"] == len(bags)
    assert stored[0]["see"] == shlex.join(["jointwear", "trend", "--db", str(db), "--robot", "cell_7",
                                           "--analysis-version", stored[0]["analysis_version"]])


def test_history_import_of_recorded_estimates_says_where_they_are(tmp_path, capsys):
    table = tmp_path / "est.csv"
    table.write_text("joint,time,wear,wear_std\njoint_3,2026-03-01T02:00:00Z,12.5,1.5\n", encoding="utf-8")
    rc, out, _ = run(["history", "import", table, "--db", tmp_path / "h.db", "--robot", "cell_2"], capsys)
    assert rc == 0
    assert f"stored in {tmp_path / 'h.db'}: robot cell_2, joint(s) joint_3, analysis version live: 1" in out
    assert (f"see them: jointwear trend --db {tmp_path / 'h.db'} --robot cell_2 --analysis-version live") in out


def test_trend_names_the_versions_in_the_store_and_which_one_it_shows(bags, tmp_path, capsys):
    db = tmp_path / "h.db"
    assert run(["history", "import", *bags, "--db", db, "--reestimate", "--method", "bayes", "--json"], capsys)[0] == 0
    # only a re-estimated version, no live estimates: trend shows it (it used to say "no estimates") and says why
    rc, out, _ = run(["trend", "--db", db], capsys)
    assert rc == 0 and "joint_1" in out and "joint_2" in out
    assert "analysis version bayes:ref-2011r:" in out and "the only analysis version in the store" in out
    rc, out, _ = run(["trend", "--db", db, "--json"], capsys)
    data = json.loads(out)
    assert len(data["joints"]) == 2 and data["analysis_version"].startswith("bayes:ref-2011r:")
    assert [v["estimates"] for v in data["analysis_versions"]] == [len(bags)]
    # live estimates too: live is shown by default, and the other version is named with how to see it
    table = tmp_path / "live.csv"
    table.write_text("robot,joint,time,wear,wear_std\nrobot_1,joint_1,2026-01-05T02:00:00Z,15.0,1.0\n",
                     encoding="utf-8")
    assert run(["history", "import", table, "--db", db], capsys)[0] == 0
    rc, out, _ = run(["trend", "--db", db], capsys)
    line = next(ln for ln in out.splitlines() if ln.startswith("analysis version "))
    assert line.startswith("analysis version live (1 estimates; the default: the estimates the cell made)")
    assert f"also in the store: {data['analysis_version']} ({len(bags)} estimates)" in line
    rc, out, _ = run(["trend", "--db", db, "--json"], capsys)
    bayes = data["analysis_version"]
    data = json.loads(out)
    assert data["analysis_version"] == "live" and data["analysis_version_why"].startswith("the default")
    assert {v["name"]: v["estimates"] for v in data["analysis_versions"]} == {"live": 1, bayes: len(bags)}


def test_trend_with_several_versions_and_no_live_ones_asks_which(bags, tmp_path, capsys):
    db = tmp_path / "h.db"
    for m in ("bayes", "paper"):
        assert run(["history", "import", *bags, "--db", db, "--reestimate", "--method", m, "--json"], capsys)[0] == 0
    rc, out, err = run(["trend", "--db", db], capsys)
    assert rc == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "bayes:ref-2011r:" in err and "paper:ref-2011r:" in err and "--analysis-version" in err


@pytest.fixture(scope="module")
def folder_run(bare_bags, tmp_path_factory):
    """``fleet reprocess`` of the bare bags without --robot: (db, the command's words, its text output)."""
    import contextlib
    import io

    db = tmp_path_factory.mktemp("folder_run") / "h.db"
    base = ["fleet", "reprocess", *map(str, bare_bags), "--db", str(db), "--params", "ref-2011r", "--method",
            "paper", "--workers", "1", "--quiet"]
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert cli_main(base) == 0
    return db, base, buf.getvalue()


def test_fleet_reprocess_says_a_robot_name_came_from_a_folder_and_where_it_stored(bare_bags, folder_run, capsys):
    _db, _base, out = folder_run
    folder = bare_bags[0].parent
    assert f"robot name 'bags' taken from folder {folder} (its bags record no robot); use --robot to set it" in out
    where = next(ln for ln in out.splitlines() if ln.startswith("stored in "))
    assert "robot bags, joint(s) joint_1, analysis version ref-2011r/paper/" in where
    rc, shown, _ = run(see_command(next(ln for ln in out.splitlines() if "see them:" in ln)), capsys)
    assert rc == 0 and "bags" in shown and "joint_1" in shown


def test_fleet_reprocess_rerun_with_another_robot_is_refused_with_the_reason(folder_run, capsys):
    """Decided: refused, not re-attributed. The store keeps every estimate it wrote (no renaming path), so a
    rerun of the same analysis version under another name would leave the bags under 'bags' and skip them;
    the refusal names where they are and the two ways to get them under the new name."""
    db, base, _ = folder_run
    rc, out, err = run([*base, "--robot", "cell_7"], capsys)
    assert rc == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "--robot cell_7: 2 of these bags were already re-analysed" in err and "under robot bags" in err
    assert "--label" in err
    from jointwear_ros.history import HistoryStore

    with HistoryStore(f"sqlite:///{db}") as store:
        assert {r.robot for r in store.estimates(analysis_version=None)} == {"bags"}
    # a plain rerun says where the skipped bags' estimates are
    rc, out, _ = run(base, capsys)
    assert rc == 0 and "2 skipped" in out and "the skipped bags were done before" in out
    assert "stored in " in out and "robot bags, joint(s) joint_1" in out
    # with the name they were stored under: skipped, and said so
    rc, out, _ = run([*base, "--robot", "bags"], capsys)
    assert rc == 0 and "the skipped bags' estimates are already stored under robot bags (2 bag(s))" in out
    # the way the refusal names: a new label stores them under cell_7
    rc, out, _ = run([*base, "--robot", "cell_7", "--label", "cell7-paper", "--json"], capsys)
    data = json.loads(out)
    assert rc == 0 and data["robot_from_folder"] == [] and data["estimates"] == 2
    assert [(g["robot"], g["analysis_version"], g["joints"]) for g in data["stored"]] == [
        ("cell_7", "cell7-paper", ["joint_1"])]


# --------------------------------------------------------------------------- replay: like with like


def _bag_with_recorded_estimate(tmp_path_factory, name: str, **changes):
    """The replay tests' synthetic bag, its recorded WearEstimate changed by ``changes``."""
    from dataclasses import replace

    from test_replay import _estimate_msg, _synthetic, _write

    _path, _obs, res, msgs, store = _synthetic(tmp_path_factory)
    rec = replace(res, result=replace(res.result, **{k: getattr(res.result, k) + v for k, v in changes.items()}))
    path = tmp_path_factory.mktemp(name) / "bag"
    _write(path, store, [*msgs, _estimate_msg(store, rec)])
    return path, res


def test_replay_reports_the_wear_difference_not_the_largest_of_unlike_quantities(tmp_path_factory, capsys):
    path, _res = _bag_with_recorded_estimate(tmp_path_factory, "wear_off", wear=0.85, wear_high=3.96)
    rc, out, _ = run(["replay", path, "--json"], capsys)
    est = json.loads(out)["comparison"]["estimates"]
    assert rc == 0 and est["paired"] == 1 and len(est["differ"]) == 1
    assert est["max_abs_diff"] == pytest.approx(0.85, abs=1e-9)  # the wear's, not the upper bound's 3.96
    assert est["max_abs_diff_by_field"]["wear_high"] == pytest.approx(3.96, abs=1e-9)
    rc, out, _ = run(["replay", path], capsys)
    assert "max |wear diff| 0.85" in out and "estimates differ by: wear 0.85, wear_std 0, wear_low 0, wear_high 3.96" \
        in out


def test_replay_with_another_method_is_not_compared_as_a_reproduction(tmp_path_factory, capsys):
    path, res = _bag_with_recorded_estimate(tmp_path_factory, "other_method")
    assert res.result.method == "joint"
    rc, out, _ = run(["replay", path, "--method", "paper", "--json"], capsys)
    data = json.loads(out)
    est = data["comparison"]["estimates"]
    assert rc == 0 and est["paired"] == 0 and est["differ"] == [] and est["max_abs_diff"] is None
    (other,) = est["other_method"]
    assert (other["replayed_method"], other["recorded_method"]) == ("paper", "joint")
    assert other["wear_diff"] == pytest.approx(data["wear"]["estimate"] - res.result.wear, abs=1e-12)
    rc, out, _ = run(["replay", path, "--method", "paper"], capsys)
    assert "DIFFER" not in out and "max |wear diff|" not in out
    assert "estimates of another method, not compared as a reproduction (1): replayed with paper where the cell " \
           "ran joint" in out
    assert f"joint_1 cycle 1: wear {data['wear']['estimate']:.2f} (paper) vs {res.result.wear:.2f} recorded (joint)" \
        in out


# --------------------------------------------------------------------------- history export: no .part left


@pytest.fixture
def history_db(tmp_path, capsys):
    table = tmp_path / "est.csv"
    rows = "".join(f"robot_1,joint_1,2026-03-{d:02d}T02:00:00Z,{10 + d * 0.1},1.0\n" for d in range(1, 11))
    table.write_text("robot,joint,time,wear,wear_std\n" + rows, encoding="utf-8")
    db = tmp_path / "h.db"
    assert run(["history", "import", table, "--db", db], capsys)[0] == 0
    return db


def test_history_export_to_a_directory_is_refused_and_leaves_no_part_file(history_db, tmp_path, capsys):
    out_dir = tmp_path / "DIR"
    out_dir.mkdir()
    rc, _out, err = run(["history", "export", "--db", history_db, "--out", out_dir], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "is a directory" in err
    assert not list(tmp_path.glob("*.part")) and not list(out_dir.iterdir())


def test_history_export_failing_midway_leaves_no_part_file_and_the_old_table(history_db, tmp_path, capsys,
                                                                             monkeypatch):
    out = tmp_path / "history.csv"
    assert run(["history", "export", "--db", history_db, "--out", out], capsys)[0] == 0
    before = out.read_bytes()
    import jointwear_ros.history.importers as importers

    real_writer = csv.writer

    class FullDisk:
        def __init__(self, fh):
            self.w, self.n = real_writer(fh), 0

        def writerow(self, row):
            self.n += 1
            if self.n > 4:
                raise OSError(28, "No space left on device")
            return self.w.writerow(row)

    monkeypatch.setattr(importers.csv, "writer", FullDisk)
    rc, _, err = run(["history", "export", "--db", history_db, "--out", out], capsys)
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "No space left on device" in err
    assert not list(tmp_path.glob("*.part")) and out.read_bytes() == before
