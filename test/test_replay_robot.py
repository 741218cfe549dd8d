"""Replay of a robot cycle's bag (every joint in one bag, docs/robot.md): per-joint cores, per-joint estimates.

The bag is written with the project's MCAP bag writer (io/mcap_bag.py, through
``fleet.synthetic_bags.write_robot_cycle_bag``) from the pure synthetic robot cycle: three joints
tested one after another under one cycle id, every JointState carrying all three, per-joint
temperatures (``frame_id`` = joint), joint_3 on a drive of its own torque scale (recorded as the
observer's ``joint_3.torque_scale``), and the observations and estimates the live nodes published
(the pure cores run per joint, as the nodes do).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from jointwear_ros.cli import main as cli_main
from jointwear_ros.contract import CycleState, CycleStatus
from jointwear_ros.fleet.reanalysis import reprocess_bag
from jointwear_ros.fleet.synthetic_bags import store_header, write_robot_cycle_bag
from jointwear_ros.history import HistoryStore
from jointwear_ros.io.params import node_params_from_yaml
from jointwear_ros.io.typestore import jointwear_typestore
from jointwear_ros.monitor import MonitorConfig, WearMonitor
from jointwear_ros.observer import ObserverConfig, observe_arrays
from jointwear_ros.observer.synthetic import synthetic_robot_cycle
from jointwear_ros.replay import replay_bag
from jointwear_ros.resources import config_path

JOINTS = ["joint_1", "joint_2", "joint_3"]
WEARS = (10.0, 45.0, 20.0)
TEMPERATURES = (35.0, 40.0, 45.0)
TORQUE_SCALES = (200.0, 200.0, 100.0)
SPEEDS = (30.0, 45.0, 60.0)


def _params() -> tuple[dict, dict]:
    return (node_params_from_yaml(config_path("friction_observer.yaml"), "friction_observer"),
            node_params_from_yaml(config_path("wear_estimator.yaml"), "wear_estimator"))


def _live(cyc):
    """What the live nodes published: per joint its own observer core and monitor (method paper)."""
    observations, results = [], []
    for k, j in enumerate(JOINTS):
        cfg = ObserverConfig(joint_name=j, torque_scale=TORQUE_SCALES[k])
        statuses = [s for s in cyc.statuses if s.joint_name == j]
        temps = [(t, c) for t, c, jj in cyc.temperatures if jj == j]
        out = observe_arrays(cfg, cyc.stamps, cyc.position[:, k], cyc.velocity[:, k], cyc.effort[:, k], statuses, temps)
        assert len(out.observations) == len(SPEEDS), out.rejections
        mon = WearMonitor(MonitorConfig(joint_name=j, method="paper"))
        mon.on_status(CycleStatus(cycle_id=1, state=CycleState.RUNNING, speeds_total=len(SPEEDS), joint_name=j), now=0.0)
        for o in out.observations:
            results += mon.add(o, now=o.stamp)
        observations += out.observations
    assert len(results) == len(JOINTS)
    return observations, results


def _extra(store, observations, results):
    T = store.types
    out = []
    for o in observations:
        d = o.to_dict()
        t = d.pop("stamp")
        out.append((t + 0.01, "/jointwear/friction_observations", "jointwear_msgs/msg/FrictionObservation",
                    T["jointwear_msgs/msg/FrictionObservation"](header=store_header(store, t, ""), **d)))
    for r in results:
        res = r.result
        out.append((r.stamp + 0.02, "/jointwear/wear_estimate", "jointwear_msgs/msg/WearEstimate",
                    T["jointwear_msgs/msg/WearEstimate"](
                        header=store_header(store, r.stamp, ""), joint_name=r.joint_name, cycle_id=r.cycle_id,
                        method=res.method, wear=res.wear, wear_std=res.wear_std, wear_low=res.wear_low,
                        wear_high=res.wear_high, temperature_estimate=res.temperature,
                        speeds=np.array(res.speeds, dtype=float), per_speed_wear=np.array(res.per_speed_wear, dtype=float),
                        alarm_threshold=35.0, alarm=bool(res.wear >= 35.0), level=0,
                        evidence="complete", confirmation="confirmed", source=r.source)))
    return out


@pytest.fixture(scope="module")
def robot_bag(tmp_path_factory):
    return _robot_bag(tmp_path_factory)


@pytest.fixture(scope="module")
def robot_bag_wall_clock(tmp_path_factory):
    """The same robot cycle stamped as a cell on wall time (the history refuses stamps before 2010)."""
    return _robot_bag(tmp_path_factory, t0=1.7e9 + 100.0)


def _robot_bag(tmp_path_factory, t0=100.0):
    cyc = synthetic_robot_cycle(JOINTS, WEARS, SPEEDS, rate=500.0, seed=4, noise_std=0.002, t0=t0,
                                torque_scales=TORQUE_SCALES, temperatures=TEMPERATURES, temperature_rate=2.0)
    observations, results = _live(cyc)
    store = jointwear_typestore()
    path = tmp_path_factory.mktemp("robot") / "robot_cycle"
    write_robot_cycle_bag(path, cyc, robot="cell_7", temperature_topic="/joint_temperature",
                          observer_params={"joint_3.torque_scale": 100.0},
                          estimator_params={"joint_3.hardware_id": "cell_7/wrist"},
                          extra=_extra(store, observations, results), store=store)
    return path, observations, results


def test_replay_of_a_robot_bag_gives_each_joint_its_recorded_observations_and_estimate(robot_bag):
    path, observations, results = robot_bag
    rep = replay_bag(path, *_params())
    assert rep.joints == JOINTS
    # bit for bit but the stamp (stored in the bag as integer nanoseconds)
    assert [{**o.to_dict(), "stamp": 0} for o in rep.observations] == [{**o.to_dict(), "stamp": 0} for o in observations]
    assert [o.stamp for o in rep.observations] == pytest.approx([o.stamp for o in observations], abs=1e-9)
    assert [(c.joint_name, c.cycle_id) for c in rep.cycles] == [(j, 1) for j in JOINTS]
    for c, live, wear, temp in zip(rep.cycles, results, WEARS, TEMPERATURES):
        assert c.result.wear == live.result.wear and c.result.wear_std == live.result.wear_std
        # the joint's own truth: its own torque scale and its own temperature sensor were used
        assert abs(c.result.wear - wear) < 3 * c.result.wear_std, (c.joint_name, c.result.wear, c.result.wear_std)
        assert 0.3 < c.result.wear_std < 6.0
        assert {o.temperature for o in rep.observations if o.joint_name == c.joint_name} == {temp}
    assert [c.level for c in rep.cycles] == [0, 2, 0]
    cmp_ = rep.comparison()
    assert cmp_["observations"]["matched"] == 9 and cmp_["observations"]["max_abs_diff"] == 0.0
    assert cmp_["estimates"]["matched"] == 3 and cmp_["estimates"]["max_abs_diff"] == 0.0
    for j in JOINTS:
        cj = rep.comparison(j)
        assert (cj["observations"]["matched"], cj["estimates"]["matched"], cj["estimates"]["max_abs_diff"]) == (3, 1, 0.0)


def test_replay_without_the_joints_own_setting_misreads_that_joint_only(robot_bag):
    """joint_3's recorded torque scale matters: ignoring the recorded parameters (config: 200 N·m for every
    joint) halves joint_3's friction, the others are unchanged."""
    path, observations, _ = robot_bag
    op, mp = _params()
    rep = replay_bag(path, op, {**mp, "method": "paper"}, use_recorded_params=False)
    assert rep.joints == JOINTS  # no recorded parameters: the joints the bag's statuses name
    by = {(o.joint_name, o.speed): o for o in rep.observations}
    for o in observations:
        got = by[(o.joint_name, o.speed)]
        if o.joint_name == "joint_3":
            assert got.tau_f == pytest.approx(0.5 * o.tau_f, rel=1e-12)
        else:
            assert got.tau_f == o.tau_f


