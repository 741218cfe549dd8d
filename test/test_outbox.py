"""The estimate outbox (issue 29, item 3): the buffer, spool and retry of estimates the history store could not take,
as a pure history component: a real SQLite store that cannot be opened, then is; a write that fails after the open
(another writer's lock); a spool that cannot be written (its RAM fallback then holds the buffer); a kill and a
restart; each estimate stored once, in the order it came."""

from __future__ import annotations

import json
import sqlite3
from dataclasses import asdict
from pathlib import Path

import pytest

from jointwear_ros.history import EstimateRecord, HistoryStore
from jointwear_ros.history.outbox import Outbox, SpoolPaths, default_spool, fallback_spool, same_disk
from jointwear_ros.history.screen import ScreenConfig, screen_record

NOW = 1.75e9


def _rec(cycle: int, joint: str = "joint_6", wear: float | None = None) -> EstimateRecord:
    return EstimateRecord("cell_7", joint, cycle_id=cycle, time=NOW - 3600.0 + 60.0 * cycle,
                          wear=29.0 + 0.5 * cycle if wear is None else wear, wear_std=0.5)


class Cell:
    """A store file whose directory can be blocked (a file where the directory should be: the store cannot be
    opened) and a real lock another writer can take on it; the opener the outbox is given."""

    def __init__(self, root: Path) -> None:
        self.dir = root / "store"
        self.db = self.dir / "h.db"
        self.opened = 0
        self.writes = 0
        self.locker: sqlite3.Connection | None = None

    def block(self) -> None:
        self.dir.write_text("not a directory\n")

    def unblock(self) -> None:
        self.dir.unlink()

    def lock(self) -> None:
        self.locker = sqlite3.connect(str(self.db), isolation_level=None)
        self.locker.execute("BEGIN EXCLUSIVE")

    def unlock(self) -> None:
        if self.locker is not None:
            self.locker.rollback()
            self.locker.close()
            self.locker = None

    def open(self) -> HistoryStore:
        self.opened += 1
        store = HistoryStore(f"sqlite:///{self.db}", lock_timeout_s=0.05, write_attempts=1)
        real = store.write_estimates

        def counted(*args, **kwargs):
            self.writes += 1
            return real(*args, **kwargs)

        store.write_estimates = counted  # type: ignore[method-assign]
        return store

    def cycles(self, joint: str = "joint_6") -> list[int]:
        with HistoryStore(f"sqlite:///{self.db}", read_only=True) as s:
            return [r.cycle_id for r in s.estimates(robot="cell_7", joint=joint)]


@pytest.fixture
def cell(tmp_path):
    c = Cell(tmp_path)
    yield c
    c.unlock()


def _paths(tmp_path: Path, spool: Path | None = None, legacy: Path | None = None) -> SpoolPaths:
    return SpoolPaths(spool or tmp_path / "ros_home" / "spool.jsonl", tmp_path / "shm" / "ram.jsonl", legacy)


def _box(cell: Cell, paths: SpoolPaths, **kw) -> Outbox:
    logs: list[tuple[str, str]] = []
    box = Outbox(cell.open, paths, clock=lambda: NOW, log=lambda level, msg: logs.append((level, msg)), **kw)
    box.logs = logs  # type: ignore[attr-defined]
    return box


def _lines(path: Path) -> list[int]:
    return [json.loads(x)["cycle_id"] for x in path.read_text().splitlines()] if path.exists() else []


def test_a_store_that_cannot_be_opened_buffers_and_spools_then_takes_everything_once_in_order(cell, tmp_path):
    cell.block()
    paths = _paths(tmp_path)
    box = _box(cell, paths)
    for k in (1, 2, 3):
        assert box.put(_rec(k)) is False
    assert box.error is not None and box.error.startswith("cannot open") and cell.writes == 0
    assert [r.cycle_id for r, _ in box.pending] == [1, 2, 3] and _lines(paths.spool) == [1, 2, 3]
    assert [lv for lv, _ in box.logs].count("error") == 1  # the failure said once, not per estimate
    assert box.retry() is False  # still blocked: tried, nothing lost
    cell.unblock()
    assert box.retry() is True  # the store came back and took the buffer
    assert box.error is None and not box.pending and box.stored == 3 and not paths.spool.exists()
    assert cell.cycles() == [1, 2, 3]
    assert box.retry() is False and cell.writes == 1  # nothing waits: no write


