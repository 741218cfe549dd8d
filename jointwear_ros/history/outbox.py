"""The estimate outbox: estimates the history store could not take yet, kept until it takes them (pure: no ROS).

A live writer (the ``wear_trend`` node) hands every estimate to :meth:`Outbox.put`: it is written to the store at
once, in its own transaction, when the store works. When it fails (disk full, PostgreSQL down, a locked or damaged
file, a store that cannot even be opened), the estimate waits:

- in a bounded buffer (``max_items``; beyond, the oldest is dropped and counted in :attr:`Outbox.dropped`; it stays
  in the spool file, so a restart still stores it);
- in a spool file (:class:`SpoolPaths`; default ``$ROS_HOME/wear_trend_<robot>.pending.jsonl``, never beside the
  store's file, whose disk is the one that fills), one JSON line per estimate, fsynced, so a kill loses nothing;
- when the spool cannot be written either (the same disk is full, a directory that is a file), in a RAM file in
  ``/dev/shm`` (:func:`fallback_spool`), which survives the process being killed (not a reboot): the whole buffer
  is written there, each estimate once; when even that fails, in memory only.

:meth:`Outbox.retry` (the writer calls it on its own timer) writes the whole buffer in one transaction; the store's
inserts are idempotent, so an estimate written twice (a retry after a commit whose answer was lost, a spool
read again) is stored once. :meth:`Outbox.load` reads, on start, what a killed run left in the spool, the fallback
and the spool an earlier version kept beside the store's file (each estimate once, in arrival order);
:meth:`Outbox.close` makes a last attempt and leaves the rest in a spool file.

The store is opened by the ``open_store`` callable given (again at every attempt while it cannot be opened), the
screening clock is the ``clock`` given: a test drives both.

>>> from jointwear_ros.history import EstimateRecord, HistoryStore
>>> d = Path(tempfile.gettempdir()) / "jointwear-outbox-example"  # written only while the store fails
>>> box = Outbox(lambda: HistoryStore("sqlite://"), SpoolPaths(d / "spool.jsonl", d / "ram.jsonl"),
...              clock=lambda: 1.75e9)
>>> box.put(EstimateRecord("robot_1", "joint_1", cycle_id=1, time=1.75e9 - 60, wear=20.0, wear_std=0.8))
True
>>> box.stored, len(box.pending), box.error
(1, 0, None)
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any, Protocol

from ..errors import JointwearError
from .backends import backend_for
from .records import EstimateRecord
from .screen import Refusal, ScreenConfig, screen_record

__all__ = ["Outbox", "OutboxStore", "SpoolPaths", "default_spool", "fallback_spool", "same_disk"]

#: ``log(level, message)``: level is ``"info"``, ``"warning"`` or ``"error"``
Log = Callable[[str, str], None]


class OutboxStore(Protocol):
    """What the outbox needs of a history store (:class:`~jointwear_ros.history.HistoryStore` has it)."""

    def write_estimates(self, records: Iterable[EstimateRecord], *, now: float | None = ...,
                        screen: ScreenConfig | None = ..., strict: bool = ...,
                        extra_refused: Sequence[Refusal] = ...) -> Any: ...

    def close(self) -> None: ...


def default_spool(db_url: str, robot: str) -> Path:
    """``$ROS_HOME`` (``~/.ros``)``/wear_trend_<robot>.pending.jsonl``: never beside the store's file, whose disk is
    the one that fills when the store fails for lack of space."""
    return Path(os.environ.get("ROS_HOME", "~/.ros")).expanduser() / f"wear_trend_{robot}.pending.jsonl"


def fallback_spool(db_url: str, robot: str) -> Path:
    """Where the buffer goes when its spool cannot be written (that disk is full too): a RAM file system
    (``/dev/shm``), which survives the process being killed (not a reboot); the temp directory without one. One
    file per store and robot."""
    base = Path("/dev/shm")
    if not (base.is_dir() and os.access(base, os.W_OK)):
        base = Path(tempfile.gettempdir())
    tag = hashlib.sha1(str(db_url).encode()).hexdigest()[:10]
    return base / f"jointwear-wear_trend-{robot}-{tag}.pending.jsonl"


def same_disk(a: Path, b: Path | None) -> bool:
    """Whether ``a`` and ``b`` (files, existing or not) are on one file system (False when unknown)."""
    if b is None:
        return False

    def dev(p: Path) -> int | None:
        for q in (p, *p.parents):
            try:
                return q.stat().st_dev
            except OSError:
                continue
        return None

    da, db = dev(a.expanduser()), dev(b.expanduser())
    return da is not None and da == db


@dataclass(frozen=True)
class SpoolPaths:
    """The outbox's files: the spool, its RAM fallback, and the spool an earlier version kept beside the store's
    file (read on start only)."""

    spool: Path
    fallback: Path
    legacy: Path | None = None

    @classmethod
    def for_store(cls, db_url: str, robot: str, buffer_path: str | Path = "") -> SpoolPaths:
        """The files of ``robot``'s outbox for the store ``db_url``: ``buffer_path`` when given, else
        :func:`default_spool`; the legacy spool (``<store file>.<robot>.pending.jsonl``) only without a
        ``buffer_path``, as earlier versions kept it."""
        db_file = backend_for(str(db_url)).file
        legacy = (db_file.with_name(db_file.name + f".{robot}.pending.jsonl")
                  if db_file is not None and not str(buffer_path) else None)
        spool = Path(str(buffer_path)) if str(buffer_path) else default_spool(str(db_url), robot)
        return cls(spool, fallback_spool(str(db_url), robot), legacy)

    def all(self) -> list[Path]:
        """Every file, in the order :meth:`Outbox.load` reads them (the oldest first)."""
        return [*([self.legacy] if self.legacy is not None else []), self.spool, self.fallback]


def _quiet(level: str, message: str) -> None:
    pass


class Outbox:
    """Estimates on their way to the history store (see the module docstring).

    Parameters
    ----------
    open_store : opens the store (raises :class:`~jointwear_ros.errors.JointwearError` when it cannot); called at
        the first write and again at each attempt while it fails.
    paths : the spool files.
    clock : the screening clock (seconds since the epoch).
    screen : the screening bounds (the writer may replace :attr:`screen` at run time).
    max_items : the buffer's bound.
    log : ``log(level, message)`` for what an operator should read (a failing store, a spool that cannot be
        written, a dropped estimate).
    """

    def __init__(self, open_store: Callable[[], OutboxStore], paths: SpoolPaths, *, clock: Callable[[], float],
                 screen: ScreenConfig | None = None, max_items: int = 10000, log: Log | None = None) -> None:
        self._open_store = open_store
        self.paths = paths
        self.clock = clock
        self.screen = screen or ScreenConfig()
        self.max_items = max(1, int(max_items))
        self.log = log or _quiet
        self.store: OutboxStore | None = None
        #: estimates (and their refusals) waiting for the store, oldest first
        self.pending: deque[tuple[EstimateRecord, Refusal | None]] = deque()
        #: why the store fails (``"cannot write: ..."``), None while it works
        self.error: str | None = None
        self.failures = 0
        self.stored = 0
        self.duplicates = 0
        self.dropped = 0
        self._spool_ok = True
        self._fallback_ok = True

    # ------------------------------------------------------------------ the store
    def open(self) -> bool:
        """Open the store unless it is open; False (and :attr:`error` set) when it cannot be."""
        if self.store is not None:
            return True
        try:
            self.store = self._open_store()
        except JointwearError as exc:
            self.fail("cannot open", exc)
            return False
        return True

    def fail(self, what: str, exc: BaseException) -> None:
        """Record a failure of the store (a write here, or a read by the writer): the store is failing until the
        next write succeeds."""
        text = f"{what}: {exc}"
        if self.error is None:
            self.log("error", f"history store failing: {text}; estimates are buffered and retried")
        self.error = text
        self.failures += 1

    # ------------------------------------------------------------------ estimates in
    def put(self, rec: EstimateRecord, refusal: Refusal | None = None) -> bool:
        """Hand over one estimate (with its refusal when the screening refused it: kept in ``refused``). Written
        at once when the store works; else it waits with the buffer (the retry writes it: no blocking attempt of
        its own while the store fails) and goes to the spool. True when the buffer is empty afterwards."""
        self.pending.append((rec, refusal))
        if len(self.pending) > self.max_items:
            lost, _ = self.pending.popleft()
            self.dropped += 1
            self.log("error", f"buffer full ({self.max_items}): the oldest buffered estimate ({lost.joint} cycle "
                              f"{lost.cycle_id}) is dropped from memory (its spool line stays)")
        if self.error is None and self.flush():
            return True
        self._spool_append(rec)  # the store failed: this one waits, on disk where possible
        return False

    def waiting(self, joint: str | None = None) -> list[EstimateRecord]:
        """The accepted estimates waiting for the store (of one joint), oldest first."""
        return [r for r, f in self.pending if f is None and (joint is None or r.joint == joint)]

    # ------------------------------------------------------------------ writing
    def flush(self) -> bool:
        """Write every buffered estimate (accepted and refused) in one transaction; True when the buffer is empty."""
        if not self.pending:
            return True
        if not self.open():
            return False
        assert self.store is not None
        items = list(self.pending)
        ok = [r for r, f in items if f is None]
        bad = [f for _, f in items if f is not None]
        try:
            res = self.store.write_estimates(ok, now=self.clock(), screen=self.screen, strict=False,
                                             extra_refused=bad)
        except Exception as exc:  # any driver error (disk full, connection lost) is a store failure
            self.fail("cannot write", exc)
            return False
        for _ in items:
            self.pending.popleft()
        self._spool_clear()
        self.stored += int(res.added)
        self.duplicates += int(res.duplicates)
        if self.error is not None:
            self.log("info", f"history store writable again: {len(items)} buffered estimate(s) written "
                             f"({res.added} new)")
        self.error = None
        return True

    def retry(self) -> bool:
        """The writer's timer: write the buffer while the store fails or estimates wait. True when the store was
        failing and now took everything (the writer then reads its history again)."""
        if self.error is None and not self.pending:
            return False
        was = self.error
        return self.flush() and was is not None

    # ------------------------------------------------------------------ start and stop
    def load(self) -> int:
        """Take back what an earlier run could not store (it was stopped, or killed, while the store failed): from
        the legacy spool, the spool and the RAM fallback, each estimate once, in arrival order. Re-screened with
        the current clock. Returns how many were loaded."""
        seen: set[tuple[str, str, int, int]] = {(r.robot, r.joint, r.cycle_id, r.time_ns) for r, _ in self.pending}
        total = 0
        for path in self.paths.all():
            if not path.is_file():
                continue
            n = 0
            try:
                for line in path.read_text(encoding="utf-8").splitlines():
                    try:
                        rec = EstimateRecord(**json.loads(line))
                    except (ValueError, TypeError):
                        continue  # a line cut by a crash
                    key = (rec.robot, rec.joint, rec.cycle_id, rec.time_ns)
                    if key in seen:
                        continue
                    seen.add(key)
                    self.pending.append((rec, screen_record(rec, now=self.clock(), cfg=self.screen)))
                    n += 1
            except OSError as exc:
                self.log("warning", f"cannot read the buffer {path}: {exc}")
            if n:
                self.log("info", f"{n} estimate(s) buffered by a previous run reloaded from {path}")
            total += n
        return total

    def close(self) -> Path | None:
        """A last attempt at the buffer; what the store does not take stays in a spool file (returned; None when
        nothing is left). Closes the store."""
        where: Path | None = None
        if self.pending and not self.flush():
            where = self.paths.spool
            if not self._spool_ok or not self.paths.spool.is_file():
                self._spool_clear()
                try:
                    for rec, _ in self.pending:
                        _append_line(self.paths.spool, rec)
                except OSError:
                    self._spool_clear()
                    self._rewrite_fallback()
                    where = self.paths.fallback
            self.log("error", f"{len(self.pending)} estimate(s) not stored at exit: kept in {where}")
        if self.store is not None:
            self.store.close()
            self.store = None
        return where

    # ------------------------------------------------------------------ the spool files
    def _spool_append(self, rec: EstimateRecord) -> None:
        if self._spool_ok:
            try:
                _append_line(self.paths.spool, rec)
                return
            except OSError as exc:  # the disk the store failed on may be full too
                self._spool_ok = False
                self.log("error", f"cannot spool the buffer to {self.paths.spool} ({exc}); the buffer goes to "
                                  f"{self.paths.fallback} (RAM: kept through a kill, not a reboot)")
                self._rewrite_fallback()  # the whole buffer (this estimate is in it), each estimate once
                return
        self._fallback_append(rec)

    def _rewrite_fallback(self) -> None:
        try:
            self.paths.fallback.unlink(missing_ok=True)
        except OSError:
            pass
        for r, _ in self.pending:
            self._fallback_append(r)

    def _fallback_append(self, rec: EstimateRecord) -> None:
        if not self._fallback_ok:
            return
        try:
            _append_line(self.paths.fallback, rec)
        except OSError as exc:
            self._fallback_ok = False
            self.log("error", f"cannot spool the buffer to {self.paths.fallback} either ({exc}); buffered in memory "
                              "only")

    def _spool_clear(self) -> None:
        for path in self.paths.all():
            try:
                path.unlink(missing_ok=True)
            except OSError:
                pass
        self._spool_ok = self._fallback_ok = True


def _append_line(path: Path, rec: EstimateRecord) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(asdict(rec)) + "\n")  # NaN/inf as JSON's NaN/Infinity, read back by json
        fh.flush()
        os.fsync(fh.fileno())
