"""Which bags a re-analysis has already done: a small table beside the history's estimates.

``fleet_bags`` (one row per analysis version and bag fingerprint: the bag's
path, how many estimates it gave, the seconds it took, when it was done) lives
in the same database as the wear history (SQLite or PostgreSQL, the store's
engine), so a re-analysis is resumable from wherever it runs: a bag whose
fingerprint is in the table for the same analysis version is skipped, also a
bag that gave no estimate (an aborted cycle), which the estimates table alone
could not tell. Rows are written after the bag's estimates (both idempotent),
so an interrupted run loses nothing and duplicates nothing. Failed bags get
no row: the next run tries them again.

SQLAlchemy Core, created with ``checkfirst`` on first use.
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from typing import Any

from sqlalchemy import BigInteger, Column, Float, Integer, MetaData, String, Table, Text, UniqueConstraint, select
from sqlalchemy.exc import SQLAlchemyError

__all__ = ["done_fingerprints", "ensure_ledger", "fleet_bags_t", "mark_done"]

_metadata = MetaData()

fleet_bags_t = Table(
    "fleet_bags", _metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("analysis_version", String(200), nullable=False),
    Column("fingerprint", String(100), nullable=False),
    Column("bag", Text, nullable=False),
    Column("estimates", Integer, nullable=False),
    Column("seconds", Float, nullable=False),
    Column("done_ns", BigInteger, nullable=False),
    UniqueConstraint("analysis_version", "fingerprint", name="uq_fleet_bag"),
)


def _insert(store: Any) -> Any:
    if store.dialect == "postgresql":
        from sqlalchemy.dialects.postgresql import insert
    else:
        from sqlalchemy.dialects.sqlite import insert  # type: ignore[assignment]
    return insert(fleet_bags_t)


def ensure_ledger(store: Any) -> None:
    """Create ``fleet_bags`` if missing (concurrent creators are fine)."""
    from ..history import HistoryError

    try:
        _metadata.create_all(store.engine, checkfirst=True)
    except SQLAlchemyError as exc:
        from sqlalchemy import inspect

        if not inspect(store.engine).has_table("fleet_bags"):  # not just a lost race on CREATE TABLE
            raise HistoryError(f"{store.display_url}: cannot create the fleet_bags table: "
                               f"{str(exc).splitlines()[0]}") from None


def done_fingerprints(store: Any, analysis_version: str) -> set[str]:
    """Fingerprints of the bags already done for ``analysis_version``."""
    q = select(fleet_bags_t.c.fingerprint).where(fleet_bags_t.c.analysis_version == analysis_version)
    with store.engine.connect() as conn:
        return {str(r[0]) for r in conn.execute(q).all()}


def mark_done(store: Any, analysis_version: str, outcomes: Iterable[Any]) -> int:
    """Record bags as done (idempotent); return how many rows were new."""
    now = time.time_ns()
    stmt = _insert(store).on_conflict_do_nothing(index_elements=["analysis_version", "fingerprint"])
    n = 0
    with store.engine.begin() as conn:
        for o in outcomes:
            n += int(conn.execute(stmt.values(
                analysis_version=analysis_version, fingerprint=o.fingerprint, bag=o.bag,
                estimates=len(o.records), seconds=float(o.seconds), done_ns=now)).rowcount or 0)
    return n
