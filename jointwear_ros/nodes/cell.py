"""A simulated cell as a library: start the nodes as child processes, and an in-process operator client.

What ``jointwear demo`` does, reusable by scripts and tests:

- :func:`start_child` starts one node's console script (or ``python -m``) with its ``config/<node>.yaml``,
  parameter files and ``-p`` overrides, in the environment it is given (build it with
  :func:`jointwear_ros.nodes.runtime.loopback_env`: loopback discovery, a domain of its own), its
  output in ``logdir/<node>.log`` (or a file of its own); :class:`Child` is the process (``stop``,
  ``output``, ``log_tail``); :func:`stop_children` stops a cell (SIGINT, then SIGTERM, SIGKILL). The test
  harness (test/conftest.py's ``NodeProcess``) starts its nodes with these too.
- :class:`Operator` is an rclpy node in its own context, on the cell's domain: it waits for the
  graph (:func:`ready_conditions`), calls ``/test_cycle/run`` (:meth:`Operator.start_cycle` retries a
  refusal whose :class:`~jointwear_ros.contract.RefusalReason` is ``retryable``), collects the
  cycle's statuses (as :class:`~jointwear_ros.contract.CycleStatus`), observations, estimates and its
  ``wear_estimator: <joint>`` diagnostics, and knows when a cycle is over: :meth:`Operator.estimated`
  (every joint tested has its estimate, or the estimator's verdict that there is none),
  :meth:`Operator.complete` (the observer has finished every speed and the newest estimate covers
  every observation) and :meth:`Operator.joint_report` (a joint's newest estimate and the
  diagnostic status heard after it, as a :class:`JointReport`).

The cell's environment is passed to the children as a dict; the operator takes the domain id as an
argument (``rclpy.init(domain_id=...)``). Loopback-only discovery is read by the RMW from
``ROS_AUTOMATIC_DISCOVERY_RANGE`` when the operator's context starts: the operator sets it for that
call only and restores the environment after.
"""

from __future__ import annotations

import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, TypeVar

from ..contract import CycleState, CycleStatus, DiagnosticLevel, RefusalReason, status_from_msg
from ..errors import JointwearError
from ..resources import config_path

__all__ = ["SIM_STATE_TIMEOUT_WALL", "CellError", "Child", "JointReport", "Operator", "after", "die_with_parent",
           "ready_conditions", "run_until_accepted", "simulated_cycle_params", "start_child", "stop_children"]

_Answer = TypeVar("_Answer")


#: test_cycle's wall-clock watchdog (``state_timeout_wall``) in a simulated cell, at least: the simulator is a
#: process on the same machine, and a loaded one starved it of CPU for 1.02-1.48 s (two test workers at load
#: 11-22) without it having died, which failed the cycle at the configured 1 s. 3 s still catches a simulator that
#: died; a real cell keeps its configured value. The demos and the test harness's simulated cells both use it.
SIM_STATE_TIMEOUT_WALL = 3.0


def simulated_cycle_params(params: Mapping[str, Any]) -> dict[str, Any]:
    """test_cycle's ``params`` for a cell whose joints are a simulator (``simulator: true``): its wall-clock
    watchdog at least :data:`SIM_STATE_TIMEOUT_WALL` unless ``params`` set one; other params as given."""
    out = dict(params)
    if out.get("simulator") and "state_timeout_wall" not in out:
        out["state_timeout_wall"] = SIM_STATE_TIMEOUT_WALL
    return out


class CellError(JointwearError):
    """The cell could not do what was asked (a node died, a timeout, a refused request)."""


def _quiet(text: str) -> None:
    """The default progress callback: say nothing."""


