"""Read-only access to the history store and a background watcher that keeps the plant's snapshot current.

Requests never touch the database: one thread polls the store every ``refresh_s`` seconds with a
cheap fingerprint query (per joint: row counts and the newest row ids of ``estimates`` and
``maintenance``), re-reads through :meth:`HistoryStore.history` only the joints that changed (the
whole store in one query when many did), runs their trend
(:func:`~jointwear_ros.serve.core.analyze_plant`) and swaps in a new :class:`Snapshot`. Levels are
re-derived every poll (a joint turns STALE with time, without any new row).

**Read-only.** :class:`~jointwear_ros.history.HistoryStore` opens a store for writing (it creates a
missing SQLite file and its directory, switches the journal to WAL, migrates). ``serve`` must never
write, so :func:`open_readonly` runs the store's own queries over its backend's watch engine
(:meth:`~jointwear_ros.history.backends.HistoryBackend.watch_engine`): SQLite through
``file:...?mode=ro`` (a missing file is an error, never created; a short busy timeout), PostgreSQL
with ``default_transaction_read_only=on``, a connect and a statement timeout.

**Failures** (a missing, locked, migrating or unreachable store; a schema this software does not
read) never end the service: the snapshot keeps the last good rows, marked with the time they were
read and the error, and :attr:`Snapshot.store_ok` is False; the metrics keep exporting the last known
per-joint values, marked by ``jointwear_store_up 0`` (see :mod:`jointwear_ros.serve.web`), so no alert on
a joint's level resolves because the store went away.
"""

from __future__ import annotations

import math
import threading
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

from ..errors import JointwearError, one_line
from ..history import LIVE, SCHEMA_VERSION, EstimateRecord, HistoryError, HistoryStore
from ..history.trends import screened_history
from ..trend import TrendConfig, TrendResult
from .core import JointHistory, JointView, analyze_plant, joint_view, refused_view, source_summary

__all__ = ["Snapshot", "StoreWatcher", "open_readonly"]


def open_readonly(url: str, *, timeout_s: float = 5.0) -> HistoryStore:
    """A :class:`HistoryStore` whose connections cannot write (see the module doc). Raises
    :class:`HistoryError` when the store is not there or not readable by this software."""
    return HistoryStore.watching(url, timeout_s=timeout_s)


def _fingerprint(store: HistoryStore, analysis_version: str) -> dict[tuple[str, str], tuple[Any, ...]]:
    """Per joint: (estimates, newest estimate row id, maintenance events, newest event row id): any row added to
    or removed from a joint changes its entry (:meth:`HistoryStore.change_marks`)."""
    return dict(store.change_marks(analysis_version))


@dataclass(frozen=True)
class JointData:
    """A joint's trend and what it was computed from (for the plots)."""

    result: TrendResult | None
    records: list[EstimateRecord]
    maintenance_times: list[float]
    newest_time: float
    refused: str = ""  # why the trend refused the history
    rows_refused: int = 0  # stored rows the screening refused


@dataclass(frozen=True)
class Snapshot:
    """What the service shows: the plant's rows at one moment and the state of the store."""

    version: int = 0  # bumps whenever anything shown changes (rows, levels, store state)
    views: tuple[JointView, ...] = ()
    joints: dict[tuple[str, str], JointData] = field(default_factory=dict)
    store_ok: bool = False
    error: str = "not read yet"
    loaded_at: float = math.nan  # when the rows were read from the store (s since the epoch)
    checked_at: float = math.nan  # last poll, successful or not
    error_since: float = math.nan
    loads: int = 0
    failures: int = 0
    estimates: int = 0
    last_load_s: float = math.nan
    last_changed: int = 0  # joints re-read and re-analysed by the last load

    @property
    def fresh(self) -> bool:
        """Rows are current: the last poll read the store successfully."""
        return self.store_ok


