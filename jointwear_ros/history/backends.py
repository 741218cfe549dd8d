"""History backends: the databases a wear history can live in, behind one protocol.

A backend is chosen once, from the URL's scheme (:func:`backend_for`), as rosbags' reader picks a
storage plugin from one mapping; the store (:class:`~jointwear_ros.history.HistoryStore`), the
fleet ledger, ``jointwear serve`` and the CLI then ask the backend and never look at the URL or
the dialect again. A backend knows how to reach its database three ways (to write, to read
without ever writing, and to watch with short timeouts for the web service), which ``INSERT``
skips an existing row (``ON CONFLICT DO NOTHING``), whether it keeps its data in a file, and which of
its errors may pass when the transaction is run again (:meth:`HistoryBackend.retryable`, by the driver's
error code: the store and the fleet ledger retry those, never by matching a message).

Built in (:data:`BACKENDS`, scheme -> class):

- :class:`SqliteBackend`: ``sqlite:///path`` (a bare path too), ``sqlite://`` in memory. Writers
  use WAL, ``synchronous=FULL`` and a 30 s busy timeout; a reader opens the file ``mode=ro``
  while a writer has it open and ``immutable`` otherwise (never a side file, never a new file).
- :class:`PostgresBackend`: ``postgresql://`` / ``postgres://`` (given the psycopg 3 driver) and
  ``postgresql+psycopg://``; readers' sessions are read-only transactions.

A new one is a class following :class:`HistoryBackend` added with :func:`register_backend`
(docs/extending.md, "A history backend"). The schema, its migrations and every query are the
store's, in SQLAlchemy Core: a backend needs a SQLAlchemy dialect with ``INSERT ... ON CONFLICT
DO NOTHING ... RETURNING``.

>>> b = backend_for("h.db")
>>> b.name, b.url, b.file.name
('sqlite', 'sqlite:///h.db', 'h.db')
>>> backend_for("postgres://u@db.cell/wear").url
'postgresql+psycopg://u@db.cell/wear'
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, ClassVar, Protocol, runtime_checkable

from sqlalchemy import Table, create_engine, event
from sqlalchemy.engine import Engine
from sqlalchemy.pool import NullPool

from ..errors import InputDataError, JointwearError

__all__ = [
    "BACKENDS",
    "PG_RETRYABLE",
    "SQLITE_RETRYABLE",
    "HistoryBackend",
    "HistoryError",
    "PostgresBackend",
    "SqliteBackend",
    "backend_for",
    "normalize_url",
    "register_backend",
]


class HistoryError(JointwearError):
    """The history store cannot be opened, migrated, read or written.

    ``retryable``: the backend said the database error behind it may pass when the transaction is run
    again (:meth:`HistoryBackend.retryable`: a lock, a deadlock, a serialization failure); ``detail``: that
    error's one line, without the store's URL.
    """

    def __init__(self, message: str, *, retryable: bool = False, detail: str = "") -> None:
        super().__init__(message)
        self.retryable = bool(retryable)
        self.detail = detail or message


@runtime_checkable
class HistoryBackend(Protocol):
    """What the history store needs from a database kind.

    ``name`` is the SQLAlchemy dialect name (``store.dialect``); ``url`` the normalized URL the
    backend was made from (``Backend(url)``; :meth:`canonical` normalizes a URL of its schemes).
    """

    name: ClassVar[str]
    url: str

    @classmethod
    def canonical(cls, url: str) -> str:
        """The URL as this backend stores it (its driver named)."""
        ...

    @property
    def display_url(self) -> str:
        """The URL to show a user (no password)."""
        ...

    @property
    def file(self) -> Path | None:
        """The file the history lives in; None for a server or an in-memory database."""
        ...

    def exists(self) -> bool:
        """Whether the database is there to be read, without creating anything (a server: True; it
        answers on connect)."""
        ...

    def engine(self, *, read_only: bool = False, lock_timeout_s: float | None = None) -> Engine:
        """An engine to write (creating a missing database where the kind can), or, ``read_only``, one that
        never writes and never creates anything. ``lock_timeout_s``: how long a statement waits for a lock
        another writer holds before it fails (None: the kind's default; a live node keeps it short, so it is
        never blocked for long)."""
        ...

    def watch_engine(self, timeout_s: float) -> Engine:
        """A read-only engine for a long-running reader (``jointwear serve``): short connect and
        statement timeouts, no pooled connection kept on a file; :class:`HistoryError` when there is
        nothing to watch."""
        ...

    def insert(self, table: Table) -> Any:
        """``INSERT`` into ``table`` with ``.on_conflict_do_nothing(index_elements=...)`` and ``.returning``."""
        ...

    def retryable(self, exc: BaseException) -> bool:
        """Whether a database error (SQLAlchemy's, or the driver's own) may pass when its transaction is run
        again: a lock another writer held, a deadlock, a serialization failure. Decided by the driver's
        error type and code, never by the message (translated with the server's locale)."""
        ...


class SqliteBackend:
    """An SQLite file (``sqlite:///path``) or an in-memory database (``sqlite://``)."""

    name: ClassVar[str] = "sqlite"

    def __init__(self, url: str) -> None:
        self.url = url
        self.path = url.split(":///", 1)[1] if ":///" in url else ""

    @classmethod
    def canonical(cls, url: str) -> str:
        return url

    @property
    def display_url(self) -> str:
        return self.url

    @property
    def file(self) -> Path | None:
        return Path(self.path).expanduser() if self.path and self.path != ":memory:" else None

    def exists(self) -> bool:
        return not self.path or Path(self.path).expanduser().is_file()

    def engine(self, *, read_only: bool = False, lock_timeout_s: float | None = None) -> Engine:
        f = self.file
        if read_only and f is not None:
            return _sqlite_read_only_engine(f)
        if f is not None:
            f.parent.mkdir(parents=True, exist_ok=True)
        wait = 30.0 if lock_timeout_s is None else float(lock_timeout_s)  # SQLite's default: a 30 s busy timeout
        engine = create_engine(self.url, connect_args={"timeout": wait})
        ms = max(1, int(wait * 1000))
        event.listen(engine, "connect", lambda conn, rec: _sqlite_pragmas(conn, rec, ms))
        return engine

    def watch_engine(self, timeout_s: float) -> Engine:
        import sqlite3
        from urllib.parse import quote

        f = self.file
        if f is None:
            raise HistoryError(f"{self.url}: an in-memory SQLite store has no history to serve; give a file path")
        p = f.resolve()
        if not p.is_file():
            raise HistoryError(f"{p}: no such history file (fill it with jointwear history import or wear_trend)")
        uri = f"file:{quote(str(p))}?mode=ro"

        def connect() -> sqlite3.Connection:
            return sqlite3.connect(uri, uri=True, timeout=timeout_s, check_same_thread=False)

        return create_engine("sqlite://", creator=connect, poolclass=NullPool)

    def insert(self, table: Table) -> Any:
        from sqlalchemy.dialects.sqlite import insert

        return insert(table)

    def retryable(self, exc: BaseException) -> bool:
        """``sqlite3.OperationalError`` whose primary result code is SQLITE_BUSY or SQLITE_LOCKED (the
        database, or a table, held by another connection past the busy timeout).

        >>> import sqlite3
        >>> busy = sqlite3.OperationalError("database is locked"); busy.sqlite_errorcode = 5
        >>> full = sqlite3.OperationalError("database is locked"); full.sqlite_errorcode = 13
        >>> b = SqliteBackend("sqlite://")
        >>> b.retryable(busy), b.retryable(full), b.retryable(sqlite3.OperationalError("database is locked"))
        (True, False, False)
        """
        import sqlite3

        orig = _driver_error(exc)
        code = getattr(orig, "sqlite_errorcode", None)
        return isinstance(orig, sqlite3.OperationalError) and isinstance(code, int) and (code & 0xFF) in SQLITE_RETRYABLE


class PostgresBackend:
    """A PostgreSQL database (a fleet's shared history), through psycopg 3."""

    name: ClassVar[str] = "postgresql"

    def __init__(self, url: str) -> None:
        self.url = url

    @classmethod
    def canonical(cls, url: str) -> str:
        return "postgresql+psycopg://" + url.split("://", 1)[1]

    @property
    def display_url(self) -> str:
        from sqlalchemy.engine import make_url

        try:
            return make_url(self.url).render_as_string(hide_password=True)
        except Exception:
            return self.url

    @property
    def file(self) -> Path | None:
        return None

    def exists(self) -> bool:
        return True

    def engine(self, *, read_only: bool = False, lock_timeout_s: float | None = None) -> Engine:
        # PostgreSQL's default: no lock timeout (a writer waits its turn); a short one only when asked
        args = {} if lock_timeout_s is None else {"options": f"-c lock_timeout={max(1, int(lock_timeout_s * 1000))}"}
        engine = create_engine(self.url, pool_pre_ping=True, connect_args=args)
        if read_only:
            event.listen(engine, "connect", _pg_read_only)
        return engine

    def watch_engine(self, timeout_s: float) -> Engine:
        opts = f"-c default_transaction_read_only=on -c statement_timeout={int(timeout_s * 4000)}"
        return create_engine(self.url, pool_pre_ping=True, pool_size=1, max_overflow=1,
                             connect_args={"connect_timeout": max(1, int(timeout_s)), "options": opts})

    def insert(self, table: Table) -> Any:
        from sqlalchemy.dialects.postgresql import insert

        return insert(table)

    def retryable(self, exc: BaseException) -> bool:
        """An error whose SQLSTATE (psycopg's ``sqlstate``, psycopg2's ``pgcode``) is a serialization failure
        (40001), a deadlock (40P01), a lock not available (55P03: the lock timeout) or a connection exception
        (class 08).

        >>> class E(Exception):
        ...     sqlstate = "40P01"
        >>> b = PostgresBackend("postgresql+psycopg://u@h/d")
        >>> b.retryable(E("deadlock detected")), b.retryable(Exception("deadlock detected"))
        (True, False)
        """
        orig = _driver_error(exc)
        code = getattr(orig, "sqlstate", None) or getattr(orig, "pgcode", None)
        return isinstance(code, str) and (code in PG_RETRYABLE or code[:2] in PG_RETRYABLE_CLASSES)


#: SQLite primary result codes of a database another connection holds: SQLITE_BUSY, SQLITE_LOCKED.
SQLITE_RETRYABLE = frozenset({5, 6})
#: PostgreSQL SQLSTATEs of a transaction that may pass when run again: serialization_failure, deadlock_detected,
#: lock_not_available (a lock timeout).
PG_RETRYABLE = frozenset({"40001", "40P01", "55P03"})
#: PostgreSQL SQLSTATE classes that may pass when run again: 08, connection exception.
PG_RETRYABLE_CLASSES = frozenset({"08"})


def _driver_error(exc: BaseException) -> BaseException:
    """The driver's own error behind a SQLAlchemy one (``exc.orig``), else ``exc``."""
    orig = getattr(exc, "orig", None)
    return orig if isinstance(orig, BaseException) else exc


#: URL scheme -> backend class: the one place a URL's kind is decided.
BACKENDS: dict[str, type[HistoryBackend]] = {
    "sqlite": SqliteBackend,
    "sqlite+pysqlite": SqliteBackend,
    "postgresql": PostgresBackend,
    "postgres": PostgresBackend,
    "postgresql+psycopg": PostgresBackend,
}
_BUILT_IN = frozenset(BACKENDS)


def register_backend(scheme: str, cls: type[HistoryBackend]) -> type[HistoryBackend]:
    """Make URLs ``<scheme>://...`` open with ``cls``; a scheme already taken by another class is an error."""
    key = str(scheme).strip().lower()
    if not key or "://" in key:
        raise InputDataError(f"backend scheme {scheme!r}: give the scheme alone, as 'sqlite' or 'postgresql'")
    old = BACKENDS.get(key)
    if old is not None and old is not cls:
        raise InputDataError(f"URL scheme {key!r} is taken by {old.__module__}.{old.__qualname__}")
    BACKENDS[key] = cls
    return cls


def _split(url: str | Path) -> tuple[str, type[HistoryBackend]]:
    u = str(url).strip()
    if not u:
        raise InputDataError("database URL is empty: give a path (SQLite file) or sqlite:///path or postgresql://...")
    if "://" not in u:
        u = f"sqlite:///{u}"
    scheme = u.split("://", 1)[0].lower()
    cls = BACKENDS.get(scheme)
    if cls is None:
        others = sorted(set(BACKENDS) - _BUILT_IN)
        raise InputDataError(f"database URL scheme {scheme + '://'!r} is not supported: use a file path, "
                             "sqlite:///path or postgresql://user@host/db"
                             + (f" (or {', '.join(s + '://' for s in others)})" if others else ""))
    return cls.canonical(u), cls


def normalize_url(url: str | Path) -> str:
    """``path`` -> ``sqlite:///path``; ``postgresql://`` -> ``postgresql+psycopg://``; others as their backend has them.

    >>> normalize_url("h.db"), normalize_url("postgresql://u@/d?host=/tmp")
    ('sqlite:///h.db', 'postgresql+psycopg://u@/d?host=/tmp')
    """
    return _split(url)[0]


def backend_for(url: str | Path) -> HistoryBackend:
    """The backend of ``url`` (a bare path is an SQLite file); :class:`InputDataError` for an unknown scheme."""
    u, cls = _split(url)
    return cls(u)  # type: ignore[call-arg]


# -- SQLite and PostgreSQL session settings -------------------------------------------------------
def _sqlite_read_only_engine(path: Path) -> Engine:
    """An engine that never writes and never creates a file: a reader who may only read the history (another
    user, a read-only filesystem) must not leave ``-wal``/``-shm`` files that block the owner's writes.

    While a writer has the database open (its ``-wal`` exists) the reader joins it read-only (``mode=ro``);
    otherwise nobody is writing and the file is opened ``immutable`` (no locks, no side files).
    """
    import sqlite3
    from urllib.parse import quote

    if not path.is_file():
        raise HistoryError(f"{path}: no such history file")
    uri = "file:" + quote(str(path.resolve()))
    uri += "?mode=ro" if Path(str(path) + "-wal").exists() else "?immutable=1"

    def connect() -> sqlite3.Connection:
        conn = sqlite3.connect(uri, uri=True, timeout=30.0, check_same_thread=False)
        conn.execute("PRAGMA query_only=1")
        return conn

    return create_engine("sqlite://", creator=connect)


def _pg_read_only(dbapi_conn: Any, _record: Any) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("SET SESSION CHARACTERISTICS AS TRANSACTION READ ONLY")
    cur.close()
    dbapi_conn.commit()


def _sqlite_pragmas(dbapi_conn: Any, _record: Any, busy_ms: int = 30000) -> None:
    cur = dbapi_conn.cursor()
    cur.execute("PRAGMA journal_mode=WAL")
    cur.execute("PRAGMA synchronous=FULL")
    cur.execute(f"PRAGMA busy_timeout={int(busy_ms)}")
    cur.close()
