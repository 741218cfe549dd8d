"""A simulated cell as a library: start the nodes as child processes, and an in-process operator client.

What ``jointwear demo`` does, reusable by scripts and tests:

- :func:`start_child` starts one node's console script with its ``config/<node>.yaml`` and ``-p``
  overrides, in the environment it is given (build it with
  :func:`jointwear_ros.nodes.runtime.loopback_env`: loopback discovery, a domain of its own), its
  output in ``logdir/<node>.log``; :func:`stop_children` stops them (SIGINT, then SIGTERM, SIGKILL).
- :class:`Operator` is an rclpy node in its own context, on the cell's domain: it waits for the
  graph (:func:`ready_conditions`), calls ``/test_cycle/run`` (:meth:`Operator.start_cycle` retries a
  refusal whose :class:`~jointwear_ros.contract.RefusalReason` is ``retryable``), and collects the
  cycle's status, observations, estimates and its ``wear_estimator: <joint>`` diagnostics.

The cell's environment is passed to the children as a dict; the operator takes the domain id as an
argument (``rclpy.init(domain_id=...)``). Loopback-only discovery is read by the RMW from
``ROS_AUTOMATIC_DISCOVERY_RANGE`` when the operator's context starts: the operator sets it for that
call only and restores the environment after.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from ..contract import CycleState, RefusalReason
from ..errors import JointwearError
from ..resources import config_path

__all__ = ["CellError", "Child", "Operator", "after", "die_with_parent", "ready_conditions", "start_child",
           "stop_children"]


class CellError(JointwearError):
    """The cell could not do what was asked (a node died, a timeout, a refused request)."""


def _quiet(text: str) -> None:
    """The default progress callback: say nothing."""


@dataclass
class Child:
    """One node process and its log file."""

    name: str
    proc: subprocess.Popen[bytes]
    log: Path
    fh: IO[bytes]

    def alive(self) -> bool:
        return self.proc.poll() is None

    def log_tail(self, lines: int = 8) -> str:
        try:
            text = self.log.read_text(errors="replace").strip().splitlines()
        except OSError:
            return ""
        return " | ".join(text[-lines:])


def _executable(name: str) -> str:
    local = Path(sys.executable).parent / name
    if local.is_file():
        return str(local)
    found = shutil.which(name)
    if found is None:
        raise CellError(f"console script {name!r} not found next to {sys.executable} or on PATH; "
                        "install the package (make env / pip install -e .)")
    return found


def _param_args(params: Mapping[str, Any]) -> list[str]:
    out: list[str] = []
    for k, v in params.items():
        if isinstance(v, bool):
            text = "true" if v else "false"
        elif isinstance(v, float):
            text = repr(v)
        else:
            text = str(v)
        out += ["-p", f"{k}:={text}"]
    return out


def _prctl() -> Callable[..., int] | None:
    """libc's ``prctl`` on Linux (None elsewhere), looked up once, before any fork."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl  # type: ignore[no-any-return]
    except (OSError, AttributeError):  # pragma: no cover - a libc without prctl
        return None


_PRCTL = _prctl()
_PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    """``preexec_fn`` for a node process: SIGTERM it when the process that started it dies.

    A cell whose driver (``jointwear demo``, a script, a test) is killed hard must not leave nodes
    running: a test_cycle node could go on moving a joint, and nodes left on the domain answer the
    next cell's messages. SIGTERM lets the node stop as on Ctrl-C (zero command first). Linux only
    (``prctl(PR_SET_PDEATHSIG)``); elsewhere nothing. The signal follows the *thread* that started
    the child: start children from a thread that lives as long as they should (the main thread).
    """
    if _PRCTL is not None:
        _PRCTL(_PR_SET_PDEATHSIG, int(signal.SIGTERM))


