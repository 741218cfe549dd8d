"""``jointwear replay BAG``: re-run the friction observer and the wear monitor on a recorded bag.

Offline (the default) no ROS runtime is used: the bag is read with rosbags,
``/joint_states``, ``/test_cycle/status`` and ``/joint_temperature`` are fed
in log-time order, split per joint (every joint the live observer served;
docs/robot.md), to the same pure cores the live nodes run
(:class:`~jointwear_ros.observer.FrictionObserverCore`,
:class:`~jointwear_ros.monitor.WearMonitor`), with the parameters the live
nodes declared (recorded ``/parameter_events``) over the config files. The
result is compared with the FrictionObservation and WearEstimate messages
recorded in the bag, per (joint, cycle), like with like (each quantity with itself, the newest
estimate of a cycle on each side, the same method: an estimate of another ``--method`` is shown
beside the recorded one, not counted as matched or differing); ``--json`` adds a ``joints`` list with
each joint's wear, level, cycles and comparison (the one-joint fields stay).

``--publish`` plays the bag onto a live graph instead (raw CDR bytes, log-time
spacing divided by ``--rate``) and publishes ``/clock`` from the log times.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from ..errors import InputDataError
from . import UsageError
from .common import check_method, format_table, node_params, parse_float, print_json

__all__ = ["register", "replay_summary"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    p = sub.add_parser(
        "replay",
        help="re-run the friction observer and wear estimator on a recorded bag (offline), or play it",
        description="Re-run the friction observer core and the wear monitor on a rosbag2/MCAP bag in log-time "
                    "order, offline (no ROS runtime), and compare with the observations and estimate recorded "
                    "live. With --publish, play the bag onto a live ROS graph with /clock.",
    )
    p.add_argument("bag", nargs="+", metavar="BAG",
                   help="rosbag2 bag directories (as the recorder writes them) or globs; several are replayed one "
                        "after another (each bag once); --publish plays one")
    p.add_argument("--json", action="store_true", help="print JSON (fields observations, wear, comparison, ...)")
    p.add_argument("--method", default=None, help="estimator method instead of the recorded/configured one")
    p.add_argument("--observer-params", default=None, metavar="YAML",
                   help="friction_observer params file (default config/friction_observer.yaml)")
    p.add_argument("--estimator-params", default=None, metavar="YAML",
                   help="wear_estimator params file (default config/wear_estimator.yaml)")
    p.add_argument("--ignore-recorded-params", action="store_true",
                   help="use only the params files, not the parameters recorded in /parameter_events")
    p.add_argument("--publish", action="store_true", help="play the bag onto a live ROS graph instead")
    p.add_argument("--delay", default="0.5",
                   help="with --publish: seconds to wait after creating the publishers so that "
                        "subscribers match before the first message (default 0.5)")
    p.add_argument("--wait-for-subscribers", default="0", metavar="N",
                   help="with --publish: before playing, wait until every played topic has at least N matched "
                        "subscribers (default 0: do not wait), at most --wait-timeout seconds")
    p.add_argument("--wait-timeout", default="60",
                   help="with --wait-for-subscribers: give up after this many seconds, exit code 2 (default 60); also how "
                        "long the playback waits for a reliable subscriber that has stopped taking messages, and at its end for "
                        "the last messages to be acknowledged")
    p.add_argument("--rate", default="1.0", help="with --publish: playback speed factor (default 1 = recorded speed)")
    p.add_argument("--topics", default=None,
                   help="with --publish: comma list of topics to play (default: all but /clock, /rosout, "
                        "/parameter_events)")
    p.set_defaults(func=cmd_replay)


def replay_summary(result: Any) -> dict[str, Any]:
    """The JSON of a replay: observations, rejections, the last cycle's wear and level, all cycles, comparison,
    and per joint (``joints``) the same for that joint alone.

    The top-level ``wear`` and ``diagnostic_level`` are those of the last estimated cycle (of any joint;
    for a one-joint bag, the joint's); ``joints`` has one entry per replayed joint that had a status,
    an observation or a result: ``joint``, ``wear``, ``diagnostic_level`` (its last estimated cycle),
    ``observations`` and ``rejections`` (counts), ``cycles`` and ``comparison``.
    """
    def cycle_entry(c: Any) -> dict[str, Any]:
        return {
            "joint": c.joint_name,
            "cycle_id": c.cycle_id,
            "source": getattr(c, "source", "test_cycle"),
            "wear": None if c.result is None else
            {"estimate": c.result.wear, "std": c.result.wear_std, "method": c.result.method,
             "low": c.result.wear_low, "high": c.result.wear_high, "temperature": c.result.temperature},
            "diagnostic_level": c.level_name,
            "message": c.message,
            "revision": c.revision,
        }

    def last_of(cycles: list[dict[str, Any]]) -> dict[str, Any] | None:
        return next((c for c in reversed(cycles) if c["wear"] is not None), cycles[-1] if cycles else None)

    cycles = [cycle_entry(c) for c in result.cycles]
    last = last_of(cycles)
    joints = []
    for j in getattr(result, "joints", []) or []:
        mine = [c for c in cycles if c["joint"] == j]
        n_obs = sum(o.joint_name == j for o in result.observations)
        n_rej = sum(r.joint_name == j for r in result.rejections)
        if not (mine or n_obs or n_rej):
            continue  # configured, never tested in this bag
        lj = last_of(mine)
        joints.append({
            "joint": j,
            "wear": None if lj is None else lj["wear"],
            "diagnostic_level": None if lj is None else lj["diagnostic_level"],
            "observations": n_obs,
            "rejections": n_rej,
            "cycles": mine,
            "comparison": result.comparison(j),
        })
    return {
        "bag": result.bag,
        "observations": [o.to_dict() for o in result.observations],
        "rejections": [str(r) for r in result.rejections],
        "wear": None if last is None else last["wear"],
        "diagnostic_level": None if last is None else last["diagnostic_level"],
        "cycles": cycles,
        "joints": joints,
        "comparison": result.comparison(),
        "joint_state_samples": result.samples,
        "messages_lost": result.messages_lost,
        "settings": getattr(result, "settings", {}),
    }


def settings_line(settings: dict[str, str]) -> str:
    """Which method, parameter set and settings a replay used, and where each came from (one line)."""
    src = {"given": "given", "recorded": "recorded in the bag", "recorded estimates": "named by the recorded "
           "estimates", "config": "NOT recorded in the bag: from the config files"}
    rest = ("the other estimator settings recorded in the bag" if settings.get("estimator") == "recorded"
            else "the other estimator settings NOT recorded in the bag: from the config files")
    return (f"method {settings.get('method') or '?'} ({src.get(settings.get('method_from', ''), '?')}), "
            f"parameter set {settings.get('params') or '?'} ({src.get(settings.get('params_from', ''), '?')}); "
            + rest)


def cmd_replay(args: argparse.Namespace) -> int:
    import glob

    from ..io.bags import check_bag_path, discover_bags

    for b in args.bag:
        if not glob.has_magic(b):
            check_bag_path(Path(b))  # a missing bag: the reader's own one line
    selection = discover_bags(args.bag)
    if not selection.bags:
        raise UsageError("no bag among " + "; ".join(f"{s['path']}: {s['reason']}" for s in selection.skipped[:3]))
    if args.publish:
        if len(selection.bags) > 1:
            raise UsageError(f"--publish plays one bag; {len(selection.bags)} given")
        args.bag = str(selection.bags[0])
        return _publish(args)
    from ..replay import replay_bag

    check_method(args.method, "--method")
    observer = node_params(args.observer_params, "friction_observer.yaml", "friction_observer", "--observer-params")
    estimator = node_params(args.estimator_params, "wear_estimator.yaml", "wear_estimator", "--estimator-params")
    if args.estimator_params is not None and "method" in estimator:
        check_method(str(estimator["method"]), f"--estimator-params {args.estimator_params}: method")
    overrides = {"method": args.method} if args.method else None
    results = [replay_bag(b, observer, estimator, use_recorded_params=not args.ignore_recorded_params,
                          overrides=overrides) for b in selection.bags]  # a bad bag: exit 2 before any output
    if args.json:
        summaries = [replay_summary(r) for r in results]
        print_json(summaries[0] if len(summaries) == 1 else summaries)
        return 0
    for n, result in enumerate(results):
        if n:
            print()
        _print_replay(result)
    return 0


def _print_replay(result: Any) -> None:
    summary = replay_summary(result)
    print(f"bag: {result.bag}  ({result.samples} joint-state samples, {result.statuses} status messages)")
    if result.messages_lost:
        print("warning: INCOMPLETE bag, messages lost while recording: "
              + ", ".join(f"{t} {n}" for t, n in result.messages_lost.items())
              + "; the replay may differ from the live run")
    rows = [[o.joint_name, o.cycle_id, o.speed, o.tau_f, o.tau_f_std, o.load_torque, o.temperature, o.samples_plus,
             o.samples_minus] for o in result.observations]
    if rows:
        print(format_table(["joint", "cycle", "speed", "tau_f", "tau_f_std", "load", "temp", "n+", "n-"], rows))
    else:
        print("no friction observations")
    for r in result.rejections:
        print(f"rejected: {r}")
    for c in summary["cycles"]:
        w = c["wear"]
        est = "no estimate" if w is None else f"wear {w['estimate']:.2f} ± {w['std']:.2f} ({w['method']})"
        what = "production shift" if c["source"] == "production" else "cycle"
        print(f"{c['joint']} {what} {c['cycle_id']}: {est}, level {c['diagnostic_level']}: {c['message']}")
    print("settings: " + settings_line(result.settings))
    cmp_ = summary["comparison"]
    for line in comparison_lines(cmp_):
        print(line)
    if len(summary["joints"]) > 1:
        for j in summary["joints"]:
            w, c = j["wear"], j["comparison"]
            est = "no estimate" if w is None else f"wear {w['estimate']:.2f} ± {w['std']:.2f}"
            print(f"{j['joint']}: {est}, level {j['diagnostic_level']}; {j['observations']} observation(s), "
                  f"{j['rejections']} rejected; estimates {c['estimates']['matched']}/{c['estimates']['recorded']} "
                  "matched the recorded ones" + (f", {len(c['estimates']['differ'])} DIFFER"
                                                  if c["estimates"]["differ"] else "")
                  + (f", {len(c['estimates']['other_method'])} of another method (not compared)"
                     if c["estimates"]["other_method"] else ""))


def comparison_lines(cmp_: dict[str, Any]) -> list[str]:
    """The replay-vs-recorded comparison as text, naming what is compared with what: each quantity with
    itself (tau_f with tau_f, wear with wear), the same cycles, the same method; an estimate of another
    method is shown beside the recorded one, never counted as a match or a difference."""
    o, e = cmp_["observations"], cmp_["estimates"]
    if not (o["recorded"] or e["recorded"]):
        return ["the bag holds no recorded FrictionObservation/WearEstimate messages to compare with"]

    def num(x: Any) -> str:
        return "n/a" if x is None else f"{x:.3g}"

    out = [f"vs recorded: observations {o['matched']}/{o['recorded']} matched"
           + (f", {len(o['differ'])} DIFFER" if o["differ"] else "")
           + f" (per joint, cycle and speed: tau_f, its std, load, temperature, ...), max |tau_f diff| "
           f"{num(o['max_abs_diff'])}; "
           + ("estimates: none of the recorded method to compare (below)" if not e["paired"] and e.get("other_method")
              else f"estimates {e['matched']}/{e['recorded']} matched")
           + (f", {len(e['differ'])} DIFFER" if e["differ"] else "")
           + (f" (the newest per joint and cycle, same method: wear, std, 90 % bounds), max |wear diff| "
              f"{num(e['max_abs_diff'])}" if e["paired"] else "")]
    by = e.get("max_abs_diff_by_field") or {}
    if e["differ"] and by:
        out.append("estimates differ by: " + ", ".join(f"{k} {num(v)}" for k, v in by.items()))
    for d in e["differ"]:
        out.append(f"DIFFERS: {d}")
    other = e.get("other_method", [])
    if other:
        methods = sorted({(x["replayed_method"], x["recorded_method"]) for x in other})
        out.append(f"estimates of another method, not compared as a reproduction ({len(other)}): replayed with "
                   + "; ".join(f"{a} where the cell ran {b}" for a, b in methods))
        for x in other:
            out.append(f"  {x['joint']} cycle {x['cycle_id']}: wear {x['replayed_wear']:.2f} ({x['replayed_method']})"
                       f" vs {x['recorded_wear']:.2f} recorded ({x['recorded_method']}), {x['wear_diff']:+.2f}")
    for d in o.get("not_replayed", []):
        out.append(f"NOT REPLAYED: the recorded observation {d} (the replay's rejections say why)")
    return out


# --------------------------------------------------------------------------- --publish


def _publish(args: argparse.Namespace) -> int:
    """Play the bag's raw messages onto the graph with /clock from the log times."""
    from rosbags.highlevel import AnyReader

    from ..io.bags import check_bag_path
    from ..io.typestore import jointwear_typestore

    rate = parse_float(args.rate, "--rate")
    if not rate > 0:
        raise UsageError(f"--rate: {args.rate!r} must be > 0")
    delay_s = parse_float(args.delay, "--delay")
    if not 0 <= delay_s <= 3600:
        raise UsageError(f"--delay: {args.delay!r} must be between 0 and 3600 s")
    try:
        min_subs = int(args.wait_for_subscribers)
    except ValueError:
        min_subs = -1
    if min_subs < 0:
        raise UsageError(f"--wait-for-subscribers: {args.wait_for_subscribers!r} must be a whole number >= 0")
    wait_timeout = parse_float(args.wait_timeout, "--wait-timeout")
    if not 0 < wait_timeout <= 86400:
        raise UsageError(f"--wait-timeout: {args.wait_timeout!r} must be between 0 and 86400 s")
    bag = check_bag_path(Path(args.bag))
    from ..io.recover import check_bag

    check_bag(bag)  # a damaged bag is refused with the file and offset before anything is published
    try:
        import rclpy
        from rclpy.impl.implementation_singleton import rclpy_implementation
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock

        RCLError = rclpy_implementation.RCLError

        from ..nodes.runtime import message_class, use_prompt_acks
    except ImportError as exc:
        raise InputDataError(f"--publish needs rclpy (the ROS 2 wheels): {exc}") from None
    skip = {"/clock", "/rosout", "/parameter_events"}
    wanted = None if args.topics is None else {t.strip() for t in args.topics.split(",") if t.strip()}
    use_prompt_acks()  # the end's wait for acknowledgements returns when the subscribers have it, not at 3 s
    rclpy.init()
    node = rclpy.create_node("jointwear_replay")
    played = 0
    try:
        with AnyReader([bag], default_typestore=jointwear_typestore()) as reader:
            pubs: dict[int, Any] = {}
            conns = []
            for c in reader.connections:
                if (wanted is not None and c.topic not in wanted) or (wanted is None and c.topic in skip):
                    continue
                try:
                    cls = message_class(c.msgtype)
                except Exception as exc:
                    print(f"jointwear replay: not playing {c.topic}: type {c.msgtype} not importable ({exc})",
                          file=sys.stderr)
                    continue
                qos_list = getattr(c.ext, "offered_qos_profiles", []) or []
                latched = any(getattr(q.durability, "name", "") == "TRANSIENT_LOCAL" for q in qos_list)
                # KEEP_ALL: a message stays with the publisher until every reliable subscriber has it, so a
                # subscriber that falls behind the playback is delayed, never loses one (KEEP_LAST would overwrite)
                qos = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                                 history=HistoryPolicy.KEEP_LAST if latched else HistoryPolicy.KEEP_ALL,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
                pubs[c.id] = node.create_publisher(cls, c.topic, qos)
                conns.append(c)
            clock_pub = node.create_publisher(Clock, "/clock", 10)
            if min_subs:
                _wait_for_subscribers({c.topic: pubs[c.id] for c in conns}, min_subs, wait_timeout)
            print(f"jointwear replay: playing {len(conns)} topics of {bag} at {rate:g}x", file=sys.stderr)
            time.sleep(delay_s)  # let subscribers match the new publishers
            t0_log: int | None = None
            t0_wall = time.monotonic()
            last_clock = -1
            for conn, t, raw in reader.messages(connections=conns):
                if t0_log is None:
                    t0_log = t
                due = t0_wall + (t - t0_log) * 1e-9 / rate
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                if t != last_clock:
                    msg = Clock()
                    msg.clock.sec, msg.clock.nanosec = divmod(int(t), 1_000_000_000)
                    clock_pub.publish(msg)
                    last_clock = t
                _publish_waiting(pubs[conn.id], bytes(raw), conn.topic, wait_timeout, RCLError)
                played += 1
            # reliable subscribers get the last messages before this process goes away: a subscriber that is
            # behind has up to --wait-timeout s to take them (5 s was too short for a CPU-starved observer seconds
            # behind a 3x playback: the last 343 joint states of a production demo were lost with this process)
            unacked = _wait_all_acked({c.topic: pubs[c.id] for c in conns}, wait_timeout)
            if unacked:
                print(f"jointwear replay: not every subscriber acknowledged the last messages of "
                      f"{', '.join(unacked)} within {wait_timeout:g} s", file=sys.stderr)
    except InputDataError:
        raise
    except KeyboardInterrupt:
        raise
    except Exception as exc:
        raise InputDataError(f"{bag}: cannot play the bag ({type(exc).__name__}: {exc})") from None
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    print(f"jointwear replay: published {played} messages", file=sys.stderr)
    return 0


def _publish_waiting(pub: Any, data: bytes, topic: str, patience: float, rcl_error: type[Exception]) -> None:
    """Publish ``data``; while a reliable subscriber is behind the playback, wait for it instead of failing.

    A KEEP_ALL publisher keeps each message until every reliable subscriber has it; when a slow
    subscriber (a loaded machine) lets that history fill, the middleware blocks the write for its
    blocking time and then refuses it ("Failed to publish: cannot publish data"), with the message
    not written. It is sent again once the subscribers have taken some (``wait_for_all_acked``), so
    none is lost and none is sent twice; a subscriber that takes nothing for ``patience`` s is an
    InputDataError naming the topic.
    """
    from rclpy.duration import Duration

    give_up: float | None = None
    while True:
        try:
            pub.publish(data)
            return
        except rcl_error as exc:
            now = time.monotonic()
            give_up = now + patience if give_up is None else give_up
            if now > give_up:
                raise InputDataError(
                    f"{topic}: a subscriber took no message for {patience:g} s, the playback cannot go on "
                    f"({str(exc).splitlines()[0]}); raise --wait-timeout or check the consumers") from None
            pub.wait_for_all_acked(Duration(seconds=0.2))


def _wait_all_acked(pubs: dict[str, Any], timeout: float) -> list[str]:
    """Wait until every reliable subscriber acknowledged each publisher's messages, ``timeout`` s in all; the
    topics still unacknowledged then."""
    from rclpy.duration import Duration

    end = time.monotonic() + timeout
    return [t for t, p in pubs.items()
            if not p.wait_for_all_acked(Duration(seconds=max(end - time.monotonic(), 0.0)))]


def _wait_for_subscribers(pubs: dict[str, Any], n: int, timeout: float) -> None:
    """Block until each publisher has ``n`` matched subscriptions; InputDataError after ``timeout`` s."""
    print(f"jointwear replay: waiting for {n} subscriber(s) on each of {len(pubs)} topics", file=sys.stderr)
    end = time.monotonic() + timeout
    while True:
        short = {t: p.get_subscription_count() for t, p in pubs.items() if p.get_subscription_count() < n}
        if not short:
            return
        if time.monotonic() > end:
            raise InputDataError(
                f"--wait-for-subscribers {n}: after {timeout:g} s still too few subscribers on "
                + ", ".join(f"{t} ({c})" for t, c in sorted(short.items()))
                + "; start the consumers (same ROS_DOMAIN_ID) or lower N"
            )
        time.sleep(0.05)

