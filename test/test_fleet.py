"""Fleet re-analysis on Dask: recorded bags into the wear history (SQLite and a real PostgreSQL server),
idempotent and resumable, a broken bag reported and skipped; versions compared; the fleet page."""

from __future__ import annotations

import json
import logging
import shutil
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from jointwear_ros.cli import main as cli_main
from jointwear_ros.errors import InputDataError
from jointwear_ros.fleet import analysis_version, bag_fingerprint, expand_bags, reprocess_bag
from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_fleet
from jointwear_ros.history import HistoryStore

ROBOTS, JOINTS, NIGHTS = 2, 2, 5  # 20 bags
RATES = (0.0, 1.5)  # wear per night: a flat joint and a growing one


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """20 nightly bags of 2 robots x 2 joints in the recorder's format, plus one corrupt (truncated) bag."""
    root = tmp_path_factory.mktemp("fleet")
    specs = fleet_specs(ROBOTS, JOINTS, NIGHTS, rates=RATES, start_wear=15.0, method="joint")
    bags = write_fleet(root / "bags", specs)
    broken = root / "bags" / "robot_01" / "robot_01_joint_9_n0000"
    shutil.copytree(bags[0], broken)
    mcap = next(broken.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    return root, specs, bags, broken


@pytest.fixture(scope="module")
def scheduler():
    """One Dask LocalCluster (2 single-thread worker processes) for the module; its address."""
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                           scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},  # no fixed port 8787
                           silence_logs=logging.ERROR)
    client = Client(cluster)
    yield cluster.scheduler_address
    client.close()
    cluster.close()


def _run(args: list[str], capsys) -> dict:
    assert cli_main(args) == 0, capsys.readouterr().err
    return json.loads(capsys.readouterr().out)


def _check_first_and_second_run(url: str, fleet, scheduler, capsys) -> None:
    root, specs, bags, broken = fleet
    glob = str(root / "bags" / "*" / "*")
    out = _run(["fleet", "reprocess", glob, "--db", url, "--scheduler", scheduler, "--json", "--quiet"], capsys)
    assert out["bags"] == 21 and out["estimates"] == 20 and out["skipped"] == 0
    assert out["workers"] == 2
    assert [f["bag"] for f in out["failed"]] == [str(broken.resolve())]
    # the bag check names the file and the byte where the truncated bag ends, and the way out
    assert "unfinished at byte" in out["failed"][0]["error"] and "bag recover" in out["failed"][0]["error"]
    assert str(broken.resolve()) in out["failed"][0]["error"]
    version = out["analysis_version"]
    with HistoryStore(url) as store:
        recs = store.estimates(analysis_version=version)
        assert len(recs) == 20 and store.count() == 20
        by_bag = {r.bag: r for r in recs}
        for spec, bag in zip(specs, bags):
            r = by_bag[str(bag.resolve())]
            assert (r.robot, r.joint, r.cycle_id, r.method) == (spec.robot, spec.joint, 1, "joint")
            assert r.time == pytest.approx(spec.t0, abs=600.0)
            assert 0 < r.wear_std < 6.0
            assert abs(r.wear - spec.wear) < 4 * r.wear_std
            assert r.analysis_version == version and r.source == "reprocess"
    again = _run(["fleet", "reprocess", glob, "--db", url, "--scheduler", scheduler, "--json", "--quiet"], capsys)
    assert again["estimates"] == 0 and again["skipped"] == 20 and len(again["failed"]) == 1
    assert again["analysis_version"] == version
    with HistoryStore(url) as store:
        assert store.count() == 20


@pytest.mark.slow
def test_reprocess_of_20_bags_gives_20_estimates_once_and_reports_the_broken_bag(fleet, scheduler, db_url, capsys):
    """On an SQLite file and on a real PostgreSQL server (test/conftest.py's ``db_url``)."""
    _check_first_and_second_run(db_url, fleet, scheduler, capsys)


@pytest.mark.slow
def test_an_interrupted_reprocess_resumes_where_it_stopped(fleet, scheduler, tmp_path, capsys):
    root, _, bags, _broken = fleet
    url = f"sqlite:///{tmp_path / 'h.db'}"
    # the first run on a LocalCluster of its own (the default), the second on the module's cluster
    first = _run(["fleet", "reprocess", *map(str, bags[:7]), "--db", url, "--workers", "2", "--json", "--quiet"],
                 capsys)
    assert first["estimates"] == 7 and first["failed"] == [] and first["workers"] == 2
    rest = _run(["fleet", "reprocess", str(root / "bags"), "--db", url, "--scheduler", scheduler, "--json"], capsys)
    assert rest["bags"] == 21 and rest["skipped"] == 7 and rest["estimates"] == 13 and len(rest["failed"]) == 1