class StoreWatcher:
    """Polls a history store in a thread and keeps :attr:`snapshot` current (see the module doc).

    Parameters
    ----------
    url : the store (SQLite file path or URL, PostgreSQL URL).
    cfg : trend settings (alarm, WARN horizon).
    stale_days : newest estimate older than this (and not ERROR): STALE.
    refresh_s : seconds between polls.
    analysis_version : which estimates.
    clock : seconds since the epoch (tests pass a fixed one).
    opener : opens the store (default :func:`open_readonly`).
    """

    def __init__(self, url: str, cfg: TrendConfig, *, stale_days: float = 7.0, refresh_s: float = 2.0,
                 analysis_version: str = LIVE, clock: Callable[[], float] = _time.time,
                 opener: Callable[[str], HistoryStore] = open_readonly) -> None:
        self.url, self.cfg, self.stale_days, self.refresh_s = url, cfg, float(stale_days), float(refresh_s)
        self.analysis_version, self.clock, self.opener = analysis_version, clock, opener
        self.snapshot = Snapshot()
        self._store: HistoryStore | None = None
        self._fp: dict[tuple[str, str], tuple[Any, ...]] | None = None
        self._stop = threading.Event()
        self._changed = threading.Condition()
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ polling
    def poll(self) -> Snapshot:
        """One poll: read the store if it changed, re-derive the levels, publish the snapshot."""
        now = self.clock()
        old = self.snapshot
        try:
            if self._store is None:
                store = self.opener(self.url)
                v = store.schema_version()
                if v != SCHEMA_VERSION:
                    store.close()
                    raise HistoryError(f"schema version {v}, this software reads {SCHEMA_VERSION} "
                                       f"({'being created or migrated' if v < SCHEMA_VERSION else 'written by a newer jointwear'})")
                self._store = store
            fp = _fingerprint(self._store, self.analysis_version)
            if fp != self._fp or not old.store_ok:
                t0 = _time.perf_counter()
                changed = {k for k, v in fp.items() if (self._fp or {}).get(k) != v}
                joints = {k: d for k, d in old.joints.items() if k in fp and k not in changed}
                joints.update(self._load(now, changed, full=len(changed) > max(8, len(fp) // 4)))
                new = replace(old, joints=joints, loaded_at=now, loads=old.loads + 1,
                              estimates=sum(v[0] for v in fp.values()), last_load_s=_time.perf_counter() - t0,
                              last_changed=len(changed))
                self._fp = fp
            else:
                new = replace(old, loaded_at=now)
            new = replace(new, views=self._views(new.joints, now), store_ok=True, error="", checked_at=now,
                          error_since=math.nan)
        except (JointwearError, OSError) as exc:  # the store's errors are HistoryError lines
            self._drop_store()
            msg = one_line(exc)
            new = replace(old, store_ok=False, error=msg, checked_at=now, failures=old.failures + 1,
                          error_since=old.error_since if not old.store_ok and math.isfinite(old.error_since) else now)
        if (_shown(new.views), new.store_ok, new.error) != (_shown(old.views), old.store_ok, old.error) \
                or new.loads != old.loads:
            new = replace(new, version=old.version + 1)
        self._publish(new)
        return new

    def _load(self, now: float, keys: set[tuple[str, str]], full: bool) -> dict[tuple[str, str], JointData]:
        """Read and analyse the joints ``keys`` (one query for all of the store when ``full``)."""
        assert self._store is not None
        # screened as the trend command and the wear_trend node screen it: a stored row with an impossible
        # wear or std, or a time far in the future or the past, never reaches the trend (it would hide an alarm)
        refused: list[dict[str, Any]] = []
        if full:
            hist, refused = screened_history(self._store, self.analysis_version, now=now)
        else:
            hist = {}
            for rb, jt in sorted(keys):
                part, part_refused = screened_history(self._store, self.analysis_version, robot=rb, joint=jt, now=now)
                hist.update(part)
                refused += part_refused
        n_refused: dict[tuple[str, str], int] = {}
        for row in refused:
            key = (str(row["robot"]), str(row["joint"]))
            n_refused[key] = n_refused.get(key, 0) + 1
        items = []
        for (rb, jt), (recs, events) in sorted(hist.items()):
            if (rb, jt) not in keys:
                continue
            items.append(JointHistory(rb, jt, [r.time for r in recs], [r.wear for r in recs],
                                      [r.wear_std for r in recs], [r.cycle_id for r in recs],
                                      [e.time for e in events], params=recs[-1].params if recs else "",
                                      evidence=[r.evidence for r in recs],
                                      sources=[r.cycle_source for r in recs]))
        out = {}
        for h, (view, r) in zip(items, analyze_plant(items, self.cfg, now, self.stale_days, smooth=False)):
            recs, events = hist[(h.robot, h.joint)]
            out[(h.robot, h.joint)] = JointData(r, recs, [e.time for e in events],
                                                max((x.time for x in recs), default=math.nan), view.refused,
                                                n_refused.get((h.robot, h.joint), 0))
        return out

    def _views(self, joints: dict[tuple[str, str], JointData], now: float) -> tuple[JointView, ...]:
        views = []
        for (rb, jt), d in sorted(joints.items()):
            if d.result is None:
                v = refused_view(rb, jt, d.refused, d.newest_time, now, len(d.records))
            else:
                v = joint_view(d.result, d.newest_time, now, self.stale_days)
            recs = d.records
            newest_source, per_source = source_summary([r.time for r in recs], [r.wear for r in recs],
                                                       [r.wear_std for r in recs], [r.cycle_source for r in recs])
            views.append(replace(v, rows_refused=d.rows_refused, newest_source=newest_source, sources=per_source))
        return tuple(views)

    def _publish(self, snap: Snapshot) -> None:
        with self._changed:
            self.snapshot = snap
            self._changed.notify_all()

    def _drop_store(self) -> None:
        if self._store is not None:
            try:
                self._store.close()
            except Exception:
                pass
        self._store, self._fp = None, None

    # ------------------------------------------------------------------ thread
    def start(self) -> None:
        self.poll()
        self._thread = threading.Thread(target=self._run, name="jointwear-serve-watcher", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.refresh_s):
            try:
                self.poll()
            except Exception as exc:
                self._publish(replace(self.snapshot, store_ok=False, error=f"internal error: {one_line(exc)}",
                                      checked_at=self.clock(), version=self.snapshot.version + 1))

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10)
        self._drop_store()

    def wait_change(self, version: int, timeout: float) -> Snapshot:
        """The snapshot once its version differs from ``version`` (or after ``timeout`` s)."""
        with self._changed:
            self._changed.wait_for(lambda: self.snapshot.version != version, timeout=timeout)
            return self.snapshot


def _shown(views: tuple[JointView, ...]) -> tuple[JointView, ...]:
    """The views as a page shows them: ages to a tenth of a day (the page's precision), so the version
    changes when something visible does, not on every poll."""
    return tuple(replace(v, age_days=round(v.age_days, 1)) for v in views)

