"""The wear history store on SQLite and on a real PostgreSQL server: idempotence, concurrency, migrations, trends."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from sqlalchemy import inspect, text

from jointwear_ros.errors import InputDataError
from jointwear_ros.history import (
    SCHEMA_VERSION,
    EstimateRecord,
    HistoryError,
    HistoryStore,
    MaintenanceEvent,
    normalize_url,
    trends_from_store,
)
from jointwear_ros.history.importers import estimates_from_csv, write_csv
from jointwear_ros.trend import TrendConfig

T0 = 1.7e9
DAY = 86400.0


def _records(n: int, joint: str = "joint_1", robot: str = "robot_1", rate: float = 0.2, w0: float = 10.0,
             start_cycle: int = 1, t0: float = T0) -> list[EstimateRecord]:
    rng = np.random.default_rng(7)
    return [EstimateRecord(robot, joint, cycle_id=start_cycle + i, time=t0 + i * DAY,
                           wear=float(w0 + rate * i + rng.normal(0, 0.8)), wear_std=0.85, method="joint",
                           params="ref-2011r", temperature=40.0 + i % 3)
            for i in range(n)]


def test_store_inserts_each_estimate_once_and_reads_it_back_exactly(db_url):
    recs = _records(30)
    with HistoryStore(db_url) as s:
        assert s.add_estimates(recs) == 30
        assert s.add_estimates(recs) == 0
        assert s.add_estimates(recs[:10] + _records(5, joint="joint_2")) == 5
        assert s.count() == 35
        back = s.estimates(robot="robot_1", joint="joint_1")
    assert [r.cycle_id for r in back] == list(range(1, 31))
    assert [r.wear for r in back] == [r.wear for r in recs]
    assert all(b.time_ns == r.time_ns for b, r in zip(back, recs))
    assert back[0].temperature == 40.0 and back[0].method == "joint" and back[0].params == "ref-2011r"


def test_restarted_cycle_ids_are_new_estimates_because_time_is_part_of_the_identity(db_url):
    first = _records(5)
    restarted = _records(5, t0=T0 + 10 * DAY)  # test_cycle restarted: cycle ids 1..5 again, later times
    with HistoryStore(db_url) as s:
        assert s.add_estimates(first) == 5
        assert s.add_estimates(restarted) == 5
        assert s.add_estimates(first + restarted) == 0
        assert [r.cycle_id for r in s.estimates()] == [1, 2, 3, 4, 5, 1, 2, 3, 4, 5]


def test_the_same_estimate_from_the_live_node_and_from_its_bag_is_one_entry(db_url):
    live = _records(3)
    from_bag = [EstimateRecord(**{**r.__dict__, "bag": "jointwear_20261123", "source": "bag"}) for r in live]
    with HistoryStore(db_url) as s:
        assert s.add_estimates(live) == 3
        assert s.add_estimates(from_bag) == 0
        reest = [EstimateRecord(**{**r.__dict__, "analysis_version": "bayes:ref-2011r:0.1.0"}) for r in live]
        assert s.add_estimates(reest) == 3  # another analysis version is another entry
        assert s.analysis_versions() == ["bayes:ref-2011r:0.1.0", "live"]
        assert s.count("live") == 3


def test_maintenance_events_are_idempotent_and_start_a_new_trend_segment(db_url):
    before = _records(60, rate=0.25)
    after = _records(40, rate=0.0, w0=3.0, start_cycle=100, t0=T0 + 70 * DAY)
    ev = MaintenanceEvent("robot_1", "joint_1", T0 + 65 * DAY, "reducer_replaced", "new RV reducer")
    with HistoryStore(db_url) as s:
        s.add_estimates(before + after)
        assert s.add_maintenance(ev) is True
        assert s.add_maintenance(ev) is False
        assert s.maintenance(robot="robot_1") == [ev]
        (tr,) = trends_from_store(s)
    assert tr.segments == 2 and tr.estimates == 40 and tr.estimates_total == 100
    assert abs(tr.wear - 3.0) < 4 * tr.wear_std and tr.wear_std < 0.5
    assert tr.time_to_alarm is None and tr.level_name == "OK"


def test_trend_query_gives_one_result_per_joint_with_the_growing_one_warned(db_url):
    with HistoryStore(db_url) as s:
        s.add_estimates(_records(80, joint="joint_1", rate=0.25, w0=12.0)   # reaches 35 about 12 days later
                        + _records(80, joint="joint_2", rate=0.0, w0=12.0))
        res = {r.joint: r for r in trends_from_store(s, TrendConfig())}
    assert sorted(res) == ["joint_1", "joint_2"]
    g, f = res["joint_1"], res["joint_2"]
    assert g.level_name == "WARN" and f.level_name == "OK"
    assert g.time_to_alarm is not None and g.time_to_alarm.lo90 <= 12.0 <= g.time_to_alarm.hi90
    assert 0.2 < g.rate_per_day < 0.3 and g.rate_std < 0.05
    assert f.time_to_alarm is None and not f.growth_detected


def test_schema_migrates_forward_from_version_one_and_is_left_alone_when_current(db_url):
    with HistoryStore(db_url, migrate_to=1) as s:
        assert s.schema_version() == 1
        assert not any(ix["name"] == "ix_estimates_joint_time"
                       for ix in inspect(s.engine).get_indexes("estimates"))
        s.add_estimates(_records(3))
        with s.engine.begin() as conn:  # as version 1 was written before estimates had an evidence column
            conn.execute(text("ALTER TABLE estimates DROP COLUMN evidence"))
            conn.execute(text("ALTER TABLE estimates DROP COLUMN cycle_source"))
    with pytest.raises(HistoryError, match="schema version 1, this software needs 6"):
        HistoryStore(db_url, create=False)
    with HistoryStore(db_url) as s:
        assert s.schema_version() == SCHEMA_VERSION == 6
        assert any(ix["name"] == "ix_estimates_joint_time" for ix in inspect(s.engine).get_indexes("estimates"))
        assert s.count() == 3  # data kept
        assert {r.evidence for r in s.estimates()} == {"complete"}  # rows from before: complete
        assert {r.cycle_source for r in s.estimates()} == {"test_cycle"}  # and from test cycles
        assert s.migrate() == []


def test_migration_to_three_moves_rows_the_screening_refuses_into_refused(db_url):
    """Rows an older version stored unscreened (wear 1e300, std 1e-300, 2000, ten years ahead) leave the trend's
    input on migration and are kept, with their reason, in ``refused``."""
    good = _records(5)
    bad = [EstimateRecord("robot_1", "joint_1", cycle_id=90 + i, time=t, wear=w, wear_std=sd)
           for i, (t, w, sd) in enumerate([(T0, 1e300, 0.8), (T0 + DAY, 0.0, 1e-300),
                                           (time.time() + 3650 * DAY, 36.0, 0.8), (946684800.0, 40.0, 0.8)])]
    with HistoryStore(db_url, migrate_to=2) as s:
        with s.engine.begin() as conn:  # as version 2 wrote them: no screening
            from jointwear_ros.history.store import estimates_t
            conn.execute(estimates_t.insert(), [
                {"robot": r.robot, "joint": r.joint, "hardware_id": "", "cycle_id": r.cycle_id,
                 "time_ns": r.time_ns, "wear": r.wear, "wear_std": r.wear_std, "temperature": None, "method": "",
                 "params": "", "software_version": "", "bag": "", "analysis_version": "live", "source": "csv",
                 "inserted_ns": 0} for r in good + bad])
    with HistoryStore(db_url) as s:
        assert s.count() == 5
        ref = s.refused()
    assert sorted((int(r["cycle_id"]), r["reason"]) for r in ref) == [
        (90, "wear_out_of_range"), (91, "std_out_of_range"), (92, "time_in_future"), (93, "time_before_min")]
    assert float(next(r for r in ref if r["cycle_id"] == 90)["wear"]) == 1e300


def test_a_database_of_a_newer_schema_is_refused_in_one_line_and_not_written(db_url):
    with HistoryStore(db_url) as s:
        s.add_estimates(_records(2))
        with s.engine.begin() as conn:
            conn.execute(text("INSERT INTO schema_version (version, applied_ns) VALUES (99, 0)"))
    for kw in ({}, {"create": False}, {"read_only": True}):
        if kw.get("read_only") and not db_url.startswith("sqlite"):
            continue
        with pytest.raises(HistoryError, match="schema version 99 was written by a newer jointwear") as ei:
            HistoryStore(db_url, **kw)
        assert "\n" not in str(ei.value)
    with _raw(db_url) as conn:
        assert conn.execute(text("SELECT count(*) FROM estimates")).scalar_one() == 2


def _raw(db_url):
    from sqlalchemy import create_engine

    from jointwear_ros.history import normalize_url
    return create_engine(normalize_url(db_url)).connect()


def test_an_empty_database_opened_without_create_is_refused(db_url):
    with pytest.raises(HistoryError, match="schema version 0"):
        HistoryStore(db_url, create=False)


WRITER = textwrap.dedent("""
    import sys
    import numpy as np
    from jointwear_ros.history import EstimateRecord, HistoryStore
    url, seed = sys.argv[1], int(sys.argv[2])
    rng = np.random.default_rng(seed)
    s = HistoryStore(url)
    order = rng.permutation(120)
    added = 0
    for start in range(0, 120, 15):  # overlapping batches: every writer writes all 120 estimates
        batch = [EstimateRecord("robot_%d" % (i % 3), "joint_1", cycle_id=i, time=1.7e9 + 3600.0 * i,
                                wear=float(i) / 10, wear_std=0.9) for i in order[start:start + 15]]
        added += s.add_estimates(batch)
    print(added)
