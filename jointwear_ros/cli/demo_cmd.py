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

``--commission`` (:func:`run_commission_demo`): the same cell, kept running over a commissioning run
planned by :mod:`jointwear_ros.commission.demo`: a robot on the shipped non-reference sets, one cycle
that trips the effort limit (skipped and named), baseline cycles at w = 0 over a warm-up and several
window loads, every joint commissioned in-process, a test cycle at other wear levels estimated with
the commissioned sets and with ``ref-2011r`` (docs/nodes-bag-demo.md).
"""

from __future__ import annotations

import argparse
import math
import os
import random
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..commission.names import MIN_BASELINE_CYCLES
from ..contract import CycleState, DiagnosticLevel, level_name, worst_level
from ..errors import JointwearError
from ..nodes.cell import (
    SIM_STATE_TIMEOUT_WALL,
    CellError,
    Child,
    JointReport,
    Operator,
    ready_conditions,
    start_child,
    stop_children,
)
from ..resources import node_config
from . import UsageError
from .common import check_method, check_output_dir, format_table, parse_float, parse_float_list, print_json

__all__ = ["DEMO_NODES", "DemoError", "register", "run_demo"]

#: Child nodes in start order (the recorder first, so it sees everything).
DEMO_NODES = ("recorder", "joint_sim", "test_cycle", "friction_observer", "wear_estimator")


#: The demo could not complete (a node died, a timeout, a refused request).
DemoError = CellError

#: Default real-time factor of a robot demo (``--joints``): six joints at 2x would take minutes of wall time.
ROBOT_REAL_TIME_FACTOR = 3.0
#: Most joints of a demo robot.
MAX_DEMO_JOINTS = 12
#: The arm a ``--joints`` demo simulates unless ``--arm`` says otherwise; ``none``: independent joints.
DEFAULT_ARM = "ur5"
ARM_CHOICES = ("ur5", "panda", "none")
#: Largest payload of the demo arm, kg (joint_sim's range).
MAX_PAYLOAD = 20.0


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "demo",
        help="run the simulated cell: all nodes, one test cycle by service call, the wear estimate",
        description="Start joint_sim, test_cycle, friction_observer, wear_estimator and recorder as child "
                    "processes, trigger a test cycle through /test_cycle/run as an operator would, wait for "
                    "the wear estimate and print a summary (observations, estimate vs the true wear, "
                    "diagnostic level, bag path).",
    )
    p.add_argument("--joints", type=int, default=None, metavar="N",
                   help="test a robot of N joints in one robot cycle (the first N of test_cycle's joints); "
                        "--json then gives wear and true_wear as lists, one entry per joint (default: the one "
                        "configured joint)")
    p.add_argument("--wear", default=None,
                   help="true wear of the simulated joint, 0-100 (default 20); with --joints one value for all "
                        "or a comma list, one per joint (default " + ",".join(f"{w:g}" for w in DEFAULT_ROBOT_WEAR)
                        + ", cycled)")
    p.add_argument("--speeds", default=None,
                   help="cycle speeds, motor rad/s, comma list or START:STOP:COUNT (default: test_cycle's, 8 speeds)")
    p.add_argument("--out", default="out/demo", help="output directory: bags/ and logs/ (default out/demo)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--real-time-factor", default=None,
                   help=f"sim seconds per wall second (default 2; {ROBOT_REAL_TIME_FACTOR:g} with --joints)")
    p.add_argument("--temperature", default=None,
                   help="joint temperature of the simulator, degC (default: config); with --joints one value or "
                        "a comma list, one per joint")
    p.add_argument("--method", default=None, help="wear estimator method (default: config/wear_estimator.yaml)")
    p.add_argument("--timeout", default=None,
                   help="wall seconds to wait for the estimate (default 180); with --commission, for each cycle "
                        "(default 900)")
    p.add_argument("--set", action="append", default=[], metavar="NODE.PARAM=VALUE",
                   help="override a node parameter, e.g. joint_sim.temperature=30 (repeatable)")
    p.add_argument("--domain-id", type=int, default=None,
                   help="ROS_DOMAIN_ID of the cell (default: $ROS_DOMAIN_ID, else a random free-ish one)")
    p.add_argument("--arm", default=None, metavar="ARM",
                   help=f"with --joints: the simulated arm, {' | '.join(ARM_CHOICES)} (default {DEFAULT_ARM}: its "
                        "rigid-body dynamics from the URDF with Pinocchio; none: independent joints)")
    p.add_argument("--sweep", default=None, choices=("simultaneous", "sequential"),
                   help="with --joints: sweep every joint at once along one line in joint space (simultaneous, "
                        "the default) or one joint after another (sequential)")
    p.add_argument("--payload", default=None, metavar="KG",
                   help="with --arm: payload at the flange, kg (default 0)")
    c = p.add_argument_group(
        "commissioning (--commission)",
        "Simulate the arm (or, with --arm none, a robot whose joints use the shipped non-reference sets arm6-base, "
        "cobot-j3, arm6-wrist), record baseline cycles at w = 0 while the joints warm up and their load changes "
        "(on the arm: payload and pose), skip any cycle that failed, commission every joint, run a cycle at other "
        "wear levels and print each joint's estimate with its commissioned set against ref-2011r's "
        "(docs/nodes-bag-demo.md).")
    c.add_argument("--commission", action="store_true",
                   help="run the commissioning demo (with --joints N: N joints, default 6) on the arm (--arm, default "
                        f"{DEFAULT_ARM}; none: independent joints on the shipped sets), every joint at once unless "
                        "--sweep sequential; on an arm the payload and pose change the load between cycles")
    c.add_argument("--baseline-cycles", type=int, default=6, metavar="K",
                   help=f"baseline cycles at w = 0 over the warm-up (default 6; at least {MIN_BASELINE_CYCLES})")
    c.add_argument("--test-wear", default="10,30,40",
                   help="true wear of the test cycle, spread over the joints in turn (default 10,30,40)")
    c.add_argument("--wear-calibration", default=None,
                   help="wear calibration of the commissioned sets: paper | relative | FILE (default: "
                        "commissioning's default)")
    c.add_argument("--no-overload", action="store_true",
                   help="leave out the cycle that takes a joint beyond test_cycle's effort limit (on an arm: an "
                        "overload payload; independent joints: the first joint's window load) "
                        "(by default it runs first, fails, and is skipped by name)")
    pr = p.add_argument_group(
        "production (--production)",
        "wear from the robot's own program, no test cycle: the arm (--arm, default ur5) runs its pick-and-place for "
        "--shifts shifts of --cycles cycles at known wear (--wear, one per joint), a part of --payload kg (default 2) "
        "carried one way; the cell's joint states are played onto the plant's nodes (production_observer, "
        "wear_estimator, cycle_on_demand, recorder) at --real-time-factor (default 3); prints each joint's "
        "production estimate against its true wear, the pass counts, the cycle requests and whether the replay "
        "equals live (docs/production.md)")
    pr.add_argument("--production", action="store_true", help="run the production demo (out/production by default)")
    pr.add_argument("--shifts", type=int, default=2, metavar="N", help="production shifts (default 2)")
    pr.add_argument("--cycles", type=int, default=3, metavar="K",
                    help="pick-and-place cycles per shift (default 3: one of each product of the speed mix)")
    p.set_defaults(func=cmd_demo)


def _progress(text: str) -> None:
    print(f"[demo] {text}", file=sys.stderr, flush=True)


@dataclass
class DemoResult:
    """What the operator saw: cycle id, observations, each joint's :class:`~jointwear_ros.nodes.cell.JointReport`
    (its estimate, diagnostic level and true wear), the bag.

    ``robot`` is true for ``--joints N``: :meth:`as_dict` then gives ``wear`` and ``true_wear`` as lists
    (one entry per joint); a one-joint cell gives them as one object and one number."""

    cycle_id: int
    observations: list[dict[str, Any]]
    joints: list[JointReport]
    final_state: str
    bag: str | None = None
    wall_seconds: float = 0.0
    cell_seconds: float = math.nan
    logs: str = ""
    robot: bool = False
    rejections: list[str] = field(default_factory=list)
    #: why the cycle did not end DONE, naming the node that said so ("" when it ended DONE)
    failure: str = ""
    #: the simulated arm ("": independent joints), its payload (kg) and how the joints were swept
    arm: str = ""
    payload: float = 0.0
    sweep: str = "sequential"

    @property
    def diagnostic_level(self) -> str:
        return _worst_level([j.diagnostic_level for j in self.joints])

    @property
    def diagnostic_message(self) -> str:
        if len(self.joints) == 1:
            return self.joints[0].diagnostic_message
        return "; ".join(f"{j.joint}: {j.diagnostic_level}" for j in self.joints)

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"bag": self.bag, "cycle_id": self.cycle_id, "observations": self.observations}
        if self.robot:
            out["wear"] = [{"joint": j.joint, **j.wear_dict(), "diagnostic_level": j.diagnostic_level,
                            "diagnostic_message": j.diagnostic_message, "cycle_state": j.final_state,
                            "cell_seconds": _finite_or_none(j.cell_seconds)} for j in self.joints]
            out["true_wear"] = [{"joint": j.joint, "wear": j.true_wear} for j in self.joints]
            out.update({"arm": self.arm or None, "payload": self.payload, "sweep": self.sweep})
        else:
            out["wear"] = self.joints[0].wear_dict()
            out["true_wear"] = self.joints[0].true_wear
        out.update({
            "diagnostic_level": self.diagnostic_level,
            "diagnostic_message": self.diagnostic_message,
            "cycle_state": self.final_state,
            "wall_seconds": self.wall_seconds,
            "cell_seconds": _finite_or_none(self.cell_seconds),
            "logs": self.logs,
            "failure": self.failure or None,
        })
        return out



#: The largest ROS domain id Fast DDS accepts (its port arithmetic refuses larger ones).
MAX_DOMAIN_ID = 232


def _check_domain_id(domain_id: int | None) -> None:
    """``--domain-id`` within 0-232 (a one-line usage error otherwise)."""
    if domain_id is not None and not 0 <= domain_id <= MAX_DOMAIN_ID:
        raise UsageError(f"--domain-id: {domain_id} is outside 0-{MAX_DOMAIN_ID}")


def _domain_id(domain_id: int | None) -> int:
    """The cell's ROS domain: ``domain_id``, else ``ROS_DOMAIN_ID``, else one of 10-99 at random."""
    if domain_id is not None:
        return domain_id
    env_id = os.environ.get("ROS_DOMAIN_ID", "")
    return int(env_id) if env_id.isdigit() else random.Random(os.getpid() ^ int(time.time())).randint(10, 99)


