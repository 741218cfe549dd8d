"""History backends: chosen once from the URL, behind one protocol; the fleet ledger is a migration of the store."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import pytest
from sqlalchemy import inspect

from jointwear_ros.errors import InputDataError
from jointwear_ros.fleet.ledger import LEDGER_SCHEMA_VERSION, done_fingerprints, ensure_ledger, mark_done
from jointwear_ros.history import (
    BACKENDS,
    SCHEMA_VERSION,
    EstimateRecord,
    HistoryBackend,
    HistoryError,
    HistoryStore,
    PostgresBackend,
    SqliteBackend,
    backend_for,
    register_backend,
)
from jointwear_ros.history.store import fleet_bags_t

ROOT = Path(__file__).resolve().parents[1]


def test_the_backend_is_chosen_from_the_url_once_and_follows_the_protocol(tmp_path):
    f = backend_for(tmp_path / "h.db")
    assert isinstance(f, SqliteBackend) and isinstance(f, HistoryBackend)
    assert f.url == f"sqlite:///{tmp_path / 'h.db'}" and f.file == tmp_path / "h.db" and f.name == "sqlite"
    assert not f.exists() and not (tmp_path / "h.db").exists()  # asking creates nothing
    for url in ("sqlite://", "sqlite:///:memory:"):
        assert backend_for(url).file is None
    assert backend_for("sqlite://").exists() and not backend_for("sqlite:///:memory:").exists()
    pg = backend_for("postgres://jw:secret@db.cell/wear")
    assert isinstance(pg, PostgresBackend) and isinstance(pg, HistoryBackend)
    assert pg.url == "postgresql+psycopg://jw:secret@db.cell/wear" and pg.file is None and pg.exists()
    assert "secret" not in pg.display_url and pg.name == "postgresql"
    with pytest.raises(InputDataError, match=re.escape("scheme 'mysql://' is not supported")):
        backend_for("mysql://x@y/z")
    with pytest.raises(InputDataError, match="database URL is empty"):
        backend_for("  ")


def test_a_store_takes_its_dialect_and_inserts_from_its_backend(db_url):
    with HistoryStore(db_url) as s:
        assert s.dialect == s.backend.name == backend_for(db_url).name
        assert s.url == backend_for(db_url).url
        e = EstimateRecord("r", "j", cycle_id=1, time=1.7e9, wear=1.0, wear_std=1.0)
        assert (s.add_estimates([e]), s.add_estimates([e])) == (1, 0)


def test_registering_a_scheme_refuses_one_that_is_taken_and_a_url_in_place_of_a_scheme(monkeypatch):
    monkeypatch.setattr("jointwear_ros.history.backends.BACKENDS", dict(BACKENDS))
    from jointwear_ros.history import backends

    with pytest.raises(InputDataError, match="'sqlite' is taken by .*SqliteBackend"):
        register_backend("sqlite", PostgresBackend)
    with pytest.raises(InputDataError, match="give the scheme alone"):
        register_backend("memdb://", SqliteBackend)
    assert register_backend("sqlite", SqliteBackend) is SqliteBackend  # the same class again is no change
    register_backend("Lite", SqliteBackend)
    assert backends.BACKENDS["lite"] is SqliteBackend and isinstance(backend_for("lite:///x.db"), SqliteBackend)
    with pytest.raises(InputDataError, match=re.escape("scheme 'nope://' is not supported: use a file path, "
                                                       "sqlite:///path or postgresql://user@host/db (or lite://)")):
        backend_for("nope://x")


def test_the_fleet_ledger_is_created_by_the_store_migration_and_keeps_an_older_ledgers_rows(db_url):
    assert LEDGER_SCHEMA_VERSION <= SCHEMA_VERSION
    with HistoryStore(db_url, migrate_to=LEDGER_SCHEMA_VERSION - 1) as s:
        assert not inspect(s.engine).has_table("fleet_bags")
        with pytest.raises(HistoryError, match="has no fleet ledger"):
            ensure_ledger(SimpleNamespace(schema_version=s.schema_version, read_only=True,
                                          display_url=s.display_url))
        fleet_bags_t.create(s.engine)  # as jointwear fleet reprocess created it before it was a migration
        outcome = SimpleNamespace(fingerprint="f1", bag="/bags/a.mcap", records=[1, 2], seconds=0.5)
        assert mark_done(s, "ref-2011r/joint/abc", [outcome]) == 1
        ensure_ledger(s)  # migrates (to the ledger's version; opening a store migrates it the rest of the way)
        assert s.schema_version() == LEDGER_SCHEMA_VERSION
        assert done_fingerprints(s, "ref-2011r/joint/abc") == {"f1"}
        assert mark_done(s, "ref-2011r/joint/abc", [outcome]) == 0
    with HistoryStore(db_url) as s:  # a new store has the ledger from its migrations, with nothing else to call
        assert inspect(s.engine).has_table("fleet_bags") and s.migrate() == []


def test_no_module_switches_on_the_dialect_or_the_url_outside_the_backends():
    pattern = re.compile(r"""dialect\s*[!=]=|startswith\(\s*\(?["'](sqlite|postgres)|dialects\.(sqlite|postgresql)""")
    hits = []
    for path in sorted((ROOT / "jointwear_ros").rglob("*.py")):
        if path.relative_to(ROOT).as_posix() == "jointwear_ros/history/backends.py":
            continue
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if pattern.search(line):
                hits.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not hits, "\n".join(hits)
