"""The wear history store (SQLAlchemy Core over a backend: SQLite by default, PostgreSQL for a fleet) and its trend
queries."""

from __future__ import annotations

from .backends import BACKENDS, HistoryBackend, PostgresBackend, SqliteBackend, backend_for, register_backend
from .records import LIVE, EstimateRecord, MaintenanceEvent
from .screen import REASONS, Refusal, ScreenConfig
from .store import MIGRATIONS, SCHEMA_VERSION, HistoryError, HistoryStore, WriteResult, normalize_url
from .trends import screened_history, trends_from_store

__all__ = [
    "BACKENDS",
    "LIVE",
    "MIGRATIONS",
    "REASONS",
    "SCHEMA_VERSION",
    "EstimateRecord",
    "HistoryBackend",
    "HistoryError",
    "HistoryStore",
    "MaintenanceEvent",
    "PostgresBackend",
    "Refusal",
    "ScreenConfig",
    "SqliteBackend",
    "WriteResult",
    "backend_for",
    "normalize_url",
    "register_backend",
    "screened_history",
    "trends_from_store",
]