def _start_cell(children: list[Child], params: dict[str, Any], env: dict[str, str], logdir: Path,
                names: Sequence[str], domain_id: int) -> Operator:
    """Start the cell's nodes (each added to ``children`` as it starts, so :func:`_stop_cell` stops what
    started) and an operator, and wait until the graph is connected: the operator, ready to call."""
    for name in DEMO_NODES:
        children.append(start_child(name, params[name], env, logdir))
        _progress(f"started {name} (pid {children[-1].proc.pid})")
    op = Operator(names, domain_id, progress=_progress)
    missing = ready_conditions(op)
    op.spin_until(lambda: not missing(), 60.0, children, "the nodes to connect")
    return op


#: Wall seconds the recorder runs on after the operator heard a run's last result (its estimates and
#: diagnostics): the recorder takes them off its queue by then. The producers stop meanwhile.
RECORDER_GRACE = 0.5
#: friction_observer's ``poll_period`` in a demo cell (s, wall; config 0.5): after DONE the clock stands
#: (lockstep) and the last speed is processed at the first poll after ``poll_grace`` s of silence; a
#: shorter period only ends that wait sooner (the same samples, the same observation).
DEMO_POLL_PERIOD = 0.1


def _stop_cell(children: list[Child], heard: float | None = None) -> None:
    """Stop the cell's nodes: the producers first (each waits until the recorder acknowledged its last
    messages), then the recorder and the clock source (joint_sim) together, not before :data:`RECORDER_GRACE`
    s after the operator heard the run's results (``heard``, ``time.monotonic()``; None: at once). The
    recorder, on sim time, needs no /clock to stop: it closes its bag and waits for acknowledgements on the
    wall clock."""
    _progress("stopping the nodes")
    stop_children([c for c in children if c.name not in ("joint_sim", "recorder")], progress=_progress)
    if heard is not None:
        time.sleep(max(0.0, heard + RECORDER_GRACE - time.monotonic()))
    stop_children([c for c in children if c.name in ("recorder", "joint_sim")], progress=_progress)


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _worst_level(names: Sequence[str]) -> str:
    """The name of the most urgent of the joints' diagnostic levels (:func:`~jointwear_ros.contract.worst_level`:
    ERROR over WARN over STALE over OK); a name that is no level (UNKNOWN: no status heard) counts worst.

    >>> _worst_level(["OK", "STALE", "ERROR", "WARN"]), _worst_level(["OK", "UNKNOWN", "ERROR"]), _worst_level([])
    ('ERROR', 'UNKNOWN', 'OK')
    """
    unknown = [n for n in names if n not in DiagnosticLevel.__members__]
    return unknown[0] if unknown else level_name(worst_level(DiagnosticLevel[n] for n in names))


def _config_value(node: str, name: str, default: Any) -> Any:
    """Parameter ``name`` of ``config/<node>.yaml`` (``default`` if the file or the name is not there)."""
    try:
        return node_config(node).get(name, default)
    except JointwearError:
        return default


def _sim_state_timeout_wall() -> float:
    """state_timeout_wall of config/test_cycle.yaml, at least :data:`SIM_STATE_TIMEOUT_WALL`."""
    try:
        configured = float(_config_value("test_cycle", "state_timeout_wall", 1.0))
    except (TypeError, ValueError):
        configured = 1.0
    return max(configured, SIM_STATE_TIMEOUT_WALL)


def _config_done_timeout() -> float:
    """done_timeout of config/wear_estimator.yaml (2 s if it cannot be read)."""
    try:
        return float(_config_value("wear_estimator", "done_timeout", 2.0))
    except (TypeError, ValueError):
        return 2.0


#: Default true wear of the joints of a ``--joints N`` demo: OK, WARN and ERROR joints in one robot.
DEFAULT_ROBOT_WEAR = (12.0, 20.0, 26.0, 31.0, 39.0, 46.0)
#: The nodes that take a ``joints`` list (docs/robot.md).
_JOINT_NODES = ("joint_sim", "test_cycle", "friction_observer", "wear_estimator")


def robot_joint_names(n: int) -> list[str]:
    """The first ``n`` joints of test_cycle's configured ``joints`` (``joint_<k>`` beyond those)."""
    configured = _config_value("test_cycle", "joints", None)
    names = [str(j) for j in configured] if isinstance(configured, list) and configured else []
    if not names:
        names = [str(_config_value("test_cycle", "joint_name", "joint_1"))]
    k = 1
    while len(names) < n:
        candidate = f"joint_{k}"
        if candidate not in names:
            names.append(candidate)
        k += 1
    return names[:n]


