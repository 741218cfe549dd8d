"""Bulk re-analysis of a fleet's bags on Dask: one task per bag, results into the wear history.

:func:`reprocess` fingerprints every bag, asks the history store which of
them this analysis version has already done (skipped), submits the rest to a
``dask.distributed`` cluster (a ``LocalCluster`` of ``workers`` single-thread
processes by default, or an existing scheduler by address, or a given
``Client``), and writes each finished bag's estimates to the store as they
complete (``as_completed``, in batches), then marks the bags done. A bag that
fails is reported, not retried in this run, and never stops the others.
Writing is idempotent (the store's unique identity), so a run interrupted
anywhere can simply be started again.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from .. import __version__
from ..errors import InputDataError
from .reanalysis import BagOutcome, analysis_version, bag_fingerprint, default_node_params, reprocess_bag

__all__ = ["Progress", "ReprocessReport", "expand_bags", "open_client", "reprocess"]


@dataclass
class ReprocessReport:
    """What a re-analysis did (the CLI's JSON)."""

    bags: int
    estimates: int
    skipped: int
    failed: list[dict[str, str]]
    analysis_version: str
    seconds: float
    processed: int = 0
    workers: int = 0
    scheduler: str = ""
    bag_seconds: list[float] = field(default_factory=list)
    bag_cpu_seconds: list[float] = field(default_factory=list)
    #: per bag re-analysed: ``bag``, ``robot``, ``method``, ``params`` and where each came from
    settings: list[dict[str, str]] = field(default_factory=list)
    #: matched paths that are not bags, with the reason (``{"path", "reason"}``)
    not_bags: list[dict[str, str]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "bags": self.bags, "estimates": self.estimates, "skipped": self.skipped, "failed": self.failed,
            "settings": self.settings, "not_bags": self.not_bags,
            "analysis_version": self.analysis_version, "seconds": self.seconds, "processed": self.processed,
            "workers": self.workers, "scheduler": self.scheduler,
            "bags_per_second": self.processed / self.seconds if self.seconds > 0 else None,
        }


class Progress:
    """A one-line progress bar on a stream: bags done, failed, skipped, rate.

    On a terminal the line is redrawn in place; otherwise a line is written at
    every tenth of the work (and at the end), so logs stay short.
    """

    def __init__(self, total: int, stream: IO[str] | None = None, enabled: bool = True, width: int = 30) -> None:
        self.total, self.stream, self.enabled, self.width = total, stream or sys.stderr, enabled, width
        self.t0 = time.perf_counter()
        self.done = self.failed = self.skipped = 0
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._next = 0

    def line(self) -> str:
        n = self.done + self.failed + self.skipped
        frac = n / self.total if self.total else 1.0
        bar = "#" * round(frac * self.width)
        dt = time.perf_counter() - self.t0
        rate = (self.done + self.failed) / dt if dt > 0 else 0.0
        return (f"reprocess [{bar:<{self.width}}] {n}/{self.total} bags: {self.done} done, {self.failed} failed, "
                f"{self.skipped} skipped, {rate:.1f} bags/s")

    def update(self, *, done: int = 0, failed: int = 0, skipped: int = 0) -> None:
        self.done += done
        self.failed += failed
        self.skipped += skipped
        if not self.enabled:
            return
        n = self.done + self.failed + self.skipped
        if self._tty:
            self.stream.write("\r" + self.line())
            self.stream.flush()
        elif n >= self._next or n == self.total:
            self.stream.write(self.line() + "\n")
            self._next = n + max(1, math.ceil(self.total / 10))

    def ready(self, workers: int, bags: int) -> None:
        """One line when the workers are up and the handler of Ctrl-C is in place, before any bag is sent."""
        if self.enabled:
            text = f"reprocess: {workers} worker(s) ready, {bags} bag(s) to replay (Ctrl-C stops the run; the bags " \
                   "finished by then are kept)"
            self.stream.write(("\r" + text.ljust(len(self.line())) if self._tty else text) + "\n")
            self.stream.flush()

    def close(self) -> None:
        if self.enabled and self._tty:
            self.stream.write("\n")
            self.stream.flush()


def expand_bags(patterns: Sequence[str]) -> list[Path]:
    """Bag directories named by ``patterns`` (paths or globs; a directory that is not a bag stands for
    the bags under it), each bag once (its directory and the ``.mcap`` in it are one bag), in the order
    given. Raises InputDataError when a pattern names nothing. What was matched and skipped, and why:
    :func:`jointwear_ros.io.bags.discover_bags`."""
    from ..io.bags import discover_bags

    return discover_bags(patterns).bags


def open_client(scheduler: str | None = None, workers: int = 2) -> tuple[Any, Callable[[], None]]:
    """A Dask ``Client`` on an existing scheduler, or on a new ``LocalCluster`` of ``workers`` processes
    with one thread each; and the function that closes what was opened."""
    from dask.distributed import Client, LocalCluster

    if scheduler:
        refused = _refused(scheduler)
        if refused is not None:
            raise InputDataError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler there "
                                 f"({type(refused).__name__}: {refused.strerror or refused})")
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise InputDataError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler there "
                                 f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None
        return client, client.close
    if workers < 1:
        raise InputDataError(f"--workers {workers}: must be at least 1")
    with _sigint_held():
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},  # no fixed port 8787
                               silence_logs=logging.ERROR)
        client = Client(cluster)

    def close() -> None:
        client.close()
        cluster.close()

    return client, close


