"""The wear history store (SQLAlchemy Core: SQLite by default, PostgreSQL for a fleet) and its trend queries."""

from __future__ import annotations

from .store import (
    LIVE,
    MIGRATIONS,
    SCHEMA_VERSION,
    EstimateRecord,
    HistoryError,
    HistoryStore,
    MaintenanceEvent,
    normalize_url,
)
from .trends import trends_from_store

__all__ = [
    "LIVE",
    "MIGRATIONS",
    "SCHEMA_VERSION",
    "EstimateRecord",
    "HistoryError",
    "HistoryStore",
    "MaintenanceEvent",
    "normalize_url",
    "trends_from_store",
]
