"""docs/extending.md runs as written, and docs/index.md lists every doc.

Every ``python`` and ``sh`` block of the guide runs here: a block whose first line is
``# file: PATH`` is written to PATH in a scratch directory (as are ``yaml`` blocks with that
line); the others run there in document order, python blocks in this process (tracebacks point
into docs/extending.md), sh blocks with ``bash -e``, the scratch directory on PYTHONPATH and
the environment's ``bin`` on PATH. The node example's own test module is imported and its
tests called; the node is also started as a process with its config file and must log a
published estimate and stop cleanly on SIGINT. The guide's ``[project.entry-points...]`` toml
blocks are installed into the scratch directory as ``pip install`` would (a ``.dist-info`` with
``entry_points.txt``), so the estimator it names is found by name, in this process and in the
``jointwear`` commands; the estimator registry and the history backends are restored afterwards.
"""

from __future__ import annotations

import contextlib
import inspect
import io
import os
import re
import signal
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "extending.md"
INDEX = ROOT / "docs" / "index.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```$", re.S | re.M)
FILE_LINE = re.compile(r"#\s*file:\s*(\S+)")


@dataclass(frozen=True)
class Block:
    lang: str
    code: str
    line: int  # line of the block's first code line in the markdown file

    @property
    def path(self) -> str | None:
        first = self.code.split("\n", 1)[0]
        m = FILE_LINE.fullmatch(first.strip())
        return m.group(1) if m else None


def blocks(md: Path) -> list[Block]:
    text = md.read_text(encoding="utf-8")
    return [Block(m.group(1), m.group(2), text.count("\n", 0, m.start(2)) + 1) for m in FENCE.finditer(text)]


RECIPE_LINE = re.compile(r"#\s*\S+,\s*(insert before:|new file)")
#: the guide's blocks but section 8's recipes, which test/test_docs_recipes.py applies to a copy of the checkout
GUIDE_BLOCKS = [b for b in blocks(GUIDE) if not RECIPE_LINE.match(b.code.split("\n", 1)[0].strip())]


def _purge_user_modules() -> None:
    """Forget the guide's package: its modules, and the workbench shapes it registered."""
    from jointwear_ros.workbench import SHAPES

    for name in [n for n in sys.modules if n == "my_jointwear" or n.startswith("my_jointwear.")]:
        del sys.modules[name]
    for shape in [s for s, cls in SHAPES.items() if cls.__module__.startswith("my_jointwear")]:
        del SHAPES[shape]


def _install_entry_points(ws: Path) -> dict[str, dict[str, str]]:
    """The guide's entry point tables written as an installed distribution's metadata in ``ws`` (what pip does)."""
    groups: dict[str, dict[str, str]] = {}
    for b in GUIDE_BLOCKS:
        if b.lang == "toml":
            for group, eps in tomllib.loads(b.code).get("project", {}).get("entry-points", {}).items():
                groups.setdefault(group, {}).update(eps)
    dist = ws / "my_jointwear-0.1.dist-info"
    dist.mkdir(exist_ok=True)
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: my_jointwear\nVersion: 0.1\n", encoding="utf-8")
    (dist / "entry_points.txt").write_text("".join(
        f"[{g}]\n" + "".join(f"{k} = {v}\n" for k, v in eps.items()) + "\n" for g, eps in groups.items()),
        encoding="utf-8")
    return groups


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """The guide's files written into a scratch directory, put first on sys.path; the estimator registry and the
    history backends as they were before the guide registered its own."""
    from jointwear_ros.estimation import ESTIMATORS
    from jointwear_ros.history import BACKENDS

    ws = tmp_path_factory.mktemp("extending")
    for b in GUIDE_BLOCKS:
        if b.path is not None:
            target = ws / b.path
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(b.code, encoding="utf-8")
    _install_entry_points(ws)
    estimators, backends = dict(ESTIMATORS._classes), dict(BACKENDS)
    sys.path.insert(0, str(ws))
    _purge_user_modules()
    yield ws
    sys.path.remove(str(ws))
    _purge_user_modules()
    ESTIMATORS._classes.clear()
    ESTIMATORS._classes.update(estimators)
    BACKENDS.clear()
    BACKENDS.update(backends)


