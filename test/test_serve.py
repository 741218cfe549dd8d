"""``jointwear serve``: the plant's page, ``/api/joints`` and ``/metrics`` agree with ``trend --json``; the page
follows the store live; it never writes and survives a store that goes away, is migrated or unreachable.

A real server process (uvicorn) over a real store (an SQLite file and a real PostgreSQL), read over HTTP.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import math
import re
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from jointwear_ros.contract import DiagnosticLevel, level_name
from jointwear_ros.history import SCHEMA_VERSION, EstimateRecord, HistoryStore
from jointwear_ros.serve.core import plant_level, rank_views
from jointwear_ros.trend import DAY

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

from plant_example import (  # noqa: E402
    ERROR_JOINT,
    OUTLIER_JOINT,
    PARTIAL_JOINT,
    STALE_JOINT,
    expected_alarm_expected,
    expected_levels,
    write_plant,
)
from plant_screenshot import start_serve, stop  # noqa: E402

OK, WARN, ERROR, STALE = DiagnosticLevel.OK, DiagnosticLevel.WARN, DiagnosticLevel.ERROR, DiagnosticLevel.STALE


def get(url: str) -> tuple[int, str]:
    try:
        with urllib.request.urlopen(url, timeout=30) as r:
            return r.status, r.read().decode()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read().decode()


def api(base: str) -> dict:
    code, body = get(base + "/api/joints")
    assert code == 200
    return json.loads(body)


def metrics(base: str) -> dict[str, dict[tuple[str, str], float]]:
    """name -> (robot, joint) -> value, from the exposition text (labels in any order)."""
    code, body = get(base + "/metrics")
    assert code == 200
    out: dict[str, dict] = {}
    for line in body.splitlines():
        m = re.fullmatch(r"(jointwear_\w+)(?:\{(.*)\})? (\S+)", line)
        if not m:
            continue
        labels = dict(re.findall(r'(\w+)="([^"]*)"', m.group(2) or ""))
        key = (labels.get("robot", ""), labels.get("joint", "")) if "robot" in labels else labels.get("level", "")
        out.setdefault(m.group(1), {})[key] = float(m.group(3))
    return out


def wait_for(cond, timeout: float = 30.0, what: str = "condition"):
    deadline = time.monotonic() + timeout
    while True:
        v = cond()
        if v:
            return v
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.1)


def trend_json(db: str, *extra: str) -> dict[tuple[str, str], dict]:
    """``jointwear trend --db DB --json`` (the CLI in this process: a new interpreter per call cost more than the
    trend of the plant)."""
    from jointwear_ros.cli import main as cli_main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert cli_main(["trend", "--db", db, "--json", *extra]) == 0
    return {(j["robot"], j["joint"]): j for j in json.loads(out.getvalue())["joints"]}


# ---------------------------------------------------------------------------- the pure level rule


@given(st.sampled_from([OK, WARN, ERROR]), st.floats(0, 100), st.floats(0.01, 60))
def test_plant_level_is_the_trend_level_unless_silent_and_never_hides_an_error(trend_level, age_days, stale_days):
    now = 1.8e9
    last = now - age_days * DAY
    lv = plant_level(trend_level, last, now, stale_days)
    if trend_level == ERROR:
        assert lv == ERROR
    elif now - last > stale_days * DAY:
        assert lv == STALE
    else:
        assert lv == trend_level
    assert plant_level(trend_level, math.nan, now, stale_days) == (ERROR if trend_level == ERROR else STALE)
    assert level_name(lv) in ("OK", "WARN", "ERROR", "STALE")


nums = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.none())


@given(st.sampled_from([OK, WARN, ERROR, STALE]), st.floats(allow_nan=True), st.floats(allow_nan=True), nums, nums,
       nums, st.text(max_size=5))
def test_api_rows_are_strict_json_with_nulls_where_unknown(level, wear, t, med, lo, hi, refused):
    from jointwear_ros.serve.core import JointView

    v = JointView("r", "j", int(level), int(level), wear, 0.3, 0.01, t, 1.0, med, lo, hi, 5, 5, "m", refused)
    row = v.as_api()
    json.dumps(row, allow_nan=False)  # NaN or inf would not be JSON
    for key, x in (("wear", wear), ("time", t), ("days_to_alarm", med), ("days_to_alarm_low", lo),
                   ("days_to_alarm_high", hi)):
        assert row[key] == (x if x is not None and math.isfinite(x) else None)
    assert row["level"] == level_name(level) and row["refused"] == (refused or None)


# ---------------------------------------------------------------------------- one plant, every view agrees


@pytest.fixture(scope="module")
def plant_db(tmp_path_factory):
    db = str(tmp_path_factory.mktemp("plant") / "plant.db")
    write_plant(db)
    return db


@pytest.fixture(scope="module")
def served(plant_db):
    proc, base = start_serve(plant_db)
    yield base
    stop(proc)


def test_page_api_metrics_and_trend_json_agree_on_every_joint_of_a_plant(plant_db, served):
    """One condition level and one forecast per joint, the same on every surface (docs/levels.md): the plant
    holds OK, WARN, ERROR, STALE, a joint near the warning level, a held outlier and a partial cycle."""
    from jointwear_ros.condition import condition_level

    expected = expected_levels()
    assert len(expected) == 30 and ERROR_JOINT in expected and STALE_JOINT in expected
    tj = trend_json(plant_db)
    rows = {(j["robot"], j["joint"]): j for j in api(served)["joints"]}
    m = metrics(served)
    code, page = get(served + "/")
    assert code == 200
    assert set(tj) == set(rows) == set(expected) == set(m["jointwear_joint_level"])
    with HistoryStore(plant_db) as store:
        newest = {k: store.estimates(robot=k[0], joint=k[1])[-1] for k in expected}
    forecast = expected_alarm_expected()
    for key, want in expected.items():
        t, a = tj[key], rows[key]
        if want is None:  # near the warning level: the rule on the joint's newest estimate decides
            e = newest[key]
            want = condition_level(e.wear, e.wear_std).name
        assert t["level"] == a["level"] == want, key
        assert level_name(int(m["jointwear_joint_level"][key])) == want, key
        tr = re.search(rf'<tr data-robot="{key[0]}" data-joint="{key[1]}" data-level="(\w+)" '
                       rf'data-alarm-expected="(\w+)">', page)
        assert tr and tr.group(1) == want and tr.group(2) == ("true" if forecast[key] else "false"), key
        # the forecast: its own field, the same everywhere, never the level
        assert t["alarm_expected"] is a["alarm_expected"] is forecast[key], key
        assert m["jointwear_joint_alarm_expected"][key] == float(forecast[key]), key
        assert a["level_wear"] == pytest.approx(t["condition"]["wear"], rel=1e-9)
        assert m["jointwear_joint_level_wear"][key] == pytest.approx(t["condition"]["wear"], rel=1e-9)
        assert a["wear"] == pytest.approx(t["wear"], rel=1e-9) and a["wear_std"] == pytest.approx(t["wear_std"])
        assert m["jointwear_joint_wear"][key] == pytest.approx(t["wear"], rel=1e-9)
        assert m["jointwear_joint_wear_std"][key] == pytest.approx(t["wear_std"], rel=1e-9)
        assert a["time"] == pytest.approx(t["newest_time"], abs=1e-6)
        tta = t["time_to_alarm_days"]
        if tta is None:
            assert a["days_to_alarm"] is a["days_to_alarm_low"] is a["days_to_alarm_high"] is None
            assert key not in m.get("jointwear_joint_days_to_alarm", {})
        else:
            assert (a["days_to_alarm"], a["days_to_alarm_low"]) == pytest.approx((tta["median"], tta["lo90"]))
            assert m["jointwear_joint_days_to_alarm_low"][key] == pytest.approx(tta["lo90"])
            assert m["jointwear_joint_days_to_alarm"][key] == pytest.approx(tta["median"])
    # the ERROR joint: at the alarm; the silent one: STALE with its age, though its trend alone says OK
    assert rows[ERROR_JOINT]["wear"] >= 35 and rows[ERROR_JOINT]["days_to_alarm"] == 0
    assert rows[STALE_JOINT]["trend_level"] == "OK" and rows[STALE_JOINT]["age_days"] > 21
    assert m["jointwear_joint_estimate_age_seconds"][STALE_JOINT] > 21 * DAY
    # the outlier 20 above a flat history is held, seen, and changes nothing; the partial cycle is marked
    assert rows[OUTLIER_JOINT]["newest_estimate"] == "unconfirmed" and rows[OUTLIER_JOINT]["level"] == "OK"
    assert newest[OUTLIER_JOINT].wear > rows[OUTLIER_JOINT]["level_wear"] + 15
    assert tj[OUTLIER_JOINT]["condition"]["held"][-1]["status"] == "unconfirmed"
    assert rows[PARTIAL_JOINT]["evidence"] == "partial" and tj[PARTIAL_JOINT]["condition"]["evidence"] == "partial"
    # the fleet page (a static report of the same store) shows the same level and forecast for every joint
    from jointwear_ros.fleet.report import write_report

    with HistoryStore(plant_db) as store:
        # its table is what is compared (the plots: test_fleet.py); without them, 30 plots' CPU less
        index = write_report(store, Path(plant_db).parent / "fleet_page", version="live", plots=False)
    fleet = index.read_text()
    rows_f = {(r, j): (lv, ex) for r, j, lv, ex in re.findall(
        r"<td class=l>(\w+)</td><td class=l><a href='#[^']*'>(\w+)</a></td><td class=l data-level='(\w+)'>\w+</td>"
        r"<td class=l data-alarm-expected='(\w+)'>", fleet)}
    assert set(rows_f) == set(expected) and "<img src='img/" not in fleet
    for key in expected:
        assert rows_f[key] == (tj[key]["level"], "true" if tj[key]["alarm_expected"] else "false"), key
    counts = {name: float(sum(1 for k in tj if tj[k]["level"] == name)) for name in ("OK", "WARN", "ERROR", "STALE")}
    assert m["jointwear_joints"] == counts and counts["WARN"] >= 2 and counts["ERROR"] == counts["STALE"] == 1
    assert m["jointwear_store_up"][""] == 1.0 if "" in m["jointwear_store_up"] else True


@pytest.mark.slow
def test_trend_stale_days_moves_the_silent_joint_and_never_an_error(plant_db):
    tj = trend_json(plant_db, "--stale-days", "30")
    assert tj[STALE_JOINT]["level"] == "OK"
    tj = trend_json(plant_db, "--stale-days", "0.01")  # every joint silent for more than 15 minutes
    assert tj[ERROR_JOINT]["level"] == "ERROR"
    assert {j["level"] for k, j in tj.items() if k != ERROR_JOINT} == {"STALE"}
    r = subprocess.run([sys.executable, "-m", "jointwear_ros", "trend", "--db", plant_db, "--stale-days", "-1"],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--stale-days" in r.stderr


def test_the_plant_robot_and_joint_pages_and_their_plots(served):
    code, page = get(served + "/")
    counts = {name: sum(1 for j in api(served)["joints"] if j["level"] == name) for name in ("OK", "ERROR")}
    assert code == 200 and "1 ERROR" in page and f"{counts['OK']} OK" in page and 'src="/plot/plant.png' in page
    code, robot = get(served + f"/robot/{ERROR_JOINT[0]}")
    assert code == 200 and robot.count("<tr data-robot=") == 6 and robot.count('class="joint-plot"') == 6
    code, joint = get(served + f"/joint/{ERROR_JOINT[0]}/{ERROR_JOINT[1]}")
    assert code == 200 and "at the alarm now" in joint and joint.count("<tr><td>20") == 20  # newest 20 estimates
    for path in ("/plot/plant.png", f"/plot/{ERROR_JOINT[0]}/{ERROR_JOINT[1]}.png"):
        with urllib.request.urlopen(served + path, timeout=60) as r:
            png = r.read()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    # bounded: unknown names and other methods are refused, never looked up in the store
    assert get(served + "/joint/cell_1/joint_99")[0] == 404
    assert get(served + "/robot/" + "x" * 5000)[0] == 404
    assert get(served + "/plot/nobody/none.png")[0] == 404
    req = urllib.request.Request(served + "/api/joints", data=b"{}", method="POST")
    with pytest.raises(urllib.error.HTTPError) as exc:
        urllib.request.urlopen(req, timeout=10)
    assert exc.value.code == 405


def test_rank_puts_error_then_warn_then_stale_then_ok(served):
    from jointwear_ros.serve.core import JointView

    views = []
    for j in api(served)["joints"]:
        lv = int(DiagnosticLevel[j["level"]])
        views.append(JointView(j["robot"], j["joint"], lv, lv, j["wear"], j["wear_std"], 0.0, j["time"], 0.0,
                               j["days_to_alarm"], j["days_to_alarm_low"], j["days_to_alarm_high"], 1, 1, ""))
    order = [v.level_name for v in rank_views(views)]
    n_warn = order.count("WARN")
    assert n_warn >= 2 and order[: 2 + n_warn] == ["ERROR"] + ["WARN"] * n_warn + ["STALE"]
    assert set(order[2 + n_warn:]) == {"OK"}


# ---------------------------------------------------------------------------- live, read-only, faults


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.slow
def test_a_new_estimate_appears_on_the_page_and_in_metrics_without_a_restart(tmp_path):
    db = tmp_path / "plant.db"
    write_plant(str(db))
    proc, base = start_serve(str(db), "--refresh", "0.5")
    try:
        _, page = get(base + "/")
        version = int(re.search(r'<main data-version="(\d+)"', page).group(1))
        now = time.time()
        new = [EstimateRecord("cell_9", "joint_1", cycle_id=k + 1, time=now - (6 - k) * 3600.0, wear=41.0 + 0.1 * k,
                              wear_std=0.85) for k in range(6)]
        t0 = time.monotonic()
        with HistoryStore(str(db)) as store:  # the writer (wear_trend or history import) adds a joint at ERROR
            assert store.add_estimates(new) == 6
        wait_for(lambda: ("cell_9", "joint_1") in metrics(base).get("jointwear_joint_level", {}), 10, "metrics")
        delay = time.monotonic() - t0
        m = metrics(base)
        assert m["jointwear_joint_level"][("cell_9", "joint_1")] == 2.0 and m["jointwear_joints"]["ERROR"] == 2.0
        _, page = get(base + "/")
        assert int(re.search(r'<main data-version="(\d+)"', page).group(1)) > version
        assert '<tr data-robot="cell_9" data-joint="joint_1" data-level="ERROR" ' in page
        print(f"new estimate shown after {delay:.2f} s (refresh 0.5 s)")
        assert delay < 5.0  # the documented bound: --refresh plus one analysis of the store (< 1 s here)
    finally:
        stop(proc)


def test_serve_never_writes_and_survives_the_store_going_away_and_coming_back(tmp_path):
    db = tmp_path / "plant.db"
    write_plant(str(db))
    with HistoryStore(str(db)) as s:
        s.engine.dispose()
    before = _digest(db)
    proc, base = start_serve(str(db), "--refresh", "0.3")
    try:
        assert len(api(base)["joints"]) == 30
        db.rename(tmp_path / "moved.db")  # the store disappears (a remount, a move)
        wait_for(lambda: not api(base)["store_ok"], 10, "the failure to show")
        m = metrics(base)
        assert m["jointwear_store_up"] == {"": 0.0} if "" in m["jointwear_store_up"] else True
        # the last known level of every joint stays (marked by store_up 0): no critical alert resolves because the
        # store went away
        assert len(m["jointwear_joint_level"]) == 30 and m["jointwear_joint_level"][ERROR_JOINT] == 2.0
        _, page = get(base + "/")
        assert "History store not readable" in page and "not current" in page
        (tmp_path / "moved.db").rename(db)
        wait_for(lambda: api(base)["store_ok"], 10, "the store to be read again")
        assert len(metrics(base)["jointwear_joint_level"]) == 30
    finally:
        stop(proc)
    assert _digest(db) == before  # read-only: not a byte of the store changed
    assert not (tmp_path / "file:").exists()


def test_a_store_being_migrated_is_reported_then_served_once_migrated(tmp_path):
    db = tmp_path / "old.db"
    with HistoryStore(str(db), migrate_to=1) as s:  # schema version 1: a migration is pending
        s.add_estimates([EstimateRecord("r", "j", 1, time.time() - 3600, 10.0, 0.8)])
    proc, base = start_serve(str(db), "--refresh", "0.3")
    try:
        state = api(base)
        assert state["store_ok"] is False and "schema version 1" in state["error"] and state["joints"] == []
        assert "being created or migrated" in get(base + "/")[1]
        with HistoryStore(str(db)) as s:  # the owner migrates it
            assert s.schema_version() == SCHEMA_VERSION
        wait_for(lambda: api(base)["store_ok"], 10, "the migrated store to be read")
        assert [j["level"] for j in api(base)["joints"]] == ["OK"]
    finally:
        stop(proc)


def test_bad_db_and_a_port_in_use_are_one_line_and_exit_2(tmp_path, served, capsys):
    from jointwear_ros.cli import main

    junk = tmp_path / "junk.db"
    junk.write_bytes(b"this is not a database" * 100)
    port = int(served.rsplit(":", 1)[1])
    for args, what in [(["--db", str(tmp_path / "none.db")], "no such history file"),
                       (["--db", str(junk)], "not a jointwear history store"),
                       (["--db", "mysql://x@y/z"], "is not supported"),
                       (["--db", str(junk).replace("junk", "none"), "--port", "x"], "--port"),
                       (["--db", str(tmp_path / "none.db"), "--stale-days", "0"], "--stale-days")]:
        rc = main(["serve", *args])
        err = capsys.readouterr().err
        assert rc == 2 and err.count("\n") == 1 and what in err, (args, err)
        assert not (tmp_path / "none.db").exists()
    db = tmp_path / "ok.db"
    write_plant(str(db))
    rc = main(["serve", "--db", str(db), "--port", str(port)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "in use" in err, err


def test_an_unreachable_postgresql_is_reported_on_the_page_and_in_metrics(tmp_path):
    with socket.socket() as s:  # a port where nothing listens
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc, base = start_serve(f"postgresql://jw@127.0.0.1:{port}/plant", "--refresh", "0.5")
    try:
        state = api(base)
        assert state["store_ok"] is False and state["joints"] == [] and "127.0.0.1" in state["error"]
        assert metrics(base)["jointwear_store_up"] == {"": 0.0}
        _, page = get(base + "/")
        assert "History store not readable" in page
    finally:
        stop(proc)


def test_serve_reads_a_postgresql_history_as_the_trend_does(postgres_url):
    write_plant(postgres_url)
    tj = trend_json(postgres_url)
    proc, base = start_serve(postgres_url)
    try:
        rows = {(j["robot"], j["joint"]): j for j in api(base)["joints"]}
    finally:
        stop(proc)
    levels = {k: r["level"] for k, r in rows.items()}
    assert levels == {k: t["level"] for k, t in tj.items()}
    assert all(want is None or levels[k] == want for k, want in expected_levels().items())


def test_the_watcher_re_reads_only_the_joints_that_changed(tmp_path):
    from jointwear_ros.history import MaintenanceEvent
    from jointwear_ros.serve.watch import StoreWatcher
    from jointwear_ros.trend import TrendConfig

    db = str(tmp_path / "plant.db")
    write_plant(db)
    w = StoreWatcher(db, TrendConfig(), stale_days=7)
    try:
        s1 = w.poll()
        assert s1.store_ok and s1.last_changed == 30 and len(s1.views) == 30 and s1.estimates == 1800
        s2 = w.poll()
        assert (s2.loads, s2.version) == (s1.loads, s1.version)  # nothing changed: nothing re-read or re-shown
        with HistoryStore(db) as store:
            store.add_estimates([EstimateRecord("cell_1", "joint_1", 999, time.time() - 60, 9.0, 0.85)])
        s3 = w.poll()
        assert s3.last_changed == 1 and s3.version == s2.version + 1 and s3.estimates == 1801
        assert s3.joints[("cell_1", "joint_1")].result.estimates_total == 61
        assert all(s3.joints[k] is s2.joints[k] for k in s2.joints if k != ("cell_1", "joint_1"))
        with HistoryStore(db) as store:  # a maintenance event is a change of that joint too
            store.add_maintenance(MaintenanceEvent("cell_2", "joint_3", time.time() - 3 * DAY, "regrease"))
        s4 = w.poll()
        assert s4.last_changed == 1 and s4.joints[("cell_2", "joint_3")].result.segments == 2
    finally:
        w.stop()


def test_a_locked_store_is_reported_and_requests_stay_fast(tmp_path):
    import sqlite3

    db = tmp_path / "plant.db"
    write_plant(str(db))
    proc, base = start_serve(str(db), "--refresh", "0.3")
    locker = sqlite3.connect(str(db), timeout=1.0)
    try:
        assert api(base)["store_ok"]
        locker.execute("PRAGMA locking_mode=EXCLUSIVE")  # another program takes the store for itself
        locker.execute("BEGIN EXCLUSIVE")
        state = wait_for(lambda: (lambda a: a if not a["store_ok"] else None)(api(base)), 30, "the lock to show")
        assert "locked" in state["error"]
        t0 = time.monotonic()
        code, page = get(base + "/")  # served from the last snapshot, never waiting on the lock
        assert code == 200 and "History store not readable" in page and time.monotonic() - t0 < 2.0
        m = metrics(base)  # the last known levels stay, marked by the store-down series
        assert m["jointwear_store_up"].get("", 0.0) == 0.0 and len(m["jointwear_joint_level"]) == 30
        locker.rollback()
        locker.close()
        wait_for(lambda: api(base)["store_ok"], 30, "the store to be read again")
        assert len(api(base)["joints"]) == 30
    finally:
        locker.close()
        stop(proc)


def test_bad_rows_written_straight_into_the_store_never_hide_an_error_joint(tmp_path):
    # a joint at ERROR, then rows another tool wrote straight into the database (past the importer's
    # screening): wear 1e300, wear 0 with std 1e-300, ten years ahead, the year 2000. The page, the API and
    # /metrics keep the joint at ERROR and count the refused rows.
    import sqlite3

    db = tmp_path / "plant.db"
    now = time.time()
    with HistoryStore(str(db)) as store:
        assert store.add_estimates([EstimateRecord("cell_1", "joint_2", cycle_id=k + 1, time=now - (8 - k) * 86400.0,
                                                   wear=37.0 + 0.2 * k, wear_std=0.8) for k in range(8)]) == 8
    bad = [(100, now - 3600.0, 1e300, 0.8), (101, now - 1800.0, 0.0, 1e-300), (102, now + 10 * 365.25 * 86400, 5.0, 0.8),
           (103, 946684800.0, 40.0, 0.8)]
    with sqlite3.connect(db) as conn:
        for cid, t, w, s in bad:
            conn.execute("INSERT INTO estimates (robot, joint, hardware_id, cycle_id, time_ns, wear, wear_std, method, "
                         "params, software_version, bag, analysis_version, source, inserted_ns) VALUES "
                         "('cell_1', 'joint_2', '', ?, ?, ?, ?, '', '', '', '', 'live', 'live', ?)",
                         (cid, int(t * 1e9), w, s, int(now * 1e9)))
    proc, base = start_serve(str(db), "--refresh", "0.3")
    try:
        (row,) = [j for j in api(base)["joints"] if j["joint"] == "joint_2"]
        assert row["level"] == "ERROR" and 37.0 < row["wear"] < 40.0, row
        assert row["rows_refused"] == 4, row
        m = metrics(base)
        assert m["jointwear_joint_level"][("cell_1", "joint_2")] == 2.0
        assert m["jointwear_joint_estimates_refused"][("cell_1", "joint_2")] == 4.0
        _, page = get(base + "/")
        assert '<tr data-robot="cell_1" data-joint="joint_2" data-level="ERROR" ' in page
    finally:
        stop(proc)