@pytest.mark.slow
def test_a_new_parameter_set_is_a_new_analysis_version_and_compare_names_the_changes(fleet, scheduler, tmp_path,
                                                                                     capsys):
    _root, _specs, bags, _ = fleet
    url = f"sqlite:///{tmp_path / 'h.db'}"
    base = ["fleet", "reprocess", *map(str, bags), "--db", url, "--scheduler", scheduler, "--json", "--quiet"]
    a = _run([*base, "--label", "before"], capsys)
    b = _run([*base, "--params", "paper-printed"], capsys)
    assert a["analysis_version"] == "before" and b["analysis_version"].startswith("paper-printed/recorded/")
    assert a["estimates"] == b["estimates"] == 20
    with HistoryStore(url) as store:
        assert store.count("before") == 20 and store.count(b["analysis_version"]) == 20
        after = {(r.robot, r.joint, r.time): r for r in store.estimates(analysis_version=b["analysis_version"])}
        for r in store.estimates(analysis_version="before"):
            # the printed set's wear coefficient is 10x: the same friction increase is a 10x smaller wear
            assert after[(r.robot, r.joint, r.time)].params == "paper-printed"
            assert after[(r.robot, r.joint, r.time)].wear < 0.5 * r.wear
    cmp_ = _run(["fleet", "compare", "--db", url, "--from", "before", "--to", b["analysis_version"], "--json"], capsys)
    assert cmp_["joints"] == ROBOTS * JOINTS and len(cmp_["changed"]) == ROBOTS * JOINTS
    for c in cmp_["changed"]:
        assert c["wear"]["change"] < -5.0 and c["wear"]["change"] == pytest.approx(c["wear"]["to"] - c["wear"]["from"])
        assert any(r.startswith("wear ") for r in c["reasons"])
    same = _run(["fleet", "compare", "--db", url, "--from", "before", "--to", "before", "--json"], capsys)
    assert same["joints"] == ROBOTS * JOINTS and same["changed"] == []
    # the fleet page: every joint ranked, its plot, and the changes
    assert cli_main(["fleet", "report", "--db", url, "--out", str(tmp_path / "page")]) == 0
    page = (tmp_path / "page" / "index.html").read_text()
    for r in range(ROBOTS):
        for j in range(JOINTS):
            slug = f"robot_{r + 1:02d}__joint_{j + 1}"
            assert f"id='{slug}'" in page and (tmp_path / "page" / "img" / f"{slug}.png").stat().st_size > 1000
    assert page.count("<tr class=") >= ROBOTS + ROBOTS * JOINTS + ROBOTS * JOINTS
    assert f"{ROBOTS * JOINTS} of {ROBOTS * JOINTS} joints changed" in page
    assert (tmp_path / "page" / "img" / "changes.png").is_file()


def test_reprocess_bag_never_raises_for_broken_bags(fleet, tmp_path):
    _root, _, bags, broken = fleet
    (tmp_path / "notabag").mkdir()
    (tmp_path / "garbled").mkdir()
    (tmp_path / "garbled" / "metadata.yaml").write_text("rosbag2_bagfile_information: [1, 2\n")
    for path, says in [(broken, "unfinished at byte"), (tmp_path / "missing", "no such"),
                       (tmp_path / "notabag", "not a rosbag2 bag"), (tmp_path / "garbled", "")]:
        out = reprocess_bag(path, method="paper")
        assert out.error is not None and says in out.error and out.records == [], (path, out.error)
        assert "\n" not in out.error
    good = reprocess_bag(bags[0], method="paper")
    assert good.error is None and len(good.records) == 1 and good.fingerprint == bag_fingerprint(bags[0])


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(offset=st.floats(0.0, 1.0), length=st.integers(1, 4096), byte=st.integers(0, 255))
def test_reprocess_bag_of_a_damaged_mcap_gives_an_error_or_records_never_an_exception(fleet, tmp_path, offset,
                                                                                      length, byte):
    _, _, bags, _ = fleet
    target = Path(tempfile.mkdtemp(dir=tmp_path)) / "bag"  # one per example (tmp_path is per test)
    shutil.copytree(bags[1], target)
    mcap = next(target.glob("*.mcap"))
    data = bytearray(mcap.read_bytes())
    start = int(offset * (len(data) - 1))
    data[start:start + length] = bytes([byte]) * len(data[start:start + length])
    mcap.write_bytes(bytes(data))
    out = reprocess_bag(target, method="paper")
    assert (out.error is None) or (out.records == [] and "\n" not in out.error)
    for r in out.records:
        assert r["wear_std"] > 0