def run_demo(
    wear: float | Sequence[float],
    speeds: Sequence[float] | None,
    out: Path,
    real_time_factor: float = 2.0,
    temperature: float | Sequence[float] | None = None,
    method: str | None = None,
    timeout: float = 180.0,
    domain_id: int | None = None,
    overrides: dict[str, dict[str, Any]] | None = None,
    joints: int | None = None,
    arm: str | None = None,
    sweep: str | None = None,
    payload: float = 0.0,
) -> DemoResult:
    """Run the simulated cell for one test cycle; see the module docstring.

    ``joints=None``: the configured single joint (``wear`` and ``temperature`` are numbers). ``joints=N``:
    a robot cycle over the first N configured joints; ``wear`` (and ``temperature``) may then be one value
    per joint, and the result's :meth:`DemoResult.as_dict` gives lists. With ``joints``, ``arm`` (``ur5``,
    ``panda``; ``None``: independent joints) puts the cell on that arm (:func:`arm_cell_parameters`, with
    ``payload`` kg at the flange) and ``sweep`` is test_cycle's (``simultaneous`` or ``sequential``; ``None``:
    its config)."""
    from ..io.bags import OBSERVATION_FIELDS, find_bags, message_fields
    from ..nodes.runtime import loopback_env

    t_start = time.monotonic()
    domain_id = _domain_id(domain_id)
    env = loopback_env(domain_id)  # for the children; the operator takes the domain id itself
    logdir = out / "logs"
    bagdir = out / "bags"
    logdir.mkdir(parents=True, exist_ok=True)
    bagdir.mkdir(parents=True, exist_ok=True)
    bags_before = set(find_bags(bagdir))
    # Timeouts that guard against a dead process run in sim time: scale them by the real-time factor
    # so each keeps its configured grace in wall seconds (a process briefly starved of CPU on a loaded
    # machine is not dead; at 3x, 0.5 s of sim time is 0.17 s of wall time).
    rtf_grace = max(float(real_time_factor), 1.0)
    sim_params: dict[str, Any] = {"use_sim_time": False, "publish_clock": True,
                                  "real_time_factor": float(real_time_factor),
                                  "command_timeout": float(_config_value("joint_sim", "command_timeout", 0.5))
                                  * rtf_grace}
    params: dict[str, dict[str, Any]] = {
        "recorder": {"use_sim_time": True, "output_dir": str(bagdir.resolve()), "split": "session"},
        "joint_sim": sim_params,
        "test_cycle": {"use_sim_time": True, "simulator": True,
                       "state_timeout": float(_config_value("test_cycle", "state_timeout", 0.25)) * rtf_grace,
                       "state_timeout_wall": _sim_state_timeout_wall()},
        "friction_observer": {"use_sim_time": True, "poll_period": DEMO_POLL_PERIOD},
        # The last speed's observation comes just after DONE; done_timeout runs in sim time,
        # so scale it to keep the config's grace in wall seconds on a loaded machine.
        "wear_estimator": {"use_sim_time": True, "done_timeout": _config_done_timeout() * float(real_time_factor),
                           **({"method": method} if method else {})},
    }
    if joints is None:
        wears = [float(wear)] if isinstance(wear, (int, float)) else [float(w) for w in wear][:1]
        temps = None if temperature is None else (
            [float(temperature)] if isinstance(temperature, (int, float)) else [float(t) for t in temperature][:1])
        sim_params["wear"] = wears[0]
        if temps is not None:
            sim_params["temperature"] = temps[0]
        for node, values in (overrides or {}).items():
            params[node].update(values)
        # the joint the cell drives: the test cycle's (its config, or a --set override)
        names = [str(params["test_cycle"].get("joint_name") or _config_value("test_cycle", "joint_name", "joint_1"))]
    else:
        names = robot_joint_names(joints)
        wears = _per_joint(wear, names, "wear")
        temps = None if temperature is None else _per_joint(temperature, names, "temperature")
        for node in _JOINT_NODES:
            params[node]["joints"] = list(names)
        for i, j in enumerate(names):
            sim_params[f"{j}.wear"] = wears[i]
            if temps is not None:
                sim_params[f"{j}.temperature"] = temps[i]
        if arm is not None:
            from ..simcell import arm_cell_parameters

            for node, values in arm_cell_parameters(arm, names, payload).items():
                params[node].update(values)
        if sweep is not None:
            params["test_cycle"]["sweep"] = sweep
        for node, values in (overrides or {}).items():
            params[node].update(values)
    children: list[Child] = []
    op: Operator | None = None
    heard: float | None = None
    per_joint: list[JointReport] = []
    observations: list[dict[str, Any]] = []
    cycle_id = 0
    final_state = "?"
    failure = ""
    cell_seconds = math.nan
    try:
        _progress(f"ROS_DOMAIN_ID={domain_id}, loopback only; logs in {logdir}")
        op = _start_cell(children, params, env, logdir, names, domain_id)
        _progress(f"graph connected after {time.monotonic() - t_start:.1f} s; calling /test_cycle/run")
        # as an operator would: a refusal whose reason is retryable (the joint state not there yet or
        # late: nodes still starting on a loaded machine) is retried for a while; any other is final
        cycle_id, message = op.start_cycle(speeds or [], children)
        _progress(f"cycle {cycle_id} accepted: {message}")
        shown: list[tuple[Any, ...] | None] = [None]
        # a simultaneous cycle reports every joint at each step: one progress line per step, not per joint
        together = len(names) > 1 and (params["test_cycle"].get("sweep")
                                       or _config_value("test_cycle", "sweep", "sequential")) == "simultaneous"

        def tick() -> None:
            st = op.status if op is not None else None
            if st is None or st.cycle_id != cycle_id:
                return
            key = (st.state, st.speeds_done) if together else (st.joint_name, st.state, st.speeds_done)
            if key != shown[0]:
                shown[0] = key
                state = st.state_name
                extra = f": {st.message}" if st.state in (CycleState.ABORTED, CycleState.FAILED) and st.message else ""
                where = (f"{len(names)} joints at once " if together else
                         f"{st.joint_name} ({st.joints_done + 1} of {len(st.joints)}) " if len(names) > 1 else "")
                _progress(f"cycle {cycle_id} {where}{state}, speeds done {st.speeds_done}/{st.speeds_total}{extra}")

        op.spin_until(lambda: op.estimated(cycle_id), timeout, children,  # type: ignore[union-attr]
                      f"the WearEstimate of cycle {cycle_id}", tick)
        try:
            op.spin_until(lambda: op.complete(cycle_id), 60.0, children,  # type: ignore[union-attr]
                          f"every observation of cycle {cycle_id} in its joint's estimate")
        except DemoError as exc:
            _progress(f"{exc}; reporting the newest estimate, which may lack an observation")
        for joint, true_wear in zip(names, wears):
            report = op.joint_report(cycle_id, joint, children)
            report.true_wear = float(true_wear)
            per_joint.append(report)
        observations = [message_fields(o, OBSERVATION_FIELDS) for o in op.observations if o.cycle_id == cycle_id]
        order = {j: i for i, j in enumerate(names)}
        observations.sort(key=lambda o: (order.get(o["joint_name"], len(order)), o["speed"]))
        final = op.status
        final_state = final.state_name if final is not None and final.cycle_id == cycle_id else "?"
        if final is not None and final.cycle_id == cycle_id and final.state in (CycleState.ABORTED,
                                                                                 CycleState.FAILED):
            failure = (f"test_cycle: cycle {cycle_id} {final.state_name}"
                       + (f" at {final.joint_name}" if final.joint_name else "")
                       + (f": {final.message}" if final.message else " (no reason given)"))
        cell_seconds = op.cell_seconds(cycle_id)
        heard = time.monotonic()  # the recorder gets the estimate and diagnostics too: _stop_cell
    finally:
        if op is not None:
            op.close()
        if children:
            _stop_cell(children, heard)
    bags = [b for b in find_bags(bagdir) if b not in bags_before]
    bag = str(bags[-1]) if bags else None
    if bag is None:
        _progress(f"the recorder wrote no bag; see {logdir / 'recorder.log'}")
    return DemoResult(
        cycle_id=cycle_id, observations=observations, joints=per_joint, final_state=final_state, bag=bag,
        wall_seconds=time.monotonic() - t_start, cell_seconds=cell_seconds, logs=str(logdir),
        robot=joints is not None, failure=failure, arm=arm or "", payload=float(payload),
        sweep=str(params["test_cycle"].get("sweep") or _config_value("test_cycle", "sweep", "sequential")),
    )


def _per_joint(value: float | Sequence[float], names: Sequence[str], what: str) -> list[float]:
    """One value per joint: a number for all, or a sequence of exactly one per joint."""
    if isinstance(value, (int, float)):
        return [float(value)] * len(names)
    values = [float(v) for v in value]
    if len(values) != len(names):
        raise CellError(f"{len(values)} {what} values for {len(names)} joints ({', '.join(names)})")
    return values


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


def check_overrides(overrides: dict[str, dict[str, Any]]) -> None:
    """Every ``--set NODE.PARAM=VALUE`` names a parameter the node takes (its declarations, a joint's own
    ``<joint>.<setting>``, or its config file), of the declared type and within the declared range; an
    integer where a double is declared becomes that double (what everyone types)."""
    from ..errors import ParameterError
    from ..nodes.runtime import node_parameter, node_parameters

    for node, values in overrides.items():
        for name, value in values.items():
            decl = node_parameter(node, name)
            if decl is None:
                known = set(node_parameters(node)) | set(_config_value_names(node))
                if name in known:
                    continue
                raise UsageError(f"--set {node}.{name}: {node} has no parameter {name!r}; "
                                 f"it has {', '.join(sorted(known))}")
            try:
                values[name] = decl.check(value)
            except ParameterError as exc:
                raise UsageError(f"--set {node}.{exc}") from None
        if node == "wear_estimator" and "method" in values:
            check_method(str(values["method"]), "--set wear_estimator.method")


def _config_value_names(node: str) -> list[str]:
    try:
        return list(node_config(node))
    except JointwearError:
        return []


#: Most speeds of a demo cycle (each takes seconds of simulated motion).
MAX_DEMO_SPEEDS = 64


def _sim_parameter_set(overrides: dict[str, dict[str, Any]]) -> str:
    """The parameter set joint_sim will simulate with (its config, or --set joint_sim.params)."""
    if "params" in overrides.get("joint_sim", {}):
        return str(overrides["joint_sim"]["params"])
    return str(_config_value("joint_sim", "params", "ref-2011r"))


def _values_per_joint(text: str | None, flag: str, n: int | None, default: Sequence[float]) -> list[float]:
    """A number, or with --joints a comma list of one number per joint (the default cycled to n)."""
    if text is None:
        return [default[i % len(default)] for i in range(n or 1)]
    values = parse_float_list(text, flag) if "," in text else [parse_float(text, flag)]
    if n is None and len(values) != 1:
        raise UsageError(f"{flag}: {len(values)} values given; a list needs --joints N (one value per joint)")
    if n is not None and len(values) == 1:
        values = values * n
    if n is not None and len(values) != n:
        raise UsageError(f"{flag}: {len(values)} values for --joints {n}; give one value, or one per joint")
    return values


