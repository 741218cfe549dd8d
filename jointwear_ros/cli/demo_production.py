"""``jointwear demo --production``: wear from the robot's own program, end to end, without a test cycle.

1. **The production.** The rigid-body arm (:mod:`jointwear_ros.sim.production`, in this process) runs its
   pick-and-place program for ``shifts`` shifts of ``cycles`` cycles at known wear per joint, a part carried
   one way (``payload`` kg), self-heating joints and a product mix (the program's speed override cycle by
   cycle, :data:`SPEED_MIX`); what the cell's ``/joint_states`` and ``/joint_temperature`` carried is written
   to an MCAP bag (:func:`~jointwear_ros.io.production_bag.record_production`), stamped from :data:`DEMO_START`.
2. **Live.** The plant's nodes run as processes on a loopback ROS graph of their own: ``production_observer``
   (with the arm's model and the part's mass), ``wear_estimator``, ``cycle_on_demand`` and the ``recorder``;
   the bag is played onto the graph with ``/clock`` (``jointwear replay --publish``, ``rate`` x real time),
   the operator ends the last shift (``/production_observer/end_shift``) once the observer has every sample,
   and each shift's production estimates (``WearEstimate`` with ``source: production``) are collected. Nothing
   stopped the program: no test cycle ran.
3. **Replay equals live.** The recorded bag is read back: the production observer's core over its joint states
   with the settings the live node recorded (``jointwear data from-production``) gives the live observations
   field for field, and the wear monitor over them (``jointwear replay``) the live estimates.

The summary (and ``--json``): per joint the last shift's production estimate with its std against the true
wear, or why the shift could not tell (a joint the program never moves at an informative speed says so), the
pass counts (seen, paired, of which corrected for the part, rejected by reason), the cycle requests the
on-demand policy made, and whether the replay equals live.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputDataError
from . import UsageError

__all__ = ["DEMO_START", "PRODUCTION_NODES", "PRODUCTION_WEAR", "SPEED_MIX", "ProductionDemoResult",
           "cmd_demo_production", "run_production_demo"]

#: The true wear of each joint in the demo, per arm (the held flange joint last).
PRODUCTION_WEAR = {"ur5": (10.0, 25.0, 40.0, 5.0, 30.0, 0.0), "panda": (10.0, 25.0, 40.0, 5.0, 30.0, 15.0, 0.0)}
#: The program's speed override cycle by cycle: a product mix (one product at full speed, a fragile one at
#: half, a light one at 1.5x), so each joint cruises at several speeds within a shift (docs/production.md).
SPEED_MIX = (1.0, 0.5, 1.5)
#: The stamp of the production's time 0 (2026-09-21 06:00 UTC, the start of a morning shift): fixed, so
#: the demo's bags are the same run after run.
DEMO_START = 1_790_056_800.0
#: The plant's nodes the demo starts (no joint_sim, no test_cycle: the robot is the recorded program).
PRODUCTION_NODES = ("recorder", "wear_estimator", "production_observer", "cycle_on_demand")
#: the nodes that queue the whole played production (Fast DDS holds more than 5000 samples a reader only with
#: deep_queue_env's profile)
DEEP_QUEUE_NODES = ("recorder", "production_observer")


def _progress(text: str) -> None:
    print(f"[demo] {text}", file=sys.stderr, flush=True)


@dataclass
class ProductionDemoResult:
    """What ``demo --production`` found (:meth:`as_dict` is the ``--json`` document)."""

    arm: str
    payload: float
    shifts: int
    cycles: int
    names: list[str]
    true_wear: list[float]
    #: per joint the newest live production estimate: (shift, wear, std, level name) or None
    estimates: dict[str, tuple[int, float, float, str] | None]
    #: per joint why the last shift could not tell (from the production observer's DONE or the estimator)
    reasons: dict[str, str]
    #: per joint the pass counts summed over the shifts
    passes: dict[str, dict[str, Any]]
    requests: list[dict[str, str]]
    production_bag: str
    recorded_bag: str | None
    replay: dict[str, Any] = field(default_factory=dict)
    wall_seconds: float = math.nan
    sim_seconds: float = math.nan
    logs: str = ""
    failure: str = ""

    @property
    def replay_equals_live(self) -> bool:
        return bool(self.replay.get("observations_equal")) and bool(self.replay.get("estimates_equal"))

    def z(self, joint: str) -> float | None:
        e = self.estimates.get(joint)
        if e is None or not (math.isfinite(e[1]) and math.isfinite(e[2]) and e[2] > 0):
            return None
        return (e[1] - self.true_wear[self.names.index(joint)]) / e[2]

    def as_dict(self) -> dict[str, Any]:
        wear = []
        for j in self.names:
            e = self.estimates.get(j)
            told = e is not None and math.isfinite(e[1])
            z = self.z(j)
            wear.append({"joint": j, "estimate": e[1] if told else None, "std": e[2] if told else None,  # type: ignore[index]
                         "source": "production", "shift": e[0] if e is not None else None,
                         "level": e[3] if e is not None else None, "z": None if z is None else round(z, 3),
                         "reason": self.reasons.get(j, "") if not told else ""})
        seen = sum(p["seen"] for p in self.passes.values())
        paired = sum(p["paired"] for p in self.passes.values())
        return {
            "arm": self.arm, "payload": self.payload, "shifts": self.shifts, "cycles_per_shift": self.cycles,
            "speed_mix": list(SPEED_MIX), "wear": wear,
            "true_wear": [{"joint": j, "wear": w} for j, w in zip(self.names, self.true_wear, strict=True)],
            "passes": [{"joint": j, **self.passes[j]} for j in self.names],
            "passes_seen": seen, "passes_paired": paired,
            "passes_rejected": sum(p["rejected_total"] for p in self.passes.values()),
            "cycle_requests": self.requests, "test_cycles_run": 0, "production_stopped_seconds": 0.0,
            "replay_equals_live": self.replay_equals_live, "replay": self.replay,
            "production_bag": self.production_bag, "bag": self.recorded_bag, "logs": self.logs,
            "sim_seconds": round(self.sim_seconds, 1), "wall_seconds": round(self.wall_seconds, 1),
            "failure": self.failure or None,
        }


def _counts(shifts: list[Any], names: list[str]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    for j in names:
        rej: dict[str, int] = {}
        seen = paired = model = corrected = 0
        for s in shifts:
            c = s.joints[j]
            seen += c.passes
            paired += c.paired
            model += c.model
            corrected += len(c.payload_kg)
            for k, v in c.rejected.items():
                rej[k] = rej.get(k, 0) + v
        out[j] = {"seen": seen, "paired": paired, "payload_corrected": corrected, "model": model,
                  "rejected": dict(sorted(rej.items())),
                  "rejected_total": sum(v for k, v in rej.items() if k != "held still")}
    return out


def _same_observations(live: list[dict[str, Any]], offline: list[Any]) -> tuple[bool, str]:
    """The live production observations (recorded) against the core's over the same samples, field by field."""
    from ..io.bags import OBSERVATION_FIELDS

    key = [f for f in OBSERVATION_FIELDS if f not in ("stamp",)]
    a = sorted((tuple(o[f] for f in key) for o in live), key=repr)
    b = sorted((tuple(getattr(o, f) for f in key) for o in offline), key=repr)
    if len(a) != len(b):
        return False, f"{len(a)} live observation(s), {len(b)} offline"
    bad = sum(1 for x, y in zip(a, b, strict=True) if x != y)
    return bad == 0, f"{len(a)} observation(s), {bad} differ"


