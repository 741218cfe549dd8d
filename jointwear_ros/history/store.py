"""The wear history store: every estimate of every joint, and its maintenance events.

One schema and one code path (SQLAlchemy Core) for the embedded default, an
SQLite file (``sqlite:///path``; WAL journal, a busy timeout, so a reader and
the ``wear_trend`` node can share it), and PostgreSQL for a fleet
(``postgresql+psycopg://user@host/db``; a plain ``postgresql://`` URL is given
the psycopg 3 driver). A bare path is taken as an SQLite file. What differs
between the two is a backend (:mod:`jointwear_ros.history.backends`), chosen
once from the URL; nothing here asks which one it is.

Tables
------
``estimates``
    robot, joint, hardware_id, cycle_id, time_ns (the estimate's stamp, ns
    since the epoch, rounded to the microsecond), wear, wear_std, temperature (°C, NaN/NULL when not
    estimated), method, params (parameter set), software_version, bag (where
    it was read from; ``""`` live), analysis_version (``"live"`` for the
    estimates the cell made; a re-estimation with another model writes its
    own version), source (``live``, ``bag``, ``csv``: how the row entered the history), inserted_ns,
    evidence, cycle_source (``test_cycle`` or ``production``: the WearEstimate's ``source``, where the
    estimate's observations came from; ``cycle_id`` is then the test cycle's or the production shift's).
    **Identity** ``UNIQUE (robot, joint, analysis_version, cycle_id, time_ns)``:
    the cycle id alone is not (a restarted test_cycle counts from 1 again),
    the time stamp makes it so; the bag is not part of it, so the estimates a
    live ``wear_trend`` stored and the same estimates imported later from the
    cell's bag are one entry, not two.
``maintenance``
    robot, joint, time_ns, kind (``regrease``, ``reducer_replaced``, ...),
    note; ``UNIQUE (robot, joint, time_ns, kind)``. An event starts a new
    segment of the joint's trend.
``refused``
    every estimate the screening refused (:mod:`~jointwear_ros.history.screen`: a wear or std
    outside the physical range, a time before 2010 or in the future, a jumped clock, a malformed
    value), kept with its values as text (exactly as given, NaN and 1e300 included), the reason code
    and a one-line explanation; never read by the trend. ``UNIQUE (robot, joint, analysis_version,
    cycle_id, time, wear, wear_std)``: the same bad row imported twice is one entry.
``fleet_bags``
    the fleet ledger: one row per analysis version and bag fingerprint a re-analysis has done
    (:mod:`jointwear_ros.fleet.ledger` reads and writes it through :meth:`HistoryStore.bags_done` and
    :meth:`HistoryStore.mark_bags_done`; schema version 4 creates it).
    Schema version 5 adds ``estimates.evidence`` (``complete``/``partial``), version 6
    ``estimates.cycle_source`` (rows stored before it are ``test_cycle``: production estimates did not exist).
``schema_version``
    one row per applied migration (version, applied_ns). :data:`MIGRATIONS`
    are forward only; :meth:`HistoryStore.migrate` applies the missing ones
    in order, each in its own transaction.

Inserts are idempotent and safe under concurrent writers: ``INSERT ... ON
CONFLICT DO NOTHING`` through the backend's ``insert`` (SQLite and
PostgreSQL both have it), so two processes writing the same estimate leave
one row and neither fails. Each call of :meth:`HistoryStore.add_estimates`
is one transaction: after it returns, its rows are durable (SQLite
``synchronous=FULL`` in WAL mode), which is what the ``wear_trend`` node
relies on when it is killed.

>>> s = HistoryStore("sqlite://")               # in memory
>>> e = EstimateRecord("robot_1", "joint_1", cycle_id=1, time=1.7e9, wear=10.0, wear_std=0.8)
>>> s.add_estimates([e, e]), s.add_estimates([e])
(1, 0)
>>> [r.wear for r in s.estimates(robot="robot_1", joint="joint_1")]
[10.0]
>>> s.schema_version()
6
>>> r = s.write_estimates([EstimateRecord("robot_1", "joint_1", cycle_id=2, time=1.7e9, wear=1e300, wear_std=0.8)])
>>> r.added, [f.reason for f in r.refused], [x["wear"] for x in s.refused()]
(0, ['wear_out_of_range'], ['1e+300'])
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy import (
    BigInteger,
    Column,
    Float,
    Integer,
    MetaData,
    String,
    Table,
    Text,
    UniqueConstraint,
    func,
    inspect,
    select,
    text,
)
from sqlalchemy.engine import Connection, Engine
from sqlalchemy.exc import ArgumentError, OperationalError, SQLAlchemyError

from ..errors import InputDataError, one_line
from .backends import HistoryBackend, HistoryError, backend_for, normalize_url
from .records import LIVE, EstimateRecord, MaintenanceEvent
from .screen import Refusal, ScreenConfig, screen_record

__all__ = [
    "LIVE",
    "MIGRATIONS",
    "SCHEMA_VERSION",
    "EstimateRecord",
    "HistoryError",
    "HistoryStore",
    "MaintenanceEvent",
    "WriteResult",
    "fleet_bags_t",
    "normalize_url",
]

metadata = MetaData()

estimates_t = Table(
    "estimates", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("robot", String(200), nullable=False),
    Column("joint", String(200), nullable=False),
    Column("hardware_id", String(200), nullable=False, default=""),
    Column("cycle_id", BigInteger, nullable=False),
    Column("time_ns", BigInteger, nullable=False),
    Column("wear", Float, nullable=False),
    Column("wear_std", Float, nullable=False),
    Column("temperature", Float, nullable=True),
    Column("method", String(100), nullable=False, default=""),
    Column("params", String(200), nullable=False, default=""),
    Column("software_version", String(100), nullable=False, default=""),
    Column("bag", Text, nullable=False, default=""),
    Column("analysis_version", String(200), nullable=False, default=LIVE),
    Column("source", String(20), nullable=False, default="live"),
    Column("inserted_ns", BigInteger, nullable=False),
    Column("evidence", String(20), nullable=False, server_default="complete"),
    Column("cycle_source", String(20), nullable=False, server_default="test_cycle"),
    UniqueConstraint("robot", "joint", "analysis_version", "cycle_id", "time_ns", name="uq_estimate_identity"),
)

maintenance_t = Table(
    "maintenance", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("robot", String(200), nullable=False),
    Column("joint", String(200), nullable=False),
    Column("time_ns", BigInteger, nullable=False),
    Column("kind", String(100), nullable=False),
    Column("note", Text, nullable=False, default=""),
    UniqueConstraint("robot", "joint", "time_ns", "kind", name="uq_maintenance_identity"),
)

schema_version_t = Table(
    "schema_version", metadata,
    Column("version", Integer, primary_key=True, autoincrement=False),
    Column("applied_ns", BigInteger, nullable=False),
)


refused_t = Table(
    "refused", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("robot", String(200), nullable=False),
    Column("joint", String(200), nullable=False),
    Column("analysis_version", String(200), nullable=False, default=LIVE),
    Column("cycle_id", BigInteger, nullable=False),
    Column("time", String(40), nullable=False),
    Column("wear", String(40), nullable=False),
    Column("wear_std", String(40), nullable=False),
    Column("hardware_id", String(200), nullable=False, default=""),
    Column("method", String(100), nullable=False, default=""),
    Column("params", String(200), nullable=False, default=""),
    Column("bag", Text, nullable=False, default=""),
    Column("source", String(20), nullable=False, default="live"),
    Column("reason", String(40), nullable=False),
    Column("detail", Text, nullable=False, default=""),
    Column("inserted_ns", BigInteger, nullable=False),
    UniqueConstraint("robot", "joint", "analysis_version", "cycle_id", "time", "wear", "wear_std",
                     name="uq_refused_identity"),
)


fleet_bags_t = Table(
    "fleet_bags", metadata,
    Column("id", Integer, primary_key=True, autoincrement=True),
    Column("analysis_version", String(200), nullable=False),
    Column("fingerprint", String(100), nullable=False),
    Column("bag", Text, nullable=False),
    Column("estimates", Integer, nullable=False),
    Column("seconds", Float, nullable=False),
    Column("done_ns", BigInteger, nullable=False),
    UniqueConstraint("analysis_version", "fingerprint", name="uq_fleet_bag"),
)


def _m1(conn: Connection) -> None:
    """Version 1: the three tables."""
    metadata.create_all(conn, tables=[estimates_t, maintenance_t, schema_version_t])


def _m2(conn: Connection) -> None:
    """Version 2: indexes for the per-joint queries of the trend (robot, joint, time)."""
    conn.execute(text("CREATE INDEX IF NOT EXISTS ix_estimates_joint_time "
                      "ON estimates (robot, joint, analysis_version, time_ns)"))
    conn.execute(text("CREATE INDEX IF NOT EXISTS ix_maintenance_joint_time ON maintenance (robot, joint, time_ns)"))


def _m3(conn: Connection) -> None:
    """Version 3: the ``refused`` table; rows stored before the screening existed that it refuses (wear or std
    outside the physical range, a time before 2010 or in the future) move there, with their reason."""
    metadata.create_all(conn, tables=[refused_t])
    conn.execute(text("CREATE INDEX IF NOT EXISTS ix_refused_joint ON refused (robot, joint)"))
    c = ScreenConfig()
    now_ns = _time.time_ns()
    cases = [
        ("wear_out_of_range", f"wear < {c.wear_min!r} OR wear > {c.wear_max!r}"),
        ("std_out_of_range", f"wear_std < {c.std_min!r} OR wear_std > {c.std_max!r}"),
        ("time_before_min", f"time_ns < {int(c.min_time * 1e9)}"),
        ("time_in_future", f"time_ns > {now_ns + int(c.future_tolerance_s * 1e9)}"),
    ]
    for reason, cond in cases:
        conn.execute(text(
            "INSERT INTO refused (robot, joint, analysis_version, cycle_id, time, wear, wear_std, hardware_id, "
            "method, params, bag, source, reason, detail, inserted_ns) "
            "SELECT robot, joint, analysis_version, cycle_id, CAST(time_ns / 1000000000.0 AS VARCHAR(40)), "
            "CAST(wear AS VARCHAR(40)), CAST(wear_std AS VARCHAR(40)), hardware_id, method, params, bag, source, "
            f"'{reason}', 'moved by the schema-3 migration', {now_ns} FROM estimates WHERE {cond} "
            "ON CONFLICT DO NOTHING"))
        conn.execute(text(f"DELETE FROM estimates WHERE {cond}"))


def _m4(conn: Connection) -> None:
    """Version 4: the fleet ledger ``fleet_bags`` (:mod:`jointwear_ros.fleet.ledger`: which bags a re-analysis has
    done). A store where an earlier ``jointwear fleet reprocess`` created it already keeps its rows."""
    metadata.create_all(conn, tables=[fleet_bags_t], checkfirst=True)


def _m5(conn: Connection) -> None:
    """Version 5: ``estimates.evidence`` (``complete``/``partial``, :mod:`jointwear_ros.condition`); rows stored
    before it are ``complete`` (a store created at version 1 by this code has the column already)."""
    if "evidence" not in {c["name"] for c in inspect(conn).get_columns("estimates")}:
        conn.execute(text("ALTER TABLE estimates ADD COLUMN evidence VARCHAR(20) NOT NULL DEFAULT 'complete'"))


def _m6(conn: Connection) -> None:
    """Version 6: ``estimates.cycle_source`` (``test_cycle``/``production``, :class:`jointwear_ros.contract.Source`);
    rows stored before it are ``test_cycle`` (a store created at version 1 by this code has the column already)."""
    if "cycle_source" not in {c["name"] for c in inspect(conn).get_columns("estimates")}:
        conn.execute(text("ALTER TABLE estimates ADD COLUMN cycle_source VARCHAR(20) NOT NULL DEFAULT 'test_cycle'"))


#: forward migrations, version -> function; applied in order, each in its own transaction
MIGRATIONS: dict[int, Callable[[Connection], None]] = {1: _m1, 2: _m2, 3: _m3, 4: _m4, 5: _m5, 6: _m6}
SCHEMA_VERSION = max(MIGRATIONS)


class HistoryStore:
    """Wear estimates and maintenance events of robots' joints, in SQLite or PostgreSQL.

    Parameters
    ----------
    url : ``sqlite:///path`` (default kind; the file and its directory are created), ``sqlite://``
        (in memory), ``postgresql+psycopg://...`` or ``postgresql://...``, or a bare file path.
    create : create/migrate the schema to :data:`SCHEMA_VERSION` (else it must be current).
    migrate_to : with ``create``, stop at this schema version (tests of migrations).
    lock_timeout_s : how long a statement waits for another writer's lock before it fails (None: the backend's
        default, 30 s on SQLite, none on PostgreSQL; the ``wear_trend`` node keeps it short so that a locked
        store never stops its diagnostics).
    write_attempts : tries of a write transaction that meets a deadlock or a lock (5; the node makes one and
        retries on its own timer).
    """

    def __init__(self, url: str | Path, *, create: bool = True, migrate_to: int | None = None,
                 read_only: bool = False, lock_timeout_s: float | None = None, write_attempts: int = 5) -> None:
        self.write_attempts = max(1, int(write_attempts))
        self.backend: HistoryBackend = backend_for(url)
        self.url = self.backend.url
        self.dialect = self.backend.name
        self.read_only = bool(read_only)
        if self.read_only:
            create = False
        try:
            self.engine: Engine = (self.backend.engine(read_only=True) if self.read_only else
                                   self.backend.engine(lock_timeout_s=lock_timeout_s))
            found = self.schema_version()
            if found > SCHEMA_VERSION:
                raise HistoryError(f"{self.display_url}: schema version {found} was written by a newer jointwear "
                                   f"(this one knows up to {SCHEMA_VERSION}): upgrade jointwear to use it; "
                                   "nothing was written")
            if create:
                self.migrate(migrate_to)
            elif found != SCHEMA_VERSION:
                raise HistoryError(f"{self.display_url}: schema version {found}, "
                                   f"this software needs {SCHEMA_VERSION}"
                                   + ("; it holds no history yet (fill it with jointwear history import or the "
                                      "wear_trend node)" if found == 0 else
                                      "; jointwear history import (or the wear_trend node) migrates it"))
        except ArgumentError as exc:
            raise InputDataError(f"database URL {str(url)!r} is not valid ({exc}); "
                                 "use sqlite:///path or postgresql://user@host/db") from None
        except (OperationalError, SQLAlchemyError, OSError) as exc:
            raise HistoryError(f"{self.display_url}: cannot open the history store: {one_line(exc)}") from None
        except ModuleNotFoundError as exc:
            raise InputDataError(f"database URL {str(url)!r}: its driver is not installed ({exc}); "
                                 "use sqlite:///path or postgresql://user@host/db") from None

    @contextmanager
    def _reading(self, what: str) -> Iterator[None]:
        """Any database error while reading -> one :class:`HistoryError` line (a damaged page, a lost server)."""
        try:
            yield
        except SQLAlchemyError as exc:
            hint = ("; the file is damaged: restore it from a backup, or export what is readable with "
                    "sqlite3 DB .recover") if "malformed" in str(exc) or "not a database" in str(exc) else ""
            raise self._error(f"read {what}", exc, hint) from None

    def _error(self, what: str, exc: BaseException, hint: str = "") -> HistoryError:
        """A database error as one :class:`HistoryError` line, ``retryable`` as the backend says."""
        return HistoryError(f"{self.display_url}: cannot {what}: {one_line(exc)}{hint}",
                            retryable=self.backend.retryable(exc), detail=one_line(exc))

    @classmethod
    def watching(cls, url: str | Path, *, timeout_s: float = 5.0) -> HistoryStore:
        """The store's queries over its backend's watch engine (:meth:`HistoryBackend.watch_engine`: read-only,
        short timeouts), for a long-running reader; nothing is opened for writing, created or migrated."""
        store = cls.__new__(cls)
        store.backend = backend_for(url)
        store.url, store.dialect, store.read_only = store.backend.url, store.backend.name, True
        store.engine = store.backend.watch_engine(timeout_s)
        return store

    @property
    def display_url(self) -> str:
        """The URL without a password."""
        return self.backend.display_url

    # ------------------------------------------------------------------ schema
    def schema_version(self) -> int:
        """The highest applied migration (0 for an empty database)."""
        with self._reading("the schema version"), self.engine.connect() as conn:
            if not inspect(conn).has_table("schema_version"):
                return 0
            v = conn.execute(select(schema_version_t.c.version).order_by(schema_version_t.c.version.desc())).first()
        return int(v[0]) if v else 0

    def migrate(self, target: int | None = None) -> list[int]:
        """Apply the missing forward migrations up to ``target`` (default the newest); return those applied.

        Concurrent openers are safe: a migration whose version row another
        process inserted first is rolled back and skipped.
        """
        target = SCHEMA_VERSION if target is None else int(target)
        applied: list[int] = []
        for version in sorted(v for v in MIGRATIONS if v <= target):
            if version <= self.schema_version():
                continue
            try:
                with self.engine.begin() as conn:
                    MIGRATIONS[version](conn)
                    ins = self.insert(schema_version_t).values(version=version, applied_ns=_time.time_ns())
                    res = conn.execute(ins.on_conflict_do_nothing(index_elements=["version"])
                                       .returning(schema_version_t.c.version))
                    if not res.fetchall():  # another process applied it meanwhile
                        continue
            except SQLAlchemyError as exc:
                # lost a race on CREATE TABLE/INDEX with another process opening a new store: wait for its
                # version row (its transaction commits the tables and the row together)
                for _ in range(50):
                    if self.schema_version() >= version:
                        break
                    _time.sleep(0.1)
                if self.schema_version() >= version:
                    continue
                raise HistoryError(f"{self.display_url}: migration to schema version {version} failed: "
                                   f"{one_line(exc)}") from None
            applied.append(version)
        return applied

    def insert(self, table: Table) -> Any:
        """``INSERT`` into ``table`` that can skip existing rows (``on_conflict_do_nothing``), from the backend."""
        return self.backend.insert(table)

    # ------------------------------------------------------------------ writing
    def add_estimates(self, records: Iterable[EstimateRecord], *, now: float | None = None,
                      screen: ScreenConfig | None = None) -> int:
        """Insert the records (one transaction); return how many accepted ones were new. Duplicates are
        skipped; the ones the screening refuses are kept in ``refused`` (see :meth:`write_estimates`)."""
        return self.write_estimates(records, now=now, screen=screen).added

    def write_estimates(self, records: Iterable[EstimateRecord], *, now: float | None = None,
                        screen: ScreenConfig | None = None, strict: bool = True,
                        not_before: dict[tuple[str, str], float] | None = None,
                        extra_refused: Sequence[Refusal] = ()) -> WriteResult:
        """Screen and insert the records in one transaction: the accepted into ``estimates``, the refused into
        ``refused`` with their reason (:mod:`~jointwear_ros.history.screen`; ``now`` is the screening clock,
        default the wall clock). ``strict``: a malformed record (NaN, std <= 0, no name) raises
        :class:`InputDataError` before anything is written; else it is refused and kept like the others.
        ``not_before``: (robot, joint) -> the newest stamp so far (live arrival order: a stamp far before it is
        a clock jump). ``extra_refused``: refusals screened by the caller (the live node's clock-jump check), kept
        in ``refused`` in the same transaction."""
        if self.read_only:
            raise HistoryError(f"{self.display_url}: opened read-only; nothing can be written")
        now = _time.time() if now is None else float(now)
        records = list(records)
        if strict:
            for i, r in enumerate(records):
                r.check(f"estimate {i}")
        now_ns = _time.time_ns()
        rows: list[dict[str, Any]] = []
        refused: list[Refusal] = list(extra_refused)
        bad_rows: list[dict[str, Any]] = [_refused_row(f, now_ns) for f in refused]
        for r in records:
            nb = None if not_before is None else not_before.get((r.robot, r.joint))
            f = screen_record(r, now=now, cfg=screen, not_before=nb)
            if f is not None:
                refused.append(f)
                bad_rows.append(_refused_row(f, now_ns))
                continue
            d = asdict(r)
            d.pop("time")
            d.pop("received")
            d["time_ns"] = r.time_ns
            d["cycle_id"] = int(r.cycle_id)
            d["temperature"] = float(r.temperature) if math.isfinite(float(r.temperature)) else None
            d["inserted_ns"] = now_ns
            rows.append(d)
        res = WriteResult(added=0, duplicates=0, refused=refused)
        if not rows and not bad_rows:
            return res
        stmt = self.insert(estimates_t).on_conflict_do_nothing(
            index_elements=["robot", "joint", "analysis_version", "cycle_id", "time_ns"]).returning(estimates_t.c.id)
        bad_stmt = self.insert(refused_t).on_conflict_do_nothing(
            index_elements=["robot", "joint", "analysis_version", "cycle_id", "time", "wear", "wear_std"]
        ).returning(refused_t.c.id)
        # one lock order for every writer: concurrent transactions inserting overlapping keys in different
        # orders deadlock on PostgreSQL's unique index (seen with 4 writers); sorted, they queue instead
        rows.sort(key=lambda d: (d["robot"], d["joint"], d["analysis_version"], d["cycle_id"], d["time_ns"]))
        bad_rows.sort(key=lambda d: (d["robot"], d["joint"], d["analysis_version"], d["cycle_id"], d["time"]))
        for attempt in range(self.write_attempts):
            n = nb_new = 0
            try:
                with self.engine.begin() as conn:
                    for start in range(0, len(rows), 1000):
                        # executemany with RETURNING ("insertmanyvalues": multi-row INSERTs on SQLite and
                        # psycopg): the rows returned are exactly the new ones, on every dialect
                        n += len(conn.execute(stmt, rows[start:start + 1000]).all())
                    for start in range(0, len(bad_rows), 1000):
                        nb_new += len(conn.execute(bad_stmt, bad_rows[start:start + 1000]).all())
                break
            except SQLAlchemyError as exc:  # a lock, deadlock or serialization failure (the backend says): again
                if attempt == self.write_attempts - 1 or not self.backend.retryable(exc):
                    raise self._error("write estimates", exc) from None
                _time.sleep(0.05 * (attempt + 1))
        res.added, res.duplicates, res.refused_new = n, len(rows) - n, nb_new
        return res

    def has_estimate(self, r: EstimateRecord) -> bool:
        """Whether an estimate with this identity (robot, joint, analysis version, cycle id, time) is stored."""
        c = estimates_t.c
        q = select(c.id).where(c.robot == r.robot, c.joint == r.joint, c.analysis_version == r.analysis_version,
                               c.cycle_id == int(r.cycle_id), c.time_ns == r.time_ns).limit(1)
        with self._reading("the estimates"), self.engine.connect() as conn:
            return conn.execute(q).first() is not None

    def refused(self, robot: str | None = None, joint: str | None = None,
                analysis_version: str | None = LIVE) -> list[dict[str, Any]]:
        """The refused estimates (values as stored text, reason, detail), oldest insert first."""
        if self.schema_version() < 3:
            return []
        c = refused_t.c
        q = _filtered(refused_t, robot, joint, analysis_version)
        with self._reading("the refused estimates"), self.engine.connect() as conn:
            rows = conn.execute(q.order_by(c.robot, c.joint, c.id)).mappings().all()
        return [{k: r[k] for k in ("robot", "joint", "analysis_version", "cycle_id", "time", "wear", "wear_std",
                                   "source", "bag", "reason", "detail")} for r in rows]

    def add_maintenance(self, ev: MaintenanceEvent, *, now: float | None = None, future_tolerance_s: float = 3600.0,
                        known_joints: Sequence[str] | None = None, new_joint: bool = False) -> bool:
        """Insert a maintenance event; False when the same event (robot, joint, time, kind) is already there.

        Refused (:class:`InputDataError`): an event more than ``future_tolerance_s`` after ``now`` (it would hide
        every estimate before it: an ERROR joint showed OK), and, unless ``new_joint``, an event of a joint
        without estimates in the history or ``known_joints`` (a misspelt name)."""
        if self.read_only:
            raise HistoryError(f"{self.display_url}: opened read-only; nothing can be written")
        ev.check()
        now = _time.time() if now is None else float(now)
        if ev.time > now + future_tolerance_s:
            raise InputDataError(f"maintenance event {ev.kind!r} of {ev.robot}/{ev.joint} at {ev.time:.3f} is "
                                 f"{(ev.time - now) / 86400.0:.3g} days in the future: record it when it is done")
        if not new_joint:
            try:
                every = set(self.joints(None))
            except SQLAlchemyError as exc:
                raise HistoryError(f"{self.display_url}: cannot read the joints: {one_line(exc)}") from None
            known = {j for r, j in every if r == ev.robot} | set(known_joints or ())
            if not known:
                robots = sorted({r for r, _ in every})
                raise InputDataError(f"robot {ev.robot!r} has no estimates in the history; robots there: "
                                     f"{', '.join(robots) or 'none (import estimates first)'}: check the name "
                                     "(a new joint: --new-joint)")
            if ev.joint not in known:
                raise InputDataError(f"joint {ev.joint!r} of robot {ev.robot!r} has no estimates in the history "
                                     f"; its joints: {', '.join(sorted(known))}: "
                                     "check the name (a new joint: --new-joint)")
        stmt = self.insert(maintenance_t).values(robot=ev.robot, joint=ev.joint, time_ns=ev.time_ns, kind=ev.kind,
                                                  note=ev.note)
        stmt = stmt.on_conflict_do_nothing(index_elements=["robot", "joint", "time_ns", "kind"]).returning(
            maintenance_t.c.id)
        try:
            with self.engine.begin() as conn:
                return bool(conn.execute(stmt).fetchall())
        except SQLAlchemyError as exc:
            raise HistoryError(f"{self.display_url}: cannot write the maintenance event: {one_line(exc)}") from None

    # ------------------------------------------------------------------ reading
    def estimates(self, robot: str | None = None, joint: str | None = None,
                  analysis_version: str | None = LIVE, since: float | None = None) -> list[EstimateRecord]:
        """Estimates in time order, filtered by robot/joint/analysis version (``None``: any)."""
        c = estimates_t.c
        q = _filtered(estimates_t, robot, joint, analysis_version)
        if since is not None:
            q = q.where(c.time_ns >= int(since * 1e9))
        q = q.order_by(c.robot, c.joint, c.time_ns, c.id)
        with self._reading("the estimates"), self.engine.connect() as conn:
            rows = conn.execute(q).mappings().all()
        return [_record(r) for r in rows]

    def count(self, analysis_version: str | None = None) -> int:
        """Number of stored estimates (of one analysis version, or all)."""
        q = select(func.count()).select_from(estimates_t)
        if analysis_version is not None:
            q = q.where(estimates_t.c.analysis_version == analysis_version)
        with self._reading("the estimates"), self.engine.connect() as conn:
            return int(conn.execute(q).scalar_one())

    def maintenance(self, robot: str | None = None, joint: str | None = None) -> list[MaintenanceEvent]:
        """Maintenance events in time order."""
        c = maintenance_t.c
        q = select(maintenance_t)
        if robot is not None:
            q = q.where(c.robot == robot)
        if joint is not None:
            q = q.where(c.joint == joint)
        with self._reading("the maintenance events"), self.engine.connect() as conn:
            rows = conn.execute(q.order_by(c.robot, c.joint, c.time_ns, c.id)).mappings().all()
        return [MaintenanceEvent(r["robot"], r["joint"], r["time_ns"] * 1e-9, r["kind"], r["note"]) for r in rows]

    def joints(self, analysis_version: str | None = LIVE) -> list[tuple[str, str]]:
        """The (robot, joint) pairs that have estimates, sorted."""
        q = select(estimates_t.c.robot, estimates_t.c.joint).distinct()
        if analysis_version is not None:
            q = q.where(estimates_t.c.analysis_version == analysis_version)
        with self._reading("the joints"), self.engine.connect() as conn:
            return sorted((str(a), str(b)) for a, b in conn.execute(q).all())

    def analysis_versions(self) -> list[str]:
        """The analysis versions present."""
        q = select(estimates_t.c.analysis_version).distinct()
        with self._reading("the analysis versions"), self.engine.connect() as conn:
            return sorted(str(r[0]) for r in conn.execute(q).all())

    def history(self, analysis_version: str | None = LIVE, robot: str | None = None,
                joint: str | None = None) -> dict[tuple[str, str], tuple[list[EstimateRecord], list[MaintenanceEvent]]]:
        """(robot, joint) -> (estimates in time order, maintenance events): what the trend core takes."""
        out: dict[tuple[str, str], tuple[list[EstimateRecord], list[MaintenanceEvent]]] = {}
        for r in self.estimates(robot=robot, joint=joint, analysis_version=analysis_version):
            out.setdefault((r.robot, r.joint), ([], []))[0].append(r)
        for ev in self.maintenance(robot=robot, joint=joint):
            if (ev.robot, ev.joint) in out:
                out[(ev.robot, ev.joint)][1].append(ev)
        return out

    def versions_by_recency(self) -> list[str]:
        """The analysis versions present, oldest first by when their newest estimate was written."""
        c = estimates_t.c
        q = select(c.analysis_version, func.max(c.inserted_ns)).group_by(c.analysis_version)
        with self._reading("the analysis versions"), self.engine.connect() as conn:
            rows = conn.execute(q).all()
        return [str(v) for v, _ in sorted(rows, key=lambda r: (int(r[1] or 0), str(r[0])))]

    def change_marks(self, analysis_version: str | None = LIVE) -> dict[tuple[str, str], tuple[int, int, int, int]]:
        """Per joint with estimates: (estimates, newest estimate row id, maintenance events, newest event row id).
        Any row added to or removed from a joint changes its entry: what a long-running reader polls to know
        which joints to read again (two grouped aggregate queries over the store's indexes)."""
        e, m = estimates_t.c, maintenance_t.c
        qe = select(e.robot, e.joint, func.count(), func.max(e.id)).group_by(e.robot, e.joint)
        if analysis_version is not None:
            qe = qe.where(e.analysis_version == analysis_version)
        qm = select(m.robot, m.joint, func.count(), func.max(m.id)).group_by(m.robot, m.joint)
        with self._reading("the joints' row counts"), self.engine.connect() as conn:
            est, mnt = conn.execute(qe).all(), conn.execute(qm).all()
        events = {(str(r), str(j)): (int(n), int(i)) for r, j, n, i in mnt}
        return {(str(r), str(j)): (int(n), int(i), *events.get((str(r), str(j)), (0, 0))) for r, j, n, i in est}

    # ------------------------------------------------------------------ the fleet ledger (fleet_bags)
    def bags_done(self, analysis_version: str) -> set[str]:
        """Fingerprints of the bags a re-analysis ``analysis_version`` has done (:mod:`jointwear_ros.fleet.ledger`;
        one transaction, one attempt: the error's ``retryable`` says whether another may pass)."""
        q = select(fleet_bags_t.c.fingerprint).where(fleet_bags_t.c.analysis_version == analysis_version)
        with self._reading("the fleet ledger"), self.engine.connect() as conn:
            return {str(r[0]) for r in conn.execute(q).all()}

    def mark_bags_done(self, analysis_version: str, bags: Iterable[Mapping[str, Any]]) -> int:
        """Record bags (``fingerprint``, ``bag``, ``estimates``, ``seconds``) as done for ``analysis_version``:
        idempotent, one transaction, one attempt (the error's ``retryable`` says whether another may pass),
        rows in fingerprint order (one lock order for every writer). Returns how many rows were new."""
        if self.read_only:
            raise HistoryError(f"{self.display_url}: opened read-only; nothing can be written")
        now = _time.time_ns()
        rows: list[dict[str, Any]] = sorted(
            ({"analysis_version": analysis_version, "fingerprint": str(b["fingerprint"]), "bag": str(b["bag"]),
              "estimates": int(b["estimates"]), "seconds": float(b["seconds"]), "done_ns": now} for b in bags),
            key=lambda r: str(r["fingerprint"]))
        stmt = self.insert(fleet_bags_t).on_conflict_do_nothing(
            index_elements=["analysis_version", "fingerprint"]).returning(fleet_bags_t.c.id)
        n = 0
        try:
            with self.engine.begin() as conn:
                for row in rows:
                    # the rows RETURNING gives back are the new ones, on every backend (a rowcount is -1 on psycopg)
                    n += len(conn.execute(stmt.values(**row)).all())
        except SQLAlchemyError as exc:
            raise self._error("record the bags done in the fleet ledger", exc) from None
        return n

    def close(self) -> None:
        self.engine.dispose()

    def __enter__(self) -> HistoryStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


@dataclass
class WriteResult:
    """What :meth:`HistoryStore.write_estimates` did: new accepted rows, accepted ones already stored, and every
    refusal of the call (``refused_new`` of them were not yet in ``refused``)."""

    added: int
    duplicates: int
    refused: list[Refusal] = field(default_factory=list)
    refused_new: int = 0


def _refused_row(f: Refusal, now_ns: int) -> dict[str, Any]:
    r = f.record

    def txt(x: Any) -> str:
        try:
            return repr(float(x))[:40]
        except (TypeError, ValueError):
            return str(x)[:40]

    try:
        cid = int(r.cycle_id)
    except (TypeError, ValueError, OverflowError):
        cid = -1
    return {"robot": str(r.robot)[:200], "joint": str(r.joint)[:200], "analysis_version": r.analysis_version,
            "cycle_id": cid if -2**63 <= cid < 2**63 else -1, "time": txt(r.time), "wear": txt(r.wear),
            "wear_std": txt(r.wear_std), "hardware_id": r.hardware_id, "method": r.method, "params": r.params,
            "bag": r.bag, "source": r.source, "reason": f.reason, "detail": f.detail, "inserted_ns": now_ns}


def _filtered(table: Table, robot: str | None, joint: str | None, analysis_version: str | None) -> Any:
    """``SELECT table`` filtered by robot, joint and analysis version (``None``: any)."""
    c = table.c
    q = select(table)
    for col, value in (("robot", robot), ("joint", joint), ("analysis_version", analysis_version)):
        if value is not None:
            q = q.where(c[col] == value)
    return q


def _record(r: Any) -> EstimateRecord:
    t = r["temperature"]
    return EstimateRecord(
        robot=r["robot"], joint=r["joint"], cycle_id=int(r["cycle_id"]), time=r["time_ns"] * 1e-9,
        wear=float(r["wear"]), wear_std=float(r["wear_std"]), hardware_id=r["hardware_id"],
        temperature=math.nan if t is None else float(t), method=r["method"], params=r["params"],
        software_version=r["software_version"], bag=r["bag"], analysis_version=r["analysis_version"],
        source=r["source"], evidence=r.get("evidence") or "complete",
        cycle_source=r.get("cycle_source") or "test_cycle",
    )