@dataclass
class Child:
    """One node process and its log file (``own_log``: a temporary file :meth:`close` removes)."""

    name: str
    proc: subprocess.Popen[bytes]
    log: Path
    fh: IO[bytes]
    own_log: bool = False

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return self.proc.poll() is None

    def output(self) -> str:
        """Everything the node wrote so far."""
        try:
            return self.log.read_text(errors="replace")
        except OSError:
            return ""

    def log_tail(self, lines: int = 8) -> str:
        return " | ".join(self.output().strip().splitlines()[-lines:])

    def stop(self, sig: int = signal.SIGINT, timeout: float = 15.0) -> int:
        """Send ``sig`` (SIGINT: as Ctrl-C), wait ``timeout`` s, then SIGKILL; the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self.fh.close()
        return int(self.proc.returncode)

    def close(self) -> None:
        """Stop it (if still running) and remove its log if the log is its own temporary file."""
        self.stop()
        if self.own_log:
            self.log.unlink(missing_ok=True)


@dataclass
class JointReport:
    """How one joint fared in a cycle, as the operator saw it: its newest estimate (the ``WearEstimate``
    fields; empty: none), the ``wear_estimator: <joint>`` diagnostic status heard after it, the joint's
    final cycle state and its cell time (sim s, from its first status of the cycle to its first final one).
    ``true_wear``: the simulated joint's wear, when the cell is a simulation (NaN: unknown)."""

    joint: str
    estimate: dict[str, Any] = field(default_factory=dict)
    diagnostic_level: str = "UNKNOWN"
    diagnostic_message: str = ""
    final_state: str = "?"
    cell_seconds: float = math.nan
    true_wear: float = math.nan

    def wear_dict(self) -> dict[str, Any]:
        e = self.estimate
        return {"estimate": e.get("wear"), "std": e.get("wear_std"), "method": e.get("method"),
                "low": e.get("wear_low"), "high": e.get("wear_high"), "temperature": e.get("temperature_estimate")}


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


def start_child(name: str, params: Mapping[str, Any], env: Mapping[str, str], logdir: Path | None = None, *,
                log: Path | None = None, params_files: Sequence[Path] = (), args: Sequence[str] = (),
                config: bool = True, as_module: bool = False,
                preexec_fn: Callable[[], None] | None = die_with_parent) -> Child:
    """Start node ``name``: its config file (unless ``config=False``), then ``params_files``, then ``params`` as
    ``-p`` overrides, then ``args``.

    Its output goes to ``log``, else ``logdir/<name>.log``, else a temporary file (:meth:`Child.close`
    removes it). ``as_module``: run ``python -m jointwear_ros.nodes.<name>`` with this interpreter (the
    package on ``sys.path``, as a test of a checkout wants) instead of the console script.
    """
    cmd = [sys.executable, "-m", f"jointwear_ros.nodes.{name}"] if as_module else [_executable(name)]
    cmd.append("--ros-args")
    cfg = config_path(f"{name}.yaml")
    if config and cfg.is_file():
        cmd += ["--params-file", str(cfg)]
    for f in params_files:
        cmd += ["--params-file", str(f)]
    cmd += _param_args(params) + list(args)
    own = log is None and logdir is None
    if log is None:
        if logdir is None:
            fd, tmp = tempfile.mkstemp(prefix=f"{name}-", suffix=".log")
            os.close(fd)
            log = Path(tmp)
        else:
            log = logdir / f"{name}.log"
    fh = log.open("wb")
    fh.write(("$ " + " ".join(cmd) + "\n").encode())
    fh.flush()
    proc = subprocess.Popen(cmd, env=dict(env), stdout=fh, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                            preexec_fn=preexec_fn)
    return Child(name, proc, log, fh, own)


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


def _accepted(answer: Any) -> bool:
    return bool(answer.accepted)


def _reason(answer: Any) -> Any:
    return answer.reason


def _say_nothing(answer: Any) -> None:
    """The default ``progress`` of :func:`run_until_accepted`."""