def start_child(name: str, params: Mapping[str, Any], env: Mapping[str, str], logdir: Path) -> Child:
    """Start node ``name`` with its config file and ``params`` overrides; output to ``logdir/<name>.log``."""
    cmd = [_executable(name), "--ros-args"]
    cfg = config_path(f"{name}.yaml")
    if cfg.is_file():
        cmd += ["--params-file", str(cfg)]
    cmd += _param_args(params)
    log = logdir / f"{name}.log"
    fh = log.open("wb")
    fh.write(("$ " + " ".join(cmd) + "\n").encode())
    fh.flush()
    proc = subprocess.Popen(cmd, env=dict(env), stdout=fh, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            preexec_fn=die_with_parent)
    return Child(name, proc, log, fh)


def stop_children(children: Sequence[Child], sigint_timeout: float = 15.0, sigterm_timeout: float = 5.0,
                  progress: Callable[[str], None] = _quiet) -> None:
    """SIGINT every child, then SIGTERM and SIGKILL the ones still running after the timeouts."""
    for sig, timeout in ((signal.SIGINT, sigint_timeout), (signal.SIGTERM, sigterm_timeout), (signal.SIGKILL, 5.0)):
        running = [c for c in children if c.alive()]
        if not running:
            break
        for c in running:
            try:
                c.proc.send_signal(sig)
            except ProcessLookupError:
                pass
        end = time.monotonic() + timeout
        while time.monotonic() < end and any(c.alive() for c in running):
            time.sleep(0.05)
        if sig != signal.SIGINT:
            for c in running:
                if c.alive():
                    progress(f"{c.name} did not stop on {signal.Signals(sig).name}")
    for c in children:
        try:
            c.proc.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            pass
        c.fh.close()


def after(deadline: float) -> Callable[[], bool]:
    """A predicate that turns true at ``deadline`` (time.monotonic)."""
    return lambda: time.monotonic() > deadline


@contextmanager
def _loopback_discovery() -> Iterator[None]:
    """``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` while a context starts (the RMW reads it then), restored after."""
    key = "ROS_AUTOMATIC_DISCOVERY_RANGE"
    saved = os.environ.get(key)
    os.environ[key] = "LOCALHOST"
    try:
        yield
    finally:
        if saved is None:
            del os.environ[key]
        else:
            os.environ[key] = saved


