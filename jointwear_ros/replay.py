"""Offline replay: a recorded bag through the live nodes' pure cores, in log-time order.

:func:`replay_bag` reads a rosbag2/MCAP bag (no ROS runtime), feeds its ``/joint_states``,
``/test_cycle/status`` and temperature messages to :class:`~jointwear_ros.observer.FrictionObserverCore`
and the observations to :class:`~jointwear_ros.monitor.WearMonitor`, exactly as the
``friction_observer`` and ``wear_estimator`` nodes do live, and compares what it gets with the
observations and estimates the bag recorded. ``jointwear replay``, ``jointwear history import
--reestimate`` and the fleet re-analysis use it; the live nodes never do.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .contract import observation_from_msg, stamp_to_seconds
from .errors import InputDataError
from .io.bags import (
    ESTIMATE_TYPE,
    JOINT_STATE_TYPE,
    OBSERVATION_TYPE,
    STATUS_TYPE,
    TEMPERATURE_TYPE,
    bag_messages_lost,
    check_bag_path,
    estimate_fields,
    joint_sample,
    read_messages,
    status_fields,
    temperature_value,
)
from .io.params import nest, recorded_node_params
from .io.recover import check_bag
from .monitor import MonitorConfig, WearMonitor
from .observer import FrictionObservationData, FrictionObserverCore, ObserverConfig

__all__ = ["ReplayResult", "replay_bag"]


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

    def comparison(self) -> dict[str, Any]:
        """Replayed vs recorded: observations matched by (cycle_id, speed), estimates by cycle_id.

        A cycle re-estimated after a late observation has several results on
        each side; the newest of each is compared (what a consumer keeps).
        """
        numeric = ("tau_f", "tau_f_std", "tau_plus", "tau_minus", "load_torque", "temperature", "position",
                   "samples_plus", "samples_minus")
        rec = {(int(o["cycle_id"]), round(float(o["speed"]), 9)): o for o in self.recorded_observations}
        matched, max_diff, missing = 0, 0.0, []
        for o in self.observations:
            r = rec.get((int(o.cycle_id), round(float(o.speed), 9)))
            if r is None:
                missing.append(f"cycle {o.cycle_id} speed {o.speed:g}")
                continue
            matched += 1
            for f in numeric:
                a, b = float(getattr(o, f)), float(r[f])
                if math.isnan(a) and math.isnan(b):
                    continue
                max_diff = max(max_diff, abs(a - b)) if math.isfinite(a - b) else math.inf
        est = {int(e["cycle_id"]): e for e in self.recorded_estimates}  # the newest per cycle
        newest = {int(c.cycle_id): c for c in self.cycles if c.result is not None}
        e_matched, e_diff = 0, 0.0
        for cid, c in newest.items():
            e = est.get(cid)
            if e is None:
                continue
            e_matched += 1
            for a, b in ((c.result.wear, e["wear"]), (c.result.wear_std, e["wear_std"]),
                         (c.result.wear_low, e["wear_low"]), (c.result.wear_high, e["wear_high"])):
                d = abs(float(a) - float(b))
                e_diff = max(e_diff, d) if math.isfinite(d) else (e_diff if math.isnan(a) and math.isnan(b) else math.inf)
        return {
            "observations": {
                "recorded": len(self.recorded_observations), "replayed": len(self.observations),
                "matched": matched, "max_abs_diff": max_diff if matched else None,
                "not_recorded": missing,
            },
            "estimates": {
                "recorded": len(self.recorded_estimates), "replayed": sum(c.result is not None for c in self.cycles),
                "revisions": sum(getattr(c, "revision", 0) > 0 for c in self.cycles),
                "matched": e_matched, "max_abs_diff": e_diff if e_matched else None,
            },
        }


def replay_bag(
    path: str | os.PathLike[str],
    observer_params: dict[str, Any],
    monitor_params: dict[str, Any],
    *,
    use_recorded_params: bool = True,
    joint_states_topic: str = "",
    status_topic: str = "",
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
    their clock at receipt.
    """
    p = check_bag_path(Path(path))
    check_bag(p)  # a damaged bag is refused with its offset, never replayed as if whole
    obs_params = dict(observer_params)
    mon_params = dict(monitor_params)
    if use_recorded_params:
        events = [m.msg for m in read_messages(p, topics=["/parameter_events"])]
        obs_params.update(recorded_node_params(events, observer_node))
        mon_params.update(recorded_node_params(events, monitor_node))
    if overrides:
        mon_params.update(overrides)
    mon_tree = nest(mon_params)
    opts = mon_tree.get("estimator_options", {})
    if isinstance(opts, str):  # the wear_estimator node takes a JSON object string
        try:
            mon_tree["estimator_options"] = dict(json.loads(opts)) if opts.strip() else {}
        except (ValueError, TypeError) as exc:
            raise InputDataError(f"estimator_options = {opts!r} is not a JSON object: {exc}") from None
    try:
        ocfg = ObserverConfig.from_mapping(nest(obs_params))
        mcfg = MonitorConfig.from_mapping(mon_tree)
    except (TypeError, ValueError) as exc:
        raise InputDataError(f"{p}: observer/estimator parameters are malformed ({exc})") from None
    # the topics the live nodes used (their parameters), unless given
    joint_states_topic = joint_states_topic or str(obs_params.get("joint_states_topic", "/joint_states"))
    status_topic = status_topic or str(obs_params.get("status_topic", "/test_cycle/status"))
    if temperature_topic is None:
        temperature_topic = str(obs_params.get("temperature_topic", ""))
    observations_topic = observations_topic or str(obs_params.get("observations_topic",
                                                                  "/jointwear/friction_observations"))
    estimate_topic = estimate_topic or str(mon_params.get("estimate_topic", "/jointwear/wear_estimate"))
    core = FrictionObserverCore(ocfg)
    monitor = WearMonitor(mcfg)
    joint = ocfg.joint_name
    observations: list[FrictionObservationData] = []
    rejections: list[Any] = []
    cycles: list[Any] = []
    recorded_obs: list[dict[str, Any]] = []
    recorded_est: list[dict[str, Any]] = []
    samples = statuses = 0
    now = -math.inf

    def take(out: Any) -> None:
        observations.extend(out.observations)
        rejections.extend(out.rejections)
        for o in out.observations:
            cycles.extend(monitor.add(o, now=now))

    def stamp_or_now(t: float) -> float:  # the live observer stamps header-less messages on receipt
        return t if t > 0 else now

    topics = [joint_states_topic, status_topic, observations_topic, estimate_topic]
    if temperature_topic:
        topics.append(temperature_topic)
    seen_js = False
    for m in read_messages(p, topics=topics):
        now = max(now, m.log_time * 1e-9)
        if m.topic == joint_states_topic and m.msgtype == JOINT_STATE_TYPE:
            seen_js = True
            s = joint_sample(m.msg, joint)
            if s is not None:
                samples += 1
                take(core.on_joint_state(stamp_or_now(s[0]), *s[1:]))
        elif m.topic == status_topic and m.msgtype == STATUS_TYPE:
            statuses += 1
            f = status_fields(m.msg)
            f["stamp"] = stamp_or_now(f["stamp"])
            take(core.on_status(**f))
            cycles.extend(monitor.on_status(now, f["cycle_id"], f["state"], f["speeds_done"],
                                            f["speeds_total"], f["joint_name"]))
        elif m.topic == temperature_topic and m.msgtype == TEMPERATURE_TYPE:
            t, c = temperature_value(m.msg)
            take(core.on_temperature(stamp_or_now(t), c))
        elif m.topic == observations_topic and m.msgtype == OBSERVATION_TYPE:
            recorded_obs.append(asdict(observation_from_msg(m.msg)))
        elif m.topic == estimate_topic and m.msgtype == ESTIMATE_TYPE:
            d = estimate_fields(m.msg)
            d["stamp"] = stamp_to_seconds(m.msg.header)
            recorded_est.append(d)
        if now > -math.inf and m.topic != joint_states_topic:
            cycles.extend(monitor.poll(now))
    if not seen_js:
        raise InputDataError(
            f"{p}: no {JOINT_STATE_TYPE} messages on {joint_states_topic}; "
            "record /joint_states (and /test_cycle/status) to replay the observer"
        )
    take(core.flush())
    if math.isfinite(now):
        cycles.extend(monitor.poll(now + mcfg.done_timeout + mcfg.idle_timeout + 1.0))
    return ReplayResult(
        bag=str(p), observations=observations, rejections=rejections, cycles=cycles,
        recorded_observations=recorded_obs, recorded_estimates=recorded_est, samples=samples,
        statuses=statuses, observer_params=obs_params, monitor_params=mon_params,
        messages_lost=bag_messages_lost(p),
    )