def run_production_demo(out: Path, *, arm: str = "ur5", shifts: int = 2, cycles: int = 3,
                        wear: list[float] | None = None, payload: float = 2.0, rate: float = 3.0,
                        timeout: float = 300.0, domain_id: int, seed: int = 0) -> ProductionDemoResult:
    """The production demo (module docstring) on ROS domain ``domain_id``."""
    from ..contract import CycleState, level_name
    from ..io.bags import find_bags
    from ..io.params import node_params_from_yaml
    from ..io.production_bag import ShiftClock, production_shifts, read_production, record_production
    from ..nodes.cell import Operator, start_child, stop_children
    from ..nodes.runtime import deep_queue_env, loopback_env
    from ..observer import ProductionConfig
    from ..replay import replay_bag
    from ..resources import config_path
    from ..settings import from_mapping
    from ..sim.arm import ArmModel
    from ..sim.arms import arm_spec
    from ..sim.production import SelfHeating, pick_and_place, run_production
    from .data_cmd import production_settings

    t_wall = time.monotonic()
    spec = arm_spec(arm)
    names = [f"joint_{i}" for i in range(1, len(spec.joints) + 1)]
    true = [float(w) for w in (wear if wear is not None else PRODUCTION_WEAR[spec.name])]
    if len(true) != len(names):
        raise UsageError(f"--wear: the {spec.name} has {len(names)} joints; give {len(names)} values or one")
    logdir, bagdir = out / "logs", out / "bags"
    logdir.mkdir(parents=True, exist_ok=True)
    bagdir.mkdir(parents=True, exist_ok=True)
    stamp = time.strftime("%Y%m%d_%H%M%S")
    # 1. the production, simulated in this process and written as the cell's traffic
    _progress(f"simulating the {spec.name}'s pick-and-place: {shifts} shift(s) x {cycles} cycles, a {payload:g} kg "
              f"part carried one way, speed override {'/'.join(f'{x:g}' for x in SPEED_MIX)} cycle by cycle, "
              f"wear {', '.join(f'{w:g}' for w in true)}")

    def said(shift: int, cycle: int, sim_time: float) -> None:
        _progress(f"  shift {shift + 1}, cycle {cycle} done at {sim_time:.0f} s of production")

    run = run_production(spec.name, pick_and_place(spec.name, payload=payload), shifts=shifts, cycles=cycles,
                         wear=true, temperature=40.0, heating=SelfHeating(), seed=seed, speed_override=SPEED_MIX,
                         progress=said)
    names = list(run.names)
    prod_bag = record_production(run, bagdir / f"production_{stamp}", start=DEMO_START)
    sim_seconds = float(run.t[-1] - run.t[0])
    n_samples = int(run.t.size)
    _progress(f"{sim_seconds:.0f} s of production, {n_samples} joint states: {prod_bag}")
    origin = DEMO_START + float(run.shift_start[0])
    shift_seconds = (float(run.shift_start[1] - run.shift_start[0]) if len(run.shift_start) > 1
                     else float(run.t[-1] - run.shift_start[0]) + 1.0)
    # 2. the plant's nodes, live, the bag played onto their graph
    domain = int(domain_id)
    env = loopback_env(domain)
    before = set(find_bags(bagdir))
    params: dict[str, dict[str, Any]] = {
        # the recorder too takes every played state into its queue (a starved recorder falls behind as the
        # observer does); both get deep_queue_env below
        "recorder": {"use_sim_time": True, "output_dir": str(bagdir.resolve()), "split": "session",
                     "queue_depth": max(10000, n_samples)},
        "wear_estimator": {"use_sim_time": True, "joints": names},
        "production_observer": {"use_sim_time": True, "joints": names, "arm": spec.name, "payload": float(payload),
                                "shift_seconds": shift_seconds, "shift_origin": origin, "shift_idle": 3600.0,
                                # the whole played production fits its queue: an observer the machine starves of
                                # CPU falls behind and catches up, it drops nothing (3751 of 28205 joint states
                                # were dropped with two test workers on two cores); Fast DDS holds more than
                                # 5000 only with deep_queue_env's profile
                                "qos_overrides./joint_states.subscription.depth": max(10000, n_samples),
                                "qos_overrides./joint_temperature.subscription.depth": max(10000, n_samples)},
        "cycle_on_demand": {"use_sim_time": True},
    }
    children: list[Any] = []
    player: subprocess.Popen[bytes] | None = None
    op: Any = None
    statuses: list[Any] = []
    requests: list[dict[str, str]] = []
    po_samples: dict[str, tuple[int, int, int]] = {}  # per joint: samples taken, held, lost (its diagnostics)
    failure = ""
    try:
        _progress(f"ROS_DOMAIN_ID={domain}, loopback only; logs in {logdir}")
        for name in PRODUCTION_NODES:
            children.append(start_child(name, params[name], deep_queue_env(env) if name in DEEP_QUEUE_NODES
                                        else env, logdir))
            _progress(f"started {name} (pid {children[-1].proc.pid})")
        op = Operator(names, domain, progress=_progress)
        from diagnostic_msgs.msg import DiagnosticArray
        from jointwear_msgs.msg import TestCycleStatus
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from std_srvs.srv import Trigger

        from ..contract import status_from_msg

        rel = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
        latched = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
        op.node.create_subscription(TestCycleStatus, "/production/status",
                                    lambda m: statuses.append(status_from_msg(m)), rel)

        def on_request(msg: Any) -> None:
            for s in msg.status:
                requests.append({"joint": s.hardware_id, "reason": s.message,
                                 **{v.key: v.value for v in s.values if v.key == "kind"}})

        def on_diag(msg: Any) -> None:
            for s in msg.status:
                if s.name.startswith("production_observer: "):
                    v = {kv.key: kv.value for kv in s.values}
                    if all(v.get(k, "").isdigit() for k in ("samples", "held", "lost_messages")):
                        po_samples[s.name] = (int(v["samples"]), int(v["held"]), int(v["lost_messages"]))

        op.node.create_subscription(DiagnosticArray, "/jointwear/cycle_request", on_request, latched)
        op.node.create_subscription(DiagnosticArray, "/diagnostics", on_diag, rel)
        end_client = op.node.create_client(Trigger, "/production_observer/end_shift")
        # the recorder subscribes to the played topics once the player advertises them (its graph scans run on
        # the wall clock); the player waits for it and the observer
        op.spin_until(lambda: "production_observer" in op.subscribers("/joint_states")
                      and "wear_estimator" in op.subscribers("/jointwear/friction_observations")
                      and "cycle_on_demand" in op.subscribers("/jointwear/wear_estimate")
                      and end_client.service_is_ready(), 60.0, children, "the nodes to connect")
        _progress(f"graph connected after {time.monotonic() - t_wall:.1f} s; playing the production at {rate:g}x")
        cmd = [sys.executable, "-m", "jointwear_ros", "replay", str(prod_bag), "--publish", "--rate", f"{rate:g}",
               # two subscribers on each topic: production_observer and the recorder (which subscribes once it
               # sees the player's topics; a recorder that came late lost the production's first seconds)
               "--topics", "/joint_states,/joint_temperature", "--wait-for-subscribers", "2", "--delay", "1"]
        with (logdir / "replay.log").open("wb") as fh:
            player = subprocess.Popen(cmd, env=dict(env), stdout=fh, stderr=subprocess.STDOUT,
                                      stdin=subprocess.DEVNULL)
            shown = [0]

            def tick() -> None:
                done = {s.cycle_id for s in statuses if s.state == CycleState.DONE}
                if len(done) != shown[0]:
                    shown[0] = len(done)
                    _progress(f"production shift {max(done)} ended: its observations and estimates are out")

            op.spin_until(lambda: player.poll() is not None, timeout, children, "the production to play", tick)
        if player.returncode != 0:
            raise InputDataError(f"playing {prod_bag} failed (exit {player.returncode}); see {logdir / 'replay.log'}")
        # every joint state is sent; the observer holds the newest reorder_margin of them until end_shift flushes
        # them: wait until each one is taken, held or reported lost (its diagnostics say so every
        # diagnostics_period; a loaded observer works through its queue first), or the counts stood still 15 s
        steady: dict[str, Any] = {"value": None, "since": time.monotonic()}

        def caught_up() -> bool:
            now = min(po_samples.values()) if po_samples else None
            if now != steady["value"]:
                steady.update(value=now, since=time.monotonic())
            return now is not None and (sum(now) >= n_samples or time.monotonic() - steady["since"] > 15.0)

        op.spin_until(caught_up, 180.0, children, f"production_observer to take the {n_samples} joint states")
        taken, held, lost = steady["value"]
        unheard = n_samples - taken - held - lost  # dropped from its full queue, which no counter sees
        _progress(f"production_observer took {taken} of {n_samples} joint states, {held} held for their temperatures "
                  f"until the shift ends" + (f", {lost} lost on the way" if lost else "")
                  + (f"; {unheard} never reached it (its queue overflowed while it was behind: CPU starved?)"
                     if unheard > 0 else ""))
        fut = end_client.call_async(Trigger.Request())
        op.spin_until(fut.done, 30.0, children, "the answer of /production_observer/end_shift")
        _progress(f"the operator ended the last shift: {fut.result().message}")
        last = max(s.cycle_id for s in statuses if s.state == CycleState.RUNNING)

        def estimated() -> bool:
            done = {s.joint_name: s for s in statuses if s.cycle_id == last and s.state == CycleState.DONE}
            if set(done) != set(names):
                return False
            got = {(e.joint_name, e.cycle_id) for e in op.estimates if e.source == "production"}
            return all((j, last) in got for j in names if done[j].speeds_total > 0)

        op.spin_until(estimated, 60.0, children, f"the estimates of production shift {last}", tick)
        time.sleep(1.5)  # cycle_on_demand gathers its asks for 1 s; the recorder gets the last messages
        op.ex.spin_once(timeout_sec=0.2)
    except Exception as exc:  # a node died or timed out: the result says so, the nodes are stopped
        failure = str(exc)
        _progress(f"failed: {failure}")
    finally:
        if player is not None and player.poll() is None:
            player.terminate()
        if op is not None:
            estimates_msgs = list(op.estimates)
            op.close()
        else:
            estimates_msgs = []
        if children:
            _progress("stopping the nodes")
            stop_children([c for c in children if c.name != "recorder"], progress=_progress)
            stop_children([c for c in children if c.name == "recorder"], progress=_progress)
    bags = [b for b in find_bags(bagdir) if b not in before and not b.name.startswith("production_")]
    recorded = str(bags[-1]) if bags else None
    # the newest production estimate per joint, and why a joint could not tell
    estimates: dict[str, tuple[int, float, float, str] | None] = {j: None for j in names}
    for e in estimates_msgs:
        if e.source == "production" and e.joint_name in estimates:
            old = estimates[e.joint_name]
            if old is None or e.cycle_id >= old[0]:
                estimates[e.joint_name] = (int(e.cycle_id), float(e.wear), float(e.wear_std),
                                           level_name(int(e.level)))
    reasons = {}
    for j in names:
        done = [s for s in statuses if s.joint_name == j and s.state == CycleState.DONE]
        if done and done[-1].speeds_total == 0:
            reasons[j] = done[-1].message
        elif estimates[j] is not None and not math.isfinite(estimates[j][1]):  # type: ignore[index]
            reasons[j] = f"{j}: the estimator could not tell from this shift (see wear_estimator.log)"
    # 3. replay equals live: the core over the same samples with the recorded settings, the monitor over them
    replay: dict[str, Any] = {}
    offline_shifts: list[Any] = []
    if recorded is not None and not failure:
        values, _used = production_settings([recorded], tuple(names))
        configs = [from_mapping(ProductionConfig, values, joint=j) for j in names]
        samples = read_production([recorded])  # the joint states as the plant recorded them
        mass = float(values.get("payload", 0.0))  # type: ignore[arg-type]
        models = ArmModel(str(values["arm"]), names).observer_models(
            payload_mass=mass if mass > 0 else None, model_based=bool(values.get("model_based", False)))
        clock = ShiftClock(float(values["shift_seconds"]), float(values["shift_origin"]))  # type: ignore[arg-type]
        offline_shifts = production_shifts(samples, configs, clock=clock, models=models)
        rep = replay_bag(recorded, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
                         node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))
        live_obs = [o for o in rep.recorded_observations if o.get("source") == "production"]
        same, what = _same_observations(live_obs, [o for s in offline_shifts for o in s.observations])
        est = rep.comparison()["estimates"]
        replay = {"observations_equal": same, "observations": what,
                  "estimates_equal": bool(est["paired"]) and est["matched"] == est["paired"] == est["recorded"],
                  "estimates_compared": est["paired"], "estimates_recorded": est["recorded"],
                  "estimates_max_abs_diff": est["max_abs_diff"], "estimates_differ": est["differ"][:5]}
    passes = _counts(offline_shifts, names) if offline_shifts else {
        j: {"seen": 0, "paired": 0, "payload_corrected": 0, "model": 0, "rejected": {}, "rejected_total": 0}
        for j in names}
    return ProductionDemoResult(
        arm=spec.name, payload=float(payload), shifts=shifts, cycles=cycles, names=names, true_wear=true,
        estimates=estimates, reasons=reasons, passes=passes, requests=requests, production_bag=str(prod_bag),
        recorded_bag=recorded, replay=replay, wall_seconds=time.monotonic() - t_wall, sim_seconds=sim_seconds,
        logs=str(logdir), failure=failure)


