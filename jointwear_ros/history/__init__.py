"""The wear history store (SQLAlchemy Core: SQLite by default, PostgreSQL for a fleet) and its trend queries."""

from __future__ import annotations

from .screen import REASONS, Refusal, ScreenConfig
from .store import (
    LIVE,
    MIGRATIONS,
    SCHEMA_VERSION,
    EstimateRecord,
    HistoryError,
    HistoryStore,
    MaintenanceEvent,
    WriteResult,
    normalize_url,
)
from .trends import screened_history, trends_from_store

__all__ = [
    "LIVE",
    "MIGRATIONS",
    "REASONS",
    "SCHEMA_VERSION",
    "EstimateRecord",
    "HistoryError",
    "HistoryStore",
    "MaintenanceEvent",
    "Refusal",
    "ScreenConfig",
    "WriteResult",
    "normalize_url",
    "screened_history",
    "trends_from_store",
]
