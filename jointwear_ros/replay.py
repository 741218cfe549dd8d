"""Offline replay: a recorded bag through the live nodes' pure cores, in log-time order.

:func:`replay_bag` reads a rosbag2/MCAP bag once (no ROS runtime), feeds its ``/joint_states``,
``/test_cycle/status`` and temperature messages to a :class:`~jointwear_ros.observer.RobotObserver`
and the observations to a :class:`~jointwear_ros.monitor.RobotMonitor`: the same per-joint cores
and routing the ``friction_observer`` and ``wear_estimator`` nodes run live (docs/robot.md: each
JointState split by name, each status to its ``joint_name``'s cores, each temperature to its
``header.frame_id``'s), and compares what it gets with the observations and estimates the bag
recorded, per (joint, cycle). ``jointwear replay``, ``jointwear history import --reestimate``
and the fleet re-analysis use it; the live nodes never do.

**Production.** The estimator's production input replays like live: each ``/production/status``
(the production observer's per-joint RUNNING → DONE of a shift, the estimator's
``production_status_topic``) goes to the monitor as a production shift's status, and each recorded
``FrictionObservation`` whose ``source`` is ``production`` to the monitor at its log time, as the live
estimator heard it; the estimates are keyed and compared by (joint, source, cycle id). The production
observations are the recorded ones (this replay re-derives only the test cycle's observations from
``/joint_states``), so they are not among the compared observations.

**Which joints.** The joints the live observer served, from the bag's ``/parameter_events``
(its ``joints``, or its ``joint_name`` when it ran one joint); when the bag has no recorded
parameters (or they are ignored), every joint named by the bag's test-cycle statuses; when
those name none, the configured ``joints`` (or ``joint_name``). Per-joint settings
(``<joint>.<setting>``, recorded or configured) apply to their joint.
"""

from __future__ import annotations

import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .contract import Source, observation_from_msg, stamp_to_seconds, status_from_msg
from .errors import InputDataError, ParameterError
from .io.bags import (
    ESTIMATE_TYPE,
    JOINT_STATE_TYPE,
    OBSERVATION_TYPE,
    STATUS_TYPE,
    TEMPERATURE_TYPE,
    check_bag_path,
    estimate_fields,
    read_bag_once,
    temperature_value,
)
from .io.params import nest
from .io.recover import check_bag
from .monitor import MonitorConfig, RobotMonitor
from .observer import FrictionObservationData, ObserverConfig, ObserverOutput, RobotObserver
from .settings import from_mapping

__all__ = ["MATCH_TOLERANCE", "ReplayResult", "replay_bag"]

#: a replayed value matches the recorded one within this relative tolerance (of max(1, |recorded|));
#: the same cores on the same data give the same numbers, so anything more is a difference
MATCH_TOLERANCE = 1e-9