def cmd_demo(args: argparse.Namespace) -> int:
    if args.commission and args.production:
        raise UsageError("--commission and --production are two demos: give one")
    if args.commission:
        return cmd_demo_commission(args)
    if args.production:
        from .demo_production import cmd_demo_production

        _check_domain_id(args.domain_id)
        return cmd_demo_production(args, _domain_id(args.domain_id))
    n = args.joints
    if n is not None and not 1 <= n <= MAX_DEMO_JOINTS:
        raise UsageError(f"--joints: {n} is outside 1-{MAX_DEMO_JOINTS}")
    wears = _values_per_joint(args.wear, "--wear", n, DEFAULT_ROBOT_WEAR if n is not None else (20.0,))
    for w in wears:
        if not 0.0 <= w <= 100.0:
            raise UsageError(f"--wear: {w:g} is outside 0-100")
    speeds = parse_float_list(args.speeds, "--speeds") if args.speeds is not None else None
    if speeds is not None and any(not s > 0 for s in speeds):
        raise UsageError(f"--speeds: every speed must be > 0 rad/s (got {args.speeds})")
    rtf = (parse_float(args.real_time_factor, "--real-time-factor") if args.real_time_factor is not None
           else ROBOT_REAL_TIME_FACTOR if n is not None else 2.0)
    if not 0.01 <= rtf <= 100.0:
        raise UsageError(f"--real-time-factor: {rtf:g} is outside 0.01-100")
    timeout = parse_float(args.timeout, "--timeout") if args.timeout is not None else 180.0
    if not 0 < timeout <= 86400:
        raise UsageError(f"--timeout: {timeout:g} must be more than 0 and at most 86400 s")
    temperatures = (_values_per_joint(args.temperature, "--temperature", n, ()) if args.temperature is not None
                    else None)
    _check_domain_id(args.domain_id)
    if args.method is not None:  # the estimators (scipy) load only to check a method given
        check_method(args.method, "--method")
    arm, payload = _arm_args(args, n)
    overrides = parse_overrides(args.set)
    check_overrides(overrides)
    checks = [(flag, value) for flag, value in [("--temperature", t) for t in temperatures or []]
              + [("--set joint_sim.temperature", overrides.get("joint_sim", {}).get("temperature"))]
              if value is not None]
    info: Any = None
    if checks or "params" in overrides.get("joint_sim", {}):  # the model (numpy) loads only to check these
        from ..model import load_parameter_set_info

        info = load_parameter_set_info(_sim_parameter_set(overrides))
    for flag, value in checks:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise UsageError(f"{flag}: {value!r} is not a number")
        try:
            info.check_range("temperature", float(value))
        except JointwearError as exc:
            raise UsageError(f"{flag}: {exc}") from None
    if speeds is not None:
        max_speed = overrides.get("test_cycle", {}).get("max_speed", _config_value("test_cycle", "max_speed", 280.0))
        if isinstance(max_speed, (int, float)) and not isinstance(max_speed, bool):
            too_fast = [s for s in speeds if s > float(max_speed)]
            if too_fast:
                raise UsageError(f"--speeds: {too_fast[0]:g} rad/s is above test_cycle's max_speed {float(max_speed):g} "
                                 "rad/s (motor side); the request would be refused")
        if len(speeds) > MAX_DEMO_SPEEDS:
            raise UsageError(f"--speeds: {len(speeds)} speeds; a demo cycle takes at most {MAX_DEMO_SPEEDS}")
    check_output_dir(args.out, "--out")
    if n is not None and any("joints" in overrides.get(node, {}) for node in _JOINT_NODES):
        raise UsageError("--set NODE.joints: the demo sets the joints of every node from --joints N")
    temperature: float | list[float] | None = None
    if temperatures is not None:
        temperature = temperatures if n is not None else temperatures[0]
    res = run_demo(wears if n is not None else wears[0], speeds, Path(args.out), rtf, temperature, args.method,
                   timeout, args.domain_id, overrides, joints=n, arm=arm, payload=payload,
                   sweep=args.sweep or ("simultaneous" if n is not None and n > 1 else None))
    # a cycle that did not end DONE, or a joint without an estimate, is a failed demo (exit 1), whatever the level
    rc = 0 if all(j.estimate for j in res.joints) and not res.failure else 1
    if res.failure:
        print(f"jointwear demo: {res.failure}; logs in {res.logs}", file=sys.stderr)
    if args.json:
        print_json(res.as_dict())
        return rc
    if res.robot:
        return _print_robot(res, rc)
    rows = [[o["speed"], o["tau_f"], o["tau_f_std"], o["load_torque"], o["temperature"], o["samples_plus"],
             o["samples_minus"]] for o in res.observations]
    print(f"friction observations of cycle {res.cycle_id} ({res.final_state}):")
    print(format_table(["speed", "tau_f", "tau_f_std", "load", "temp", "n+", "n-"], rows) if rows else "  none")
    joint = res.joints[0]
    e = joint.estimate
    if e:
        z = (e["wear"] - joint.true_wear) / e["wear_std"] if e["wear_std"] > 0 else math.nan
        print(f"wear estimate: {e['wear']:.2f} ± {e['wear_std']:.2f} ({e['method']}); true wear {joint.true_wear:g} "
              f"({z:+.1f} std)")
        t = e.get("temperature_estimate")
        if t is not None and math.isfinite(t):
            print(f"joint temperature estimate: {t:.1f} degC (from the friction curve; no sensor used)")
    else:
        print(f"wear estimate: none (cycle {res.final_state}); true wear {joint.true_wear:g}")
    print(f"diagnostic level: {res.diagnostic_level} ({res.diagnostic_message})")
    print(f"bag: {res.bag}")
    print(f"logs: {res.logs}; {res.wall_seconds:.1f} s wall")
    return rc


def _arm_args(args: argparse.Namespace, n: int | None) -> tuple[str | None, float]:
    """``--arm`` and ``--payload`` checked against ``--joints``: the arm (``None``: independent joints) and kg."""
    if n is None:
        given = [f for f, v in (("--arm", args.arm), ("--sweep", args.sweep), ("--payload", args.payload))
                 if v is not None]
        if given:
            raise UsageError(f"{given[0]} needs --joints N (a robot cycle); the one-joint demo runs the single "
                             "simulated joint")
        return None, 0.0
    name = (args.arm if args.arm is not None else DEFAULT_ARM).strip().lower()
    if name not in ARM_CHOICES:
        raise UsageError(f"--arm: {args.arm!r} is not an arm; choose one of {', '.join(ARM_CHOICES)}")
    payload = parse_float(args.payload, "--payload") if args.payload is not None else 0.0
    if name == "none":
        if args.payload is not None:
            raise UsageError("--payload needs an arm (--arm ur5 or panda); independent joints carry none")
        return None, 0.0
    from ..sim.arms import arm_spec  # the simulator's package (numpy, the model): for an arm only

    spec = arm_spec(name)
    if n > len(spec.joints):
        raise UsageError(f"--joints: {n} joints, but the {spec.title} (--arm {name}) has {len(spec.joints)}")
    if not 0.0 <= payload <= MAX_PAYLOAD:
        raise UsageError(f"--payload: {payload:g} kg is outside 0-{MAX_PAYLOAD:g}")
    return name, payload


def _print_robot(res: DemoResult, rc: int) -> int:
    """The text summary of a robot demo: one row per joint."""
    rows: list[list[Any]] = []
    for j in res.joints:
        e = j.estimate
        if e:
            z = (e["wear"] - j.true_wear) / e["wear_std"] if e["wear_std"] > 0 else math.nan
            t = e.get("temperature_estimate")
            rows.append([j.joint, f"{j.true_wear:g}", f"{e['wear']:.2f} ± {e['wear_std']:.2f}", f"{z:+.1f}",
                         _fixed(t, 1), j.diagnostic_level, j.final_state, _fixed(j.cell_seconds, 1)])
        else:
            rows.append([j.joint, f"{j.true_wear:g}", "none", "", "", j.diagnostic_level, j.final_state,
                         _fixed(j.cell_seconds, 1)])
    n_obs = len(res.observations)
    on = (f" on the {res.arm} arm" + (f" with {res.payload:g} kg" if res.payload else "")) if res.arm else ""
    print(f"robot cycle {res.cycle_id} ({res.final_state}){on}: {len(res.joints)} joints swept {res.sweep}ly, "
          f"{n_obs} friction observations")
    print(format_table(["joint", "true w", "estimate", "z", "T est", "level", "cycle", "cell s"], rows))
    print(f"worst level: {res.diagnostic_level}")
    cell = f"{res.cell_seconds:.0f} s of cell time (sim), " if math.isfinite(res.cell_seconds) else ""
    print(f"bag: {res.bag}")
    print(f"logs: {res.logs}; {cell}{res.wall_seconds:.1f} s wall")
    return rc


def _fixed(x: float | None, digits: int) -> str:
    """``x`` with ``digits`` decimals; empty when unknown."""
    return f"{x:.{digits}f}" if x is not None and math.isfinite(x) else ""


# --------------------------------------------------------------------------- demo --commission

#: Default real-time factor of the commissioning demo (sim seconds per wall second).
COMMISSION_REAL_TIME_FACTOR = 3.0
#: Default real-time factor of the commissioning demo on an arm: at 3x, with another job on the 2 cores, the live
#: UR5's joints lagged off the approach line (hold_tolerance) in 5 of 9 cycles; the runs measured ran at 2x.
ARM_COMMISSION_REAL_TIME_FACTOR = 2.0
#: Sim seconds the arm settles after a jog, before a commissioning cycle starts.
ARM_SETTLE_SECONDS = 2.0
#: Default wall seconds one cycle of the commissioning demo may take.
COMMISSION_CYCLE_TIMEOUT = 900.0
#: What the joints of an arm run in the simulator during commissioning (said in the output).
_ARM_SET_NOTE = ("every joint runs ref-2011r in the simulator, sized by its torque scale (effort / 2, gear 100); "
                 "commissioning identifies each joint's own model from its baseline")


@dataclass
class CycleRecord:
    """One cycle of a commissioning run as the operator saw it: its stage, final state, the joint and reason
    where it stopped (ABORTED/FAILED), its cell time and observations (FrictionObservation fields + ``time``)."""

    cycle_id: int
    stage: str
    state: str
    joint: str = ""
    reason: str = ""
    cell_seconds: float = math.nan
    observations: list[dict[str, Any]] = field(default_factory=list)
    live: dict[str, dict[str, Any]] = field(default_factory=dict)
    bag: str | None = None
    #: on an arm: the cycle's payload (kg) and window centres (rad)
    payload: float | None = None
    positions: dict[str, float] = field(default_factory=dict)

    @property
    def usable(self) -> bool:
        return self.state == "DONE"

    def skipped_dict(self) -> dict[str, Any]:
        return {"cycle_id": self.cycle_id, "stage": self.stage, "state": self.state, "joint": self.joint,
                "reason": self.reason, "node": "test_cycle", "bag": self.bag}


