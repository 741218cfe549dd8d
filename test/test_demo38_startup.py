"""The demo cell's fixed costs: what a node and the demo load before they are needed, and the order the cell
stops in (the imports run in a fresh interpreter, the stop on plain child processes), and when the cell is ready
for a cycle (over DDS)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from jointwear_ros.cli import demo_cmd
from jointwear_ros.nodes.cell import Child

ROOT = Path(__file__).resolve().parents[1]


def _fresh(code: str) -> subprocess.CompletedProcess[str]:
    """``code`` in a fresh interpreter on this checkout (its modules loaded from nothing)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True, env=env,
                          timeout=120, check=False)


def test_the_wear_estimator_node_imports_without_scipy_stats_or_optimize():
    # a cell waits for this node before its cycle starts: the estimate's modules load once it spins
    proc = _fresh("""
        import sys
        import jointwear_ros.nodes.wear_estimator
        print([m for m in ("scipy.stats", "scipy.optimize") if m in sys.modules])
    """)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["[]"], proc.stdout


def test_the_default_prior_loads_no_scipy_stats_and_is_the_same():
    # the priors' own uniform and normal laws (priors.py): an estimate never pays scipy.stats' import
    proc = _fresh("""
        import json, sys
        from jointwear_ros.estimation.crb import DEFAULT_CRB_PRIOR
        from jointwear_ros.estimation.priors import parse_temperature_prior
        before = "scipy.stats" in sys.modules
        prior = parse_temperature_prior(DEFAULT_CRB_PRIOR)
        print(json.dumps([before, "scipy.stats" in sys.modules, prior.label, list(prior.support(1.0))]))
    """)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout) == [False, False, "uniform:25:55", [25.0, 55.0]]


def test_the_demo_checks_its_arguments_without_loading_the_estimators_or_the_model(capsys):
    # --speeds above test_cycle's max_speed is refused after every other check, before any node starts
    proc = _fresh("""
        import sys
        from jointwear_ros.cli import main
        rc = main(["demo", "--speeds", "10,900", "--out", "out/never"])
        print(rc, [m for m in ("jointwear_ros.estimation.registry", "jointwear_ros.model.paramsets", "scipy")
                   if m in sys.modules])
    """)
    assert "--speeds: 900 rad/s is above test_cycle's max_speed" in proc.stderr, proc.stderr
    assert proc.stdout.split() == ["2", "[]"], (proc.stdout, proc.stderr)
    # they still load to check a method or a temperature given
    from jointwear_ros.cli import main

    assert main(["demo", "--method", "nonesuch", "--out", "out/never"]) == 2
    assert "--method: unknown wear estimation method 'nonesuch'" in capsys.readouterr().err
    assert main(["demo", "--temperature", "-300", "--out", "out/never"]) == 2
    assert "--temperature:" in capsys.readouterr().err


_NODE = """
import pathlib, signal, sys, time
name, folder, linger = sys.argv[1], pathlib.Path(sys.argv[2]), float(sys.argv[3])
def stop(signum, frame):
    (folder / f"{name}.signalled").write_text(repr(time.monotonic()))
    time.sleep(linger)  # as a node finishing its bag or its acknowledgements
    (folder / f"{name}.exited").write_text(repr(time.monotonic()))
    sys.exit(0)
signal.signal(signal.SIGINT, stop)
(folder / f"{name}.ready").write_text("")
while True:
    time.sleep(0.01)
"""


def test_the_cell_stops_the_producers_then_the_recorder_and_the_clock_source_together(tmp_path):
    """The producers (each waits for the recorder's acknowledgement on its way out) stop first; the recorder
    then stops together with joint_sim, the clock source (no sim-time node is left to need /clock), and not
    before RECORDER_GRACE s after the operator heard the run's results."""
    linger = {"recorder": 1.0, "joint_sim": 0.2, "test_cycle": 0.2, "friction_observer": 0.2, "wear_estimator": 0.2}
    children = []
    try:
        for name in demo_cmd.DEMO_NODES:
            log = tmp_path / f"{name}.log"
            fh = log.open("wb")
            proc = subprocess.Popen([sys.executable, "-c", _NODE, name, str(tmp_path), str(linger[name])],
                                    stdout=fh, stderr=subprocess.STDOUT)
            children.append(Child(name, proc, log, fh))
        end = time.monotonic() + 60.0
        while not all((tmp_path / f"{n}.ready").exists() for n in demo_cmd.DEMO_NODES):
            assert time.monotonic() < end, "the child processes did not start"
            time.sleep(0.02)
        heard = time.monotonic()
        demo_cmd._stop_cell(children, heard)
    finally:
        for c in children:
            if c.alive():
                c.proc.send_signal(signal.SIGKILL)
                c.proc.wait()
    assert all(c.proc.returncode == 0 for c in children), [(c.name, c.proc.returncode) for c in children]

    def at(name: str, what: str) -> float:
        return float((tmp_path / f"{name}.{what}").read_text())

    producers = ("test_cycle", "friction_observer", "wear_estimator")
    last_producer = max(at(p, "exited") for p in producers)
    assert at("recorder", "signalled") >= last_producer
    assert at("joint_sim", "signalled") >= last_producer
    assert at("recorder", "signalled") >= heard + demo_cmd.RECORDER_GRACE
    # together: joint_sim is not left for after the recorder has closed its bag
    assert at("joint_sim", "signalled") < at("recorder", "exited")



@pytest.mark.ros
def test_the_cell_is_not_ready_until_each_sim_time_node_stamps_on_its_clock(ros_context, ros_domain_of_the_module):
    # the graph shows a node's /clock subscription before it matched: an observer still without /clock lost a
    # cycle's first window; a node's /diagnostics stamped after 0 shows its clock runs
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from jointwear_ros.nodes.cell import Operator, ready_conditions

    op = Operator("joint_1", ros_domain_of_the_module)
    node = rclpy.create_node("demo38_cell", context=ros_context)
    pub = node.create_publisher(DiagnosticArray, "/diagnostics",
                                QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))

    def spin_until(predicate, what: str) -> None:
        end = time.monotonic() + 30.0
        while not predicate():
            assert time.monotonic() < end, f"timed out waiting for {what}"
            op.ex.spin_once(timeout_sec=0.05)

    def send(sec: int) -> None:
        arr = DiagnosticArray(status=[DiagnosticStatus(name="friction_observer: joint_1", hardware_id="joint_1")])
        arr.header.stamp.sec = sec
        pub.publish(arr)

    try:
        missing = ready_conditions(op, clocked=("friction_observer",))
        spin_until(lambda: pub.get_subscription_count() > 0, "the operator's /diagnostics subscription")
        send(0)  # before /clock: a sim-time node stamps 0
        spin_until(lambda: op._heard >= 1, "the status stamped 0")
        assert "/clock -> friction_observer (no /diagnostics stamped on it yet)" in missing()
        send(1795000000)
        spin_until(lambda: op._heard >= 2, "the status stamped on the clock")
        assert not [m for m in missing() if m.startswith("/clock ->")], missing()
    finally:
        node.destroy_node()
        op.close()
