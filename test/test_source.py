"""Every friction observation and wear estimate carries its source (``test_cycle`` or ``production``): the contract,
the wear monitor (a production shift is a unit like a test cycle, never mixed with the test cycle of its id),
replay, the history (its migration), the observation tables, ``estimate``, ``trend`` and ``serve``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from sqlalchemy import text

from jointwear_ros.contract import CycleState, CycleStatus, Source, observation_from_msg, observation_to_msg, source_of
from jointwear_ros.errors import InputDataError
from jointwear_ros.history import SCHEMA_VERSION, EstimateRecord, HistoryStore
from jointwear_ros.history.importers import estimates_from_csv, write_csv
from jointwear_ros.model import load_parameter_set, paper_wear_model
from jointwear_ros.monitor import MonitorConfig, WearMonitor
from jointwear_ros.observer import FrictionObservationData
from jointwear_ros.trend import TrendConfig, analyze_joint

ROOT = Path(__file__).resolve().parents[1]
T0 = 1.75e9
DAY = 86400.0


def _obs(cycle_id: int, speed: float, wear: float, source: str = "test_cycle", stamp: float = 1.0,
         joint: str = "joint_1") -> FrictionObservationData:
    """An observation of the reference model at ``wear`` (40 degC measured)."""
    tau = float(paper_wear_model().evaluate(load_parameter_set("ref-2011r"), speed=speed, load_torque=0.1,
                                            temperature=40.0, wear=wear))
    return FrictionObservationData(stamp=stamp, joint_name=joint, cycle_id=cycle_id, speed=speed, tau_f=tau,
                                   tau_f_std=3e-4, tau_plus=0.1 + tau, tau_minus=0.1 - tau, load_torque=0.1,
                                   temperature=40.0, position=0.0, samples_plus=500, samples_minus=500,
                                   source=source)


def _status(cycle_id: int, state: CycleState, total: int = 3) -> CycleStatus:
    return CycleStatus(cycle_id=cycle_id, state=state, speeds_total=total, joint_name="joint_1")


# ---------------------------------------------------------------------------- the contract

def test_the_source_vocabulary_reads_empty_as_a_test_cycle_and_refuses_anything_else():
    assert Source.parse("") is Source.parse(None) is Source.TEST_CYCLE
    assert Source.parse(" production ") is Source.PRODUCTION and Source.PRODUCTION == "production"
    assert source_of("") == "test_cycle"
    with pytest.raises(InputDataError, match="source 'shift' is neither 'test_cycle' nor 'production'"):
        Source.parse("shift")


def test_an_observation_message_keeps_its_source_and_one_without_the_field_is_a_test_cycles():
    from jointwear_msgs.msg import FrictionObservation

    o = _obs(3, 40.0, 20.0, source="production", stamp=12.5)
    msg = observation_to_msg(o, FrictionObservation)
    assert msg.source == "production" and observation_from_msg(msg) == o
    assert FrictionObservation().source == ""  # the generated default: read as a test cycle's
    # a message of a bag recorded before the field (rosbags gives it the bag's own definition: no attribute)
    old = SimpleNamespace(**{k: getattr(msg, k) for k in (
        "header", "joint_name", "cycle_id", "speed", "tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque",
        "temperature", "position", "samples_plus", "samples_minus")})
    assert observation_from_msg(old) == replace(o, source="test_cycle")
    msg.source = "nightly"
    with pytest.raises(InputDataError, match="'nightly'"):
        observation_from_msg(msg)


# ---------------------------------------------------------------------------- the wear monitor

def test_the_monitor_keeps_a_production_shift_apart_from_the_test_cycle_with_the_same_id():
    """Test cycle 3 (wear 10) and production shift 3 (wear 40) interleaved: two results, each from its own
    observations only, each saying its source; the production shift completes on its own status."""
    mon = WearMonitor(MonitorConfig(seed=1))
    out = mon.on_status(_status(3, CycleState.RUNNING), now=0.0)
    out += mon.on_status(_status(3, CycleState.RUNNING), now=0.0, source=Source.PRODUCTION)
    for i, v in enumerate((20.0, 80.0, 160.0)):
        out += mon.add(_obs(3, v, 10.0, stamp=1.0 + i), now=1.0 + i)
        out += mon.add(_obs(3, v, 40.0, source="production", stamp=1.5 + i), now=1.5 + i)
    assert sorted(r.source for r in out) == ["production", "test_cycle"]
    by = {r.source: r for r in out}
    for src, wear in (("test_cycle", 10.0), ("production", 40.0)):
        r = by[src]
        assert r.cycle_id == 3 and r.result is not None and r.result.wear == pytest.approx(wear, abs=0.5)
        assert {o.source for o in r.observations} == {src} and len(r.observations) == 3
        assert dict(r.values)["source"] == src
    assert "production shift 3" in by["production"].message and "production" not in by["test_cycle"].message
    assert mon.open_cycles == () and not mon.ignored


def test_a_production_shift_without_its_status_is_estimated_on_the_idle_timeout_and_a_bad_source_is_dropped():
    mon = WearMonitor(MonitorConfig(seed=1, idle_timeout=5.0))
    out = []
    for i, v in enumerate((20.0, 80.0, 160.0)):
        out += mon.add(_obs(7, v, 30.0, source="production", stamp=1.0 + i))
    out += mon.add(_obs(7, 40.0, 30.0, source="nightly", stamp=4.0))
    assert out == [] and mon.open_cycles == (("production", 7),) and mon.rejected_count == 1
    assert "'nightly' is neither" in mon.ignored[-1]
    out = mon.poll(100.0)
    assert len(out) == 1 and out[0].source == "production" and out[0].result.wear == pytest.approx(30.0, abs=0.5)


# ---------------------------------------------------------------------------- the history

def _records(n: int, source: str = "test_cycle", t0: float = T0, start: int = 1) -> list[EstimateRecord]:
    return [EstimateRecord("robot_1", "joint_1", cycle_id=start + i, time=t0 + i * DAY, wear=10.0 + 0.2 * i,
                           wear_std=0.8, method="paper", params="ref-2011r", cycle_source=source)
            for i in range(n)]


def test_a_store_without_the_cycle_source_column_migrates_and_its_rows_are_test_cycles(db_url):
    with HistoryStore(db_url, migrate_to=5) as s:
        with s.engine.begin() as conn:  # the rows of a version-5 store, then the column it did not have
            conn.execute(text("DELETE FROM schema_version WHERE version > 5"))
        s.add_estimates(_records(3))
        with s.engine.begin() as conn:
            conn.execute(text("ALTER TABLE estimates DROP COLUMN cycle_source"))
    with HistoryStore(db_url) as s:
        assert s.schema_version() == SCHEMA_VERSION == 6
        assert [r.cycle_source for r in s.estimates()] == ["test_cycle"] * 3
        # the same cycle id from a production shift is a new entry (its own time), read back as production
        assert s.add_estimates(_records(1, "production", t0=T0 + 0.5 * DAY)) == 1
        assert [(r.cycle_id, r.cycle_source) for r in s.estimates()] == [
            (1, "test_cycle"), (1, "production"), (2, "test_cycle"), (3, "test_cycle")]


def test_history_csv_round_trips_the_cycle_source_and_reads_a_table_without_it(tmp_path):
    recs = _records(2) + _records(2, "production", t0=T0 + 0.5 * DAY)
    write_csv(recs, tmp_path / "h.csv")
    back = estimates_from_csv(tmp_path / "h.csv")
    assert sorted((r.cycle_id, r.cycle_source) for r in back) == [
        (1, "production"), (1, "test_cycle"), (2, "production"), (2, "test_cycle")]
    (tmp_path / "old.csv").write_text("robot,joint,time,wear,wear_std\nr,j,1750000000,10,0.8\n")
    assert [r.cycle_source for r in estimates_from_csv(tmp_path / "old.csv")] == ["test_cycle"]
    (tmp_path / "bad.csv").write_text("robot,joint,time,wear,wear_std,cycle_source\nr,j,1750000000,10,0.8,shift\n")
    with pytest.raises(InputDataError, match=r"bad.csv:2: cycle_source: source 'shift' is neither"):
        estimates_from_csv(tmp_path / "bad.csv")


# ---------------------------------------------------------------------------- the trend, its figure, the CLI

def test_the_trend_never_takes_a_production_shift_for_a_revision_of_the_test_cycle_with_its_id():
    times = [T0, T0 + 600.0, T0 + DAY, T0 + DAY + 600.0]  # within the revision window of each other
    kw = {"cycle_ids": [1, 1, 2, 2], "cfg": TrendConfig()}
    mixed = analyze_joint(times, [10.0, 11.0, 10.5, 11.5], [0.8] * 4,
                          sources=["test_cycle", "production", "test_cycle", "production"], **kw)
    assert mixed.estimates == 4
    assert analyze_joint(times, [10.0, 11.0, 10.5, 11.5], [0.8] * 4, **kw).estimates == 2  # all test cycles


@pytest.fixture
def two_source_db(tmp_path) -> str:
    db = str(tmp_path / "two.db")
    with HistoryStore(db) as s:  # daily test cycles, and production shifts in between (the newest)
        s.add_estimates(_records(6, t0=T0) + _records(9, "production", t0=T0 + 0.4 * DAY))
    return db


def test_trend_shows_each_estimates_source_in_its_table_json_and_figure(two_source_db, tmp_path, saved, capsys):
    from jointwear_ros.cli import main as cli_main

    assert cli_main(["trend", "--db", two_source_db, "--json", "--stale-days", "100000"]) == 0
    row = json.loads(capsys.readouterr().out)["joints"][0]
    assert row["newest_source"] == "production"
    assert row["sources"]["test_cycle"]["estimates"] == 6 and row["sources"]["production"]["estimates"] == 9
    assert row["sources"]["production"]["wear"] == pytest.approx(10.0 + 0.2 * 8)
    assert cli_main(["trend", "--db", two_source_db, "--stale-days", "100000", "--plot", str(tmp_path / "p")]) == 0
    table = capsys.readouterr().out
    assert "newest from" in table and "production" in table and "test 6 prod 9" in table
    fig = saved["trend_robot_1_joint_1.png"]
    labels = [t.get_text() for ax in fig.axes for leg in [ax.get_legend()] if leg for t in leg.get_texts()]
    labels += [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert any(lb.startswith("production estimates") for lb in labels), labels
    assert any(lb.startswith("test-cycle estimates") for lb in labels), labels


def test_serve_shows_the_sources_on_the_page_in_the_api_and_in_metrics(two_source_db):
    sys.path.insert(0, str(ROOT / "tools"))
    from plant_screenshot import start_serve, stop
    from test_serve import api, get

    proc, base = start_serve(two_source_db, "--stale-days", "100000")
    try:
        row = api(base)["joints"][0]
        assert row["newest_source"] == "production"
        assert {k: v["estimates"] for k, v in row["sources"].items()} == {"test_cycle": 6, "production": 9}
        code, body = get(base + "/metrics")
        assert code == 200
        assert 'jointwear_joint_source_estimates{joint="joint_1",robot="robot_1",source="production"} 9.0' in body
        assert 'jointwear_joint_source_estimates{joint="joint_1",robot="robot_1",source="test_cycle"} 6.0' in body
        assert 'jointwear_joint_level{joint="joint_1",robot="robot_1"}' in body  # the per-joint series as they were
        code, page = get(base + "/")
        assert code == 200 and 'data-newest-source="production"' in page and "9 production" in page
        code, joint = get(base + "/joint/robot_1/joint_1")
        assert code == 200 and joint.count('data-cycle-source="production"') == 9
    finally:
        stop(proc)


# ---------------------------------------------------------------------------- tables and estimate

def _table_rows(cycle: int, wear: float, source: str) -> list[str]:
    return [f"{v},{_obs(cycle, v, wear).tau_f!r},0.1,40.0,{cycle},{source}" for v in (20.0, 80.0, 160.0)]


def test_estimate_json_gives_a_production_shift_and_the_test_cycle_of_its_id_apart(tmp_path):
    p = tmp_path / "obs.csv"
    p.write_text("\n".join(["speed,tau_f,load_torque,temperature,cycle,source", *_table_rows(1, 10.0, "test_cycle"),
                            *_table_rows(1, 40.0, "production")]) + "\n")
    r = subprocess.run([sys.executable, "-m", "jointwear_ros", "estimate", str(p), "--params", "ref-2011r",
                        "--method", "paper", "--json"], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    rows = {e["cycle_source"]: e for e in json.loads(r.stdout)["estimates"]}
    assert set(rows) == {"test_cycle", "production"} and {e["cycle"] for e in rows.values()} == {1}
    assert rows["test_cycle"]["estimate"] == pytest.approx(10.0, abs=0.5)
    assert rows["production"]["estimate"] == pytest.approx(40.0, abs=0.5)
    p.write_text("\n".join(["speed,tau_f,load_torque,temperature,cycle,source", *_table_rows(1, 10.0, "shift")]))
    r = subprocess.run([sys.executable, "-m", "jointwear_ros", "estimate", str(p), "--params", "ref-2011r"],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "column 'source', row 1" in r.stderr


def test_observation_tables_keep_the_source_through_bag_and_csv(tmp_path):
    from jointwear_ros.io.tables import read_bag, read_csv, write_bag, write_csv
    from jointwear_ros.types import ObservationTable

    t = ObservationTable({"speed": [20.0, 80.0, 20.0], "tau_f": [0.07, 0.08, 0.07], "cycle": [1.0, 1.0, 1.0],
                          "time": [1.0, 2.0, 3.0], "production": [0.0, 0.0, 1.0]})
    back = read_bag(write_bag(t, tmp_path / "bag"))
    assert back["production"].tolist() == [0.0, 0.0, 1.0]
    write_csv(back, tmp_path / "t.csv")
    assert "source" in (tmp_path / "t.csv").read_text().splitlines()[1]
    assert read_csv(tmp_path / "t.csv")["production"].tolist() == [0.0, 0.0, 1.0]
    only_tc = ObservationTable({k: v for k, v in t.columns.items() if k != "production"})
    assert "production" not in read_bag(write_bag(only_tc, tmp_path / "bag2"))  # as it always was


# ---------------------------------------------------------------------------- replay

def test_replay_of_a_bag_with_production_status_gives_the_live_production_estimate(tmp_path_factory):
    """A bag with a test cycle 1 and production shift 1 (its /production/status, its observations and the live
    estimate of each): replay gives both, each from its own source, equal to the recorded ones."""
    from test_replay import _estimate_msg, _header, _monitor_config, _synthetic, _write

    from jointwear_ros.io.params import node_params_from_yaml
    from jointwear_ros.replay import replay_bag
    from jointwear_ros.resources import config_path

    _, _, tc_result, msgs, store = _synthetic(tmp_path_factory)
    T = store.types
    t_start = 200.0
    prod = [_obs(1, v, 40.0, source="production", stamp=t_start + 10.0 * (i + 1)) for i, v in
            enumerate((20.0, 80.0, 160.0))]
    live = WearMonitor(_monitor_config())  # the live estimator heard this
    results = live.on_status(_status(1, CycleState.RUNNING), now=t_start, source=Source.PRODUCTION)
    for o in prod:
        results += live.add(o, now=o.stamp + 0.01)
    results += live.on_status(_status(1, CycleState.DONE), now=t_start + 40.0, source=Source.PRODUCTION)
    assert len(results) == 1 and results[0].source == "production" and results[0].result is not None
    extra = []
    for t, st in ((t_start, CycleState.RUNNING), (t_start + 40.0, CycleState.DONE)):
        extra.append((t, "/production/status", "jointwear_msgs/msg/TestCycleStatus",
                      T["jointwear_msgs/msg/TestCycleStatus"](
                          header=_header(store, t), joint_name="joint_1", cycle_id=1, state=int(st), phase=0,
                          current_speed=0.0, speeds_done=0, speeds_total=3, window_center=0.0,
                          window_half_width=0.0, message="", joints=["joint_1"], joints_done=0)))
    for o in prod:
        d = o.to_dict()
        t = d.pop("stamp")
        extra.append((t + 0.01, "/jointwear/friction_observations", "jointwear_msgs/msg/FrictionObservation",
                      T["jointwear_msgs/msg/FrictionObservation"](header=_header(store, t), **d)))
    bag = tmp_path_factory.mktemp("prod") / "bag"
    _write(bag, store, [*msgs, _estimate_msg(store, tc_result), *extra, _estimate_msg(store, results[0])])
    rep = replay_bag(bag, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
                     node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))
    assert rep.production_statuses == 2 and rep.production_observations == 3
    by = {c.source: c for c in rep.cycles if c.result is not None}
    assert set(by) == {"test_cycle", "production"} and by["production"].cycle_id == by["test_cycle"].cycle_id == 1
    assert by["production"].result.wear == results[0].result.wear
    assert by["test_cycle"].result.wear == tc_result.result.wear
    assert by["production"].result.wear == pytest.approx(40.0, abs=1.0) and not math.isclose(
        by["production"].result.wear, by["test_cycle"].result.wear, abs_tol=5.0)
    cmp_ = rep.comparison()
    assert cmp_["estimates"]["paired"] == cmp_["estimates"]["matched"] == 2 and not cmp_["estimates"]["differ"]
    assert cmp_["observations"]["matched"] == 3 and not cmp_["observations"]["not_replayed"]
    assert np.isfinite(cmp_["estimates"]["max_abs_diff"])
    # the fleet re-analysis of the bag: one record per (source, cycle), each with its source for the history
    from jointwear_ros.fleet.reanalysis import reprocess_bag

    out = reprocess_bag(bag, params="ref-2011r", method=str(_monitor_config().method))
    assert not out.error and sorted((r["cycle_id"], r["cycle_source"]) for r in out.records) == [
        (1, "production"), (1, "test_cycle")]
    assert {r["cycle_source"]: EstimateRecord(**r).wear for r in out.records}["production"] == results[0].result.wear