def run_until_accepted(send: Callable[[], _Answer], wait: Callable[[float], None], retry_for: float, *,
                       pause: float = 1.0, accepted: Callable[[_Answer], bool] = _accepted,
                       reason: Callable[[_Answer], Any] = _reason,
                       progress: Callable[[_Answer], None] = _say_nothing) -> _Answer:
    """Ask for a test cycle as an operator would: ``send()`` calls ``/test_cycle/run`` and returns the answer
    (a ``RunTestCycle.Response`` by default); a refusal whose :class:`~jointwear_ros.contract.RefusalReason`
    is ``retryable`` (the joint state not there yet or late, a cycle still running) is sent again after
    ``wait(pause)`` (``progress(answer)`` first) for ``retry_for`` seconds. The last answer, accepted or not.
    The cell's :class:`Operator` and the tests' operators ask this way."""
    end = time.monotonic() + retry_for
    while True:
        answer = send()
        if accepted(answer) or not RefusalReason(reason(answer)).retryable or time.monotonic() > end:
            return answer
        progress(answer)
        wait(pause)


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
        self._diag_names = {f"wear_estimator: {j}": j for j in self.joints}
        #: the newest ``friction_observer: <joint>`` status of each joint (its per-cycle counts)
        self.observer_status: dict[str, Any] = {}
        self._observer_names = {f"friction_observer: {j}": j for j in self.joints}
        #: the nodes heard on /diagnostics with a stamp after 0: their clock runs (a sim-time node has /clock)
        self.clocked: set[str] = set()
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.observations: list[Any] = []
        self.estimates: list[Any] = []
        #: (arrival number, message): the order this operator heard estimates and statuses in
        self.diagnostics: list[tuple[int, Any]] = []
        self.estimate_arrivals: list[int] = []
        self._heard = 0
        #: the newest cycle status heard (None before the first)
        self.status: CycleStatus | None = None
        #: every cycle status heard, in order (a robot cycle's progress, joint by joint)
        self.statuses: list[CycleStatus] = []
        # the same by cycle id, the cycles over and each cycle's joints started, kept as they come: the waits
        # ask these at every spin (20 Hz), and scanning every status heard (thousands a cycle) each time took a
        # third of a six-joint demo's operator CPU
        self._cycle_statuses: dict[int, list[CycleStatus]] = {}
        self._cycles_over: set[int] = set()
        self._started: dict[int, list[str]] = {}
        self.node.create_subscription(FrictionObservation, "/jointwear/friction_observations",
                                      self.observations.append, qos)
        self.node.create_subscription(WearEstimate, "/jointwear/wear_estimate", self._on_estimate, qos)
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diag, qos)
        self.node.create_subscription(TestCycleStatus, "/test_cycle/status", self._on_status, qos)
        self.client = self.node.create_client(RunTestCycle, "/test_cycle/run")
        self._param_clients: dict[str, Any] = {}
        self._jog_pub: Any = None
        #: the newest joint positions heard (joint side, rad), while jogging
        self.positions: dict[str, float] = {}
        self.Request = RunTestCycle.Request

    def _on_estimate(self, msg: Any) -> None:
        self._heard += 1
        self.estimates.append(msg)
        self.estimate_arrivals.append(self._heard)

    def _on_diag(self, msg: Any) -> None:
        self._heard += 1
        stamped = msg.header.stamp.sec > 0 or msg.header.stamp.nanosec > 0
        for st in msg.status:
            if stamped:
                self.clocked.add(str(st.name).split(":", 1)[0])
            if st.name in self._diag_names:
                self.diagnostics.append((self._heard, st))
            elif st.name in self._observer_names:
                self.observer_status[self._observer_names[st.name]] = st

    def _on_status(self, msg: Any) -> None:
        st = status_from_msg(msg)
        self.status = st
        self.statuses.append(st)
        self._cycle_statuses.setdefault(st.cycle_id, []).append(st)
        if st.robot_cycle_over:
            self._cycles_over.add(st.cycle_id)
        started = self._started.setdefault(st.cycle_id, [])
        if st.state != CycleState.IDLE and st.joint_name not in started:
            started.append(st.joint_name)

    def robot_cycle_over(self, cycle_id: int) -> bool:
        """True once the robot cycle ``cycle_id`` has ended: its last joint DONE, or any joint ABORTED or
        FAILED (the cycle stops there), per the status contract of ``docs/robot.md``."""
        return cycle_id in self._cycles_over

    def observer_done(self, cycle_id: int, joint: str) -> bool:
        """The observer has finished every speed ``joint`` ran in cycle ``cycle_id`` (an observation or a
        rejected window each, per its ``friction_observer: <joint>`` status) and this operator has
        heard each of those observations. A joint whose test ended early counts the speeds it began."""
        mine = [st for st in self._cycle_statuses.get(cycle_id, ()) if st.in_cycle(cycle_id, joint)]
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
        return list(self._started.get(cycle_id, ()))

    # -- the cycle's results ---------------------------------------------------------------
    def estimates_of(self, cycle_id: int, joint: str) -> list[Any]:
        """The ``WearEstimate`` messages of ``joint`` in cycle ``cycle_id``, in arrival order."""
        return [e for e in self.estimates if e.cycle_id == cycle_id and e.joint_name == joint]

    def diagnostics_of(self, cycle_id: int, joint: str, after: int = 0) -> list[Any]:
        """The ``wear_estimator: <joint>`` statuses of cycle ``cycle_id`` (their ``cycle_id`` key) heard after
        arrival number ``after``."""
        name = f"wear_estimator: {joint}"
        return [d for n, d in self.diagnostics
                if n > after and d.name == name
                and ("cycle_id", str(cycle_id)) in {(kv.key, kv.value) for kv in d.values}]

    def joint_estimated(self, cycle_id: int, joint: str) -> bool:
        """``joint`` has an estimate in cycle ``cycle_id``, or the estimator's verdict that there is none (a status
        of that cycle without a "wear" key)."""
        return bool(self.estimates_of(cycle_id, joint)) or any(
            "wear" not in {kv.key for kv in d.values} for d in self.diagnostics_of(cycle_id, joint))

    def estimated(self, cycle_id: int) -> bool:
        """One joint: it is estimated (:meth:`joint_estimated`). A robot cycle: it has ended and every joint it
        started is estimated."""
        if len(self.joints) == 1:
            return self.joint_estimated(cycle_id, self.joints[0])
        return self.robot_cycle_over(cycle_id) and all(
            self.joint_estimated(cycle_id, j) for j in self.joints_started(cycle_id))

    def complete(self, cycle_id: int) -> bool:
        """Every observation of cycle ``cycle_id`` is in its joint's newest estimate.

        The estimator estimates a joint when all its speeds are in, or done_timeout after DONE (a rejected
        window sends nothing): on a loaded machine the observer can be later than that, and the estimator
        then revises the estimate with the late observation. So this waits until the observer has finished
        every speed of each joint (:meth:`observer_done`) and the newest estimate covers every observation.
        """
        for j in self.joints_started(cycle_id):
            if not self.observer_done(cycle_id, j):
                return False
            seen = {round(o.speed, 9) for o in self.observations if o.cycle_id == cycle_id and o.joint_name == j}
            ests = self.estimates_of(cycle_id, j)
            if ests and not seen <= {round(v, 9) for v in ests[-1].speeds}:
                return False
        return True

    def joint_report(self, cycle_id: int, joint: str, children: Sequence[Child], wait: float = 15.0) -> JointReport:
        """The newest estimate of ``joint`` in cycle ``cycle_id`` and the diagnostic status heard after it (waiting
        up to ``wait`` s for that status; UNKNOWN with the reason when none comes), its final state and cell time."""
        from ..io.bags import ESTIMATE_FIELDS, message_fields

        ests = self.estimates_of(cycle_id, joint)
        est = ests[-1] if ests else None
        # the estimator publishes an estimate, then its status (and republishes the status every
        # diagnostics_period): the status of the newest estimate is one heard after it
        heard_est = 0
        if est is not None:
            i_est = max(i for i, e in enumerate(self.estimates) if e is est)
            heard_est = self.estimate_arrivals[i_est]
        try:
            self.spin_until(lambda: bool(self.diagnostics_of(cycle_id, joint, heard_est)), wait, children,
                            f"the /diagnostics status of {joint} in cycle {cycle_id}")
            diag = self.diagnostics_of(cycle_id, joint, heard_est)[-1]
            raw = diag.level
            level = DiagnosticLevel.name_of(raw[0] if isinstance(raw, bytes) else int(raw))
            dmsg = str(diag.message)
        except CellError as exc:
            level, dmsg = "UNKNOWN", str(exc)
        report = JointReport(joint, message_fields(est, ESTIMATE_FIELDS) if est is not None else {}, level, dmsg)
        # cell time: from the joint's first status of the cycle to its first final one (the node
        # republishes the final status while idle: later copies are not cell time)
        js = [st for st in self._cycle_statuses.get(cycle_id, ()) if st.in_cycle(cycle_id, joint)]
        end = self.joint_end(cycle_id, joint)
        if js:
            last = end if end is not None else js[-1]
            report.final_state = last.state_name
            report.cell_seconds = last.stamp - js[0].stamp if end is not None else math.nan
        else:
            report.final_state = "NOT_TESTED"
        return report

    def joint_end(self, cycle_id: int, joint: str) -> CycleStatus | None:
        """The first final (DONE, ABORTED, FAILED) status of ``joint`` in cycle ``cycle_id``, if any."""
        return next((st for st in self._cycle_statuses.get(cycle_id, ()) if st.in_cycle(cycle_id, joint) and st.ended), None)

    def cell_seconds(self, cycle_id: int) -> float:
        """Cell time of the robot cycle (sim s): from its first status to its joints' last first-final one; NaN
        while it has not ended."""
        mine = self._cycle_statuses.get(cycle_id, [])
        ends = [e for e in (self.joint_end(cycle_id, j) for j in self.joints) if e is not None]
        if mine and ends and self.robot_cycle_over(cycle_id):
            return max(e.stamp for e in ends) - mine[0].stamp
        return math.nan

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
        """Call ``/test_cycle/run`` as an operator would (:func:`run_until_accepted`: a retryable refusal is
        re-sent every second for ``retry_for`` seconds); any other refusal raises :class:`CellError` with the
        reason. Returns (cycle id, plan)."""

        def send() -> tuple[bool, int, RefusalReason, str]:
            return self.call_run(speeds, children, timeout)

        def wait(seconds: float) -> None:
            self.spin_until(after(time.monotonic() + seconds), seconds + 4.0, children, "a retry")

        def retrying(answer: tuple[bool, int, RefusalReason, str]) -> None:
            self.progress(f"/test_cycle/run refused ({answer[2].name}: {answer[3]}); retrying in 1 s")

        accepted, cycle_id, reason, message = run_until_accepted(
            send, wait, retry_for, accepted=lambda a: a[0], reason=lambda a: a[2], progress=retrying)
        if not accepted:
            raise CellError(f"/test_cycle/run refused the request ({reason.name}): {message}")
        return cycle_id, message

    def set_parameters(self, node: str, values: Mapping[str, Any], children: Sequence[Child],
                       timeout: float = 15.0) -> None:
        """Set parameters of a running node as ``ros2 param set`` would (its ``~/set_parameters`` service), e.g.
        ``set_parameters("joint_sim", {"joint_3.temperature": 35.0})``: a live change of the simulation between
        cycles. Raises :class:`CellError` with the node's reason for a value it refused."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        if not values:
            return
        client = self._param_clients.get(node)
        if client is None:
            client = self.node.create_client(SetParameters, f"/{node}/set_parameters")
            self._param_clients[node] = client
        self.spin_until(client.service_is_ready, timeout, children, f"/{node}/set_parameters")
        names = list(values)
        req = SetParameters.Request(parameters=[Parameter(n, value=values[n]).to_parameter_msg() for n in names])
        fut = client.call_async(req)
        self.spin_until(fut.done, timeout, children, f"the answer of /{node}/set_parameters")
        refused = [f"{n}: {r.reason}" for n, r in zip(names, fut.result().results) if not r.successful]
        if refused:
            raise CellError(f"{node} refused parameter(s) {'; '.join(refused)}")

    def jog_to(self, targets: Mapping[str, float], children: Sequence[Child], speed: float = 0.3,
               tolerance: float = 0.03, timeout: float = 60.0,
               command_topic: str = "/velocity_controller/commands") -> None:
        """Move joints to ``targets`` (joint side, rad) with velocity commands, as an operator jogs a joint back
        after a cycle stopped it near or beyond a limit (test_cycle refuses to start a joint outside its
        limits). Only while no cycle runs: test_cycle commands the joints then. The command array carries one
        velocity per joint of this operator, in its order (the order of joint_sim's ``joints``); each joint
        moves at most ``speed`` rad/s, slowing near its target, until every joint is within ``tolerance``."""
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray

        if self._jog_pub is None:
            self._jog_pub = self.node.create_publisher(Float64MultiArray, command_topic, 10)
        pub = self._jog_pub
        self.positions.clear()
        # the joint states only while jogging: kept after it, this process took every state of the cycles that
        # followed on rclpy's Python executor (1.5 kHz in a six-joint demo at 3x, about 0.4 ms each)
        sub = self.node.create_subscription(JointState, "/joint_states", self._on_joint_state, 10)
        try:
            self._jog(targets, children, pub, speed, tolerance, timeout)
        finally:
            self.node.destroy_subscription(sub)

    def _jog(self, targets: Mapping[str, float], children: Sequence[Child], pub: Any, speed: float,
             tolerance: float, timeout: float) -> None:
        from std_msgs.msg import Float64MultiArray

        self.spin_until(lambda: all(j in self.positions for j in targets), 15.0, children, "/joint_states")

        def command() -> list[float]:
            out = []
            for j in self.joints:
                err = targets[j] - self.positions[j] if j in targets and j in self.positions else 0.0
                out.append(0.0 if abs(err) < tolerance else max(-speed, min(speed, 2.0 * err)))
            return out

        def arrived() -> bool:
            cmd = command()
            pub.publish(Float64MultiArray(data=cmd))
            return not any(cmd)

        end = time.monotonic() + timeout
        while not arrived():
            if time.monotonic() > end:
                raise CellError(f"timed out after {timeout:.0f} s jogging {', '.join(targets)} to "
                                f"{', '.join(f'{v:g}' for v in targets.values())} rad")
            self.spin_until(after(time.monotonic() + 0.02), 5.0, children, "a jog step")
        pub.publish(Float64MultiArray(data=[0.0] * len(self.joints)))

    def _on_joint_state(self, msg: Any) -> None:
        for name, pos in zip(msg.name, msg.position):
            self.positions[str(name)] = float(pos)

    def close(self) -> None:
        try:
            self.ex.shutdown()
            self.node.destroy_node()
        finally:
            self.rclpy.try_shutdown(context=self.ctx)


#: the cell's nodes on sim time: each must have heard /clock before a cycle starts (a node without it stamps
#: and times its messages at 0; an observer without it lost a cycle's first window)
SIM_TIME_NODES = ("recorder", "test_cycle", "friction_observer", "wear_estimator")


def ready_conditions(op: Operator, clocked: Sequence[str] = SIM_TIME_NODES) -> Callable[[], list[str]]:
    """What the cell still lacks before a cycle can start (empty: ready): each topic's subscribers and the
    ``/test_cycle/run`` service on the graph, and each node of ``clocked`` heard on /diagnostics with a stamp
    after 0 (its clock runs: a sim-time node has /clock; the graph shows a subscription, not that it
    matched)."""
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
        lack_clock = [n for n in clocked if n not in op.clocked]
        if lack_clock:
            out.append(f"/clock -> {', '.join(lack_clock)} (no /diagnostics stamped on it yet)")
        return out

    return missing