def test_analysis_version_follows_the_parameter_set_content(tmp_path):
    from jointwear_ros.model.paramsets import load_parameter_set_info

    src = load_parameter_set_info("ref-2011r").path
    mine = tmp_path / "ref-2011r.yaml"
    mine.write_text(src.read_text())
    assert analysis_version(str(mine), "joint").split("/")[-1] == analysis_version(str(mine), "joint").split("/")[-1]
    v1 = analysis_version(str(mine), "joint")
    mine.write_text(src.read_text().replace("Fc0: 0.04", "Fc0: 0.041"))
    assert "Fc0: 0.041" in mine.read_text()
    assert analysis_version(str(mine), "joint") != v1
    assert analysis_version(str(mine), "joint", "9.9") != analysis_version(str(mine), "joint")
    assert analysis_version(None, None, label="x") == "x"


def test_expand_bags_takes_globs_and_directories_of_bags(fleet, tmp_path):
    root, _, _bags, _ = fleet
    got = expand_bags([str(root / "bags" / "robot_01"), str(root / "bags" / "*" / "robot_01_*")])
    assert len(got) == NIGHTS * JOINTS + 1  # robot_01's bags and the broken one, each once
    with pytest.raises(InputDataError, match="no bag matches"):
        expand_bags([str(tmp_path / "none*")])


@pytest.mark.parametrize(("args", "says"), [
    (["--workers", "0"], "--workers: 0 must be between 1 and 1024"),
    (["--workers", "two"], "--workers: 'two' is not a whole number"),
    (["--method", "magic"], "--method: unknown method 'magic'"),
    (["--params", "no-such-set"], "no-such-set"),
    (["--label", " "], "label"),
])
def test_reprocess_rejects_bad_arguments_with_one_line(fleet, tmp_path, capsys, args, says):
    _, _, bags, _ = fleet
    db = tmp_path / "h.db"
    rc = cli_main(["fleet", "reprocess", str(bags[0]), "--db", f"sqlite:///{db}", *args])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and err.startswith("jointwear: error: ") and says in err
    assert not db.exists()  # nothing written


def test_compare_and_report_reject_a_missing_history_and_an_unknown_version(tmp_path, capsys):
    for args in (["fleet", "compare", "--db", str(tmp_path / "no.db"), "--from", "a", "--to", "b"],
                 ["fleet", "report", "--db", str(tmp_path / "no.db"), "--out", str(tmp_path / "o")]):
        assert cli_main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "no such history file" in err
    db = tmp_path / "h.db"
    HistoryStore(f"sqlite:///{db}").close()
    assert cli_main(["fleet", "compare", "--db", str(db), "--from", "a", "--to", "b"]) == 2
    assert "analysis version 'a' is not in" in capsys.readouterr().err
    assert cli_main(["fleet", "report", "--db", str(db), "--out", str(tmp_path / "o")]) == 2
    assert "no estimates" in capsys.readouterr().err


def test_scheduler_that_is_not_there_is_a_one_line_error(fleet, tmp_path, capsys):
    _, _, bags, _ = fleet
    rc = cli_main(["fleet", "reprocess", str(bags[0]), "--db", str(tmp_path / "h.db"), "--scheduler",
                   "tcp://127.0.0.1:9", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "cannot connect to a Dask scheduler" in err
    assert "ConnectionRefusedError" in err  # nothing listens there: said at once, not after the client's timeout


def test_progress_bar_counts_done_failed_and_skipped_bags():
    import io

    from jointwear_ros.fleet import Progress

    out = io.StringIO()
    bar = Progress(20, stream=out)
    bar.update(skipped=5)
    for _ in range(14):
        bar.update(done=1)
    bar.update(failed=1)
    bar.close()
    lines = out.getvalue().splitlines()
    assert 2 <= len(lines) <= 11  # a line per tenth of the work off a terminal, and the last
    assert "20/20 bags: 14 done, 1 failed, 5 skipped" in lines[-1] and "bags/s" in lines[-1]
    quiet = io.StringIO()
    Progress(3, stream=quiet, enabled=False).update(done=3)
    assert quiet.getvalue() == ""


def test_one_worker_reanalyses_in_this_process_with_the_clusters_numbers(fleet, scheduler, tmp_path):
    """``--workers 1`` starts no cluster (the bags in the command's own process) and gives what the cluster gives."""
    from jointwear_ros.fleet import reprocess

    _, _, bags, broken = fleet
    chosen = [*bags[:3], broken]
    with HistoryStore(f"sqlite:///{tmp_path / 'here.db'}") as a, HistoryStore(f"sqlite:///{tmp_path / 'dask.db'}") as b:
        here = reprocess(chosen, a, workers=1)
        there = reprocess(chosen, b, scheduler=scheduler)
        rows = [[(r.robot, r.joint, r.cycle_id, r.time, r.wear, r.wear_std, r.bag) for r in s.estimates(
            analysis_version=here.analysis_version)] for s in (a, b)]
    assert (here.workers, here.scheduler) == (1, "") and (there.workers, there.scheduler) == (2, scheduler)
    assert here.estimates == there.estimates == 3 and rows[0] == rows[1] and len(rows[0]) == 3
    assert here.failed == there.failed and [f["bag"] for f in here.failed] == [str(broken.resolve())]
