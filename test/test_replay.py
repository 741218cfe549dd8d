"""Offline replay of bags (no ROS runtime): same observations and estimate as recorded; bad bags are one-line errors."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer

from jointwear_ros.cli import main as cli_main
from jointwear_ros.contract import CycleState, CycleStatus
from jointwear_ros.io.bags import bag_info
from jointwear_ros.io.params import node_params_from_yaml
from jointwear_ros.io.typestore import jointwear_typestore
from jointwear_ros.monitor import MonitorConfig, WearMonitor
from jointwear_ros.observer import ObserverConfig, observe_arrays
from jointwear_ros.observer.synthetic import synthetic_cycle
from jointwear_ros.replay import replay_bag
from jointwear_ros.resources import config_path
from jointwear_ros.settings import from_mapping

SPEEDS = (20.0, 80.0, 160.0)


def _time(store, t: float):
    sec = int(np.floor(t))
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=round((t - sec) * 1e9) % 1_000_000_000)


def _header(store, t: float):
    return store.types["std_msgs/msg/Header"](stamp=_time(store, t), frame_id="")


def _monitor_config() -> MonitorConfig:
    params = node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator")
    return from_mapping(MonitorConfig, params)


def _observer_config() -> ObserverConfig:
    return from_mapping(ObserverConfig, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"))


def _estimate_msg(store, res):
    r = res.result
    return (res.stamp + 0.02, "/jointwear/wear_estimate", "jointwear_msgs/msg/WearEstimate",
            store.types["jointwear_msgs/msg/WearEstimate"](
                header=_header(store, res.stamp), joint_name="joint_1", cycle_id=res.cycle_id, method=r.method,
                wear=r.wear, wear_std=r.wear_std, wear_low=r.wear_low, wear_high=r.wear_high,
                temperature_estimate=r.temperature, speeds=np.array(r.speeds, dtype=float),
                per_speed_wear=np.array(r.per_speed_wear, dtype=float), alarm_threshold=35.0,
                alarm=bool(r.wear >= 35.0), level=int(res.level), evidence=res.evidence,
                confirmation=res.confirmation, source=res.source))


def _write(path: Path, store, msgs, custom: dict[str, str] | None = None) -> None:
    msgs = sorted(msgs, key=lambda m: m[0])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for k, v in (custom or {}).items():
            w.set_custom_data(k, v)
        conns = {}
        for t, topic, typ, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, typ, typestore=store)
            w.write(conns[topic], round(t * 1e9), store.serialize_cdr(msg, typ))


@pytest.fixture(scope="module")
def synthetic_bag(tmp_path_factory) -> tuple[Path, list, object]:
    """A bag as the recorder writes it: /joint_states (with a second joint), status, and the
    observations/estimate computed by the observer's vectorised offline path and the monitor."""
    path, observations, result, _, _ = _synthetic(tmp_path_factory)
    return path, observations, result


def _synthetic(tmp_path_factory, t0=50.0):
    cyc = synthetic_cycle(SPEEDS, wear=25.0, rate=500.0, noise_std=0.002, seed=3, t0=t0)
    out = observe_arrays(_observer_config(), cyc.stamps, cyc.position, cyc.velocity, cyc.effort, cyc.statuses)
    assert len(out.observations) == len(SPEEDS), out.rejections
    monitor = WearMonitor(_monitor_config())
    results = []
    for o in out.observations:
        results += monitor.add(o, now=o.stamp)
    results += monitor.on_status(cyc.statuses[-1], now=cyc.statuses[-1].stamp)
    results += monitor.poll(1e12)
    assert len(results) == 1 and results[0].result is not None

    store = jointwear_typestore()
    T = store.types
    path = tmp_path_factory.mktemp("replay") / "bag"
    msgs: list[tuple[float, str, str, object]] = []
    for t, p, v, e in zip(cyc.stamps, cyc.position, cyc.velocity, cyc.effort):
        msgs.append((t, "/joint_states", "sensor_msgs/msg/JointState", T["sensor_msgs/msg/JointState"](
            header=_header(store, t), name=["joint_0", "joint_1"], position=np.array([0.5, p]),
            velocity=np.array([0.0, v]), effort=np.array([3.0, e]))))
    for st in cyc.statuses:
        msgs.append((st.stamp, "/test_cycle/status", "jointwear_msgs/msg/TestCycleStatus",
                     T["jointwear_msgs/msg/TestCycleStatus"](
            header=_header(store, st.stamp), joint_name=st.joint_name, cycle_id=st.cycle_id, state=st.state,
            phase=st.phase, current_speed=st.current_speed, speeds_done=st.speeds_done, speeds_total=st.speeds_total,
            window_center=st.window_center, window_half_width=st.window_half_width, message="",
            joints=[st.joint_name], joints_done=0)))
    for o in out.observations:
        d = o.to_dict()
        t = d.pop("stamp")
        msgs.append((t + 0.01, "/jointwear/friction_observations", "jointwear_msgs/msg/FrictionObservation",
                     T["jointwear_msgs/msg/FrictionObservation"](header=_header(store, t), **d)))
    _write(path, store, [*msgs, _estimate_msg(store, results[0])])
    return path, out.observations, results[0], msgs, store


