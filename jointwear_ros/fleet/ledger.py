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
reads and writes it only through the store (:meth:`~jointwear_ros.history.HistoryStore.bags_done`,
:meth:`~jointwear_ros.history.HistoryStore.mark_bags_done`: no SQL here).

Concurrent writers (two re-analyses of overlapping bags, a wear_trend node) can meet in the database: a
PostgreSQL deadlock (SQLSTATE ``40P01``) or serialization failure (``40001``), an SQLite write lock still
held after its busy timeout (``SQLITE_BUSY``/``SQLITE_LOCKED``). The ledger's read and its write are each one
transaction, retried up to :data:`RETRIES` times with a doubling pause when the error is one of these,
decided by the store's backend from the driver's exception (its SQLSTATE or SQLite error code, never its
text: :meth:`~jointwear_ros.history.HistoryBackend.retryable`, carried as ``HistoryError.retryable``); a
transient error that outlasts the retries is a :class:`LedgerBusyError` (one line, exit 2: run again), any
other database error a :class:`~jointwear_ros.history.HistoryError`.
Rows are inserted in fingerprint order, so two ledger writers take their locks in one order.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any, TypeVar

from ..errors import TransientError
from ..history.backends import HistoryError

__all__ = [
    "LEDGER_SCHEMA_VERSION",
    "RETRIES",
    "LedgerBusyError",
    "done_fingerprints",
    "ensure_ledger",
    "mark_done",
]

#: The store's schema version that created ``fleet_bags`` (its migration 4).
LEDGER_SCHEMA_VERSION = 4
#: Attempts of one ledger transaction that meets a deadlock, serialization failure or lock.
RETRIES = 5
#: The pause before the second attempt, in seconds; doubled before each further one.
BACKOFF_S = 0.05

T = TypeVar("T")


class LedgerBusyError(HistoryError, TransientError):
    """The ledger's transaction met a deadlock or a lock on every attempt."""


def _retrying(store: Any, what: str, work: Callable[[], T]) -> T:
    """``work()`` (one transaction of the store), run again after an error its backend calls retryable, at most
    :data:`RETRIES` times."""
    for attempt in range(1, RETRIES + 1):
        try:
            return work()
        except HistoryError as exc:
            if not exc.retryable:
                raise HistoryError(f"{store.display_url}: cannot {what}: {exc.detail}") from None
            if attempt == RETRIES:
                raise LedgerBusyError(
                    f"{store.display_url}: cannot {what}: {exc.detail} (a deadlock or lock with another "
                    f"writer on each of {RETRIES} attempts); nothing of this batch was recorded, run again to "
                    "finish the rest", retryable=True, detail=exc.detail) from None
            time.sleep(BACKOFF_S * 2 ** (attempt - 1))
    raise AssertionError("unreachable")  # pragma: no cover


def ensure_ledger(store: Any) -> None:
    """Bring the store to the schema that holds ``fleet_bags`` (its own migration path; concurrent
    openers are fine). A store opened read-only, or one written by a newer jointwear, is refused there."""
    if store.schema_version() >= LEDGER_SCHEMA_VERSION:
        return
    if store.read_only:
        raise HistoryError(f"{store.display_url}: schema version {store.schema_version()} has no fleet ledger "
                           f"(version {LEDGER_SCHEMA_VERSION}); open it for writing to migrate it")
    store.migrate(LEDGER_SCHEMA_VERSION)


def done_fingerprints(store: Any, analysis_version: str) -> set[str]:
    """Fingerprints of the bags already done for ``analysis_version``."""
    return _retrying(store, "read the fleet ledger", lambda: store.bags_done(analysis_version))


def mark_done(store: Any, analysis_version: str, outcomes: Iterable[Any]) -> int:
    """Record bags as done (idempotent, one transaction, retried on a deadlock or lock); return how many
    rows were new."""
    bags = [{"fingerprint": o.fingerprint, "bag": o.bag, "estimates": len(o.records), "seconds": float(o.seconds)}
            for o in outcomes]
    return _retrying(store, "record the bags done in the fleet ledger",
                     lambda: store.mark_bags_done(analysis_version, bags))
