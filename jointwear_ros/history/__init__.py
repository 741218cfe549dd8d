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
    WriteResult,
    normalize_url,
)
from .screen import REASONS, Refusal, ScreenConfig
from .trends import screened_history, trends_from_store

__all__ = [
    "LIVE",
    "MIGRATIONS",
    "SCHEMA_VERSION",
    "EstimateRecord",
    "HistoryError",
    "HistoryStore",
    "MaintenanceEvent",
    "REASONS",
    "Refusal",
    "ScreenConfig",
    "WriteResult",
    "normalize_url",
    "screened_history",
    "trends_from_store",
]