def test_a_write_that_fails_after_the_open_waits_for_the_retry_without_an_attempt_of_its_own(cell, tmp_path):
    paths = _paths(tmp_path)
    box = _box(cell, paths)
    assert box.put(_rec(1)) is True and box.stored == 1 and cell.writes == 1
    cell.lock()  # another writer holds the store's write lock
    assert box.put(_rec(2)) is False
    assert box.error is not None and box.error.startswith("cannot write") and "locked" in box.error
    writes = cell.writes
    assert box.put(_rec(3)) is False and cell.writes == writes  # while failing, the retry timer writes
    assert _lines(paths.spool) == [2, 3]
    cell.unlock()
    assert box.retry() is True and box.stored == 3 and cell.opened == 1
    assert cell.cycles() == [1, 2, 3] and not paths.spool.exists()


def test_a_spool_that_cannot_be_written_sends_the_whole_buffer_to_the_fallback_each_estimate_once(cell, tmp_path):
    blocked = tmp_path / "full_disk"
    blocked.write_text("a file where the spool's folder should be: the spool cannot be written\n")
    cell.block()
    paths = _paths(tmp_path, spool=blocked / "spool.jsonl")
    box = _box(cell, paths)
    for k in (1, 2, 3, 4):
        box.put(_rec(k))
    assert _lines(paths.fallback) == [1, 2, 3, 4] and not paths.spool.exists()
    assert any("cannot spool the buffer" in m for _, m in box.logs)
    cell.unblock()
    assert box.retry() and cell.cycles() == [1, 2, 3, 4] and not paths.fallback.exists()


def test_with_no_file_writable_the_buffer_lives_in_memory_and_the_store_still_gets_it(cell, tmp_path):
    wall = tmp_path / "wall"
    wall.write_text("x\n")
    cell.block()
    paths = SpoolPaths(wall / "spool.jsonl", wall / "ram.jsonl")
    box = _box(cell, paths)
    for k in (1, 2):
        box.put(_rec(k))
    assert len(box.pending) == 2 and any("buffered in memory only" in m for _, m in box.logs)
    cell.unblock()
    assert box.retry() and cell.cycles() == [1, 2]


def test_a_kill_loses_nothing_the_restart_stores_every_estimate_once_in_arrival_order(cell, tmp_path):
    cell.block()
    paths = _paths(tmp_path)
    box = _box(cell, paths)
    arrival = [5, 2, 9, 7]  # cycle ids out of order: the order kept is the arrival's
    for k in arrival:
        box.put(_rec(k))
    del box  # killed: no close, no last attempt
    cell.unblock()
    again = _box(cell, paths)
    assert again.load() == 4 and [r.cycle_id for r, _ in again.pending] == arrival
    assert again.flush() and again.stored == 4 and sorted(cell.cycles()) == sorted(arrival)
    assert not paths.spool.exists()
    third = _box(cell, paths)
    assert third.load() == 0  # nothing left behind to store twice


def test_a_record_in_several_spools_and_already_in_the_store_is_stored_once(cell, tmp_path):
    legacy = tmp_path / "store_h.db.cell_7.pending.jsonl"
    paths = _paths(tmp_path, legacy=legacy)
    box = _box(cell, paths)
    assert box.put(_rec(1))  # stored
    line = lambda k: json.dumps(asdict(_rec(k))) + "\n"  # noqa: E731
    legacy.write_text(line(1) + line(2))
    paths.spool.parent.mkdir(parents=True)
    paths.spool.write_text(line(2) + line(3) + '{"robot": "cell_7", "joint": "jo')  # a line cut by a crash
    paths.fallback.parent.mkdir(parents=True)
    paths.fallback.write_text(line(1) + line(2) + line(3) + line(4))
    again = _box(cell, paths)
    assert again.load() == 4 and [r.cycle_id for r, _ in again.pending] == [1, 2, 3, 4]
    assert again.flush() and again.stored == 3 and again.duplicates == 1
    assert cell.cycles() == [1, 2, 3, 4] and not any(p.exists() for p in paths.all())