@dataclass
class CommissionedJoint:
    """One joint's outcome: its commissioned set, and the test cycle's estimate with it and with ref-2011r."""

    joint: str
    params: str
    frame: str
    true_wear: float
    parameter_set: str | None = None
    estimate: float | None = None
    std: float | None = None
    temperature: float | None = None
    reference_estimate: float | None = None
    reference_std: float | None = None
    live_estimate: float | None = None
    live_std: float | None = None
    baseline_cycles: list[int] = field(default_factory=list)
    commission: dict[str, Any] = field(default_factory=dict)
    error: str = ""
    #: on an arm: the planned load span of the baseline (normalized gravity, smallest and largest) and whether
    #: commissioning identified the load dependence (False: fixed at 0, the priors say why)
    load_span: tuple[float, float] | None = None
    #: why the joint's load dependence cannot be identified on the arm ("" when it can)
    unloaded: str = ""

    @property
    def load_identified(self) -> bool | None:
        """Whether the commissioned set has its load terms (None: not commissioned): False when commissioning
        fixed the load sensitivities at 0 because the load hardly changed (its prior says so)."""
        if not self.commission:
            return None
        return not self.load_note

    @property
    def load_note(self) -> str:
        """Why the joint's load dependence was not identified (the plan's reason, or commissioning's prior), ""
        when it was."""
        return self.unloaded or next((p for p in self.commission.get("priors", []) if "load" in p), "")

    @property
    def z(self) -> float | None:
        if self.estimate is None or not self.std:
            return None
        return (self.estimate - self.true_wear) / self.std

    @property
    def reference_z(self) -> float | None:
        if self.reference_estimate is None or not self.reference_std:
            return None
        return (self.reference_estimate - self.true_wear) / self.reference_std

    def as_dict(self) -> dict[str, Any]:
        c = self.commission
        return {"joint": self.joint, "true_wear": self.true_wear, "estimate": self.estimate, "std": self.std,
                "z": self.z, "reference_estimate": self.reference_estimate, "reference_std": self.reference_std,
                "reference_z": self.reference_z, "parameter_set": self.parameter_set, "simulated_set": self.params,
                "frame": self.frame, "temperature_estimate": self.temperature, "live_estimate": self.live_estimate,
                "live_std": self.live_std, "baseline_cycles": self.baseline_cycles,
                "wear_calibration": c.get("wear_calibration"), "verdict": c.get("verdict"),
                "converged": c.get("converged"), "cv_rmse": c.get("cv_rmse"), "noise_floor": c.get("noise_floor"),
                "commission_warnings": c.get("warnings", []), "error": self.error or None,
                "load_span": list(self.load_span) if self.load_span is not None else None,
                "load_identified": self.load_identified, "load_note": self.load_note or None}


@dataclass
class CommissionDemoResult:
    joints: list[CommissionedJoint]
    cycles: list[CycleRecord]
    wall_seconds: float
    real_time_factor: float
    speeds: list[float]
    sets_dir: str
    bags: list[str]
    logs: str
    #: the simulated arm ("": independent joints) and how its joints were swept
    arm: str = ""
    sweep: str = "sequential"
    #: the plan run (commission.demo.PlannedCycle), one per planned cycle
    plan: list[Any] = field(default_factory=list)

    @property
    def cell_seconds(self) -> float:
        cells = [c.cell_seconds for c in self.cycles if math.isfinite(c.cell_seconds)]
        return float(sum(cells)) if cells else math.nan

    @property
    def skipped(self) -> list[CycleRecord]:
        return [c for c in self.cycles if not c.usable]

    def as_dict(self) -> dict[str, Any]:
        return {
            "arm": self.arm or None,
            "sweep": self.sweep,
            "simulated_set": _ARM_SET_NOTE if self.arm else None,
            "commissioned": [j.as_dict() for j in self.joints],
            "skipped_cycles": [c.skipped_dict() for c in self.skipped],
            "cycles": [{"cycle_id": c.cycle_id, "stage": c.stage, "state": c.state,
                        "cell_seconds": _finite_or_none(c.cell_seconds), "observations": len(c.observations),
                        "bag": c.bag, **({"payload": c.payload} if c.payload is not None else {}),
                        **({"positions": c.positions} if c.positions else {})}
                       for c in self.cycles],
            "speeds": self.speeds,
            "real_time_factor": self.real_time_factor,
            "cell_seconds": _finite_or_none(self.cell_seconds),
            "wall_seconds": self.wall_seconds,
            "sets_dir": self.sets_dir,
            "bags": self.bags,
            "logs": self.logs,
        }


def _observation_dict(o: Any) -> dict[str, Any]:
    from ..io.bags import OBSERVATION_FIELDS, message_fields, stamp_seconds

    d = message_fields(o, OBSERVATION_FIELDS)
    d["time"] = stamp_seconds(o.header)
    return d


def _run_cycle(op: Operator, children: Sequence[Child], stage: str, speeds: Sequence[float], names: Sequence[str],
               timeout: float, together: bool = False) -> CycleRecord:
    """Start one robot cycle, follow it to its end, wait for its observations; what happened. ``together``: every
    joint is swept at once (one progress line per speed step, not per joint)."""
    cycle_id, _ = op.start_cycle(speeds, children)
    _progress(f"{stage} cycle {cycle_id} accepted")
    shown: list[tuple[Any, ...] | None] = [None]

    def tick() -> None:
        st = op.status
        if st is None or st.cycle_id != cycle_id:
            return
        key = (st.state, st.speeds_done) if together else (st.joint_name, st.state, st.speeds_done)
        if key != shown[0]:
            shown[0] = key
            extra = f": {st.message}" if st.state in (CycleState.ABORTED, CycleState.FAILED) and st.message else ""
            where = (f"{len(names)} joints at once " if together else
                     f"{st.joint_name} ({st.joints_done + 1} of {len(st.joints)}) " if len(names) > 1 else "")
            _progress(f"{stage} cycle {cycle_id} {where}{st.state_name}, speeds done "
                      f"{st.speeds_done}/{st.speeds_total}{extra}")

    op.spin_until(lambda: op.robot_cycle_over(cycle_id), timeout, children, f"the end of {stage} cycle {cycle_id}",
                  tick)
    stopped = next((st for st in op.statuses if st.cycle_id == cycle_id
                    and st.state in (CycleState.ABORTED, CycleState.FAILED)), None)
    rec = CycleRecord(cycle_id, stage, "DONE" if stopped is None else stopped.state_name)
    if stopped is not None:
        rec.reason = stopped.message or "no reason given"
        # on a line cycle every joint's status carries the stop: the joint is the one its reason names
        rec.joint = _named_joint(rec.reason, names) or stopped.joint_name
    else:
        try:  # every speed of every joint observed (the observer may trail the cycle's end on a loaded machine)
            op.spin_until(lambda: all(op.observer_done(cycle_id, j) for j in op.joints_started(cycle_id)), 60.0,
                          children, f"every observation of cycle {cycle_id}")
        except CellError as exc:
            _progress(f"{exc}; going on with the observations heard")
    rec.cell_seconds = op.cell_seconds(cycle_id)
    rec.observations = [_observation_dict(o) for o in op.observations if o.cycle_id == cycle_id]
    return rec


def _named_joint(reason: str, names: Sequence[str]) -> str:
    """The joint a watchdog's reason names first (``watchdog: joint joint_2: |effort| ...``, ``watchdog: reverse
    move not finished ...: joint_5 at -2.205 rad``), "" if none.

    >>> _named_joint("watchdog: reverse move not finished after 6.1 s: joint_5 at -2.2 rad", ["joint_1", "joint_5"])
    'joint_5'
    """
    import re

    found = [(m.start(), j) for j in names if (m := re.search(rf"(?<![\w.]){re.escape(j)}(?![\w.])", reason))]
    return min(found)[1] if found else ""


