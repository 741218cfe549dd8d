"""The history CLI under faults (issue 20): one line on stderr and exit 2, nothing written, or the bad row refused
and reported; a reader that never writes; a newer schema refused."""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path

import pytest
from sqlalchemy import text

from jointwear_ros.cli import main as cli_main
from jointwear_ros.history import EstimateRecord, HistoryStore

DAY = 86400.0


def run(args, capsys):
    rc = cli_main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


def _one_line_exit_2(rc, err, says):
    assert rc == 2 and says in err and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err and "internal error" not in err


@pytest.fixture
def db(tmp_path) -> Path:
    p = tmp_path / "h.db"
    now = time.time()
    with HistoryStore(p) as s:
        s.add_estimates([EstimateRecord("cell_7", "joint_3", cycle_id=i, time=now - (20 - i) * DAY, wear=20.0 + 0.1 * i,
                                        wear_std=0.7) for i in range(20)])
    return p


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


@pytest.mark.parametrize(("cell", "says"), [("nan", "cycle_id = 'nan' is not an integer"),
                                            ("inf", "cycle_id = 'inf' is not an integer"),
                                            ("-inf", "cycle_id = '-inf' is not an integer")])
def test_a_csv_cycle_id_nan_or_inf_is_one_line_exit_2(cell, says, tmp_path, capsys):
    p = tmp_path / "c.csv"
    p.write_text(f"robot,joint,time,wear,wear_std,cycle_id\nr,j,1700000000,3,1,{cell}\n")
    rc, _, err = run(["history", "import", p, "--db", tmp_path / "h.db"], capsys)
    _one_line_exit_2(rc, err, says)


def test_a_csv_time_far_ahead_is_refused_and_reported_not_overflowed(tmp_path, capsys):
    p = tmp_path / "c.csv"
    p.write_text("robot,joint,time,wear,wear_std\nr,j,99999999999,3,1\n")  # year 5138: passed the old check
    rc, out, err = run(["history", "import", p, "--db", tmp_path / "h.db", "--json"], capsys)
    info = json.loads(out)
    assert rc == 0 and info["added"] == 0 and [f["reason"] for f in info["refused"]] == ["time_in_future"], err
    with HistoryStore(tmp_path / "h.db") as s:
        assert s.count() == 0 and [r["reason"] for r in s.refused()] == ["time_in_future"]


@pytest.mark.parametrize("page", [1, 0])  # page 1 (data), 0: every page after the header page
def test_a_damaged_database_page_is_one_line_exit_2_and_import_writes_nothing(page, db, tmp_path, capsys):
    csv_ = tmp_path / "more.csv"
    csv_.write_text(f"robot,joint,time,wear,wear_std\ncell_7,joint_3,{time.time() - 60:.3f},25,0.7\n")
    size = db.stat().st_size
    with db.open("r+b") as fh:
        fh.seek(4096 * max(page, 1))
        fh.write(bytes([0x55]) * (4096 if page else size - 4096))
    before = _sha(db)
    outcomes = []
    for args in (["trend", "--db", db], ["history", "export", "--db", db, "--out", tmp_path / "e.csv"],
                 ["history", "import", csv_, "--db", db]):
        rc, _, err = run(args, capsys)
        assert rc in (0, 2) and "internal error" not in err and "Traceback" not in err, err
        if rc == 2:
            _one_line_exit_2(rc, err, str(db.name))
        outcomes.append(rc)
    assert 2 in outcomes  # the damage is seen by at least one reader
    if outcomes[2] == 2:
        assert _sha(db) == before  # import refused: not a byte written


@pytest.mark.parametrize("url", ["mysql://u@h/d", "mongodb://x/y", "oracle://a"])
def test_an_unsupported_database_url_scheme_is_one_line_exit_2(url, tmp_path, capsys):
    for args in (["trend", "--db", url], ["history", "export", "--db", url, "--out", tmp_path / "e.csv"],
                 ["history", "maintenance", "--db", url, "--robot", "r", "--joint", "j", "--kind", "regrease"]):
        rc, _, err = run(args, capsys)
        _one_line_exit_2(rc, err, "is not supported")