def test_the_bounded_buffer_drops_the_oldest_from_memory_and_the_spool_keeps_it_for_the_restart(cell, tmp_path):
    cell.block()
    paths = _paths(tmp_path)
    box = _box(cell, paths, max_items=3)
    for k in range(1, 6):
        box.put(_rec(k))
    assert [r.cycle_id for r, _ in box.pending] == [3, 4, 5] and box.dropped == 2
    assert _lines(paths.spool) == [1, 2, 3, 4, 5]
    del box
    cell.unblock()
    again = _box(cell, paths, max_items=3)
    again.load()
    assert again.flush() and cell.cycles() == [1, 2, 3, 4, 5]


def test_close_makes_a_last_attempt_and_leaves_the_rest_in_a_spool_file(cell, tmp_path):
    paths = _paths(tmp_path)
    box = _box(cell, paths)
    box.put(_rec(1))
    assert box.close() is None and box.store is None  # nothing left: the store closed
    (tmp_path / "down").mkdir()
    cell = Cell(tmp_path / "down")
    cell.block()
    box = _box(cell, paths)
    box.put(_rec(2))
    box.put(_rec(3))
    assert box.close() == paths.spool and _lines(paths.spool) == [2, 3]
    # the spool's disk full at exit: the fallback keeps them
    blocked = tmp_path / "full"
    blocked.write_text("x\n")
    paths2 = _paths(tmp_path, spool=blocked / "spool.jsonl")
    box = _box(cell, paths2)
    box.load()  # nothing there
    box.put(_rec(4))
    assert box.close() == paths2.fallback and _lines(paths2.fallback) == [4]


def test_refused_estimates_wait_with_the_rest_and_land_in_the_refused_table(cell, tmp_path):
    cell.block()
    box = _box(cell, _paths(tmp_path))
    bad = _rec(2, wear=1e300)
    box.put(_rec(1))
    box.put(bad, screen_record(bad, now=NOW))
    assert box.waiting("joint_6") == [_rec(1)]  # the trend counts only the accepted ones
    cell.unblock()
    assert box.retry() and box.stored == 1
    with HistoryStore(f"sqlite:///{cell.db}", read_only=True) as s:
        assert [(r["cycle_id"], r["reason"]) for r in s.refused()] == [(2, "wear_out_of_range")]


def test_a_reloaded_estimate_is_screened_again_with_the_clock_and_bounds_given(cell, tmp_path):
    paths = _paths(tmp_path)
    paths.spool.parent.mkdir(parents=True)
    paths.spool.write_text(json.dumps(asdict(_rec(1, wear=120.0))) + "\n")
    box = Outbox(cell.open, paths, clock=lambda: NOW, screen=ScreenConfig(wear_max=100.0))
    box.load()
    assert [f.reason for _, f in box.pending] == ["wear_out_of_range"]
    assert box.flush() and box.stored == 0 and cell.cycles() == []


def test_the_spool_files_of_a_store_and_robot(tmp_path, monkeypatch):
    monkeypatch.setenv("ROS_HOME", str(tmp_path / "ros_home"))
    db = tmp_path / "data" / "history.db"
    p = SpoolPaths.for_store(str(db), "cell_7")
    assert p.spool == default_spool(str(db), "cell_7") == tmp_path / "ros_home" / "wear_trend_cell_7.pending.jsonl"
    assert p.legacy == tmp_path / "data" / "history.db.cell_7.pending.jsonl"  # read on start, never written
    assert p.fallback == fallback_spool(str(db), "cell_7") != fallback_spool(str(tmp_path / "o.db"), "cell_7")
    given = SpoolPaths.for_store(str(db), "cell_7", tmp_path / "elsewhere.jsonl")
    assert given.spool == tmp_path / "elsewhere.jsonl" and given.legacy is None
    assert SpoolPaths.for_store("postgresql://u@h/d", "cell_7").legacy is None
    assert same_disk(p.spool, db) and not same_disk(p.spool, None)