def run_commission_demo(
    joints: int,
    out: Path,
    speeds: Sequence[float] | None = None,
    baseline_cycles: int = 6,
    test_wear: Sequence[float] = (10.0, 30.0, 40.0),
    wear_calibration: str | None = None,
    overload: bool = True,
    real_time_factor: float = COMMISSION_REAL_TIME_FACTOR,
    cycle_timeout: float = COMMISSION_CYCLE_TIMEOUT,
    domain_id: int | None = None,
    overrides: dict[str, dict[str, Any]] | None = None,
    arm: str | None = None,
    sweep: str | None = None,
) -> CommissionDemoResult:
    """Commission a simulated robot of ``joints`` joints end to end (see ``jointwear demo --help``).

    ``arm`` (``ur5``, ``panda``): the cell on that arm (:func:`~jointwear_ros.simcell.arm_cell_parameters`), every
    joint on ``ref-2011r`` sized by its torque scale, commissioned in the joint frame; the plan is
    :func:`~jointwear_ros.commission.demo.plan_arm_commissioning`: between cycles the operator sets joint_sim's
    ``payload`` and each joint's temperature and wear, and test_cycle's window centres (``<joint>.position``), then
    jogs the arm to them. ``sweep`` is test_cycle's (``None``: every joint at once on an arm, else its config).
    ``arm=None``: the independent-joint robot on the shipped sets, each window's gravity set per cycle.

    One cell (the five nodes of the demo) runs every cycle of :func:`~jointwear_ros.commission.demo.
    plan_commissioning`; between cycles the operator sets joint_sim's per-joint temperature, gravity and wear
    (``<joint>.temperature`` ...), as a warm-up and other poses would change them. A cycle that did not end DONE
    is skipped by name and re-run once (the overloaded one is not re-run). Each joint is then commissioned
    in-process (:func:`~jointwear_ros.commission.commission`, the default wear calibration unless
    ``wear_calibration``) on its baseline observations, its set written to ``OUT/sets/<joint>.yaml``, and the
    test cycle (temperature not given) estimated with that set and with ``ref-2011r``
    (:func:`~jointwear_ros.commission.estimate_cycles`, joint estimator). The live wear_estimator is switched to
    the commissioned sets before the test cycle; its estimates are reported as ``live_estimate``.
    """
    from ..commission.demo import (
        ARM_APPROACH_SPEED,
        ARM_LOADING,
        arm_joints,
        demo_joints,
        plan_arm_commissioning,
        plan_commissioning,
    )
    from ..io.bags import find_bags
    from ..nodes.runtime import loopback_env

    t_start = time.monotonic()
    domain_id = _domain_id(domain_id)
    env = loopback_env(domain_id)
    logdir, bagdir, setdir = out / "logs", out / "bags", out / "sets"
    for d in (logdir, bagdir, setdir):
        d.mkdir(parents=True, exist_ok=True)
    bags_before = set(find_bags(bagdir))
    names = robot_joint_names(joints)
    if arm is not None:
        setups = arm_joints(arm, names)
        plan = plan_arm_commissioning(arm, setups, baseline_cycles, test_wear, overload)
        speeds = list(speeds or ARM_LOADING[arm].speeds or [])
        sweep = sweep or ("simultaneous" if len(names) > 1 else None)
    else:
        setups = demo_joints(names)
        plan = plan_commissioning(setups, baseline_cycles, test_wear, overload)
    first = plan[0].settings
    rtf_grace = max(float(real_time_factor), 1.0)
    sim: dict[str, Any] = {"use_sim_time": False, "publish_clock": True, "real_time_factor": float(real_time_factor),
                           "command_timeout": float(_config_value("joint_sim", "command_timeout", 0.5)) * rtf_grace}
    cyc: dict[str, Any] = {"use_sim_time": True, "simulator": True,
                           "state_timeout": float(_config_value("test_cycle", "state_timeout", 0.25)) * rtf_grace,
                           "state_timeout_wall": _sim_state_timeout_wall()}
    obs: dict[str, Any] = {"use_sim_time": True, "temperature_topic": "/joint_temperature",
                           "poll_period": DEMO_POLL_PERIOD}
    for j in setups:
        s = first[j.name]
        sim.update({f"{j.name}.params": j.params, f"{j.name}.temperature": s.temperature, f"{j.name}.wear": s.wear})
        if arm is None:  # on an arm, the arm gives each joint its drive, pose and effort limit (below)
            sim.update({f"{j.name}.gear_ratio": j.gear_ratio, f"{j.name}.torque_scale": j.torque_scale,
                        f"{j.name}.gravity_torque": s.gravity_torque})
            cyc.update({f"{j.name}.gear_ratio": j.gear_ratio, f"{j.name}.effort_limit": j.effort_limit})
            obs.update({f"{j.name}.gear_ratio": j.gear_ratio, f"{j.name}.torque_scale": j.torque_scale})
    params: dict[str, dict[str, Any]] = {
        "recorder": {"use_sim_time": True, "output_dir": str(bagdir.resolve()), "split": "cycle"},
        "joint_sim": sim, "test_cycle": cyc, "friction_observer": obs,
        "wear_estimator": {"use_sim_time": True, "done_timeout": _config_done_timeout() * float(real_time_factor)},
    }
    if arm is not None:
        from ..simcell import arm_cell_parameters

        for node, values in arm_cell_parameters(arm, names, float(plan[0].payload or 0.0)).items():
            params[node].update(values)
        for j in setups:
            cyc[f"{j.name}.approach_speed"] = ARM_APPROACH_SPEED
            if speeds:  # test_cycle checks a new window centre against its configured speeds
                cyc[f"{j.name}.speeds"] = [float(v) for v in speeds]
            if first[j.name].position is not None:
                cyc[f"{j.name}.position"] = first[j.name].position
    if sweep is not None:
        cyc["sweep"] = sweep
    together = len(names) > 1 and (cyc.get("sweep") or _config_value("test_cycle", "sweep", "sequential")) \
        == "simultaneous"
    for node in _JOINT_NODES:
        params[node]["joints"] = list(names)
    for node, values in (overrides or {}).items():
        params[node].update(values)
    children: list[Child] = []
    op: Operator | None = None
    heard: float | None = None
    records: list[CycleRecord] = []
    results: list[CommissionedJoint] = []
    try:
        _progress(f"ROS_DOMAIN_ID={domain_id}, loopback only; logs in {logdir}; "
                  + (f"on the {arm} arm, {_ARM_SET_NOTE}" if arm else ", ".join(f"{j.name} {j.params}" for j in setups)))
        op = _start_cell(children, params, env, logdir, names, domain_id)
        _progress(f"graph connected after {time.monotonic() - t_start:.1f} s")
        n_plan = len(plan)
        jog = False
        for k, pc in enumerate(plan):
            if pc.stage == "test" and not results:
                results = _commission_joints(setups, records, setdir, wear_calibration, plan if arm else ())
                _switch_estimator(op, children, results)
            live: dict[str, Any] = {}
            for jn, st in pc.settings.items():
                live.update({f"{jn}.temperature": st.temperature, f"{jn}.wear": st.wear})
                if arm is None:
                    live[f"{jn}.gravity_torque"] = st.gravity_torque
            if arm is not None:
                live["payload"] = float(pc.payload or 0.0)
                op.set_parameters("test_cycle", {f"{jn}.position": st.position for jn, st in pc.settings.items()},
                                  children)
            op.set_parameters("joint_sim", live, children)
            centres = ({jn: float(st.position) for jn, st in pc.settings.items() if st.position is not None}
                       if arm else {jn: _window_centre(jn) for jn in names})
            _progress(f"cycle {k + 1} of {n_plan} ({pc.stage})"
                      + (f", payload {pc.payload:g} kg: " if pc.payload is not None else ": ") + ", ".join(
                          f"{jn} {st.temperature:.1f} degC, load {st.gravity_torque:g}"
                          + (f" at {st.position:g} rad" if st.position is not None else "")
                          + (f", wear {st.wear:g}" if st.wear else "") for jn, st in pc.settings.items()))
            for attempt in (0, 1):
                if jog or arm is not None:
                    # as an operator would after a stop, with the next window's load (and on an arm before every
                    # cycle, to its new pose): jog the joints to their windows (test_cycle refuses to start a
                    # joint that overran a limit)
                    try:
                        op.jog_to(centres, children)
                    except CellError as exc:
                        _progress(f"{exc}; test_cycle will approach the windows itself")
                    if arm is not None:
                        # the drives settle at the new pose and payload before test_cycle takes the arm's
                        # positions as its approach's origin (a shoulder still settling from a payload change
                        # ran 0.023-0.029 rad off the approach line, over hold_tolerance)
                        time.sleep(ARM_SETTLE_SECONDS / float(real_time_factor))
                    jog = False
                rec = _run_cycle(op, children, pc.stage, speeds or [], names, cycle_timeout, together)
                rec.payload = pc.payload
                rec.positions = centres if arm else {}
                records.append(rec)
                if rec.usable:
                    break
                _progress(f"{pc.stage} cycle {rec.cycle_id} {rec.state} at {rec.joint}: {rec.reason}; skipped"
                          + ("" if pc.stage == "overload" or attempt else ", running it again"))
                jog = True
                if pc.stage == "overload":
                    break
            if pc.stage == "test" and records[-1].usable:
                _live_estimates(op, children, records[-1], names)
        heard = time.monotonic()
    finally:
        if op is not None:
            op.close()
        if children:
            _stop_cell(children, heard)
    if not results:  # the run ended before its test cycle
        results = _commission_joints(setups, records, setdir, wear_calibration, plan if arm else ())
    test_settings = next(pc for pc in plan if pc.stage == "test").settings
    for res in results:
        res.true_wear = test_settings[res.joint].wear
    _estimate_tests(results, [r for r in records if r.usable and r.stage == "test"])
    bags = [str(b) for b in _sort_bags([b for b in find_bags(bagdir) if b not in bags_before], records, bagdir)]
    return CommissionDemoResult(results, records, time.monotonic() - t_start, float(real_time_factor),
                                [float(s) for s in speeds or []], str(setdir), bags, str(logdir), arm=arm or "",
                                sweep=str(cyc.get("sweep") or _config_value("test_cycle", "sweep", "sequential")),
                                plan=plan)


