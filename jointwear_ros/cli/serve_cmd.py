"""``jointwear serve --db URL``: the plant's live web page, ``/api/joints`` and Prometheus ``/metrics``.

Read-only over the history store (see :mod:`jointwear_ros.serve`); binds 127.0.0.1 unless ``--host``
says otherwise. A bad ``--db`` (malformed URL, no such file, not a history store) or a port that cannot
be bound: one line on stderr, exit 2. A store that is locked or unreachable at start is reported on the
page and in ``/metrics`` (the service starts and keeps polling). Stops on Ctrl-C / SIGTERM.
"""

from __future__ import annotations

import argparse
import socket
import sys

from . import UsageError
from .common import parse_float

__all__ = ["register"]

DEFAULT_PORT = 9471


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser("serve", help="live web page, /api/joints and Prometheus /metrics over the history store",
                       description="Serve the plant's view of the wear history: a live page of every robot's "
                                   "joints (level, wear, time to alarm, plots), /api/joints (JSON) and /metrics "
                                   "(Prometheus). Read-only; refreshed when the store changes.")
    p.add_argument("--db", required=True, help="history store URL or SQLite file path (read only)")
    p.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1: this machine only)")
    p.add_argument("--port", default=str(DEFAULT_PORT), help=f"TCP port (default {DEFAULT_PORT}; 0: any free one)")
    p.add_argument("--horizon-days", default="30", help="WARN horizon in days, as trend --horizon (default 30)")
    p.add_argument("--stale-days", default="7", help="STALE when the newest estimate is older (default 7)")
    p.add_argument("--alarm", default="35", help="alarm wear level, as trend --alarm (default 35)")
    p.add_argument("--refresh", default="2", help="seconds between reads of the store (default 2)")
    p.add_argument("--analysis-version", default="live", help="which estimates (default live)")
    p.set_defaults(func=cmd_serve)


def _bind(host: str, port: int) -> socket.socket:
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
    except socket.gaierror as exc:
        raise UsageError(f"--host {host}: not an address of this machine ({exc.strerror})") from None
    family, kind, proto, _name, addr = infos[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(addr)
        sock.listen(128)
    except OSError as exc:
        sock.close()
        why = "in use by another program" if exc.errno == 98 else exc.strerror
        raise UsageError(f"--host {host} --port {port}: cannot listen ({why}); choose another --port") from None
    sock.set_inheritable(True)
    return sock


def cmd_serve(args: argparse.Namespace) -> int:
    try:
        import uvicorn

        from ..serve.web import create_app
    except ImportError as exc:
        raise UsageError(f"jointwear serve needs {exc.name or exc}: pip install 'jointwear_ros[serve]' "
                         "(starlette, uvicorn, jinja2, prometheus_client)") from None
    from ..history import HistoryError, normalize_url
    from ..serve.watch import StoreWatcher, open_readonly
    from ..trend import TrendConfig

    horizon = parse_float(args.horizon_days, "--horizon-days")
    stale = parse_float(args.stale_days, "--stale-days")
    alarm = parse_float(args.alarm, "--alarm")
    refresh = parse_float(args.refresh, "--refresh")
    if horizon < 0 or stale <= 0 or not 0 < alarm <= 100 or not 0.05 <= refresh <= 3600:
        raise UsageError(f"--horizon-days {horizon:g} must be >= 0, --stale-days {stale:g} > 0, --alarm {alarm:g} "
                         f"in (0, 100] and --refresh {refresh:g} in [0.05, 3600] s")
    try:
        port = int(args.port)
    except ValueError:
        raise UsageError(f"--port {args.port!r} is not a port number (1-65535, or 0 for any free port)") from None
    if not 0 <= port <= 65535:
        raise UsageError(f"--port {port} is not a port number (1-65535, or 0 for any free port)")
    url = normalize_url(args.db)
    try:  # a store that is not there or not a history store is a bad --db: say so now, not on the page
        probe = open_readonly(url)
    except HistoryError as exc:
        raise UsageError(f"--db {args.db}: {exc}") from None
    probe.close()
    sock = _bind(args.host, port)  # a port in use is found before anything is read
    watcher = StoreWatcher(url, TrendConfig(alarm=alarm, horizon_days=horizon), stale_days=stale,
                           refresh_s=refresh, analysis_version=args.analysis_version)
    try:
        snap = watcher.poll()
        if not snap.store_ok and _is_bad_store(snap.error):
            raise UsageError(f"--db {args.db}: not a jointwear history store ({snap.error})")
        host, bound = sock.getsockname()[:2]
        shown = f"[{host}]" if ":" in host else host
        print(f"jointwear serve: http://{shown}:{bound}/ (metrics /metrics, JSON /api/joints); store "
              f"{'read: ' + str(len(snap.views)) + ' joints' if snap.store_ok else 'NOT readable: ' + snap.error}; "
              f"refresh {refresh:g} s; Ctrl-C stops", flush=True)
        if not snap.store_ok:
            print(f"jointwear serve: warning: {snap.error} (the page says so; polling every {refresh:g} s)",
                  file=sys.stderr, flush=True)
        watcher.start()
        config = uvicorn.Config(create_app(watcher, poll_ms=int(max(1.0, min(refresh, 5.0)) * 1000)),
                                log_level="warning", access_log=False, limit_concurrency=64,
                                timeout_keep_alive=5, lifespan="on")
        uvicorn.Server(config).run(sockets=[sock])
    finally:
        watcher.stop()
        sock.close()
    return 0


def _is_bad_store(error: str) -> bool:
    """Errors that no waiting will fix (a wrong file or schema), as opposed to a locked or unreachable store."""
    e = error.lower()
    return any(k in e for k in ("not a database", "schema version 0", "no such table", "newer jointwear"))