""")


@pytest.mark.slow
def test_concurrent_writer_processes_lose_nothing_and_duplicate_nothing(db_url):
    HistoryStore(db_url).close()  # schema first, as a deployment does
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, db_url, str(seed)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for seed in range(4)]
    outs = [p.communicate(timeout=120) for p in procs]
    for p, (_out, err) in zip(procs, outs):
        assert p.returncode == 0, err[-2000:]
    added = [int(o.strip()) for o, _ in outs]
    assert sum(added) == 120  # each estimate inserted by exactly one writer
    with HistoryStore(db_url) as s:
        assert s.count() == 120
        assert sorted(r.cycle_id for r in s.estimates()) == list(range(120))


def test_csv_export_imports_back_to_the_same_entries(db_url, tmp_path):
    recs = _records(25)
    with HistoryStore(db_url) as s:
        s.add_estimates(recs)
        out = tmp_path / "export.csv"
        assert write_csv(s.estimates(), out) == 25
        back = estimates_from_csv(out)
        assert s.add_estimates(back) == 0
    assert [(r.robot, r.joint, r.cycle_id, r.time_ns, r.wear) for r in back] == \
        [(r.robot, r.joint, r.cycle_id, r.time_ns, r.wear) for r in recs]


@pytest.mark.parametrize(("kw", "match"), [
    ({"wear": math.nan}, "wear = nan is not a finite number"),
    ({"wear_std": 0.0}, "wear_std = 0.0 must be > 0"),
    ({"joint": ""}, "must be non-empty"),
    ({"time": 1e13}, "is not seconds since the epoch"),
])
def test_store_refuses_unusable_estimates_and_writes_nothing(kw, match):
    s = HistoryStore("sqlite://")
    good = _records(2)
    bad = EstimateRecord(**{**good[0].__dict__, "cycle_id": 99, **kw})
    with pytest.raises(InputDataError, match=match):
        s.add_estimates([*good, bad])
    assert s.count() == 0


def test_urls_are_normalized_and_bad_ones_named():
    assert normalize_url("/x/h.db") == "sqlite:////x/h.db"
    assert normalize_url("postgres://u@h/d") == "postgresql+psycopg://u@h/d"
    with pytest.raises(InputDataError, match="database URL is empty"):
        normalize_url(" ")
    with pytest.raises((InputDataError, HistoryError)):
        HistoryStore("nosuchdialect://x")


OPENER = textwrap.dedent("""
    import sys
    from jointwear_ros.history import EstimateRecord, HistoryStore
    s = HistoryStore(sys.argv[1])
    print(s.add_estimates([EstimateRecord("r", "j", cycle_id=1, time=1.7e9, wear=1.0, wear_std=1.0)]))
