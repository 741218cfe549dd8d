"""Installed as colcon installs it: not editable, into a prefix of its own, found through the ament index.

A copy of the source tree is installed the way colcon's ament_python build does it
(``setup.py egg_info build install --prefix P --single-version-externally-managed``, which honours
``setup.cfg``'s ``install_scripts`` so ``ros2 run`` finds the executables in ``lib/jointwear_ros``).
Then the source tree is out of reach (cwd elsewhere, ``PYTHONPATH`` at the prefix's site-packages, ahead
of the venv's editable install) and only ``AMENT_PREFIX_PATH`` tells where things are: the new prefix
plus the ROS environment (the venv, which holds the ROS wheels and ``jointwear_msgs``).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import sysconfig
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def prefix(tmp_path_factory):
    p = tmp_path_factory.mktemp("prefix")
    work = tmp_path_factory.mktemp("colcon")
    src = work / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(".git", ".venv", "build", "out", "*.egg-info",
                                                              "__pycache__", ".pytest_cache", ".mypy_cache"))
    proc = subprocess.run(
        [sys.executable, "setup.py", "egg_info", "--egg-base", str(work), "build", "--build-base", str(work / "build"),
         "install", "--prefix", str(p), "--record", str(work / "install.log"), "--single-version-externally-managed"],
        cwd=src, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    shutil.rmtree(src)  # nothing may be read from a source tree afterwards
    return p


def _site_packages(prefix: Path) -> Path:
    rel = Path(sysconfig.get_paths()["purelib"]).relative_to(sys.prefix)
    return prefix / rel


def _env(prefix: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "AMENT_PREFIX_PATH", "JOINTWEAR_PARAMS_PATH")}
    env["PYTHONPATH"] = str(_site_packages(prefix))
    env["AMENT_PREFIX_PATH"] = os.pathsep.join([str(prefix), sys.prefix])
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return env


def test_installed_layout_has_the_share_files_and_scripts(prefix):
    share = prefix / "share" / "jointwear_ros"
    assert (share / "package.xml").is_file()
    assert (share / "config" / "params" / "ref-2011r.yaml").is_file()
    assert (share / "config" / "wear_estimator.yaml").is_file()
    assert (share / "launch" / "jointwear.launch.py").is_file()
    assert (prefix / "share" / "ament_index" / "resource_index" / "packages" / "jointwear_ros").is_file()
    for script in ("jointwear", "joint_sim", "test_cycle", "friction_observer", "wear_estimator", "recorder"):
        assert (prefix / "lib" / "jointwear_ros" / script).is_file(), script  # where ros2 run looks


def test_installed_package_finds_its_parameter_sets_through_the_ament_index(prefix, tmp_path):
    code = (
        "import jointwear_ros, jointwear_ros.resources as r\n"
        "from jointwear_ros.model import load_parameter_set\n"
        "from jointwear_ros.model.paramsets import load_parameter_set_info\n"
        "from jointwear_ros.io.typestore import jointwear_typestore\n"
        "assert r.source_tree() is None, r.source_tree()\n"
        "print(jointwear_ros.__file__)\n"
        "print(load_parameter_set_info('ref-2011r').path)\n"
        "print(load_parameter_set('ref-2011r')['Fsw'].value)\n"
        "print('jointwear_msgs/msg/WearEstimate' in jointwear_typestore().fielddefs)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=_env(prefix),
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    module, params_path, fsw, has_msgs = proc.stdout.split()
    assert module.startswith(str(prefix)), module
    assert params_path == str(prefix / "share" / "jointwear_ros" / "config" / "params" / "ref-2011r.yaml")
    assert float(fsw) == pytest.approx(9.10e-4)
    assert has_msgs == "True"


def test_installed_cli_runs_from_the_prefix(prefix, tmp_path):
    proc = subprocess.run([str(prefix / "lib" / "jointwear_ros" / "jointwear"), "model", "curve", "--params",
                           "ref-2011r", "--wear", "35", "--speeds", "47", "--json"],
                          cwd=tmp_path, env=_env(prefix), capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert '"tau_f"' in proc.stdout


@pytest.mark.ros
def test_installed_node_starts_with_its_installed_params_file(prefix, tmp_path):
    env = _env(prefix)
    env.setdefault("ROS_DOMAIN_ID", os.environ.get("ROS_DOMAIN_ID", "42"))
    params = prefix / "share" / "jointwear_ros" / "config" / "wear_estimator.yaml"
    log = tmp_path / "wear_estimator.log"
    with log.open("w") as fh:
        proc = subprocess.Popen([str(prefix / "lib" / "jointwear_ros" / "wear_estimator"), "--ros-args",
                                 "--params-file", str(params)],
                                cwd=tmp_path, env=env, stdout=fh, stderr=subprocess.STDOUT, text=True)
    try:
        # the node came up (it logs what it estimates, after loading its parameter set) and is still up;
        # one that cannot find its resources exits instead
        deadline = time.monotonic() + 60.0
        while "estimating wear of" not in log.read_text() and proc.poll() is None:
            assert time.monotonic() < deadline, log.read_text()
            time.sleep(0.1)
        assert proc.poll() is None, log.read_text()
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=20)
    out = log.read_text()
    assert proc.returncode == 0, out
    assert "unknown parameter set" not in out