def test_replay_of_a_bag_gives_the_recorded_observations_and_estimate(synthetic_bag):
    path, observations, result = synthetic_bag
    rep = replay_bag(path, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
                     node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))
    assert [o.to_dict() for o in rep.observations] == [o.to_dict() for o in observations]
    assert len(rep.cycles) == 1
    assert rep.cycles[0].result.wear == result.result.wear
    assert rep.cycles[0].result.wear_std == result.result.wear_std
    cmp_ = rep.comparison()
    assert cmp_["observations"]["matched"] == len(SPEEDS) and cmp_["observations"]["max_abs_diff"] == 0.0
    assert cmp_["estimates"]["matched"] == 1 and cmp_["estimates"]["max_abs_diff"] == 0.0


def test_replay_compares_the_newest_estimate_of_a_cycle_revised_live(tmp_path_factory):
    """Live, the last observation came after the estimate: a first estimate from 2 of 3 speeds, then
    the revision with all three. Replay (on time, all three) must match the revision, not the first."""
    _, observations, result, msgs, store = _synthetic(tmp_path_factory)
    live = WearMonitor(_monitor_config())
    live.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=len(SPEEDS), joint_name="joint_1"), now=0.0)
    for o in observations[:-1]:
        assert live.add(o, now=o.stamp) == []
    t_end = observations[-1].stamp
    done = CycleStatus(cycle_id=1, state=CycleState.DONE, speeds_done=len(SPEEDS), speeds_total=len(SPEEDS),
                       joint_name="joint_1")
    (first,) = live.on_status(done, now=t_end) + live.poll(t_end + 5.0)
    (revised,) = live.add(observations[-1], now=t_end + 6.0)
    # 2 of 3 speeds, the temperature unknown: too few for a level, so no estimate was published live
    assert first.result is None and first.evidence == "insufficient"
    assert revised.revision == 1 and revised.result.wear == result.result.wear
    path = tmp_path_factory.mktemp("revised") / "bag"
    _write(path, store, [*msgs, _estimate_msg(store, revised)])
    rep = replay_bag(path, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
                     node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))
    est = rep.comparison()["estimates"]
    assert est["recorded"] == 1 and est["matched"] == 1 and est["max_abs_diff"] == 0.0