@dataclass
class ReplayResult:
    """What :func:`replay_bag` found: replayed and recorded observations/estimates, and their differences."""

    bag: str
    observations: list[Any]
    rejections: list[Any]
    cycles: list[Any]
    recorded_observations: list[dict[str, Any]]
    recorded_estimates: list[dict[str, Any]]
    samples: int
    statuses: int
    observer_params: dict[str, Any]
    monitor_params: dict[str, Any]
    #: per topic, messages the recorder was told were lost while recording (the bag is incomplete)
    messages_lost: dict[str, int] = field(default_factory=dict)

    #: the joints replayed (each through its own cores), in order
    joints: list[str] = field(default_factory=list)
    #: production statuses (``/production/status``) and recorded production observations fed to the monitor
    production_statuses: int = 0
    production_observations: int = 0
    #: where the settings came from: ``observer``/``estimator`` ("recorded" in the bag, or "config" files),
    #: ``method``/``params`` and their ``method_from``/``params_from`` ("given", "recorded",
    #: "recorded estimates": the method the live estimates name, "config")
    settings: dict[str, str] = field(default_factory=dict)

    @property
    def settings_recorded(self) -> bool:
        """True when every setting that decides the estimates came from the bag or was given."""
        s = self.settings
        return s.get("method_from") != "config" and s.get("params_from") != "config" and (
            s.get("estimator") == "recorded" or (s.get("method_from") == "given" and s.get("params_from") == "given"))

    def comparison(self, joint: str | None = None) -> dict[str, Any]:
        """Replayed vs recorded, like with like: observations matched by (joint, source, cycle_id, speed),
        estimates by (joint, source, cycle_id) and compared only when made by the same method (a test cycle and
        a production shift of the same id are different cycles; recorded production observations are the
        replay's input, not compared).

        ``joint`` restricts it to one joint. A cycle re-estimated after a late
        observation has several results on each side; the newest of each is
        compared (what a consumer keeps). A recorded message without a joint
        name is taken for the single replayed joint.

        Each quantity is compared with itself: ``max_abs_diff`` is the largest difference of the headline
        quantity (an observation's ``tau_f``, an estimate's ``wear``), ``max_abs_diff_by_field`` that of every
        compared field (``compared`` names them); ``matched`` needs every field equal. An estimate the replay
        made with another method than the recorded one (``jointwear replay --method``) is not a reproduction:
        it is listed in ``other_method`` (both methods, both wears, their difference) and counted neither as
        matched nor as differing.
        """
        single = self.joints[0] if len(self.joints) == 1 else ""

        def jn(name: Any) -> str:
            return str(name) or single

        numeric = ("tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position",
                   "samples_plus", "samples_minus")
        est_fields = ("wear", "wear_std", "wear_low", "wear_high")
        def src(d: dict[str, Any]) -> str:
            return str(d.get("source", "")) or Source.TEST_CYCLE.value

        rec_obs = [o for o in self.recorded_observations if (joint is None or jn(o["joint_name"]) == joint)
                   and src(o) == Source.TEST_CYCLE]
        rec_est = [e for e in self.recorded_estimates if joint is None or jn(e["joint_name"]) == joint]
        observations = [o for o in self.observations if joint is None or o.joint_name == joint]
        cycles = [c for c in self.cycles if joint is None or c.joint_name == joint]
        rec = {(jn(o["joint_name"]), src(o), int(o["cycle_id"]), round(float(o["speed"]), 9)): o for o in rec_obs}

        def diff(a: Any, b: Any) -> float:
            a, b = float(a), float(b)
            if math.isnan(a) and math.isnan(b):
                return 0.0
            d = abs(a - b)
            return d if math.isfinite(d) else math.inf

        def same(pairs: list[tuple[float, float]]) -> bool:
            return all((math.isnan(float(a)) and math.isnan(float(b)))
                       or abs(float(a) - float(b)) <= MATCH_TOLERANCE * max(1.0, abs(float(b))) for a, b in pairs)

        paired, matched, missing, differ = 0, 0, [], []
        o_by_field = dict.fromkeys(numeric, 0.0)
        for o in observations:
            r = rec.get((o.joint_name, o.source, int(o.cycle_id), round(float(o.speed), 9)))
            if r is None:
                missing.append(f"{o.joint_name} cycle {o.cycle_id} speed {o.speed:g}")
                continue
            paired += 1
            pairs = [(getattr(o, f), r[f]) for f in numeric]
            for f, (a, b) in zip(numeric, pairs):
                o_by_field[f] = max(o_by_field[f], diff(a, b))
            if same(pairs):
                matched += 1
            else:
                differ.append(f"{o.joint_name} cycle {o.cycle_id} speed {o.speed:g}")
        replayed_keys = {(o.joint_name, o.source, int(o.cycle_id), round(float(o.speed), 9)) for o in observations}
        not_replayed = [f"{k[0]} cycle {k[2]} speed {k[3]:g}" for k in rec if k not in replayed_keys]
        # the newest per joint, source and cycle
        est = {(jn(e["joint_name"]), src(e), int(e["cycle_id"])): e for e in rec_est}
        newest = {(c.joint_name, c.source, int(c.cycle_id)): c for c in cycles if c.result is not None}
        e_paired, e_matched, e_differ, other = 0, 0, [], []
        e_by_field = dict.fromkeys(est_fields, 0.0)
        for key, c in newest.items():
            e = est.get(key)
            if e is None:
                continue
            rec_method = str(e.get("method", "") or c.result.method)
            if str(c.result.method) != rec_method:  # another estimator: a different quantity, not a reproduction
                other.append({"joint": key[0], "source": key[1], "cycle_id": key[2], "replayed_method": str(c.result.method),
                              "recorded_method": rec_method, "replayed_wear": float(c.result.wear),
                              "recorded_wear": float(e["wear"]),
                              "wear_diff": float(c.result.wear) - float(e["wear"])})
                continue
            e_paired += 1
            pairs = [(getattr(c.result, f), e[f]) for f in est_fields]
            for f, (a, b) in zip(est_fields, pairs):
                e_by_field[f] = max(e_by_field[f], diff(a, b))
            if same(pairs):
                e_matched += 1
            else:
                what = f"production shift {key[2]}" if key[1] == Source.PRODUCTION else f"cycle {key[2]}"
                e_differ.append(f"{key[0]} {what}: replayed {float(c.result.wear):.2f} "
                                f"± {float(c.result.wear_std):.2f}, recorded {float(e['wear']):.2f} "
                                f"± {float(e['wear_std']):.2f} ({c.result.method} both)")
        return {
            "observations": {
                "recorded": len(rec_obs), "replayed": len(observations), "paired": paired,
                "matched": matched, "differ": differ, "max_abs_diff": o_by_field["tau_f"] if paired else None,
                "max_abs_diff_by_field": o_by_field if paired else None,
                "compared": "per (joint, cycle, speed): " + ", ".join(numeric) + "; max_abs_diff is tau_f's",
                "not_recorded": missing, "not_replayed": not_replayed,
            },
            "estimates": {
                "recorded": len(rec_est), "replayed": sum(c.result is not None for c in cycles),
                "revisions": sum(getattr(c, "revision", 0) > 0 for c in cycles), "paired": e_paired,
                "matched": e_matched, "differ": e_differ, "max_abs_diff": e_by_field["wear"] if e_paired else None,
                "max_abs_diff_by_field": e_by_field if e_paired else None,
                "compared": ("the newest estimate per (joint, source, cycle) of the same method: " + ", ".join(est_fields)
                             + "; max_abs_diff is the wear's"),
                "other_method": other,
            },
        }