def test_the_guide_has_the_three_worked_examples():
    files = {b.path for b in GUIDE_BLOCKS if b.path}
    assert {"my_jointwear/terms.py", "my_jointwear/shapes.py", "my_jointwear/estimators.py", "my_jointwear/wear_log_core.py",
            "my_jointwear/wear_log.py", "config/wear_log.yaml", "test/test_wear_log.py"} <= files
    assert "my_jointwear/memdb.py" in files  # the history backend of section 6
    runnable = [b for b in GUIDE_BLOCKS if b.lang in ("python", "sh") and b.path is None]
    assert len(runnable) >= 6
    # only these languages appear; a ```bash or ```py block would silently not run
    assert {b.lang for b in GUIDE_BLOCKS} <= {"python", "sh", "yaml", "toml", "text", "diff"}


def _expected_output(i: int) -> list[str]:
    """The lines of a ``# output`` text block right after block ``i`` (none when there is none)."""
    if i + 1 < len(GUIDE_BLOCKS):
        nxt = GUIDE_BLOCKS[i + 1]
        lines = nxt.code.splitlines()
        if nxt.lang == "text" and lines and lines[0].strip() == "# output":
            return [line for line in lines[1:] if line.strip()]
    return []


@pytest.mark.slow
def test_every_python_and_sh_block_of_the_guide_runs_in_order(workspace, monkeypatch):
    monkeypatch.chdir(workspace)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(workspace), os.environ.get("PYTHONPATH", "")]),
               PATH=os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")]))
    ran = checked = 0
    for i, b in enumerate(GUIDE_BLOCKS):
        if b.path is not None:
            if b.lang == "python":  # a module of the example: it must at least compile
                compile(b.code, f"{GUIDE}:{b.line}", "exec")
            continue
        if b.lang == "python":
            code = compile("\n" * (b.line - 1) + b.code, str(GUIDE), "exec")
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                exec(code, {"__name__": f"extending_md_line_{b.line}"})
            out = buf.getvalue()
        elif b.lang == "sh":
            r = subprocess.run(["bash", "-e", "-c", b.code], cwd=workspace, env=env, capture_output=True,
                               text=True, timeout=300)
            assert r.returncode == 0, f"sh block at docs/extending.md:{b.line} failed:\n{r.stdout}\n{r.stderr}"
            out = r.stdout
        else:
            continue
        ran += 1
        printed = [" ".join(line.split()) for line in out.splitlines()]
        for line in _expected_output(i):
            assert " ".join(line.split()) in printed, f"docs/extending.md:{b.line}: the block does not print {line!r}; it printed:\n{out}"
            checked += 1
    assert ran >= 6 and checked >= 13


@pytest.mark.ros
def test_the_guides_node_tests_pass(workspace, tmp_path):
    module = _load(workspace / "test" / "test_wear_log.py")
    tests = [(n, f) for n, f in vars(module).items() if n.startswith("test_") and callable(f)]
    assert len(tests) == 2
    for name, fn in tests:
        kwargs = {"tmp_path": tmp_path / name} if "tmp_path" in inspect.signature(fn).parameters else {}
        fn(**kwargs)


