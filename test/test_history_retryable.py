"""Whether a database error is worth another attempt is the backend's to say, from the driver's error type and
code (issue 29, item 4), never from the message: with real locks on SQLite and PostgreSQL, and with errors whose
text reads like a lock while their code says otherwise."""

from __future__ import annotations

import sqlite3

import pytest
from conftest import driver_error
from sqlalchemy import event

from jointwear_ros.errors import one_line
from jointwear_ros.history import EstimateRecord, HistoryError, HistoryStore, backend_for
from jointwear_ros.history import store as store_mod

T0 = 1.75e9


def _rec(cycle: int) -> EstimateRecord:
    return EstimateRecord("robot_1", "joint_1", cycle_id=cycle, time=T0 + cycle, wear=20.0, wear_std=0.8)


class _Locked:
    """Another writer holding the history's ``estimates`` table (a real lock, through the driver itself)."""

    def __init__(self, url: str) -> None:
        self.url = url
        if url.startswith("sqlite"):
            self.conn = sqlite3.connect(url.split(":///", 1)[1], isolation_level=None)
            self.conn.execute("BEGIN EXCLUSIVE")
        else:
            import psycopg
            from sqlalchemy.engine import make_url

            plain = make_url(url).set(drivername="postgresql").render_as_string(hide_password=False)
            self.conn = psycopg.connect(plain)
            self.conn.execute("LOCK TABLE estimates IN ACCESS EXCLUSIVE MODE")

    def release(self) -> None:
        if self.conn is not None:
            self.conn.rollback()
            self.conn.close()
            self.conn = None


def test_a_real_lock_of_another_writer_is_retryable_and_says_so(db_url):
    HistoryStore(db_url).close()
    lock = _Locked(db_url)
    try:
        with HistoryStore(db_url, lock_timeout_s=0.1, write_attempts=1) as s:
            with pytest.raises(HistoryError, match="cannot write estimates") as info:
                s.write_estimates([_rec(1)])
    finally:
        lock.release()
    assert info.value.retryable, info.value
    with HistoryStore(db_url) as s:
        assert s.count() == 0


def test_the_store_retries_a_real_lock_until_the_other_writer_lets_go(db_url, monkeypatch):
    HistoryStore(db_url).close()
    lock = _Locked(db_url)
    pauses: list[float] = []

    def pause(seconds: float) -> None:  # the other writer commits while the store waits between attempts
        pauses.append(seconds)
        lock.release()

    monkeypatch.setattr(store_mod._time, "sleep", pause)
    try:
        with HistoryStore(db_url, lock_timeout_s=0.1, write_attempts=3) as s:
            assert s.write_estimates([_rec(1), _rec(2)]).added == 2
    finally:
        lock.release()
    assert len(pauses) == 1


def test_an_error_that_only_reads_like_a_lock_is_written_once_and_not_retryable(db_url, monkeypatch):
    monkeypatch.setattr(store_mod._time, "sleep", lambda s: None)
    attempts = []

    def fail(conn, cursor, statement, *args):
        if statement.lstrip().upper().startswith("INSERT INTO ESTIMATES"):
            attempts.append(statement)
            raise driver_error(s.dialect, "full_says_locked")

    with HistoryStore(db_url, write_attempts=5) as s:
        event.listen(s.engine, "before_cursor_execute", fail)
        with pytest.raises(HistoryError, match="cannot write estimates") as info:
            s.write_estimates([_rec(1)])
        event.remove(s.engine, "before_cursor_execute", fail)
    assert len(attempts) == 1 and not info.value.retryable


@pytest.mark.parametrize(("url", "code", "retryable"), [
    ("sqlite:///h.db", 5, True),  # SQLITE_BUSY
    ("sqlite:///h.db", 6, True),  # SQLITE_LOCKED
    ("sqlite:///h.db", 5 | (2 << 8), True),  # SQLITE_BUSY_SNAPSHOT: an extended code of BUSY
    ("sqlite:///h.db", 13, False),  # SQLITE_FULL
    ("sqlite:///h.db", 11, False),  # SQLITE_CORRUPT
    ("sqlite:///h.db", None, False),  # no code at all: never decided by the text
])
def test_sqlite_says_busy_and_locked_are_retryable_by_their_code(url, code, retryable):
    exc = sqlite3.OperationalError("database is locked")
    if code is not None:
        exc.sqlite_errorcode = code
    assert backend_for(url).retryable(exc) is retryable


@pytest.mark.parametrize(("sqlstate", "retryable"), [
    ("40001", True), ("40P01", True), ("55P03", True), ("08006", True), ("08001", True),
    ("53100", False), ("23505", False), ("42P01", False), ("40002", False), (None, False),
])
def test_postgresql_says_which_sqlstates_are_retryable(sqlstate, retryable):
    from sqlalchemy.exc import OperationalError

    class DriverError(Exception):
        pass

    orig = DriverError("deadlock detected")
    orig.sqlstate = sqlstate
    b = backend_for("postgresql://u@h/d")
    assert b.retryable(orig) is retryable
    assert b.retryable(OperationalError("INSERT ...", {}, orig)) is retryable  # as SQLAlchemy wraps it
    old = DriverError("could not serialize access")  # psycopg2 names it pgcode
    old.pgcode = sqlstate
    assert b.retryable(old) is retryable


def test_one_line_is_the_drivers_first_line_not_the_wrappers_statement():
    from sqlalchemy.exc import OperationalError

    wrapped = OperationalError("INSERT INTO estimates ...", {"wear": 1.0}, sqlite3.OperationalError("disk I/O error"))
    assert one_line(wrapped) == "disk I/O error"
    assert one_line(ValueError("first\nsecond")) == "first" and one_line(RuntimeError()) == "RuntimeError"