def test_replay_and_bag_info_flag_a_bag_whose_recorder_lost_messages(tmp_path_factory, capsys):
    from jointwear_ros.io.bags import LOST_KEY

    _, _, _, msgs, store = _synthetic(tmp_path_factory)
    path = tmp_path_factory.mktemp("lossy") / "bag"
    _write(path, store, msgs, {LOST_KEY: json.dumps({"/joint_states": 12})})
    assert bag_info(path).messages_lost == {"/joint_states": 12}
    assert cli_main(["replay", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["messages_lost"] == {"/joint_states": 12}
    assert cli_main(["replay", str(path)]) == 0
    assert "INCOMPLETE bag, messages lost while recording: /joint_states 12" in capsys.readouterr().out
    clean = tmp_path_factory.mktemp("clean") / "bag"
    _write(clean, store, msgs)
    assert bag_info(clean).messages_lost == {}
    garbled = tmp_path_factory.mktemp("garbled") / "bag"
    _write(garbled, store, msgs, {LOST_KEY: "not json"})
    assert bag_info(garbled).messages_lost == {"(unreadable count)": 1}


def test_replay_command_prints_json_with_the_demo_fields(synthetic_bag, capsys):
    path, observations, result = synthetic_bag
    assert cli_main(["replay", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"bag", "observations", "wear", "diagnostic_level", "comparison"} <= set(out)
    assert [o["speed"] for o in out["observations"]] == [o.speed for o in observations]
    assert out["wear"]["estimate"] == pytest.approx(result.result.wear, abs=0)
    assert out["wear"]["method"] == result.result.method
    assert out["comparison"]["estimates"]["max_abs_diff"] == 0.0


def test_replay_with_another_method_uses_it_on_the_same_observations(synthetic_bag, capsys):
    path, _, _ = synthetic_bag
    assert cli_main(["replay", str(path), "--json", "--method", "paper-grid"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["wear"]["method"] == "paper-grid"
    assert out["comparison"]["observations"]["max_abs_diff"] == 0.0


def test_bag_info_lists_topics_and_counts(synthetic_bag, capsys):
    path, observations, _ = synthetic_bag
    info = bag_info(path)
    assert info.version == 9 and info.storage == "mcap"
    assert info.topics["/jointwear/friction_observations"]["count"] == len(observations)
    assert cli_main(["bag", "info", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["topics"]["/jointwear/wear_estimate"]["count"] == 1


def _one_line_error(args: list[str], capsys) -> str:
    rc = cli_main(args)
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("jointwear: error: ")
    return err


def test_replay_of_a_missing_path_is_a_one_line_error(tmp_path, capsys):
    err = _one_line_error(["replay", str(tmp_path / "nope")], capsys)
    assert "no such bag" in err


@pytest.mark.parametrize(("flag", "value", "says"), [
    ("--wait-for-subscribers", "two", "must be a whole number >= 0"),
    ("--wait-for-subscribers", "-1", "must be a whole number >= 0"),
    ("--wait-timeout", "0", "must be between 0 and 86400 s"),
])
def test_replay_publish_rejects_bad_wait_options(synthetic_bag, capsys, flag, value, says):
    err = _one_line_error(["replay", str(synthetic_bag[0]), "--publish", flag, value], capsys)
    assert flag in err and says in err


def test_replay_of_a_directory_that_is_not_a_bag_is_a_one_line_error(tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("hello")
    err = _one_line_error(["replay", str(tmp_path)], capsys)
    assert "not a rosbag2 bag (no metadata.yaml)" in err


def test_replay_of_a_truncated_bag_is_a_one_line_error(synthetic_bag, tmp_path, capsys):
    path, _, _ = synthetic_bag
    broken = tmp_path / "broken"
    shutil.copytree(path, broken)
    mcap = next(broken.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])
    err = _one_line_error(["replay", str(broken)], capsys)
    # the CRC/structure check names the file, the offset and the way out
    assert f"{mcap}: unfinished at byte " in err and f"jointwear bag recover {broken}" in err


def test_replay_of_a_bag_without_joint_states_is_a_one_line_error(tmp_path, capsys):
    store = jointwear_typestore()
    path = tmp_path / "other"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        w.write(c, 1, store.serialize_cdr(store.types["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String"))
    err = _one_line_error(["replay", str(path)], capsys)
    assert "no sensor_msgs/msg/JointState messages on /joint_states" in err


def test_replay_reads_the_bag_once(synthetic_bag, monkeypatch):
    """The settings, the joints the statuses name, the method the estimates name and the messages: one pass."""
    from rosbags.highlevel import AnyReader

    path, observations, _ = synthetic_bag
    opened: list[object] = []
    enter = AnyReader.__enter__

    def counting_enter(self):
        opened.append(self)
        return enter(self)

    monkeypatch.setattr(AnyReader, "__enter__", counting_enter)
    rep = replay_bag(path, node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
                     node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))
    assert len(opened) == 1
    assert rep.joints == ["joint_1"] and rep.settings["method_from"] == "recorded estimates"
    assert [o.to_dict() for o in rep.observations] == [o.to_dict() for o in observations]


@pytest.mark.parametrize(("flag", "node", "text", "says"), [
    ("--observer-params", "friction_observer", "joint_1:\n      max_buffer_seconds: 5000.0",
     "max_buffer_seconds=5000: outside the declared range [1.0, 3600.0] s"),
    ("--estimator-params", "wear_estimator", "warn_threshold: 150.0\n    alarm_threshold: 160.0",
     "warn_threshold=150: outside the declared range [0.0, 100.0] %"),
])
def test_replay_checks_each_setting_as_the_node_declares_it(synthetic_bag, tmp_path, capsys, flag, node, text, says):
    # the configs are built as the live node builds them (settings.from_mapping): a value the node would
    # refuse at start-up is refused in one line
    path, _, _ = synthetic_bag
    params = tmp_path / f"{node}.yaml"
    params.write_text(f"{node}:\n  ros__parameters:\n    {text}\n")
    err = _one_line_error(["replay", str(path), flag, str(params)], capsys)
    assert says in err