def test_replay_json_has_an_entry_per_joint_and_keeps_the_one_joint_fields(robot_bag, capsys):
    path, _, results = robot_bag
    assert cli_main(["replay", str(path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert {"bag", "observations", "wear", "diagnostic_level", "cycles", "comparison", "joints"} <= set(out)
    assert [c["joint"] for c in out["cycles"]] == JOINTS
    assert out["wear"]["estimate"] == results[-1].result.wear  # the last estimated cycle (joint_3)
    assert [j["joint"] for j in out["joints"]] == JOINTS
    assert [j["diagnostic_level"] for j in out["joints"]] == ["OK", "ERROR", "OK"]
    for j, r in zip(out["joints"], results):
        assert j["wear"]["estimate"] == r.result.wear and j["observations"] == 3 and j["rejections"] == 0
        assert j["comparison"]["estimates"]["matched"] == 1 and j["comparison"]["estimates"]["max_abs_diff"] == 0.0
        assert [c["cycle_id"] for c in j["cycles"]] == [1]
    assert cli_main(["replay", str(path)]) == 0
    text = capsys.readouterr().out
    assert "joint_2: wear" in text and "level ERROR" in text


def test_history_import_of_a_robot_bag_stores_one_entry_per_joint_and_cycle_once(robot_bag_wall_clock, tmp_path,
                                                                                  capsys):
    path, _, results = robot_bag_wall_clock
    db = tmp_path / "h.db"
    assert cli_main(["history", "import", str(path), "--db", str(db), "--robot", "cell_7", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["added"] == 3
    assert cli_main(["history", "import", str(path), "--db", str(db), "--robot", "cell_7", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["added"] == 0
    args = ["history", "import", str(path), "--db", str(db), "--robot", "cell_7", "--reestimate", "--method", "paper",
            "--json"]
    assert cli_main(args) == 0
    assert json.loads(capsys.readouterr().out)["added"] == 3
    assert cli_main(args) == 0
    assert json.loads(capsys.readouterr().out)["added"] == 0
    with HistoryStore(db) as s:
        live = s.estimates(analysis_version="live")
        redo = s.estimates(analysis_version="paper:ref-2011r:0.1.0")
    assert sorted((e.joint, e.cycle_id) for e in live) == [(j, 1) for j in JOINTS]
    assert sorted((e.joint, e.cycle_id) for e in redo) == [(j, 1) for j in JOINTS]
    by = {e.joint: e for e in redo}
    for r in results:
        assert by[r.joint_name].wear == r.result.wear
    assert by["joint_3"].hardware_id == "cell_7/wrist" and by["joint_1"].hardware_id == "cell_7/joint_1"


def test_fleet_reprocess_of_a_robot_bag_gives_a_record_per_joint(robot_bag):
    path, _, results = robot_bag
    out = reprocess_bag(path, method="paper")
    assert out.ok, out.error
    recs = sorted(out.records, key=lambda r: r["joint"])
    assert [(r["robot"], r["joint"], r["cycle_id"]) for r in recs] == [("cell_7", j, 1) for j in JOINTS]
    assert [r["wear"] for r in recs] == [r.result.wear for r in results]
    assert recs[2]["hardware_id"] == "cell_7/wrist" and recs[0]["hardware_id"] == "cell_7/joint_1"
    assert out.observations == 9 and out.rejections == 0


def test_replay_of_a_robot_bag_skips_a_bad_sample_only_for_its_joint(tmp_path):
    """A NaN position of joint_2 in one JointState: skipped for joint_2 (as live), joint_1 and joint_3 take the
    message; every joint still has its three observations and its estimate."""
    cyc = synthetic_robot_cycle(JOINTS, WEARS, SPEEDS, rate=500.0, seed=6, noise_std=0.002)
    k = int(np.searchsorted(cyc.stamps, cyc.cycles["joint_2"].stamps[0] + 0.3))
    cyc.position[k, 1] = math.nan  # a NaN for joint_2 only: skipped for joint_2, as live
    rep = replay_bag(write_robot_cycle_bag(tmp_path / "bag", cyc), *_params())
    assert [(c.joint_name, c.result is not None) for c in rep.cycles] == [(j, True) for j in JOINTS]
    assert [sum(o.joint_name == j for o in rep.observations) for j in JOINTS] == [3, 3, 3]
    assert rep.samples == cyc.stamps.size


def test_robot_cycle_statuses_follow_the_contract():
    cyc = synthetic_robot_cycle(JOINTS, WEARS, SPEEDS, rate=250.0, seed=2)
    order = []
    for st in cyc.statuses:
        j = st.joint_name
        assert st.joints == tuple(JOINTS) and st.joints_done == JOINTS.index(j) and st.cycle_id == 1
        if not order or order[-1] != j:
            order.append(j)
    assert order == JOINTS  # each joint RUNNING ... DONE, one after another
    last = cyc.statuses[-1]
    assert last.state == CycleState.DONE and last.robot_cycle_over  # the robot cycle is over
    assert cyc.position.shape == (cyc.stamps.size, 3) and np.all(np.diff(cyc.stamps) > 0)


def test_replay_serves_the_joints_the_live_observer_served(tmp_path):
    """Recorded joints [joint_1, joint_3]: joint_2 (tested, in every JointState) is left out as it was live
    (without recorded parameters every joint the statuses name is replayed: the test above; a one-joint
    node's recorded joint_name: test_fleet's bags)."""
    cyc = synthetic_robot_cycle(JOINTS, WEARS, SPEEDS, rate=250.0, seed=8, noise_std=0.002)
    op, mp = _params()
    two = write_robot_cycle_bag(tmp_path / "two", cyc, observer_params={"joints": ["joint_1", "joint_3"]},
                                estimator_params={"joints": ["joint_1", "joint_3"]})
    rep = replay_bag(two, op, mp)
    assert rep.joints == ["joint_1", "joint_3"]
    assert sorted({o.joint_name for o in rep.observations}) == ["joint_1", "joint_3"]
    assert [c.joint_name for c in rep.cycles] == ["joint_1", "joint_3"]