class Operator:
    """An in-process rclpy node that does what an operator does: wait, call the service, watch.

    Parameters
    ----------
    joint_name : the joint of the cell (test_cycle's ``joint_name``), or the joints of a robot cycle in
        test order; the ``wear_estimator: <joint>`` statuses of each are collected.
    domain_id : the cell's ``ROS_DOMAIN_ID`` (``None``: the environment's).
    progress : called with one line of text on what the operator does (default: nothing).
    """

    def __init__(self, joint_name: str | Sequence[str], domain_id: int | None = None,
                 progress: Callable[[str], None] = _quiet) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate
        from jointwear_msgs.srv import RunTestCycle
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.signals import SignalHandlerOptions

        self.rclpy = rclpy
        self.ctx = rclpy.Context()
        self.progress = progress
        with _loopback_discovery():
            rclpy.init(context=self.ctx, domain_id=domain_id, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("jointwear_demo_operator", context=self.ctx)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)
        self.joints: list[str] = [joint_name] if isinstance(joint_name, str) else [str(j) for j in joint_name]
        if not self.joints or len(set(self.joints)) != len(self.joints):
            raise CellError(f"the operator needs distinct joint names, got {self.joints}")
        self.joint_name = self.joints[0]
        self._diag_names = {f"wear_estimator: {j}": j for j in self.joints}
        #: the newest ``friction_observer: <joint>`` status of each joint (its per-cycle counts)
        self.observer_status: dict[str, Any] = {}
        self._observer_names = {f"friction_observer: {j}": j for j in self.joints}
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.observations: list[Any] = []
        self.estimates: list[Any] = []
        #: (arrival number, message): the order this operator heard estimates and statuses in
        self.diagnostics: list[tuple[int, Any]] = []
        self.estimate_arrivals: list[int] = []
        self._heard = 0
        self.status: Any = None
        #: every TestCycleStatus heard, in order (a robot cycle's progress, joint by joint)
        self.statuses: list[Any] = []
        self.node.create_subscription(FrictionObservation, "/jointwear/friction_observations",
                                      self.observations.append, qos)
        self.node.create_subscription(WearEstimate, "/jointwear/wear_estimate", self._on_estimate, qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, qos)
        self.node.create_subscription(TestCycleStatus, "/test_cycle/status", self._on_status, qos)
        self.client = self.node.create_client(RunTestCycle, "/test_cycle/run")
        self.Request = RunTestCycle.Request

    def _on_estimate(self, msg: Any) -> None:
        self._heard += 1
        self.estimates.append(msg)
        self.estimate_arrivals.append(self._heard)

    def _on_diag(self, msg: Any) -> None:
        self._heard += 1
        for st in msg.status:
            if st.name in self._diag_names:
                self.diagnostics.append((self._heard, st))
            elif st.name in self._observer_names:
                self.observer_status[self._observer_names[st.name]] = st

    def _on_status(self, msg: Any) -> None:
        self.status = msg
        self.statuses.append(msg)

    def robot_cycle_over(self, cycle_id: int) -> bool:
        """True once the robot cycle ``cycle_id`` has ended: its last joint DONE, or any joint ABORTED or
        FAILED (the cycle stops there), per the status contract of ``docs/robot.md``."""
        for st in self.statuses:
            if st.cycle_id != cycle_id:
                continue
            if st.state in (CycleState.ABORTED, CycleState.FAILED):
                return True
            n = max(len(st.joints), 1)
            if st.state == CycleState.DONE and st.joints_done + 1 >= n:
                return True
        return False

    def observer_done(self, cycle_id: int, joint: str) -> bool:
        """The observer has finished every speed ``joint`` ran in cycle ``cycle_id`` (an observation or a
        rejected window each, per its ``friction_observer: <joint>`` status) and this operator has
        heard each of those observations. A joint whose test ended early counts the speeds it began."""
        mine = [st for st in self.statuses if st.cycle_id == cycle_id and st.joint_name == joint]
        if not mine:
            return False
        if any(st.state == CycleState.DONE for st in mine):
            expected = max(int(st.speeds_total) for st in mine)
        elif any(st.state in (CycleState.ABORTED, CycleState.FAILED) for st in mine):
            expected = max(int(st.speeds_done) for st in mine) + 1
        else:
            return False
        st = self.observer_status.get(joint)
        if st is None:
            return False
        kv = {v.key: v.value for v in st.values}
        if kv.get("cycle_id") != str(cycle_id):
            return False
        try:
            observed = int(kv["observations_this_cycle"])
            rejected = int(kv["rejected_windows_this_cycle"])
        except (KeyError, ValueError):
            return False
        heard = sum(1 for o in self.observations if o.cycle_id == cycle_id and o.joint_name == joint)
        return observed + rejected >= expected and heard >= observed

    def joints_started(self, cycle_id: int) -> list[str]:
        """The joints of cycle ``cycle_id`` that have started (been RUNNING), in order."""
        out: list[str] = []
        for st in self.statuses:
            if st.cycle_id == cycle_id and st.state != CycleState.IDLE and st.joint_name not in out:
                out.append(str(st.joint_name))
        return out

    def spin_until(self, predicate: Callable[[], bool], timeout: float, children: Sequence[Child],
                   what: str, tick: Callable[[], None] | None = None) -> None:
        end = time.monotonic() + timeout
        while not predicate():
            for c in children:
                if not c.alive():
                    raise CellError(f"{c.name} exited with code {c.proc.returncode} while waiting for {what}; "
                                    f"log {c.log}: {c.log_tail(4)}")
            if time.monotonic() > end:
                raise CellError(f"timed out after {timeout:.0f} s waiting for {what}; logs in {children[0].log.parent}")
            self.ex.spin_once(timeout_sec=0.05)
            if tick is not None:
                tick()

    def subscribers(self, topic: str) -> set[str]:
        return {i.node_name for i in self.node.get_subscriptions_info_by_topic(topic)}

    def call_run(self, speeds: Sequence[float], children: Sequence[Child], timeout: float
                 ) -> tuple[bool, int, RefusalReason, str]:
        self._warm_up(speeds, children, timeout)
        req = self._request(speeds, dry_run=False)
        fut = self.client.call_async(req)
        self.spin_until(fut.done, timeout, children, "the answer of /test_cycle/run")
        resp = fut.result()
        return bool(resp.accepted), int(resp.cycle_id), RefusalReason(resp.reason), str(resp.message)

    def _request(self, speeds: Sequence[float], dry_run: bool) -> Any:
        """A robot-cycle request for this operator's joints, each at its configured window."""
        return self.Request(joints=list(self.joints), speeds=[float(s) for s in speeds], dry_run=dry_run)

    def _warm_up(self, speeds: Sequence[float], children: Sequence[Child], timeout: float) -> None:
        """A dry run, re-sent every 3 s until answered: right after discovery a service's first
        response can be lost (the client's response reader not yet matched), and a dry run is
        safe to repeat where the real request is not."""
        req = self._request(speeds, dry_run=True)
        end = time.monotonic() + timeout
        while True:
            fut = self.client.call_async(req)
            try:
                self.spin_until(fut.done, 3.0, children, "the answer of /test_cycle/run (dry run)")
                return
            except CellError as exc:
                if "timed out" not in str(exc) or time.monotonic() > end:
                    raise  # a node died, or no answer at all
                self.progress("no answer from /test_cycle/run yet; asking again")

    def start_cycle(self, speeds: Sequence[float], children: Sequence[Child], timeout: float = 30.0,
                    retry_for: float = 20.0) -> tuple[int, str]:
        """Call ``/test_cycle/run`` as an operator would: a refusal whose reason is retryable (the joint
        state not there yet or late, a cycle still running) is re-sent every second for ``retry_for``
        seconds; any other refusal raises :class:`CellError` with the reason. Returns (cycle id, plan)."""
        end = time.monotonic() + retry_for
        while True:
            accepted, cycle_id, reason, message = self.call_run(speeds, children, timeout)
            if accepted or not reason.retryable or time.monotonic() > end:
                break
            self.progress(f"/test_cycle/run refused ({reason.name}: {message}); retrying in 1 s")
            self.spin_until(after(time.monotonic() + 1.0), 5.0, children, "a retry")
        if not accepted:
            raise CellError(f"/test_cycle/run refused the request ({reason.name}): {message}")
        return cycle_id, message

    def close(self) -> None:
        try:
            self.ex.shutdown()
            self.node.destroy_node()
        finally:
            self.rclpy.try_shutdown(context=self.ctx)


def ready_conditions(op: Operator) -> Callable[[], list[str]]:
    needs = {
        "/joint_states": {"test_cycle", "friction_observer", "recorder"},
        "/test_cycle/status": {"friction_observer", "recorder"},
        "/jointwear/friction_observations": {"wear_estimator", "recorder"},
        "/jointwear/wear_estimate": {"recorder"},
        "/velocity_controller/commands": {"joint_sim", "recorder"},
        "/clock": {"recorder"},
    }

    def missing() -> list[str]:
        out = []
        for topic, nodes in needs.items():
            lack = nodes - op.subscribers(topic)
            if lack:
                out.append(f"{topic} <- {', '.join(sorted(lack))}")
        if not op.client.service_is_ready():
            out.append("/test_cycle/run")
        return out

    return missing