def run_commission_in_process(
    arm: str,
    joints: int,
    out: Path,
    speeds: Sequence[float] | None = None,
    baseline_cycles: int = 6,
    test_wear: Sequence[float] = (10.0, 30.0, 40.0),
    wear_calibration: str | None = None,
    overload: bool = True,
    seed: int = 0,
) -> CommissionDemoResult:
    """The commissioning run of ``jointwear demo --commission --arm ARM`` in one process, without ROS: the same
    plan (:func:`~jointwear_ros.commission.demo.plan_arm_commissioning`) on one
    :class:`~jointwear_ros.sim.arm.ArmSim` kept from cycle to cycle (payload and temperatures set between cycles,
    the arm settling 1 s under its new payload), each cycle :func:`~jointwear_ros.simcell.run_cycle` (every joint
    at once) with the cycle's window centres, then the same commissioning and test estimates as the demo's
    (sets in ``OUT/sets``). The observations' temperature is the simulated joint's (the demo's temperature
    topic); the test cycle's estimate leaves it out. A failed cycle is skipped by name, as in the demo."""
    from dataclasses import replace

    from ..commission.demo import ARM_APPROACH_SPEED, ARM_LOADING, arm_joints, plan_arm_commissioning
    from ..sim.arm import ArmSim, arm_configs
    from ..sim.arms import arm_spec
    from ..simcell import cycle_settings, run_cycle

    t_start = time.monotonic()
    setdir = out / "sets"
    setdir.mkdir(parents=True, exist_ok=True)
    spec = arm_spec(arm)
    names = robot_joint_names(joints)
    setups = arm_joints(spec.name, names)
    plan = plan_arm_commissioning(spec.name, setups, baseline_cycles, test_wear, overload)
    speeds = list(speeds or ARM_LOADING[spec.name].speeds or _config_value("test_cycle", "speeds", []))
    cycles, observers = cycle_settings(spec.name, names, speeds=tuple(float(v) for v in speeds),
                                       approach_speed=ARM_APPROACH_SPEED)
    sim = ArmSim(spec, names, arm_configs(spec, names), seeds=[seed * 100 + i for i in range(len(names))])
    records: list[CycleRecord] = []
    results: list[CommissionedJoint] = []
    for pc in plan:
        if pc.stage == "test" and not results:
            results = _commission_joints(setups, records, setdir, wear_calibration, plan)
        sim.set_payload(float(pc.payload or 0.0))
        for jn, st in pc.settings.items():
            sim.reconfigure(jn, replace(sim[jn].config, temperature=st.temperature, wear=st.wear))
        cyc = {jn: replace(cycles[jn], position=float(st.position if st.position is not None else cycles[jn].position))
               for jn, st in pc.settings.items()}
        for attempt in (0, 1):
            _jog_sim(sim, {jn: c.position for jn, c in cyc.items()})  # as the demo's operator
            sim.step(ARM_SETTLE_SECONDS)
            run = run_cycle(sim, cyc, observers, together=True, seed=seed, cycle_id=len(records) + 1)
            done = run.state == CycleState.DONE
            rec = CycleRecord(len(records) + 1, pc.stage, "DONE" if done else CycleState(run.state).name,
                              cell_seconds=run.cell_seconds, payload=pc.payload,
                              positions={jn: c.position for jn, c in cyc.items()})
            for jn in names:
                for o in run.observations[jn]:
                    d = o.to_dict()
                    d["time"] = d.pop("stamp")
                    if not math.isfinite(d["temperature"]):  # the demo's temperature topic
                        d["temperature"] = pc.settings[jn].temperature
                    rec.observations.append(d)
            records.append(rec)
            sim.stop()
            if done:
                break
            rec.reason = run.message
            rec.joint = _named_joint(run.message, names)
            _progress(f"{pc.stage} cycle {rec.cycle_id} {rec.state} at {rec.joint}: {rec.reason}; skipped"
                      + ("" if pc.stage == "overload" or attempt else ", running it again"))
            if pc.stage == "overload":
                break
    if not results:
        results = _commission_joints(setups, records, setdir, wear_calibration, plan)
    test_settings = next(pc for pc in plan if pc.stage == "test").settings
    for res in results:
        res.true_wear = test_settings[res.joint].wear
    _estimate_tests(results, [r for r in records if r.usable and r.stage == "test"])
    return CommissionDemoResult(results, records, time.monotonic() - t_start, math.inf, [float(v) for v in speeds],
                                str(setdir), [], "", arm=spec.name, sweep="simultaneous", plan=plan)


def _jog_sim(sim: Any, targets: dict[str, float], speed: float = 0.3, tolerance: float = 0.03,
             timeout: float = 60.0) -> None:
    """Move the simulated arm to ``targets`` (rad) as :meth:`Operator.jog_to` jogs the live one: every 20 ms a
    velocity command of at most ``speed`` rad/s, slowing near the target, until each joint is within
    ``tolerance``."""
    end = sim.time + timeout
    while sim.time < end:
        pos = sim.sample()[0]
        err = [targets[j] - pos[i] for i, j in enumerate(sim.names)]
        cmd = [0.0 if abs(e) < tolerance else max(-speed, min(speed, 2.0 * e)) for e in err]
        if not any(cmd):
            break
        sim.set_commands(cmd)
        sim.step(0.02)
    sim.stop()


def _sort_bags(bags: Sequence[Path], records: Sequence[CycleRecord], bagdir: Path) -> list[Path]:
    """Move each cycle's bag (the recorder splits by cycle: ``..._cycle<id>``) into ``bagdir/baseline``,
    ``bagdir/test`` or ``bagdir/skipped`` (a cycle that did not end DONE), so that ``jointwear commission
    OUT/bags/baseline/*`` takes exactly the baseline; sets each record's ``bag``. Returns the bags' new paths."""
    by_id = {r.cycle_id: r for r in records}
    out: list[Path] = []
    for b in bags:
        _, sep, tail = b.name.rpartition("_cycle")
        rec = by_id.get(int(tail)) if sep and tail.isdigit() else None
        if rec is None:
            out.append(b)
            continue
        kind = "skipped" if not rec.usable else "test" if rec.stage == "test" else "baseline"
        dest = bagdir / kind / b.name
        dest.parent.mkdir(parents=True, exist_ok=True)
        try:
            b.rename(dest)
        except OSError as exc:
            _progress(f"could not move {b} to {dest}: {exc}")
            dest = b
        rec.bag = str(dest)
        out.append(dest)
    return out


def _window_centre(joint: str) -> float:
    """test_cycle's configured window centre of ``joint`` (its ``position``), rad."""
    value = _config_value("test_cycle", f"{joint}.position", None)
    return float(value if value is not None else _config_value("test_cycle", "position", 0.0))


def _live_estimates(op: Operator, children: Sequence[Child], rec: CycleRecord, names: Sequence[str]) -> None:
    """The live wear_estimator's estimate of each joint in the test cycle (none when it does not come)."""
    try:
        op.spin_until(lambda: op.estimated(rec.cycle_id), 60.0, children, f"the live estimates of cycle {rec.cycle_id}")
        for jn in names:
            rec.live[jn] = op.joint_report(rec.cycle_id, jn, children, wait=5.0).estimate
    except CellError as exc:
        _progress(f"{exc}; reporting the in-process estimates only")


def _commission_joints(setups: Sequence[Any], records: Sequence[CycleRecord], setdir: Path,
                       wear_calibration: str | None, plan: Sequence[Any] = ()) -> list[CommissionedJoint]:
    """Commission every joint on the observations of its baseline cycles that ended DONE; write each set to
    ``setdir/<joint>.yaml``. A joint that cannot be commissioned gets the reason in ``error``. On an arm
    (``plan``: the arm's plan), each joint gets its planned load span, and a joint whose load hardly changes
    (:func:`~jointwear_ros.commission.demo.unloaded_joints`) is commissioned without the load column, saying why."""

    from ..commission import commission
    from ..commission.demo import load_span, observation_table, unloaded_joints
    from ..estimation import set_frame_table
    from ..model import ParameterSet, SetUnits

    baseline = [r for r in records if r.usable and r.stage in ("baseline", "overload")]
    unloaded = unloaded_joints(plan) if plan else {}
    out: list[CommissionedJoint] = []
    for j in setups:
        res = CommissionedJoint(j.name, j.params, j.frame, math.nan)
        if plan:
            res.load_span = tuple(round(x, 4) for x in load_span(plan, j.name))  # type: ignore[assignment]
            res.unloaded = unloaded.get(j.name, "")
            if res.unloaded:
                _progress(res.unloaded)
        out.append(res)
        rows = [o for r in baseline for o in r.observations if o["joint_name"] == j.name]
        res.baseline_cycles = sorted({int(o["cycle_id"]) for o in rows})
        units = SetUnits("joint", j.gear_ratio, j.torque_scale) if j.joint_side else SetUnits()
        _progress(f"commissioning {j.name} ({j.params}, {j.frame}) on {len(rows)} observations of "
                  f"{len(res.baseline_cycles)} baseline cycles")
        kw: dict[str, Any] = {} if wear_calibration is None else {"wear_calibration": wear_calibration}
        path = setdir / f"{j.name}.yaml"
        try:
            table = observation_table(rows, f"{j.name} baseline", load=not res.unloaded)
            # the suite's units (motor side, normalized) to the set's, as `commission --gear-ratio` does for bags
            table = set_frame_table(table, ParameterSet("x", "", {}, units=units))
            cr = commission(table, joint=j.name, robot="demo", units=units,
                            sources=[f"cycle {c}" for c in res.baseline_cycles], **kw)
            _write_set(path, cr, j.name)
            if plan and not res.unloaded and not _set_loads(path):
                # on an arm: loads that changed too little to determine the load terms (an infinite variance:
                # the set would not load); commissioned again without the load column, saying so
                why = _set_loads(path, reason=True)
                lo, hi = res.load_span or (math.nan, math.nan)
                res.unloaded = (f"{j.name}: its baseline's loads ({lo:.3f}-{hi:.3f} planned) did not determine its "
                                f"load terms ({why}); commissioned without the load column")
                _progress(res.unloaded)
                table = set_frame_table(observation_table(rows, f"{j.name} baseline", load=False),
                                        ParameterSet("x", "", {}, units=units))
                cr = commission(table, joint=j.name, robot="demo", units=units,
                                sources=[f"cycle {c}" for c in res.baseline_cycles], **kw)
                _write_set(path, cr, j.name)
        except JointwearError as exc:
            res.error = f"commissioning {j.name} failed: {exc}"
            _progress(res.error)
            continue
        res.parameter_set = str(path)
        res.commission = cr.to_dict(str(path))
        _progress(f"{j.name}: wrote {path} (verdict {cr.verdict}, CV RMSE {cr.cv_rmse:.3g}, wear calibration "
                  f"{cr.wear.label})")
    return out


