"""The wear history store (SQLAlchemy Core over a backend: SQLite by default, PostgreSQL for a fleet), its records,
the outbox of a live writer (buffer, spool and retry of the estimates the store could not take yet) and its trend
queries. All storage IO of the suite is here."""

from __future__ import annotations

from .backends import BACKENDS, HistoryBackend, PostgresBackend, SqliteBackend, backend_for, register_backend
from .outbox import Outbox, SpoolPaths
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
    "Outbox",
    "PostgresBackend",
    "Refusal",
    "ScreenConfig",
    "SpoolPaths",
    "SqliteBackend",
    "WriteResult",
    "backend_for",
    "normalize_url",
    "register_backend",
    "screened_history",
    "trends_from_store",
]
