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
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import Any

from sqlalchemy import select

from ..history.store import fleet_bags_t

__all__ = ["LEDGER_SCHEMA_VERSION", "done_fingerprints", "ensure_ledger", "fleet_bags_t", "mark_done"]

#: The store's schema version that created ``fleet_bags`` (its migration 4).
LEDGER_SCHEMA_VERSION = 4


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
    with store.engine.connect() as conn:
        return {str(r[0]) for r in conn.execute(q).all()}


def mark_done(store: Any, analysis_version: str, outcomes: Iterable[Any]) -> int:
    """Record bags as done (idempotent); return how many rows were new."""
    now = time.time_ns()
    stmt = store.insert(fleet_bags_t).on_conflict_do_nothing(
        index_elements=["analysis_version", "fingerprint"]).returning(fleet_bags_t.c.id)
    n = 0
    with store.engine.begin() as conn:
        for o in outcomes:
            # the rows RETURNING gives back are the new ones, on every backend (a rowcount is -1 on psycopg)
            n += len(conn.execute(stmt.values(
                analysis_version=analysis_version, fingerprint=o.fingerprint, bag=o.bag,
                estimates=len(o.records), seconds=float(o.seconds), done_ns=now)).all())
    return n