def _write_set(path: Path, cr: Any, joint: str) -> None:
    """Write a commissioning result's set to ``path``."""
    import yaml

    from ..model import parameter_set_document

    path.write_text(yaml.safe_dump(parameter_set_document(cr.parameter_set(joint)), sort_keys=False,
                                   allow_unicode=True), encoding="utf-8")


def _set_loads(path: Path, reason: bool = False) -> Any:
    """Whether the set at ``path`` loads (``reason``: why not, "" when it does)."""
    from ..model import load_parameter_set_info

    try:
        load_parameter_set_info(str(path))
    except JointwearError as exc:
        return str(exc).removeprefix(f"{path}: ") if reason else False
    return "" if reason else True


def _switch_estimator(op: Operator, children: Sequence[Child], joints: Sequence[CommissionedJoint]) -> None:
    """The live wear_estimator takes each commissioned set (``<joint>.params``, a live parameter) and leaves the
    observations' temperature aside, as for a joint whose temperature is not known."""
    values: dict[str, Any] = {f"{j.joint}.params": str(Path(j.parameter_set).resolve()) for j in joints
                              if j.parameter_set}
    values["use_measured_temperature"] = False
    try:
        op.set_parameters("wear_estimator", values, children)
    except CellError as exc:
        _progress(f"the live estimator keeps its sets: {exc}")


def _estimate_tests(joints: Sequence[CommissionedJoint], tests: Sequence[CycleRecord]) -> None:
    """Each joint's test cycle (the last that ended DONE), temperature left out, estimated with its commissioned
    set and with ref-2011r by the joint estimator."""
    from ..commission import estimate_cycles
    from ..commission.demo import observation_table
    from ..model import load_parameter_set_info

    ref = load_parameter_set_info("ref-2011r")
    noise = float(_config_value("wear_estimator", "observation_noise_std", 0.0015))
    test = tests[-1] if tests else None
    for res in joints:
        if test is not None:
            live = test.live.get(res.joint, {})
            res.live_estimate, res.live_std = live.get("wear"), live.get("wear_std")
        if res.error or res.parameter_set is None:
            continue
        rows = [o for o in (test.observations if test else []) if o["joint_name"] == res.joint]
        if not rows:
            res.error = (f"{res.joint}: no observations of test cycle {test.cycle_id}" if test is not None
                         else f"{res.joint}: every test cycle failed")
            continue
        # as the cell's wear_estimator sees them: no temperature, its observation_noise_std added to tau_f_std
        table = observation_table(rows, f"{res.joint} test cycle {test.cycle_id}",  # type: ignore[union-attr]
                                  temperature=False, noise_std=noise)
        try:
            e = estimate_cycles([("test", res.joint, table)], load_parameter_set_info(res.parameter_set), "joint")
            r = e[-1].result
            res.estimate, res.std, res.temperature = float(r.wear), float(r.wear_std), float(r.temperature)
        except JointwearError as exc:
            res.error = f"{res.joint}: the commissioned set refused the test cycle: {exc}"
        try:
            r = estimate_cycles([("test", res.joint, table)], ref, "joint")[-1].result
            res.reference_estimate, res.reference_std = float(r.wear), float(r.wear_std)
        except JointwearError as exc:
            _progress(f"{res.joint}: ref-2011r refused the test cycle: {exc}")


def _int_arg(value: int, flag: str, lo: int, hi: int) -> int:
    if not lo <= value <= hi:
        raise UsageError(f"{flag}: {value} is outside {lo}-{hi}")
    return value


def cmd_demo_commission(args: argparse.Namespace) -> int:
    for flag, value in (("--wear", args.wear), ("--temperature", args.temperature), ("--method", args.method)):
        if value is not None:
            raise UsageError(f"{flag}: the commissioning demo sets it per cycle (use --test-wear for the test cycle)")
    n = _int_arg(args.joints if args.joints is not None else 6, "--joints", 1, MAX_DEMO_JOINTS)
    if args.payload is not None:
        raise UsageError("--payload: the commissioning demo sets the payload per cycle (0 up to the arm's "
                         "commissioning payload, and one overload)")
    arm, _ = _arm_args(args, n)
    sweep = args.sweep or ("simultaneous" if arm is not None and n > 1 else None)
    k = _int_arg(args.baseline_cycles, "--baseline-cycles", MIN_BASELINE_CYCLES, 40)
    test_wear = parse_float_list(args.test_wear, "--test-wear") if "," in args.test_wear else [
        parse_float(args.test_wear, "--test-wear")]
    for w in test_wear:
        if not 0.0 <= w <= 100.0:
            raise UsageError(f"--test-wear: {w:g} is outside 0-100")
    speeds = parse_float_list(args.speeds, "--speeds") if args.speeds is not None else None
    if speeds is not None:
        if any(not s > 0 for s in speeds):
            raise UsageError(f"--speeds: every speed must be > 0 rad/s (got {args.speeds})")
        if len(set(speeds)) < 5:
            raise UsageError(f"--speeds: {len(set(speeds))} distinct speed(s); commissioning needs at least 5")
    rtf = (parse_float(args.real_time_factor, "--real-time-factor") if args.real_time_factor is not None
           else ARM_COMMISSION_REAL_TIME_FACTOR if arm is not None else COMMISSION_REAL_TIME_FACTOR)
    if not 0.01 <= rtf <= 100.0:
        raise UsageError(f"--real-time-factor: {rtf:g} is outside 0.01-100")
    timeout = parse_float(args.timeout, "--timeout") if args.timeout is not None else COMMISSION_CYCLE_TIMEOUT
    if not 0 < timeout <= 86400:
        raise UsageError(f"--timeout: {timeout:g} must be more than 0 and at most 86400 s")
    wc = args.wear_calibration
    if wc is not None and wc not in ("paper", "relative") and not Path(wc).is_file():
        raise UsageError(f"--wear-calibration {wc!r}: use paper, relative or an existing calibration FILE")
    _check_domain_id(args.domain_id)
    overrides = parse_overrides(args.set)
    check_overrides(overrides)
    if any("joints" in overrides.get(node, {}) for node in _JOINT_NODES):
        raise UsageError("--set NODE.joints: the demo sets the joints of every node from --joints N")
    check_output_dir(args.out, "--out")
    res = run_commission_demo(n, Path(args.out), speeds, k, test_wear, wc, not args.no_overload, rtf, timeout,
                              args.domain_id, overrides, arm=arm, sweep=sweep)
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):  # the same document --json prints
        print_json(res.as_dict())
    Path(args.out).mkdir(parents=True, exist_ok=True)
    (Path(args.out) / "commission.json").write_text(buf.getvalue(), encoding="utf-8")
    failed = [j for j in res.joints if j.error or j.estimate is None]
    rc = 1 if failed else 0
    for j in failed:
        skipped = "; ".join(f"cycle {r.cycle_id} {r.state} at {r.joint} (test_cycle: {r.reason})" for r in res.skipped)
        print(f"error: {j.error or j.joint + ': no estimate'}" + (f" [skipped: {skipped}]" if skipped else ""),
              file=sys.stderr)
    if args.json:
        print_json(res.as_dict())
        return rc
    _print_commission(res)
    return rc


def _pm(x: float | None, s: float | None) -> str:
    return "none" if x is None else f"{x:.2f} ± {s:.2f}" if s is not None else f"{x:.2f}"


def _z(z: float | None) -> str:
    return "" if z is None else f"{z:+.1f}"


def _print_commission(res: CommissionDemoResult) -> None:
    rows = []
    for j in res.joints:
        c = j.commission
        row = [j.joint, j.params, f"{j.true_wear:g}", _pm(j.estimate, j.std), _z(j.z),
               _pm(j.reference_estimate, j.reference_std), _z(j.reference_z), c.get("verdict", ""),
               str(len(j.baseline_cycles))]
        if res.arm:
            span = f"{j.load_span[0]:.2f}-{j.load_span[1]:.2f}" if j.load_span else ""
            row.append(f"{span} {'identified' if j.load_identified else 'not identified'}".strip())
        rows.append(row)
    on = f" on the {res.arm} arm, {len(res.joints)} joints swept {res.sweep}ly" if res.arm else ""
    print(f"commissioned {len(res.joints)} joint(s){on}; test cycle at unknown temperature, joint estimator")
    if res.arm:
        print(f"({_ARM_SET_NOTE}; the load changed by payload and pose between cycles)")
    print(format_table(["joint", "simulated", "true w", "commissioned", "z", "ref-2011r (before)", "z ref",
                        "verdict", "cycles"] + (["load (planned), its terms"] if res.arm else []), rows))
    for j in res.joints:
        if res.arm and j.load_note:
            print(f"{j.joint}: load not identified: {j.load_note.removeprefix(j.joint + ': ')}")
    for r in res.skipped:
        print(f"skipped {r.stage} cycle {r.cycle_id}: {r.state} at {r.joint} (test_cycle: {r.reason})")
    for j in res.joints:
        if j.parameter_set:
            print(f"{j.joint}: {j.parameter_set} (wear calibration {j.commission.get('wear_calibration')})")
        if j.error:
            print(f"{j.joint}: {j.error}")
    cell = f"{res.cell_seconds:.0f} s of cell time (sim), " if math.isfinite(res.cell_seconds) else ""
    kinds = sorted({str(Path(b).parent) for b in res.bags})
    print(f"bags: {len(res.bags)} in {', '.join(kinds) or '-'}; logs: {res.logs}")
    print(f"{len(res.cycles)} cycles, {cell}{res.wall_seconds:.1f} s wall at {res.real_time_factor:g}x real time; "
          f"the --json document: {Path(res.sets_dir).parent / 'commission.json'}")
