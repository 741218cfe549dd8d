"""Which bags a re-analysis has already done: a small table beside the history's estimates.

``fleet_bags`` (one row per analysis version and bag fingerprint: the bag's
path, how many estimates it gave, the seconds it took, when it was done) lives
in the same database as the wear history (any history backend: SQLite,
PostgreSQL), so a re-analysis is resumable from wherever it runs: a bag whose
fingerprint is in the table for the same analysis version is skipped, also a
bag that gave no estimate (an aborted cycle), which the estimates table alone
could not tell. Rows are written after the bag's estimates (both idempotent),
so an interrupted run loses nothing and duplicates nothing. Failed bags get
no row: the next run tries them again.

The table is part of the store's schema (``jointwear_ros.history.store``, its migration 4): this module
only reads and writes it, through the store's backend.

Concurrent writers (two re-analyses of overlapping bags, a wear_trend node) can meet in the database: a
PostgreSQL deadlock (SQLSTATE ``40P01``) or serialization failure (``40001``), an SQLite write lock still
held after its busy timeout (``SQLITE_BUSY``/``SQLITE_LOCKED``). The ledger's read and its write are each one
transaction, retried up to :data:`RETRIES` times with a doubling pause when the error is one of these,
decided by the driver's exception (its SQLSTATE or SQLite error code, never its text:
:func:`is_transient`); a transient error that outlasts the retries is a :class:`LedgerBusyError` (one
line, exit 2: run again), any other database error a :class:`~jointwear_ros.history.HistoryError`.
Rows are inserted in fingerprint order, so two ledger writers take their locks in one order.
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Callable, Iterable
from typing import Any, TypeVar

from sqlalchemy import select
from sqlalchemy.exc import DBAPIError, SQLAlchemyError

from ..errors import TransientError
from ..history.backends import HistoryError
from ..history.store import fleet_bags_t

__all__ = [
    "LEDGER_SCHEMA_VERSION",
    "RETRIES",
    "LedgerBusyError",
    "done_fingerprints",
    "ensure_ledger",
    "fleet_bags_t",
    "is_transient",
    "mark_done",
]

#: The store's schema version that created ``fleet_bags`` (its migration 4).
LEDGER_SCHEMA_VERSION = 4
#: Attempts of one ledger transaction that meets a deadlock, serialization failure or lock.
RETRIES = 5
#: The pause before the second attempt, in seconds; doubled before each further one.
BACKOFF_S = 0.05
#: PostgreSQL SQLSTATEs of a transaction that may succeed when run again: deadlock_detected,
#: serialization_failure (class 40, "transaction rollback").
TRANSIENT_SQLSTATES = frozenset({"40P01", "40001"})
#: SQLite primary result codes of a database another connection holds: SQLITE_BUSY, SQLITE_LOCKED.
_SQLITE_BUSY_CODES = frozenset({5, 6})

T = TypeVar("T")


class LedgerBusyError(HistoryError, TransientError):
    """The ledger's transaction met a deadlock or a lock on every attempt."""


def is_transient(exc: BaseException) -> bool:
    """Whether a database error is a deadlock, serialization failure or lock: worth running again.

    Decided by the driver's exception (psycopg's ``sqlstate``, sqlite3's ``sqlite_errorcode``), not its
    message, which is translated with the server's locale.

    >>> import sqlite3
    >>> e = sqlite3.OperationalError("database is locked"); e.sqlite_errorcode = 5
    >>> is_transient(e), is_transient(sqlite3.OperationalError("database is locked"))
    (True, False)
    """
    orig = exc.orig if isinstance(exc, DBAPIError) else exc
    if getattr(orig, "sqlstate", None) in TRANSIENT_SQLSTATES:
        return True
    code = getattr(orig, "sqlite_errorcode", None)
    return isinstance(orig, sqlite3.Error) and isinstance(code, int) and (code & 0xFF) in _SQLITE_BUSY_CODES


def _first_line(exc: BaseException) -> str:
    orig = exc.orig if isinstance(exc, DBAPIError) else exc
    lines = str(orig).strip().splitlines()
    return lines[0] if lines else type(orig).__name__


def _retrying(store: Any, what: str, work: Callable[[], T]) -> T:
    """``work()`` (one transaction), run again after a transient database error, at most :data:`RETRIES` times."""
    for attempt in range(1, RETRIES + 1):
        try:
            return work()
        except SQLAlchemyError as exc:
            if not is_transient(exc):
                raise HistoryError(f"{store.display_url}: cannot {what}: {_first_line(exc)}") from None
            if attempt == RETRIES:
                raise LedgerBusyError(
                    f"{store.display_url}: cannot {what}: {_first_line(exc)} (a deadlock or lock with another "
                    f"writer on each of {RETRIES} attempts); nothing of this batch was recorded, run again to "
                    "finish the rest") from None
            time.sleep(BACKOFF_S * 2 ** (attempt - 1))
    raise AssertionError("unreachable")  # pragma: no cover


def ensure_ledger(store: Any) -> None:
    """Bring the store to the schema that holds ``fleet_bags`` (its own migration path; concurrent
    openers are fine). A store opened read-only, or one written by a newer jointwear, is refused there."""
    from ..history import HistoryError

    if store.schema_version() >= LEDGER_SCHEMA_VERSION:
        return
    if store.read_only:
        raise HistoryError(f"{store.display_url}: schema version {store.schema_version()} has no fleet ledger "
                           f"(version {LEDGER_SCHEMA_VERSION}); open it for writing to migrate it")
    store.migrate(LEDGER_SCHEMA_VERSION)


def done_fingerprints(store: Any, analysis_version: str) -> set[str]:
    """Fingerprints of the bags already done for ``analysis_version``."""
    q = select(fleet_bags_t.c.fingerprint).where(fleet_bags_t.c.analysis_version == analysis_version)

    def read() -> set[str]:
        with store.engine.connect() as conn:
            return {str(r[0]) for r in conn.execute(q).all()}

    return _retrying(store, "read the fleet ledger", read)


def mark_done(store: Any, analysis_version: str, outcomes: Iterable[Any]) -> int:
    """Record bags as done (idempotent, one transaction, retried on a deadlock or lock); return how many
    rows were new."""
    now = time.time_ns()
    stmt = store.insert(fleet_bags_t).on_conflict_do_nothing(
        index_elements=["analysis_version", "fingerprint"]).returning(fleet_bags_t.c.id)
    rows = sorted(({"analysis_version": analysis_version, "fingerprint": o.fingerprint, "bag": o.bag,
                    "estimates": len(o.records), "seconds": float(o.seconds), "done_ns": now} for o in outcomes),
                  key=lambda r: r["fingerprint"])  # one lock order for every ledger writer

    def write() -> int:
        n = 0
        with store.engine.begin() as conn:
            for row in rows:
                # the rows RETURNING gives back are the new ones, on every backend (a rowcount is -1 on psycopg)
                n += len(conn.execute(stmt.values(**row)).all())
        return n

    return _retrying(store, "record the bags done in the fleet ledger", write)