def _joint_tree(tree: dict[str, Any], joint: str) -> dict[str, Any]:
    """Node-level settings overlaid with the joint's own (``<joint>.<setting>``, nested under the joint)."""
    own = tree.get(joint)
    return {**tree, **own} if isinstance(own, dict) else dict(tree)


def _status_joints(statuses: list[Any]) -> list[str]:
    """The joints the bag's test-cycle statuses name, in order of appearance."""
    out: list[str] = []
    for st in statuses:
        name = str(st.joint_name)
        if name and name not in out:
            out.append(name)
    return out


def _served_joints(recorded: dict[str, Any], configured: dict[str, Any], bag_joints: list[str]) -> list[str]:
    """The joints to replay (see the module docstring)."""
    rec = recorded.get("joints")
    if isinstance(rec, list) and rec:
        return [str(j) for j in rec]
    if recorded.get("joint_name"):
        return [str(recorded["joint_name"])]
    if bag_joints:
        return bag_joints
    conf = configured.get("joints")
    if isinstance(conf, list) and conf:
        return [str(j) for j in conf]
    return [str(configured.get("joint_name", "joint_1"))]


def replay_bag(
    path: str | os.PathLike[str],
    observer_params: dict[str, Any],
    monitor_params: dict[str, Any],
    *,
    use_recorded_params: bool = True,
    joint_states_topic: str = "",
    status_topic: str = "",
    production_status_topic: str = "",
    temperature_topic: str | None = None,
    observations_topic: str = "",
    estimate_topic: str = "",
    observer_node: str = "friction_observer",
    monitor_node: str = "wear_estimator",
    overrides: dict[str, Any] | None = None,
) -> ReplayResult:
    """Re-run the friction observer core and the wear monitor on a bag, offline, in log-time order.

    ``observer_params``/``monitor_params`` are flattened ROS parameters (e.g.
    from the nodes' config files); with ``use_recorded_params`` the values
    the live nodes declared (``/parameter_events`` in the bag) take precedence.
    ``overrides`` (e.g. ``{"method": "bayes"}``) apply to the monitor last.
    Topics default to the nodes' parameters (the temperature is used only when
    the observer had a ``temperature_topic``, as live). Header stamps of 0 and
    the monitor's clock are replaced by the log time, as the live nodes use
    their clock at receipt. Every joint (module docstring) has its own observer
    core and monitor; the result lists all joints' observations and cycles.
    """
    p = check_bag_path(Path(path))
    check_bag(p)  # a damaged bag is refused with its offset, never replayed as if whole
    # one pass over the bag: the settings, the joints and the messages all come from it
    bag = read_bag_once(p, (JOINT_STATE_TYPE, STATUS_TYPE, TEMPERATURE_TYPE, OBSERVATION_TYPE, ESTIMATE_TYPE))
    obs_params = dict(observer_params)
    mon_params = dict(monitor_params)
    rec_obs: dict[str, Any] = {}
    rec_mon: dict[str, Any] = {}
    if use_recorded_params:
        recorded = bag.settings()
        rec_obs = recorded.get(observer_node.lstrip("/"), {})
        rec_mon = recorded.get(monitor_node.lstrip("/"), {})
        obs_params.update(rec_obs)
        mon_params.update(rec_mon)
    overrides = dict(overrides or {})
    settings = {
        "observer": "recorded" if rec_obs else "config",
        "estimator": "recorded" if rec_mon else "config",
        "method_from": "given" if "method" in overrides else "recorded" if "method" in rec_mon else "config",
        "params_from": "given" if "params" in overrides else "recorded" if "params" in rec_mon else "config",
    }
    if use_recorded_params and settings["method_from"] == "config":
        # no recorded settings, but the live estimates name their method: use it, never another one
        topic = str(mon_params.get("estimate_topic", "/jointwear/wear_estimate"))
        methods = [str(m.msg.method) for m in bag.messages(ESTIMATE_TYPE, [topic], keep=True)]
        if methods and methods[-1]:
            overrides["method"] = methods[-1]
            settings["method_from"] = "recorded estimates"
    if overrides:
        mon_params.update(overrides)
    settings["method"] = str(mon_params.get("method", ""))
    settings["params"] = str(mon_params.get("params", ""))
    # the topics the live nodes used (their parameters), unless given
    joint_states_topic = joint_states_topic or str(obs_params.get("joint_states_topic", "/joint_states"))
    status_topic = status_topic or str(obs_params.get("status_topic", "/test_cycle/status"))
    if temperature_topic is None:
        temperature_topic = str(obs_params.get("temperature_topic", ""))
    observations_topic = observations_topic or str(obs_params.get("observations_topic",
                                                                  "/jointwear/friction_observations"))
    estimate_topic = estimate_topic or str(mon_params.get("estimate_topic", "/jointwear/wear_estimate"))
    production_status_topic = production_status_topic or str(mon_params.get("production_status_topic",
                                                                             "/production/status"))
    named = [] if rec_obs else _status_joints([m.msg for m in bag.messages(STATUS_TYPE, [status_topic], keep=True)]
                                              + [m.msg for m in bag.messages(STATUS_TYPE, [production_status_topic],
                                                                             keep=True)])
    joints = _served_joints(rec_obs, obs_params, named)
    obs_tree, mon_tree = nest(obs_params), nest(mon_params)
    try:
        # the configs as the live nodes build them from their parameters (settings.from_mapping)
        observer = RobotObserver({j: from_mapping(ObserverConfig, _joint_tree(obs_tree, j), joint_name=j)
                                  for j in joints})
        monitor = RobotMonitor({j: from_mapping(MonitorConfig, {**_joint_tree(mon_tree, j), **overrides}, joint_name=j)
                                for j in joints})
    except (ParameterError, TypeError, ValueError) as exc:
        raise InputDataError(f"{p}: observer/estimator parameters are malformed ({exc})") from None
    observations: list[FrictionObservationData] = []
    rejections: list[Any] = []
    cycles: list[Any] = []
    recorded_obs: list[dict[str, Any]] = []
    recorded_est: list[dict[str, Any]] = []
    samples = n_statuses = n_prod_statuses = n_prod_obs = 0
    now = -math.inf

    def take(out: ObserverOutput) -> None:
        # the observations go to the estimator as they are published live (the same routing)
        observations.extend(out.observations)
        rejections.extend(out.rejections)
        for o in out.observations:
            cycles.extend(monitor.add(o, now) or [])

    seen_js = False
    for i, (topic, msgtype, log_time, _raw) in enumerate(bag.records):
        if topic not in (joint_states_topic, status_topic, temperature_topic, observations_topic, estimate_topic,
                         production_status_topic):
            continue
        now = max(now, log_time * 1e-9)
        if topic == joint_states_topic and msgtype == JOINT_STATE_TYPE:
            seen_js = True
            msg = bag.message(i).msg
            js = observer.on_joint_state(stamp_to_seconds(msg.header), msg.name, msg.position, msg.velocity,
                                         msg.effort, now)
            if js.used:
                samples += 1
            for fed in js.outputs:
                take(fed.output)
        elif topic == status_topic and msgtype == STATUS_TYPE:
            n_statuses += 1
            st = status_from_msg(bag.message(i).msg)
            routed = observer.on_status(st, now)
            if routed is None:
                continue  # a joint the live node did not serve: ignored there too
            take(routed.output)
            cycles.extend(monitor.on_status(st, now) or [])
        elif topic == production_status_topic and msgtype == STATUS_TYPE:
            # the production observer's shift status: to the estimator only (the test-cycle observer never sees it)
            n_prod_statuses += 1
            cycles.extend(monitor.on_status(status_from_msg(bag.message(i).msg), now, Source.PRODUCTION) or [])
        elif temperature_topic and topic == temperature_topic and msgtype == TEMPERATURE_TYPE:
            msg = bag.message(i).msg
            t, c = temperature_value(msg)
            routed = observer.on_temperature(t, str(msg.header.frame_id), c, now)
            if routed is not None:
                take(routed.output)
        elif topic == observations_topic and msgtype == OBSERVATION_TYPE:
            msg = bag.message(i).msg
            try:
                rec_o = observation_from_msg(msg)
            except InputDataError:  # a source outside the vocabulary: the live estimator drops it too
                rec_o = None
            if rec_o is not None:
                recorded_obs.append(asdict(rec_o))
                if rec_o.source == Source.PRODUCTION:  # the estimator's production input, as live
                    n_prod_obs += 1
                    cycles.extend(monitor.add(rec_o, now) or [])
        elif topic == estimate_topic and msgtype == ESTIMATE_TYPE:
            msg = bag.message(i).msg
            d = estimate_fields(msg)
            d["stamp"] = stamp_to_seconds(msg.header)
            recorded_est.append(d)
        if now > -math.inf and topic != joint_states_topic:
            cycles.extend(monitor.poll(now))
    if not seen_js:
        raise InputDataError(
            f"{p}: no {JOINT_STATE_TYPE} messages on {joint_states_topic}; "
            "record /joint_states (and /test_cycle/status) to replay the observer"
        )
    for fed in observer.flush():
        take(fed.output)
    if math.isfinite(now):
        cycles.extend(monitor.finish(now))
    return ReplayResult(
        bag=str(p), observations=observations, rejections=rejections, cycles=cycles,
        recorded_observations=recorded_obs, recorded_estimates=recorded_est, samples=samples,
        statuses=n_statuses, observer_params=obs_params, monitor_params=mon_params,
        messages_lost=bag.messages_lost(), joints=joints, settings=settings,
        production_statuses=n_prod_statuses, production_observations=n_prod_obs,
    )
