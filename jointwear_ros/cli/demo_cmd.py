"""``jointwear demo``: the simulated cell end to end, as an operator would run it.

Starts ``recorder``, ``joint_sim``, ``test_cycle``, ``friction_observer`` and
``wear_estimator`` as child processes (their console scripts with
``--ros-args --params-file config/<node>.yaml -p ...``, DDS on loopback on
one domain), waits until the graph is connected, calls ``/test_cycle/run``,
follows the cycle on ``/test_cycle/status``, waits for the
``WearEstimate`` of that cycle and its ``/diagnostics`` status, stops the
children (SIGINT, then SIGTERM, then SIGKILL after timeouts; also on Ctrl-C
and on errors) and prints a summary: the observations, the estimate against
the true wear, the diagnostic level and the bag the recorder wrote. Child
logs go to ``OUT/logs``. Progress goes to stderr.

Sim time: ``joint_sim`` publishes ``/clock`` running ``--real-time-factor``
times faster than wall time and every node runs with ``use_sim_time``.
"""

from __future__ import annotations

import argparse
import math
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import yaml

from ..contract import CycleState, DiagnosticLevel, RefusalReason
from ..errors import JointwearError
from ..resources import config_path
from . import UsageError
from .common import check_method, check_output_dir, format_table, parse_float, parse_float_list, print_json

__all__ = ["DEMO_NODES", "DemoError", "register", "run_demo"]

#: Child nodes in start order (the recorder first, so it sees everything).
DEMO_NODES = ("recorder", "joint_sim", "test_cycle", "friction_observer", "wear_estimator")