def test_a_maintenance_event_in_the_future_or_of_a_misspelt_joint_is_refused(db, capsys):
    base = ["history", "maintenance", "--db", db, "--robot", "cell_7", "--kind", "regrease"]
    rc, _, err = run([*base, "--joint", "joint_3", "--time", str(time.time() + 30 * DAY)], capsys)
    _one_line_exit_2(rc, err, "days in the future")
    rc, _, err = run([*base, "--joint", "jiont_3"], capsys)
    _one_line_exit_2(rc, err, "'jiont_3' of robot 'cell_7' has no estimates")
    assert "its joints: joint_3" in err
    with HistoryStore(db) as s:
        assert s.maintenance() == []
    rc, out, _ = run([*base, "--joint", "joint_9", "--new-joint"], capsys)
    assert rc == 0 and "recorded" in out
    rc, out, _ = run(["trend", "--db", db, "--json"], capsys)
    assert json.loads(out)["joints"][0]["estimates"] == 20


def test_trend_on_an_empty_database_gives_user_advice(tmp_path, capsys):
    import sqlite3

    p = tmp_path / "empty.db"
    sqlite3.connect(p).close()
    rc, _, err = run(["trend", "--db", p], capsys)
    _one_line_exit_2(rc, err, "holds no history yet (fill it with jointwear history import")
    assert "create=True" not in err


def test_a_database_of_a_newer_schema_is_refused_in_one_line(db, tmp_path, capsys):
    with HistoryStore(db) as s, s.engine.begin() as conn:
        conn.execute(text("INSERT INTO schema_version (version, applied_ns) VALUES (7, 0)"))
    before = _sha(db)
    csv_ = tmp_path / "more.csv"
    csv_.write_text(f"robot,joint,time,wear,wear_std\ncell_7,joint_3,{time.time() - 60:.3f},25,0.7\n")
    for args in (["trend", "--db", db], ["history", "import", csv_, "--db", db]):
        rc, _, err = run(args, capsys)
        _one_line_exit_2(rc, err, "schema version 7 was written by a newer jointwear")
    assert _sha(db) == before


def test_trend_and_export_read_without_writing_or_leaving_files(db, tmp_path, capsys):
    """A reader that may only read (another user, a read-only filesystem) must leave no -wal/-shm files that
    block the owner's writes, and must not change the file."""
    before = _sha(db)
    rc, out, _ = run(["trend", "--db", db, "--json"], capsys)
    assert rc == 0 and json.loads(out)["joints"][0]["estimates"] == 20
    rc, _, _ = run(["history", "export", "--db", db, "--out", tmp_path / "e.csv"], capsys)
    assert rc == 0
    assert sorted(p.name for p in db.parent.iterdir() if p.name.startswith("h.db")) == ["h.db"]
    assert _sha(db) == before
    # while a writer holds it open (its -wal exists) the reader joins read-only and sees the writer's rows
    with HistoryStore(db) as w:
        w.add_estimates([EstimateRecord("cell_7", "joint_3", cycle_id=99, time=time.time() - 10, wear=22.0,
                                        wear_std=0.7)])
        assert Path(str(db) + "-wal").exists()
        with HistoryStore(db, read_only=True) as r:
            assert r.count() == 21
            with pytest.raises(Exception, match="read-only"):
                r.add_estimates([EstimateRecord("cell_7", "joint_3", 5, time.time(), 1.0, 1.0)])


def test_bag_recover_of_an_mcap_named_from_its_own_folder(tmp_path, monkeypatch, capsys):
    from rosbags.rosbag2 import StoragePlugin, Writer

    from jointwear_ros.io.typestore import jointwear_typestore

    store = jointwear_typestore()
    bag = tmp_path / "b1"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection("/x", "std_msgs/msg/String", typestore=store)
        w.write(c, 5_000_000_000, store.serialize_cdr(store.types["std_msgs/msg/String"](data="x"),
                                                       "std_msgs/msg/String"))
    monkeypatch.chdir(bag)
    rc, out, err = run(["bag", "recover", "b1.mcap"], capsys)
    assert rc == 0 and "recovered 1 message(s)" in out, err
    assert (tmp_path / "b1_recovered" / "metadata.yaml").is_file()
    # a scalar metadata.yaml: one line naming it, for every reader
    monkeypatch.chdir(tmp_path)
    (bag / "metadata.yaml").write_text("5\n")
    for args in (["bag", "info", bag], ["history", "import", bag, "--db", tmp_path / "h.db"], ["replay", bag]):
        rc, _, err = run(args, capsys)
        _one_line_exit_2(rc, err, "metadata.yaml: not rosbag2 metadata")