def _refused(scheduler: str) -> OSError | None:
    """The error when nothing listens at a ``tcp://`` scheduler address (the connection refused: known at once,
    where Dask's client retries for its whole timeout); None otherwise (another scheme, a host that does not
    answer at all: Dask's own timeout decides)."""
    import socket
    from urllib.parse import urlsplit

    try:
        u = urlsplit(scheduler if "://" in scheduler else "tcp://" + scheduler)
        host, port = u.hostname, u.port
    except ValueError:
        return None
    if u.scheme != "tcp" or not host or port is None:
        return None
    try:
        with socket.create_connection((host, port), timeout=2.0):
            return None
    except ConnectionRefusedError as exc:
        return exc
    except OSError:
        return None


@contextlib.contextmanager
def _sigint_held() -> Iterator[None]:
    """SIGINT blocked in the main thread while Dask starts: held pending, delivered when the block ends.

    Ctrl-C reaches the whole process group, and only this process should act on it (one line,
    `jointwear: interrupted`), not the worker processes, killed mid-task printing their tracebacks. Every
    thread Dask starts here inherits the block, and so does every worker process those threads spawn (a
    process keeps its signal mask across exec): the workers never receive SIGINT; they are stopped when the
    cluster is closed. A Ctrl-C while the cluster starts (seconds under load) stays pending and is delivered
    to this thread at the end of the block. (Ignoring SIGINT meanwhile, as before, lost it: a Ctrl-C during
    startup was discarded and the run went on to the last bag, exit 0.)
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # signals are handled in the main thread only; nothing to hold here
        return
    import multiprocessing.resource_tracker
    import signal

    # multiprocessing's resource tracker, started by the first spawned worker, unblocks SIGINT in the thread
    # that starts it (the Dask loop's): started here first, that thread keeps the block its workers inherit
    multiprocessing.resource_tracker.ensure_running()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class _InterruptFlag:
    """SIGINT (Ctrl-C) recorded by a handler of our own in the main thread: :meth:`check` raises
    KeyboardInterrupt once it came, however the code running when it arrived treated the exception (one
    raised inside a finalizer, such as a Dask future's ``__del__``, is printed and dropped by Python)."""

    def __init__(self, previous: Any) -> None:
        self.previous = previous
        self.seen = threading.Event()
        #: raise KeyboardInterrupt at once (else only record it: while something must not be cut half-way)
        self.armed = True

    @classmethod
    def install(cls) -> _InterruptFlag:
        import signal

        if threading.current_thread() is not threading.main_thread():
            return cls(None)  # only the main thread gets signals; nothing to install
        flag = cls(signal.getsignal(signal.SIGINT))

        def on_sigint(signum: int, frame: Any) -> None:
            flag.seen.set()
            if flag.armed:
                raise KeyboardInterrupt

        signal.signal(signal.SIGINT, on_sigint)
        return flag

    def check(self) -> None:
        if self.seen.is_set():
            raise KeyboardInterrupt

    def restore(self) -> None:
        if self.previous is not None:
            import signal

            signal.signal(signal.SIGINT, self.previous)
            self.previous = None


def _n_workers(client: Any) -> int:
    try:
        return len(client.scheduler_info(n_workers=-1)["workers"])
    except TypeError:  # older distributed: no n_workers argument
        return len(client.scheduler_info()["workers"])
    except Exception:
        return 0


def reprocess(
    bags: Sequence[str | os.PathLike[str]],
    store: Any,
    *,
    params: str | None = None,
    method: str | None = None,
    label: str | None = None,
    client: Any = None,
    scheduler: str | None = None,
    workers: int = 2,
    progress: Progress | bool = False,
    batch: int = 25,
    flush_seconds: float = 2.0,
    software_version: str = __version__,
    robot: str | None = None,
) -> ReprocessReport:
    """Re-analyse ``bags`` with parameter set ``params`` and ``method`` into ``store`` (a HistoryStore).

    ``client`` (a Dask Client) is used as is; else one is opened on ``scheduler`` or on a new
    LocalCluster of ``workers`` processes, and closed at the end. One worker and no scheduler: the bags are
    re-analysed in this process, one after another (a cluster of one worker process would only add its
    start-up: seconds of CPU and wall).
    """
    from ..history import EstimateRecord
    from .ledger import done_fingerprints, ensure_ledger, mark_done

    t0 = time.perf_counter()
    version = analysis_version(params, method, software_version, label)
    ensure_ledger(store)
    done = done_fingerprints(store, version)
    todo: list[tuple[str, str]] = []
    failed: list[dict[str, str]] = []
    skipped = 0
    in_run: set[str] = set()
    for b in bags:
        path = str(Path(b).resolve())
        try:
            fp = bag_fingerprint(path)
        except OSError as exc:
            failed.append({"bag": path, "error": f"{path}: cannot read the bag ({exc.strerror or exc})"})
            continue
        if fp in done or fp in in_run:
            skipped += 1
            continue
        in_run.add(fp)
        todo.append((path, fp))
    bar = progress if isinstance(progress, Progress) else Progress(len(bags), enabled=bool(progress))
    bar.update(skipped=skipped, failed=len(failed))
    report = ReprocessReport(bags=len(bags), estimates=0, skipped=skipped, failed=failed, analysis_version=version,
                             seconds=0.0)
    if not todo:
        bar.close()
        report.failed.sort(key=lambda f: f["bag"])
        report.seconds = time.perf_counter() - t0
        return report

    op, mp = default_node_params()
    close: Callable[[], None] | None = None
    # Ctrl-C from here on is recorded by a handler of our own (and honoured at the next finished bag whatever the
    # code running when it came did with the KeyboardInterrupt); while the cluster starts it is held pending
    # (open_client), recorded as it is delivered at the end of that, and honoured once the cluster can be closed
    interrupted = _InterruptFlag.install()
    here = client is None and not scheduler and workers == 1
    try:
        if client is None and not here:
            interrupted.armed = False
            client, close = open_client(scheduler, workers)
    finally:
        interrupted.armed = True
    try:
        interrupted.check()
        report.workers = 1 if here else _n_workers(client)
        report.scheduler = "" if here else str((getattr(client, "scheduler", None) and client.scheduler.address) or "")
        bar.ready(report.workers, len(todo))
    except BaseException:
        interrupted.restore()
        bar.close()
        if close is not None:
            close()
        raise
    pending: list[BagOutcome] = []
    last_flush = time.perf_counter()

    def flush() -> None:
        nonlocal last_flush
        if pending:
            # taken out first: a batch the store refused is reported once, not written again by the `finally`
            done_now = pending[:]
            pending.clear()
            report.estimates += store.add_estimates([EstimateRecord(**r) for o in done_now for r in o.records])
            mark_done(store, version, done_now)
        last_flush = time.perf_counter()

    task = functools.partial(reprocess_bag, params=params, method=method, version=version, observer_params=op,
                             monitor_params=mp, software_version=software_version, robot=robot)

    def outcomes() -> Iterator[tuple[str, BagOutcome | str]]:
        """(bag, its outcome or why its task failed) as each bag is finished."""
        if here:
            for path, _fp in todo:
                yield path, task(path)
            return
        from dask.distributed import as_completed

        futures = {client.submit(task, path, pure=False): path for path, _fp in todo}
        for fut in as_completed(list(futures)):
            interrupted.check()
            path = futures.pop(fut)
            if fut.status == "error":
                task_exc = fut.exception()
                yield path, (f"{path}: the Dask task failed ({type(task_exc).__name__}: "
                             f"{str(task_exc).splitlines()[0] if str(task_exc) else ''})")
                continue
            result: BagOutcome = fut.result()
            fut.release()
            yield path, result

    try:
        for path, outcome in outcomes():
            interrupted.check()
            if isinstance(outcome, str):
                failed.append({"bag": path, "error": outcome})
                bar.update(failed=1)
                continue
            if outcome.error is not None:
                failed.append({"bag": path, "error": outcome.error})
                bar.update(failed=1)
                continue
            report.processed += 1
            report.settings.append({"bag": path, **outcome.settings})
            report.bag_seconds.append(outcome.seconds)
            report.bag_cpu_seconds.append(outcome.cpu_seconds)
            pending.append(outcome)
            if len(pending) >= batch or time.perf_counter() - last_flush >= flush_seconds:
                flush()
            bar.update(done=1)
        interrupted.check()
        flush()
    finally:
        try:
            flush()
        finally:
            interrupted.restore()
            bar.close()
            if close is not None:
                close()
    report.failed.sort(key=lambda f: f["bag"])
    report.settings.sort(key=lambda f: f["bag"])
    report.seconds = time.perf_counter() - t0
    return report