""")


@pytest.mark.slow
def test_processes_opening_a_new_store_at_once_agree_on_one_schema(db_url):
    procs = [subprocess.Popen([sys.executable, "-c", OPENER, db_url], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(3)]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], [e[-500:] for _, e in outs]
    assert sorted(int(o) for o, _ in outs) == [0, 0, 1]
    with HistoryStore(db_url) as s:
        assert s.schema_version() == SCHEMA_VERSION and s.count() == 1


def test_times_are_stored_to_the_microsecond_and_read_back_exactly(db_url):
    """Stamps with fractions of a second (a live estimate's header stamp) round-trip to the microsecond, and two
    estimates of one cycle id 0.25 s apart are two entries (a store keeping whole seconds fails here)."""
    ts = [T0 + 0.123456, T0 + 0.373456, T0 + 1.999999, T0 + 86400.000001]
    recs = [EstimateRecord("robot_1", "joint_1", cycle_id=7, time=t, wear=10.0 + i, wear_std=0.8)
            for i, t in enumerate(ts)]
    with HistoryStore(db_url) as s:
        assert s.add_estimates(recs) == 4
        back = s.estimates()
    assert [round(r.time * 1e6) for r in back] == [round(t * 1e6) for t in ts]
    assert [r.time_ns for r in back] == [round(t * 1e6) * 1000 for t in ts]


def test_a_read_only_store_reads_and_never_writes(db_url):
    with HistoryStore(db_url) as s:
        s.add_estimates(_records(4))
    with HistoryStore(db_url, read_only=True) as r:
        assert r.count() == 4 and len(r.history()) == 1 and r.refused() == []
        with pytest.raises(HistoryError, match="read-only"):
            r.add_estimates(_records(2, joint="joint_9"))
        with pytest.raises(HistoryError, match="read-only"):
            r.add_maintenance(MaintenanceEvent("robot_1", "joint_1", T0, "regrease"))
        if r.dialect == "postgresql":  # the session itself refuses writes, not only this class
            with pytest.raises(Exception, match="read-only transaction"), r.engine.begin() as conn:
                conn.execute(text("DELETE FROM estimates"))
    with HistoryStore(db_url) as s:
        assert s.count() == 4