def _load(path: Path):
    import importlib.util

    spec = importlib.util.spec_from_file_location("extending_md_test_wear_log", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.ros
def test_the_guides_node_runs_as_a_process_with_its_config_and_logs_an_estimate(workspace, tmp_path,
                                                                                ros_context_per_test):
    rclpy = pytest.importorskip("rclpy")
    from jointwear_msgs.msg import WearEstimate
    from rclpy.executors import SingleThreadedExecutor

    from jointwear_ros.nodes.runtime import loopback_env

    log = tmp_path / "wear.csv"
    topic = "/wear_log_proc_test/wear_estimate"
    env = loopback_env(int(os.environ["ROS_DOMAIN_ID"]))
    env["PYTHONPATH"] = os.pathsep.join([str(workspace), env.get("PYTHONPATH", "")])
    proc = subprocess.Popen(
        [sys.executable, "-m", "my_jointwear.wear_log", "--ros-args", "--params-file",
         str(workspace / "config" / "wear_log.yaml"), "-p", f"path:={log}", "-p", f"estimate_topic:={topic}"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )
    ctx = ros_context_per_test
    peer = rclpy.create_node("wear_log_proc_test_io", context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(peer)
    try:
        pub = peer.create_publisher(WearEstimate, topic, 10)
        end = time.monotonic() + 60.0
        while pub.get_subscription_count() == 0 and time.monotonic() < end and proc.poll() is None:
            ex.spin_once(timeout_sec=0.05)
        assert pub.get_subscription_count() == 1, "the wear_log process never subscribed"
        m = WearEstimate(joint_name="joint_1", cycle_id=7, method="joint", wear=37.25, wear_std=1.5,
                         wear_low=34.25, wear_high=40.25, temperature_estimate=44.0, alarm_threshold=35.0,
                         alarm=True)
        pub.publish(m)
        end = time.monotonic() + 30.0
        while (not log.exists() or log.read_text().count("\n") < 2) and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        ex.shutdown()
        peer.destroy_node()
    assert proc.returncode == 0, out
    lines = log.read_text().splitlines()
    assert lines[0].startswith("stamp,joint_name,cycle_id,method,wear,")
    assert lines[1:] == ["0.0,joint_1,7,joint,37.25,1.5,34.25,40.25,44.0,1"], out
    assert "cycle 7: wear 37.25 ± 1.50 logged" in out


def test_the_guides_estimator_is_found_by_name_through_its_entry_point_and_works(workspace, monkeypatch):
    from my_jointwear.estimators import NominalTemperatureEstimator

    import jointwear_ros.estimation as estimation
    from jointwear_ros.monitor import MonitorConfig, WearMonitor
    from jointwear_ros.observer import FrictionObservationData

    groups = _install_entry_points(workspace)
    assert groups["jointwear.estimators"] == {"nominal-lsq": "my_jointwear.estimators:NominalTemperatureEstimator"}
    # a registry that has never seen it finds it by name, as a node or the CLI does
    fresh = estimation.EstimatorRegistry(estimation.PaperEstimator)
    assert fresh.get_class("nominal-lsq") is NominalTemperatureEstimator and list(fresh) == ["paper", "nominal-lsq"]
    assert fresh.capabilities("nominal-lsq").cycle and not fresh.capabilities("paper").cycle
    with pytest.raises(estimation.InputDataError, match="is taken by"):
        fresh.register(type("Impostor", (NominalTemperatureEstimator,), {}))

    monkeypatch.setattr(estimation.ESTIMATORS, "_classes", dict(estimation.ESTIMATORS._classes))
    estimation.ESTIMATORS._classes.pop("nominal-lsq", None)  # the process-wide registry: through the entry point too
    est = estimation.make_estimator("nominal-lsq", seed=3, temperature=45.0)
    assert est.name == "nominal-lsq" and est.temperature == 45.0
    with pytest.raises(estimation.InputDataError, match="takes no option bogus"):
        estimation.make_estimator("nominal-lsq", bogus=1)

    monitor = WearMonitor(MonitorConfig(method="nominal-lsq", idle_timeout=1.0))  # the node's path: by name
    for k, v in enumerate((30.0, 47.0, 65.0)):
        monitor.add(FrictionObservationData(
            stamp=float(k), joint_name="joint_1", cycle_id=4, speed=v, tau_f=0.09 + 0.0001 * k, tau_f_std=0.0,
            tau_plus=0.19, tau_minus=0.01, load_torque=0.1, temperature=float("nan"), position=0.0,
            samples_plus=100, samples_minus=100))
    (cycle,) = monitor.poll(now=10.0)
    assert cycle.result is not None and cycle.result.method == "nominal-lsq"
    assert 0.0 < cycle.result.wear_std < 10.0


def _links(md: Path) -> list[str]:
    return re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", md.read_text(encoding="utf-8"))


def test_the_index_lists_every_doc_and_its_links_resolve():
    docs = sorted(p.name for p in (ROOT / "docs").glob("*.md") if p.name != "index.md")
    linked = _links(INDEX)
    missing = [d for d in docs if d not in linked]
    assert not missing, f"docs/index.md does not list {', '.join(missing)}"
    for md in (INDEX, GUIDE):
        broken = [link for link in _links(md) if "://" not in link and not (md.parent / link).exists()]
        assert not broken, f"{md.name}: broken links {broken}"
    assert "docs/index.md" in (ROOT / "README.md").read_text(encoding="utf-8")


@pytest.mark.ros
def test_the_guides_node_stops_with_the_reason_when_its_path_cannot_be_written(workspace, tmp_path):
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("a file where the log's directory should be\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(workspace), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, "-m", "my_jointwear.wear_log", "--ros-args", "-p",
                        f"path:={blocker / 'wear.csv'}"], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=60)
    assert r.returncode == 1
    assert f"parameter path = '{blocker / 'wear.csv'}': cannot append to it" in r.stderr
