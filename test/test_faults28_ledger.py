"""The fleet ledger meets other writers in the database (issue 28, item 5): a deadlock, a serialization failure or
an SQLite lock is retried a bounded number of times, decided by the driver's SQLSTATE / SQLite error code (not the
message); one that outlasts the retries is one line and exit 2, never an "internal error"."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import pytest
from conftest import driver_error
from sqlalchemy import event, select
from sqlalchemy.engine import Engine

from jointwear_ros.cli import main as cli_main
from jointwear_ros.fleet import ledger
from jointwear_ros.fleet.ledger import RETRIES, LedgerBusyError, ensure_ledger, mark_done
from jointwear_ros.history import HistoryError, HistoryStore
from jointwear_ros.history.store import fleet_bags_t


@dataclass
class _Outcome:
    """What mark_done reads of a finished bag."""

    fingerprint: str
    bag: str = ""
    records: list[Any] = field(default_factory=list)
    seconds: float = 0.1


class _FailLedgerInserts:
    """Raise ``make()`` from the driver for the first ``times`` INSERTs into fleet_bags on ``target``."""

    def __init__(self, target: Any, make: Any, times: int) -> None:
        self.target, self.make, self.left, self.attempts = target, make, times, 0

    def __call__(self, conn: Any, cursor: Any, statement: str, *args: Any) -> None:
        if statement.lstrip().upper().startswith("INSERT INTO FLEET_BAGS"):
            self.attempts += 1
            if self.left > 0:
                self.left -= 1
                raise self.make()

    def __enter__(self) -> _FailLedgerInserts:
        event.listen(self.target, "before_cursor_execute", self)
        return self

    def __exit__(self, *exc: object) -> None:
        event.remove(self.target, "before_cursor_execute", self)


def _done(store: HistoryStore) -> list[str]:
    with store.engine.connect() as conn:
        return sorted(r[0] for r in conn.execute(select(fleet_bags_t.c.fingerprint)).all())


def test_a_transient_error_in_the_ledger_is_retried_and_every_bag_recorded(db_url, monkeypatch):
    pauses: list[float] = []
    monkeypatch.setattr(ledger.time, "sleep", pauses.append)
    with HistoryStore(db_url) as store:
        ensure_ledger(store)
        with _FailLedgerInserts(store.engine, lambda: driver_error(store.dialect, "busy"), times=RETRIES - 1) as fail:
            assert mark_done(store, "v1", [_Outcome("fb"), _Outcome("fa")]) == 2
        assert _done(store) == ["fa", "fb"]
    assert fail.attempts == RETRIES - 1 + 2  # every failed attempt was one INSERT; the last did both bags
    assert len(pauses) == RETRIES - 1 and pauses == sorted(pauses) and pauses[0] > 0  # a growing pause between


def test_an_error_that_only_reads_like_a_deadlock_is_not_retried(db_url, monkeypatch):
    monkeypatch.setattr(ledger.time, "sleep", lambda s: None)
    with HistoryStore(db_url) as store:
        ensure_ledger(store)
        with _FailLedgerInserts(store.engine, lambda: driver_error(store.dialect, "full_says_locked"),
                                times=RETRIES) as fail:
            with pytest.raises(HistoryError, match="cannot record the bags done") as info:
                mark_done(store, "v1", [_Outcome("fa")])
        assert not isinstance(info.value, LedgerBusyError) and fail.attempts == 1
        assert _done(store) == []


def test_a_deadlock_that_outlasts_the_retries_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    from jointwear_ros.fleet.synthetic_bags import fleet_specs, write_fleet

    monkeypatch.setattr(ledger.time, "sleep", lambda s: None)
    bags = write_fleet(tmp_path / "bags", fleet_specs(1, 1, 1, rates=(0.0,), start_wear=15.0, method="joint"))
    db = tmp_path / "h.db"
    with _FailLedgerInserts(Engine, lambda: driver_error("sqlite", "busy"), times=10 * RETRIES) as fail:
        rc = cli_main(["fleet", "reprocess", str(bags[0]), "--db", str(db), "--workers", "1", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2, err
    assert len(err.strip().splitlines()) == 1 and "internal error" not in err
    assert "fleet ledger" in err and "database is locked" in err and f"each of {RETRIES} attempts" in err
    assert fail.attempts == RETRIES  # bounded
    # the estimates were written before the ledger: a rerun records the bag and duplicates nothing
    assert cli_main(["fleet", "reprocess", str(bags[0]), "--db", str(db), "--workers", "1", "--quiet",
                     "--json"]) == 0
    capsys.readouterr()
    with HistoryStore(f"sqlite:///{db}") as store:
        assert len(_done(store)) == 1


def test_a_real_postgresql_deadlock_with_another_writer_is_retried(postgres_url):
    """Two transactions insert two bags in opposite order: PostgreSQL aborts one with SQLSTATE 40P01."""
    import psycopg
    from sqlalchemy.engine import make_url

    plain = make_url(postgres_url).set(drivername="postgresql").render_as_string(hide_password=False)
    with HistoryStore(postgres_url) as store:
        ensure_ledger(store)
        with psycopg.connect(plain, autocommit=True) as watch:
            deadlocks0 = watch.execute("SELECT deadlocks FROM pg_stat_database WHERE datname = "
                                       "current_database()").fetchone()[0]
            with psycopg.connect(plain) as other:  # holds "fb", then wants "fa"
                insert = ("INSERT INTO fleet_bags (analysis_version, fingerprint, bag, estimates, seconds, done_ns) "
                          "VALUES ('v1', %s, 'other', 0, 0.0, 0)")
                other.execute(insert, ("fb",))
                outcome: dict[str, Any] = {}

                def run() -> None:  # inserts "fa" (fingerprint order), then waits for "fb"
                    try:
                        outcome["new"] = mark_done(store, "v1", [_Outcome("fb"), _Outcome("fa")])
                    except BaseException as exc:  # the test reports it below
                        outcome["error"] = exc

                t = threading.Thread(target=run)
                t.start()
                deadline = time.monotonic() + 60
                while not watch.execute("SELECT count(*) FROM pg_stat_activity WHERE datname = current_database() "
                                        "AND wait_event_type = 'Lock'").fetchone()[0]:
                    assert time.monotonic() < deadline, "the ledger's insert never waited for the other writer"
                    time.sleep(0.01)
                # the ledger waits for "fb" while holding "fa": this insert closes the cycle; the ledger, which
                # waited first, finds the deadlock (after deadlock_timeout) and is the one aborted
                other.execute(insert, ("fa",))
                other.commit()
                t.join(60)
            deadlocks = watch.execute("SELECT deadlocks FROM pg_stat_database WHERE datname = "
                                      "current_database()").fetchone()[0]
        assert "error" not in outcome, repr(outcome.get("error"))
        assert outcome["new"] == 0  # the other writer recorded both first; nothing duplicated
        assert deadlocks > deadlocks0 and _done(store) == ["fa", "fb"]