class DemoError(JointwearError):
    """The demo could not complete (a node died, a timeout, a refused request)."""


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "demo",
        help="run the simulated cell: all nodes, one test cycle by service call, the wear estimate",
        description="Start joint_sim, test_cycle, friction_observer, wear_estimator and recorder as child "
                    "processes, trigger a test cycle through /test_cycle/run as an operator would, wait for "
                    "the wear estimate and print a summary (observations, estimate vs the true wear, "
                    "diagnostic level, bag path).",
    )
    p.add_argument("--wear", default="20", help="true wear of the simulated joint, 0-100 (default 20)")
    p.add_argument("--speeds", default=None,
                   help="cycle speeds, motor rad/s, comma list or START:STOP:COUNT (default: test_cycle's, 8 speeds)")
    p.add_argument("--out", default="out/demo", help="output directory: bags/ and logs/ (default out/demo)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--real-time-factor", default="2.0", help="sim seconds per wall second (default 2)")
    p.add_argument("--temperature", default=None, help="joint temperature of the simulator, degC (default: config)")
    p.add_argument("--method", default=None, help="wear estimator method (default: config/wear_estimator.yaml)")
    p.add_argument("--timeout", default="180", help="wall seconds to wait for the estimate (default 180)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                   help="override a node parameter, e.g. joint_sim.temperature=30 (repeatable)")
    p.add_argument("--domain-id", type=int, default=None,
                   help="ROS_DOMAIN_ID of the cell (default: $ROS_DOMAIN_ID, else a random free-ish one)")
    p.set_defaults(func=cmd_demo)


def _progress(text: str) -> None:
    print(f"[demo] {text}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- children


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
        raise DemoError(f"console script {name!r} not found next to {sys.executable} or on PATH; "
                        "install the package (make env / pip install -e .)")
    return found


def _param_args(params: dict[str, Any]) -> list[str]:
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


def start_child(name: str, params: dict[str, Any], env: dict[str, str], logdir: Path) -> Child:
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
    proc = subprocess.Popen(cmd, env=env, stdout=fh, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    return Child(name, proc, log, fh)


def stop_children(children: Sequence[Child], sigint_timeout: float = 15.0, sigterm_timeout: float = 5.0) -> None:
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
                    _progress(f"{c.name} did not stop on {signal.Signals(sig).name}")
    for c in children:
        try:
            c.proc.wait(timeout=1.0)
        except subprocess.TimeoutExpired:
            pass
        c.fh.close()


# --------------------------------------------------------------------------- the operator


@dataclass
class DemoResult:
    """What the operator saw: cycle id, observations, estimate, diagnostic level, bag."""

    cycle_id: int
    observations: list[dict[str, Any]]
    estimate: dict[str, Any]
    diagnostic_level: str
    diagnostic_message: str
    final_state: str
    true_wear: float
    bag: str | None = None
    wall_seconds: float = 0.0
    logs: str = ""
    rejections: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {
            "bag": self.bag,
            "cycle_id": self.cycle_id,
            "observations": self.observations,
            "wear": {"estimate": self.estimate.get("wear"), "std": self.estimate.get("wear_std"),
                     "method": self.estimate.get("method"), "low": self.estimate.get("wear_low"),
                     "high": self.estimate.get("wear_high"),
                     "temperature": self.estimate.get("temperature_estimate")},
            "true_wear": self.true_wear,
            "diagnostic_level": self.diagnostic_level,
            "diagnostic_message": self.diagnostic_message,
            "cycle_state": self.final_state,
            "wall_seconds": self.wall_seconds,
            "logs": self.logs,
        }


class _Operator:
    """An in-process rclpy node that does what an operator does: wait, call the service, watch."""

    def __init__(self, joint_name: str) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from jointwear_msgs.msg import FrictionObservation, TestCycleStatus, WearEstimate
        from jointwear_msgs.srv import RunTestCycle
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from rclpy.signals import SignalHandlerOptions

        self.rclpy = rclpy
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node("jointwear_demo_operator", context=self.ctx)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.ex.add_node(self.node)
        self.joint_name = joint_name
        qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        self.observations: list[Any] = []
        self.estimates: list[Any] = []
        #: (arrival number, message): the order this operator heard estimates and statuses in
        self.diagnostics: list[tuple[int, Any]] = []
        self.estimate_arrivals: list[int] = []
        self._heard = 0
        self.status: Any = None
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
            if st.name == f"wear_estimator: {self.joint_name}":
                self.diagnostics.append((self._heard, st))

    def _on_status(self, msg: Any) -> None:
        self.status = msg

    def spin_until(self, predicate: Callable[[], bool], timeout: float, children: Sequence[Child],
                   what: str, tick: Callable[[], None] | None = None) -> None:
        end = time.monotonic() + timeout
        while not predicate():
            for c in children:
                if not c.alive():
                    raise DemoError(f"{c.name} exited with code {c.proc.returncode} while waiting for {what}; "
                                    f"log {c.log}: {c.log_tail(4)}")
            if time.monotonic() > end:
                raise DemoError(f"timed out after {timeout:.0f} s waiting for {what}; logs in {children[0].log.parent}")
            self.ex.spin_once(timeout_sec=0.05)
            if tick is not None:
                tick()

    def subscribers(self, topic: str) -> set[str]:
        return {i.node_name for i in self.node.get_subscriptions_info_by_topic(topic)}

    def call_run(self, speeds: Sequence[float], children: Sequence[Child], timeout: float
                 ) -> tuple[bool, int, RefusalReason, str]:
        self._warm_up(speeds, children, timeout)
        req = self.Request(joint_name=self.joint_name, speeds=[float(s) for s in speeds], position=0.0, dry_run=False)
        fut = self.client.call_async(req)
        self.spin_until(fut.done, timeout, children, "the answer of /test_cycle/run")
        resp = fut.result()
        return bool(resp.accepted), int(resp.cycle_id), RefusalReason(resp.reason), str(resp.message)

    def _warm_up(self, speeds: Sequence[float], children: Sequence[Child], timeout: float) -> None:
        """A dry run, re-sent every 3 s until answered: right after discovery a service's first
        response can be lost (the client's response reader not yet matched), and a dry run is
        safe to repeat where the real request is not."""
        req = self.Request(joint_name=self.joint_name, speeds=[float(s) for s in speeds], position=0.0, dry_run=True)
        end = time.monotonic() + timeout
        while True:
            fut = self.client.call_async(req)
            try:
                self.spin_until(fut.done, 3.0, children, "the answer of /test_cycle/run (dry run)")
                return
            except DemoError as exc:
                if "timed out" not in str(exc) or time.monotonic() > end:
                    raise  # a node died, or no answer at all
                _progress("no answer from /test_cycle/run yet; asking again")

    def close(self) -> None:
        try:
            self.ex.shutdown()
            self.node.destroy_node()
        finally:
            self.rclpy.try_shutdown(context=self.ctx)


def _ready_conditions(op: _Operator) -> Callable[[], list[str]]:
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


def _msg_dict(msg: Any, names: Sequence[str]) -> dict[str, Any]:
    from ..io.bags import message_fields

    return message_fields(msg, names)


def _config_value(node: str, name: str, default: Any) -> Any:
    """Parameter ``name`` of ``config/<node>.yaml`` (``default`` if it cannot be read)."""
    try:
        values = yaml.safe_load(config_path(f"{node}.yaml").read_text())
        return values[node]["ros__parameters"][name]
    except Exception:
        return default


def _config_done_timeout() -> float:
    """done_timeout of config/wear_estimator.yaml (2 s if it cannot be read)."""
    try:
        return float(_config_value("wear_estimator", "done_timeout", 2.0))
    except (TypeError, ValueError):
        return 2.0


def _after(deadline: float) -> Callable[[], bool]:
    """A predicate that turns true at ``deadline`` (time.monotonic)."""
    return lambda: time.monotonic() > deadline


def run_demo(
    wear: float,
    speeds: Sequence[float] | None,
    out: Path,
    real_time_factor: float = 2.0,
    temperature: float | None = None,
    method: str | None = None,
    timeout: float = 180.0,
    domain_id: int | None = None,
    overrides: dict[str, dict[str, Any]] | None = None,
) -> DemoResult:
    """Run the simulated cell for one test cycle; see the module docstring."""
    from ..io.bags import ESTIMATE_FIELDS, OBSERVATION_FIELDS, find_bags
    from ..nodes.runtime import loopback_env

    t_start = time.monotonic()
    if domain_id is None:
        env_id = os.environ.get("ROS_DOMAIN_ID", "")
        domain_id = int(env_id) if env_id.isdigit() else random.Random(os.getpid() ^ int(time.time())).randint(10, 99)
    env = loopback_env(domain_id)
    os.environ.update({"ROS_DOMAIN_ID": env["ROS_DOMAIN_ID"],
                       "ROS_AUTOMATIC_DISCOVERY_RANGE": env["ROS_AUTOMATIC_DISCOVERY_RANGE"]})
    logdir = out / "logs"
    bagdir = out / "bags"
    logdir.mkdir(parents=True, exist_ok=True)
    bagdir.mkdir(parents=True, exist_ok=True)
    bags_before = set(find_bags(bagdir))
    sim_params: dict[str, Any] = {"use_sim_time": False, "publish_clock": True,
                                  "real_time_factor": float(real_time_factor), "wear": float(wear)}
    if temperature is not None:
        sim_params["temperature"] = float(temperature)
    params: dict[str, dict[str, Any]] = {
        "recorder": {"use_sim_time": True, "output_dir": str(bagdir.resolve()), "split": "session"},
        "joint_sim": sim_params,
        "test_cycle": {"use_sim_time": True, "simulator": True},
        "friction_observer": {"use_sim_time": True},
        # The last speed's observation comes just after DONE; done_timeout runs in sim time,
        # so scale it to keep the config's grace in wall seconds on a loaded machine.
        "wear_estimator": {"use_sim_time": True, "done_timeout": _config_done_timeout() * float(real_time_factor),
                           **({"method": method} if method else {})},
    }
    for node, values in (overrides or {}).items():
        params[node].update(values)
    # the joint the cell drives: the test cycle's (its config, or a --set override)
    joint = str(params["test_cycle"].get("joint_name") or _config_value("test_cycle", "joint_name", "joint_1"))
    children: list[Child] = []
    op: _Operator | None = None
    try:
        _progress(f"ROS_DOMAIN_ID={domain_id}, loopback only; logs in {logdir}")
        for name in DEMO_NODES:
            children.append(start_child(name, params[name], env, logdir))
            _progress(f"started {name} (pid {children[-1].proc.pid})")
        op = _Operator(joint)
        missing = _ready_conditions(op)
        op.spin_until(lambda: not missing(), 60.0, children, "the nodes to connect")
        _progress(f"graph connected after {time.monotonic() - t_start:.1f} s; calling /test_cycle/run")
        # As an operator would: a refusal because the joint state is not there yet or late
        # (nodes still starting on a loaded machine) is retried for a while; any other is final.
        retry_end = time.monotonic() + 20.0
        while True:
            accepted, cycle_id, reason, message = op.call_run(speeds or [], children, 30.0)
            if accepted or not reason.retryable or time.monotonic() > retry_end:
                break
            _progress(f"/test_cycle/run refused ({reason.name}: {message}); retrying in 1 s")
            op.spin_until(_after(time.monotonic() + 1.0), 5.0, children, "a retry")
        if not accepted:
            raise DemoError(f"/test_cycle/run refused the request ({reason.name}): {message}")
        _progress(f"cycle {cycle_id} accepted: {message}")
        shown: list[tuple[int, int] | None] = [None]

        def tick() -> None:
            st = op.status if op is not None else None
            if st is None or st.cycle_id != cycle_id:
                return
            key = (st.state, st.speeds_done)
            if key != shown[0]:
                shown[0] = key
                state = CycleState.name_of(st.state)
                extra = f": {st.message}" if st.state in (CycleState.ABORTED, CycleState.FAILED) and st.message else ""
                _progress(f"cycle {cycle_id} {state}, speeds done {st.speeds_done}/{st.speeds_total}{extra}")

        def have_estimate() -> bool:
            return any(e.cycle_id == cycle_id for e in op.estimates)  # type: ignore[union-attr]

        def diags_of_cycle(after: int = 0) -> list[Any]:
            """The operator's ``wear_estimator: <joint>`` statuses of this cycle (its ``cycle_id`` key) heard
            after arrival number ``after``."""
            return [d for n, d in op.diagnostics  # type: ignore[union-attr]
                    if n > after and ("cycle_id", str(cycle_id)) in {(kv.key, kv.value) for kv in d.values}]

        def finished() -> bool:
            # an estimate, or the estimator's verdict that there is none (no "wear" key)
            return have_estimate() or any("wear" not in {kv.key for kv in d.values} for d in diags_of_cycle())

        op.spin_until(finished, timeout, children, f"the WearEstimate of cycle {cycle_id}", tick)

        def complete() -> bool:
            # the estimator revises a cycle's estimate when an observation comes late: wait
            # briefly until the newest estimate covers every observation the operator saw
            seen = {round(o.speed, 9) for o in op.observations if o.cycle_id == cycle_id}  # type: ignore[union-attr]
            ests = [e for e in op.estimates if e.cycle_id == cycle_id]  # type: ignore[union-attr]
            return not ests or seen <= {round(v, 9) for v in ests[-1].speeds}

        try:
            op.spin_until(complete, 5.0, children, f"a revised WearEstimate of cycle {cycle_id}")
        except DemoError as exc:
            _progress(f"{exc}; reporting the newest estimate")
        i_est = next((i for i in reversed(range(len(op.estimates))) if op.estimates[i].cycle_id == cycle_id), None)
        est = None if i_est is None else op.estimates[i_est]
        # the estimator publishes an estimate, then its status (and republishes the status every
        # diagnostics_period): the status of the newest estimate is one heard after it
        heard_est = 0 if i_est is None else op.estimate_arrivals[i_est]
        try:
            def matching() -> list[Any]:
                return diags_of_cycle(heard_est)

            op.spin_until(lambda: bool(matching()), 15.0, children,
                          f"the /diagnostics status of cycle {cycle_id}")
            diag = matching()[-1]
            raw = diag.level
            level = DiagnosticLevel.name_of(raw[0] if isinstance(raw, bytes) else int(raw))
            dmsg = str(diag.message)
        except DemoError as exc:
            level, dmsg = "UNKNOWN", str(exc)
        observations = [_msg_dict(o, OBSERVATION_FIELDS) for o in op.observations if o.cycle_id == cycle_id]
        observations.sort(key=lambda o: o["speed"])
        final = op.status
        final_state = CycleState.name_of(final.state) if final is not None and final.cycle_id == cycle_id else "?"
        estimate = _msg_dict(est, ESTIMATE_FIELDS) if est is not None else {}
        time.sleep(0.5)  # the recorder gets the estimate and diagnostics too
    finally:
        if op is not None:
            op.close()
        if children:
            _progress("stopping the nodes")
            # the producers first (each waits until the recorder acknowledged its last messages),
            # then the recorder, the clock source (joint_sim) last: sim-time nodes need /clock
            stop_children([c for c in children if c.name not in ("joint_sim", "recorder")])
            stop_children([c for c in children if c.name == "recorder"])
            stop_children([c for c in children if c.name == "joint_sim"])
    bags = [b for b in find_bags(bagdir) if b not in bags_before]
    bag = str(bags[-1]) if bags else None
    if bag is None:
        _progress(f"the recorder wrote no bag; see {logdir / 'recorder.log'}")
    return DemoResult(
        cycle_id=cycle_id, observations=observations, estimate=estimate, diagnostic_level=level,
        diagnostic_message=dmsg, final_state=final_state, true_wear=float(wear), bag=bag,
        wall_seconds=time.monotonic() - t_start, logs=str(logdir),
    )


def _param_value(text: str) -> Any:
    """A parameter value as ROS would read it from ``-p``: bool, int, float, else string."""
    low = text.strip().lower()
    if low in ("true", "false"):
        return low == "true"
    for conv in (int, float):
        try:
            return conv(text)
        except ValueError:
            pass
    return text


def parse_overrides(items: Sequence[str]) -> dict[str, dict[str, Any]]:
    """``["joint_sim.temperature=30"]`` -> ``{"joint_sim": {"temperature": 30}}`` (nodes checked)."""
    out: dict[str, dict[str, Any]] = {}
    for item in items:
        key, sep, value = item.partition("=")
        node, dot, name = key.strip().partition(".")
        if not sep or not dot or not name:
            raise UsageError(f"--set {item!r}: expected NODE.PARAM=VALUE, e.g. joint_sim.temperature=30")
        if node not in DEMO_NODES:
            raise UsageError(f"--set {item!r}: unknown node {node!r}; nodes: {', '.join(DEMO_NODES)}")
        out.setdefault(node, {})[name] = _param_value(value)
    return out


def _node_parameters(node: str) -> dict[str, Any]:
    """Parameter name -> declaration (or None) a demo node takes: its config file and its declarations."""
    known: dict[str, Any] = {"use_sim_time": None}
    try:
        values = yaml.safe_load(config_path(f"{node}.yaml").read_text())
        known.update(dict.fromkeys(values[node]["ros__parameters"]))
    except Exception:  # no config file: the declarations alone
        pass
    try:
        import importlib

        decls = importlib.import_module(f"jointwear_ros.nodes.{node}").PARAMETERS
        known.update({d.name: d for d in decls})
    except (ImportError, AttributeError):
        pass
    return known


def check_overrides(overrides: dict[str, dict[str, Any]]) -> None:
    """Every ``--set NODE.PARAM=VALUE`` names a parameter the node takes, within its declared range."""
    for node, values in overrides.items():
        known = _node_parameters(node)
        for name, value in values.items():
            if name not in known:
                raise UsageError(f"--set {node}.{name}: {node} has no parameter {name!r}; "
                                 f"it has {', '.join(sorted(known))}")
            decl = known[name]
            if decl is not None and isinstance(value, (int, float)) and not isinstance(value, bool):
                if not math.isfinite(float(value)):
                    raise UsageError(f"--set {node}.{name}={value}: not a finite number")
                if (decl.min is not None and value < decl.min) or (decl.max is not None and value > decl.max):
                    raise UsageError(f"--set {node}.{name}={value}: outside the declared range "
                                     f"[{decl.min}, {decl.max}]")
        if node == "wear_estimator" and "method" in values:
            check_method(str(values["method"]), "--set wear_estimator.method")


def _sim_parameter_set(overrides: dict[str, dict[str, Any]]) -> str:
    """The parameter set joint_sim will simulate with (its config, or --set joint_sim.params)."""
    if "params" in overrides.get("joint_sim", {}):
        return str(overrides["joint_sim"]["params"])
    try:
        values = yaml.safe_load(config_path("joint_sim.yaml").read_text())
        return str(values["joint_sim"]["ros__parameters"]["params"])
    except Exception:
        return "ref-2011r"


def cmd_demo(args: argparse.Namespace) -> int:
    from ..model import load_parameter_set_info

    wear = parse_float(args.wear, "--wear")
    if not 0.0 <= wear <= 100.0:
        raise UsageError(f"--wear: {wear:g} is outside 0-100")
    speeds = parse_float_list(args.speeds, "--speeds") if args.speeds is not None else None
    if speeds is not None and any(not s > 0 for s in speeds):
        raise UsageError(f"--speeds: every speed must be > 0 rad/s (got {args.speeds})")
    rtf = parse_float(args.real_time_factor, "--real-time-factor")
    if not 0.01 <= rtf <= 100.0:
        raise UsageError(f"--real-time-factor: {rtf:g} is outside 0.01-100")
    timeout = parse_float(args.timeout, "--timeout")
    if not 0 < timeout <= 86400:
        raise UsageError(f"--timeout: {timeout:g} must be more than 0 and at most 86400 s")
    temperature = parse_float(args.temperature, "--temperature") if args.temperature is not None else None
    if args.domain_id is not None and not 0 <= args.domain_id <= 232:
        raise UsageError(f"--domain-id: {args.domain_id} is outside 0-232")
    check_method(args.method, "--method")
    overrides = parse_overrides(args.set)
    check_overrides(overrides)
    info = load_parameter_set_info(_sim_parameter_set(overrides))
    for flag, value in (("--temperature", temperature),
                        ("--set joint_sim.temperature", overrides.get("joint_sim", {}).get("temperature"))):
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UsageError(f"{flag}: {value!r} is not a number")
        try:
            info.check_range("temperature", float(value))
        except JointwearError as exc:
            raise UsageError(f"{flag}: {exc}") from None
    check_output_dir(args.out, "--out")
    res = run_demo(wear, speeds, Path(args.out), rtf, temperature, args.method, timeout, args.domain_id,
                   overrides)
    rc = 0 if res.estimate else 1
    if args.json:
        print_json(res.as_dict())
        return rc
    rows = [[o["speed"], o["tau_f"], o["tau_f_std"], o["load_torque"], o["temperature"], o["samples_plus"],
             o["samples_minus"]] for o in res.observations]
    print(f"friction observations of cycle {res.cycle_id} ({res.final_state}):")
    print(format_table(["speed", "tau_f", "tau_f_std", "load", "temp", "n+", "n-"], rows) if rows else "  none")
    e = res.estimate
    if e:
        z = (e["wear"] - res.true_wear) / e["wear_std"] if e["wear_std"] > 0 else math.nan
        print(f"wear estimate: {e['wear']:.2f} ± {e['wear_std']:.2f} ({e['method']}); true wear {res.true_wear:g} "
              f"({z:+.1f} std)")
        t = e.get("temperature_estimate")
        if t is not None and math.isfinite(t):
            print(f"joint temperature estimate: {t:.1f} degC (from the friction curve; no sensor used)")
    else:
        print(f"wear estimate: none (cycle {res.final_state}); true wear {res.true_wear:g}")
    print(f"diagnostic level: {res.diagnostic_level} ({res.diagnostic_message})")
    print(f"bag: {res.bag}")
    print(f"logs: {res.logs}; {res.wall_seconds:.1f} s wall")
    return rc