def cmd_demo_production(args: argparse.Namespace, domain_id: int) -> int:
    """``jointwear demo --production``: run it, print the summary (or ``--json``); exit 0, 1 when the live run
    failed or the replay differs from it."""
    from .common import parse_float, parse_float_list, print_json

    arm = args.arm or "ur5"
    if arm not in PRODUCTION_WEAR:
        raise UsageError(f"--arm: the production demo runs on an arm ({', '.join(PRODUCTION_WEAR)}), not {arm!r}")
    n = len(PRODUCTION_WEAR[arm])
    wear = None
    if args.wear is not None:
        wear = parse_float_list(args.wear, "--wear")
        if len(wear) == 1:
            wear = wear * n
        if len(wear) != n or not all(0.0 <= w <= 100.0 for w in wear):
            raise UsageError(f"--wear: {n} values (or one) between 0 and 100 for the {arm}'s joints")
    payload = 2.0 if args.payload is None else parse_float(args.payload, "--payload")
    if not 0.0 <= payload <= 5.0:
        raise UsageError(f"--payload: {payload:g} kg; the demo's part weighs 0-5 kg")
    rate = 3.0 if args.real_time_factor is None else parse_float(args.real_time_factor, "--real-time-factor")
    if not 0.1 <= rate <= 20.0:
        raise UsageError(f"--real-time-factor: {rate:g} is outside 0.1-20 for the production demo")
    timeout = 300.0 if args.timeout is None else parse_float(args.timeout, "--timeout")
    if not timeout > 0:
        raise UsageError(f"--timeout: {timeout:g} must be > 0 s")
    if not 1 <= args.shifts <= 20 or not 1 <= args.cycles <= 50:
        raise UsageError("--shifts 1-20 and --cycles 1-50 (each cycle is about 15 s of production)")
    res = run_production_demo(Path(args.out if args.out != "out/demo" else "out/production"), arm=arm,
                              shifts=args.shifts, cycles=args.cycles, wear=wear, payload=payload, rate=rate,
                              timeout=timeout, domain_id=domain_id)
    rc = 1 if res.failure or not res.replay_equals_live else 0
    if args.json:
        print_json(res.as_dict())
        return rc
    d = res.as_dict()
    print(f"production on the {res.arm}: {res.shifts} shift(s) x {res.cycles} pick-and-place cycles "
          f"({res.sim_seconds:.0f} s), a {res.payload:g} kg part carried one way; no test cycle ran, the program never "
          f"stopped")
    print(f"{'joint':8} {'true':>5} {'production estimate':>20} {'z':>6} {'level':>6}  passes seen/paired (+part)/rejected")
    for w, p in zip(d["wear"], d["passes"], strict=True):
        est = (f"{w['estimate']:.1f} ± {w['std']:.1f}" if w["estimate"] is not None else "cannot tell")
        z = f"{w['z']:+.2f}" if w["z"] is not None else "-"
        tw = res.true_wear[res.names.index(w["joint"])]
        print(f"{w['joint']:8} {tw:5.1f} {est:>20} {z:>6} {w['level'] or '-':>6}  {p['seen']}/{p['paired']} "
              f"(+{p['payload_corrected']})/{p['rejected_total']}"
              + (f"  {w['reason']}" if w["reason"] else ""))
    for r in res.requests:
        print(f"cycle_on_demand asks for the test cycle: {r['reason']}")
    if not res.requests:
        print("cycle_on_demand: no test cycle asked for (the production estimates decide every level)")
    rp = res.replay
    print(f"replay equals live: {'yes' if res.replay_equals_live else 'NO'} (observations: "
          f"{rp.get('observations', '-')}; estimates compared {rp.get('estimates_compared', 0)}, max |diff| "
          f"{rp.get('estimates_max_abs_diff')})")
    print(f"bags: {res.production_bag} (the cell's joint states), {res.recorded_bag} (the plant's traffic); "
          f"logs {res.logs}; {res.wall_seconds:.0f} s wall")
    if res.failure:
        print(f"failed: {res.failure}", file=sys.stderr)
    return rc

